// pomc view: a layered RGB-D panorama in the browser (three.js, bundled). The scene is pomc's own
// whole-scene export (scene.glb: one node per layer in painter's order, unlit sRGB textures, the sky
// on a dome); pano.json gives the centre, the freedom radius and the frames. State is kept in POMC
// world coordinates (Z up) and converted to glTF's Y up for drawing. See docs/viewer.md.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { VRButton } from 'three/addons/webxr/VRButton.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const HOLE_COLOUR = new THREE.Color(1, 0, 1);
const MOVE_SPEED = 0.6; // metres per second (scaled by the freedom radius below)

function vec3Param(name) {
  const v = params.get(name);
  if (v === null) return null;
  const p = v.split(',').map(Number);
  if (p.length !== 3 || p.some((x) => !Number.isFinite(x))) throw new Error(`URL parameter ${name}=${v}: expected x,y,z`);
  return new THREE.Vector3(p[0], p[1], p[2]);
}

function fail(message) {
  const s = $('status');
  s.textContent = message;
  s.className = 'error';
  s.style.display = '';
  window.pomcError = message;
  console.error(message);
}

// The layer's colour is sampled where the fragment's direction from the panorama centre meets the
// canvas, as `pomc render --method mesh` does, not at interpolated texture coordinates (which bend
// the texture across a large triangle). The glb's TEXCOORD_1 (uv1) holds each vertex's canvas
// coordinates; the texture is a translated crop of the canvas, so the exact canvas offset from the
// interpolated one moves the cropped coordinates by the same number of pixels. Offsets beyond a few
// pixels (triangles at a pole, across cube faces) keep the interpolated coordinates.
const SAMPLE_GLSL = `
uniform mat4 pomcGlToLocal;
uniform vec2 pomcCanvas;
uniform vec2 pomcTex;
uniform int pomcCube;
uniform vec3 pomcFaceC[6];
uniform vec3 pomcFaceR[6];
uniform vec3 pomcFaceD[6];
uniform vec2 pomcFaceSlot[6];
varying vec3 pomcPos;
varying vec2 pomcCanvasUv;
vec2 pomcUvOf(vec3 d) {
  if (pomcCube == 0) {
    float phi = atan(d.y, d.x);
    if (phi < 0.0) phi += 6.283185307179586;
    return vec2(phi / 6.283185307179586, atan(length(d.xy), d.z) / 3.141592653589793);
  }
  int f = 0;
  float best = -2.0;
  for (int i = 0; i < 6; i++) { float c = dot(d, pomcFaceC[i]); if (c > best) { best = c; f = i; } }
  vec2 st = vec2(dot(d, pomcFaceR[f]), dot(d, pomcFaceD[f])) / best;
  return vec2((pomcFaceSlot[f].x + (st.x + 1.0) * 0.5) / 3.0, (pomcFaceSlot[f].y + (st.y + 1.0) * 0.5) / 2.0);
}
`;
function sampleByDirection(material, meta, mapping, glToLocal) {
  const cube = mapping.kind === 'cube3x2';
  const faces = cube ? mapping.faces : [];
  const v3 = (key) => (cube ? faces.map((f) => new THREE.Vector3(...f[key])) : Array.from({ length: 6 }, () => new THREE.Vector3()));
  const img = material.map.image;
  material.onBeforeCompile = (shader) => {
    Object.assign(shader.uniforms, {
      pomcGlToLocal: { value: glToLocal },
      pomcCanvas: { value: new THREE.Vector2(meta.width, meta.height) },
      pomcTex: { value: new THREE.Vector2(img.width, img.height) },
      pomcCube: { value: cube ? 1 : 0 },
      pomcFaceC: { value: v3('centre') },
      pomcFaceR: { value: v3('right') },
      pomcFaceD: { value: v3('down') },
      pomcFaceSlot: { value: cube ? faces.map((f) => new THREE.Vector2(...f.slot)) : Array.from({ length: 6 }, () => new THREE.Vector2()) },
    });
    shader.vertexShader = shader.vertexShader
      .replace('#include <common>', '#include <common>\n#ifndef USE_UV1\nattribute vec2 uv1;\n#endif\nvarying vec3 pomcPos;\nvarying vec2 pomcCanvasUv;')
      .replace('#include <begin_vertex>', '#include <begin_vertex>\npomcPos = position;\npomcCanvasUv = uv1;');
    shader.fragmentShader = shader.fragmentShader
      .replace('#include <common>', `#include <common>\n${SAMPLE_GLSL}`)
      .replace('#include <map_fragment>', `
  vec2 pomcUv = vMapUv;
  vec2 pomcDelta = pomcUvOf(normalize((pomcGlToLocal * vec4(pomcPos, 1.0)).xyz)) - pomcCanvasUv;
  if (pomcCube == 0) pomcDelta.x -= floor(pomcDelta.x + 0.5);
  vec2 pomcPx = pomcDelta * pomcCanvas;
  if (max(abs(pomcPx.x), abs(pomcPx.y)) < 8.0) pomcUv += pomcPx / pomcTex;
  diffuseColor *= texture2D(map, pomcUv);`);
  };
  material.needsUpdate = true;
}

