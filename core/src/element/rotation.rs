//! The rotation closest to a matrix `F`: the proper rotation `R` that
//! maximises `tr(Rᵀ F)`. For `det F > 0` that is the polar factor; for a
//! reflected `F` it is `U diag(1, 1, −1) Vᵀ`, so `R` never becomes a
//! reflection. The `Polar` element turns with it, and the two-level
//! preconditioner turns each aggregate with it.
//!
//! It is found by Newton's method on SO(3), warm-started from the previous
//! step's rotation (stored as a quaternion). With `M = Rᵀ F` and the
//! right perturbation `R ← R exp([θ]×)`,
//!
//! ```text
//! tr(Rᵀ F)(θ) ≈ tr M − θ·w − ½ θᵀ (tr(M) I − sym M) θ
//! w = (M₁₂ − M₂₁, M₂₀ − M₀₂, M₀₁ − M₁₀)        (zero when M is symmetric)
//! θ = −(tr(M) I − sym M)⁻¹ w                    (Newton step)
//! ```
//!
//! At the maximum the Hessian `tr(M) I − sym M` is positive definite; when it
//! is not (far from the solution, or stuck at a saddle or the minimum where
//! `w = 0` too), a half turn about a frame axis that increases `tr(Rᵀ F)` is
//! taken if one exists, else a gradient step `θ = −w / ‖M‖`. Every update
//! increases the objective, so the search cannot cycle.
//! The quaternion update uses `(1, θ/2)` normalised, which needs no trigonometry.

use super::qr::regular;
use crate::math::{det3, dot, solve3, sqrt, Mat3, Real, Vec3};

/// Most Newton iterations per element and step (warm-started, 1–2 are typical).
pub(crate) const MAX_ITERATIONS: usize = 8;

/// One update of the rotation search.
enum Step {
    /// Rotate by the rotation vector `θ` (applied as the quaternion `(1, θ/2)`).
    Turn(Vec3),
    /// Rotate by π about frame axis `k`.
    HalfTurn(usize),
}

/// Identity rotation as a quaternion `(w, x, y, z)`.
pub(crate) const IDENTITY: [f32; 4] = [1.0, 0.0, 0.0, 0.0];

/// Rotation matrix (rows) of the unit quaternion `q = (w, x, y, z)`.
#[inline(always)]
#[must_use]
pub(crate) fn rotation<T: Real>(q: [T; 4]) -> [[T; 3]; 3] {
    let [w, x, y, z] = q;
    let (one, two) = (T::splat(1.0), T::splat(2.0));
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let (xy, xz, yz) = (x * y, x * z, y * z);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    [
        [one - two * (yy + zz), two * (xy - wz), two * (xz + wy)],
        [two * (xy + wz), one - two * (xx + zz), two * (yz - wx)],
        [two * (xz - wy), two * (yz + wx), one - two * (xx + yy)],
    ]
}

/// `Rᵀ F` for rows-stored matrices.
#[inline(always)]
pub(crate) fn rt_times<T: Real>(r: &[[T; 3]; 3], f: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let mut m = [[T::splat(0.0); 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, mij) in row.iter_mut().enumerate() {
            *mij = r[0][i] * f[0][j] + r[1][i] * f[1][j] + r[2][i] * f[2][j];
        }
    }
    m
}

/// `‖F‖²` (Frobenius), summed row by row.
#[inline(always)]
pub(crate) fn norm2<T: Real>(f: &[[T; 3]; 3]) -> T {
    f.iter().flatten().fold(T::splat(0.0), |s, v| s + *v * *v)
}

/// What a Newton iteration needs of `M = Rᵀ F`: the skew vector `w` and
/// `|w|²`, `tr M`, the Hessian `tr(M) I − sym M` and its leading 2×2 minor.
pub(crate) struct Probe<T> {
    pub(crate) w: [T; 3],
    pub(crate) w2: T,
    pub(crate) tr: T,
    pub(crate) h: [[T; 3]; 3],
    pub(crate) minor2: T,
}

#[inline(always)]
pub(crate) fn probe<T: Real>(m: &[[T; 3]; 3]) -> Probe<T> {
    let w = [m[1][2] - m[2][1], m[2][0] - m[0][2], m[0][1] - m[1][0]];
    let tr = m[0][0] + m[1][1] + m[2][2];
    let neg_half = T::splat(-0.5);
    let (s01, s02, s12) = (
        neg_half * (m[0][1] + m[1][0]),
        neg_half * (m[0][2] + m[2][0]),
        neg_half * (m[1][2] + m[2][1]),
    );
    let h = [
        [tr - m[0][0], s01, s02],
        [s01, tr - m[1][1], s12],
        [s02, s12, tr - m[2][2]],
    ];
    Probe {
        w,
        w2: dot(w, w),
        tr,
        minor2: h[0][0] * h[1][1] - h[0][1] * h[0][1],
        h,
    }
}

