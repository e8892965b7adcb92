// corofem web demo: loads corofem_web.wasm (plain extern "C" exports, no
// imports), draws the body — its embedded surface smooth-shaded, or the
// tetrahedra's boundary flat-shaded — with WebGL 2 (gl.js) onto a 2D canvas
// that holds the ground, the shadow and the tool (Canvas 2D alone where
// WebGL 2 is missing), and turns mouse drags into the haptic tool's target
// (pull mode) or into a rigid sphere pressed on the body (probe mode).
//
// Coordinates: metres, z up. The camera orbits `cam.target`.

import { createRenderer } from './gl.js';

const $ = (id) => document.getElementById(id);
const canvas = $('canvas');
const ctx = canvas.getContext('2d');
// `?antialias=on|off` overrides the renderer's choice (see gl.js);
// `?renderer=2d` draws with Canvas 2D as where WebGL 2 is missing.
const query = new URLSearchParams(location.search);
const gl = query.get('renderer') === '2d' ? null : createRenderer(query.get('antialias') ?? 'auto');

// ---------------------------------------------------------------- notices
// A message over the view: why the page cannot run (`kind` 'error'), or
// what it runs without (`kind` 'warn'). `html` is the page's own text.
function notice(kind, title, html) {
  const n = $('notice');
  n.className = kind;
  n.innerHTML = `<h2>${title}</h2>${html}`;
  n.hidden = false;
}
const BUILD = 'Build it with <code>bash examples/web/build.sh</code> and serve <code>www/</code> ' +
  'over HTTP (<code>python3 -m http.server --directory examples/web/www</code>): see docs/web.md.';

// Fetches and compiles the module, or says on the page why it cannot: the
// file is missing (or the page was opened from disk), or it is not a valid
// WebAssembly module. A server that sends another MIME type than
// application/wasm still works (compiled from the bytes).
async function loadModule(url) {
  let response;
  try {
    response = await fetch(url);
  } catch (e) {
    const local = location.protocol === 'file:';
    throw { title: 'The simulation module could not be fetched',
      html: `<p><code>${url}</code> did not load (${e.message}).` +
        (local ? ' The page was opened as a file: browsers only fetch it over HTTP.' : '') + `</p><p>${BUILD}</p>` };
  }
  if (!response.ok) {
    throw { title: 'The simulation module is missing',
      html: `<p><code>${url}</code>: HTTP ${response.status} ${response.statusText}.</p><p>${BUILD}</p>` };
  }
  const bytes = await response.arrayBuffer();
  try {
    return await WebAssembly.instantiate(bytes, {});
  } catch (e) {
    throw { title: 'The simulation module is not valid WebAssembly',
      html: `<p><code>${url}</code> (${bytes.byteLength} bytes) did not compile: ${e.message}.</p>` +
        `<p>A partly written or stale build: ${BUILD}</p>` };
  }
}

// ---------------------------------------------------------------- module
let instance;
try {
  ({ instance } = await loadModule('corofem_web.wasm'));
} catch (e) {
  notice('error', e.title ?? 'The demo cannot start', e.html ?? `<p>${e}</p>`);
  window.demo = { ready: false, failed: e.title ?? String(e) };
  throw new Error(`corofem web demo: ${e.title ?? e}`);
}
if (!gl && query.get('renderer') !== '2d') {
  notice('warn', 'WebGL 2 is not available',
    '<p>This browser gives no WebGL 2 context (turned off, or no GPU driver): the demo draws ' +
    'with Canvas 2D instead, flat-shaded and slower on large meshes.</p>');
}
const x = instance.exports;
const f32 = (ptr, n) => new Float32Array(x.memory.buffer, ptr, n);
const u32 = (ptr, n) => new Uint32Array(x.memory.buffer, ptr, n);
// Views are made after the call that returns the address: a call that
// allocates may grow the memory, which detaches older views.
const message = () => {
  const ptr = x.cf_message_ptr(), len = x.cf_message_len();
  return new TextDecoder().decode(new Uint8Array(x.memory.buffer, ptr, len));
};

// ---------------------------------------------------------------- state
const state = {
  frames: 0,           // frames drawn
  steps: 0,            // steps taken since the body was loaded
  paused: false,
  msPerStep: 0,        // smoothed wasm time per step
  fps: 0,
  lastFrame: 0,
  stats: new Float32Array(16),
  body: null,          // { name, nodes, tets, tris: Uint32Array, fixedTris: Uint8Array, weight, embedded }
  file: null,          // { name, bytes } of the last mesh file loaded
  surfaceFile: null,   // { name, bytes } of the surface file embedded in the body, if any
  msSurface: 0,        // smoothed wasm time to move and shade the embedded surface
  drawn: null,         // what the last frame drew: { surfaceTriangles, tetTriangles, edges }
  pull: null,          // { plane point, normal } while dragging the body
  mode: 'pull',        // the mouse's tool: 'pull' (spring) or 'probe' (sphere)
  hover: null,         // [px, py], the cursor on the canvas (device pixels), when over it
  ghost: null,         // { centre, radius }: where the probe would touch, drawn while hovering
  press: null,         // { base, normal, dir, depth } while pressing the probe
  orbit: null,         // { x, y, yaw, pitch } while orbiting
  error: null,
};
const cam = { yaw: -1.2, pitch: 0.45, dist: 2.2, target: [0, 0, 0.3], fov: 40 * Math.PI / 180 };

