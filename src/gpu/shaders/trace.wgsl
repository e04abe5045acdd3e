// The light-field ray trace (McGuire et al. 2017 §4, Listing 1) with the
// bi-level march of McGuire §4.1 or the Hi-Z march of Wang et al. 2019
// §4.2, and grid or SVO probe selection. Rust twin: src/trace/ (mod.rs
// trace, single.rs trace and march_piece, surfel_test); every function
// names its twin.

const MARCH_TEXEL: u32 = 0u;
const MARCH_BILEVEL: u32 = 1u;
const MARCH_HIZ: u32 = 2u;
const BILEVEL_COARSE_LEVEL: u32 = 4u;

const PROBE_HIT: u32 = 0u;
const PROBE_MISS: u32 = 1u;
const PROBE_UNKNOWN: u32 = 2u;

const TEXEL_PASS: u32 = 0u;
const TEXEL_HIT: u32 = 1u;
const TEXEL_BEHIND: u32 = 2u;

// The counters of trace::single::Steps.
var<private> fine_steps: u32;
var<private> coarse_steps: u32;
var<private> surfel_tests: u32;

struct ProbeResult {
    kind: u32,
    t: f32,
}

struct TexelResult {
    kind: u32,
    t: f32,
}

// trace::single::Piece
struct Piece {
    nx: vec2f,
    ny: vec2f,
    den: vec2f,
    sx: i32,
    sy: i32,
}

// trace::single::sgn
fn sgn(v: f32) -> f32 {
    return select(-1.0, 1.0, v >= 0.0);
}

fn motion(n: vec2f, den: vec2f) -> i32 {
    let m = n.y * den.x - n.x * den.y;
    if m > 0.0 {
        return 1;
    }
    if m < 0.0 {
        return -1;
    }
    return 0;
}

// trace::single::Piece::new
fn piece_new(a: vec3f, d: vec3f, mid: vec3f) -> Piece {
    let s = vec3f(sgn(mid.x), sgn(mid.y), sgn(mid.z));
    let den = vec2f(dot(s, a), dot(s, d));
    var nx = vec2f(a.x, d.x);
    var ny = vec2f(a.y, d.y);
    if mid.z < 0.0 {
        nx = vec2f(s.x * (den.x - s.y * a.y), s.x * (den.y - s.y * d.y));
        ny = vec2f(s.y * (den.x - s.x * a.x), s.y * (den.y - s.x * d.x));
    }
    return Piece(nx, ny, den, motion(nx, den), motion(ny, den));
}

// trace::single::Piece::at
fn piece_at(p: Piece, t: f32) -> vec2f {
    let dn = p.den.x + p.den.y * t;
    return vec2f((p.nx.x + p.nx.y * t) / dn, (p.ny.x + p.ny.y * t) / dn);
}

// trace::single::Piece::crossing
fn piece_crossing(p: Piece, n: vec2f, c: f32) -> f32 {
    let k = n.y - c * p.den.y;
    if k == 0.0 {
        return HUGE;
    }
    return (c * p.den.x - n.x) / k;
}

// trace::single::cell
fn cell_of(e: f32, side: u32, m: i32) -> i32 {
    let x = (e + 1.0) * 0.5 * f32(side) + f32(m) * 1e-4;
    return i32(clamp(floor(x), 0.0, f32(side) - 1.0));
}

// trace::single::onset: the first t where f < 0, or HUGE.
fn onset(fa: f32, fb: f32, ta: f32, tb: f32) -> f32 {
    if fa < 0.0 {
        return ta;
    }
    if fb < 0.0 {
        return ta + (tb - ta) * fa / (fa - fb);
    }
    return HUGE;
}

// trace::single::surfel_test's `meets`: the ray crosses the plane from
// front to back, or enters within tau behind it and goes deeper.
fn meets(fa: f32, fb: f32, tau: f32) -> bool {
    return fb <= 0.0 && (fa > 0.0 || (fa >= -tau && fb < fa));
}