/// The quaternion product `q ⊗ p`.
#[inline(always)]
pub(crate) fn compose<T: Real>(q: [T; 4], p: [T; 4]) -> [T; 4] {
    let [qw, qx, qy, qz] = q;
    [
        qw * p[0] - (qx * p[1] + qy * p[2] + qz * p[3]),
        qx * p[0] + qw * p[1] + (qy * p[3] - qz * p[2]),
        qy * p[0] + qw * p[2] + (qz * p[1] - qx * p[3]),
        qz * p[0] + qw * p[3] + (qx * p[2] - qy * p[1]),
    ]
}

/// `|n|²` of a quaternion.
#[inline(always)]
pub(crate) fn len2<T: Real>(n: [T; 4]) -> T {
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3]
}

/// `(8 ε ‖F‖)²`: the f32 noise floor of `|w|²` when forming `M`.
#[inline(always)]
pub(crate) fn noise_floor2<T: Real>(norm: T) -> T {
    let a = T::splat(8.0 * f32::EPSILON) * norm;
    a * a
}

/// Updates `q` in place to the rotation closest to `f`; returns `R` and
/// `Rᵀ F` for the final rotation (the caller needs it for the strain).
///
/// Newton from the warm start first (1–2 iterations in a simulation); if it
/// does not end at the maximum (large rotation since the last step, a cold
/// start, an inversion), Horn's quaternion method finds the global maximum
/// and Newton polishes it.
#[must_use]
pub(crate) fn closest_rotation(f: &Mat3, q: &mut [f32; 4]) -> (Mat3, Mat3) {
    let out = newton(f, q);
    if out.2 {
        return (out.0, out.1);
    }
    *q = horn(f, *q);
    let out = newton(f, q);
    (out.0, out.1)
}