// ---------------------------------------------------------------- controls
const dtMs = () => 2 ** Number($('dt').value);
const young = () => 10 ** Number($('young').value);
function fmtSi(v) {
  const e = Math.floor(Math.log10(v));
  return `${(v / 10 ** e).toFixed(1)}e${e}`;
}
// The probe's radius and press depth (m), friction coefficient.
const probeRadius = () => Number($('probe-r').value) / 100;
const probeDepth = () => Number($('probe-depth').value) / 100;
const probeMu = () => Number($('probe-mu').value);
const groundMu = () => Number($('ground-mu').value);
function showControls() {
  $('probe-r-out').textContent = `${$('probe-r').value} cm`;
  $('probe-depth-out').textContent = `${$('probe-depth').value} cm`;
  $('probe-mu-out').textContent = probeMu().toFixed(2);
  $('ground-mu-out').textContent = groundMu().toFixed(2);
  $('young-out').textContent = `${fmtSi(young())} Pa`;
  $('poisson-out').textContent = Number($('poisson').value).toFixed(2);
  $('cg-out').textContent = $('cg').value;
  $('dt-out').textContent = `${dtMs()} ms`;
  $('substeps-out').textContent = $('substeps').value;
}
function setStatus(text, isError = false) {
  $('status').textContent = text;
  $('status').className = isError ? 'error' : '';
  state.error = isError ? text : null;
}
function applyParams() {
  showControls();
  const r = x.cf_set_params(young(), Number($('poisson').value), Number($('method').value),
    dtMs() / 1000, Number($('cg').value), $('gravity').checked ? 1 : 0,
    Number($('preconditioner').value));
  if (r !== 0) setStatus(message(), true);
}
for (const id of ['young', 'poisson', 'cg', 'dt', 'method', 'gravity', 'preconditioner']) {
  $(id).addEventListener('input', applyParams);
}
$('substeps').addEventListener('input', showControls);
for (const id of ['probe-r', 'probe-depth']) $(id).addEventListener('input', showControls);
$('probe-mu').addEventListener('input', applyFriction);
$('ground-mu').addEventListener('input', applyFriction);
// Friction (Coulomb, static = kinetic): the probe's and the ground's.
function applyFriction() {
  showControls();
  if (x.cf_probe_friction(probeMu()) !== 0) setProbeStatus(message(), true);
  if (x.cf_ground_friction(groundMu()) !== 0) setStatus(message(), true);
}
function setProbeStatus(text, isError = false) {
  $('probe-status').textContent = text;
  $('probe-status').className = isError ? 'error' : '';
}
for (const id of ['mode-pull', 'mode-probe']) $(id).addEventListener('change', setMode);
// Pull: the spring tool; probe: the sphere. Switching lets go of either.
function setMode() {
  endDrag();
  state.mode = $('mode-probe').checked ? 'probe' : 'pull';
  const probe = state.mode === 'probe';
  $('probe-controls').className = probe ? '' : 'off';
  $('probe-hud').hidden = !probe;
  canvas.classList.toggle('probing', probe);
  $('hint').textContent = probe
    ? 'press the body to push the sphere in along the view · drag to slide it · wheel while pressing: deeper or shallower · drag elsewhere to orbit'
    : 'drag the body to pull it · drag elsewhere to orbit · wheel to zoom';
  setProbeStatus('');
}
$('reset').addEventListener('click', () => {
  endDrag();
  x.cf_reset();
  state.steps = 0;
  if (state.body) cam.target = [...state.body.centre];
});
$('pause').addEventListener('click', () => {
  state.paused = !state.paused;
  $('pause').textContent = state.paused ? 'Run' : 'Pause';
});
$('body').addEventListener('change', () => {
  const v = $('body').value;
  if (v === 'file') {
    if (state.file) loadFile(state.file);
    return;
  }
  // Each built-in body has a natural support: the beam is clamped.
  $('support').value = v === '1' ? '1' : '0';
  loadBody();
});
$('support').addEventListener('change', () => {
  if ($('support').value === '2' && $('gravity').checked) {
    $('gravity').checked = false; // a free body would only fall away
    applyParams();
  }
  // The same body again, held otherwise: its surface file too.
  const surface = state.surfaceFile;
  const ok = $('body').value === 'file' && state.file ? loadFile(state.file) : loadBody();
  if (ok && surface) loadSurface(surface);
});
$('file').addEventListener('change', async () => {
  const f = $('file').files[0];
  if (!f) return;
  loadFile({ name: f.name, bytes: new Uint8Array(await f.arrayBuffer()) });
  $('file').value = ''; // choosing the same file again loads it again
});
$('surface-file').addEventListener('change', async () => {
  const f = $('surface-file').files[0];
  if (!f) return;
  loadSurface({ name: f.name, bytes: new Uint8Array(await f.arrayBuffer()) });
  $('surface-file').value = '';
});
$('show-surface').addEventListener('change', showView);
$('show-edges').addEventListener('change', showView);

// ---------------------------------------------------------------- loading
function loadBody() {
  const b = Number($('body').value);
  if (x.cf_load_body(b, Number($('support').value)) !== 0) {
    setStatus(message(), true);
    return false;
  }
  afterLoad(['cube', 'beam', 'blob'][b]);
  setStatus('');
  return true;
}

// Copies `parts` (byte arrays) one after the other into the module's input
// buffer.
function input(...parts) {
  const len = parts.reduce((n, p) => n + p.length, 0);
  const ptr = x.cf_input(len);
  const buf = new Uint8Array(x.memory.buffer, ptr, len);
  let at = 0;
  for (const p of parts) { buf.set(p, at); at += p.length; }
}

function loadFile(file) {
  input(file.bytes);
  if (x.cf_load_input(Number($('support').value)) !== 0) {
    setStatus(`${file.name}: ${message()}`, true);
    return false;
  }
  state.file = file;
  let opt = $('body').querySelector('option[value=file]');
  if (!opt) {
    opt = document.createElement('option');
    opt.value = 'file';
    $('body').append(opt);
  }
  opt.textContent = `${file.name} (${x.cf_tet_count()} tets)`;
  $('body').value = 'file';
  afterLoad(file.name);
  const note = message();
  setStatus(`${file.name}: ${x.cf_tet_count()} tetrahedra, ${x.cf_node_count()} nodes. ${note}`);
  return true;
}

