#!/usr/bin/env python3
"""Reference static linear-elastic cantilever solutions for the corofem tests.

Package used
    scikit-fem 12.0.2 (PyPI "scikit-fem"), with numpy 2.4.6 and scipy 1.17.1,
    on Python 3.11.7.  Exact pins: requirements.txt next to this file.

How to run
    pip install -r requirements.txt
    python3 cantilever_reference.py /work/shared/meshes
    (the argument is the folder holding the beam_10x2x2_*.tetmesh files; the
    meshes are third-party data and are only read, never copied here).
    Optional second argument: output folder (default: this script's folder).

What it solves
    Static small-strain linear elasticity on the box [0,10]x[0,2]x[0,2] m,
    discretised with P1 (linear, 4-node) tetrahedra, i.e. exactly the
    constant-strain-tetrahedron (CST) FEM.
      E = 1.0e9 Pa, nu = 0.3, rho = 1000 kg/m^3
      clamp: every node with x <= 1e-6 has u = 0 (all three components)
      load case "gravity": body force rho*g, g = (0, 0, -9.81) m/s^2, consistent
          P1 load vector (for a constant body force this equals the lumped one:
          each tet gives rho*g*V/4 to each of its 4 nodes)
      load case "tip": total force (0, 0, -1.0e5) N split evenly over the nodes
          with x >= 10 - 1e-6 (nodal point forces), no gravity
    "tip deflection" = mean z-displacement of the nodes with x >= 10 - 1e-6.
    All displacements are signed (downward deflection is negative).

Independent cross-check
    For every mesh the same problem is also assembled by hand in plain numpy
    (B matrix from the P1 shape-function gradients, engineering shear strains,
    isotropic 6x6 D with lambda = E nu/((1+nu)(1-2nu)), mu = E/(2(1+nu)),
    K_e = V B^T D B, lumped load rho g V/4 per node) and solved with scipy.
    The max relative difference to the scikit-fem field is stored in the JSON
    and must be below 1e-10 (the script aborts otherwise).

What it writes (into the output folder)
    cantilever_reference.json                  summary for all meshes
    cantilever_<mesh>_gravity.csv              per mesh: node,ux,uy,uz (%.10g),
                                               displacement field, gravity case
"""

import json
import os
import platform
import sys

import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem
from skfem import Basis, ElementTetP1, ElementVector, LinearForm, MeshTet, asm, condense, solve
from skfem.helpers import dot
from skfem.models.elasticity import lame_parameters, linear_elasticity

MESHES = [
    "beam_10x2x2_h1_t6",
    "beam_10x2x2_h1_t5",
    "beam_10x2x2_h05_t6",
    "beam_10x2x2_h05_t5",
    "beam_10x2x2_h025_t6",
]

E = 1.0e9
NU = 0.3
RHO = 1000.0
G_VEC = np.array([0.0, 0.0, -9.81])
TIP_FORCE = np.array([0.0, 0.0, -1.0e5])
L, B_WIDTH, H = 10.0, 2.0, 2.0
TOL = 1e-6
KAPPA = 5.0 / 6.0
CROSSCHECK_TOL = 1e-10


def read_tetmesh(path):
    with open(path) as f:
        tokens = f.read().split()
    assert tokens[0] == "tetmesh" and tokens[1] == "1", "not a 'tetmesh 1' file"
    nn, nt = int(tokens[2]), int(tokens[3])
    off = 4
    p = np.array(tokens[off:off + 3 * nn], dtype=float).reshape(nn, 3)
    off += 3 * nn
    t = np.array(tokens[off:off + 4 * nt], dtype=np.int64).reshape(nt, 4)
    assert off + 4 * nt == len(tokens), "trailing data in mesh file"
    return p, t


