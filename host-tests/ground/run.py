#!/usr/bin/env python3
"""Bodies dropped on, and set down on, the ground: the scenes of
docs/reliability.md ("Bodies on the ground"), run with the `corofem` program.

    python3 host-tests/ground/run.py [--bin target/release/corofem] [--method qr]
        [--solver 'preconditioner="two-level";cg_iterations=4'] [CASE ...]

Meshes: the Stanford bunny and the SOFA liver of ../shared/meshes (read in
place, never copied), plus meshes TetGen makes from their surfaces into
target/ground-meshes when `tetgen` is installed (apt-get install tetgen):
`bunny_31k` (quality mesh, 31 178 tetrahedra, 2.0° smallest dihedral angle)
and `bunny_sliver` and `liver_sliver` (no quality bound: slivers down to
0.47° and 0.09°). Cases whose mesh is missing are skipped with a notice.
Every run uses the default settings but for `dt` (and what the options
add); the table gives, per case, whether it finished, the inverted elements
at the end and at most, the largest elastic energy against the energy the
body started with (kinetic and potential above the ground), and the median
time per step. Before it, each mesh's size and quality.
"""
import argparse, collections, json, math, pathlib, subprocess, sys, time

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "meshes"
MADE = ROOT / "target" / "ground-meshes"


def sub(p, q):
    return [p[k] - q[k] for k in range(3)]


def cross(u, v):
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def six_volume(p):
    """6 × the signed volume of the tetrahedron with corners p[0..4]."""
    return dot(cross(sub(p[1], p[0]), sub(p[2], p[0])), sub(p[3], p[0]))


def read_tetmesh(path):
    lines = path.read_text().split("\n")
    n, t = map(int, lines[1].split())
    nodes = [list(map(float, l.split())) for l in lines[2:2 + n]]
    tets = [list(map(int, l.split())) for l in lines[2 + n:2 + n + t]]
    return nodes, tets


def tetgen(src, name, flags):
    """Re-meshes the boundary surface of `src` with TetGen `flags`."""
    out = MADE / f"{name}.tetmesh"
    if out.exists():
        return out
    if subprocess.run(["which", "tetgen"], capture_output=True).returncode != 0:
        return None
    nodes, tets = read_tetmesh(src)
    faces = collections.Counter()
    oriented = {}
    for a, b, c, d in tets:
        for f in ((a, c, b), (a, b, d), (a, d, c), (b, c, d)):
            key = tuple(sorted(f))
            faces[key] += 1
            oriented[key] = f
    boundary = [oriented[k] for k, v in faces.items() if v == 1]
    used = sorted({i for f in boundary for i in f})
    index = {u: i for i, u in enumerate(used)}
    MADE.mkdir(parents=True, exist_ok=True)
    off = MADE / f"{name}.off"
    write(off, f"OFF\n{len(used)} {len(boundary)} 0", [nodes[u] for u in used],
          [[3] + [index[i] for i in f] for f in boundary])
    subprocess.run(["tetgen", flags, "-Q", str(off)], check=True, capture_output=True)

    def rows(p):
        r = [l.split("#")[0].split() for l in p.read_text().split("\n")]
        return [x for x in r if x]

    node_rows = rows(MADE / f"{name}.1.node")
    ele_rows = rows(MADE / f"{name}.1.ele")
    nn, ne, base = int(node_rows[0][0]), int(ele_rows[0][0]), int(node_rows[1][0])
    pts = [[float(v) for v in r[1:4]] for r in node_rows[1:1 + nn]]
    els = [[int(v) - base for v in r[1:5]] for r in ele_rows[1:1 + ne]]

    els = [[e[0], e[2], e[1], e[3]] if six_volume([pts[i] for i in e]) < 0 else e for e in els]
    keep = sorted({i for e in els for i in e})
    renum = {u: i for i, u in enumerate(keep)}
    write(out, f"tetmesh 1\n{len(keep)} {len(els)}", [pts[u] for u in keep],
          [[renum[i] for i in e] for e in els])
    return out


def write(path, header, points, cells):
    """A header line, one `x y z` line per point, one line of integers per cell."""
    with path.open("w") as o:
        o.write(header + "\n")
        for p in points:
            o.write("%.9g %.9g %.9g\n" % tuple(p))
        for c in cells:
            o.write(" ".join(str(i) for i in c) + "\n")


