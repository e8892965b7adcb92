//! Embedded surfaces: a detailed triangle surface carried by the tetrahedra.
//!
//! A simulation mesh is coarse; what a user shows is a fine triangle surface.
//! Each vertex of that surface is bound once, at rest, to one tetrahedron
//! with barycentric weights `w` (`Σ wᵢ = 1`), and then follows it:
//!
//! ```text
//!   p = p₀ + Σᵢ wᵢ uᵢ          p₀: the vertex at rest, uᵢ: node displacements
//! ```
//!
//! which is the tetrahedron's own affine map, so any affine motion of the
//! mesh moves every vertex exactly (to f32 round-off), and a vertex on a face
//! or an edge shared by several tetrahedra moves the same whichever of them
//! it is bound to (the weights of the nodes off that face are zero). Adding
//! the weighted displacements to the rest position, rather than weighting
//! the positions, keeps the rest shape bit for bit and the update accurate
//! wherever the body sits (the same reason the nodes keep displacements).
//!
//! **Binding** ([`Scene::bind_surface`]). A vertex inside the mesh binds to
//! the tetrahedron that contains it, the one it lies deepest in when
//! several do (on shared faces), the first in mesh order on a tie. A vertex
//! outside binds to the nearest tetrahedron, if that is within `reach`
//! (m), and is extrapolated by that tetrahedron's affine map; beyond `reach`
//! binding fails with [`Error::VertexTooFar`]. The search is a uniform grid
//! over the vertices (a counting sort into the caller's scratch, at most one
//! cell per vertex) visited tetrahedron by tetrahedron through each one's
//! bounding box grown by `reach`: no allocation, and the same bindings on
//! every target, whatever the order of the work. The geometry runs in f64:
//! barycentric weights in a sliver lose digits in proportion to its aspect,
//! and binding runs once.
//!
//! **Per frame** ([`Scene::update_surface`], [`vertex_normals`]): four
//! multiply-adds per coordinate and vertex, then area-weighted normals.

use crate::error::{Error, Parameter};
use crate::math::{self, cross, dot, sub, Vec3};
use crate::scene::Scene;
use crate::storage::Storage;

/// One surface vertex bound to a tetrahedron (44 bytes): its four nodes,
/// their barycentric weights and the vertex's rest position. Made by
/// [`Scene::bind_surface`]; `[SurfaceBinding::EMPTY; N]` provides memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceBinding {
    nodes: [u32; 4],
    weights: [f32; 4],
    rest: Vec3,
}

impl SurfaceBinding {
    /// An unused slot.
    pub const EMPTY: Self = Self {
        nodes: [0; 4],
        weights: [0.0; 4],
        rest: [0.0; 3],
    };

    /// The nodes of the tetrahedron the vertex follows.
    #[must_use]
    pub fn nodes(&self) -> [u32; 4] {
        self.nodes
    }

    /// The barycentric weights of those nodes at the vertex (they sum to 1;
    /// some are negative for a vertex outside the mesh).
    #[must_use]
    pub fn weights(&self) -> [f32; 4] {
        self.weights
    }

    /// The vertex's rest position (m), as given to [`Scene::bind_surface`].
    #[must_use]
    pub fn rest_position(&self) -> Vec3 {
        self.rest
    }
}

impl Default for SurfaceBinding {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// What [`Scene::bind_surface`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BindStats {
    /// Vertices inside a tetrahedron (on its faces included).
    pub inside: u32,
    /// Vertices outside the mesh, extrapolated from their nearest tetrahedron.
    pub outside: u32,
    /// The largest distance of a vertex from its tetrahedron (m); 0 when
    /// every vertex is inside.
    pub max_distance: f32,
    /// The vertex at that distance.
    pub farthest_vertex: u32,
}