// A surface file (OBJ, STL) embedded in the body: the module reads it by its
// name's extension, places it as it placed the body's mesh and binds it.
// On error the body and the surface it had stay.
function loadSurface(file) {
  const name = new TextEncoder().encode(file.name);
  input(name, file.bytes);
  const failed = x.cf_load_surface_input(name.length) !== 0;
  const text = `${file.name}: ${message()}`;
  if (failed) {
    setSurfaceStatus(text, true);
    return false;
  }
  state.surfaceFile = file;
  afterEmbed();
  setSurfaceStatus(text);
  $('show-surface').checked = true;
  showView();
  return true;
}

function setSurfaceStatus(text, isError = false) {
  $('surface-status').textContent = text;
  $('surface-status').className = isError ? 'error' : '';
}

// The embedded surface the module holds now (none, the body's own, a file's).
function afterEmbed() {
  const nv = x.cf_embedded_vertex_count(), nt = x.cf_embedded_triangle_count();
  state.body.embedded = nv ? {
    vertexCount: nv,
    triangles: u32(x.cf_embedded_triangles_ptr(), 3 * nt).slice(),
    held: new Uint8Array(x.memory.buffer, x.cf_embedded_held_ptr(), nv).slice(),
  } : null;
  const e = state.body.embedded;
  if (e) {
    // Per triangle, for the Canvas 2D path: all three corners held.
    e.heldTris = new Uint8Array(nt);
    for (let t = 0; t < nt; t++) e.heldTris[t] = e.held[e.triangles[3 * t]] & e.held[e.triangles[3 * t + 1]] & e.held[e.triangles[3 * t + 2]];
  }
  gl?.setSurface(e);
  state.msSurface = 0;
  showView();
}

// Draw the embedded surface or the boundary; the checkbox is off and
// disabled when there is no surface.
function showView() {
  const has = Boolean(state.body?.embedded);
  $('show-surface').disabled = !has;
  if (!has) $('show-surface').checked = false;
  const b = state.body;
  if (!b) return;
  const e = b.embedded;
  const parts = [`${b.name}: ${b.nodes} nodes · ${b.tets} tets · ${b.tris.length / 3} faces`];
  if (e) parts.push(`surface ${e.vertexCount} vertices · ${e.triangles.length / 3} triangles`);
  $('counts').innerHTML = parts.map((p) => `<div>${p.replace(/&/g, '&amp;').replace(/</g, '&lt;')}</div>`).join('');
}

function afterLoad(name) {
  // A new body: nothing holds or presses it; the friction carries over.
  state.pull = state.press = null;
  canvas.classList.remove('pulling');
  applyFriction();
  const n = x.cf_node_count();
  const tris = u32(x.cf_surface_ptr(), 3 * x.cf_surface_count()).slice();
  const fixed = new Uint8Array(n);
  for (const i of u32(x.cf_fixed_ptr(), x.cf_fixed_count())) fixed[i] = 1;
  const fixedTris = new Uint8Array(tris.length / 3);
  for (let t = 0; t < fixedTris.length; t++) {
    fixedTris[t] = fixed[tris[3 * t]] & fixed[tris[3 * t + 1]] & fixed[tris[3 * t + 2]];
  }
  const p = f32(x.cf_positions_ptr(), 3 * n);
  // Volume by the divergence theorem, for the weight that scales the arrow.
  let vol = 0;
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let t = 0; t < tris.length; t += 3) {
    const a = 3 * tris[t], b = 3 * tris[t + 1], c = 3 * tris[t + 2];
    const n0 = (p[b + 1] - p[a + 1]) * (p[c + 2] - p[a + 2]) - (p[b + 2] - p[a + 2]) * (p[c + 1] - p[a + 1]);
    const n1 = (p[b + 2] - p[a + 2]) * (p[c] - p[a]) - (p[b] - p[a]) * (p[c + 2] - p[a + 2]);
    const n2 = (p[b] - p[a]) * (p[c + 1] - p[a + 1]) - (p[b + 1] - p[a + 1]) * (p[c] - p[a]);
    vol += (p[a] * n0 + p[a + 1] * n1 + p[a + 2] * n2) / 6;
  }
  for (let i = 0; i < 3 * n; i++) {
    lo[i % 3] = Math.min(lo[i % 3], p[i]);
    hi[i % 3] = Math.max(hi[i % 3], p[i]);
  }
  const size = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  // The clamp, drawn as a wall behind the fixed nodes.
  let wall = null;
  const fixedIdx = u32(x.cf_fixed_ptr(), x.cf_fixed_count());
  if (fixedIdx.length) {
    const wlo = [Infinity, Infinity, Infinity], whi = [-Infinity, -Infinity, -Infinity];
    for (const i of fixedIdx) {
      for (let k = 0; k < 3; k++) {
        wlo[k] = Math.min(wlo[k], p[3 * i + k]);
        whi[k] = Math.max(whi[k], p[3 * i + k]);
      }
    }
    const m = 0.6 * Math.max(whi[1] - wlo[1], whi[2] - wlo[2], 0.05);
    wall = [[wlo[0], wlo[1] - m, wlo[2] - m], [wlo[0], whi[1] + m, wlo[2] - m],
      [wlo[0], whi[1] + m, whi[2] + m], [wlo[0], wlo[1] - m, whi[2] + m]];
  }
  // The boundary's edges, each once, for the wireframe.
  const seen = new Set(), edges = [];
  for (let t = 0; t < tris.length; t += 3) {
    for (let k = 0; k < 3; k++) {
      const a = tris[t + k], b = tris[t + (k + 1) % 3];
      const key = Math.min(a, b) * n + Math.max(a, b);
      if (!seen.has(key)) { seen.add(key); edges.push(a, b); }
    }
  }
  state.body = {
    name, nodes: n, tets: x.cf_tet_count(), tris, fixedTris, fixed, edges: new Uint32Array(edges),
    weight: 1000 * vol * 9.81, size, wall, embedded: null,
  };
  state.steps = 0;
  state.stats.fill(0);
  state.body.centre = [0, 0, 0.5 * (lo[2] + hi[2])];
  cam.target = [...state.body.centre];
  cam.dist = 0.8 + 1.6 * size;
  gl?.setTets(n, tris, state.body.edges, fixed);
  // A new body drops the surface file of the last one; a built-in body
  // comes with its own smooth surface.
  state.surfaceFile = null;
  afterEmbed();
  $('show-surface').checked = Boolean(state.body.embedded);
  setSurfaceStatus(state.body.embedded
    ? `built-in smooth surface (${state.body.embedded.vertexCount} vertices); a file replaces it`
    : 'none: the tetrahedra\'s boundary is drawn');
}

