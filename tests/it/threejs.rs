//! three.js as a client of `probes.glb` (issue 69): a page in headless
//! Chromium reads the file's own bytes, takes one probe's `extras.sh_l2`
//! into a `LightProbe` the way docs/engines.md tells a three.js user to,
//! lights a white Lambertian sphere with it alone, and reads the sphere's
//! pixels back as floats. Each pixel must be what our own SH code says the
//! probe's light gives at that pixel's normal, so the file's order,
//! convention and frame are checked by the engine that reads them, not
//! by a re-statement of its constants.
//!
//! What three.js computes (the vendored 0.180.0, `src/page/vendor`): a
//! `LightProbe` adds its nine `sh.coefficients` times its intensity (1) to
//! the `lightProbe[9]` uniform; `getLightProbeIrradiance` turns the view
//! normal back into the world frame and evaluates `shGetIrradianceAt`,
//! whose constants (0.886227, 2 × 0.511664, 2 × 0.429043, 0.743125 z² −
//! 0.247708, 0.429043) are Ramamoorthi and Hanrahan's, that is
//! `Â_l · c_lm` with `Â = (π, 2π/3, π/4)` and Sloan's basis constants:
//! the whole irradiance `E(n) = Σ Â_l L_lm Y_lm(n)`, π included, which is
//! [`ShL2::irradiance`]. `MeshLambertMaterial` adds `irradiance ·
//! BRDF_Lambert(diffuse)` with `BRDF_Lambert = diffuse / π`, and nothing
//! else lights the sphere. Drawn into a float render target (linear
//! output, no tone mapping, colour management off), a pixel of a white
//! sphere (albedo 1) is therefore exactly `E(n) / π`.

use crate::browser;
use crate::common::*;
use probeplace::diffuse::ShL2;
use serde_json::Value;
use std::f32::consts::PI;

/// Most relative difference, per channel, between a pixel and `E(n) / π`:
/// the issue's 2%. SwiftShader gives under 0.1%, nearly all of it from
/// where the rasterizer samples a pixel (its normal is off the one at the
/// pixel's centre by about 0.04°); each wrong order, sign or factor tried
/// in the file (rows swapped, z negated, x mirrored, over π, band 2 lost)
/// gave 24% or more.
const TOLERANCE: f32 = 0.02;

