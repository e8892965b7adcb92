// The body in WebGL 2: the embedded surface smooth-shaded by its vertex
// normals (computed in the module), or the tetrahedra's boundary flat-shaded,
// the boundary's edges over either, and the probe's sphere. Drawn into an offscreen canvas that
// app.js copies onto its 2D canvas between the ground and the tool, so the
// page keeps one canvas. Returns null where WebGL 2 is missing (app.js then
// draws with Canvas 2D).

const VERTEX = `#version 300 es
uniform mat4 uViewProj;
// The probe's sphere: centre and radius (w > 0) scale the unit sphere.
uniform vec4 uSphere;
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in float aHeld;
out vec3 vPos;
out vec3 vNormal;
out float vHeld;
void main() {
  vec3 p = uSphere.w > 0.0 ? uSphere.xyz + uSphere.w * aPos : aPos;
  vPos = p;
  vNormal = aNormal;
  vHeld = aHeld;
  gl_Position = uViewProj * vec4(p, 1.0);
}`;

// uMode 0: smooth (interpolated vertex normals), 1: flat (the triangle's own
// normal, from screen derivatives), 2: plain colour (lines), 3: the probe's
// sphere, smooth in the colour uColor (its alpha: translucent while aiming). Lighting as the
// Canvas 2D path: a key light fixed in the world, a head light, ambient; the
// smooth surface adds a highlight. Back faces (seen from inside: an open or
// inside-out surface) are drawn in a warm colour so they stand out.
const FRAGMENT = `#version 300 es
precision highp float;
uniform int uMode;
uniform vec3 uEye;
uniform vec3 uLight;
uniform vec4 uColor;
in vec3 vPos;
in vec3 vNormal;
in float vHeld;
out vec4 outColor;
void main() {
  if (uMode == 2) {
    outColor = vec4(uColor.rgb * uColor.a, uColor.a);
    return;
  }
  vec3 v = normalize(uEye - vPos);
  vec3 n;
  if (uMode == 1) {
    n = normalize(cross(dFdx(vPos), dFdy(vPos)));
    if (dot(n, v) < 0.0) n = -n;
  } else {
    n = dot(vNormal, vNormal) > 1e-12 ? normalize(vNormal) : v;
    if (!gl_FrontFacing) n = -n;
  }
  vec3 base = vHeld > 0.5 ? vec3(120.0, 124.0, 132.0) / 255.0 : vec3(86.0, 156.0, 214.0) / 255.0;
  if (!gl_FrontFacing) base = vec3(214.0, 128.0, 86.0) / 255.0;
  if (uMode == 3) base = uColor.rgb;
  float s = 0.3 + 0.62 * max(0.0, dot(n, uLight)) + 0.12 * max(0.0, dot(n, v));
  vec3 c = min(base * s, vec3(1.0));
  if (uMode == 0 || uMode == 3) {
    vec3 h = normalize(uLight + v);
    c += (uMode == 3 ? 0.5 : 0.22) * pow(max(0.0, dot(n, h)), 48.0);
  }
  float a = uMode == 3 ? uColor.a : 1.0;
  outColor = vec4(min(c, vec3(1.0)) * a, a);
}`;

function compile(gl, type, src) {
  const s = gl.createShader(type);
  gl.shaderSource(s, src);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}

// Multisampling on a software renderer (SwiftShader, llvmpipe: no GPU) costs
// a third of the frame rate, on a GPU next to nothing: `antialias` 'auto'
// leaves it out there only.
function softwareRenderer() {
  const probe = document.createElement('canvas').getContext('webgl2');
  if (!probe) return false;
  const info = probe.getExtension('WEBGL_debug_renderer_info');
  const name = String(probe.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : probe.RENDERER));
  probe.getExtension('WEBGL_lose_context')?.loseContext();
  return /swiftshader|llvmpipe|softpipe|software/i.test(name);
}