// ---------------------------------------------------------------- camera
function camera() {
  const cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
  const eye = [
    cam.target[0] + cam.dist * cp * Math.cos(cam.yaw),
    cam.target[1] + cam.dist * cp * Math.sin(cam.yaw),
    cam.target[2] + cam.dist * sp,
  ];
  const f = norm(sub(cam.target, eye));
  const r = norm(cross(f, [0, 0, 1]));
  const u = cross(r, f);
  const focal = 0.5 * canvas.height / Math.tan(0.5 * cam.fov);
  return { eye, f, r, u, focal, cx: 0.5 * canvas.width, cy: 0.5 * canvas.height, light: LIGHT };
}
// The key light, fixed in the world: above, from −x −y.
const LIGHT = [-0.4, -0.5, 0.85].map((v, _, a) => v / Math.hypot(...a));
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(a[0], a[1], a[2]));

// World point to canvas pixels [x, y, depth]; depth ≤ 0 is behind the eye.
function project(c, p) {
  const d = sub(p, c.eye);
  const z = dot(d, c.f);
  return [c.cx + c.focal * dot(d, c.r) / z, c.cy - c.focal * dot(d, c.u) / z, z];
}
// Canvas pixel to a world ray from the eye.
function ray(c, px, py) {
  return norm(add(c.f, add(scale(c.r, (px - c.cx) / c.focal), scale(c.u, -(py - c.cy) / c.focal))));
}

// ---------------------------------------------------------------- mouse
const dpr = () => window.devicePixelRatio || 1;
function canvasPoint(e) {
  const rect = canvas.getBoundingClientRect();
  return [(e.clientX - rect.left) * dpr(), (e.clientY - rect.top) * dpr()];
}
canvas.addEventListener('pointerdown', (e) => {
  canvas.setPointerCapture(e.pointerId);
  const [px, py] = canvasPoint(e);
  const c = camera();
  const d = ray(c, px, py);
  if (state.mode === 'probe') {
    if (e.button === 0 && state.body && pressProbe(c, d)) return;
    state.orbit = { x: e.clientX, y: e.clientY, yaw: cam.yaw, pitch: cam.pitch };
    return;
  }
  const t = state.body ? x.cf_pick(...c.eye, ...d) : -1;
  if (e.button === 0 && t > 0) {
    const hit = add(c.eye, scale(d, t));
    if (x.cf_grab(...hit) > 0) {
      // Drag in the plane through the hit point facing the camera.
      state.pull = { point: hit, normal: c.f };
      canvas.classList.add('pulling');
      return;
    }
  }
  state.orbit = { x: e.clientX, y: e.clientY, yaw: cam.yaw, pitch: cam.pitch };
});
// Probe mode, the button goes down at the cursor's ray `d`: the sphere is
// made where it first touches the body coming along the ray (so that it
// never starts inside), and from the next frame on pressed along the ray to
// the press depth. Returns false when the ray's sphere misses the body.
function pressProbe(c, d) {
  const r = probeRadius();
  const t = x.cf_probe_cast(...c.eye, ...d, r);
  if (!(t > 0)) return false;
  const base = add(c.eye, scale(d, t));
  if (x.cf_probe_set(...base, r, ...d) !== 0) {
    setProbeStatus(message(), true);
    return false;
  }
  // Slid in the plane through the touch point facing the camera.
  state.press = { base, normal: c.f, dir: d, depth: 0 };
  state.ghost = null;
  setProbeStatus('');
  canvas.classList.add('pulling');
  return true;
}
// Each frame while pressing: the depth moves toward the press depth at
// 0.5 m/s of simulated time, and the probe is sent there; the module moves
// it in equal parts over the frame's steps.
function driveProbe(simSeconds) {
  const p = state.press;
  if (!p) return;
  const goal = probeDepth(), rate = 0.5 * simSeconds;
  p.depth += Math.max(-rate, Math.min(rate, goal - p.depth));
  if (x.cf_probe_set(...add(p.base, scale(p.dir, p.depth)), probeRadius(), ...p.dir) !== 0) {
    setProbeStatus(message(), true);
    endDrag();
  }
}
canvas.addEventListener('pointerleave', () => { state.hover = null; });
canvas.addEventListener('pointermove', (e) => {
  state.hover = canvasPoint(e);
  if (state.press) {
    const [px, py] = state.hover;
    const c = camera();
    const d = ray(c, px, py);
    const p = state.press;
    const den = dot(d, p.normal);
    if (Math.abs(den) < 1e-6) return;
    const t = dot(sub(p.base, c.eye), p.normal) / den;
    p.base = add(c.eye, scale(d, t));
  } else if (state.pull) {
    const [px, py] = canvasPoint(e);
    const c = camera();
    const d = ray(c, px, py);
    const den = dot(d, state.pull.normal);
    if (Math.abs(den) < 1e-6) return;
    const t = dot(sub(state.pull.point, c.eye), state.pull.normal) / den;
    x.cf_set_target(...add(c.eye, scale(d, t)));
  } else if (state.orbit) {
    cam.yaw = state.orbit.yaw - 0.008 * (e.clientX - state.orbit.x);
    cam.pitch = Math.max(-1.4, Math.min(1.5, state.orbit.pitch + 0.008 * (e.clientY - state.orbit.y)));
  }
});
function endDrag() {
  if (state.pull) x.cf_release();
  if (state.press) x.cf_probe_clear();
  state.pull = null;
  state.press = null;
  state.orbit = null;
  canvas.classList.remove('pulling');
}
canvas.addEventListener('pointerup', endDrag);
canvas.addEventListener('pointercancel', endDrag);
canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  if (state.press) {
    // While pressing, the wheel sets the press depth: forward deeper.
    const v = Number($('probe-depth').value) - 0.0025 * e.deltaY;
    $('probe-depth').value = String(Math.max(0, Math.min(12, v)));
    showControls();
    return;
  }
  cam.dist = Math.max(0.2, Math.min(20, cam.dist * Math.exp(0.001 * e.deltaY)));
}, { passive: false });

