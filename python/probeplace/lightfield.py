"""``lightfield.bin``: the baked probe maps (McGuire et al. 2017), byte by
byte in docs/formats.md ("lightfield.bin").

:func:`load_lightfield` makes the checks probeplace's own reader makes
(src/lightfield/format.rs, ``from_bytes``), in the same order and with the
same reasons. The maps stay in the file's half precision: ``.astype(
np.float32)`` of any of them gives exactly the f32 values of Rust's
``LightField`` (f16 to f32 is exact).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ._common import Provenance, ProbeplaceError, crc32, read_file

MAGIC = b"PROBELFB"
VERSION = 1
HEADER_BYTES = 64


@dataclass(frozen=True, eq=False)
class LightField:
    """A checked ``lightfield.bin``: every probe's maps, in the order of
    ``probes.json``. Map arrays are indexed ``[probe, y, x, ...]``; texel
    (x, y) of an n×n map looks along the octahedral decoding of
    ((x + ½)/n·2 − 1, (y + ½)/n·2 − 1) (docs/formats.md). Arrays are
    read-only views of the file's bytes."""

    path: str
    resolution: int  # n, the side of the radiance, normal and distance maps
    irradiance_resolution: int  # m, the side of the irradiance and moment maps
    max_distance: np.float32  # the moments' stand-in for rays that escape
    provenance: Provenance
    positions: np.ndarray  # (P, 3) float32, world space
    radiance: np.ndarray  # (P, n, n, 3) float16, RGB arriving at the probe
    normal: np.ndarray  # (P, n, n, 2) float16, octahedral, facing the probe
    distance: np.ndarray  # (P, n, n) float16, radial; +inf where nothing is seen
    pyramid: list  # level k: (P, n >> k, n >> k, 2) float16, (min, max) distance
    irradiance: np.ndarray  # (P, m, m, 3) float16
    moments: np.ndarray  # (P, m, m, 2) float16, (E[r], E[r²])

    @property
    def probe_count(self) -> int:
        return len(self.positions)


def _file_bytes(p: int, n: int, levels: int, m: int) -> int:
    pyramid = sum((n >> k) ** 2 for k in range(levels))
    return p * (12 + 12 * n * n + 4 * pyramid + 10 * m * m) + HEADER_BYTES + 4


def _power_of_two(v: int) -> bool:
    return v > 0 and v & (v - 1) == 0


def from_bytes(data: bytes, path: str = "lightfield.bin") -> LightField:
    """Checks and reads the ``lightfield.bin`` image ``data``; ``path``
    names it in errors and in the result.

    Raises :class:`ProbeplaceError` (``PATH: reason``, probeplace's reason)
    for any file probeplace would refuse; never reads past ``data``.
    """

    def bad(reason: str) -> ProbeplaceError:
        return ProbeplaceError(f"{path}: {reason}")

    if len(data) < HEADER_BYTES + 4:
        raise bad(f"truncated: {len(data)} bytes, shorter than a header")
    if data[:8] != MAGIC:
        raise bad("not a probeplace light-field file (bad magic)")
    head = np.frombuffer(data, dtype="<u4", count=8)
    version = int(head[2])
    if version != VERSION:
        raise bad(f"version {version}; this build reads version {VERSION}")
    p, n, levels, m = (int(v) for v in head[3:7])
    if not _power_of_two(n) or not _power_of_two(m) or n > 1 << 14 or m > 1 << 14:
        raise bad(f"map sides {n} and {m} must be powers of two")
    if levels != n.bit_length():
        raise bad(f"{levels} pyramid levels for side {n}")
    want = _file_bytes(p, n, levels, m)
    if want != len(data):
        raise bad(f"{len(data)} bytes where the header implies {want}")
    body = len(data) - 4
    if crc32(data[:body]) != int.from_bytes(data[body:], "little"):
        raise bad("checksum mismatch: the file is damaged")

    at = HEADER_BYTES

    def take(dtype: str, count: int, shape: tuple) -> np.ndarray:
        nonlocal at
        a = np.frombuffer(data, dtype=dtype, count=count, offset=at)
        at += a.nbytes
        return a.reshape(shape)

    positions = take("<f4", 3 * p, (p, 3))
    radiance = take("<f2", 3 * p * n * n, (p, n, n, 3))
    normal = take("<f2", 2 * p * n * n, (p, n, n, 2))
    distance = take("<f2", p * n * n, (p, n, n))
    pyramid = [take("<f2", 2 * p * (n >> k) ** 2, (p, n >> k, n >> k, 2)) for k in range(levels)]
    irradiance = take("<f2", 3 * p * m * m, (p, m, m, 3))
    moments = take("<f2", 2 * p * m * m, (p, m, m, 2))
    assert at == body
    return LightField(
        path=path,
        resolution=n,
        irradiance_resolution=m,
        max_distance=np.frombuffer(data, dtype="<f4", count=1, offset=28)[0],
        provenance=Provenance.from_bytes(data[32:64]),
        positions=positions,
        radiance=radiance,
        normal=normal,
        distance=distance,
        pyramid=pyramid,
        irradiance=irradiance,
        moments=moments,
    )


def load_lightfield(path: "str | os.PathLike[str]") -> LightField:
    """Reads and checks the ``lightfield.bin`` at ``path`` (see :func:`from_bytes`)."""
    return from_bytes(read_file(path, "lightfield.bin"), os.fspath(path))