/// Length of the `u32` scratch [`Scene::bind_surface`] needs for a surface
/// of `vertices` vertices: the grid's cell starts (at most one cell per
/// vertex, plus one), the vertices sorted by cell, and each vertex's best
/// match so far.
#[must_use]
pub const fn surface_scratch_len(vertices: usize) -> usize {
    let cells = if vertices == 0 { 1 } else { vertices };
    // Saturating: a count whose scratch `usize` cannot hold asks for the
    // largest length, which no slice has, so binding refuses it.
    cells
        .saturating_add(1)
        .saturating_add(vertices.saturating_mul(2))
}

/// A triangle is degenerate when `|e₁ × e₂| ≤ 4 ε |e₁| |e₂|` (ε of f32) for
/// two of its edges: the sine of its angle is below what f32 coordinates
/// resolve, so it has no direction to give a normal.
const DEGENERATE_SINE: f64 = 4.0 * f32::EPSILON as f64;

impl<S: Storage> Scene<S> {
    /// Binds the vertices of a triangle surface (m, in the mesh's rest
    /// coordinates) to the built mesh's tetrahedra: one
    /// [`SurfaceBinding`] per vertex into `bindings`, in order.
    ///
    /// - `triangles` index `vertices`; they are checked here (indices in
    ///   range, three distinct vertices, not degenerate: see
    ///   [`Error::DegenerateTriangle`]) so that [`vertex_normals`] can rely
    ///   on them. Binding itself does not use them.
    /// - `reach` (m, finite, ≥ 0): how far outside the mesh a vertex may
    ///   lie. A surface modelled over the same shape as the tetrahedra lies
    ///   within a fraction of an element of their hull; a vertex farther out
    ///   than `reach` is refused ([`Error::VertexTooFar`]), which catches a
    ///   surface in other units or another place.
    /// - `scratch`: at least [`surface_scratch_len`]`(vertices.len())`
    ///   entries, clobbered.
    /// - `bindings`: at least `vertices.len()` entries; on error its
    ///   contents are unspecified. The scene is never changed.
    ///
    /// Cost: each tetrahedron tests the vertices in the grid cells its
    /// bounding box grown by `reach` covers (`cargo bench -p corofem-bench
    /// --bench surface` times it).
    pub fn bind_surface(
        &self,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        reach: f32,
        scratch: &mut [u32],
        bindings: &mut [SurfaceBinding],
    ) -> Result<BindStats, Error> {
        if self.hdr.n_elems == 0 {
            return Err(Error::NotBuilt);
        }
        if !(reach >= 0.0) || !reach.is_finite() {
            return Err(Error::InvalidParameter {
                parameter: Parameter::SurfaceReach,
            });
        }
        let n = vertices.len();
        if bindings.len() < n || u32::try_from(n).is_err() {
            return Err(Error::TooManyVertices {
                count: n,
                capacity: bindings.len().min(u32::MAX as usize),
            });
        }
        if scratch.len() < surface_scratch_len(n) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::SurfaceScratch,
            });
        }
        check_surface(vertices, triangles)?;
        if n == 0 {
            return Ok(BindStats::default());
        }
        let grid = Grid::new(vertices);
        // At most one cell per vertex, so these fit in the scratch checked
        // above; `None` cannot happen.
        let parts = scratch
            .split_at_mut_checked(grid.cells() + 1)
            .and_then(|(starts, rest)| {
                let (order, best) = rest.split_at_mut_checked(n)?;
                Some((starts, order, best.get_mut(..n)?))
            });
        let Some((starts, order, best)) = parts else {
            return Err(Error::InvalidParameter {
                parameter: Parameter::SurfaceScratch,
            });
        };
        grid.sort(vertices, starts, order);
        best.fill(f32::INFINITY.to_bits());

        // Two passes: each tetrahedron first takes the vertices it contains
        // (through its own bounding box), then, grown by `reach`, the
        // nearest of those left outside every tetrahedron. A vertex inside
        // one is never measured against the others, which is most of the
        // work on a surface that hugs the mesh.
        let reach = f64::from(reach);
        let nodes = self.nodes();
        for grow in [None, Some(reach)] {
            for e in 0..self.hdr.n_elems {
                let Some(el) = self.element(e) else { break };
                let tet = el.nodes.map(u32::from);
                let Some(tet_x) = corners(nodes, tet) else {
                    continue;
                };
                let shape = TetShape::new(tet_x);
                let (lo, hi) = shape.grown_box(grow.unwrap_or(0.0));
                grid.for_each_candidate((lo, hi), starts, order, |vi| {
                    let (Some(&rest), Some(slot), Some(b)) =
                        (vertices.get(vi), best.get_mut(vi), bindings.get_mut(vi))
                    else {
                        return;
                    };
                    let p = rest.map(f64::from);
                    let current = f32::from_bits(*slot);
                    if !inside_box(p, lo, hi) {
                        return;
                    }
                    let Some((key, w)) = shape.key(p, grow, current) else {
                        return;
                    };
                    // Keys compare as f32: the order is the same on every
                    // target, and ties go to the first tetrahedron in mesh
                    // order.
                    let key = key as f32;
                    if key < current {
                        *slot = key.to_bits();
                        *b = SurfaceBinding {
                            nodes: tet,
                            weights: w.map(|x| x as f32),
                            rest,
                        };
                    }
                });
            }
        }

        let mut stats = BindStats::default();
        let mut far2 = 0.0f32;
        for (v, &key) in best.iter().enumerate() {
            let key = f32::from_bits(key);
            if key == f32::INFINITY {
                return Err(Error::VertexTooFar { vertex: v as u32 });
            }
            if key <= 0.0 {
                stats.inside += 1;
            } else {
                stats.outside += 1;
                if key > far2 {
                    far2 = key;
                    stats.farthest_vertex = v as u32;
                }
            }
        }
        stats.max_distance = math::sqrt(far2);
        Ok(stats)
    }

    /// Moves a bound surface with the body: the current position of each
    /// vertex of `bindings` into `out` (m), in order.
    ///
    /// `out` has one entry per binding. Bindings made for another scene
    /// whose nodes do not exist here give [`Error::NodeOutOfRange`] (`out`
    /// is then partly written). No allocation; four multiply-adds per
    /// coordinate and vertex: 100 000 vertices cost about 1.3 steps of the
    /// 3k-tet bunny with the default solver (`cargo bench -p corofem-bench
    /// --bench surface`).
    pub fn update_surface(
        &self,
        bindings: &[SurfaceBinding],
        out: &mut [Vec3],
    ) -> Result<(), Error> {
        if out.len() != bindings.len() {
            return Err(Error::InvalidParameter {
                parameter: Parameter::SurfaceOut,
            });
        }
        let nodes = self.nodes();
        for (b, o) in bindings.iter().zip(out.iter_mut()) {
            let mut p = b.rest;
            for (&i, &w) in b.nodes.iter().zip(&b.weights) {
                let u = nodes
                    .get(i as usize)
                    .ok_or(Error::NodeOutOfRange { node: i })?
                    .u;
                p = math::axpy(p, w, u);
            }
            *o = p;
        }
        Ok(())
    }
}

