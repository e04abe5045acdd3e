"""An output directory as one run: what ``probeplace inspect`` checks
(src/jobs/inspect.rs) before a renderer trusts its files together."""

from __future__ import annotations

import hashlib
import json
import os
import stat
from dataclasses import dataclass

from ._common import Provenance, ProbeplaceError, _hex, fnv1a64, not_regular, read_file
from .lightfield import LightField, load_lightfield
from .probes import Probes, load_probes
from .svo import Svo, load_svo


@dataclass(frozen=True, eq=False)
class Run:
    """The files of one run, checked to belong together."""

    directory: str
    svo: Svo
    probes: Probes
    lightfield: "LightField | None"
    report: dict

    @property
    def provenance(self) -> Provenance:
        return self.svo.provenance


def _json(path: str, what: str) -> "object | None":
    """The parsed JSON file at ``path``; ``None`` when it cannot be read (it
    is not there, or not a regular file: the check for the run's whole set
    of files names it then), as ``inspect``'s provenance check skips it."""
    try:
        data = read_file(path, what)
    except ProbeplaceError:
        return None
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise ProbeplaceError(f"{path}: not JSON: {e}") from None


def _missing(path: str, why: str) -> "ProbeplaceError | None":
    """``inspect``'s ``check_whole``: the error for a data file of the run
    at ``path`` that is not there (``why`` says why it should be), or is
    there but not a regular file (a FIFO, a directory: said as such, never
    opened); ``None`` for a regular file."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return ProbeplaceError(
            f"{path}: missing, {why}: the directory holds part of a run (run the job again)")
    return not_regular(path, os.path.basename(path), st.st_mode)


MANIFEST = "manifest.json"
_MANIFEST_FORMAT = "probeplace.manifest"
_MANIFEST_VERSION = 1
#: ``manifest.json`` is read up to 64 MiB, as probeplace reads it.
_MANIFEST_LIMIT = 1 << 26
_RERUN = "run the job again"


def _is_u64(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 1 << 64


def _manifest_shape_error(m: object) -> "str | None":
    """Why ``m`` is not a manifest as probeplace's ``Manifest`` type
    reads it (src/output/manifest.rs), or ``None``."""
    if not isinstance(m, dict):
        return "expected a JSON object"
    for key in ("format", "version", "files"):
        if key not in m:
            return f"missing field `{key}`"
    if not isinstance(m["format"], str):
        return "`format` is not a string"
    v = m["version"]
    if not (isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 1 << 32):
        return "`version` is not a u32"
    prov = m.get("provenance")
    if prov is not None:
        if not isinstance(prov, dict):
            return "`provenance` is not an object"
        for key in ("tool", "config_hash", "scene_hash"):
            if not isinstance(prov.get(key), str):
                return f"`provenance.{key}` is not a string"
        if not _is_u64(prov.get("seed")):
            return "`provenance.seed` is not a u64"
    files = m["files"]
    if not isinstance(files, dict):
        return "`files` is not an object"
    for name, entry in files.items():
        if not isinstance(entry, dict) or not _is_u64(entry.get("bytes")) \
                or not isinstance(entry.get("sha256"), str):
            return f"`files.{name}` is not an entry (bytes, sha256)"
    return None


def _plain_name(name: str) -> bool:
    """Whether ``name`` is a file name of the directory itself, as Rust's
    ``Path::file_name`` is the name whole."""
    return bool(name) and "/" not in name and name not in (".", "..")


def _sha256_of(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def check_manifest(directory: str, svo_provenance: Provenance) -> None:
    """``inspect``'s manifest check (src/jobs/inspect.rs, ``check_manifest``,
    and src/output/manifest.rs, ``verify``), in its order: the manifest is
    there, a regular file, JSON of format ``probeplace.manifest`` version 1;
    every file it lists (in name order) is a plain name of the directory,
    there, a regular file and not a link, of the recorded size and SHA-256;
    no file is there that it does not list; and it records ``svo.bin``'s
    run. Raises :class:`ProbeplaceError` naming the file at fault."""
    path = os.path.join(directory, MANIFEST)

    def refuse(file: str, why: str) -> ProbeplaceError:
        return ProbeplaceError(f"{file}: {why}; {_RERUN}")

    try:
        st = os.lstat(path)
    except OSError:
        raise refuse(path, "missing: the directory was written by an older probeplace, "
                           "or is not a whole output set") from None
    if not stat.S_ISREG(st.st_mode):
        raise refuse(path, "is not a regular file")
    data = read_file(path, MANIFEST, _MANIFEST_LIMIT)
    try:
        manifest = json.loads(data.decode("utf-8"))
        why = _manifest_shape_error(manifest)
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        why = str(e)
    if why is not None:
        raise refuse(path, f"is not a probeplace manifest ({why})")
    if manifest["format"] != _MANIFEST_FORMAT:
        raise refuse(path, f"has format `{manifest['format']}`, not `{_MANIFEST_FORMAT}`")
    if manifest["version"] != _MANIFEST_VERSION:
        raise refuse(path, f"`{_MANIFEST_FORMAT}` version {manifest['version']}: "
                           f"this build reads version {_MANIFEST_VERSION}")
    files = manifest["files"]
    # A BTreeMap's order: by bytes, which for UTF-8 is by code point.
    for name in sorted(files):
        want = files[name]
        if not _plain_name(name) or name == MANIFEST:
            raise refuse(path, f"lists `{name}`, which is not a file of the directory")
        file = os.path.join(directory, name)
        try:
            st = os.lstat(file)
        except (OSError, ValueError):
            raise refuse(file, f"missing, though {MANIFEST} lists it: "
                               "the directory holds part of a run") from None
        if stat.S_ISLNK(st.st_mode):
            raise refuse(file, "is a symbolic link: a run's files are reused as regular "
                               "files only, never through links (copy the file in)")
        if not stat.S_ISREG(st.st_mode):
            raise refuse(file, "is not a regular file")
        if st.st_size != want["bytes"]:
            raise refuse(file, f"holds {st.st_size} bytes where {MANIFEST} records "
                               f"{want['bytes']}: changed since its run wrote it")
        try:
            digest = _sha256_of(file)
        except OSError as e:
            raise ProbeplaceError(f"{file}: cannot read: {e.strerror or e}") from None
        if digest != want["sha256"]:
            raise refuse(file, f"its contents are not what {MANIFEST} records (SHA-256 "
                               "differs): changed since its run wrote it, or copied from "
                               "another run")
    stray = sorted(n for n in os.listdir(directory) if n != MANIFEST and n not in files)
    if stray:
        raise ProbeplaceError(
            f"{os.path.join(directory, stray[0])}: is not a file of the run ({MANIFEST} "
            "does not list it): remove it, or run the job again")
    prov = manifest.get("provenance")
    recorded = None if prov is None else Provenance(
        _hex(prov["config_hash"]), _hex(prov["scene_hash"]), prov["seed"],
        fnv1a64(prov["tool"].encode()))
    if recorded != svo_provenance:
        raise ProbeplaceError(f"{path}: records another run than svo.bin: "
                              "the two come from different runs")


def open_run(directory: "str | os.PathLike[str]") -> Run:
    """Loads the ``svo.bin``, ``probes.json`` and, when there is one,
    ``lightfield.bin`` of the output directory ``directory``, with the
    checks ``probeplace inspect`` makes, in its order: each file whole and
    intact, every JSON file's provenance equal to ``svo.bin``'s (and
    ``lightfield.bin``'s), no data file of the run missing (``report.json``,
    ``probes.json``, ``lightfield.bin`` when the report records a bake,
    every file it lists as reused) nor anything but a regular file, the
    probe counts equal, and last the directory as its ``manifest.json``
    records it (:func:`check_manifest`: every listed file present with its
    size and SHA-256, none unlisted, the same run): an edited
    ``probes.json``, a missing manifest or another run's ``reference.exr``
    is refused as ``inspect`` refuses it.

    Raises :class:`ProbeplaceError` naming the file at fault.
    """
    directory = os.fspath(directory)
    svo_path = os.path.join(directory, "svo.bin")
    if not os.path.exists(svo_path):
        raise ProbeplaceError(f"{directory}: holds no svo.bin (write one with probeplace place)")
    svo = load_svo(svo_path)
    mixed = f"comes from another run than {svo_path}: the two come from different runs"
    parsed = {}
    for name in ("report.json", "probes.json", "compare.json"):
        path = os.path.join(directory, name)
        value = _json(path, name)
        if value is None:
            continue
        parsed[name] = value
        prov = Provenance.from_json(value.get("provenance") if isinstance(value, dict) else None)
        if prov != svo.provenance:
            raise ProbeplaceError(f"{path}: {mixed}")
    beside = f"though {svo_path} is there"
    for name in ("report.json", "probes.json"):
        e = _missing(os.path.join(directory, name), beside)
        if e is not None:
            raise e
    report = parsed.get("report.json")
    if not isinstance(report, dict):
        raise ProbeplaceError(f"{os.path.join(directory, 'report.json')}: is not a probeplace report")
    lf_path = os.path.join(directory, "lightfield.bin")
    if isinstance(report.get("bake"), dict):
        e = _missing(lf_path, "though report.json records a bake")
        if e is not None:
            raise e
    reused = report.get("reused")
    for name in reused if isinstance(reused, list) else []:
        if isinstance(name, str) and _plain_name(name):
            e = _missing(os.path.join(directory, name), "though report.json lists it as reused")
            if e is not None:
                raise e
    probes_path = os.path.join(directory, "probes.json")
    probes = load_probes(probes_path)
    if len(probes) != svo.probe_count:
        raise ProbeplaceError(
            f"{svo_path}: indexes {svo.probe_count} probes but {probes_path} has "
            f"{len(probes)}: the two come from different runs")
    field = None
    if os.path.exists(lf_path):
        field = load_lightfield(lf_path)
        if field.provenance != svo.provenance:
            raise ProbeplaceError(f"{lf_path}: {mixed}")
        if field.probe_count != svo.probe_count:
            raise ProbeplaceError(
                f"{lf_path}: holds {field.probe_count} probes but {svo_path} indexes "
                f"{svo.probe_count}: the two come from different runs")
    # Last, as inspect: the checks above name what a damaged data file is;
    # the manifest then catches every other change, and files put there.
    check_manifest(directory, svo.provenance)
    return Run(directory, svo, probes, field, report)