// ---------------------------------------------------------------- drawing
function resize() {
  const w = Math.round(canvas.clientWidth * dpr()), h = Math.round(canvas.clientHeight * dpr());
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
}

function drawGround(c) {
  if (c.eye[2] <= 0) return;
  const R = 1.2, n = 12; // lines every 0.1 m over [-1.2, 1.2]²
  ctx.lineWidth = 1 * dpr();
  for (const axes of [false, true]) {
    ctx.beginPath();
    for (let k = -n; k <= n; k++) {
      if ((k === 0) !== axes) continue;
      const v = k * R / n;
      segment(c, [v, -R, 0], [v, R, 0]);
      segment(c, [-R, v, 0], [R, v, 0]);
    }
    ctx.strokeStyle = axes ? 'rgba(255,255,255,0.22)' : 'rgba(255,255,255,0.09)';
    ctx.stroke();
  }
}
// Adds a world segment, clipped at the near plane, to the current path.
function segment(c, a, b) {
  const near = 0.05;
  const za = dot(sub(a, c.eye), c.f), zb = dot(sub(b, c.eye), c.f);
  if (za < near && zb < near) return;
  if (za < near) a = add(a, scale(sub(b, a), (near - za) / (zb - za)));
  else if (zb < near) b = add(b, scale(sub(a, b), (near - zb) / (za - zb)));
  const pa = project(c, a), pb = project(c, b);
  ctx.moveTo(pa[0], pa[1]);
  ctx.lineTo(pb[0], pb[1]);
}

function drawBody(c, p) {
  const b = state.body;
  // Shadow on the ground: the boundary's upward-facing triangles flattened
  // onto z = 0 (they cover the body's footprint with one winding), filled once.
  if (x.cf_support() !== 2 && c.eye[2] > 0) {
    ctx.beginPath();
    for (let t = 0; t < b.tris.length; t += 3) {
      const ia = 3 * b.tris[t], ib = 3 * b.tris[t + 1], ic = 3 * b.tris[t + 2];
      const nz = (p[ib] - p[ia]) * (p[ic + 1] - p[ia + 1]) - (p[ib + 1] - p[ia + 1]) * (p[ic] - p[ia]);
      if (nz <= 0) continue;
      for (let k = 0; k < 3; k++) {
        const i = 3 * b.tris[t + k];
        const q = project(c, [p[i], p[i + 1], 0]);
        if (k === 0) ctx.moveTo(q[0], q[1]); else ctx.lineTo(q[0], q[1]);
      }
      ctx.closePath();
    }
    ctx.fillStyle = 'rgba(0,0,0,0.28)';
    ctx.fill('nonzero');
  }
  if (b.wall && b.wall.every((q) => dot(sub(q, c.eye), c.f) > 0.05)) {
    ctx.beginPath();
    b.wall.forEach((q, k) => {
      const s = project(c, q);
      if (k === 0) ctx.moveTo(s[0], s[1]); else ctx.lineTo(s[0], s[1]);
    });
    ctx.closePath();
    ctx.fillStyle = 'rgba(150,156,166,0.55)';
    ctx.strokeStyle = 'rgba(210,215,222,0.8)';
    ctx.lineWidth = 1.5 * dpr();
    ctx.fill();
    ctx.stroke();
  }
  // The embedded surface moved to the body's shape and shaded, in the module.
  const e = $('show-surface').checked ? b.embedded : null;
  let skin = null;
  if (e) {
    const t0 = performance.now();
    x.cf_embedded_update();
    const ms = performance.now() - t0;
    state.msSurface = state.msSurface ? 0.95 * state.msSurface + 0.05 * ms : ms;
    skin = {
      positions: f32(x.cf_embedded_positions_ptr(), 3 * e.vertexCount),
      normals: f32(x.cf_embedded_normals_ptr(), 3 * e.vertexCount),
    };
  }
  const edges = $('show-edges').checked;
  const sphere = probeSphere();
  if (gl) {
    const rect = withSphere(c, screenRect(c, skin ? skin.positions : p), sphere);
    state.drawn = gl.draw(c, rect, p, skin, edges, sphere);
    ctx.drawImage(gl.canvas, rect.x, rect.y);
    return;
  }
  // Canvas 2D: flat-shaded triangles sorted far to near; the edges of the
  // boundary's front faces on top.
  state.drawn = { surfaceTriangles: 0, tetTriangles: 0, edges: 0 };
  if (skin) {
    fill2d(c, skin.positions, e.triangles, e.heldTris);
    state.drawn.surfaceTriangles = e.triangles.length / 3;
  } else {
    fill2d(c, p, b.tris, b.fixedTris);
    state.drawn.tetTriangles = b.tris.length / 3;
  }
  if (edges) {
    ctx.beginPath();
    for (let t = 0; t < b.tris.length; t += 3) {
      const v = [0, 1, 2].map((k) => { const i = 3 * b.tris[t + k]; return [p[i], p[i + 1], p[i + 2]]; });
      if (dot(cross(sub(v[1], v[0]), sub(v[2], v[0])), sub(c.eye, v[0])) <= 0) continue;
      const q = v.map((w) => project(c, w));
      if (q.some((w) => w[2] <= 0.01)) continue;
      ctx.moveTo(q[0][0], q[0][1]); ctx.lineTo(q[1][0], q[1][1]); ctx.lineTo(q[2][0], q[2][1]); ctx.closePath();
      state.drawn.edges += 1.5;
    }
    ctx.strokeStyle = 'rgba(238,245,255,0.75)';
    ctx.lineWidth = 1;
    ctx.stroke();
  }
  if (sphere) sphere2d(c, sphere);
}

