//! The f64 reference integrator: exactly the core's discretisation and
//! scheme (co-rotational linear tetrahedra after Nesme, Payan and Faure 2005,
//! linearised implicit Euler; docs/bench.md, "What is measured"), with every
//! implicit step's linear system solved to a relative residual of 1e-12.
//!
//! * [`RefMethod::Qr`]: QR frame of the current edges, `B` from the current
//!   shape, scaled by the rest volume: `λ' = λ/(36 V₀)`, `μ' = μ/(36 V₀)`,
//!   gradients ×6V.
//! * [`RefMethod::Polar`]: the rotation `R` closest to the deformation
//!   gradient `F = D D₀⁻¹` (edge matrices, columns `b − a, c − a, d − a`)
//!   among proper rotations (`det R = +1` also for an inverted element), from
//!   an f64 SVD, and the rest gradients (×6V₀): strains are measured in the
//!   rest shape rotated by `R`, the stiffness is `R K₀ Rᵀ` (the core's
//!   `Polar`, whose Newton search on SO(3) converges to the same `R`).
//! * Lumped mass `ρ V₀ / 4` per element node.
//! * Baraff–Witkin linearised implicit Euler with Rayleigh damping:
//!   `A = (1 + h α_M) M + h (α_K + h) K`,
//!   `b = h (f_el + m g − α_M M v) − h (α_K + h) K v`, `v += Δv`, `u += h v`.
//! * Fixed nodes: `Δv = 0` (rows and columns filtered out of CG).
//!
//! `K` is assembled as a block (3×3) CSR matrix whose sparsity pattern is
//! built once; each element adds its 16 blocks
//! `K_ij = λ' gᵢ gⱼᵀ + μ' ((gᵢ·gⱼ) I + gⱼ gᵢᵀ)` (world gradients `g`, node
//! `a` has `g_a = −(g_b + g_c + g_d)`), which is the same operator as the
//! core's matrix-free H-form. The code is generic over the float type so the
//! benchmark can time an assembled f32 variant with the same kernel.

use nalgebra::Matrix3;
use num_traits::Float;

/// The element rotation the reference measures strains in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RefMethod {
    /// QR frame of the current edges, `B` from the current shape (`Method::Qr`).
    Qr,
    /// Polar rotation of `F` with rest gradients (`Method::Polar`).
    Polar,
}

/// 3-vector.
pub type V<T> = [T; 3];

/// `a − b`.
#[inline(always)]
pub fn sub<T: Float>(a: V<T>, b: V<T>) -> V<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// `a · b`.
#[inline(always)]
pub fn dot<T: Float>(a: V<T>, b: V<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// `a × b`.
#[inline(always)]
pub fn cross<T: Float>(a: V<T>, b: V<T>) -> V<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline(always)]
fn unit<T: Float>(a: V<T>) -> V<T> {
    let n = dot(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// QR frame rows `e1, e2, e3` and local coordinates `[xb, xc, yc, xd, yd, zd]`.
#[inline(always)]
fn frame<T: Float>(ab: V<T>, ac: V<T>, ad: V<T>) -> ([V<T>; 3], [T; 6]) {
    let e1 = unit(ab);
    let e3 = unit(cross(e1, ac));
    let e2 = cross(e3, e1);
    (
        [e1, e2, e3],
        [
            dot(e1, ab),
            dot(e1, ac),
            dot(e2, ac),
            dot(e1, ad),
            dot(e2, ad),
            dot(e3, ad),
        ],
    )
}

/// The rotation closest to `f` (rows) with determinant +1: `U Vᵀ` of the
/// SVD `f = U Σ Vᵀ`, with the column of `U` of the smallest singular value
/// negated when `det(U Vᵀ) < 0` (an inverted element).
fn closest_rotation(f: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let m = Matrix3::from_fn(|r, c| f[r][c]);
    let svd = m.svd(true, true);
    let (mut u, v_t) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for Vᵀ"));
    if (u * v_t).determinant() < 0.0 {
        let k = svd.singular_values.imin();
        u.column_mut(k).neg_mut();
    }
    let r = u * v_t;
    [0, 1, 2].map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]])
}

/// The inverse of the 3×3 matrix `m` (rows).
fn inverse<T: Float>(m: [[T; 3]; 3]) -> [[T; 3]; 3] {
    let c0 = cross(m[1], m[2]);
    let c1 = cross(m[2], m[0]);
    let c2 = cross(m[0], m[1]);
    let det = dot(m[0], c0);
    // Columns of the inverse are the cofactor rows over det.
    [0, 1, 2].map(|r| [c0[r] / det, c1[r] / det, c2[r] / det])
}

