// Shared by every probeplace kernel: the bindings, the octahedral mapping
// and the probe selection structures. Each function mirrors the Rust
// function named beside it, operation for operation, so that the GPU and
// the CPU twin answer alike (tests/gpu.rs compares them).

const LEAF_BIT: u32 = 0x80000000u;
const PAYLOAD_OFFSET_BITS: u32 = 28u;
const CHILD_MASK_BITS: u32 = 8u;
const MAX_PROBES_PER_RAY: u32 = 16u;
const NO_PROBE: u32 = 0xffffffffu;
// Stands in for +inf where Rust uses it in a comparison.
const HUGE: f32 = 3.0e38;

const SELECT_GRID: u32 = 0u;
const SELECT_SVO: u32 = 1u;

struct Params {
    // Side n of the probe maps and the levels of the min pyramid.
    n: u32,
    levels: u32,
    // 0 texel, 1 bi-level, 2 Hi-Z (trace::single::March).
    march: u32,
    selection: u32,
    probe_count: u32,
    query_count: u32,
    // Side m of the irradiance maps.
    m: u32,
    svo_depth: u32,
    svo_origin: vec3f,
    svo_leaf: f32,
    svo_dims: vec3u,
    pad2: u32,
    lattice_origin: vec3f,
    pad3: f32,
    lattice_spacing: vec3f,
    pad0: u32,
    lattice_dims: vec3i,
    pad1: u32,
}

// A ray (origin, t_max, unit dir) for trace_rays; a shading point and its
// normal for gather_irradiance.
struct Query {
    origin: vec3f,
    t_max: f32,
    dir: vec3f,
    pad: f32,
}

struct Record {
    kind: u32,
    probe: u32,
    texel: u32,
    t: f32,
    fetches: u32,
    probes: u32,
    surfels: u32,
    pad: u32,
    radiance: vec4f,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var pyramid_min: texture_2d_array<f32>;
@group(0) @binding(2) var distance_map: texture_2d_array<f32>;
@group(0) @binding(3) var normal_map: texture_2d_array<f32>;
@group(0) @binding(4) var radiance_map: texture_2d_array<f32>;
@group(0) @binding(5) var irradiance_map: texture_2d_array<f32>;
@group(0) @binding(6) var moment_map: texture_2d_array<f32>;
@group(0) @binding(7) var<storage, read> positions: array<vec4f>;
@group(0) @binding(8) var<storage, read> svo_nodes: array<u32>;
@group(0) @binding(9) var<storage, read> svo_payload: array<u32>;
@group(0) @binding(10) var<storage, read> lattice_probes: array<u32>;
@group(0) @binding(11) var<storage, read> queries: array<Query>;
@group(0) @binding(12) var<storage, read_write> records: array<Record>;

fn probe_position(p: u32) -> vec3f {
    return positions[p].xyz;
}

// lightfield::octahedral::sign_not_zero
fn sign_not_zero(v: vec2f) -> vec2f {
    return select(vec2f(-1.0), vec2f(1.0), v >= vec2f(0.0));
}

// lightfield::octahedral::encode
fn oct_encode(d: vec3f) -> vec2f {
    let p = vec2f(d.x, d.y) / (abs(d.x) + abs(d.y) + abs(d.z));
    if d.z < 0.0 {
        return (vec2f(1.0) - vec2f(abs(p.y), abs(p.x))) * sign_not_zero(p);
    }
    return p;
}

// lightfield::octahedral::decode
fn oct_decode(e_in: vec2f) -> vec3f {
    let e = clamp(e_in, vec2f(-1.0), vec2f(1.0));
    let z = 1.0 - abs(e.x) - abs(e.y);
    var xy = e;
    if z < 0.0 {
        xy = (vec2f(1.0) - vec2f(abs(e.y), abs(e.x))) * sign_not_zero(e);
    }
    return normalize(vec3f(xy, z));
}

// lightfield::octahedral::texel_direction
fn texel_direction(x: i32, y: i32, n: u32) -> vec3f {
    let e = (vec2f(f32(x), f32(y)) + 0.5) / f32(n) * 2.0 - 1.0;
    return oct_decode(e);
}

// lightfield::octahedral::texel_of, as y·n + x
fn texel_of(d: vec3f, n: u32) -> u32 {
    let e = oct_encode(d);
    let c = clamp(vec2i((e + 1.0) * 0.5 * f32(n)), vec2i(0), vec2i(i32(n) - 1));
    return u32(c.y) * n + u32(c.x);
}

// lightfield::octahedral::wrap_texel
fn wrap_texel(x: i32, y: i32, n: u32) -> vec2i {
    let ni = i32(n);
    var wx = x;
    var wy = y;
    if x < 0 || x >= ni {
        wx = clamp(x, 0, ni - 1);
        wy = ni - 1 - y;
    }
    if y < 0 || y >= ni {
        wy = clamp(wy, 0, ni - 1);
        wx = ni - 1 - wx;
    }
    return vec2i(clamp(wx, 0, ni - 1), clamp(wy, 0, ni - 1));
}

// lightfield::maps::decode_normal
fn normal_at(probe: u32, t: vec2i) -> vec3f {
    return oct_decode(textureLoad(normal_map, t, probe, 0).xy);
}

// svo::Svo::probes_at: (offset, count) of the listed probes in svo_payload.
fn svo_list(point: vec3f) -> vec2u {
    let g = floor((point - params.svo_origin) / params.svo_leaf);
    if !(all(g >= vec3f(0.0)) && all(g < vec3f(params.svo_dims))) {
        return vec2u(0u);
    }
    let c = vec3u(g);
    var level = params.svo_depth;
    var word = svo_nodes[0];
    loop {
        if (word & LEAF_BIT) != 0u {
            let count = ((word >> PAYLOAD_OFFSET_BITS) & 7u) + 1u;
            let offset = word & ((1u << PAYLOAD_OFFSET_BITS) - 1u);
            if offset + count > arrayLength(&svo_payload) {
                return vec2u(0u);
            }
            return vec2u(offset, count);
        }
        let mask = word & 0xffu;
        if mask == 0u || level == 0u {
            return vec2u(0u);
        }
        level -= 1u;
        let child = ((c.x >> level) & 1u) | (((c.y >> level) & 1u) << 1u) | (((c.z >> level) & 1u) << 2u);
        if (mask & (1u << child)) == 0u {
            return vec2u(0u);
        }
        let index = (word >> CHILD_MASK_BITS) + countOneBits(mask & ((1u << child) - 1u));
        if index >= arrayLength(&svo_nodes) {
            return vec2u(0u);
        }
        word = svo_nodes[index];
    }
    return vec2u(0u);
}

// trace::Lattice::cell
fn lattice_cell(p: vec3f) -> vec3i {
    let c = vec3i(floor((p - params.lattice_origin) / params.lattice_spacing));
    return clamp(c, vec3i(0), max(params.lattice_dims - 2, vec3i(0)));
}

// trace::Lattice::corner
fn lattice_corner(cell: vec3i, i: u32) -> u32 {
    let o = vec3i(i32(i & 1u), i32((i >> 1u) & 1u), i32((i >> 2u) & 1u));
    let c = min(cell + o, params.lattice_dims - 1);
    let d = params.lattice_dims;
    return lattice_probes[u32(c.x + d.x * (c.y + d.y * c.z))];
}
