"""The readers on files built here by hand (the layouts of docs/formats.md):
what each answers and refuses, with nothing from Rust. The comparison with
probeplace's own files and answers is test_against_rust.py."""

import json
import struct

import numpy as np
import pytest

import probeplace as pp
from probeplace import svo as svo_module

LEAF = 1 << 31


def inner(mask, first):
    return mask | (first << 8)


def leaf(offset, count):
    return LEAF | ((count - 1) << 28) | offset


def svo_bytes(nodes, payload, depth=1, dims=(2, 2, 1), probes=3, max_probes=2,
              origin=(0.0, 0.0, 0.0), leaf_size=1.0, version=2):
    head = struct.pack("<8sI3ffI3IIIIII", b"PROBESVO", version, *origin, leaf_size, depth,
                       *dims, probes, max_probes, 0, len(nodes), len(payload))
    head += struct.pack("<3d", *origin) + bytes(range(32))
    body = head + struct.pack(f"<{len(nodes) + len(payload)}I", *nodes, *payload)
    return body + struct.pack("<I", pp.crc32(body))


def refix(data):
    return data[:-4] + struct.pack("<I", pp.crc32(data[:-4]))


# Root over 2 x 2 x 1 leaves, children 0 (x 0, y 0) and 3 (x 1, y 1).
TREE = svo_bytes([inner(0b1001, 1), leaf(0, 1), leaf(1, 2)], [2, 0, 1])


def test_crc_and_fnv_match_their_published_check_values():
    assert pp.crc32(b"123456789") == 0xCBF43926
    assert pp.fnv1a64(b"") == 0xCBF29CE484222325
    assert pp.fnv1a64(b"foobar") == 0x85944171F73967E8


def test_probes_at_walks_the_tree():
    s = svo_module.from_bytes(TREE)
    assert (s.depth, s.probe_count, s.max_probes) == (1, 3, 2)
    assert s.provenance.to_bytes() == bytes(range(32))
    pts = np.array([
        [0.5, 0.5, 0.5],   # child 0
        [1.5, 1.5, 0.99],  # child 3
        [1.5, 0.5, 0.5],   # child 1: not stored
        [1.0, 1.0, 0.0],   # on the corner: leaf (1, 1, 0)
        [0.999, 0.5, 0.5],
        [2.0, 0.5, 0.5],   # past the leaves
        [-1e-30, 0.5, 0.5],
        [0.5, 0.5, 1.0],   # dims z is 1
        [np.nan, 0.5, 0.5],
        [np.inf, 0.5, 0.5],
    ])
    lists, counts = s.probes_at(pts)
    assert counts.tolist() == [1, 2, 0, 2, 1, 0, 0, 0, 0, 0]
    assert lists[0].tolist() == [2, pp.NO_PROBE]
    assert lists[1].tolist() == [0, 1]
    assert s.probes_list([1.5, 1.5, 0.5]).tolist() == [0, 1]
    assert s.probes_list([3, 3, 3]).tolist() == []
    one_lists, one_count = s.probes_at([0.5, 0.5, 0.5])
    assert one_lists.shape == (2,) and int(one_count) == 1


def full_tree(depth, dims, listing):
    """Nodes and payload of a tree with a leaf for every cell of ``dims``,
    breadth first, cell (x, y, z) listing ``listing(x, y, z)``."""
    nodes, payload, queue, i = [], [], [(depth, 0, 0, 0)], 0
    while i < len(queue):
        level, x, y, z = queue[i]
        if level == 0:
            probes = listing(x, y, z)
            nodes.append(leaf(len(payload), len(probes)))
            payload += probes
        else:
            half, mask, first = 1 << (level - 1), 0, len(queue)
            for c in range(8):
                cell = (x + half * (c & 1), y + half * (c >> 1 & 1), z + half * (c >> 2 & 1))
                if all(a < d for a, d in zip(cell, dims)):
                    mask |= 1 << c
                    queue.append((level - 1, *cell))
            nodes.append(inner(mask, first))
        i += 1
    return nodes, payload