/// A reference trajectory: node displacements (m) at a series of times, and
/// their squared sum, for the error metric of the report and of the peers
/// comparison: `sqrt(Σ_k Σ_i |u_ik − u_ref,ik|² / Σ_k Σ_i |u_ref,ik|²)`, the
/// position error over the whole trajectory relative to the RMS reference
/// displacement.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    /// Node displacements at each recorded time (m).
    pub u: Vec<Vec<V<f64>>>,
    /// `Σ_k Σ_i |u_ref,ik|²` (m²).
    pub norm2: f64,
}

impl Trajectory {
    /// Records the displacements `u` (m) of the next time.
    pub fn push(&mut self, u: &[V<f64>]) {
        self.norm2 += u.iter().map(|&v| dot(v, v)).sum::<f64>();
        self.u.push(u.to_vec());
    }

    /// `Σ_i |u_i − u_ref,ik|²` (m²) of displacements `u` at recorded time
    /// `k`; NaN if `k` was not recorded.
    pub fn sq_err(&self, k: usize, u: impl IntoIterator<Item = V<f64>>) -> f64 {
        let Some(r) = self.u.get(k) else {
            return f64::NAN;
        };
        u.into_iter()
            .zip(r)
            .map(|(a, &b)| {
                let e = sub(a, b);
                dot(e, e)
            })
            .sum()
    }

    /// The relative error of a run whose [`Self::sq_err`] sum is `sq`.
    pub fn relative(&self, sq: f64) -> f64 {
        (sq / self.norm2).sqrt()
    }
}

/// Block CSR matrix with 3×3 blocks (row-major inside a block).
#[derive(Clone, Debug)]
pub struct Bsr<T> {
    /// Start of each block row in `cols`/`vals` (`n + 1` entries).
    pub row_ptr: Vec<usize>,
    /// Block column of each block.
    pub cols: Vec<u32>,
    /// Block values.
    pub vals: Vec<[T; 9]>,
}

impl<T: Float> Bsr<T> {
    /// `y = K x`.
    pub fn mul(&self, x: &[V<T>], y: &mut [V<T>]) {
        for (i, yi) in y.iter_mut().enumerate() {
            let mut s = [T::zero(); 3];
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                let b = &self.vals[k];
                let xj = x[self.cols[k] as usize];
                s[0] = s[0] + b[0] * xj[0] + b[1] * xj[1] + b[2] * xj[2];
                s[1] = s[1] + b[3] * xj[0] + b[4] * xj[1] + b[5] * xj[2];
                s[2] = s[2] + b[6] * xj[0] + b[7] * xj[1] + b[8] * xj[2];
            }
            *yi = s;
        }
    }

    /// Number of stored blocks.
    pub fn blocks(&self) -> usize {
        self.cols.len()
    }
}

/// A mesh with its rest quantities and state, for one float type.
#[derive(Clone, Debug)]
pub struct Model<T> {
    /// Rest positions (m).
    pub x0: Vec<V<T>>,
    /// Positively oriented tetrahedra.
    pub tets: Vec<[u32; 4]>,
    /// Rest local coordinates per element.
    pub rest: Vec<[T; 6]>,
    /// The element rotation (default [`RefMethod::Qr`]; see [`Model::with_method`]).
    pub method: RefMethod,
    /// Per element, the inverse of the rest edge matrix `D₀` (columns
    /// `b − a, c − a, d − a`), for [`RefMethod::Polar`].
    rest_inv: Vec<[[T; 3]; 3]>,
    /// `[λ', μ'] = [λ, μ] / (36 V₀)` per element.
    pub lame: Vec<[T; 2]>,
    /// Lumped masses (kg).
    pub mass: Vec<T>,
    /// Fixed nodes.
    pub fixed: Vec<bool>,
    /// Displacements (m).
    pub u: Vec<V<T>>,
    /// Velocities (m/s).
    pub v: Vec<V<T>>,
    /// Stiffness matrix (pattern fixed, values of the last assembly).
    pub k: Bsr<T>,
    /// For each element, the 16 block slots of `(i, j)` in `k`, row-major.
    slots: Vec<[u32; 16]>,
    /// Elastic forces of the last assembly (N).
    pub f_el: Vec<V<T>>,
}

/// Integrator settings (units as in `corofem::Settings`).
#[derive(Clone, Copy, Debug)]
pub struct RefSettings {
    /// Time step (s).
    pub dt: f64,
    /// Mass-proportional damping (1/s).
    pub rayleigh_mass: f64,
    /// Stiffness-proportional damping (s).
    pub rayleigh_stiffness: f64,
    /// Gravity (m/s²).
    pub gravity: [f64; 3],
    /// Relative residual `‖r‖/‖b‖` at which CG stops.
    pub tolerance: f64,
}