// trace::single::surfel_test
fn surfel_test(probe: u32, x: i32, y: i32, q0: vec3f, q1: vec3f, ta: f32, tb: f32) -> TexelResult {
    let n = params.n;
    let s = textureLoad(distance_map, vec2i(x, y), probe, 0).r;
    let nrm = normal_at(probe, vec2i(x, y));
    let centre = texel_direction(x, y, n) * s;
    let fa = dot(nrm, q0 - centre);
    let fb = dot(nrm, q1 - centre);
    let tau = 2.0 * s / f32(n);
    let eps = 1e-3 * s;
    var hit = HUGE;
    if meets(fa, fb, tau) {
        if fa <= 0.0 {
            hit = ta;
        } else {
            hit = ta + (tb - ta) * fa / (fa - fb);
        }
    }
    var shielded = false;
    var gate = ta;
    let offsets = array<vec2i, 4>(vec2i(-1, 0), vec2i(1, 0), vec2i(0, -1), vec2i(0, 1));
    for (var j = 0; j < 4; j++) {
        let w = wrap_texel(x + offsets[j].x, y + offsets[j].y, n);
        let sk = textureLoad(distance_map, w, probe, 0).r;
        let nk = normal_at(probe, w);
        if !(sk < HUGE) {
            continue;
        }
        let ck = texel_direction(w.x, w.y, n) * sk;
        let own_of_k = dot(nrm, ck - centre);
        let k_of_own = dot(nk, centre - ck);
        let ga = dot(nk, q0 - ck);
        let gb = dot(nk, q1 - ck);
        if own_of_k >= -eps && k_of_own >= -eps {
            if meets(ga, gb, tau) {
                var tk = ta;
                if ga > 0.0 {
                    tk = ta + (tb - ta) * ga / (ga - gb);
                }
                hit = min(hit, tk);
            }
        } else if own_of_k < eps && k_of_own < eps && ga >= 0.0 {
            shielded = true;
            let t0 = onset(fa, fb, ta, tb);
            let t1 = onset(ga, gb, ta, tb);
            gate = max(gate, t1);
            if t0 < HUGE && t1 < HUGE {
                hit = min(hit, max(t0, t1));
            }
        }
    }
    hit = max(hit, gate);
    if hit < HUGE {
        return TexelResult(TEXEL_HIT, clamp(hit, ta, tb));
    }
    if fa < -tau && !shielded {
        return TexelResult(TEXEL_BEHIND, 0.0);
    }
    return TexelResult(TEXEL_PASS, 0.0);
}

// trace::single::start_level
fn start_level(n: u32) -> u32 {
    let log2n = countTrailingZeros(n);
    if params.march == MARCH_BILEVEL {
        return min(BILEVEL_COARSE_LEVEL, log2n);
    }
    if params.march == MARCH_HIZ {
        return select(0u, log2n - 3u, log2n >= 3u);
    }
    return 0u;
}

// One coordinate's part of trace::single::march_piece's exit: the edge of
// texel i the ray reaches moving with motion m, if it is the first so far.
fn leave_by(p: Piece, n: vec2f, i: i32, m: i32, side: u32, t: f32, exit: ptr<function, f32>, up: ptr<function, u32>) {
    let next = select(i, i + 1, m > 0);
    let c = piece_crossing(p, n, 2.0 * f32(next) / f32(side) - 1.0);
    let levels = countTrailingZeros(u32(next));
    if c > t && c < *exit {
        *exit = c;
        *up = levels;
    } else if c > t && c == *exit {
        *up = max(*up, levels);
    }
}

// trace::single::climb
fn climb(level: u32, up_levels: u32, top: u32) -> u32 {
    if params.march == MARCH_HIZ && up_levels == 0u {
        return level;
    }
    if params.march == MARCH_HIZ {
        return min(level + 1u, top);
    }
    return top;
}