def test_float32_rounding_decides_the_leaf():
    # 0.5f / 0.1f rounds to 5 in f32, while in f64 it is 4.99999997: a
    # reader dividing in double precision would answer leaf 4's list.
    s = svo_module.from_bytes(svo_bytes(*full_tree(3, (8, 1, 1), lambda x, y, z: [x]), depth=3,
                                        dims=(8, 1, 1), probes=8, max_probes=1, leaf_size=0.1))
    x, size = np.float32(0.5), np.float32(0.1)
    assert np.floor(float(x) / float(size)) == 4
    assert s.probes_list([x, 0.05, 0.05]).tolist() == [5]
    xs = np.array([np.float32(k) * size for k in range(9)], dtype=np.float32)
    xs = np.concatenate([xs, np.nextafter(xs, np.float32(-1)), np.nextafter(xs, np.float32(9))])
    pts = np.stack([xs, np.full_like(xs, 0.05), np.full_like(xs, 0.05)], axis=1)
    lists, counts = s.probes_at(pts)
    want = np.floor(xs / size)
    inside = (want >= 0) & (want < 8)
    assert np.array_equal(counts, inside.astype(np.uint32))
    assert np.array_equal(lists[inside, 0], want[inside].astype(np.uint32))


@pytest.mark.parametrize("data, reason", [
    (TREE[:7], "not a probeplace SVO file (its first bytes are not PROBESVO)"),
    (b"PROBESVP" + TREE[8:], "not a probeplace SVO file (its first bytes are not PROBESVO)"),
    (TREE[:100], "truncated: 100 bytes, but the header alone takes 124"),
    (TREE[:-1], f"truncated: {len(TREE) - 1} bytes, but its header announces {len(TREE)}"),
    (TREE + b"\0", f"corrupted: {len(TREE) + 1} bytes, but its header announces {len(TREE)}"),
    (svo_bytes([0], [], version=3), "unsupported version 3: this probeplace reads version 2"),
    (TREE[:-1] + bytes([TREE[-1] ^ 1]), "corrupted: the checksum does not match the contents"),
    (svo_bytes([0], [], leaf_size=-0.25), "corrupted: leaf size -0.25 is not positive"),
    (svo_bytes([0], [], leaf_size=float("nan")), "corrupted: leaf size NaN is not positive"),
    (svo_bytes([0], [], depth=24), "corrupted: depth 24 exceeds 23"),
    (svo_bytes([0], [], dims=(3, 1, 1)), "corrupted: [3, 1, 1] leaves do not fit a root of 2 leaves"),
    (svo_bytes([0], [], max_probes=9), "corrupted: 9 probes per leaf is outside 1..=8"),
    (svo_bytes([], []), "corrupted: there is no root node"),
    (svo_bytes([inner(0b1001, 1), leaf(0, 1), leaf(1, 2)], [2, 0, 3]),
     "corrupted: probe index 3 is not below the probe count 3"),
    (svo_bytes([inner(0b1001, 0), leaf(0, 1), leaf(1, 2)], [2, 0, 1]),
     "corrupted: node 0 points outside the node array"),
    (svo_bytes([inner(0b1001, 2), leaf(0, 1), leaf(1, 2)], [2, 0, 1]),
     "corrupted: node 0 points outside the node array"),
    (svo_bytes([inner(0b1001, 1), leaf(0, 1), leaf(2, 2)], [2, 0, 1]),
     "corrupted: leaf 2 lists beyond the payload"),
    (svo_bytes([inner(0b1, 1), inner(0b1, 2), leaf(0, 1)], [2]),
     "corrupted: node 1 has children below the leaf level"),
    (svo_bytes([inner(0b1, 2), leaf(0, 1), leaf(0, 1)], [2]), "corrupted: node 1 has no parent"),
])
def test_damaged_trees_are_refused_with_probeplaces_reason(data, reason):
    with pytest.raises(pp.ProbeplaceError) as raised:
        svo_module.from_bytes(data, "x/svo.bin")
    assert str(raised.value) == f"x/svo.bin: {reason}"


