// Small mesh files written in JS for the tests: a box split into Kuhn
// tetrahedra, as Gmsh 4.1 ASCII, Gmsh 2.2 ASCII and tetmesh 1 — the writers
// add what real Gmsh files have (other element types, geometry points,
// arbitrary tags), so the readers skip and map as they must.

// Box [0, size] of cells, 6 positively oriented tetrahedra per cell.
export function boxMesh(size, cells) {
  const [nx, ny, nz] = cells;
  const nodes = [];
  for (let k = 0; k <= nz; k++) {
    for (let j = 0; j <= ny; j++) {
      for (let i = 0; i <= nx; i++) nodes.push([i * size[0] / nx, j * size[1] / ny, k * size[2] / nz]);
    }
  }
  const id = (i, j, k) => i + (nx + 1) * (j + (ny + 1) * k);
  const paths = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
  const tets = [];
  for (let k = 0; k < nz; k++) {
    for (let j = 0; j < ny; j++) {
      for (let i = 0; i < nx; i++) {
        const corner = (c) => id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        for (const p of paths) {
          const t = p.map(corner);
          if (det(nodes, t) < 0) [t[2], t[3]] = [t[3], t[2]];
          tets.push(t);
        }
      }
    }
  }
  return { nodes, tets };
}

function det(nodes, t) {
  const [a, b, c, d] = t.map((i) => nodes[i]);
  const u = [0, 1, 2].map((k) => b[k] - a[k]), v = [0, 1, 2].map((k) => c[k] - a[k]), w = [0, 1, 2].map((k) => d[k] - a[k]);
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

const TAG = 100; // node tags start here: not 0-based, not 1-based

export function toMsh41({ nodes, tets }) {
  const out = ['$MeshFormat', '4.1 0 8', '$EndMeshFormat'];
  out.push('$Entities', '1 0 0 1', `1 ${nodes[0].join(' ')} 0`, '1 0 0 0 1 1 1 0 0', '$EndEntities');
  // Node 0 in a point entity, the rest in the volume; one extra geometry
  // point that no tetrahedron uses.
  const n = nodes.length;
  out.push('$Nodes', `3 ${n + 1} ${TAG} ${TAG + n}`);
  out.push('0 1 0 1', `${TAG}`, nodes[0].join(' '));
  out.push(`3 1 0 ${n - 1}`);
  for (let i = 1; i < n; i++) out.push(`${TAG + i}`);
  for (let i = 1; i < n; i++) out.push(nodes[i].join(' '));
  out.push('0 2 0 1', `${TAG + n}`, '9 9 9');
  out.push('$EndNodes');
  // A triangle block before the tetrahedra.
  out.push('$Elements', `2 ${tets.length + 1} 1 ${tets.length + 1}`);
  out.push('2 1 2 1', `1 ${TAG} ${TAG + 1} ${TAG + 2}`);
  out.push(`3 1 4 ${tets.length}`);
  tets.forEach((t, e) => out.push(`${e + 2} ${t.map((i) => TAG + i).join(' ')}`));
  out.push('$EndElements', '');
  return out.join('\n');
}

export function toMsh2({ nodes, tets }) {
  const out = ['$MeshFormat', '2.2 0 8', '$EndMeshFormat', '$PhysicalNames', '1', '3 1 "body"', '$EndPhysicalNames'];
  out.push('$Nodes', `${nodes.length}`);
  nodes.forEach((p, i) => out.push(`${TAG + i} ${p.join(' ')}`));
  out.push('$EndNodes', '$Elements', `${tets.length + 1}`);
  out.push(`1 15 2 0 1 ${TAG}`); // a point element
  tets.forEach((t, e) => out.push(`${e + 2} 4 2 1 1 ${t.map((i) => TAG + i).join(' ')}`));
  out.push('$EndElements', '');
  return out.join('\r\n'); // Windows line ends, as Gmsh on Windows writes
}

export function toTetmesh({ nodes, tets }) {
  return ['tetmesh 1', `${nodes.length} ${tets.length}`, ...nodes.map((p) => p.join(' ')), ...tets.map((t) => t.join(' ')), ''].join('\n');
}

// A sphere of radius `r` around `centre` as OBJ text: an octahedron
// subdivided `levels` times, its vertices pushed onto the sphere
// (6 + 12 (4^levels − 1) / 3 vertices, 8 · 4^levels triangles, wound
// counter-clockwise seen from outside).
export function sphereObj(centre, r, levels) {
  const v = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
  let f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
  for (let l = 0; l < levels; l++) {
    const mid = new Map();
    const half = (a, b) => {
      const key = `${Math.min(a, b)},${Math.max(a, b)}`;
      if (!mid.has(key)) {
        const m = [0, 1, 2].map((k) => v[a][k] + v[b][k]);
        const len = Math.hypot(...m);
        v.push(m.map((x) => x / len));
        mid.set(key, v.length - 1);
      }
      return mid.get(key);
    };
    f = f.flatMap(([a, b, c]) => {
      const ab = half(a, b), bc = half(b, c), ca = half(c, a);
      return [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]];
    });
  }
  const lines = ['# a sphere', 'o sphere'];
  for (const p of v) lines.push(`v ${p.map((x, k) => centre[k] + r * x).join(' ')}`);
  for (const t of f) lines.push(`f ${t.map((i) => i + 1).join(' ')}`);
  return { text: lines.join('\n') + '\n', vertices: v.length, triangles: f.length };
}

// The box [lo, hi] as ASCII STL: 12 triangles wound outward.
export function toStl(lo, hi) {
  const corner = (c) => [0, 1, 2].map((k) => ((c >> k) & 1 ? hi[k] : lo[k]));
  // Each face as four corners counter-clockwise seen from outside.
  const faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
  const out = ['solid box'];
  for (const [a, b, c, d] of faces) {
    for (const t of [[a, b, c], [a, c, d]]) {
      out.push('facet normal 0 0 0', 'outer loop', ...t.map((i) => `vertex ${corner(i).join(' ')}`), 'endloop', 'endfacet');
    }
  }
  out.push('endsolid box', '');
  return out.join('\n');
}