/// Horn's closed form: the unit quaternion maximising `tr(R(q)ᵀ F) = qᵀ N q`
/// is the eigenvector of the symmetric 4×4 `N` with the largest eigenvalue,
/// found with cyclic Jacobi rotations (deterministic, always converges).
/// The sign is chosen to agree with `prev`.
#[must_use]
fn horn(f: &Mat3, prev: [f32; 4]) -> [f32; 4] {
    let [[fxx, fxy, fxz], [fyx, fyy, fyz], [fzx, fzy, fzz]] = *f;
    let mut a = [
        [fxx + fyy + fzz, fzy - fyz, fxz - fzx, fyx - fxy],
        [fzy - fyz, fxx - fyy - fzz, fxy + fyx, fxz + fzx],
        [fxz - fzx, fxy + fyx, fyy - fxx - fzz, fyz + fzy],
        [fyx - fxy, fxz + fzx, fyz + fzy, fzz - fxx - fyy],
    ];
    let mut v = [
        [1.0f32, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let scale2 = a.iter().flatten().fold(0.0f32, |s, x| s + x * x);
    for _sweep in 0..12 {
        let off2 = 2.0
            * (a[0][1] * a[0][1]
                + a[0][2] * a[0][2]
                + a[0][3] * a[0][3]
                + a[1][2] * a[1][2]
                + a[1][3] * a[1][3]
                + a[2][3] * a[2][3]);
        if !(off2 > f32::EPSILON * f32::EPSILON * scale2) {
            break;
        }
        jacobi_rotate::<0, 1>(&mut a, &mut v);
        jacobi_rotate::<0, 2>(&mut a, &mut v);
        jacobi_rotate::<0, 3>(&mut a, &mut v);
        jacobi_rotate::<1, 2>(&mut a, &mut v);
        jacobi_rotate::<1, 3>(&mut a, &mut v);
        jacobi_rotate::<2, 3>(&mut a, &mut v);
    }
    let mut best = 0;
    for k in 1..4 {
        if a[k][k] > a[best][best] {
            best = k;
        }
    }
    let mut q = [v[0][best], v[1][best], v[2][best], v[3][best]];
    if q[0] * prev[0] + q[1] * prev[1] + q[2] * prev[2] + q[3] * prev[3] < 0.0 {
        q = [-q[0], -q[1], -q[2], -q[3]];
    }
    let len2 = q.iter().fold(0.0f32, |s, x| s + x * x);
    if !(len2 >= f32::MIN_POSITIVE && len2.is_finite()) {
        return prev;
    }
    let inv = 1.0 / sqrt(len2);
    [q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv]
}

/// One Jacobi rotation zeroing `a[P][R]` of the symmetric `a`; accumulates
/// the rotation into the eigenvector columns of `v`. The indices are
/// constants so that every index is checked at compile time: a firmware
/// build keeps no bounds check (no panicking branch) for them.
fn jacobi_rotate<const P: usize, const R: usize>(a: &mut [[f32; 4]; 4], v: &mut [[f32; 4]; 4]) {
    let (p, r) = (P, R);
    let apr = a[p][r];
    if apr == 0.0 {
        return;
    }
    // θ = (a_rr − a_pp) / (2 a_pr), t = sign(θ) / (|θ| + √(θ² + 1)).
    let theta = (a[r][r] - a[p][p]) / (2.0 * apr);
    let t = if theta.is_finite() {
        let t = 1.0 / (theta.abs() + sqrt(theta * theta + 1.0));
        if theta < 0.0 {
            -t
        } else {
            t
        }
    } else {
        0.0
    };
    let c = 1.0 / sqrt(t * t + 1.0);
    let s = t * c;
    for row in a.iter_mut() {
        let (akp, akr) = (row[p], row[r]);
        row[p] = c * akp - s * akr;
        row[r] = s * akp + c * akr;
    }
    let (ap, ar) = (a[p], a[r]);
    a[p] = core::array::from_fn(|k| c * ap[k] - s * ar[k]);
    a[r] = core::array::from_fn(|k| s * ap[k] + c * ar[k]);
    for row in v.iter_mut() {
        let (vp, vr) = (row[p], row[r]);
        row[p] = c * vp - s * vr;
        row[r] = s * vp + c * vr;
    }
}

/// Newton's method from `q`; returns `R`, `Rᵀ F` and whether it ended at the
/// maximum (skew part at the noise floor with a positive definite Hessian).
#[must_use]
fn newton(f: &Mat3, q: &mut [f32; 4]) -> (Mat3, Mat3, bool) {
    let mut r = rotation(*q);
    let mut m = rt_times(&r, f);
    let norm2 = norm2(f);
    if !regular(norm2) {
        return (r, m, true);
    }
    let norm = sqrt(norm2);
    // Stop at the f32 noise floor of forming M (a few ulps of ‖F‖) or when the
    // skew part stops shrinking.
    let floor2 = noise_floor2(norm);
    let mut last2 = f32::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let Probe {
            w,
            w2,
            tr,
            h,
            minor2,
        } = probe(&m);
        let concave = h[0][0] > 0.0 && minor2 > 0.0 && det3(h[0], h[1], h[2]) > 0.0;
        let step = if concave {
            // Near the maximum: Newton, until the skew part reaches the noise
            // floor or stops shrinking.
            if w2 <= floor2 || w2 >= 0.25 * last2 || !w2.is_finite() {
                return (r, m, w2 <= 64.0 * floor2);
            }
            last2 = w2;
            match solve3(&h, w) {
                Some(t) => Step::Turn([-t[0], -t[1], -t[2]]),
                None => Step::Turn([-w[0] / norm, -w[1] / norm, -w[2] / norm]),
            }
        } else {
            // Far from it, maybe at a saddle or the minimum: a half turn about
            // a frame axis `k` changes tr(RᵀF) to 2 M_kk − tr M; take the best
            // one if it gains, else a gradient step.
            last2 = f32::INFINITY;
            let (k, best) = (0..3)
                .map(|k| (k, 2.0 * m[k][k] - tr))
                .fold((0, f32::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
            if best > tr + 8.0 * f32::EPSILON * norm {
                Step::HalfTurn(k)
            } else if w2 > floor2 && w2.is_finite() {
                Step::Turn([-w[0] / norm, -w[1] / norm, -w[2] / norm])
            } else {
                return (r, m, false);
            }
        };
        // q ← q ⊗ p with p = (1, θ/2) (normalised below) or a half turn (0, e_k).
        let p = match step {
            Step::Turn(t) => [1.0, 0.5 * t[0], 0.5 * t[1], 0.5 * t[2]],
            Step::HalfTurn(k) => {
                let mut p = [0.0; 4];
                if let Some(pk) = p.get_mut(k + 1) {
                    *pk = 1.0;
                }
                p
            }
        };
        let n = compose(*q, p);
        let len2 = len2(n);
        if !regular(len2) {
            return (r, m, false);
        }
        let inv = 1.0 / sqrt(len2);
        *q = [n[0] * inv, n[1] * inv, n[2] * inv, n[3] * inv];
        r = rotation(*q);
        m = rt_times(&r, f);
    }
    (r, m, false)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the formulas
mod tests {
    use super::*;

    fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
        let mut m = [[0.0f32; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
            }
        }
        m
    }

    fn assert_rotation(r: &Mat3) {
        let rtr = rt_times(r, r);
        for i in 0..3 {
            for j in 0..3 {
                // f32 round-off of a normalised quaternion.
                assert!((rtr[i][j] - if i == j { 1.0 } else { 0.0 }).abs() < 1e-5);
            }
        }
        assert!(det3(r[0], r[1], r[2]) > 0.0);
    }

    #[test]
    fn recovers_a_rotation_times_a_stretch() {
        let mut q0 = [0.9f32, 0.3, -0.2, 0.25];
        let n = q0.iter().map(|v| v * v).sum::<f32>().sqrt();
        q0.iter_mut().for_each(|v| *v /= n);
        let rot = rotation(q0);
        let s = [[1.3, 0.1, 0.0], [0.1, 0.8, 0.05], [0.0, 0.05, 1.1]];
        let f = mat_mul(&rot, &s);
        let mut q = IDENTITY;
        let (r, m) = closest_rotation(&f, &mut q);
        assert_rotation(&r);
        for i in 0..3 {
            for j in 0..3 {
                assert!((r[i][j] - rot[i][j]).abs() < 1e-5); // f32 round-off
                assert!((m[i][j] - m[j][i]).abs() < 1e-5); // Rᵀ F symmetric
            }
        }
    }

    #[test]
    fn inverted_gradient_gives_a_proper_rotation() {
        // F = diag(1, 1, −0.5): the closest rotation is the identity.
        let f = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -0.5]];
        let mut q = [0.0, 0.0, 0.0, 1.0]; // start 180° away about z
        let (r, _) = closest_rotation(&f, &mut q);
        assert_rotation(&r);
        // tr(RᵀF) is maximal (1.5) at the identity.
        let tr = r[0][0] * f[0][0] + r[1][1] * f[1][1] + r[2][2] * f[2][2];
        assert!(tr > 1.5 - 1e-4, "tr = {tr}");
    }

    #[test]
    fn zero_gradient_keeps_the_warm_start() {
        let mut q = IDENTITY;
        let (r, _) = closest_rotation(&[[0.0; 3]; 3], &mut q);
        assert_eq!(q, IDENTITY);
        assert_rotation(&r);
    }
}

#[cfg(test)]
mod convergence {
    use super::*;

    /// Large rotations and random (also inverted) stretches from a cold start.
    #[test]
    fn converges_from_identity_for_random_gradients() {
        let mut seed = 12345u32;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed as f32 / u32::MAX as f32) * 2.0 - 1.0
        };
        let mut worst = 0.0f32;
        let mut worst_it = 0;
        for _ in 0..2000 {
            let f = [
                [rnd(), rnd(), rnd()],
                [rnd(), rnd(), rnd()],
                [rnd(), rnd(), rnd()],
            ];
            let mut q = IDENTITY;
            let (_, m) = closest_rotation(&f, &mut q);
            let norm = f.iter().flatten().map(|v| v * v).sum::<f32>().sqrt();
            let skew = ((m[0][1] - m[1][0]).powi(2)
                + (m[1][2] - m[2][1]).powi(2)
                + (m[2][0] - m[0][2]).powi(2))
            .sqrt()
                / norm;
            if skew > worst {
                worst = skew;
                worst_it += 1;
            }
        }
        assert!(worst < 1e-5, "worst relative skew {worst} ({worst_it})");
    }
}

#[cfg(test)]
mod horn_tests {
    use super::*;

    #[test]
    fn horn_recovers_a_pure_rotation() {
        let q0 = [0.5f32, 0.5, -0.5, 0.5];
        let f = rotation(q0);
        let q = horn(&f, IDENTITY);
        for k in 0..4 {
            assert!((q[k] - q0[k]).abs() < 1e-5, "{q:?} vs {q0:?}"); // f32 Jacobi round-off
        }
    }
}