/// The page's script. It imports three.js from the page's own text as
/// `view3d.js` does (a `file://` page cannot import modules by URL), reads
/// the `.glb` from `#glb` (base64): its 12-byte header and its first
/// chunk, the JSON, where the node `probe N` (N from `#out`'s
/// `data-probe`) has `extras.sh_l2`. It then draws the sphere (radius 1,
/// at the origin) with an orthographic camera framing it exactly from six
/// directions, and for a 3 × 3 grid of pixels well inside its disc writes
/// the pixel's world normal (from where the pixel lies on the disc and the
/// camera's axes) and its RGBA into `#out` as JSON, `data-state` `done`,
/// or the error and `failed`.
const SCRIPT: &str = r#"
(async function () {
  'use strict';
  const $ = (id) => document.getElementById(id);
  const out = $('out');
  try {
    const text = (id) => $(id).textContent;
    const blob = (s) => URL.createObjectURL(new Blob([s], { type: 'text/javascript' }));
    const core = blob(text('three-core'));
    const three = text('three');
    if (!three.includes('"./three.core.min.js"')) throw new Error('no core import to rewrite');
    const THREE = await import(blob(three.split('"./three.core.min.js"').join(JSON.stringify(core))));

    // probes.glb, as a glTF reader reads it: header, then the JSON chunk.
    const glb = Uint8Array.from(atob(text('glb').trim()), (c) => c.charCodeAt(0));
    const view = new DataView(glb.buffer);
    if (view.getUint32(0, true) !== 0x46546c67) throw new Error('not a GLB file');
    if (view.getUint32(16, true) !== 0x4e4f534a) throw new Error('first chunk is not JSON');
    const json = JSON.parse(new TextDecoder().decode(glb.subarray(20, 20 + view.getUint32(12, true))));
    const name = 'probe ' + out.dataset.probe;
    const node = json.nodes.find((n) => n.name === name);
    if (!node || !node.extras || !node.extras.sh_l2) throw new Error(name + ' has no extras.sh_l2');

    // docs/engines.md's line for three.js, as it is.
    const probe = new THREE.LightProbe();
    probe.sh.fromArray(node.extras.sh_l2.flat());

    THREE.ColorManagement.enabled = false;
    const scene = new THREE.Scene();
    scene.add(probe);
    scene.add(new THREE.Mesh(
      new THREE.SphereGeometry(1, 256, 128),
      new THREE.MeshLambertMaterial({ color: 0xffffff })));
    const renderer = new THREE.WebGLRenderer({ antialias: false });
    renderer.toneMapping = THREE.NoToneMapping;
    renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    renderer.setClearColor(0x000000, 0);
    if (!renderer.extensions.has('EXT_color_buffer_float')) {
      throw new Error('no EXT_color_buffer_float: cannot draw into floats');
    }
    const size = 64;
    const target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType });
    const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.5, 10);
    const pixels = new Float32Array(4 * size * size);
    const views = [
      [[0, 0, 1], [0, 1, 0]], [[0, 0, -1], [0, 1, 0]],
      [[1, 0, 0], [0, 1, 0]], [[-1, 0, 0], [0, 1, 0]],
      [[0, 1, 0], [0, 0, 1]], [[0, -1, 0], [0, 0, 1]],
    ];
    const samples = [];
    for (const [from, up] of views) {
      camera.position.set(5 * from[0], 5 * from[1], 5 * from[2]);
      camera.up.set(up[0], up[1], up[2]);
      camera.lookAt(0, 0, 0);
      camera.updateMatrixWorld();
      renderer.setRenderTarget(target);
      renderer.render(scene, camera);
      renderer.readRenderTargetPixels(target, 0, 0, size, size, pixels);
      renderer.setRenderTarget(null);
      // The camera's right, up and backward axes in the world frame.
      const e = camera.matrixWorld.elements;
      const axes = [[e[0], e[1], e[2]], [e[4], e[5], e[6]], [e[8], e[9], e[10]]];
      for (const j of [14, 32, 50]) {
        for (const i of [14, 32, 50]) {
          // Pixel (i, j), row 0 at the bottom, has its centre at (x, y)
          // on the frustum [-1, 1]²; the sphere's point there faces
          // x right + y up + z back.
          const x = -1 + (2 * i + 1) / size;
          const y = -1 + (2 * j + 1) / size;
          const z = Math.sqrt(1 - x * x - y * y);
          const n = [0, 1, 2].map((a) => x * axes[0][a] + y * axes[1][a] + z * axes[2][a]);
          const k = 4 * (j * size + i);
          samples.push({ n, rgba: Array.from(pixels.subarray(k, k + 4)) });
        }
      }
    }
    out.textContent = JSON.stringify({ revision: THREE.REVISION, samples });
    out.dataset.state = 'done';
  } catch (e) {
    out.textContent = String((e && e.stack) || e);
    out.dataset.state = 'failed';
  }
})();
"#;

/// The page: three.js and the `.glb` as inert script blocks, the probe to
/// light with, and [`SCRIPT`].
fn page(glb: &[u8], probe: usize) -> String {
    use base64::Engine;
    let vendor = |f: &str| std::fs::read_to_string(root().join("src/page/vendor").join(f)).unwrap();
    let inert = |id: &str, text: &str| {
        assert!(!text.to_ascii_lowercase().contains("</script"), "{id}");
        format!("<script type=\"text/x-module-text\" id=\"{id}\">{text}</script>\n")
    };
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>three.js LightProbe</title></head><body>\n\
         <pre id=\"out\" data-probe=\"{probe}\" data-state=\"loading\"></pre>\n{}{}{}<script>{SCRIPT}</script>\n</body></html>\n",
        inert("three-core", &vendor("three.core.min.js")),
        inert("three", &vendor("three.module.min.js")),
        inert("glb", &base64::engine::general_purpose::STANDARD.encode(glb)),
    )
}

/// One probe's SH from `sh.json`'s `total` rows (nine `[r, g, b]`).
fn sh_of(rows: &Value) -> ShL2 {
    let rows: Vec<[f32; 3]> = serde_json::from_value(rows.clone()).unwrap();
    assert_eq!(rows.len(), 9);
    let mut sh = ShL2::ZERO;
    for (c, row) in sh.coefficients.iter_mut().zip(rows) {
        *c = row.into();
    }
    sh
}

/// Whether the irradiance of `sh` stays at least a tenth of its largest,
/// in every channel, over 2000 directions spread evenly over the sphere
/// (a Fibonacci lattice). Near zero (beside the light, a probe's band-limited
/// irradiance rings below zero behind it), a relative difference would
/// measure only where the rasterizer put the pixel, not what three.js made
/// of the file.
fn clear_of_zero(sh: &ShL2) -> bool {
    const N: usize = 2000;
    let golden = PI * (3.0 - 5f32.sqrt());
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
    for i in 0..N {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / N as f32;
        let r = (1.0 - z * z).sqrt();
        let (s, c) = (i as f32 * golden).sin_cos();
        let e = sh.irradiance(glam::Vec3::new(r * c, r * s, z));
        (lo, hi) = (lo.min(e), hi.max(e));
    }
    lo.cmpge(0.1 * hi).all()
}