def tet_volumes(p, t):
    a, b, c, d = (p[t[:, i]] for i in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0


def node_sets(p):
    clamped = np.where(p[:, 0] <= TOL)[0]
    tip = np.where(p[:, 0] >= L - TOL)[0]
    return clamped, tip


# --------------------------------------------------------------------------
# 1) scikit-fem solution
# --------------------------------------------------------------------------
def assemble(p, t, element, nu):
    """The vector basis of `element` on the mesh, the stiffness for Poisson
    ratio `nu`, and the consistent gravity load."""
    mesh = MeshTet(np.ascontiguousarray(p.T), np.ascontiguousarray(t.T))
    basis = Basis(mesh, ElementVector(element))
    lam, mu = lame_parameters(E, nu)
    K = asm(linear_elasticity(lam, mu), basis)

    @LinearForm
    def body_force(v, w):
        return RHO * dot(G_VEC.reshape(3, 1, 1) * np.ones_like(v.value), v)

    return basis, K, asm(body_force, basis)


def solve_skfem(p, t):
    basis, K, f_grav = assemble(p, t, ElementTetP1(), NU)

    # nodal_dofs[c, i] = global dof of component c at mesh node i
    nd = basis.nodal_dofs
    assert nd.shape == (3, p.shape[0])
    clamped, tip = node_sets(p)
    f_tip = np.zeros(basis.N)
    for c in range(3):
        f_tip[nd[c, tip]] += TIP_FORCE[c] / len(tip)

    D = nd[:, clamped].ravel()
    out = {}
    for name, f in (("gravity", f_grav), ("tip", f_tip)):
        u = solve(*condense(K, f, D=D))
        out[name] = np.stack([u[nd[c]] for c in range(3)], axis=1)  # (n_nodes, 3)
    return out


# --------------------------------------------------------------------------
# 2) independent hand-written numpy/scipy CST assembly
# --------------------------------------------------------------------------
def solve_manual(p, t):
    nn, nt = p.shape[0], t.shape[0]
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    Dm = np.zeros((6, 6))
    Dm[:3, :3] = lam
    Dm[np.arange(3), np.arange(3)] += 2 * mu
    Dm[3:, 3:] = mu * np.eye(3)  # engineering shear strains gamma = 2 eps

    rows, cols, vals = [], [], []
    f_grav = np.zeros(3 * nn)
    for e in range(nt):
        idx = t[e]
        X = p[idx]
        # shape functions N_a = c0 + c . x ; solve [1 x y z] coefficients
        M = np.hstack([np.ones((4, 1)), X])
        C = np.linalg.inv(M)  # column a -> coefficients of N_a
        V = np.linalg.det(M) / 6.0
        assert V > 0
        grad = C[1:, :].T  # (4, 3): grad N_a
        Bm = np.zeros((6, 12))
        for a in range(4):
            gx, gy, gz = grad[a]
            Bm[:, 3 * a:3 * a + 3] = [
                [gx, 0, 0],
                [0, gy, 0],
                [0, 0, gz],
                [gy, gx, 0],  # gamma_xy
                [0, gz, gy],  # gamma_yz
                [gz, 0, gx],  # gamma_zx
            ]
        Ke = V * Bm.T @ Dm @ Bm
        dofs = (3 * idx[:, None] + np.arange(3)[None, :]).ravel()
        rows.append(np.repeat(dofs, 12))
        cols.append(np.tile(dofs, 12))
        vals.append(Ke.ravel())
        for a in range(4):
            f_grav[3 * idx[a]:3 * idx[a] + 3] += RHO * G_VEC * V / 4.0
    K = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(3 * nn, 3 * nn)).tocsr()

    clamped, tip = node_sets(p)
    f_tip = np.zeros(3 * nn)
    for n in tip:
        f_tip[3 * n:3 * n + 3] += TIP_FORCE / len(tip)
    fixed = np.zeros(3 * nn, dtype=bool)
    for n in clamped:
        fixed[3 * n:3 * n + 3] = True
    free = np.where(~fixed)[0]
    Kff = K[free][:, free].tocsc()
    lu = spla.splu(Kff)
    out = {}
    for name, f in (("gravity", f_grav), ("tip", f_tip)):
        u = np.zeros(3 * nn)
        u[free] = lu.solve(f[free])
        res = np.linalg.norm(Kff @ u[free] - f[free]) / np.linalg.norm(f[free])
        assert res < 1e-10, res
        out[name] = u.reshape(nn, 3)
    return out