/// What a reference step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct RefStats {
    /// CG iterations.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
}

impl<T: Float> Model<T> {
    /// Builds the model from positions (m), positively oriented tetrahedra and
    /// the material (Pa, −, kg/m³); `fixed` lists the fixed nodes.
    pub fn new(
        positions: &[[f32; 3]],
        tets: &[[u32; 4]],
        young: f64,
        poisson: f64,
        density: f64,
        fixed: &[u32],
    ) -> Self {
        let c = |x: f32| T::from(x).unwrap();
        let cf = |x: f64| T::from(x).unwrap();
        let x0: Vec<V<T>> = positions
            .iter()
            .map(|p| [c(p[0]), c(p[1]), c(p[2])])
            .collect();
        let n = x0.len();
        let lam = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
        let mu = young / (2.0 * (1.0 + poisson));
        let mut rest = Vec::with_capacity(tets.len());
        let mut rest_inv = Vec::with_capacity(tets.len());
        let mut lame = Vec::with_capacity(tets.len());
        let mut mass = vec![T::zero(); n];
        for t in tets {
            let p = |k: usize| x0[t[k] as usize];
            let (_, l) = frame(sub(p(1), p(0)), sub(p(2), p(0)), sub(p(3), p(0)));
            let six_v0 = l[0] * l[2] * l[5];
            assert!(six_v0 > T::zero(), "element not positively oriented");
            rest.push(l);
            let (e1, e2, e3) = (sub(p(1), p(0)), sub(p(2), p(0)), sub(p(3), p(0)));
            rest_inv.push(inverse([0, 1, 2].map(|r| [e1[r], e2[r], e3[r]])));
            let s = cf(6.0) / (cf(36.0) * six_v0);
            lame.push([cf(lam) * s, cf(mu) * s]);
            let quarter = cf(density) * six_v0 / cf(24.0);
            for &i in t {
                mass[i as usize] = mass[i as usize] + quarter;
            }
        }
        let mut is_fixed = vec![false; n];
        for &i in fixed {
            is_fixed[i as usize] = true;
        }
        // Sparsity pattern: node adjacency through elements, sorted.
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for t in tets {
            for &i in t {
                for &j in t {
                    adj[i as usize].push(j);
                }
            }
        }
        let mut row_ptr = vec![0usize; n + 1];
        let mut cols = Vec::new();
        for (i, a) in adj.iter_mut().enumerate() {
            a.sort_unstable();
            a.dedup();
            cols.extend_from_slice(a);
            row_ptr[i + 1] = cols.len();
        }
        let slots = tets
            .iter()
            .map(|t| {
                let mut s = [0u32; 16];
                for (a, &i) in t.iter().enumerate() {
                    let row = &cols[row_ptr[i as usize]..row_ptr[i as usize + 1]];
                    for (b, &j) in t.iter().enumerate() {
                        let k = row.binary_search(&j).unwrap();
                        s[4 * a + b] = (row_ptr[i as usize] + k) as u32;
                    }
                }
                s
            })
            .collect();
        let nb = cols.len();
        Self {
            x0,
            tets: tets.to_vec(),
            rest,
            method: RefMethod::Qr,
            rest_inv,
            lame,
            mass,
            fixed: is_fixed,
            u: vec![[T::zero(); 3]; n],
            v: vec![[T::zero(); 3]; n],
            k: Bsr {
                row_ptr,
                cols,
                vals: vec![[T::zero(); 9]; nb],
            },
            slots,
            f_el: vec![[T::zero(); 3]; n],
        }
    }

    /// The same model with element rotations of `method`.
    #[must_use]
    pub fn with_method(mut self, method: RefMethod) -> Self {
        self.method = method;
        self
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.x0.len()
    }

    /// Current positions (m).
    pub fn position(&self, i: usize) -> V<T> {
        let (x, u) = (self.x0[i], self.u[i]);
        [x[0] + u[0], x[1] + u[1], x[2] + u[2]]
    }