// `antialias`: 'on', 'off' or 'auto'.
export function createRenderer(antialias = 'auto') {
  const canvas = document.createElement('canvas');
  const msaa = antialias === 'on' || (antialias === 'auto' && !softwareRenderer());
  const gl = canvas.getContext('webgl2', { antialias: msaa, premultipliedAlpha: true, alpha: true });
  if (!gl) return null;
  let program;
  try {
    program = gl.createProgram();
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
  } catch (e) {
    console.warn('WebGL 2 shaders failed; drawing with Canvas 2D:', e.message);
    return null;
  }
  const loc = (name) => gl.getUniformLocation(program, name);
  const u = {
    viewProj: loc('uViewProj'), mode: loc('uMode'), eye: loc('uEye'), light: loc('uLight'), color: loc('uColor'),
    sphere: loc('uSphere'),
  };

  // A mesh: positions (and normals) re-uploaded each frame, per-vertex held
  // flags and indices uploaded once.
  function mesh(vertexCount, indices, held, withNormals, edges) {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const pos = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, pos);
    gl.bufferData(gl.ARRAY_BUFFER, 12 * vertexCount, gl.DYNAMIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    let nrm = null;
    if (withNormals) {
      nrm = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, nrm);
      gl.bufferData(gl.ARRAY_BUFFER, 12 * vertexCount, gl.DYNAMIC_DRAW);
      gl.enableVertexAttribArray(1);
      gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 0, 0);
    } else {
      gl.disableVertexAttribArray(1);
    }
    const heldBuf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, heldBuf);
    gl.bufferData(gl.ARRAY_BUFFER, held, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(2);
    gl.vertexAttribPointer(2, 1, gl.UNSIGNED_BYTE, true, 0, 0);
    const idx = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, idx);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    let edgeVao = null, edgeIdx = null;
    if (edges) {
      edgeVao = gl.createVertexArray();
      gl.bindVertexArray(edgeVao);
      gl.bindBuffer(gl.ARRAY_BUFFER, pos);
      gl.enableVertexAttribArray(0);
      gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
      edgeIdx = gl.createBuffer();
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, edgeIdx);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, edges, gl.STATIC_DRAW);
    }
    gl.bindVertexArray(null);
    return {
      vao, pos, nrm, count: indices.length, edgeVao, edgeCount: edges ? edges.length : 0,
      free() {
        for (const b of [pos, nrm, heldBuf, idx, edgeIdx]) if (b) gl.deleteBuffer(b);
        gl.deleteVertexArray(vao);
        if (edgeVao) gl.deleteVertexArray(edgeVao);
      },
    };
  }

  let tets = null, surface = null;
  // The unit sphere (positions are normals), for the probe: made once.
  const ball = unitSphere(24, 16);
  const sphere = mesh(ball.positions.length / 3, ball.indices, new Uint8Array(ball.positions.length / 3), true, null);
  gl.bindBuffer(gl.ARRAY_BUFFER, sphere.pos);
  gl.bufferSubData(gl.ARRAY_BUFFER, 0, ball.positions);
  gl.bindBuffer(gl.ARRAY_BUFFER, sphere.nrm);
  gl.bufferSubData(gl.ARRAY_BUFFER, 0, ball.positions);

  return {
    canvas,
    antialias: gl.getContextAttributes()?.antialias ?? false,
    // The tetrahedra's boundary: nodes, triangles, edges (pairs), fixed flags.
    setTets(nodeCount, tris, edges, fixed) {
      tets?.free();
      tets = mesh(nodeCount, tris, fixed, false, edges);
    },
    // The embedded surface, or null.
    setSurface(s) {
      surface?.free();
      surface = s ? mesh(s.vertexCount, s.triangles, s.held, true, null) : null;
    },
    // Draws a frame into the rectangle `rect` ({ x, y, w, h }, pixels) of
    // app.js's canvas: the canvas here covers only that rectangle, rounded
    // up to 64 pixels (so that it is rarely resized), which keeps what a
    // software renderer clears and copies small. `cam`: app.js's camera;
    // `nodes`: node positions; `skin`: { positions, normals } of the
    // embedded surface when it is to be drawn; `edges`: draw the boundary's
    // edges on top; `ball`: the probe's sphere ({ centre, radius, ghost }:
    // translucent, over the body, while aiming) or null. Returns what was
    // drawn.
    draw(cam, rect, nodes, skin, edges, ball) {
      const width = 64 * Math.ceil(rect.w / 64), height = 64 * Math.ceil(rect.h / 64);
      if (canvas.width !== width || canvas.height !== height) {
        canvas.width = width;
        canvas.height = height;
      }
      gl.viewport(0, 0, width, height);
      gl.clearColor(0, 0, 0, 0);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      if (!tets) return { surfaceTriangles: 0, tetTriangles: 0, edges: 0 };
      gl.useProgram(program);
      gl.uniformMatrix4fv(u.viewProj, false, viewProj(cam, rect.x, rect.y, width, height));
      gl.uniform3fv(u.eye, cam.eye);
      gl.uniform3fv(u.light, cam.light);
      gl.uniform4f(u.sphere, 0, 0, 0, 0);
      gl.enable(gl.DEPTH_TEST);
      gl.depthFunc(gl.LEQUAL);
      gl.disable(gl.BLEND);
      gl.bindBuffer(gl.ARRAY_BUFFER, tets.pos);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, nodes);
      const drawn = { surfaceTriangles: 0, tetTriangles: 0, edges: 0 };
      if (skin && surface) {
        gl.bindBuffer(gl.ARRAY_BUFFER, surface.pos);
        gl.bufferSubData(gl.ARRAY_BUFFER, 0, skin.positions);
        gl.bindBuffer(gl.ARRAY_BUFFER, surface.nrm);
        gl.bufferSubData(gl.ARRAY_BUFFER, 0, skin.normals);
        gl.uniform1i(u.mode, 0);
        gl.bindVertexArray(surface.vao);
        gl.drawElements(gl.TRIANGLES, surface.count, gl.UNSIGNED_INT, 0);
        drawn.surfaceTriangles = surface.count / 3;
      } else {
        gl.uniform1i(u.mode, 1);
        gl.bindVertexArray(tets.vao);
        gl.drawElements(gl.TRIANGLES, tets.count, gl.UNSIGNED_INT, 0);
        drawn.tetTriangles = tets.count / 3;
      }
      if (edges && tets.edgeVao) {
        // Hidden lines of the boundary itself, drawn over whatever is shown:
        // the boundary's depth alone (pushed back a little), then its edges.
        gl.clear(gl.DEPTH_BUFFER_BIT);
        gl.colorMask(false, false, false, false);
        gl.enable(gl.POLYGON_OFFSET_FILL);
        gl.polygonOffset(1, 2);
        gl.uniform1i(u.mode, 1);
        gl.bindVertexArray(tets.vao);
        gl.drawElements(gl.TRIANGLES, tets.count, gl.UNSIGNED_INT, 0);
        gl.disable(gl.POLYGON_OFFSET_FILL);
        gl.colorMask(true, true, true, true);
        gl.enable(gl.BLEND);
        gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
        gl.uniform1i(u.mode, 2);
        gl.uniform4f(u.color, 0.93, 0.96, 1.0, 0.75);
        gl.bindVertexArray(tets.edgeVao);
        gl.drawElements(gl.LINES, tets.edgeCount, gl.UNSIGNED_INT, 0);
        gl.disable(gl.BLEND);
        drawn.edges = tets.edgeCount / 2;
      }
      if (ball) {
        // Pressed, hidden where the body wraps it; aiming, a glass sphere
        // that leaves the depth alone.
        gl.uniform1i(u.mode, 3);
        gl.uniform4f(u.sphere, ...ball.centre, ball.radius);
        gl.uniform4f(u.color, 0.86, 0.88, 0.91, ball.ghost ? 0.4 : 1);
        if (ball.ghost) {
          gl.enable(gl.BLEND);
          gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
          gl.depthMask(false);
        }
        gl.enable(gl.CULL_FACE);
        gl.bindVertexArray(sphere.vao);
        gl.drawElements(gl.TRIANGLES, sphere.count, gl.UNSIGNED_INT, 0);
        gl.disable(gl.CULL_FACE);
        gl.depthMask(true);
        gl.disable(gl.BLEND);
        gl.uniform4f(u.sphere, 0, 0, 0, 0);
        drawn.sphere = true;
      }
      gl.bindVertexArray(null);
      return drawn;
    },
  };
}