/// Area-weighted vertex normals of a triangle surface: for each vertex, the
/// unit sum of `(b − a) × (c − a)` over its triangles (counter-clockwise
/// triangles seen from outside give outward normals). A vertex in no
/// triangle, or whose triangles' normals cancel, gets `[0, 0, 0]`.
///
/// `normals` has one entry per position; a triangle index beyond the
/// positions gives [`Error::TriangleIndexOutOfRange`] (`normals` is then
/// partly written).
pub fn vertex_normals(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    normals: &mut [Vec3],
) -> Result<(), Error> {
    if normals.len() != positions.len() {
        return Err(Error::InvalidParameter {
            parameter: Parameter::SurfaceOut,
        });
    }
    normals.fill([0.0; 3]);
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = triangle_corners(positions, t, *tri)?;
        let n = cross(sub(b, a), sub(c, a));
        for &i in tri {
            if let Some(m) = normals.get_mut(i as usize) {
                *m = math::add(*m, n);
            }
        }
    }
    for m in normals.iter_mut() {
        *m = math::normalize(*m).unwrap_or([0.0; 3]);
    }
    Ok(())
}

fn triangle_corners(positions: &[Vec3], t: usize, tri: [u32; 3]) -> Result<[Vec3; 3], Error> {
    let at = |i: u32| {
        positions
            .get(i as usize)
            .copied()
            .ok_or(Error::TriangleIndexOutOfRange {
                triangle: t,
                vertex: i,
            })
    };
    Ok([at(tri[0])?, at(tri[1])?, at(tri[2])?])
}

