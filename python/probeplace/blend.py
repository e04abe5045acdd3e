"""The probes and weights of the validation renders' diffuse blend
(McGuire et al. 2017 §5.2), from the files a run writes: what
``probeplace::blend_weights`` answers, bit for bit.

For a point p with unit normal n the blend weighs each of its terms (a
probe) by

    w = spatial × max(n·ω, MIN_NORMAL_WEIGHT) × visibility

and divides by the sum of the w ("We normalize the result by the sum of all
eight weights", §5.2): ω is the unit direction from p toward the probe
("a clamped dot product of the shading point's surface normal and the
direction towards each probe center", a smooth backface test) and the
visibility is Chebyshev's bound σ² / (σ² + (r − E[r])²) for r > E[r] (else
1), σ² = |E[r²] − E[r]²| floored at 1e-6, from the probe's distance moments
read bilinearly in direction −ω at the distance r to the probe ("a Chebyshev
visibility test of the local radiance distance distribution"). At the probe
itself (r = 0) facing counts n·0, so the floor, and visibility 1. The
spatial weight follows the selection:

- a regular grid (:class:`Lattice`): trilinear over the eight corners of the
  cell holding p, clamped to the lattice; the terms are the corners in
  order (bit 0 = +x, bit 1 = +y, bit 2 = +z), a probe twice where the
  lattice has one layer along an axis;
- the SVO selection (an :class:`~probeplace.svo.Svo`): every probe, in
  index order, 1 / (|q − p|² + leaf²) with the tree's leaf size (the SVO's
  lists change at node faces and their weights jump there; weighting every
  probe is continuous, and the Chebyshev test removes the probes that
  cannot see p: src/trace/gather.rs).

Every value is computed in float32, one operation at a time in Rust's order
(numpy's float32 arithmetic is IEEE single precision, as Rust's is; Rust's
``f32::max`` and glam's ``clamp`` are ``a > b ? a : b``, which the
``np.where`` below repeat, NaN included), so the weights are Rust's bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._common import ProbeplaceError
from .lightfield import LightField
from .svo import NO_PROBE, Svo

#: The floor of the normal weight (``trace::gather::MIN_NORMAL_WEIGHT``): a
#: probe behind the surface still counts a little, so that a point with
#: every probe behind it is not left black.
MIN_NORMAL_WEIGHT = np.float32(0.05)
#: The floor of the moments' variance in the Chebyshev test.
_MIN_VARIANCE = np.float32(1e-6)
#: Terms of the blend on a grid: the cell's corners.
GRID_TERMS = 8
#: Points × terms computed at once (memory: some 30 float32 arrays that big).
_CHUNK = 1 << 18

_F0, _F1, _HALF = np.float32(0), np.float32(1), np.float32(0.5)


@dataclass(frozen=True, eq=False)
class Lattice:
    """The probes of a light field recognized as a regular grid, as
    ``probeplace::trace::Lattice::from_positions`` recognizes them: the
    grid selection of the validation renders (McGuire's placement;
    ``--method grid:…`` runs)."""

    origin: np.ndarray  # (3,) float32: lattice point (0, 0, 0)
    spacing: np.ndarray  # (3,) float32: per axis (1 where an axis has one layer)
    dims: np.ndarray  # (3,) int64: points per axis
    index: np.ndarray  # (dims product,) uint32: probe of each point, x fastest, then y, z

    @property
    def probe_count(self) -> int:
        return len(self.index)

    @classmethod
    def from_positions(cls, positions) -> "Lattice | None":
        """The lattice of ``positions`` ((P, 3), converted to float32, as
        ``LightField.positions`` holds them), or ``None`` unless they are
        finite, at least one, and exactly the points of an nx × ny × nz
        lattice with constant spacing per axis (to 1e-4 of the largest
        coordinate)."""
        pos = np.asarray(positions, dtype=np.float32).reshape(-1, 3)
        p_count = len(pos)
        if p_count == 0 or not np.isfinite(pos).all():
            return None
        # fold(0, max(|x|, |y|, |z|)).max(1e-6): exact in any order.
        scale = max(np.float32(np.abs(pos).max()), np.float32(1e-6))
        tol = np.float32(1e-4) * scale
        axes = [np.empty(p_count, dtype=np.float32) for _ in range(3)]
        lengths = [0, 0, 0]
        for p in pos:
            for i in range(3):
                seen = axes[i][:lengths[i]]
                if not np.any(np.abs(seen - p[i]) <= tol):
                    axes[i][lengths[i]] = p[i]
                    lengths[i] += 1
            # The axes only grow: once they span more points than there are
            # probes, the count check below must fail (Rust finds the same
            # None later).
            if lengths[0] * lengths[1] * lengths[2] > p_count:
                return None
        origin = np.zeros(3, dtype=np.float32)
        spacing = np.ones(3, dtype=np.float32)
        for i in range(3):
            # Distinct by more than tol, so no -0 beside +0: np.sort orders
            # them as Rust's total_cmp does.
            axis = np.sort(axes[i][:lengths[i]])
            origin[i] = axis[0]
            if len(axis) > 1:
                spacing[i] = (axis[-1] - axis[0]) / np.float32(len(axis) - 1)
                if np.any(np.abs((axis[1:] - axis[:-1]) - spacing[i]) > tol):
                    return None
        dims = np.array(lengths, dtype=np.int64)
        if int(dims.prod()) != p_count:
            return None
        c = _round_half_away((pos - origin) / spacing)
        if np.any(c < 0) or np.any(c >= dims):
            return None
        c = c.astype(np.int64)
        flat = c[:, 0] + dims[0] * (c[:, 1] + dims[1] * c[:, 2])
        index = np.full(p_count, NO_PROBE, dtype=np.uint32)
        index[flat] = np.arange(p_count, dtype=np.uint32)
        if np.any(index == NO_PROBE):
            return None  # two probes at one lattice point
        for a in (origin, spacing, dims, index):
            a.flags.writeable = False
        return cls(origin, spacing, dims, index)

    def cell(self, points: np.ndarray) -> np.ndarray:
        """``Lattice::cell``: the lower corner of the cell holding each
        float32 point, clamped to the lattice ((N, 3) int64)."""
        g = np.floor((points - self.origin) / self.spacing)
        c = _saturating_i32(g)
        return np.clip(c, 0, np.maximum(self.dims - 2, 0))

    def corner(self, cell: np.ndarray, i: int) -> np.ndarray:
        """``Lattice::corner``: the probe at corner ``i`` of each cell."""
        o = np.array([i & 1, (i >> 1) & 1, (i >> 2) & 1], dtype=np.int64)
        c = np.minimum(cell + o, self.dims - 1)
        return self.index[c[:, 0] + self.dims[0] * (c[:, 1] + self.dims[1] * c[:, 2])]


def _round_half_away(x: np.ndarray) -> np.ndarray:
    """Rust's ``f32::round``: to the nearest integer, halves away from zero
    (numpy's ``round`` takes halves to even)."""
    t = np.trunc(x)
    return t + np.where(np.abs(x - t) >= _HALF, np.copysign(_F1, x), _F0)


def _saturating_i32(x: np.ndarray) -> np.ndarray:
    """Rust's ``x as i32`` for float32 ``x`` (already integral): NaN is 0,
    beyond the range the nearest end (int64 result)."""
    wide = np.nan_to_num(np.asarray(x, dtype=np.float64), nan=0.0)
    return np.clip(wide, -2.0 ** 31, 2.0 ** 31 - 1).astype(np.int64)


def _wrap_texel(x: np.ndarray, y: np.ndarray, n: int):
    """``octahedral::wrap_texel``: the texel across the octahedral fold
    from (x, y), each in -1..=n."""
    out_x = (x < 0) | (x >= n)
    wx = np.where(out_x, np.clip(x, 0, n - 1), x)
    wy = np.where(out_x, n - 1 - y, y)
    out_y = (y < 0) | (y >= n)
    wy = np.where(out_y, np.clip(wy, 0, n - 1), wy)
    wx = np.where(out_y, n - 1 - wx, wx)
    return np.clip(wx, 0, n - 1), np.clip(wy, 0, n - 1)


def _encode(dx, dy, dz):
    """``octahedral::encode``: the point of [-1, 1]² of direction d."""
    s = (np.abs(dx) + np.abs(dy)) + np.abs(dz)
    px, py = dx / s, dy / s
    sx = np.where(px >= 0, _F1, -_F1)
    sy = np.where(py >= 0, _F1, -_F1)
    lower = dz < 0
    ex = np.where(lower, (_F1 - np.abs(py)) * sx, px)
    ey = np.where(lower, (_F1 - np.abs(px)) * sy, py)
    return ex, ey


def _bilinear_moments(moments: np.ndarray, m: int, probe, dx, dy, dz):
    """``trace::gather::bilinear`` of the (P, m, m, 2) float32 moment maps:
    each probe's map in direction d, wrapping across the fold."""
    ex, ey = _encode(dx, dy, dz)
    mf = np.float32(m)
    ux = (ex + _F1) * _HALF * mf - _HALF
    uy = (ey + _F1) * _HALF * mf - _HALF
    x0, y0 = np.floor(ux), np.floor(uy)
    fx, fy = ux - x0, uy - y0
    # `x0 as i64`: NaN is 0; finite values lie in -1..=m (|e| <= 1).
    xi, yi = _saturating_i32(x0), _saturating_i32(y0)
    out0 = np.zeros(np.shape(ux), dtype=np.float32)
    out1 = np.zeros(np.shape(ux), dtype=np.float32)
    for dx_, dy_, w in ((0, 0, (_F1 - fx) * (_F1 - fy)), (1, 0, fx * (_F1 - fy)),
                        (0, 1, (_F1 - fx) * fy), (1, 1, fx * fy)):
        x, y = _wrap_texel(xi + dx_, yi + dy_, m)
        texel = moments[probe, y, x]
        out0 = out0 + w * texel[..., 0]
        out1 = out1 + w * texel[..., 1]
    return out0, out1


def _terms(positions, moments, m, probe, spatial, p, n):
    """``for_each_term``'s weight of each (point, term): ``probe`` and
    ``spatial`` (N, K), ``p`` and ``n`` (N, 1, 3) float32."""
    q = positions[probe]
    tx, ty, tz = q[..., 0] - p[..., 0], q[..., 1] - p[..., 1], q[..., 2] - p[..., 2]
    r = np.sqrt((tx * tx + ty * ty) + tz * tz)
    near = r > 0
    safe = np.where(near, r, _F1)
    ox = np.where(near, tx / safe, _F0)
    oy = np.where(near, ty / safe, _F0)
    oz = np.where(near, tz / safe, _F0)
    facing = (n[..., 0] * ox + n[..., 1] * oy) + n[..., 2] * oz
    facing = np.where(facing > MIN_NORMAL_WEIGHT, facing, MIN_NORMAL_WEIGHT)
    mean, second = _bilinear_moments(moments, m, probe, -ox, -oy, -oz)
    variance = np.abs(second - mean * mean)
    variance = np.where(variance > _MIN_VARIANCE, variance, _MIN_VARIANCE)
    d = r - mean
    chebyshev = np.where(r <= mean, _F1, variance / (variance + d * d))
    visibility = np.where(near, chebyshev, _F1)
    return spatial * facing * visibility


def blend_terms(field: LightField, selection: "Svo | Lattice") -> int:
    """How many terms the blend has: 8 on a grid, every probe with the SVO."""
    return GRID_TERMS if isinstance(selection, Lattice) else field.probe_count


def blend_weights(field: LightField, selection: "Svo | Lattice", points, normals):
    """The probes and normalized weights the validation renders' diffuse
    blend reads at each point with its unit normal (module docs):
    ``probeplace::blend_weights``, bit for bit.

    ``selection`` is the run's :class:`~probeplace.svo.Svo` (the SVO
    selection of the Hi-Z render, and of the bi-level render of probes off
    a grid) or the :class:`Lattice` of ``field.positions`` (the bi-level
    render of a grid). ``points`` and ``normals`` are one ``(3,)`` or many
    ``(..., 3)`` of the same shape, world space, converted to float32 first.

    Returns ``(probes, weights, counts)``: ``probes`` uint32 and
    ``weights`` float32 of shape ``(..., K)``, K = :func:`blend_terms`, the
    terms in blend order, and ``counts`` uint32 of shape ``(...)``: K, or 0
    where the weights sum to no positive number (a non-finite point), whose
    rows hold :data:`~probeplace.NO_PROBE` and 0. Each weight is in [0, 1]
    and a row's weights sum to 1 up to a rounding per term; ``Σ weights ·
    E`` of the probes' irradiance maps read in direction n is the render's
    irradiance up to that rounding.

    Raises :class:`ProbeplaceError` when ``selection`` indexes another
    number of probes than ``field`` holds (files of different runs), and
    ``ValueError`` for arrays of the wrong shape.
    """
    if not isinstance(selection, (Svo, Lattice)):
        raise TypeError(f"selection must be an Svo or a Lattice, not {type(selection).__name__}")
    if selection.probe_count != field.probe_count:
        what = getattr(selection, "path", "the lattice")
        raise ProbeplaceError(
            f"{what}: indexes {selection.probe_count} probes but {field.path} holds "
            f"{field.probe_count}: the two come from different runs")
    pts = np.asarray(points, dtype=np.float32)
    nrm = np.asarray(normals, dtype=np.float32)
    if pts.shape[-1:] != (3,) or nrm.shape != pts.shape:
        raise ValueError(f"points and normals must have one shape (..., 3), not {pts.shape} "
                         f"and {nrm.shape}")
    shape = pts.shape[:-1]
    pts, nrm = pts.reshape(-1, 3), nrm.reshape(-1, 3)
    k = blend_terms(field, selection)
    probes = np.full((len(pts), k), NO_PROBE, dtype=np.uint32)
    weights = np.zeros((len(pts), k), dtype=np.float32)
    counts = np.zeros(len(pts), dtype=np.uint32)
    if k == 0:
        return probes.reshape(shape + (k,)), weights.reshape(shape + (k,)), counts.reshape(shape)
    positions = np.asarray(field.positions, dtype=np.float32)
    moments = np.asarray(field.moments, dtype=np.float32)
    m = field.irradiance_resolution
    step = max(1, _CHUNK // k)
    with np.errstate(all="ignore"):
        for at in range(0, len(pts), step):
            p, n = pts[at:at + step], nrm[at:at + step]
            if isinstance(selection, Lattice):
                cell = selection.cell(p)
                f = (p - selection.origin) / selection.spacing - cell.astype(np.float32)
                f = np.where(f > _F0, f, _F0)  # glam's clamp: max, then min
                f = np.where(f < _F1, f, _F1)
                probe = np.stack([selection.corner(cell, i) for i in range(GRID_TERMS)], axis=1)
                spatial = np.empty((len(p), GRID_TERMS), dtype=np.float32)
                for i in range(GRID_TERMS):
                    w = [f[:, a] if (i >> a) & 1 else _F1 - f[:, a] for a in range(3)]
                    spatial[:, i] = w[0] * w[1] * w[2]
            else:
                probe = np.broadcast_to(np.arange(k, dtype=np.intp), (len(p), k))
                q = positions[None, :, :]
                vx = q[..., 0] - p[:, None, 0]
                vy = q[..., 1] - p[:, None, 1]
                vz = q[..., 2] - p[:, None, 2]
                soft = selection.leaf_size * selection.leaf_size
                spatial = _F1 / (((vx * vx + vy * vy) + vz * vz) + soft)
            w = _terms(positions, moments, m, probe, spatial, p[:, None, :], n[:, None, :])
            # The sum in term order, as Rust adds them (not np.sum's pairs).
            total = np.zeros(len(p), dtype=np.float32)
            for j in range(k):
                total = total + w[:, j]
            ok = total > 0
            rows = np.arange(at, at + len(p))[ok]
            probes[rows] = probe[ok]
            weights[rows] = w[ok] / total[ok, None]
            counts[rows] = k
    return probes.reshape(shape + (k,)), weights.reshape(shape + (k,)), counts.reshape(shape)
