"""``probes.json``: the probes, in world space (docs/formats.md,
"probes.json").

:func:`load_probes` accepts what probeplace's own reader accepts
(src/placement/file.rs, ``parse_world``: an object of ``format``
``probeplace.probes``, version 1, with a ``probes`` array, or a bare array
of ``[x, y, z]``), with the same reasons for what it refuses.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ._common import Provenance, ProbeplaceError, read_file

FORMAT = "probeplace.probes"
VERSION = 1
#: Most probes a file may hold (probeplace's ``placement::file::MAX_PROBES``).
MAX_PROBES = 1 << 20


@dataclass(frozen=True, eq=False)
class Probes:
    """The probes of a ``probes.json`` (or of a bare array of positions),
    in file order: the order ``svo.bin``'s indices and ``lightfield.bin``'s
    maps refer to. Fields a file lacks are ``None`` (scalars), NaN
    (``clearance``, ``position_file``) or 0 (``cluster_size``), ``False`` (``fixed``)."""

    path: str
    positions: np.ndarray  # (P, 3) float64, world space
    cluster_size: np.ndarray  # (P,) uint32
    clearance: np.ndarray  # (P,) float64; NaN where the file has null
    position_file: np.ndarray  # (P, 3) float64, the OBJ's coordinates
    voxel_class: list  # "free", "solid", "outside" or None, per probe
    fixed: np.ndarray  # (P,) bool: the config's fixed_probes (they come first)
    method: "str | None" = None
    seed: "int | None" = None
    scene: "str | None" = None
    space: "dict | None" = None
    provenance: "Provenance | None" = None
    raw: dict = field(default_factory=dict)  # the parsed file, when it is an object

    def __len__(self) -> int:
        return len(self.positions)


def _number(v: object) -> "float | None":
    """``serde_json::Value::as_f64``: a JSON number, else ``None``."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not JSON")


def from_bytes(data: bytes, path: str = "probes.json") -> Probes:
    """Reads the probes of ``data``; ``path`` names it in errors.

    Raises :class:`ProbeplaceError` (``PATH: reason``) for a file that is
    not JSON, has no ``probes`` array, holds no probe or more than
    :data:`MAX_PROBES`, or has an entry without three finite numbers for its
    position.
    """

    def bad(reason: str) -> ProbeplaceError:
        return ProbeplaceError(f"{path}: {reason}")

    try:
        value = json.loads(data.decode("utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise bad(f"not JSON: {e}") from None
    if isinstance(value, list):
        entries, top = value, {}
    elif isinstance(value, dict):
        top = value
        fmt = value.get("format")
        if not isinstance(fmt, str):
            raise bad(f"has no `format`: expected `{FORMAT}` (or a bare array of [x, y, z])")
        if fmt != FORMAT:
            raise bad(f"is a `{fmt}` file, not `{FORMAT}` (or a bare array of [x, y, z])")
        version = value.get("version")
        if type(version) is not int or version != VERSION:
            shown = "(none)" if "version" not in value else json.dumps(
                version, separators=(",", ":"), ensure_ascii=False)
            raise bad(f"`{FORMAT}` version {shown}: this build reads version {VERSION}")
        entries = value.get("probes")
        if not isinstance(entries, list):
            raise bad("has no `probes` array")
    else:
        raise bad("expected a `probes` object or an array of [x, y, z]")
    if not entries:
        raise bad("holds no probe")
    if len(entries) > MAX_PROBES:
        raise bad(f"holds {len(entries)} probes; at most {MAX_PROBES} are read")

    count = len(entries)
    positions = np.empty((count, 3), dtype=np.float64)
    cluster = np.zeros(count, dtype=np.uint32)
    clearance = np.full(count, np.nan)
    position_file = np.full((count, 3), np.nan)
    classes: list = [None] * count
    fixed = np.zeros(count, dtype=bool)
    for i, e in enumerate(entries):
        if isinstance(e, dict):
            position, size = e.get("position"), e.get("cluster_size")
        else:
            position, size = e, None
        xyz = ([x for x in map(_number, position) if x is not None]
               if isinstance(position, list) else [])
        if len(xyz) != 3:
            raise bad(f"probe {i}: `position` must be three numbers")
        if not all(math.isfinite(x) for x in xyz):
            raise bad(f"probe {i}: the position is not finite")
        positions[i] = xyz
        if isinstance(size, int) and not isinstance(size, bool) and size >= 0:
            cluster[i] = min(size, 0xFFFFFFFF)
        if isinstance(e, dict):
            c = _number(e.get("clearance"))
            if c is not None:
                clearance[i] = c
            f = e.get("position_file")
            if isinstance(f, list) and len(f) == 3 and all(_number(x) is not None for x in f):
                position_file[i] = [_number(x) for x in f]
            if isinstance(e.get("voxel_class"), str):
                classes[i] = e["voxel_class"]
            fixed[i] = e.get("fixed") is True
    for a in (positions, cluster, clearance, position_file, fixed):
        a.flags.writeable = False
    text = lambda k: top.get(k) if isinstance(top.get(k), str) else None  # noqa: E731
    seed = top.get("seed")
    return Probes(
        path=path,
        positions=positions,
        cluster_size=cluster,
        clearance=clearance,
        position_file=position_file,
        voxel_class=classes,
        fixed=fixed,
        method=text("method"),
        seed=seed if isinstance(seed, int) and not isinstance(seed, bool) else None,
        scene=text("scene"),
        space=top.get("space") if isinstance(top.get("space"), dict) else None,
        provenance=Provenance.from_json(top.get("provenance")),
        raw=top,
    )


def load_probes(path: "str | os.PathLike[str]") -> Probes:
    """Reads the ``probes.json`` at ``path`` (see :func:`from_bytes`)."""
    return from_bytes(read_file(path, "probes.json"), os.fspath(path))