/// Checks a triangle surface as [`Scene::bind_surface`] does, without a
/// scene: finite vertices ([`Error::NonFiniteVertex`]), triangle indices in
/// range ([`Error::TriangleIndexOutOfRange`]), three distinct vertices with
/// corners not collinear ([`Error::DegenerateTriangle`]). The first problem
/// found is the error.
pub fn check_surface(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), Error> {
    if let Some(v) = vertices.iter().position(|p| !math::is_finite3(*p)) {
        return Err(Error::NonFiniteVertex { vertex: v as u32 });
    }
    for (t, &tri) in triangles.iter().enumerate() {
        let corners = triangle_corners(vertices, t, tri)?;
        let [a, b, c] = corners.map(|p| p.map(f64::from));
        let (e1, e2) = (sub(b, a), sub(c, a));
        let n = cross(e1, e2);
        let limit = DEGENERATE_SINE * DEGENERATE_SINE * dot(e1, e1) * dot(e2, e2);
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || !(dot(n, n) > limit) {
            return Err(Error::DegenerateTriangle { triangle: t });
        }
    }
    Ok(())
}

fn corners(nodes: &[crate::storage::Node], tet: [u32; 4]) -> Option<[[f64; 3]; 4]> {
    let x = |i: u32| nodes.get(i as usize).map(|n| n.x0.map(f64::from));
    Some([x(tet[0])?, x(tet[1])?, x(tet[2])?, x(tet[3])?])
}

fn inside_box(p: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> bool {
    (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k])
}

/// A tetrahedron at rest, in f64, with what barycentric weights need.
struct TetShape {
    x: [[f64; 3]; 4],
    /// Rows of `[b − a, c − a, d − a]⁻¹`: weights 1–3 of `p` are `rowᵢ·(p − a)`.
    inv: [[f64; 3]; 3],
    /// `|∇wᵢ|²` of each weight: `wᵢ / |∇wᵢ|` is the signed distance to the
    /// plane of the face opposite corner `i`.
    grad2: [f64; 4],
}

