"""Readers of probeplace's outputs, in Python with numpy only.

    import probeplace
    run = probeplace.open_run("out/cornell")       # every file, checked as one run
    svo = probeplace.load_svo("out/cornell/svo.bin")
    lists, counts = svo.probes_at(points)          # (N, 3) world points
    field = probeplace.load_lightfield("out/cornell/lightfield.bin")
    probes = probeplace.load_probes("out/cornell/probes.json")
    # the diffuse blend of the validation renders: probes and weights
    ids, weights, counts = probeplace.blend_weights(field, svo, points, normals)

Each loader makes the checks probeplace's own Rust reader makes and raises
:class:`ProbeplaceError` (``PATH: reason``) for a file it would refuse.
Byte layouts: docs/formats.md.
"""

from ._common import ProbeplaceError, Provenance, crc32, fnv1a64
from .blend import Lattice, blend_terms, blend_weights
from .lightfield import LightField, load_lightfield
from .probes import Probes, load_probes
from .run import Run, open_run
from .svo import NO_PROBE, Svo, load_svo
from . import blend, lightfield, probes, svo

__all__ = [
    "ProbeplaceError",
    "Provenance",
    "crc32",
    "fnv1a64",
    "Lattice",
    "blend_terms",
    "blend_weights",
    "LightField",
    "load_lightfield",
    "Probes",
    "load_probes",
    "Run",
    "open_run",
    "NO_PROBE",
    "Svo",
    "load_svo",
    "blend",
    "lightfield",
    "probes",
    "svo",
]

__version__ = "0.1.0"