// The sphere to draw: the probe where the last step left it, or, hovering
// in probe mode, where it would touch the body ({ centre, radius, ghost }).
function probeSphere() {
  if (x.cf_probe_state()) {
    const v = f32(x.cf_vec_ptr(), 8);
    return { centre: [v[0], v[1], v[2]], radius: v[3], ghost: false };
  }
  const g = state.ghost;
  return g ? { centre: g.centre, radius: g.radius, ghost: true } : null;
}
// Where the probe would touch the body along the ray under the cursor.
function updateGhost(c) {
  state.ghost = null;
  if (state.mode !== 'probe' || state.press || state.orbit || !state.hover || !state.body) return;
  const d = ray(c, ...state.hover);
  const r = probeRadius();
  const t = x.cf_probe_cast(...c.eye, ...d, r);
  if (t > 0) state.ghost = { centre: add(c.eye, scale(d, t)), radius: r };
}
// The rectangle `rect` grown to hold the sphere's outline.
function withSphere(c, rect, sphere) {
  if (!sphere) return rect;
  const q = project(c, sphere.centre);
  if (!(q[2] > 1.05 * sphere.radius)) return { x: 0, y: 0, w: canvas.width, h: canvas.height };
  // The outline's radius on screen, with a margin for its perspective.
  const s = 1.3 * c.focal * sphere.radius / (q[2] - sphere.radius) + 4;
  const x0 = Math.max(0, Math.min(rect.x, Math.floor(q[0] - s))), y0 = Math.max(0, Math.min(rect.y, Math.floor(q[1] - s)));
  const x1 = Math.min(canvas.width, Math.max(rect.x + rect.w, Math.ceil(q[0] + s)));
  const y1 = Math.min(canvas.height, Math.max(rect.y + rect.h, Math.ceil(q[1] + s)));
  return x1 > x0 && y1 > y0 ? { x: x0, y: y0, w: x1 - x0, h: y1 - y0 } : rect;
}
// Canvas 2D: the sphere as a shaded disc over the body.
function sphere2d(c, sphere) {
  const q = project(c, sphere.centre);
  if (!(q[2] > 0.05)) return;
  const rad = c.focal * sphere.radius / q[2];
  const g = ctx.createRadialGradient(q[0] - 0.35 * rad, q[1] - 0.4 * rad, 0.1 * rad, q[0], q[1], rad);
  g.addColorStop(0, '#f4f6f9');
  g.addColorStop(1, '#6d737c');
  ctx.globalAlpha = sphere.ghost ? 0.35 : 1;
  ctx.fillStyle = g;
  ctx.beginPath();
  ctx.arc(q[0], q[1], rad, 0, 2 * Math.PI);
  ctx.fill();
  ctx.globalAlpha = 1;
}

// The pixels the points `p` (x y z each) cover on the canvas, with a margin
// for lines; the whole canvas when one is near or behind the eye.
function screenRect(c, p) {
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (let i = 0; i < p.length; i += 3) {
    const q = project(c, [p[i], p[i + 1], p[i + 2]]);
    if (!(q[2] > 0.05)) return { x: 0, y: 0, w: canvas.width, h: canvas.height };
    x0 = Math.min(x0, q[0]); x1 = Math.max(x1, q[0]);
    y0 = Math.min(y0, q[1]); y1 = Math.max(y1, q[1]);
  }
  const m = 4;
  x0 = Math.max(0, Math.floor(x0) - m); y0 = Math.max(0, Math.floor(y0) - m);
  x1 = Math.min(canvas.width, Math.ceil(x1) + m); y1 = Math.min(canvas.height, Math.ceil(y1) + m);
  return x1 > x0 && y1 > y0 ? { x: x0, y: y0, w: x1 - x0, h: y1 - y0 } : { x: 0, y: 0, w: 1, h: 1 };
}

