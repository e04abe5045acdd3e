// Diffuse indirect light from the irradiance probes (McGuire et al. 2017
// §5.2): spatial (trilinear on a grid, inverse square over every probe
// otherwise) × clamped-normal × Chebyshev weights, normalized. Rust
// twin: src/lightfield/gather.rs (irradiance_at, bilinear). Queries hold a
// shading point in `origin` and its unit normal in `dir`; the irradiance
// goes to `radiance` of the record.

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

var<private> gather_sum: vec3f;
var<private> gather_total: f32;

fn gather_add(probe: u32, spatial: f32, p: vec3f, n: vec3f) {
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
    let w = spatial * facing * visibility;
    gather_sum += bilinear(false, probe, n).xyz * w;
    gather_total += w;
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
    gather_sum = vec3f(0.0);
    gather_total = 0.0;
    if params.selection == SELECT_GRID {
        let cell = lattice_cell(p);
        let f = clamp((p - params.lattice_origin) / params.lattice_spacing - vec3f(cell), vec3f(0.0), vec3f(1.0));
        for (var c = 0u; c < 8u; c++) {
            let o = vec3u(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
            let w = select(vec3f(1.0) - f, f, o == vec3u(1u));
            gather_add(lattice_corner(cell, c), w.x * w.y * w.z, p, n);
        }
    } else {
        let soft = params.svo_leaf * params.svo_leaf;
        for (var probe = 0u; probe < params.probe_count; probe++) {
            let v = probe_position(probe) - p;
            gather_add(probe, 1.0 / (dot(v, v) + soft), p, n);
        }
    }
    var e = vec3f(0.0);
    if gather_total > 0.0 {
        e = gather_sum / gather_total;
    }
    records[i] = Record(0u, 0u, 0u, 0.0, 0u, 0u, 0u, 0u, vec4f(e, 1.0));
}