def meshes():
    bunny, liver = SHARED / "bunny_ftw_3k.tetmesh", SHARED / "liver_ftw_3k.tetmesh"
    have = {}
    if bunny.exists():
        have["bunny_3k"] = (bunny, 1.0)
        have["bunny_31k"] = (tetgen(bunny, "bunny_31k", "-pq1.4a0.00000048"), 1.0)
        have["bunny_sliver"] = (tetgen(bunny, "bunny_sliver", "-p"), 1.0)
    if liver.exists():
        # The liver is in SOFA's units (~6.5 long): 0.03 makes it ~0.2 m.
        have["liver_3k"] = (liver, 0.03)
        have["liver_sliver"] = (tetgen(liver, "liver_sliver", "-p"), 0.03)
    return {k: v for k, v in have.items() if v[0] is not None}


# name: mesh, E (Pa), ν, dt (s), seconds, drop height (m), velocity, spin,
# and the axis that is up (the meshes have y up; z up lays the bunny on its
# side)
CASES = [
    ("rest, 1 ms", "bunny_31k", 5e4, 0.3, 1e-3, 1.5, None, None, None),
    ("rest, 5 ms", "bunny_31k", 5e4, 0.3, 5e-3, 1.5, None, None, None),
    ("rest, 1 ms", "bunny_3k", 5e4, 0.3, 1e-3, 2.0, None, None, None),
    ("rest, 5 ms", "bunny_3k", 5e4, 0.3, 5e-3, 2.0, None, None, None),
    ("drop, spin, 2 ms", "bunny_3k", 2e4, 0.45, 2e-3, 2.0, 0.3, [0.0, -2.0, 0.0], [0.0, 0.0, 20.0]),
    ("drop, spin, 2 ms", "liver_3k", 2e4, 0.45, 2e-3, 2.0, 0.3, [0.0, -2.0, 0.0], [3.0, 0.0, 20.0]),
    ("drop, spin, 2 ms", "liver_sliver", 2e4, 0.45, 2e-3, 2.0, 0.3, [0.0, -2.0, 0.0], [0.0, 0.0, 20.0]),
    ("drop, stiff, 10 ms", "bunny_3k", 1e8, 0.49, 1e-2, 2.0, 0.3, None, None),
    ("drop, stiff, 10 ms", "bunny_sliver", 1e8, 0.49, 1e-2, 2.0, 0.3, None, None),
    ("drop on its side, stiff, 10 ms", "bunny_3k", 1e8, 0.49, 1e-2, 2.0, 0.3, None, None, 2),
    ("drop on its side, stiff, 10 ms", "bunny_sliver", 1e8, 0.49, 1e-2, 2.0, 0.3, None, None, 2),
    ("drop, spin, stiff, 10 ms", "bunny_3k", 1e8, 0.49, 1e-2, 2.0, 0.3, [0.0, -2.0, 0.0], [3.0, 0.0, 20.0]),
    ("drop, soft, 5 ms", "bunny_3k", 5e3, 0.49, 5e-3, 3.0, 0.3, None, None),
    ("drop, soft, 5 ms", "bunny_31k", 5e3, 0.49, 5e-3, 3.0, 0.3, None, None),
    ("drop, 50 ms", "bunny_3k", 1e5, 0.3, 5e-2, 4.0, 0.3, None, None),
    ("drop, 50 ms", "bunny_31k", 1e5, 0.3, 5e-2, 4.0, 0.3, None, None),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "corofem"))
    ap.add_argument("--method")
    ap.add_argument("--solver", default="", help="extra [solver] lines, ';'-separated")
    ap.add_argument("cases", nargs="*", help="case names or meshes to run (default: all)")
    a = ap.parse_args()
    have = meshes()
    work = MADE / "runs"
    work.mkdir(parents=True, exist_ok=True)
    for mesh, (path, _) in have.items():
        if not a.cases or mesh in a.cases or any(c[1] == mesh and c[0] in a.cases for c in CASES):
            print(quality(mesh, *read_tetmesh(path)))
    print()
    print("| case | mesh (tets) | finished | inverted at the end / most | largest elastic / start energy (J) | ms per step |")
    print("|---|---|---|---|---|---|")
    for name, mesh, young, nu, dt, seconds, height, vel, spin, *up in CASES:
        up = up[0] if up else 1
        normal = [1.0 if k == up else 0.0 for k in range(3)]
        if a.cases and name not in a.cases and mesh not in a.cases:
            continue
        if mesh not in have:
            print(f"| {name} | {mesh}: not available (needs ../shared/meshes, and tetgen for the made ones) | | | | |")
            continue
        path, scale = have[mesh]
        nodes, tets = read_tetmesh(path)
        ymin = scale * min(p[up] for p in nodes)
        offset = ymin - (height or 0.0)
        solver = [f"dt = {dt}", f"steps = {round(seconds / dt)}"]
        if a.method:
            solver.append(f'method = "{a.method}"')
        solver += [s for s in a.solver.split(";") if s]
        text = (f'[mesh]\nfile = "{path}"\nscale = {scale}\n'
                f"[material]\nyoung = {young}\npoisson = {nu}\ndensity = 1000.0\n"
                "[solver]\n" + "\n".join(solver) + "\n"
                f"[world]\ngravity = {[-9.81 if k == up else 0.0 for k in range(3)]}\n"
                f"ground = {{ normal = {normal}, offset = {offset} }}\n")
        if vel or spin:
            text += f"[initial]\nvelocity = {vel or [0.0] * 3}\nangular_velocity = {spin or [0.0] * 3}\n"
        text += f"[output]\nevery = {max(1, round(0.01 / dt))}\n"
        stem = f"{mesh}_{name}".replace(" ", "_").replace(",", "")
        scene = work / f"{stem}.toml"
        scene.write_text(text)
        out = work / f"{stem}.json"
        t = time.time()
        r = subprocess.run([a.bin, "run", str(scene), "--out", str(out)], capture_output=True, text=True)
        if r.returncode != 0:
            print(f"| {name} | {mesh} ({len(tets)}) | **no**: {r.stderr.strip().splitlines()[-1][:120]} | | | |")
            continue
        j = json.loads(out.read_text())
        h = j["history"]
        # Energy at the start: kinetic plus potential above the ground.
        start = h[0]["kinetic_energy"] + potential(scale, tets, nodes, offset, up)
        max_el = max(x["elastic_energy"] for x in h)
        max_inv = max(x["inverted"] for x in h)
        print(f"| {name} | {mesh} ({len(tets)}) | yes | {j['final']['inverted']} / {max_inv} | "
              f"{max_el:.2e} / {start:.2f} | {j['timing']['ms_per_step_median']:.2f} |")