// Triangles `tris` of the points `p` (x y z each), front faces far to near,
// flat-shaded by the key light and a head light; `held` marks per triangle
// those drawn grey.
function fill2d(c, p, tris, held) {
  const n = p.length / 3;
  const sx = new Float32Array(n), sy = new Float32Array(n), sz = new Float32Array(n);
  for (let i = 0; i < n; i++) {
    const q = project(c, [p[3 * i], p[3 * i + 1], p[3 * i + 2]]);
    sx[i] = q[0]; sy[i] = q[1]; sz[i] = q[2];
  }
  const order = [];
  for (let t = 0, k = 0; t < tris.length; t += 3, k++) {
    const ia = 3 * tris[t], ib = 3 * tris[t + 1], ic = 3 * tris[t + 2];
    const a = [p[ia], p[ia + 1], p[ia + 2]];
    const nrm = cross(sub([p[ib], p[ib + 1], p[ib + 2]], a), sub([p[ic], p[ic + 1], p[ic + 2]], a));
    if (dot(nrm, sub(c.eye, a)) <= 0) continue;
    const za = sz[tris[t]], zb = sz[tris[t + 1]], zc = sz[tris[t + 2]];
    if (za <= 0.01 || zb <= 0.01 || zc <= 0.01) continue;
    order.push([za + zb + zc, k, nrm]);
  }
  order.sort((u, v) => v[0] - u[0]);
  ctx.lineJoin = 'round';
  ctx.lineWidth = 0.8;
  for (const [, k, nrm] of order) {
    const l = Math.hypot(nrm[0], nrm[1], nrm[2]) || 1;
    const ndl = dot(nrm, LIGHT) / l;
    const head = -dot(nrm, c.f) / l;
    const s = 0.3 + 0.62 * Math.max(0, ndl) + 0.12 * Math.max(0, head);
    const base = held[k] ? [120, 124, 132] : [86, 156, 214];
    const col = `rgb(${Math.min(255, base[0] * s) | 0},${Math.min(255, base[1] * s) | 0},${Math.min(255, base[2] * s) | 0})`;
    const i0 = tris[3 * k], i1 = tris[3 * k + 1], i2 = tris[3 * k + 2];
    ctx.beginPath();
    ctx.moveTo(sx[i0], sy[i0]);
    ctx.lineTo(sx[i1], sy[i1]);
    ctx.lineTo(sx[i2], sy[i2]);
    ctx.closePath();
    ctx.fillStyle = col;
    ctx.strokeStyle = col; // hides the seams between neighbouring fills
    ctx.fill();
    ctx.stroke();
  }
}

function drawTool(c, p) {
  if (!x.cf_grab_state()) return;
  const v = f32(x.cf_vec_ptr(), 6);
  const attach = [v[0], v[1], v[2]], target = [v[3], v[4], v[5]];
  const s = state.stats;
  const force = [s[3], s[4], s[5]];
  const mag = Math.hypot(...force);
  // Grabbed nodes.
  ctx.fillStyle = 'rgba(242,158,76,0.85)';
  const g = u32(x.cf_grabbed_ptr(), x.cf_grabbed_count());
  for (const i of g) {
    const q = project(c, [p[3 * i], p[3 * i + 1], p[3 * i + 2]]);
    if (q[2] <= 0.01) continue;
    ctx.beginPath();
    ctx.arc(q[0], q[1], 2 * dpr(), 0, 2 * Math.PI);
    ctx.fill();
  }
  // The spring, body to cursor.
  const pa = project(c, attach), pt = project(c, target);
  ctx.setLineDash([5 * dpr(), 4 * dpr()]);
  ctx.strokeStyle = 'rgba(255,255,255,0.7)';
  ctx.lineWidth = 1.5 * dpr();
  ctx.beginPath(); ctx.moveTo(pa[0], pa[1]); ctx.lineTo(pt[0], pt[1]); ctx.stroke();
  ctx.setLineDash([]);
  // The force on the tool, from the cursor.
  let tip = pt;
  if (mag > 1e-6) {
    tip = project(c, add(target, scale(force, arrowLength(mag) / mag)));
    arrow(pt, tip, '#f29e4c');
  }
  ctx.beginPath();
  ctx.arc(pt[0], pt[1], 4 * dpr(), 0, 2 * Math.PI);
  ctx.fillStyle = '#fff';
  ctx.fill();
  forceLabel(mag, tip);
}

// The arrow's length for a force of `mag` N (m): it grows with |F| and
// saturates at 0.4 body sizes, a few times the body's weight.
const arrowLength = (mag) => 0.4 * Math.max(0.3, state.body.size) * Math.tanh(0.05 + mag / Math.max(state.body.weight, 1e-3));

// The force the body exerts on the probe, from the sphere's surface on the
// side it points to (away from the body), and its size in newtons.
function drawProbe(c) {
  if (!x.cf_probe_state()) return;
  const v = f32(x.cf_vec_ptr(), 8);
  const centre = [v[0], v[1], v[2]], r = v[3], force = [v[4], v[5], v[6]];
  const mag = Math.hypot(...force);
  if (!(mag > 1e-6)) return;
  const u = scale(force, 1 / mag);
  const from = add(centre, scale(u, r));
  if (dot(sub(from, c.eye), c.f) < 0.05) return;
  const to = add(from, scale(u, arrowLength(mag)));
  const pf = project(c, from), tip = project(c, to);
  arrow(pf, tip, '#f29e4c');
  forceLabel(mag, tip);
}

function forceLabel(mag, tip) {
  const label = `${mag.toFixed(mag < 10 ? 2 : 1)} N`;
  const [lx, ly] = [tip[0] + 8 * dpr(), tip[1] - 6 * dpr()];
  ctx.font = `bold ${14 * dpr()}px system-ui, sans-serif`;
  ctx.lineJoin = 'round';
  ctx.lineWidth = 4 * dpr();
  ctx.strokeStyle = 'rgba(20,22,26,0.9)';
  ctx.strokeText(label, lx, ly);
  ctx.fillStyle = '#f29e4c';
  ctx.fillText(label, lx, ly);
}

function arrow(a, b, color) {
  const dx = b[0] - a[0], dy = b[1] - a[1];
  const l = Math.hypot(dx, dy);
  if (l < 1) return;
  const ux = dx / l, uy = dy / l, h = Math.min(14 * dpr(), 0.4 * l), w = 0.45 * h;
  ctx.strokeStyle = color;
  ctx.fillStyle = color;
  ctx.lineWidth = 3 * dpr();
  ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0] - ux * h, b[1] - uy * h); ctx.stroke();
  ctx.beginPath();
  ctx.moveTo(b[0], b[1]);
  ctx.lineTo(b[0] - ux * h - uy * w, b[1] - uy * h + ux * w);
  ctx.lineTo(b[0] - ux * h + uy * w, b[1] - uy * h - ux * w);
  ctx.closePath();
  ctx.fill();
}