impl TetShape {
    fn new(x: [[f64; 3]; 4]) -> Self {
        let (e1, e2, e3) = (sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0]));
        // A built element has a positive volume (the build refuses flat and,
        // unless asked to re-orient, inverted ones), so `det` is not zero.
        let det = dot(e1, cross(e2, e3));
        let s = 1.0 / det;
        let row = |r: [f64; 3]| r.map(|c| c * s);
        let inv = [row(cross(e2, e3)), row(cross(e3, e1)), row(cross(e1, e2))];
        let g0 = math::neg(math::add(math::add(inv[0], inv[1]), inv[2]));
        let grad2 = [g0, inv[0], inv[1], inv[2]].map(|g| dot(g, g));
        Self { x, inv, grad2 }
    }

    /// How well `p` fits this tetrahedron, smaller being better, with its
    /// weights; `None` where the pass passes it over. Containment (`grow`
    /// `None`): `−(least weight)`, for a point inside only, so the deepest
    /// tetrahedron wins. Nearest (`Some(r)`): the squared distance, for a
    /// point outside within `r` and nearer than `best` (its key so far;
    /// `≤ 0`, inside another tetrahedron, skips it).
    fn key(&self, p: [f64; 3], grow: Option<f64>, best: f32) -> Option<(f64, [f64; 4])> {
        if grow.is_some() && best <= 0.0 {
            return None;
        }
        let w = self.weights(p);
        let key = match grow {
            None => {
                let least = w.iter().fold(f64::INFINITY, |m, &x| m.min(x));
                if !(least >= 0.0) {
                    return None;
                }
                -least
            }
            Some(r) => {
                // A cheap lower bound first: the distance to the faces'
                // planes.
                if self.plane_distance2(w) > (r * r).min(f64::from(best)) {
                    return None;
                }
                self.distance2(p, w).filter(|&d2| d2 <= r * r)?
            }
        };
        Some((key, w))
    }

    /// A lower bound of the squared distance from a point of weights `w`
    /// to the tetrahedron: its squared distance to the farthest plane of a
    /// face it lies beyond (0 inside).
    fn plane_distance2(&self, w: [f64; 4]) -> f64 {
        w.into_iter()
            .zip(self.grad2)
            .filter(|&(wi, _)| wi < 0.0)
            .fold(0.0, |m, (wi, g2)| m.max(wi * wi / g2))
    }

    fn grown_box(&self, reach: f64) -> ([f64; 3], [f64; 3]) {
        let [a, b, c, d] = self.x;
        let lo: [f64; 3] = core::array::from_fn(|k| a[k].min(b[k]).min(c[k]).min(d[k]) - reach);
        let hi: [f64; 3] = core::array::from_fn(|k| a[k].max(b[k]).max(c[k]).max(d[k]) + reach);
        (lo, hi)
    }

    fn weights(&self, p: [f64; 3]) -> [f64; 4] {
        let d = sub(p, self.x[0]);
        let (w1, w2, w3) = (
            dot(self.inv[0], d),
            dot(self.inv[1], d),
            dot(self.inv[2], d),
        );
        [1.0 - w1 - w2 - w3, w1, w2, w3]
    }

    /// `None` when `p` is inside (every weight ≥ 0); otherwise the squared
    /// distance to the tetrahedron: the nearest of the faces `p` lies beyond
    /// (those opposite a negative weight), since the closest point of a
    /// convex body to a point outside lies on a face that point sees.
    fn distance2(&self, p: [f64; 3], w: [f64; 4]) -> Option<f64> {
        let [a, b, c, d] = self.x;
        // The face opposite each corner.
        let faces = [[b, c, d], [a, c, d], [a, b, d], [a, b, c]];
        let mut d2 = None::<f64>;
        for (face, wi) in faces.into_iter().zip(w) {
            if wi < 0.0 {
                let r = sub(p, closest_on_triangle(p, face));
                let e = dot(r, r);
                d2 = Some(d2.map_or(e, |m: f64| m.min(e)));
            }
        }
        d2
    }
}

/// The point of triangle `t` closest to `p` (Ericson, *Real-Time Collision
/// Detection*, §5.1.5: the Voronoi region of `p` among the corners, edges
/// and face).
fn closest_on_triangle(p: [f64; 3], t: [[f64; 3]; 3]) -> [f64; 3] {
    let [a, b, c] = t;
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return math::axpy(a, d1 / (d1 - d3), ab);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return math::axpy(a, d2 / (d2 - d6), ac);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return math::axpy(b, (d4 - d3) / ((d4 - d3) + (d5 - d6)), sub(c, b));
    }
    let denom = 1.0 / (va + vb + vc);
    math::axpy(math::axpy(a, vb * denom, ab), vc * denom, ac)
}

/// A uniform grid over the vertices' bounding box with at most one cell per
/// vertex.
struct Grid {
    lo: [f64; 3],
    inv_size: f64,
    n: [usize; 3],
}