// trace::single::march_piece; kind PROBE_MISS means "reached the end".
fn march_piece(probe: u32, a: vec3f, d: vec3f, piece: Piece, ta: f32, tb: f32, at_origin: bool) -> ProbeResult {
    let n = params.n;
    let top = start_level(n);
    var level = top;
    var coarse_end = ta;
    var t = ta;
    var budget = 16u * n * (top + 1u) + 64u;
    while t < tb && budget > 0u {
        budget -= 1u;
        let side = n >> level;
        let e = piece_at(piece, t);
        let ix = cell_of(e.x, side, piece.sx);
        let iy = cell_of(e.y, side, piece.sy);
        // The exit edge, and how many levels up it is still a texel edge.
        var exit = tb;
        var up_levels = 0u;
        if piece.sx != 0 {
            leave_by(piece, piece.nx, ix, piece.sx, side, t, &exit, &up_levels);
        }
        if piece.sy != 0 {
            leave_by(piece, piece.ny, iy, piece.sy, side, t, &exit, &up_levels);
        }
        let lo = textureLoad(pyramid_min, vec2i(ix, iy), probe, level).r;
        let in_front = max(length(a + d * t), length(a + d * exit)) < lo;
        if level > 0u {
            coarse_steps += 1u;
            if in_front {
                t = exit;
                level = climb(level, up_levels, top);
            } else if params.march == MARCH_BILEVEL || (at_origin && t == ta) {
                coarse_end = exit;
                level = 0u;
            } else {
                level -= 1u;
            }
            continue;
        }
        fine_steps += 1u;
        if !in_front {
            surfel_tests += 1u;
            let r = surfel_test(probe, ix, iy, a + d * t, a + d * exit, t, exit);
            if r.kind == TEXEL_HIT {
                return ProbeResult(PROBE_HIT, r.t);
            }
            if r.kind == TEXEL_BEHIND {
                return ProbeResult(PROBE_UNKNOWN, t);
            }
        }
        t = exit;
        if params.march == MARCH_HIZ {
            level = climb(level, up_levels, top);
        } else if params.march == MARCH_BILEVEL && t >= coarse_end {
            level = top;
        }
    }
    if t < tb {
        return ProbeResult(PROBE_UNKNOWN, t);
    }
    return ProbeResult(PROBE_MISS, tb);
}

// trace::single::trace
fn trace_probe(probe: u32, origin: vec3f, dir: vec3f, t0: f32, t1: f32) -> ProbeResult {
    let a = origin - probe_position(probe);
    var cuts = array<f32, 5>(t0, t1, t1, t1, t1);
    var k = 1;
    for (var i = 0; i < 3; i++) {
        if dir[i] != 0.0 {
            let t = -a[i] / dir[i];
            if t > t0 && t < t1 {
                cuts[k] = t;
                k += 1;
            }
        }
    }
    cuts[k] = t1;
    // Insertion sort of cuts[1..k].
    for (var i = 2; i < k; i++) {
        var j = i;
        while j > 1 && cuts[j - 1] > cuts[j] {
            let tmp = cuts[j];
            cuts[j] = cuts[j - 1];
            cuts[j - 1] = tmp;
            j -= 1;
        }
    }
    for (var w = 0; w < k; w++) {
        let ta = cuts[w];
        let tb = cuts[w + 1];
        if tb <= ta {
            continue;
        }
        let mid = a + dir * (0.5 * (ta + tb));
        if dot(mid, mid) == 0.0 {
            continue;
        }
        let r = march_piece(probe, a, dir, piece_new(a, dir, mid), ta, tb, w == 0);
        if r.kind != PROBE_MISS {
            return r;
        }
    }
    return ProbeResult(PROBE_MISS, t1);
}

var<private> tried: array<u32, 16>;

fn was_tried(p: u32, count: u32) -> bool {
    for (var i = 0u; i < count; i++) {
        if tried[i] == p {
            return true;
        }
    }
    return false;
}