function draw() {
  resize();
  const c = camera();
  const grad = ctx.createLinearGradient(0, 0, 0, canvas.height);
  grad.addColorStop(0, '#3a4250');
  grad.addColorStop(1, '#171a1f');
  ctx.fillStyle = grad;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!state.body) return;
  const p = f32(x.cf_positions_ptr(), 3 * state.body.nodes);
  if (x.cf_support() === 2) {
    // A free body drifts: the camera follows its centre.
    const m = [0, 0, 0];
    for (let i = 0; i < p.length; i++) m[i % 3] += p[i];
    const target = scale(m, 3 / p.length);
    if (target.every(Number.isFinite)) cam.target = add(scale(cam.target, 0.9), scale(target, 0.1));
  } else {
    drawGround(c);
  }
  updateGhost(c);
  drawBody(c, p);
  drawTool(c, p);
  drawProbe(c);
}

// ---------------------------------------------------------------- loop
function showStats() {
  const s = state.stats;
  $('ms-step').textContent = state.msPerStep.toFixed(3);
  $('ms-surface').textContent = state.drawn?.surfaceTriangles ? state.msSurface.toFixed(3) : '–';
  $('steps-frame').textContent = s[0] | 0;
  $('fps').textContent = state.fps.toFixed(0);
  $('sim-time').textContent = s[8].toFixed(2);
  $('inverted').textContent = s[1] | 0;
  $('inverted').className = s[1] > 0 ? 'bad' : '';
  $('force').textContent = Math.hypot(s[3], s[4], s[5]).toFixed(2);
  $('probe-force').textContent = Math.hypot(s[12], s[13], s[14]).toFixed(2);
  $('probe-contacts').textContent = s[11] | 0;
  if (s[15]) {
    setProbeStatus('The sphere would have started inside the body: it was moved out against the press direction, and presses in from there.');
  }
  $('angmom').textContent = s[9].toPrecision(3);
  if (s[7] && !state.error) {
    setStatus('A step diverged and was refused: lower the time step, raise the CG iterations or press Reset.', true);
    state.error = null; // keep trying; the message stays until the next status
  }
}

function frame(now) {
  try {
    if (state.body && !state.paused) {
      const n = Number($('substeps').value);
      driveProbe(n * dtMs() / 1000);
      const t0 = performance.now();
      const done = x.cf_step(n);
      const t1 = performance.now();
      state.stats.set(f32(x.cf_stats_ptr(), 16));
      if (done > 0) {
        const ms = (t1 - t0) / done;
        state.msPerStep = state.msPerStep ? 0.95 * state.msPerStep + 0.05 * ms : ms;
      }
      state.steps += done;
    }
    draw();
    if (state.lastFrame) {
      const fps = 1000 / Math.max(1e-3, now - state.lastFrame);
      state.fps = state.fps ? 0.95 * state.fps + 0.05 * fps : fps;
    }
    state.lastFrame = now;
    state.frames++;
    showStats();
  } catch (e) {
    setStatus(`The module stopped (${e.message}). Reload the page.`, true);
    throw e;
  }
  requestAnimationFrame(frame);
}

// ---------------------------------------------------------------- start
showControls();
applyParams();
setMode();
$('renderer').textContent = gl
  ? `WebGL 2${gl.antialias ? '' : ', no multisampling'}`
  : 'Canvas 2D (flat shading, sorted triangles)';
$('body').value = '1';
$('support').value = '1';
loadBody();
requestAnimationFrame(frame);

// For the browser test and the curious: state and helpers on window.
window.demo = {
  state,
  exports: x,
  positions: () => Array.from(f32(x.cf_positions_ptr(), 3 * state.body.nodes)),
  // The tetrahedra's boundary triangles (what picking hits).
  surface: () => Array.from(state.body.tris),
  renderer: gl ? 'webgl2' : '2d',
  eye: () => camera().eye,
  cam, // the orbit camera: { yaw, pitch, dist, target }
  // The probe as the module holds it ({ centre, radius, force, contacts }),
  // or null; and the press the mouse makes ({ dir, depth }), or null.
  probe: () => {
    if (!x.cf_probe_state()) return null;
    const v = Array.from(f32(x.cf_vec_ptr(), 8));
    return { centre: v.slice(0, 3), radius: v[3], force: v.slice(4, 7), contacts: v[7] };
  },
  press: () => (state.press ? { dir: [...state.press.dir], depth: state.press.depth } : null),
  draw,
  // Canvas point (CSS pixels, relative to the canvas) of a world point.
  screenOf: (p) => {
    const q = project(camera(), p);
    return [q[0] / dpr(), q[1] / dpr()];
  },
  // Milliseconds per step for `steps` steps of the current body, run in one
  // call (after `warmup` untimed steps); the state is then reset.
  bench: (steps = 400, warmup = 50) => {
    x.cf_step(warmup);
    const t0 = performance.now();
    const done = x.cf_step(steps);
    const ms = (performance.now() - t0) / done;
    x.cf_reset();
    return ms;
  },
  // Milliseconds per move-and-shade of the embedded surface (update_surface
  // and vertex_normals in the module), `count` calls after `warmup`, with
  // the body deformed by `steps` steps first; the state is then reset.
  benchSurface: (count = 400, warmup = 50, steps = 200) => {
    x.cf_step(steps);
    for (let i = 0; i < warmup; i++) x.cf_embedded_update();
    const t0 = performance.now();
    let done = 0;
    for (let i = 0; i < count; i++) done += x.cf_embedded_update();
    const ms = (performance.now() - t0) / Math.max(done, 1);
    x.cf_reset();
    return done ? ms : NaN;
  },
  ready: true,
};