def test_fast_check_agrees_with_the_node_walk():
    # The vectorized soundness check must accept exactly the trees the node
    # walk (probeplace's rule) accepts: mutate node words of small trees.
    rng = np.random.default_rng(5)
    nodes, payload = full_tree(2, (4, 3, 4), lambda x, y, z: [(x + y + z) % 4])
    base = svo_module.from_bytes(svo_bytes(nodes, payload, depth=2, dims=(4, 3, 4), probes=4,
                                           max_probes=1))
    sound = 0
    for trial in range(1000):
        nodes = base.nodes.copy()
        if trial % 2:
            nodes = nodes[: rng.integers(1, len(nodes) + 1)]
        for _ in range(rng.integers(1, 4)):
            i = rng.integers(len(nodes))
            choice = rng.integers(4)
            if choice == 0:
                nodes[i] = rng.integers(0, 1 << 32, dtype=np.uint64)
            elif choice == 1:
                nodes[i] = inner(int(rng.integers(0, 256)), int(rng.integers(0, len(nodes) + 2)))
            elif choice == 2:
                nodes[i] = leaf(int(rng.integers(0, 6)), int(rng.integers(1, 3)))
            else:
                nodes[i] = 0
        tree = svo_module.Svo(**{**base.__dict__, "nodes": nodes})
        fast = svo_module._tree_is_sound(tree)
        walk = svo_module._first_tree_fault(tree) is None
        assert fast == walk, (trial, nodes.tolist())
        sound += walk
    assert 0 < sound < 1000


def lightfield_bytes(p=2, n=2, m=1, version=1, levels=None):
    levels = n.bit_length() if levels is None else levels
    head = struct.pack("<8s5If", b"PROBELFB", version, p, n, levels, m, 9.5) + bytes(32)
    rng = np.random.default_rng(p * 100 + n)
    count = p * (6 * n * n + 2 * sum((n >> k) ** 2 for k in range(levels)) + 5 * m * m)
    halves = rng.standard_normal(count).astype("<f2")
    body = head + np.arange(3 * p, dtype="<f4").tobytes() + halves.tobytes()
    return body + struct.pack("<I", pp.crc32(body)), halves


def test_light_field_sections_come_in_file_order():
    data, halves = lightfield_bytes()
    f = pp.lightfield.from_bytes(data)
    assert (f.probe_count, f.resolution, f.irradiance_resolution, len(f.pyramid)) == (2, 2, 1, 2)
    assert f.max_distance == np.float32(9.5)
    assert f.positions.tolist() == [[0, 1, 2], [3, 4, 5]]
    got = np.concatenate([a.ravel() for a in (f.radiance, f.normal, f.distance, *f.pyramid,
                                              f.irradiance, f.moments)])
    assert np.array_equal(got.view(np.uint16), halves.view(np.uint16))
    assert f.radiance[1, 0, 1].tolist() == halves[12 + 3:12 + 6].astype(np.float32).tolist()