async function main() {
  const info = await (await fetch('./pano.json')).json();
  document.title = `${info.title} — pomc view`;
  $('title').textContent = info.title;

  const toGl = new THREE.Matrix4().fromArray(info.world_to_gltf);
  const localToWorld = new THREE.Matrix4().fromArray(info.local_to_world);
  const worldToLocal = localToWorld.clone().invert();
  const centre = new THREE.Vector3(...info.centre);
  const radius = info.freedom_radius;
  const gl = (v) => v.clone().applyMatrix4(toGl);
  const glDir = (v) => v.clone().transformDirection(toGl);

  // Camera state (world frame).
  const size = params.get('size');
  let fixedSize = null;
  if (size !== null) {
    const m = /^(\d+)x(\d+)$/.exec(size);
    if (!m) throw new Error(`URL parameter size=${size}: expected WxH`);
    fixedSize = [Number(m[1]), Number(m[2])];
  }
  const hfov = params.has('fov') ? Number(params.get('fov')) : 90;
  if (!(hfov > 0 && hfov < 180)) throw new Error(`URL parameter fov=${params.get('fov')}: expected degrees in (0, 180)`);
  const up = (vec3Param('up') || new THREE.Vector3(0, 0, 1)).normalize();
  const start = {
    eye: vec3Param('eye') || centre.clone(),
    look: vec3Param('look'),
  };
  // By default, the centre of the panorama image (azimuth 180°, local −X) as `pomc render`;
  // +X is the image's left/right seam.
  if (!start.look) start.look = start.eye.clone().add(new THREE.Vector3(-1, 0, 0).transformDirection(localToWorld));
  const state = { eye: new THREE.Vector3(), yaw: 0, pitch: 0 };
  // A frame around `up`: forward reference and side.
  const ref = Math.abs(up.y) < 0.9 ? new THREE.Vector3(0, 1, 0) : new THREE.Vector3(1, 0, 0);
  const fwd0 = ref.clone().sub(up.clone().multiplyScalar(ref.dot(up))).normalize();
  const side0 = new THREE.Vector3().crossVectors(fwd0, up);
  const direction = () => {
    const c = Math.cos(state.pitch);
    return fwd0.clone().multiplyScalar(c * Math.cos(state.yaw))
      .add(side0.clone().multiplyScalar(c * Math.sin(state.yaw)))
      .add(up.clone().multiplyScalar(Math.sin(state.pitch)));
  };
  function reset() {
    state.eye.copy(start.eye);
    const d = start.look.clone().sub(start.eye).normalize();
    state.pitch = Math.asin(Math.max(-1, Math.min(1, d.dot(up))));
    state.yaw = Math.atan2(d.dot(side0), d.dot(fwd0));
    // The exact look-at of the URL until the user moves (no round trip through yaw and pitch).
    state.exact = start.look.clone();
  }
  const localDistance = (eye) => eye.clone().applyMatrix4(worldToLocal).length();
  function clampEye(eye) {
    const local = eye.clone().applyMatrix4(worldToLocal);
    if (local.length() > radius) local.multiplyScalar(radius / local.length());
    return local.applyMatrix4(localToWorld);
  }

  // Renderer.
  const renderer = new THREE.WebGLRenderer({ antialias: false, logarithmicDepthBuffer: true, preserveDrawingBuffer: true });
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  renderer.setPixelRatio(fixedSize ? 1 : window.devicePixelRatio);
  document.body.appendChild(renderer.domElement);
  renderer.domElement.tabIndex = 0;

  const extent = Math.max(info.extent, radius, 1e-3);
  const far = (info.sky_radius || 0) * 1.05 + 2 * extent + 2 * radius;
  const camera = new THREE.PerspectiveCamera(60, 1, Math.max(1e-3, extent * 1e-6), far);
  const rig = new THREE.Group();
  rig.add(camera);
  const scene = new THREE.Scene();
  scene.add(rig);

  const gltf = await new GLTFLoader().loadAsync(`./${info.scene}`);
  const layerNodes = [];
  const domes = [];
  gltf.scene.traverse((o) => {
    if (o.userData && o.userData.layer !== undefined) layerNodes.push(o);
  });
  const glToLocal = worldToLocal.clone().multiply(toGl.clone().invert());
  layerNodes.forEach((node, k) => {
    const sky = node.userData.sky_radius !== undefined;
    const meta = info.layers.find((l) => l.index === node.userData.layer && l.sky === sky);
    node.traverse((m) => {
      if (!m.isMesh) return;
      if (meta && m.geometry.attributes.uv1 && m.material.map) sampleByDirection(m.material, meta, info.mapping, glToLocal);
      m.frustumCulled = false;
      // Painter's order for equal depths (later layers win ties, as in `pomc render`).
      m.renderOrder = sky ? -1 : k;
      if (sky) {
        // Infinitely far: the dome follows the eye, drawn behind everything.
        m.material.depthTest = false;
        m.material.depthWrite = false;
      }
    });
    if (sky) domes.push(node);
  });
  scene.add(gltf.scene);

  // Layer toggles, one per manifest layer (its surface and its sky dome together).
  const layersBox = $('layers');
  const byLayer = new Map();
  for (const node of layerNodes) {
    const k = node.userData.layer;
    if (!byLayer.has(k)) byLayer.set(k, []);
    byLayer.get(k).push(node);
  }
  for (const [k, nodes] of byLayer) {
    const metas = info.layers.filter((l) => l.index === k);
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = true;
    box.dataset.layer = k;
    box.addEventListener('change', () => { nodes.forEach((n) => { n.visible = box.checked; }); redraw(); });
    const name = (metas.find((l) => !l.sky) || metas[0] || {}).name || nodes[0].name;
    label.append(box, ` ${name}${metas.some((l) => l.sky) ? ' (sky)' : ''}`);
    label.title = `layer ${k}: ${metas.reduce((a, l) => a + l.triangles, 0)} triangles`;
    layersBox.appendChild(label);
  }
  const only = params.get('layers');
  if (only !== null) {
    // `layers=` (empty) hides every layer.
    const keep = new Set(only.split(',').filter((k) => k.trim() !== '').map(Number));
    layerNodes.forEach((n) => { n.visible = keep.has(n.userData.layer); });
    layersBox.querySelectorAll('input').forEach((b) => { b.checked = keep.has(Number(b.dataset.layer)); });
  }
  const holes = $('holes');
  holes.checked = params.get('holes') === '1';
  holes.addEventListener('change', redraw);
  $('reset').addEventListener('click', () => { reset(); redraw(); });

  function place() {
    const eyeGl = gl(state.eye);
    const look = state.exact || state.eye.clone().add(direction());
    if (renderer.xr.isPresenting) {
      rig.position.copy(eyeGl);
    } else {
      rig.position.set(0, 0, 0);
      camera.position.copy(eyeGl);
      camera.up.copy(glDir(up));
      camera.lookAt(gl(look));
    }
    for (const d of domes) d.position.copy(eyeGl).sub(gl(centre));
    const dist = localDistance(state.eye);
    const r = $('radius');
    r.classList.toggle('outside', dist > radius * (1 + 1e-9));
    r.querySelector('.text').textContent =
      `${dist.toFixed(2)} m from the centre (freedom radius ${radius.toFixed(2)} m)` +
      (dist > radius * (1 + 1e-9) ? ': outside, holes expected' : '');
    r.querySelector('.fill').style.width = `${Math.min(100, (100 * dist) / radius)}%`;
  }
  function resize() {
    const [w, h] = fixedSize || [window.innerWidth, window.innerHeight];
    renderer.setSize(w, h, !fixedSize);
    camera.aspect = w / h;
    // Horizontal field of view, as `pomc render --fov`.
    camera.fov = THREE.MathUtils.radToDeg(2 * Math.atan(Math.tan(THREE.MathUtils.degToRad(hfov) / 2) * (h / w)));
    camera.updateProjectionMatrix();
  }
  let dirty = true;
  function redraw() { dirty = true; }

  // Controls: drag to look, keys and wheel to move, pinch on touch screens.
  const keys = new Set();
  const pointers = new Map();
  let pinch = null;
  const canvas = renderer.domElement;
  const radPerPixel = () => THREE.MathUtils.degToRad(hfov) / canvas.clientWidth;
  function move(forward, right, lift) {
    const d = direction();
    const flat = d.clone().sub(up.clone().multiplyScalar(d.dot(up)));
    if (flat.lengthSq() < 1e-12) flat.copy(fwd0);
    flat.normalize();
    const side = new THREE.Vector3().crossVectors(flat, up);
    const step = flat.multiplyScalar(forward).add(side.multiplyScalar(right)).add(up.clone().multiplyScalar(lift));
    state.exact = null;
    state.eye = clampEye(state.eye.clone().add(step));
    redraw();
  }
  canvas.addEventListener('pointerdown', (e) => {
    canvas.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    canvas.focus();
  });
  canvas.addEventListener('pointermove', (e) => {
    const p = pointers.get(e.pointerId);
    if (!p) return;
    if (pointers.size === 1) {
      state.exact = null;
      state.yaw -= (e.clientX - p.x) * radPerPixel();
      state.pitch = Math.max(-1.55, Math.min(1.55, state.pitch + (e.clientY - p.y) * radPerPixel()));
      redraw();
    }
    p.x = e.clientX;
    p.y = e.clientY;
    if (pointers.size === 2) {
      const [a, b] = [...pointers.values()];
      const d = Math.hypot(a.x - b.x, a.y - b.y);
      if (pinch !== null) move(((d - pinch) / canvas.clientWidth) * radius, 0, 0);
      pinch = d;
    }
  });
  const release = (e) => { pointers.delete(e.pointerId); pinch = null; };
  canvas.addEventListener('pointerup', release);
  canvas.addEventListener('pointercancel', release);
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); move(-Math.sign(e.deltaY) * 0.05 * radius, 0, 0); }, { passive: false });
  window.addEventListener('keydown', (e) => {
    if (e.key === 'r' || e.key === 'R') { reset(); redraw(); return; }
    keys.add(e.key.toLowerCase());
  });
  window.addEventListener('keyup', (e) => keys.delete(e.key.toLowerCase()));
  window.addEventListener('blur', () => keys.clear());
  window.addEventListener('resize', () => { resize(); redraw(); });

  // "Enter VR" only where the browser offers immersive sessions.
  if ('xr' in navigator && (await navigator.xr.isSessionSupported('immersive-vr').catch(() => false))) {
    renderer.xr.enabled = true;
    renderer.xr.setReferenceSpaceType('local');
    document.body.appendChild(VRButton.createButton(renderer));
    renderer.xr.addEventListener('sessionstart', redraw);
    renderer.xr.addEventListener('sessionend', redraw);
  }

  // For tests and scripts: the camera in the world frame and its distance from the centre in the
  // panorama frame (where the freedom radius is).
  window.pomcCamera = () => ({
    eye: state.eye.toArray(),
    direction: (state.exact ? state.exact.clone().sub(state.eye).normalize() : direction()).toArray(),
    distance: localDistance(state.eye),
    freedomRadius: radius,
  });

  reset();
  resize();
  let last = performance.now();
  let ready = false;
  renderer.setAnimationLoop((now) => {
    const dt = Math.min(0.1, (now - last) / 1000);
    last = now;
    const speed = MOVE_SPEED * Math.max(radius, 0.1) * dt;
    const k = (...names) => (names.some((n) => keys.has(n)) ? 1 : 0);
    const f = k('w', 'arrowup') - k('s', 'arrowdown');
    const r = k('d', 'arrowright') - k('a', 'arrowleft');
    const l = k('e', 'pageup') - k('q', 'pagedown');
    if (f || r || l) move(f * speed, r * speed, l * speed);
    if (!dirty && !renderer.xr.isPresenting) return;
    dirty = false;
    place();
    renderer.setClearColor(holes.checked ? HOLE_COLOUR : 0x000000, 1);
    renderer.render(scene, camera);
    if (!ready) {
      ready = true;
      $('status').style.display = 'none';
      $('hud').classList.toggle('hidden', params.get('hud') === '0');
      // The frame just drawn is complete once the browser has presented it.
      requestAnimationFrame(() => { window.pomcReady = true; });
    }
  });
}

main().catch((e) => fail(`pomc view: ${e && e.message ? e.message : e}`));