# --------------------------------------------------------------------------
def analytical():
    A = B_WIDTH * H
    I = B_WIDTH * H ** 3 / 12.0
    G = E / (2 * (1 + NU))
    q = RHO * abs(G_VEC[2]) * A
    F = abs(TIP_FORCE[2])
    eb_q = q * L ** 4 / (8 * E * I)
    sh_q = q * L ** 2 / (2 * KAPPA * G * A)
    eb_F = F * L ** 3 / (3 * E * I)
    sh_F = F * L / (KAPPA * G * A)
    return {
        "note": "signed tip z-displacements (negative = downward); magnitudes are the usual "
                "delta = qL^4/(8EI) (+ qL^2/(2 kappa G A)) and FL^3/(3EI) (+ FL/(kappa G A))",
        "A_m2": A, "I_m4": I, "G_Pa": G, "kappa": KAPPA, "kappa_text": "5/6 (rectangular section)",
        "q_N_per_m": q, "F_N": F,
        "gravity": {"euler_bernoulli_tip_uz": -eb_q, "timoshenko_tip_uz": -(eb_q + sh_q),
                    "timoshenko_shear_term": -sh_q},
        "tip": {"euler_bernoulli_tip_uz": -eb_F, "timoshenko_tip_uz": -(eb_F + sh_F),
                "timoshenko_shear_term": -sh_F},
    }


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    mesh_dir = sys.argv[1]
    out_dir = sys.argv[2] if len(sys.argv) > 2 else os.path.dirname(os.path.abspath(__file__))
    ana = analytical()
    result = {
        "description": "Static linear elasticity, P1 tetrahedra (CST), cantilever box [0,10]x[0,2]x[0,2] m "
                       "clamped at x<=1e-6. tip_uz_mean = mean uz over nodes with x>=10-1e-6. "
                       "Generated by cantilever_reference.py.",
        "package": "scikit-fem", "package_version": skfem.__version__,
        "numpy_version": np.__version__, "scipy_version": scipy.__version__,
        "python_version": platform.python_version(),
        "material": {"E_Pa": E, "nu": NU, "rho_kg_per_m3": RHO, "g_m_per_s2": G_VEC.tolist()},
        "load_cases": {
            "gravity": "body force rho*g, consistent (= lumped) P1 load vector",
            "tip": "total force (0,0,-1e5) N split evenly over the nodes with x>=10-1e-6, no gravity",
        },
        "clamp": "all nodes with x <= 1e-6, all components",
        "analytical": ana,
        "crosscheck": "independent numpy CST assembly + scipy splu; max |u_skfem-u_numpy| / max|u_skfem| per case",
        "meshes": {},
    }
    for name in MESHES:
        p, t = read_tetmesh(os.path.join(mesh_dir, name + ".tetmesh"))
        assert np.all(tet_volumes(p, t) > 0)
        clamped, tip = node_sets(p)
        u = solve_skfem(p, t)
        um = solve_manual(p, t)
        rel = {k: float(np.max(np.abs(u[k] - um[k])) / np.max(np.abs(u[k]))) for k in u}
        assert max(rel.values()) < CROSSCHECK_TOL, (name, rel)
        ug, ut = u["gravity"], u["tip"]
        entry = {
            "nodes": int(p.shape[0]), "tets": int(t.shape[0]),
            "clamped_nodes": int(len(clamped)), "tip_nodes": int(len(tip)),
            "gravity": {
                "tip_uz_mean": float(ug[tip, 2].mean()),
                "min_uz": float(ug[:, 2].min()),
                "min_uz_node": int(np.argmin(ug[:, 2])),
                "total_load_N": float(RHO * G_VEC[2] * tet_volumes(p, t).sum()),
                "csv": f"cantilever_{name}_gravity.csv",
            },
            "tip": {
                "tip_uz_mean": float(ut[tip, 2].mean()),
                "min_uz": float(ut[:, 2].min()),
            },
            "crosscheck_max_rel_diff": rel,
        }
        for case in ("gravity", "tip"):
            fe = entry[case]["tip_uz_mean"]
            entry[case]["ratio_to_euler_bernoulli"] = fe / ana[case]["euler_bernoulli_tip_uz"]
            entry[case]["ratio_to_timoshenko"] = fe / ana[case]["timoshenko_tip_uz"]
        result["meshes"][name] = entry
        with open(os.path.join(out_dir, f"cantilever_{name}_gravity.csv"), "w") as f:
            f.write("node,ux,uy,uz\n")
            for i in range(p.shape[0]):
                f.write("%d,%.10g,%.10g,%.10g\n" % (i, ug[i, 0], ug[i, 1], ug[i, 2]))
        print(f"{name:22s} n={p.shape[0]:5d} t={t.shape[0]:6d} "
              f"grav tip={entry['gravity']['tip_uz_mean']:.6e} min={entry['gravity']['min_uz']:.6e} "
              f"tipload tip={entry['tip']['tip_uz_mean']:.6e} xcheck={max(rel.values()):.2e}")
    with open(os.path.join(out_dir, "cantilever_reference.json"), "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    print("EB/Timoshenko:", json.dumps(ana, indent=1))


if __name__ == "__main__":
    main()
