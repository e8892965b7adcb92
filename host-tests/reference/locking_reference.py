#!/usr/bin/env python3
"""Reference tip sags of the gravity cantilever as the Poisson ratio nears 1/2.

How far linear tetrahedra lock (grow too stiff) on a nearly incompressible
material: the cantilever of cantilever_reference.py (box [0,10]x[0,2]x[0,2] m,
E = 1e9 Pa, rho = 1000 kg/m^3, clamped at x = 0, sagging under gravity) solved
for nu in {0.3, 0.45, 0.49, 0.499} on the five shared beam meshes with

  P1 tetrahedra (4 nodes, constant strain): corofem's discretisation, so its
      static sag must reproduce these;
  P2 tetrahedra (10 nodes, quadratic): far less prone to locking; on the
      finest mesh, the converged sag that P1 is measured against.

Package used: scikit-fem 12.0.2 with numpy and scipy (requirements.txt).

How to run
    pip install -r requirements.txt
    python3 locking_reference.py /work/shared/meshes [output folder]

Writes locking_reference.json: for each mesh and nu, the mean z-displacement
(m, signed) of the mesh vertices at x = 10, for P1 and P2.
"""

import json
import os
import sys

import numpy as np
import skfem
from skfem import ElementTetP1, ElementTetP2, condense, solve

from cantilever_reference import E, L, MESHES, RHO, TOL, assemble, read_tetmesh

NUS = [0.3, 0.45, 0.49, 0.499]


def tip_sag(p, t, element, nu):
    basis, K, f = assemble(p, t, element, nu)
    # Every dof on the face x = 0 (vertex, and for P2 edge, dofs).
    clamped = basis.get_dofs(lambda x: x[0] <= TOL).all()
    u = solve(*condense(K, f, D=clamped))
    # nodal_dofs[c, i]: component c at mesh vertex i.
    nd = basis.nodal_dofs
    tip = np.where(p[:, 0] >= L - TOL)[0]
    return float(np.mean(u[nd[2, tip]]))


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: locking_reference.py <mesh folder> [output folder]")
    src = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.dirname(os.path.abspath(__file__))
    result = {"package": f"scikit-fem {skfem.__version__}", "E": E, "rho": RHO, "nu": NUS, "meshes": {}}
    for name in MESHES:
        p, t = read_tetmesh(os.path.join(src, name + ".tetmesh"))
        rows = {}
        for nu in NUS:
            p1 = tip_sag(p, t, ElementTetP1(), nu)
            p2 = tip_sag(p, t, ElementTetP2(), nu)
            rows[str(nu)] = {"p1_tip_uz_mean": p1, "p2_tip_uz_mean": p2}
            print(f"{name} nu {nu}: P1 {p1:.6e} m, P2 {p2:.6e} m, P1/P2 {p1 / p2:.4f}", flush=True)
        result["meshes"][name] = rows
    with open(os.path.join(out, "locking_reference.json"), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