@pytest.mark.parametrize("mutate, reason", [
    (lambda d: d[:60], "truncated: 60 bytes, shorter than a header"),
    (lambda d: b"PROBESVO" + d[8:], "not a probeplace light-field file (bad magic)"),
    (lambda d: lightfield_bytes(version=2)[0], "version 2; this build reads version 1"),
    (lambda d: lightfield_bytes(n=3, levels=2)[0], "map sides 3 and 1 must be powers of two"),
    (lambda d: lightfield_bytes(levels=3)[0], "3 pyramid levels for side 2"),
    (lambda d: d[:-1], "{len} bytes where the header implies {full}"),
    (lambda d: refix(d[:12] + struct.pack("<I", 3) + d[16:]), "{len} bytes where the header implies 338"),
    (lambda d: d[:70] + bytes([d[70] ^ 1]) + d[71:], "checksum mismatch: the file is damaged"),
])
def test_damaged_light_fields_are_refused_with_probeplaces_reason(mutate, reason):
    good = lightfield_bytes()[0]
    data = mutate(good)
    with pytest.raises(pp.ProbeplaceError) as raised:
        pp.lightfield.from_bytes(data, "lf.bin")
    assert str(raised.value) == "lf.bin: " + reason.format(len=len(data), full=len(good))


def test_probes_read_both_forms_and_refuse_what_probeplace_refuses(tmp_path):
    doc = {"format": "probeplace.probes", "version": 1, "method": "sdf-skeleton", "seed": 3,
           "probes": [{"index": 0, "position": [0.1, 0.2, 0.3], "position_file": [1, 2, 3],
                       "clearance": None, "voxel_class": None, "cluster_size": 5}]}
    p = pp.probes.from_bytes(json.dumps(doc).encode())
    assert p.positions.tolist() == [[0.1, 0.2, 0.3]] and p.cluster_size.tolist() == [5]
    assert np.isnan(p.clearance[0]) and p.voxel_class == [None] and p.seed == 3
    assert p.provenance is None
    assert p.fixed.tolist() == [False]
    doc["probes"][0]["fixed"] = True
    assert pp.probes.from_bytes(json.dumps(doc).encode()).fixed.tolist() == [True]
    bare = pp.probes.from_bytes(b"[[1, 2, 3], [4, 5, 6]]")
    assert len(bare) == 2 and bare.cluster_size.tolist() == [0, 0]
    assert bare.fixed.tolist() == [False, False]
    for text, reason in [
        (b"{}", "has no `format`: expected `probeplace.probes` (or a bare array of [x, y, z])"),
        (json.dumps({"format": "probeplace.probes", "version": 1}).encode(),
         "has no `probes` array"),
        (json.dumps({**doc, "format": "probeplace.report"}).encode(),
         "is a `probeplace.report` file, not `probeplace.probes` (or a bare array of [x, y, z])"),
        (b"[]", "holds no probe"),
        (b"7", "expected a `probes` object or an array of [x, y, z]"),
        (b"[[1, 2]]", "probe 0: `position` must be three numbers"),
        (b"[[1, 2, 3], [1, 2, 1e400]]", "probe 1: the position is not finite"),
        (json.dumps({**doc, "version": 2}).encode(),
         "`probeplace.probes` version 2: this build reads version 1"),
    ]:
        with pytest.raises(pp.ProbeplaceError) as raised:
            pp.probes.from_bytes(text, "p.json")
        assert str(raised.value) == "p.json: " + reason
    for text in (b"[[1, NaN, 2]]", b"\xff", b"{"):
        with pytest.raises(pp.ProbeplaceError, match=r"^p\.json: not JSON: "):
            pp.probes.from_bytes(text, "p.json")
    missing = tmp_path / "nothing.json"
    with pytest.raises(pp.ProbeplaceError, match="probes.json not found"):
        pp.load_probes(missing)


def test_provenance_shows_its_hashes_in_hex_as_the_json_writes_them():
    p = pp.Provenance.from_json({
        "tool": "probeplace 0.1.0", "config_hash": "00ab12cd34ef5678",
        "scene_hash": "ffffffffffffffff", "seed": 7, "config_given": "a.ron",
        "cwd": "/", "config_text": "()", "overrides": {"no_refine": False}})
    text = repr(p)
    assert "config_hash=00ab12cd34ef5678" in text
    assert "scene_hash=ffffffffffffffff" in text
    assert "seed=7" in text


