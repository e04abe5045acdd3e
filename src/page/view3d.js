// The 3D view of a probeplace report.html (src/report/view3d.rs writes the
// page; docs/formats.md, "report.html", describes it).
//
// The page carries everything it needs, so that it works offline from
// file://: three.js as text in script blocks of type
// text/x-probeplace-module (never run as they are), and the scene and
// probes as JSON in the script block #v3-data. A page
// from file:// cannot import a module by a relative URL, so each module's
// text becomes a blob: URL, its one import rewritten to the blob of what it
// imports, and is then imported dynamically.
//
// What it draws: the mesh (quantized u16 positions, flat-shaded by
// material), the probes as spheres coloured by clearance, the coverage
// holes as red points, the domain's frame, and for the probe under the
// pointer its influence box (the SVO leaf cells that list it) and figures.
// It renders on demand (after a change), not in a loop.
//
// Progress and failures are written into #v3-status (data-state: loading,
// drawn or failed), which the headless-browser tests read.
(function () {
  'use strict';

  const $ = (id) => document.getElementById(id);
  const status = $('v3-status');

  function setStatus(state, text) {
    status.dataset.state = state;
    status.textContent = text;
  }

  // Decodes standard base64 into bytes.
  function bytes(b64) {
    const text = atob(b64);
    const out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
    return out;
  }

  // Little-endian typed arrays of a base64 string (every platform a
  // browser runs on is little-endian; each array has its own buffer, so
  // alignment holds).
  const floats = (b64) => new Float32Array(bytes(b64).buffer);

  // Imports three.js and OrbitControls from the page's own text.
  async function loadThree() {
    const text = (id) => $(id).textContent;
    const blobUrl = (source) =>
      URL.createObjectURL(new Blob([source], { type: 'text/javascript' }));
    const rewrite = (source, from, to) => {
      if (!source.includes(from)) throw new Error('view3d: no ' + from + ' to rewrite');
      return source.split(from).join(to);
    };
    const core = blobUrl(text('v3-three-core'));
    const three = blobUrl(rewrite(text('v3-three'), '"./three.core.min.js"', JSON.stringify(core)));
    const orbit = blobUrl(rewrite(text('v3-orbit'), "from 'three'", 'from ' + JSON.stringify(three)));
    const THREE = await import(three);
    const { OrbitControls } = await import(orbit);
    return { THREE, OrbitControls };
  }

  // A colour given as sRGB bytes, as the legend's CSS shows it.
  const srgb = (THREE, c) => new THREE.Color().setRGB(c[0] / 255, c[1] / 255, c[2] / 255, THREE.SRGBColorSpace);

  // The clearance colour of a probe: the ramp over [0, max], or the
  // colours of probes in solid (negative) and outside the grid (NaN).
  function clearanceColour(THREE, colours, c) {
    if (Number.isNaN(c)) return srgb(THREE, colours.outside);
    if (c < 0) return srgb(THREE, colours.solid);
    const ramp = colours.ramp;
    const t = colours.clearance_max > 0 ? Math.min(c / colours.clearance_max, 1) : 0;
    const x = t * (ramp.length - 1);
    const i = Math.min(Math.floor(x), ramp.length - 2);
    const f = x - i;
    const mix = ramp[i].map((v, k) => v + f * (ramp[i + 1][k] - v));
    return srgb(THREE, mix);
  }

  // The scene's mesh: one geometry, one group and material per scene
  // material.
  function buildMesh(THREE, m, clipping) {
    const q = new Uint16Array(bytes(m.positions).buffer);
    const positions = new Float32Array(q.length);
    for (let i = 0; i < q.length; i++) {
      const axis = i % 3;
      positions[i] = m.min[axis] + (q[i] / 65535) * m.size[axis];
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    const raw = bytes(m.indices).buffer;
    const indices = m.index_bytes === 2 ? new Uint16Array(raw) : new Uint32Array(raw);
    geometry.setIndex(new THREE.BufferAttribute(indices, 1));
    const materials = m.groups.map((g, i) => {
      geometry.addGroup(g.start, g.count, i);
      return new THREE.MeshLambertMaterial({
        color: new THREE.Color().setRGB(g.color[0], g.color[1], g.color[2]),
        flatShading: true,
        side: THREE.FrontSide,
        clippingPlanes: clipping,
        // Holes lie on the surface: push the surface back a little so that
        // their points win the depth test.
        polygonOffset: true,
        polygonOffsetFactor: 1,
        polygonOffsetUnits: 1,
      });
    });
    geometry.computeBoundingSphere();
    return new THREE.Mesh(geometry, materials);
  }

  // One probe set: the probe spheres (an instanced mesh; its instance ids
  // index `records`) and the hole points.
  function buildSet(THREE, data, set, radius, clipping) {
    const records = floats(set.data);
    const n = set.shown;
    const sphere = new THREE.SphereGeometry(radius, 16, 12);
    const probes = new THREE.InstancedMesh(
      sphere,
      new THREE.MeshBasicMaterial({ clippingPlanes: clipping }),
      Math.max(n, 1),
    );
    probes.count = n;
    const at = new THREE.Matrix4();
    for (let i = 0; i < n; i++) {
      const r = i * data.record;
      at.makeTranslation(records[r + 1], records[r + 2], records[r + 3]);
      probes.setMatrixAt(i, at);
      probes.setColorAt(i, clearanceColour(THREE, data.colours, records[r + 4]));
    }
    probes.instanceMatrix.needsUpdate = true;
    if (probes.instanceColor) probes.instanceColor.needsUpdate = true;
    probes.computeBoundingSphere();
    const holeGeometry = new THREE.BufferGeometry();
    holeGeometry.setAttribute('position', new THREE.BufferAttribute(floats(set.hole_data), 3));
    const holes = new THREE.Points(
      holeGeometry,
      new THREE.PointsMaterial({
        color: srgb(THREE, data.colours.hole),
        size: 5,
        sizeAttenuation: false,
        clippingPlanes: clipping,
      }),
    );
    return { set, records, probes, holes };
  }

  // The figures of probe `i` of a set, for the info box.
  function describe(data, built, i) {
    const r = i * data.record;
    const v = built.records;
    const o = data.origin;
    const f = (x) => (Math.abs(x) >= 1000 || (x !== 0 && Math.abs(x) < 0.01) ? x.toExponential(3) : x.toFixed(3));
    const world = [0, 1, 2].map((k) => f(o[k] + v[r + 1 + k]));
    const c = v[r + 4];
    const clearance = Number.isNaN(c) ? 'outside the SDF grid' : f(c) + (c < 0 ? ' (in solid)' : '');
    const lines = [
      'probe ' + v[r] + ' of ' + built.set.name,
      'world (' + world.join(', ') + ')',
      'clearance ' + clearance,
    ];
    if (Number.isNaN(v[r + 5])) {
      lines.push('listed by no SVO leaf');
    } else {
      const size = [0, 1, 2].map((k) => f(v[r + 8 + k] - v[r + 5 + k]));
      lines.push('influence box ' + size.join(' × ') + ' (SVO leaf cells listing it: ' + v[r + 11] + ', first in ' + v[r + 12] + ')');
    }
    return lines.join('\n');
  }

  // The share of (up to 32 of) a set's probes that the mesh hides from the
  // camera: a ray from the camera meets a triangle before the probe.
  function hiddenShare(THREE, mesh, camera, built, record) {
    const n = built.set.shown;
    if (n === 0) return 0;
    const step = Math.max(1, Math.ceil(n / 32));
    const ray = new THREE.Raycaster();
    const eye = camera.position;
    let hidden = 0;
    let tried = 0;
    for (let i = 0; i < n; i += step) {
      const r = i * record;
      const p = new THREE.Vector3(built.records[r + 1], built.records[r + 2], built.records[r + 3]);
      const d = p.clone().sub(eye);
      const far = d.length();
      ray.set(eye, d.normalize());
      ray.far = far * 0.999;
      if (ray.intersectObject(mesh, false).length > 0) hidden++;
      tried++;
    }
    return hidden / tried;
  }

  function start(THREE, OrbitControls, data) {
    const canvas = $('v3-canvas');
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.localClippingEnabled = true;
    const scene = new THREE.Scene();
    scene.background = srgb(THREE, data.colours.background);

    const [dmin, dmax] = data.domain.map((p) => new THREE.Vector3(p[0], p[1], p[2]));
    const bounds = new THREE.Box3(
      new THREE.Vector3(...data.mesh.min),
      new THREE.Vector3(...data.mesh.min.map((v, k) => v + data.mesh.size[k])),
    ).union(new THREE.Box3(dmin, dmax));
    const centre = bounds.getCenter(new THREE.Vector3());
    const diagonal = Math.max(bounds.getSize(new THREE.Vector3()).length(), 1e-6);

    // "cut above": one horizontal plane clipping the mesh, probes and holes.
    const cut = new THREE.Plane(new THREE.Vector3(0, -1, 0), bounds.max.y + diagonal);
    const clipping = [cut];

    const mesh = buildMesh(THREE, data.mesh, clipping);
    scene.add(mesh);
    scene.add(new THREE.Box3Helper(new THREE.Box3(dmin, dmax), srgb(THREE, data.colours.domain)));
    const influence = new THREE.Box3Helper(new THREE.Box3(), srgb(THREE, data.colours.box_));
    influence.visible = false;
    scene.add(influence);

    scene.add(new THREE.AmbientLight(0xffffff, 1.2));
    const camera = new THREE.PerspectiveCamera(45, 1, diagonal / 2000, diagonal * 20);
    // A headlight, so that whatever faces the viewer is lit.
    const headlight = new THREE.DirectionalLight(0xffffff, 1.6);
    headlight.position.set(0.3, 0.5, 1);
    camera.add(headlight);
    scene.add(camera);

    const radius = diagonal * 0.009;
    const sets = data.sets.map((s) => buildSet(THREE, data, s, radius, clipping));
    let current = null;

    const controls = new OrbitControls(camera, canvas);
    controls.enableDamping = false;
    function home() {
      const direction = new THREE.Vector3(0.55, 0.75, 1.0).normalize();
      camera.position.copy(centre).addScaledVector(direction, diagonal * 1.3);
      controls.target.copy(centre);
      controls.update();
    }

    function render() {
      renderer.render(scene, camera);
    }

    function resize() {
      const w = Math.max(canvas.clientWidth, 1);
      const h = Math.max(canvas.clientHeight, 1);
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      render();
    }

    function show(index) {
      if (current) scene.remove(current.probes, current.holes);
      current = sets[index];
      scene.add(current.probes, current.holes);
      current.holes.visible = $('v3-holes').checked;
      influence.visible = false;
      const s = current.set;
      const probes = s.shown < s.probes ? s.shown + ' of its ' + s.probes + ' probes (every ' + Math.ceil(s.probes / s.shown) + 'th)' : 'all ' + s.probes + ' probes';
      const holes = s.holes_shown < s.holes ? s.holes_shown + ' of its ' + s.holes + ' coverage holes (a sample)' : 'all ' + s.holes + ' coverage holes';
      $('v3-note').textContent = s.name + ': ' + probes + ' and ' + holes + ' are drawn.';
      $('v3-info').textContent = 'Hover a probe.';
      render();
    }

    // Hover: the probe under the pointer, its box and figures.
    const raycaster = new THREE.Raycaster();
    const pointer = new THREE.Vector2();
    let hovered = -1;
    canvas.addEventListener('pointermove', (event) => {
      const rect = canvas.getBoundingClientRect();
      pointer.set(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
      raycaster.setFromCamera(pointer, camera);
      const hit = raycaster.intersectObject(current.probes, false)[0];
      const id = hit ? hit.instanceId : -1;
      if (id === hovered) return;
      hovered = id;
      if (id < 0) {
        influence.visible = false;
        $('v3-info').textContent = 'Hover a probe.';
      } else {
        const r = id * data.record;
        const v = current.records;
        influence.visible = !Number.isNaN(v[r + 5]);
        if (influence.visible) {
          influence.box.min.set(v[r + 5], v[r + 6], v[r + 7]);
          influence.box.max.set(v[r + 8], v[r + 9], v[r + 10]);
        }
        $('v3-info').textContent = describe(data, current, id);
      }
      render();
    });

    // The controls of the bar.
    controls.addEventListener('change', render);
    $('v3-mesh').addEventListener('change', (e) => {
      mesh.visible = e.target.checked;
      render();
    });
    $('v3-holes').addEventListener('change', (e) => {
      current.holes.visible = e.target.checked;
      render();
    });
    const xray = $('v3-xray');
    function setXray(on) {
      xray.checked = on;
      for (const m of mesh.material) {
        m.transparent = on;
        m.opacity = on ? 0.25 : 1;
        m.depthWrite = !on;
        m.needsUpdate = true;
      }
    }
    xray.addEventListener('change', (e) => {
      setXray(e.target.checked);
      render();
    });
    $('v3-backfaces').addEventListener('change', (e) => {
      for (const m of mesh.material) {
        m.side = e.target.checked ? THREE.DoubleSide : THREE.FrontSide;
        m.needsUpdate = true;
      }
      render();
    });
    $('v3-cut').addEventListener('input', (e) => {
      const t = Number(e.target.value) / 1000;
      // At the top of the range nothing is cut.
      cut.constant = t >= 1 ? bounds.max.y + diagonal : bounds.min.y + t * (bounds.max.y - bounds.min.y);
      render();
    });
    $('v3-reset').addEventListener('click', () => {
      home();
      render();
    });
    const selector = $('v3-set');
    if (selector) selector.addEventListener('change', (e) => show(Number(e.target.value)));
    window.addEventListener('resize', resize);

    home();
    // A building modelled from outside (its facade facing out) hides its
    // probes from any viewpoint outside: start in x-ray then.
    if (hiddenShare(THREE, mesh, camera, sets[0], data.record) > 0.5) {
      setXray(true);
      $('v3-xray-note').textContent = 'X-ray is on because the scene hides most probes from this viewpoint.';
    }
    show(0);
    resize();
    const drawn = renderer.info.render.triangles;
    if (!(drawn > 0)) throw new Error('view3d: the first frame drew no triangle');
    const m = data.mesh;
    setStatus(
      'drawn',
      '3D view drawn: ' + m.shown + ' triangles' + (m.shown < m.triangles ? ' (of ' + m.triangles + ')' : '') + ', ' + sets.length + ' probe set(s).',
    );
    status.dataset.triangles = String(drawn);
  }

  async function main() {
    const data = JSON.parse($('v3-data').textContent);
    const { THREE, OrbitControls } = await loadThree();
    start(THREE, OrbitControls, data);
  }

  main().catch((error) => {
    setStatus('failed', 'The 3D view failed: ' + error.message);
    console.error('view3d:', error);
  });
})();