/// The acceptance of issue 69's three.js item: after a bake of our Cornell
/// box, `probes.glb` read by three.js 0.180 in headless Chromium lights a
/// white Lambertian sphere through `LightProbe` with the probe's
/// `extras.sh_l2`, and at 54 normals spread over the whole sphere (six
/// views, nine pixels each, none near the silhouette) each pixel is
/// `E(n) / π` of [`ShL2::irradiance`] (module docs) within 2% per channel.
/// The probe is the one whose light is most directional (largest band-1
/// magnitude against band 0) among those whose irradiance stays clear of
/// zero ([`clear_of_zero`]), and its irradiance over those normals must
/// vary far more than 2%, so that a wrong order, sign, constant or frame
/// fails. Our side reads the SH from `sh.json`, not from the `.glb`.
#[test]
fn three_js_lights_a_sphere_with_a_probe_of_probes_glb_as_we_do() {
    let test = "three_js_lights_a_sphere_with_a_probe_of_probes_glb_as_we_do";
    let Some(chromium) = browser::chromium(test) else {
        return;
    };
    let bake = shared_job("bake", "configs/cornell.ron", &[]);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = [
        "export",
        bake.dir.to_str().unwrap(),
        "--format",
        "glb",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    let o = probeplace(&args);
    assert!(
        o.status.success(),
        "probeplace {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );

    let sh: Vec<ShL2> = read_json(&bake.dir.join("sh.json"))["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| sh_of(&p["total"]))
        .collect();
    let directional = |s: &ShL2| {
        let band1: f32 = s.coefficients[1..4]
            .iter()
            .map(|c| c.length_squared())
            .sum();
        band1.sqrt() / s.coefficients[0].length()
    };
    let probe = (0..sh.len())
        .filter(|&i| clear_of_zero(&sh[i]))
        .max_by(|&a, &b| directional(&sh[a]).total_cmp(&directional(&sh[b])))
        .expect("a probe whose irradiance stays clear of zero");
    let sh = sh[probe];

    let glb = std::fs::read(out.join("probes.glb")).unwrap();
    let html = dir.path().join("lightprobe.html");
    std::fs::write(&html, page(&glb, probe)).unwrap();
    let loaded = browser::load(&chromium, &html);
    let result = loaded.text("out");
    assert_eq!(
        loaded.attr("out", "data-state").as_deref(),
        Some("done"),
        "the page: {result}\n{}",
        loaded.log
    );
    let result: Value = serde_json::from_str(&result).unwrap();
    assert_eq!(result["revision"], "180");
    let samples = result["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 54);

    let mut worst = (0.0f32, String::new());
    let mut luminance = Vec::new();
    for s in samples {
        let n: [f32; 3] = serde_json::from_value(s["n"].clone()).unwrap();
        let rgba: [f32; 4] = serde_json::from_value(s["rgba"].clone()).unwrap();
        let n = glam::Vec3::from(n);
        assert!((n.length() - 1.0).abs() < 1e-5, "normal {n}");
        assert_eq!(rgba[3], 1.0, "at {n}: not on the sphere: {rgba:?}");
        let want = sh.irradiance(n) / PI;
        luminance.push(want.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722)));
        for c in 0..3 {
            assert!(want[c] > 0.0, "probe {probe} at {n}: E = {want}");
            let error = (rgba[c] - want[c]).abs() / want[c];
            if error >= worst.0 {
                worst = (
                    error,
                    format!("at n = {n}, channel {c}: {} against {}", rgba[c], want[c]),
                );
            }
        }
    }
    let (lo, hi) = luminance
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    eprintln!(
        "{test}: probe {probe} (band 1 / band 0 {:.3}); E/π over the normals {lo:.4}..{hi:.4}; \
         largest relative difference {:.2e} {}",
        directional(&sh),
        worst.0,
        worst.1
    );
    assert!(
        hi > 1.5 * lo,
        "probe {probe}'s light barely varies ({lo}..{hi}): the check would not discriminate"
    );
    assert!(
        worst.0 <= TOLERANCE,
        "probe {probe}: three.js's pixel is not E(n)/π {}",
        worst.1
    );
}