    /// Elastic forces into `f_el` and the stiffness matrix into `k`, at the
    /// current displacements (QR, `B` from the current shape).
    pub fn assemble(&mut self) {
        for f in self.f_el.iter_mut() {
            *f = [T::zero(); 3];
        }
        for b in self.k.vals.iter_mut() {
            *b = [T::zero(); 9];
        }
        for (e, t) in self.tets.iter().enumerate() {
            let ids = t.map(|i| i as usize);
            // Edges as rest edge + displacement difference (as the core does).
            let edge = |k: usize| {
                let r = sub(self.x0[ids[k]], self.x0[ids[0]]);
                let d = sub(self.u[ids[k]], self.u[ids[0]]);
                [r[0] + d[0], r[1] + d[1], r[2] + d[2]]
            };
            let z = T::zero();
            // `fr`: world → element frame (rows); `g`: gradients of b, c, d in
            // that frame; `du`: displacements of b, c, d relative to a there.
            let (fr, g, du) = match self.method {
                RefMethod::Qr => {
                    let (fr, l) = frame(edge(1), edge(2), edge(3));
                    let l0 = self.rest[e];
                    let [xb, xc, yc, xd, yd, zd] = l;
                    // Local gradients ×6V of b, c, d (the corrected table
                    // of corofem's element/qr.rs).
                    let g = [
                        [yc * zd, -(xc * zd), xc * yd - yc * xd],
                        [z, xb * zd, -(xb * yd)],
                        [z, z, xb * yc],
                    ];
                    // Local displacement; u_a = 0, u_b = (ubx,0,0), u_c = (ucx,ucy,0).
                    let du = [
                        [l[0] - l0[0], z, z],
                        [l[1] - l0[1], l[2] - l0[2], z],
                        [l[3] - l0[3], l[4] - l0[4], l[5] - l0[5]],
                    ];
                    (fr, g, du)
                }
                RefMethod::Polar => {
                    // F = D D₀⁻¹; R the closest proper rotation; the frame
                    // is the rest shape rotated by R (world → frame: Rᵀ).
                    let inv = self.rest_inv[e];
                    // det D₀ = 6 V₀ = xb·yc·zd of the rest QR coordinates.
                    let l0 = self.rest[e];
                    let six_v0 = l0[0] * l0[2] * l0[5];
                    let d = [edge(1), edge(2), edge(3)];
                    let f = [0, 1, 2].map(|r| {
                        [0, 1, 2].map(|c| {
                            d[0][r] * inv[0][c] + d[1][r] * inv[1][c] + d[2][r] * inv[2][c]
                        })
                    });
                    let to64 = |x: T| x.to_f64().unwrap_or(f64::NAN);
                    let r = closest_rotation(f.map(|row| row.map(to64)));
                    let fr = [0, 1, 2].map(|i| [0, 1, 2].map(|j| T::from(r[j][i]).unwrap_or(z)));
                    // Rest gradients ×6V₀: the rows of D₀⁻¹ times det D₀.
                    let g = [0, 1, 2].map(|i| inv[i].map(|v| v * six_v0));
                    // Rᵀ d − d₀ for b, c, d (d₀ = rest edge).
                    let x0 = |k: usize| sub(self.x0[ids[k]], self.x0[ids[0]]);
                    let du = [1, 2, 3].map(|k| {
                        let (dk, rk) = (edge(k), x0(k));
                        [0, 1, 2].map(|i| dot(fr[i], dk) - rk[i])
                    });
                    (fr, g, du)
                }
            };
            // H = Σ du_i g_iᵀ; σ = λ' tr H I + μ' (H + Hᵀ); f_i = −σ g_i.
            let [lam, mu] = self.lame[e];
            let mut h = [[z; 3]; 3];
            for r in 0..3 {
                for c in 0..3 {
                    h[r][c] = du[0][r] * g[0][c] + du[1][r] * g[1][c] + du[2][r] * g[2][c];
                }
            }
            let tr = h[0][0] + h[1][1] + h[2][2];
            let mut s = [[z; 3]; 3];
            for r in 0..3 {
                for c in 0..3 {
                    s[r][c] = mu * (h[r][c] + h[c][r]);
                }
                s[r][r] = s[r][r] + lam * tr;
            }
            let to_world = |f: V<T>| {
                let [e1, e2, e3] = fr;
                [
                    f[0] * e1[0] + f[1] * e2[0] + f[2] * e3[0],
                    f[0] * e1[1] + f[1] * e2[1] + f[2] * e3[1],
                    f[0] * e1[2] + f[1] * e2[2] + f[2] * e3[2],
                ]
            };
            let mut fw = [[z; 3]; 4];
            let mut gw = [[z; 3]; 4];
            for i in 0..3 {
                let fl = [
                    -(s[0][0] * g[i][0] + s[0][1] * g[i][1] + s[0][2] * g[i][2]),
                    -(s[1][0] * g[i][0] + s[1][1] * g[i][1] + s[1][2] * g[i][2]),
                    -(s[2][0] * g[i][0] + s[2][1] * g[i][1] + s[2][2] * g[i][2]),
                ];
                fw[i + 1] = to_world(fl);
                gw[i + 1] = to_world(g[i]);
            }
            for c in 0..3 {
                fw[0][c] = -(fw[1][c] + fw[2][c] + fw[3][c]);
                gw[0][c] = -(gw[1][c] + gw[2][c] + gw[3][c]);
            }
            for a in 0..4 {
                let fa = &mut self.f_el[ids[a]];
                for c in 0..3 {
                    fa[c] = fa[c] + fw[a][c];
                }
            }
            let sl = &self.slots[e];
            for a in 0..4 {
                for b in 0..4 {
                    let (gi, gj) = (gw[a], gw[b]);
                    let gg = dot(gi, gj);
                    let blk = &mut self.k.vals[sl[4 * a + b] as usize];
                    for r in 0..3 {
                        for c in 0..3 {
                            let mut v = lam * gi[r] * gj[c] + mu * gj[r] * gi[c];
                            if r == c {
                                v = v + mu * gg;
                            }
                            blk[3 * r + c] = blk[3 * r + c] + v;
                        }
                    }
                }
            }
        }
    }
}