def blend_field(positions, wall=50.0, m=4, n=2, far_wall=None):
    """A light field of ``positions`` whose moments put every surface at
    ``wall`` (the last probe's at ``far_wall`` when given)."""
    p = len(positions)
    levels = n.bit_length()
    head = struct.pack("<8s5If", b"PROBELFB", 1, p, n, levels, m, 9.5) + bytes(32)
    maps = np.zeros(p * (6 * n * n + 2 * sum((n >> k) ** 2 for k in range(levels))
                         + 3 * m * m), dtype="<f2")
    moments = np.empty((p, m * m, 2), dtype="<f2")
    moments[:] = (wall, wall * wall)
    if far_wall is not None:
        moments[-1] = (far_wall, far_wall * far_wall)
    body = (head + np.asarray(positions, dtype="<f4").tobytes() + maps.tobytes()
            + moments.tobytes())
    return pp.lightfield.from_bytes(body + struct.pack("<I", pp.crc32(body)))


def cube(side=2, step=2.0):
    return [[x * step, y * step, z * step]
            for z in range(side) for y in range(side) for x in range(side)]


def test_lattice_is_recognized_in_any_order_and_only_a_full_grid():
    pts = np.array(cube(3, 0.5), dtype=np.float32)[::-1]
    lat = pp.Lattice.from_positions(pts)
    assert lat.dims.tolist() == [3, 3, 3] and lat.spacing.tolist() == [0.5] * 3
    # Lattice point (x, y, z) holds the probe standing there.
    for k, q in enumerate(pts):
        c = np.round(q / 0.5).astype(int)
        assert lat.index[c[0] + 3 * (c[1] + 3 * c[2])] == k
    flat = pp.Lattice.from_positions([[0, 1, 0], [2, 1, 0], [4, 1, 0]])
    assert flat.dims.tolist() == [3, 1, 1] and flat.spacing.tolist() == [2, 1, 1]
    broken = pts.copy()
    broken[4, 0] += np.float32(0.1)
    for bad in (broken, pts[1:], np.zeros((0, 3)), np.vstack([pts[:-1], pts[:1]]),
                np.where(np.arange(27)[:, None] == 3, np.nan, pts)):
        assert pp.Lattice.from_positions(bad) is None


def test_at_a_grid_probe_that_probe_takes_all_the_weight():
    field = blend_field(cube())
    lat = pp.Lattice.from_positions(field.positions)
    probes, weights, counts = pp.blend_weights(field, lat, field.positions,
                                               np.tile([0, 1, 0], (8, 1)))
    assert counts.tolist() == [8] * 8
    for k in range(8):
        assert weights[k][probes[k] == k].tolist() == [1.0]
        assert not weights[k][probes[k] != k].any()


