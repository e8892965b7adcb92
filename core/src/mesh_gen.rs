//! Generated meshes: a box split into tetrahedra, written into caller slices
//! (no allocation), for tests, firmware and demos that have no mesh file.

use crate::error::{Error, Parameter};
use crate::math::{det3, sub, Vec3};

/// A box `[0, size.x] × [0, size.y] × [0, size.z]` of `cells` cubes, each
/// split into 5 or 6 tetrahedra.
///
/// Six per cell is the Kuhn split around the diagonal `(0,0,0)–(1,1,1)`; five
/// per cell alternates two mirror-image splits in a checkerboard so the face
/// diagonals of neighbouring cells match. Every tetrahedron is positively
/// oriented. Node `(i, j, k)` has index `i + (nx+1) (j + (ny+1) k)`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoxMesh {
    /// Edge lengths (m).
    pub size: Vec3,
    /// Cells along x, y, z (each ≥ 1).
    pub cells: [u32; 3],
    /// 5 or 6.
    pub tets_per_cell: u8,
}

/// Corner `c` (bits x = 1, y = 2, z = 4) of a cell.
const CORNER: [[u32; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [0, 1, 0],
    [1, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [0, 1, 1],
    [1, 1, 1],
];

/// Kuhn split: the six monotone paths from corner 0 to corner 7.
const SIX: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];
/// Five-tetrahedra split of an even cell: four corner tetrahedra and the
/// central one on the corners with an even number of bits.
const FIVE_EVEN: [[usize; 4]; 5] = [
    [1, 0, 3, 5],
    [2, 0, 3, 6],
    [4, 0, 5, 6],
    [7, 3, 5, 6],
    [0, 3, 5, 6],
];
/// The mirror split, for odd cells.
const FIVE_ODD: [[usize; 4]; 5] = [
    [0, 1, 2, 4],
    [3, 1, 2, 7],
    [5, 1, 4, 7],
    [6, 2, 4, 7],
    [1, 2, 4, 7],
];

impl BoxMesh {
    /// Number of nodes `(nx+1)(ny+1)(nz+1)` (saturating).
    #[must_use]
    pub const fn node_count(&self) -> usize {
        let [x, y, z] = self.cells;
        // `saturating_add`: `u32::MAX + 1` does not fit a 32-bit usize.
        (x as usize)
            .saturating_add(1)
            .saturating_mul((y as usize).saturating_add(1))
            .saturating_mul((z as usize).saturating_add(1))
    }

    /// Number of tetrahedra `nx·ny·nz·tets_per_cell` (saturating).
    #[must_use]
    pub const fn tet_count(&self) -> usize {
        let [x, y, z] = self.cells;
        (x as usize)
            .saturating_mul(y as usize)
            .saturating_mul(z as usize)
            .saturating_mul(self.tets_per_cell as usize)
    }

    /// Writes the nodes (m) and tetrahedra into the front of the slices and
    /// returns their counts.
    pub fn generate(
        &self,
        nodes: &mut [Vec3],
        tets: &mut [[u32; 4]],
    ) -> Result<(usize, usize), Error> {
        let [cx, cy, cz] = self.cells;
        if cx == 0 || cy == 0 || cz == 0 {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Cells,
            });
        }
        if !self.size.iter().all(|s| *s > 0.0 && s.is_finite()) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Size,
            });
        }
        let split: &[[usize; 4]] = match self.tets_per_cell {
            5 => &FIVE_EVEN,
            6 => &SIX,
            _ => {
                return Err(Error::InvalidParameter {
                    parameter: Parameter::TetsPerCell,
                })
            }
        };
        let (n_nodes, n_tets) = (self.node_count(), self.tet_count());
        if n_nodes > nodes.len() || n_nodes > u32::MAX as usize {
            return Err(Error::TooManyNodes {
                count: n_nodes,
                capacity: nodes.len(),
            });
        }
        if n_tets > tets.len() {
            return Err(Error::TooManyElements {
                count: n_tets,
                capacity: tets.len(),
            });
        }
        let (nx, ny) = (cx + 1, cy + 1);
        let h = [
            self.size[0] / cx as f32,
            self.size[1] / cy as f32,
            self.size[2] / cz as f32,
        ];
        // In index order `i + nx (j + ny k)`. Loops rather than `idx % nx`:
        // no division, so no division-by-zero branch for the compiler to keep.
        let mut slots = nodes.iter_mut().take(n_nodes);
        for k in 0..=cz {
            for j in 0..=cy {
                for i in 0..=cx {
                    if let Some(p) = slots.next() {
                        *p = [i as f32 * h[0], j as f32 * h[1], k as f32 * h[2]];
                    }
                }
            }
        }
        let mut out = tets.iter_mut();
        for k in 0..cz {
            for j in 0..cy {
                for i in 0..cx {
                    let corners = if split.len() == 5 && (i + j + k) % 2 == 1 {
                        &FIVE_ODD[..]
                    } else {
                        split
                    };
                    let id = |c: usize| {
                        // Every split names corners 0..8; the mask shows the
                        // compiler so (no bounds check: firmware links with
                        // no panicking branch).
                        let [di, dj, dk] = CORNER[c & 7];
                        (i + di) + nx * ((j + dj) + ny * (k + dk))
                    };
                    for t in corners {
                        let mut tet = [id(t[0]), id(t[1]), id(t[2]), id(t[3])];
                        let p = |n: u32| nodes.get(n as usize).copied().unwrap_or([0.0; 3]);
                        let e = |a: u32, b: u32| sub(p(b), p(a));
                        if det3(e(tet[0], tet[1]), e(tet[0], tet[2]), e(tet[0], tet[3])) < 0.0 {
                            tet.swap(2, 3);
                        }
                        if let Some(slot) = out.next() {
                            *slot = tet;
                        }
                    }
                }
            }
        }
        Ok((n_nodes, n_tets))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_volume() {
        for tpc in [5u8, 6] {
            let b = BoxMesh {
                size: [2.0, 1.0, 1.0],
                cells: [4, 2, 3],
                tets_per_cell: tpc,
            };
            let mut nodes = [[0.0; 3]; 60];
            let mut tets = [[0u32; 4]; 144];
            let (n, t) = b.generate(&mut nodes, &mut tets).unwrap();
            assert_eq!((n, t), (5 * 3 * 4, 24 * tpc as usize));
            let mut vol = 0.0f32;
            for tet in &tets[..t] {
                let p = |i: u32| nodes[i as usize];
                let v = det3(
                    sub(p(tet[1]), p(tet[0])),
                    sub(p(tet[2]), p(tet[0])),
                    sub(p(tet[3]), p(tet[0])),
                ) / 6.0;
                assert!(v > 0.0);
                vol += v;
            }
            assert!((vol - 2.0).abs() < 1e-5); // f32 sum of 144 exact-ish volumes
        }
    }

    #[test]
    fn faces_conform() {
        // Every interior triangle is shared by exactly two tetrahedra, every
        // boundary one by one: count triangle multiplicities.
        for tpc in [5u8, 6] {
            let b = BoxMesh {
                size: [1.0; 3],
                cells: [3, 3, 3],
                tets_per_cell: tpc,
            };
            let mut nodes = [[0.0; 3]; 64];
            let mut tets = [[0u32; 4]; 162];
            let (_, t) = b.generate(&mut nodes, &mut tets).unwrap();
            let mut faces: [[u32; 3]; 648] = [[0; 3]; 648];
            let mut nf = 0;
            for tet in &tets[..t] {
                for skip in 0..4 {
                    let mut f = [0u32; 3];
                    let mut k = 0;
                    for (m, &v) in tet.iter().enumerate() {
                        if m != skip {
                            f[k] = v;
                            k += 1;
                        }
                    }
                    f.sort_unstable();
                    faces[nf] = f;
                    nf += 1;
                }
            }
            let faces = &mut faces[..nf];
            faces.sort_unstable();
            let mut boundary = 0;
            let mut i = 0;
            while i < faces.len() {
                let mut j = i;
                while j < faces.len() && faces[j] == faces[i] {
                    j += 1;
                }
                assert!(j - i <= 2, "a face shared by {} tets", j - i);
                boundary += usize::from(j - i == 1);
                i = j;
            }
            // 6 faces × 3×3 squares × 2 triangles.
            assert_eq!(boundary, 108);
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let mut nodes = [[0.0; 3]; 8];
        let mut tets = [[0u32; 4]; 6];
        let b = BoxMesh {
            size: [1.0; 3],
            cells: [1, 1, 1],
            tets_per_cell: 4,
        };
        assert!(b.generate(&mut nodes, &mut tets).is_err());
        let b = BoxMesh {
            size: [1.0; 3],
            cells: [2, 1, 1],
            tets_per_cell: 6,
        };
        assert!(matches!(
            b.generate(&mut nodes, &mut tets),
            Err(Error::TooManyNodes { .. })
        ));
    }
}
