"""An output directory as one run: what ``probeplace inspect`` checks
(src/jobs/inspect.rs) before a renderer trusts its files together."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

from ._common import Provenance, ProbeplaceError, read_file
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
    """The parsed JSON file at ``path``, ``None`` when there is none."""
    if not os.path.isfile(path):
        return None
    try:
        return json.loads(read_file(path, what).decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise ProbeplaceError(f"{path}: not JSON: {e}") from None


def open_run(directory: "str | os.PathLike[str]") -> Run:
    """Loads the ``svo.bin``, ``probes.json`` and, when there is one,
    ``lightfield.bin`` of the output directory ``directory``, with the
    checks ``probeplace inspect`` makes: each file whole and intact, every
    JSON file's provenance equal to ``svo.bin``'s (and ``lightfield.bin``'s),
    the probe counts equal, and no data file of the run missing
    (``report.json``, ``probes.json``, ``lightfield.bin`` when the report
    records a bake, every file it lists as reused).

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
    whole = ": the directory holds part of a run (run the job again)"
    for name in ("report.json", "probes.json"):
        if name not in parsed:
            raise ProbeplaceError(f"{os.path.join(directory, name)}: missing, {beside}{whole}")
    report = parsed["report.json"]
    if not isinstance(report, dict):
        raise ProbeplaceError(f"{os.path.join(directory, 'report.json')}: is not a probeplace report")
    lf_path = os.path.join(directory, "lightfield.bin")
    if isinstance(report.get("bake"), dict) and not os.path.isfile(lf_path):
        raise ProbeplaceError(f"{lf_path}: missing, though report.json records a bake{whole}")
    reused = report.get("reused")
    for name in reused if isinstance(reused, list) else []:
        if isinstance(name, str) and name and os.path.basename(name) == name \
                and not os.path.isfile(os.path.join(directory, name)):
            raise ProbeplaceError(f"{os.path.join(directory, name)}: missing, "
                                  f"though report.json lists it as reused{whole}")
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
    return Run(directory, svo, probes, field, report)
