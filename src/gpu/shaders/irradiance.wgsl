// Diffuse indirect light from the irradiance probes (McGuire et al. 2017
// §5.2): spatial (trilinear on a grid, inverse square over every probe
// otherwise) × clamped-normal × Chebyshev weights, normalized. Rust
// twin: src/trace/gather.rs (irradiance_at, blend_weights, bilinear).
// Queries hold a shading point in `origin` and its unit normal in `dir`;
// the irradiance goes to `radiance` of the record.
//
// The blend's weights come from one function, `blend_term`, which
// `gather_irradiance` blends with and `blend_weights` reports: a renderer
// copying `blend_count` and `blend_term` (with `bilinear`,
// `chebyshev_visibility` and what they read) weighs the probes as the
// validation render does.

const MIN_NORMAL_WEIGHT: f32 = 0.05;

// trace::gather::bilinear, for the irradiance (rgb) or moment (rg) map.
fn bilinear(moments: bool, probe: u32, d: vec3f) -> vec4f {
    let m = params.m;
    let e = oct_encode(d);
    let ux = (e.x + 1.0) * 0.5 * f32(m) - 0.5;
    let uy = (e.y + 1.0) * 0.5 * f32(m) - 0.5;
    let x0 = floor(ux);
    let y0 = floor(uy);
    let fx = ux - x0;
    let fy = uy - y0;
    let offsets = array<vec2i, 4>(vec2i(0, 0), vec2i(1, 0), vec2i(0, 1), vec2i(1, 1));
    let weights = array<f32, 4>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    var out = vec4f(0.0);
    for (var k = 0; k < 4; k++) {
        let xy = wrap_texel(i32(x0) + offsets[k].x, i32(y0) + offsets[k].y, m);
        var texel: vec4f;
        if moments {
            texel = textureLoad(moment_map, xy, probe, 0);
        } else {
            texel = textureLoad(irradiance_map, xy, probe, 0);
        }
        out += weights[k] * texel;
    }
    return out;
}

// lightfield::irradiance::chebyshev_visibility
fn chebyshev_visibility(moments: vec2f, r: f32) -> f32 {
    let mean = moments.x;
    if r <= mean {
        return 1.0;
    }
    let variance = max(abs(moments.y - mean * mean), 1e-6);
    let d = r - mean;
    return variance / (variance + d * d);
}

// One term of the diffuse blend: a probe and its weight before
// normalization (trace::gather::for_each_term).
struct BlendTerm {
    probe: u32,
    weight: f32,
}

// How many terms the blend at any point has: the eight corners of the
// point's grid cell, or every probe with the SVO selection.
fn blend_count() -> u32 {
    if params.selection == SELECT_GRID {
        return 8u;
    }
    return params.probe_count;
}

// Term k (< blend_count()) of the blend at p with unit normal n, in the
// order of trace::gather::for_each_term and with its operations: the
// spatial weight (corner k of the cell, trilinear; or probe k, 1 / (|q −
// p|² + leaf²)) × max(n·ω, MIN_NORMAL_WEIGHT) × Chebyshev visibility of
// the probe's moments toward p. Normalized weights are weight / Σ weight
// over k (gather_irradiance, blend_weights).
fn blend_term(k: u32, p: vec3f, n: vec3f) -> BlendTerm {
    var probe = k;
    var spatial: f32;
    if params.selection == SELECT_GRID {
        let cell = lattice_cell(p);
        let f = clamp((p - params.lattice_origin) / params.lattice_spacing - vec3f(cell), vec3f(0.0), vec3f(1.0));
        let o = vec3u(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
        let w = select(vec3f(1.0) - f, f, o == vec3u(1u));
        probe = lattice_corner(cell, k);
        spatial = w.x * w.y * w.z;
    } else {
        let v = probe_position(k) - p;
        spatial = 1.0 / (dot(v, v) + params.svo_leaf * params.svo_leaf);
    }
    let to_probe = probe_position(probe) - p;
    let r = length(to_probe);
    var toward = vec3f(0.0);
    if r > 0.0 {
        toward = to_probe / r;
    }
    let facing = max(dot(n, toward), MIN_NORMAL_WEIGHT);
    var visibility = 1.0;
    if r > 0.0 {
        visibility = chebyshev_visibility(bilinear(true, probe, -toward).xy, r);
    }
    return BlendTerm(probe, spatial * facing * visibility);
}

@compute @workgroup_size(64)
fn gather_irradiance(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x;
    if i >= params.query_count {
        return;
    }
    let q = queries[i];
    let p = q.origin;
    let n = q.dir;
    var sum = vec3f(0.0);
    var total = 0.0;
    let count = blend_count();
    for (var k = 0u; k < count; k++) {
        let t = blend_term(k, p, n);
        sum += bilinear(false, t.probe, n).xyz * t.weight;
        total += t.weight;
    }
    var e = vec3f(0.0);
    if total > 0.0 {
        e = sum / total;
    }
    records[i] = Record(0u, 0u, 0u, 0.0, 0u, 0u, 0u, 0u, vec4f(e, 1.0));
}

// The normalized weight of one term (trace::gather::blend_weights): query
// i holds the point in `origin`, its unit normal in `dir` and the term's
// index k in `t_max` (as a float); record i gets the term's probe in
// `probe`, k in `texel` and weight / Σ weight in `t`. A k past the blend,
// or a blend whose weights sum to no positive number, gives NO_PROBE and
// 0. Each query sums all the terms again: a check of `blend_term` against
// its Rust twin (tests/it/gpu.rs), not a way to render.
@compute @workgroup_size(64)
fn blend_weights(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x;
    if i >= params.query_count {
        return;
    }
    let q = queries[i];
    let k = u32(q.t_max);
    let count = blend_count();
    var total = 0.0;
    for (var j = 0u; j < count; j++) {
        total += blend_term(j, q.origin, q.dir).weight;
    }
    var probe = NO_PROBE;
    var w = 0.0;
    if k < count && total > 0.0 {
        let t = blend_term(k, q.origin, q.dir);
        probe = t.probe;
        w = t.weight / total;
    }
    records[i] = Record(0u, probe, k, w, 0u, 0u, 0u, 0u, vec4f(0.0));
}