impl Model<f64> {
    /// One implicit Euler step, the linear system solved to `s.tolerance`.
    #[allow(clippy::needless_range_loop)] // node loops over several parallel arrays
    pub fn step(&mut self, s: &RefSettings) -> RefStats {
        let n = self.nodes();
        let h = s.dt;
        let mc = 1.0 + h * s.rayleigh_mass;
        let kc = h * (s.rayleigh_stiffness + h);
        self.assemble();
        let mut kv = vec![[0.0; 3]; n];
        self.k.mul(&self.v, &mut kv);
        let mut b = vec![[0.0; 3]; n];
        for i in 0..n {
            if self.fixed[i] {
                continue;
            }
            let m = self.mass[i];
            for c in 0..3 {
                let f = self.f_el[i][c] + m * s.gravity[c] - s.rayleigh_mass * m * self.v[i][c];
                b[i][c] = h * f - kc * kv[i][c];
            }
        }
        // Mass-preconditioned CG on the free nodes, from Δv = 0.
        let free = |i: usize, x: [f64; 3]| if self.fixed[i] { [0.0; 3] } else { x };
        let mut x = vec![[0.0; 3]; n];
        let mut r = b.clone();
        let inv_p: Vec<f64> = self.mass.iter().map(|m| 1.0 / (mc * m)).collect();
        let mut z: Vec<[f64; 3]> = (0..n)
            .map(|i| free(i, r[i].map(|v| v * inv_p[i])))
            .collect();
        let mut d = z.clone();
        let mut q = vec![[0.0; 3]; n];
        let norm = |v: &[[f64; 3]]| v.iter().map(|a| dot(*a, *a)).sum::<f64>().sqrt();
        let b_norm = norm(&b);
        let mut rz: f64 = (0..n).map(|i| dot(r[i], z[i])).sum();
        let mut stats = RefStats::default();
        if b_norm > 0.0 {
            for it in 0..100_000 {
                let rn = norm(&r) / b_norm;
                stats.residual = rn;
                if rn <= s.tolerance {
                    break;
                }
                self.k.mul(&d, &mut q);
                for i in 0..n {
                    q[i] = free(
                        i,
                        [
                            mc * self.mass[i] * d[i][0] + kc * q[i][0],
                            mc * self.mass[i] * d[i][1] + kc * q[i][1],
                            mc * self.mass[i] * d[i][2] + kc * q[i][2],
                        ],
                    );
                }
                let dq: f64 = (0..n).map(|i| dot(d[i], q[i])).sum();
                let alpha = rz / dq;
                for i in 0..n {
                    for c in 0..3 {
                        x[i][c] += alpha * d[i][c];
                        r[i][c] -= alpha * q[i][c];
                    }
                    z[i] = free(i, r[i].map(|v| v * inv_p[i]));
                }
                let rz_new: f64 = (0..n).map(|i| dot(r[i], z[i])).sum();
                let beta = rz_new / rz;
                rz = rz_new;
                for i in 0..n {
                    for c in 0..3 {
                        d[i][c] = z[i][c] + beta * d[i][c];
                    }
                }
                stats.iterations = it + 1;
            }
        }
        for i in 0..n {
            for c in 0..3 {
                self.v[i][c] += x[i][c];
                self.u[i][c] += h * self.v[i][c];
            }
        }
        stats
    }
}