impl Grid {
    fn new(vertices: &[Vec3]) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(p[k]));
                hi[k] = hi[k].max(f64::from(p[k]));
            }
        }
        let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let longest = ext[0].max(ext[1]).max(ext[2]);
        let most = vertices.len().max(1) as u64;
        // Start at cells far smaller than needed and double their size
        // until the count fits: the finest grid of at most one cell per
        // vertex, for solid, flat and straight point sets alike.
        let mut size = longest / most as f64;
        let mut n = [1usize; 3];
        if longest > 0.0 {
            for _ in 0..128 {
                let m = ext.map(|e| (e / size) as u64 + 1);
                if m[0].saturating_mul(m[1]).saturating_mul(m[2]) <= most {
                    n = m.map(|c| c as usize);
                    break;
                }
                size *= 2.0;
            }
        }
        let inv_size = if n == [1, 1, 1] { 0.0 } else { 1.0 / size };
        Self { lo, inv_size, n }
    }

    fn cells(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// The cell holding `p`, clamped to the grid (so a box reaching beyond
    /// the vertices visits the edge cells).
    fn cell_of_f64(&self, p: [f64; 3]) -> [usize; 3] {
        core::array::from_fn(|k| {
            let c = (p[k] - self.lo[k]) * self.inv_size;
            // `as` saturates: negative and NaN give 0.
            (c as usize).min(self.n[k].saturating_sub(1))
        })
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.n[1] + c[1]) * self.n[0] + c[0]
    }

    /// Calls `f` with each vertex (index) in the cells that the box
    /// `[lo, hi]` meets, cell by cell: a superset of those inside it.
    fn for_each_candidate(
        &self,
        (lo, hi): ([f64; 3], [f64; 3]),
        starts: &[u32],
        order: &[u32],
        mut f: impl FnMut(usize),
    ) {
        let (c0, c1) = (self.cell_of_f64(lo), self.cell_of_f64(hi));
        for z in c0[2]..=c1[2] {
            for y in c0[1]..=c1[1] {
                for x in c0[0]..=c1[0] {
                    let cell = self.index([x, y, z]);
                    let (Some(&s), Some(&t)) = (starts.get(cell), starts.get(cell + 1)) else {
                        continue;
                    };
                    for &v in order.get(s as usize..t as usize).unwrap_or_default() {
                        f(v as usize);
                    }
                }
            }
        }
    }

    /// Counting sort of the vertices by cell: `order[starts[c]..starts[c +
    /// 1]]` are the vertices of cell `c`, in increasing order.
    fn sort(&self, vertices: &[Vec3], starts: &mut [u32], order: &mut [u32]) {
        starts.fill(0);
        for p in vertices {
            let c = self.index(self.cell_of_f64(p.map(f64::from)));
            if let Some(s) = starts.get_mut(c + 1) {
                *s += 1;
            }
        }
        let mut sum = 0u32;
        for s in starts.iter_mut() {
            sum += *s;
            *s = sum;
        }
        // `starts[c]` is now where cell `c` begins; fill moving a cursor
        // that is then shifted back.
        for (v, p) in vertices.iter().enumerate() {
            let c = self.index(self.cell_of_f64(p.map(f64::from)));
            if let Some(s) = starts.get_mut(c) {
                if let Some(o) = order.get_mut(*s as usize) {
                    *o = v as u32;
                }
                *s += 1;
            }
        }
        let mut previous = 0;
        for s in starts.iter_mut() {
            previous = core::mem::replace(s, previous);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BoxMesh, BuildOptions, Material, VecScene};
    use std::vec;
    use std::vec::Vec;

    fn beam() -> (VecScene, Vec<Vec3>) {
        let mesh = BoxMesh {
            size: [1.0, 0.5, 0.25],
            cells: [4, 2, 1],
            tets_per_cell: 6,
        };
        let mut nodes = vec![[0.0f32; 3]; 45];
        let mut tets = vec![[0u32; 4]; 48];
        let (n, t) = mesh.generate(&mut nodes, &mut tets).unwrap();
        let mut scene = VecScene::with_capacity(n, t);
        let material = Material {
            young: 1.0e5,
            poisson: 0.3,
            density: 1000.0,
        };
        scene
            .build(&nodes[..n], &tets[..t], &material, BuildOptions::default())
            .unwrap();
        (scene, nodes[..n].to_vec())
    }

    #[test]
    fn closest_point_regions() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(closest_on_triangle([-1.0, -1.0, 1.0], t), t[0]);
        assert_eq!(closest_on_triangle([2.0, -0.5, 0.0], t), t[1]);
        assert_eq!(closest_on_triangle([-0.5, 3.0, 0.0], t), t[2]);
        assert_eq!(closest_on_triangle([0.5, -1.0, 2.0], t), [0.5, 0.0, 0.0]);
        assert_eq!(closest_on_triangle([1.0, 1.0, 0.0], t), [0.5, 0.5, 0.0]);
        assert_eq!(
            closest_on_triangle([0.25, 0.25, -3.0], t),
            [0.25, 0.25, 0.0]
        );
    }

    #[test]
    fn grid_sorts_every_vertex_once_in_order() {
        let pts: Vec<Vec3> = (0..50)
            .map(|i| [(i % 7) as f32 * 0.1, (i % 3) as f32, 0.0])
            .collect();
        let grid = Grid::new(&pts);
        assert!(grid.cells() <= pts.len());
        let mut starts = vec![0u32; grid.cells() + 1];
        let mut order = vec![0u32; pts.len()];
        grid.sort(&pts, &mut starts, &mut order);
        assert_eq!(starts[grid.cells()] as usize, pts.len());
        let mut seen = order.clone();
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(i, &v)| v as usize == i));
        for c in 0..grid.cells() {
            let cell = &order[starts[c] as usize..starts[c + 1] as usize];
            assert!(cell.windows(2).all(|w| w[0] < w[1]));
            for &v in cell {
                let p = pts[v as usize].map(f64::from);
                assert_eq!(grid.index(grid.cell_of_f64(p)), c);
            }
        }
    }

    #[test]
    fn nodes_bind_to_themselves_and_outside_points_extrapolate() {
        let (scene, nodes) = beam();
        let mut scratch = vec![0u32; surface_scratch_len(nodes.len() + 1)];
        let mut b = vec![SurfaceBinding::EMPTY; nodes.len() + 1];
        let mut verts = nodes.clone();
        verts.push([1.05, 0.25, 0.125]); // 5 cm beyond the end face
        let stats = scene
            .bind_surface(&verts, &[], 0.06, &mut scratch, &mut b)
            .unwrap();
        assert_eq!(stats.inside as usize, nodes.len());
        assert_eq!(stats.outside, 1);
        // 1.05 − 1.0 in f32, and a square root: within a few ulps of 0.05.
        assert!((stats.max_distance - 0.05).abs() < 1e-6);
        assert_eq!(
            scene.bind_surface(&verts, &[], 0.04, &mut scratch, &mut b),
            Err(Error::VertexTooFar {
                vertex: nodes.len() as u32
            })
        );
        let mut out = vec![[0.0; 3]; verts.len()];
        scene.update_surface(&b, &mut out).unwrap();
        assert_eq!(out, verts, "at rest every vertex is where it was given");
    }

    #[test]
    fn normals_of_a_square() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 5.0, 5.0],
        ];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let mut n = [[9.0; 3]; 5];
        vertex_normals(&p, &tris, &mut n).unwrap();
        assert_eq!(&n[..4], &[[0.0, 0.0, 1.0]; 4]);
        assert_eq!(n[4], [0.0; 3]);
        assert_eq!(
            vertex_normals(&p, &[[0, 1, 7]], &mut n),
            Err(Error::TriangleIndexOutOfRange {
                triangle: 0,
                vertex: 7
            })
        );
        assert_eq!(
            check_surface(&p, &[[0, 1, 2], [0, 0, 3]]),
            Err(Error::DegenerateTriangle { triangle: 1 })
        );
        assert_eq!(
            check_surface(&p, &[[0, 1, 2], [0, 1, 1]]),
            Err(Error::DegenerateTriangle { triangle: 1 })
        );
        let collinear = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1e-9, 0.0]];
        assert_eq!(
            check_surface(&collinear, &[[0, 1, 2]]),
            Err(Error::DegenerateTriangle { triangle: 0 })
        );
    }
}
