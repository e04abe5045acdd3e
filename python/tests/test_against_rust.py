"""The Python readers against probeplace's Rust ones, on the files
tests/it/readers.rs writes. That test names a manifest of cases in
``PROBEPLACE_READERS_MANIFEST`` and checks afterwards that every case was
verified here (each test appends its case to the manifest's ``verified``
file). Without the variable (pytest run by hand) these tests are skipped;
test_readers.py needs nothing from Rust.
"""

import json
import os
import signal

import numpy as np
import pytest

import probeplace as pp

_MANIFEST_PATH = os.environ.get("PROBEPLACE_READERS_MANIFEST")
MANIFEST = {}
if _MANIFEST_PATH:
    with open(_MANIFEST_PATH) as f:
        MANIFEST = json.load(f)


def cases(section):
    return [pytest.param(c, id=c["name"]) for c in MANIFEST.get(section, [])]


def verified(key):
    with open(MANIFEST["verified"], "a") as f:
        f.write(key + "\n")


def assert_answers(svo, points_path, answers_path, non_empty=None):
    """``svo.probes_at`` on every point equals Rust's answers."""
    pts = np.fromfile(points_path, dtype="<f4").astype(np.float32).reshape(-1, 3)
    ans = np.fromfile(answers_path, dtype="<u4").astype(np.uint32).reshape(-1, 9)
    assert len(pts) == len(ans)
    k = svo.max_probes
    assert np.all(ans[:, 1 + k:] == pp.NO_PROBE), "Rust lists more than max_probes"
    lists, counts = svo.probes_at(pts)
    assert lists.shape == (len(pts), k) and counts.shape == (len(pts),)
    bad = np.nonzero((counts != ans[:, 0]) | np.any(lists != ans[:, 1:1 + k], axis=1))[0]
    assert len(bad) == 0, "; ".join(
        f"point {i} {pts[i].tolist()}: Python {lists[i, :counts[i]].tolist()}, "
        f"Rust {ans[i, 1:1 + ans[i, 0]].tolist()}" for i in bad[:5])
    if non_empty is not None:
        assert int(np.count_nonzero(counts)) == non_empty
    # One point at a time, and in another shape, as a renderer might ask.
    for i in range(0, len(pts), 97):
        assert svo.probes_list(pts[i]).tolist() == ans[i, 1:1 + ans[i, 0]].tolist()
    n = len(pts) // 6 * 6
    if n:
        grid_lists, grid_counts = svo.probes_at(pts[:n].reshape(2, -1, 3, 3))
        assert np.array_equal(grid_counts.reshape(-1), counts[:n])
        assert np.array_equal(grid_lists.reshape(-1, k), lists[:n])


def assert_field(field, case):
    """``field`` holds what Rust's ``LightField::read`` read: the header's
    figures and every value, bit for bit once widened to f32."""
    n, m = case["resolution"], case["irradiance_resolution"]
    assert (field.probe_count, field.resolution, field.irradiance_resolution) == (
        case["probes"], n, m)
    assert len(field.pyramid) == case["levels"]
    assert int(np.float32(field.max_distance).view(np.uint32)) == case["max_distance_bits"]
    assert field.provenance.to_bytes().hex() == case["provenance"]
    p = field.probe_count
    assert field.radiance.shape == (p, n, n, 3) and field.moments.shape == (p, m, m, 2)
    parts = [field.positions, field.radiance, field.normal, field.distance,
             *field.pyramid, field.irradiance, field.moments]
    values = np.concatenate([np.asarray(a, dtype=np.float32).ravel() for a in parts])
    want = np.fromfile(case["dump"], dtype="<f4").astype(np.float32)
    assert values.shape == want.shape
    bad = np.nonzero(values.view(np.uint32) != want.view(np.uint32))[0]
    assert len(bad) == 0, f"{len(bad)} values differ, first at {bad[0]}: " \
                          f"{values[bad[0]]} against Rust's {want[bad[0]]}"


@pytest.mark.parametrize("case", cases("probes_at"))
def test_probes_at_answers_as_rust(case):
    svo = pp.load_svo(case["svo"])
    assert len(np.fromfile(case["points"], dtype="<f4")) == 3 * case["count"]
    assert_answers(svo, case["points"], case["answers"], case["non_empty"])
    verified(f"probes_at:{case['name']}")


@pytest.mark.parametrize("case", cases("runs"))
def test_output_directory_reads_as_one_run(case):
    run = pp.open_run(case["dir"])
    assert run.provenance.to_bytes().hex() == case["provenance"]
    assert run.probes.provenance == run.provenance
    assert len(run.probes) == run.svo.probe_count == case["probes"]
    want = np.fromfile(case["positions"], dtype="<f8").astype(np.float64).reshape(-1, 3)
    assert np.array_equal(run.probes.positions.view(np.uint64), want.view(np.uint64))
    assert run.probes.cluster_size.tolist() == case["cluster_size"]
    assert (run.lightfield is not None) == case["lightfield"]
    if run.lightfield is not None:
        assert run.lightfield.provenance == run.provenance
        # Positions in lightfield.bin are probes.json's, rounded to f32.
        assert np.array_equal(run.lightfield.positions, run.probes.positions.astype(np.float32))
    verified(f"run:{case['name']}")


