#!/usr/bin/env python3
"""Writes rounded_beam.obj: the 1 m x 0.2 m x 0.2 m beam of rounded_beam.toml
with its edges and corners rounded (radius 5 cm), as a triangle surface that
the coarse box mesh carries ([visual]). Every point of the box's surface on a
2 cm grid is moved onto the rounded box: the nearest point of the inner box
(shrunk by the radius) plus the radius along the way out. Faces stay flat
where they are farther than the radius from an edge. Run it from anywhere;
it writes next to itself.
"""
import math
import os

SIZE = (1.0, 0.2, 0.2)  # m, as [mesh] size
CELLS = (50, 10, 10)  # grid points per edge, minus one
RADIUS = 0.05  # m


def main():
    index = {}
    vertices = []
    faces = []

    def vertex(g):
        if g not in index:
            q = [g[a] * SIZE[a] / CELLS[a] for a in range(3)]
            c = [min(max(q[a], RADIUS), SIZE[a] - RADIUS) for a in range(3)]
            d = [q[a] - c[a] for a in range(3)]
            n = math.sqrt(sum(x * x for x in d))
            # + 0.0: no "-0.000000" in the file.
            p = [round(c[a] + RADIUS * d[a] / n, 6) + 0.0 for a in range(3)]
            index[g] = len(vertices) + 1
            vertices.append(p)
        return index[g]

    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        for side in (0, CELLS[a]):
            for u in range(CELLS[b]):
                for v in range(CELLS[c]):
                    quad = []
                    for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        g = [0, 0, 0]
                        g[a], g[b], g[c] = side, u + du, v + dv
                        quad.append(vertex(tuple(g)))
                    if side == 0:
                        quad.reverse()
                    faces.append((quad[0], quad[1], quad[2]))
                    faces.append((quad[0], quad[2], quad[3]))

    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "rounded_beam.obj"), "w") as f:
        f.write("# rounded_beam.obj: written by make_rounded_beam.py\n")
        for p in vertices:
            f.write("v %.6f %.6f %.6f\n" % tuple(p))
        for t in faces:
            f.write("f %d %d %d\n" % t)


main()