// A unit sphere of `slices` × `stacks` quads (positions, which are also its
// normals, and triangle indices wound counter-clockwise seen from outside).
function unitSphere(slices, stacks) {
  const positions = [], indices = [];
  for (let j = 0; j <= stacks; j++) {
    const th = Math.PI * j / stacks;
    for (let i = 0; i <= slices; i++) {
      const ph = 2 * Math.PI * i / slices;
      positions.push(Math.sin(th) * Math.cos(ph), Math.sin(th) * Math.sin(ph), Math.cos(th));
    }
  }
  const w = slices + 1;
  for (let j = 0; j < stacks; j++) {
    for (let i = 0; i < slices; i++) {
      const a = j * w + i, b = a + w;
      indices.push(a, b, a + 1, a + 1, b, b + 1);
    }
  }
  return { positions: new Float32Array(positions), indices: new Uint32Array(indices) };
}

// The perspective of app.js's `project` as a column-major matrix, for the
// `w` × `h` pixels at (x0, y0) of its canvas: a point at depth z = d·f
// (d from the eye) goes to the pixel `(cx + focal d·r / z, cy − focal d·u / z)`,
// and z lies between a near and a far plane.
function viewProj(c, x0, y0, w, h) {
  const near = 0.02, far = 100;
  const a = (far + near) / (far - near), b = -2 * far * near / (far - near);
  const sx = 2 * c.focal / w, sy = 2 * c.focal / h;
  const ox = 2 * (c.cx - x0) / w - 1, oy = 1 - 2 * (c.cy - y0) / h;
  // Rows acting on (p, 1): v·(p − eye) for the camera's axes.
  const at = (v) => [v[0], v[1], v[2], -(v[0] * c.eye[0] + v[1] * c.eye[1] + v[2] * c.eye[2])];
  const R = at(c.r), U = at(c.u), F = at(c.f);
  const rows = [
    R.map((e, i) => sx * e + ox * F[i]),
    U.map((e, i) => sy * e + oy * F[i]),
    F.map((e, i) => a * e + (i === 3 ? b : 0)),
    F,
  ];
  // Column-major.
  return new Float32Array([0, 1, 2, 3].flatMap((col) => rows.map((row) => row[col])));
}