@pytest.mark.parametrize("case", cases("lightfields"))
def test_light_field_reads_as_rust(case):
    assert_field(pp.load_lightfield(case["path"]), case)
    verified(f"lightfield:{case['name']}")


LOADERS = {
    "svo": pp.load_svo,
    "lightfield": pp.load_lightfield,
    "probes": pp.load_probes,
    "run": pp.open_run,
}


@pytest.mark.parametrize("case", cases("damaged"))
def test_damaged_file_is_refused_as_rust_refuses_it(case):
    load = LOADERS[case["kind"]]
    if "error" in case:
        with pytest.raises(pp.ProbeplaceError) as raised:
            load(case["path"])
        message = str(raised.value)
        assert "\n" not in message
        if case.get("exact", True):
            assert message == case["error"]
        else:
            assert message.startswith(case["path"] + ": ")
    else:
        got = load(case["path"])
        if case["kind"] == "svo":
            assert_answers(got, case["points"], case["answers"])
        elif case["kind"] == "lightfield":
            assert_field(got, case["field"])
        elif case["kind"] == "probes":
            assert got.positions.ravel().tolist() == case["positions"]
            assert got.cluster_size.tolist() == case["cluster_size"]
    verified(f"damaged:{case['kind']}:{case['name']}")


@pytest.mark.parametrize("case", cases("blend"))
def test_blend_weights_answer_as_rust(case):
    """``blend_weights`` gives Rust's probes and weights, bit for bit, on
    the run's files; ``Lattice.from_positions`` finds a grid where Rust does."""
    field = pp.load_lightfield(case["lightfield"])
    lattice = pp.Lattice.from_positions(field.positions)
    assert (lattice is not None) == case["is_grid"]
    selection = lattice if case["grid"] else pp.load_svo(case["svo"])
    k = case["terms"]
    assert pp.blend_terms(field, selection) == k
    pts = np.fromfile(case["points"], dtype="<f4").astype(np.float32).reshape(-1, 3)
    nrm = np.fromfile(case["normals"], dtype="<f4").astype(np.float32).reshape(-1, 3)
    ans = np.fromfile(case["answers"], dtype="<u4").astype(np.uint32).reshape(-1, 1 + 2 * k)
    assert len(pts) == len(nrm) == len(ans) == case["count"]
    probes, weights, counts = pp.blend_weights(field, selection, pts, nrm)
    assert probes.shape == weights.shape == (len(pts), k) and counts.shape == (len(pts),)
    want_probes, want_bits = ans[:, 1::2], ans[:, 2::2]
    bad = np.nonzero((counts != ans[:, 0]) | np.any(probes != want_probes, axis=1)
                     | np.any(weights.view(np.uint32) != want_bits, axis=1))[0]
    assert len(bad) == 0, f"{len(bad)} points differ; " + "; ".join(
        f"point {i} {pts[i].tolist()} n {nrm[i].tolist()}: Python {probes[i].tolist()} "
        f"{weights[i].tolist()}, Rust {want_probes[i].tolist()} "
        f"{want_bits[i].view(np.float32).tolist()}" for i in bad[:3])
    assert int(np.count_nonzero(counts)) == case["non_empty"]
    # One point at a time, as a renderer might ask, answers alike.
    for i in range(0, len(pts), 211):
        p1, w1, c1 = pp.blend_weights(field, selection, pts[i], nrm[i])
        assert int(c1) == counts[i] and np.array_equal(p1, probes[i])
        assert np.array_equal(w1.view(np.uint32), weights[i].view(np.uint32))
    verified(f"blend:{case['name']}")


#: Seconds one case of the shared table may take: a reader that blocks on
#: a FIFO or reads /dev/zero fails the case instead of hanging the run.
TABLE_SECONDS = 20


def _too_slow(signum, frame):
    raise TimeoutError(f"still reading after {TABLE_SECONDS} s")


@pytest.mark.parametrize("case", cases("table"))
def test_shared_table_case_is_read_as_the_table_says(case):
    """tests/cases/readers.json: ``open_run`` refuses the directory with
    the expected words (one line, a :class:`ProbeplaceError`), or accepts
    it, within :data:`TABLE_SECONDS`."""
    old = signal.signal(signal.SIGALRM, _too_slow)
    signal.alarm(TABLE_SECONDS)
    try:
        if case["expect"] == "accepted":
            pp.open_run(case["dir"])
        else:
            with pytest.raises(pp.ProbeplaceError) as raised:
                pp.open_run(case["dir"])
            message = str(raised.value)
            assert "\n" not in message
            assert message.startswith(case["dir"] + "/"), message
            assert case["expect"] in message, message
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    verified(f"table:{case['name']}")