def test_weights_sum_to_one_and_follow_inverse_square_and_facing():
    field = blend_field(cube())
    tree = svo_module.from_bytes(svo_bytes([0], [], probes=8, leaf_size=0.25))
    lat = pp.Lattice.from_positions(field.positions)
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.5, 2.5, (200, 3))
    nrm = rng.normal(size=(200, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    for sel in (tree, lat):
        probes, weights, counts = pp.blend_weights(field, sel, pts, nrm)
        assert np.all(counts == pp.blend_terms(field, sel))
        assert np.all((weights >= 0) & (weights <= 1))
        assert np.allclose(weights.astype(np.float64).sum(axis=1), 1, atol=1e-6)
    # With nothing occluding, the SVO selection's weights are the softened
    # inverse square distance times the clamped cosine, recomputed in f64.
    probes, weights, _ = pp.blend_weights(field, tree, pts, nrm)
    v = field.positions[None].astype(np.float64) - pts.astype(np.float32)[:, None]
    d2 = (v ** 2).sum(axis=2)
    facing = np.maximum(np.einsum("nk,npk->np", nrm.astype(np.float32), v / np.sqrt(d2)[..., None]),
                        0.05)
    raw = facing / (d2 + 0.25 ** 2)
    assert np.allclose(weights, raw / raw.sum(axis=1, keepdims=True), rtol=1e-5, atol=1e-7)


def test_a_probe_behind_a_wall_loses_its_weight():
    # The far probe sees a surface at 1.0 in every direction: a point 3.0
    # from it is hidden (Chebyshev), whatever the selection.
    line = [[0, 0, 0], [0, 0, 4]]
    tree = svo_module.from_bytes(svo_bytes([0], [], probes=2, leaf_size=0.1))
    walled, open_ = blend_field(line, wall=10, far_wall=1.0), blend_field(line, wall=10)

    def far(field, sel):
        probes, weights, _ = pp.blend_weights(field, sel, [0, 0, 1], [1, 0, 0])
        return float(weights[probes == 1].sum())

    for sel in (tree, pp.Lattice.from_positions(line)):
        assert far(open_, sel) > 0.05 and far(walled, sel) < 1e-5 * far(open_, sel)


def test_blend_refuses_what_it_cannot_answer():
    field = blend_field(cube())
    other = svo_module.from_bytes(svo_bytes([0], [], probes=9), "other/svo.bin")
    with pytest.raises(pp.ProbeplaceError, match="other/svo.bin: indexes 9 probes but"):
        pp.blend_weights(field, other, [0, 0, 0], [0, 1, 0])
    tree = svo_module.from_bytes(svo_bytes([0], [], probes=8))
    with pytest.raises(ValueError, match="one shape"):
        pp.blend_weights(field, tree, [[0, 0, 0]], [0, 1, 0])
    with pytest.raises(TypeError):
        pp.blend_weights(field, None, [0, 0, 0], [0, 1, 0])
    probes, weights, counts = pp.blend_weights(field, tree, [[np.nan, 0, 0], [0, 0, 0]],
                                               [[0, 1, 0], [0, 1, 0]])
    assert counts.tolist() == [0, 8]
    assert (probes[0] == pp.NO_PROBE).all() and not weights[0].any()


@pytest.mark.parametrize("make, reason", [
    ("fifo", "is a FIFO (named pipe), not a svo.bin (a regular file)"),
    ("zero", "is a device, not a svo.bin (a regular file)"),
    ("dir", "is a directory, not a svo.bin (a regular file)"),
    ("huge", "svo.bin is 64.0 GiB, over the limit of 64.0 GiB"),
])
def test_a_path_that_is_not_a_readable_file_is_refused_without_reading(tmp_path, make, reason):
    # Under an alarm: the old reader blocked for ever on a FIFO and read
    # /dev/zero until memory ran out (MemoryError, not ProbeplaceError).
    import os
    import signal

    path = tmp_path / "svo.bin"
    if make == "fifo":
        os.mkfifo(path)
    elif make == "zero":
        os.symlink("/dev/zero", path)
    elif make == "dir":
        path.mkdir()
    else:
        with open(path, "wb") as f:
            f.truncate((1 << 36) + 1)  # sparse: nothing of it on disk

    def too_slow(signum, frame):
        raise TimeoutError("the reader blocked")

    old = signal.signal(signal.SIGALRM, too_slow)
    signal.alarm(10)
    try:
        for load in (pp.load_svo, pp.load_lightfield):
            with pytest.raises(pp.ProbeplaceError) as raised:
                load(path)
            want = reason if load is pp.load_svo else reason.replace("svo.bin", "lightfield.bin")
            assert str(raised.value) == f"{path}: {want}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def test_a_file_is_read_up_to_its_size_and_no_further(tmp_path):
    path = tmp_path / "svo.bin"
    path.write_bytes(TREE)
    assert pp.load_svo(path).probe_count == 3
    from probeplace import _common
    assert _common.read_file(path, "svo.bin") == TREE
    with pytest.raises(pp.ProbeplaceError, match="over the limit of 100 bytes"):
        _common.read_file(path, "svo.bin", limit=100)