def quality(name, nodes, tets):
    """The mesh's size, smallest dihedral angle and spread of volumes."""
    smallest, volumes = 180.0, []
    for e in tets:
        p = [nodes[i] for i in e]
        volumes.append(abs(six_volume(p)))
        # Outward face normals; the dihedral angle at the edge two faces
        # share is π minus the angle between their normals.
        faces = [(1, 2, 3, 0), (0, 3, 2, 1), (0, 1, 3, 2), (0, 2, 1, 3)]
        normals = []
        for a, b, c, opposite in faces:
            n = cross(sub(p[b], p[a]), sub(p[c], p[a]))
            if dot(n, sub(p[opposite], p[a])) > 0:
                n = [-x for x in n]
            normals.append([x / math.sqrt(dot(n, n)) for x in n])
        for i in range(4):
            for j in range(i + 1, 4):
                c = max(-1.0, min(1.0, dot(normals[i], normals[j])))
                smallest = min(smallest, 180.0 - math.degrees(math.acos(c)))
    return (f"mesh {name}: {len(nodes)} nodes, {len(tets)} tetrahedra, smallest dihedral "
            f"angle {smallest:.2f}°, volumes spanning {max(volumes) / min(volumes):.2g}×")


def potential(scale, tets, nodes, offset, up):
    """m g (h_c − offset) of the mesh at rest, its centre's height h_c along
    the axis `up`, density 1000 kg/m³."""
    m_total, my = 0.0, 0.0
    for e in tets:
        p = [[scale * c for c in nodes[i]] for i in e]
        m = 1000.0 * abs(six_volume(p)) / 6.0
        m_total += m
        my += m * sum(q[up] for q in p) / 4.0
    return 9.81 * (my - m_total * offset)


if __name__ == "__main__":
    sys.exit(main())
