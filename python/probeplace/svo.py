"""``svo.bin``: the sparse voxel octree of probe indices (Wang et al. 2019
§4.1), byte by byte in docs/formats.md ("svo.bin").

:func:`load_svo` makes the checks probeplace's own reader makes
(src/svo/format.rs, ``from_bytes`` and ``validate``), in the same order and
with the same reasons; :meth:`Svo.probes_at` answers what ``Svo::probes_at``
answers, bit for bit: the leaf of a point is ``floor((p - origin) /
leaf_size)`` computed in float32, one operation at a time, as Rust's
``Vec3`` does (numpy's float32 arithmetic is IEEE single precision, as
Rust's is).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ._common import Provenance, ProbeplaceError, crc32, read_file

MAGIC = b"PROBESVO"
VERSION = 2
HEADER_BYTES = 120
CHECKSUM_BYTES = 4
#: The most leaves a tree may have (probeplace's ``sdf::MAX_VOXELS``).
MAX_LEAVES = 64_000_000
#: The padding of :meth:`Svo.probes_at`'s lists past their count.
NO_PROBE = np.uint32(0xFFFFFFFF)

_LEAF_BIT = 0x80000000
_PAYLOAD_OFFSET_BITS = 28
_CHILD_MASK_BITS = 8
_POPCOUNT8 = np.array([bin(i).count("1") for i in range(256)], dtype=np.uint32)


@dataclass(frozen=True, eq=False)
class Svo:
    """A checked ``svo.bin``, in world coordinates.

    ``nodes`` and ``payload`` are the file's u32 words (read-only arrays),
    as the WGSL kernels bind them (docs/formats.md, "Readers").
    """

    path: str
    origin: np.ndarray  # (3,) float32: world lower corner of leaf (0, 0, 0)
    origin_exact: np.ndarray  # (3,) float64: the same, exact
    leaf_size: np.float32
    depth: int
    dims: np.ndarray  # (3,) uint32: leaves along x, y, z
    probe_count: int
    max_probes: int
    leaves_without_visible_probe: int
    provenance: Provenance
    nodes: np.ndarray  # (N,) uint32
    payload: np.ndarray  # (M,) uint32

    def probes_at(self, points) -> tuple[np.ndarray, np.ndarray]:
        """The probes listed for each world-space point, best first.

        ``points`` is one point ``(3,)`` or many ``(..., 3)``; they are
        converted to float32 first (round to nearest, as a Rust ``Vec3``
        would hold them). Returns ``(lists, counts)``: ``lists`` of shape
        ``(..., max_probes)``, uint32, the first ``counts[...]`` entries of
        each row the probe indices and the rest :data:`NO_PROBE`; ``counts``
        of shape ``(...)``. A count of 0 means outside the domain, solid or
        outside-the-scene space, or a non-finite point.
        """
        pts = np.asarray(points, dtype=np.float32)
        if pts.shape[-1:] != (3,):
            raise ValueError(f"points must have shape (..., 3), not {pts.shape}")
        shape = pts.shape[:-1]
        pts = pts.reshape(-1, 3)
        counts = np.zeros(len(pts), dtype=np.uint32)
        offsets = np.zeros(len(pts), dtype=np.uint64)
        with np.errstate(all="ignore"):
            # Svo::probes_at: ((point - origin) / leaf_size).floor() in f32.
            g = np.floor((pts - self.origin) / self.leaf_size)
            inside = (
                np.isfinite(g).all(axis=1)
                & (g >= np.float32(0)).all(axis=1)
                & (g < self.dims.astype(np.float32)).all(axis=1)
            )
        which = np.nonzero(inside)[0]
        c = g[which].astype(np.uint32)
        word = np.full(len(which), self.nodes[0], dtype=np.uint32)
        level = np.full(len(which), self.depth, dtype=np.uint32)
        # Each pass goes one level down; a tree of depth d ends by pass d + 1.
        for _ in range(self.depth + 2):
            if len(which) == 0:
                break
            leaf = (word & np.uint32(_LEAF_BIT)) != 0
            count = ((word >> np.uint32(_PAYLOAD_OFFSET_BITS)) & np.uint32(7)) + np.uint32(1)
            offset = word & np.uint32((1 << _PAYLOAD_OFFSET_BITS) - 1)
            listed = leaf & (offset.astype(np.uint64) + count <= len(self.payload))
            counts[which[listed]] = count[listed]
            offsets[which[listed]] = offset[listed]
            mask = word & np.uint32(0xFF)
            go = ~leaf & (mask != 0) & (level != 0)
            which, word, level, c, mask = which[go], word[go], level[go] - np.uint32(1), c[go], mask[go]
            child = (
                ((c[:, 0] >> level) & np.uint32(1))
                | (((c[:, 1] >> level) & np.uint32(1)) << np.uint32(1))
                | (((c[:, 2] >> level) & np.uint32(1)) << np.uint32(2))
            )
            bit = np.uint32(1) << child
            below = _POPCOUNT8[mask & (bit - np.uint32(1))]
            index = (word >> np.uint32(_CHILD_MASK_BITS)).astype(np.uint64) + below
            go = ((mask & bit) != 0) & (index < len(self.nodes))
            which, level, c, index = which[go], level[go], c[go], index[go]
            word = self.nodes[index.astype(np.intp)]
        k = np.arange(self.max_probes, dtype=np.uint64)
        at = np.minimum(offsets[:, None] + k, max(len(self.payload), 1) - 1).astype(np.intp)
        source = self.payload if len(self.payload) else np.zeros(1, dtype=np.uint32)
        lists = np.where(k < counts[:, None], source[at], NO_PROBE).astype(np.uint32)
        return lists.reshape(shape + (self.max_probes,)), counts.reshape(shape)

    def probes_list(self, point) -> np.ndarray:
        """The probes listed for one point, best first (uint32, length 0 to
        ``max_probes``)."""
        p = np.asarray(point, dtype=np.float32).reshape(3)
        empty = np.zeros(0, dtype=np.uint32)
        with np.errstate(all="ignore"):
            g = np.floor((p - self.origin) / self.leaf_size)
            if not (np.isfinite(g).all() and (g >= 0).all()
                    and (g < self.dims.astype(np.float32)).all()):
                return empty
        # The walk of probes_at, for one point in Python integers.
        c = [int(v) for v in g]
        level, word = self.depth, int(self.nodes[0])
        for _ in range(self.depth + 2):
            if word & _LEAF_BIT:
                count = ((word >> _PAYLOAD_OFFSET_BITS) & 7) + 1
                offset = word & ((1 << _PAYLOAD_OFFSET_BITS) - 1)
                if offset + count > len(self.payload):
                    return empty
                return self.payload[offset:offset + count].copy()
            mask = word & 0xFF
            if mask == 0 or level == 0:
                return empty
            level -= 1
            child = (c[0] >> level & 1) | (c[1] >> level & 1) << 1 | (c[2] >> level & 1) << 2
            if not mask >> child & 1:
                return empty
            index = (word >> _CHILD_MASK_BITS) + int(_POPCOUNT8[mask & ((1 << child) - 1)])
            if index >= len(self.nodes):
                return empty
            word = int(self.nodes[index])
        return empty

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World lower and upper corners of the leaves (float32, as
        ``origin + dims * leaf_size`` rounds)."""
        return self.origin, self.origin + self.dims.astype(np.float32) * self.leaf_size