// trace::nearest_untried
fn nearest_untried(p: vec3f, count: u32) -> u32 {
    var best = NO_PROBE;
    var best_d = HUGE;
    for (var i = 0u; i < params.probe_count; i++) {
        if was_tried(i, count) {
            continue;
        }
        let v = probe_position(i) - p;
        let d2 = dot(v, v);
        if best == NO_PROBE || d2 < best_d {
            best = i;
            best_d = d2;
        }
    }
    return best;
}

// trace::closest_corner
fn closest_corner(cell: vec3i, p: vec3f, dir: vec3f, count: u32) -> u32 {
    var best_d = HUGE;
    var best = 0u;
    var found = false;
    for (var i = 0u; i < 8u; i++) {
        let probe = lattice_corner(cell, i);
        if was_tried(probe, count) {
            continue;
        }
        let v = probe_position(probe) - p;
        let w = v - dir * dot(v, dir);
        let d2 = dot(w, w);
        if !found || d2 < best_d {
            best_d = d2;
            best = i;
            found = true;
        }
    }
    return best;
}

@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x;
    if i >= params.query_count {
        return;
    }
    let q = queries[i];
    let origin = q.origin;
    let dir = q.dir;
    fine_steps = 0u;
    coarse_steps = 0u;
    surfel_tests = 0u;
    var t = 0.0;
    var count = 0u;
    var grid_cell = vec3i(-2147483647);
    var corner = 0u;
    var corners_used = 0u;
    var kind = 3u;
    var probe_out = NO_PROBE;
    var t_out = 0.0;
    loop {
        if count >= MAX_PROBES_PER_RAY {
            kind = 2u;
            probe_out = tried[count - 1u];
            t_out = t;
            break;
        }
        let here = origin + dir * t;
        var next = NO_PROBE;
        if params.selection == SELECT_SVO {
            let list = svo_list(here);
            for (var j = 0u; j < list.y; j++) {
                let p = svo_payload[list.x + j];
                if !was_tried(p, count) {
                    next = p;
                    break;
                }
            }
            if next == NO_PROBE {
                next = nearest_untried(here, count);
            }
        } else {
            let cell = lattice_cell(here);
            if any(cell != grid_cell) {
                grid_cell = cell;
                corners_used = 0u;
                corner = closest_corner(cell, here, dir, count);
            } else {
                corner = (corner + 3u) % 8u;
            }
            while corners_used < 8u {
                corners_used += 1u;
                let p = lattice_corner(cell, corner);
                if !was_tried(p, count) {
                    next = p;
                    break;
                }
                corner = (corner + 3u) % 8u;
            }
        }
        if next == NO_PROBE {
            kind = select(2u, 3u, count == 0u);
            probe_out = select(NO_PROBE, tried[max(count, 1u) - 1u], count > 0u);
            t_out = t;
            break;
        }
        tried[count] = next;
        count += 1u;
        let r = trace_probe(next, origin, dir, t, q.t_max);
        if r.kind == PROBE_HIT {
            kind = 0u;
            probe_out = next;
            t_out = r.t;
            break;
        }
        if r.kind == PROBE_MISS {
            kind = 1u;
            probe_out = next;
            t_out = q.t_max;
            break;
        }
        t = max(r.t, t);
    }
    // trace::RayOutcome::lookup
    var texel = NO_PROBE;
    var radiance = vec4f(0.0);
    if probe_out != NO_PROBE {
        var toward = origin + dir * t_out - probe_position(probe_out);
        if kind == 1u {
            toward = dir;
        }
        texel = texel_of(toward, params.n);
        let xy = vec2i(i32(texel % params.n), i32(texel / params.n));
        radiance = vec4f(textureLoad(radiance_map, xy, probe_out, 0).rgb, 1.0);
    }
    records[i] = Record(kind, probe_out, texel, t_out, fine_steps + coarse_steps, count, surfel_tests, 0u, radiance);
}