def _rust_f32(x: np.float32) -> str:
    """``x`` as Rust's ``Display`` for f32 writes it (shortest round trip,
    never an exponent)."""
    if np.isnan(x):
        return "NaN"
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    return np.format_float_positional(np.float32(x), unique=True, trim="-")


def _dims_text(dims) -> str:
    return "[" + ", ".join(str(int(d)) for d in dims) + "]"


def from_bytes(data: bytes, path: str = "svo.bin") -> Svo:
    """Checks and reads the ``svo.bin`` image ``data``; ``path`` names it
    in errors and in the result.

    Raises :class:`ProbeplaceError` (``PATH: reason``, probeplace's reason)
    for any file probeplace would refuse; never reads past ``data``.
    """

    def bad(reason: str) -> ProbeplaceError:
        return ProbeplaceError(f"{path}: {reason}")

    minimum = HEADER_BYTES + CHECKSUM_BYTES
    if len(data) < 8 or data[:8] != MAGIC:
        raise bad("not a probeplace SVO file (its first bytes are not PROBESVO)")
    if len(data) < minimum:
        raise bad(f"truncated: {len(data)} bytes, but the header alone takes {minimum}")
    head = np.frombuffer(data, dtype="<u4", count=HEADER_BYTES // 4)
    version = int(head[2])
    if version != VERSION:
        raise bad(f"unsupported version {version}: this probeplace reads version {VERSION}")
    node_count, payload_count = int(head[14]), int(head[15])
    expected = minimum + 4 * (node_count + payload_count)
    if len(data) < expected:
        raise bad(f"truncated: {len(data)} bytes, but its header announces {expected}")
    if len(data) > expected:
        raise bad(f"corrupted: {len(data)} bytes, but its header announces {expected}")
    body = len(data) - CHECKSUM_BYTES
    if crc32(data[:body]) != int.from_bytes(data[body:], "little"):
        raise bad("corrupted: the checksum does not match the contents")

    floats = np.frombuffer(data, dtype="<f4", count=HEADER_BYTES // 4)
    words = np.frombuffer(data, dtype="<u4", count=node_count + payload_count,
                          offset=HEADER_BYTES).astype(np.uint32)
    words.flags.writeable = False
    svo = Svo(
        path=path,
        origin=floats[3:6].astype(np.float32),
        origin_exact=np.frombuffer(data, dtype="<f8", count=3, offset=64).astype(np.float64),
        leaf_size=np.float32(floats[6]),
        depth=int(head[7]),
        dims=head[8:11].astype(np.uint32),
        probe_count=int(head[11]),
        max_probes=int(head[12]),
        leaves_without_visible_probe=int(head[13]),
        provenance=Provenance.from_bytes(data[88:120]),
        nodes=words[:node_count],
        payload=words[node_count:],
    )
    for a in (svo.origin, svo.origin_exact, svo.dims):
        a.flags.writeable = False
    reason = _invalid(svo)
    if reason is not None:
        raise bad(f"corrupted: {reason}")
    return svo


def load_svo(path: "str | os.PathLike[str]") -> Svo:
    """Reads and checks the ``svo.bin`` at ``path`` (see :func:`from_bytes`)."""
    return from_bytes(read_file(path, "svo.bin"), os.fspath(path))


def _invalid(svo: Svo) -> "str | None":
    """Why ``svo`` breaks an invariant ``probes_at`` relies on
    (``format::validate``), or ``None``."""
    if not np.isfinite(svo.origin).all():
        return "the origin is not finite"
    if not (np.isfinite(svo.leaf_size) and svo.leaf_size > 0):
        return f"leaf size {_rust_f32(svo.leaf_size)} is not positive"
    if svo.depth > 23:
        return f"depth {svo.depth} exceeds 23"
    side = 1 << svo.depth
    dims = [int(d) for d in svo.dims]
    if min(dims) == 0 or max(dims) > side:
        return f"{_dims_text(dims)} leaves do not fit a root of {side} leaves"
    if dims[0] * dims[1] * dims[2] > MAX_LEAVES:
        return f"{_dims_text(dims)} leaves are more than the {MAX_LEAVES} a tree may have"
    if not 1 <= svo.max_probes <= 8:
        return f"{svo.max_probes} probes per leaf is outside 1..=8"
    if len(svo.nodes) == 0:
        return "there is no root node"
    over = np.nonzero(svo.payload >= svo.probe_count)[0]
    if len(over):
        return f"probe index {int(svo.payload[over[0]])} is not below the probe count {svo.probe_count}"
    # The vectorized check is the fast path for the trees probeplace
    # writes; the node walk, slower, is the rule (and names the fault).
    if _tree_is_sound(svo):
        return None
    return _first_tree_fault(svo)


def _tree_is_sound(svo: Svo) -> bool:
    """Whether the node walk of ``validate`` passes, vectorized: every leaf
    lists inside the payload, every inner node but an empty root has
    children stored after it and inside the array, the children's ranges
    cover every node but the root exactly once, and no node with children
    stands at the leaf level."""
    w = svo.nodes.astype(np.uint64)
    n = len(w)
    idx = np.arange(n, dtype=np.uint64)
    leaf = (w & _LEAF_BIT) != 0
    count = ((w >> _PAYLOAD_OFFSET_BITS) & 7) + 1
    offset = w & ((1 << _PAYLOAD_OFFSET_BITS) - 1)
    if np.any(leaf & ((count > svo.max_probes) | (offset + count > len(svo.payload)))):
        return False
    mask = w & 0xFF
    parent = ~leaf & (mask != 0)
    if np.any(~leaf & (mask == 0) & (idx != 0)):
        return False
    first = w >> _CHILD_MASK_BITS
    kids = _POPCOUNT8[mask.astype(np.intp)].astype(np.uint64)
    if np.any(parent & ((first <= idx) | (first + kids > n))):
        return False
    # Coverage by the children's ranges: 0 for the root, 1 for every other node.
    cover = np.zeros(n + 1, dtype=np.int64)
    np.add.at(cover, first[parent].astype(np.intp), 1)
    np.add.at(cover, (first[parent] + kids[parent]).astype(np.intp), -1)
    cover = np.cumsum(cover[:n])
    if cover[0] != 0 or np.any(cover[1:] != 1):
        return False
    # Levels, one layer at a time from the root (each child comes after its
    # parent, so every node is reached); a parent at level 0 is a fault.
    level = np.zeros(n, dtype=np.int64)
    level[0] = svo.depth
    layer = np.array([0], dtype=np.intp)
    while len(layer):
        layer = layer[parent[layer]]
        if np.any(level[layer] == 0):
            return False
        starts, sizes = first[layer].astype(np.intp), kids[layer].astype(np.intp)
        children = np.repeat(starts, sizes) + (
            np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes))
        level[children] = np.repeat(level[layer] - 1, sizes)
        layer = children
    return True


def _first_tree_fault(svo: Svo) -> "str | None":
    """The first fault of ``validate``'s node walk, node by node, as it
    names it; ``None`` for a sound tree."""
    nodes = svo.nodes.tolist()
    n, payload = len(nodes), len(svo.payload)
    level: list = [None] * n
    level[0] = svo.depth
    for i, w in enumerate(nodes):
        lv = level[i]
        if lv is None:
            return f"node {i} has no parent"
        if w & _LEAF_BIT:
            count = ((w >> _PAYLOAD_OFFSET_BITS) & 7) + 1
            offset = w & ((1 << _PAYLOAD_OFFSET_BITS) - 1)
            if count > svo.max_probes or offset + count > payload:
                return f"leaf {i} lists beyond the payload"
            continue
        mask = w & 0xFF
        if mask == 0:
            if i != 0:
                return f"inner node {i} has no child"
            continue
        if lv == 0:
            return f"node {i} has children below the leaf level"
        first, count = w >> _CHILD_MASK_BITS, bin(mask).count("1")
        if first <= i or first + count > n:
            return f"node {i} points outside the node array"
        for j in range(first, first + count):
            if level[j] is not None:
                return f"node {i} shares a child with another node"
            level[j] = lv - 1
    return None
