//! The `Polar` method: rotation from the polar decomposition of the
//! deformation gradient, with `det R = +1` also for inverted elements.
//!
//! `R` is the rotation closest to `F` — it maximises `tr(Rᵀ F)` over proper
//! rotations. For `det F > 0` that is the polar factor; for an inverted element
//! it is `U diag(1, 1, −1) Vᵀ` (the smallest singular value changes sign), so
//! `R` never becomes a reflection and the element is pushed back through itself.
//!
//! The maximiser is [`closest_rotation`](super::rotation::closest_rotation)
//! (Newton on SO(3), warm-started from the previous step's rotation); the
//! lanes run its regular path together. Converged `R` makes `Rᵀ F`
//! symmetric, which is why the polar method is free of ghost torques even
//! with rest gradients.
//!
//! Without the feature `polar` only the one-element kernel is compiled: the
//! `QrInvertible` method's inverted elements use it.

use super::hform::{energy, grad_h, neg_stress_times, stress};
#[cfg(feature = "polar")]
use super::qr::regular;
use super::rotation::closest_rotation;
#[cfg(feature = "polar")]
use super::rotation::{
    compose, len2, noise_floor2, norm2, probe, rotation, rt_times, MAX_ITERATIONS,
};
#[cfg(feature = "polar")]
use super::Batch;
use super::{ElementForces, Kernel};
#[cfg(feature = "polar")]
use crate::lanes::LANES;
use crate::math::{det3, mat_vec, Real, Vec3};

/// [`closest_rotation`] of every lane at once, for the lanes where it takes
/// its regular path: Newton from the warm start `q`, every iteration on the
/// concave side with a solvable Newton system, ending at the maximum. Each
/// such lane goes through exactly the operations of the scalar Newton search, so its `R`,
/// `Rᵀ F` and new `q` are the bits of [`closest_rotation`]. The other lanes
/// (a zero `F`, a half turn or gradient step, Horn's method) are marked
/// irregular, for the caller to redo alone from the same `q`.
#[cfg(feature = "polar")]
#[inline(always)]
#[must_use]
pub(crate) fn closest_rotation_lanes(f: &[[Batch; 3]; 3], q: [Batch; 4]) -> LaneRotations {
    let mut q = q;
    let mut r = rotation(q);
    let mut m = rt_times(&r, f);
    let norm2 = norm2(f);
    let floor2 = noise_floor2(norm2.root());
    let mut regular_lane = [false; LANES];
    for (g, n2) in regular_lane.iter_mut().zip(norm2.0) {
        *g = regular(n2);
    }
    // Lanes still iterating; each stops where `newton` returns.
    let mut active = regular_lane;
    let mut last2 = [f32::INFINITY; LANES];
    for _ in 0..MAX_ITERATIONS {
        let p = probe(&m);
        let det = det3(p.h[0], p.h[1], p.h[2]);
        for (j, (a, g)) in active.iter_mut().zip(regular_lane.iter_mut()).enumerate() {
            let at = |v: Batch| v.0.get(j).copied().unwrap_or(0.0);
            let (w2, floor2) = (at(p.w2), at(floor2));
            let last = last2.get(j).copied().unwrap_or(f32::INFINITY);
            if !*a {
                continue;
            }
            let concave = at(p.h[0][0]) > 0.0 && at(p.minor2) > 0.0 && at(det) > 0.0;
            if !concave {
                (*a, *g) = (false, false);
            } else if w2 <= floor2 || w2 >= 0.25 * last || !w2.is_finite() {
                (*a, *g) = (false, w2 <= 64.0 * floor2);
            } else if let Some(l) = last2.get_mut(j) {
                *l = w2;
            }
        }
        if !active.contains(&true) {
            break;
        }
        let (t, det, limit) = crate::math::cramer3(&p.h, p.w);
        let half = Batch::splat(0.5);
        let n = compose(
            q,
            [Batch::splat(1.0), half * -t[0], half * -t[1], half * -t[2]],
        );
        let len2 = len2(n);
        for (j, (a, g)) in active.iter_mut().zip(regular_lane.iter_mut()).enumerate() {
            let at = |v: Batch| v.0.get(j).copied().unwrap_or(0.0);
            let solved = at(det).abs() > at(limit) && at(det).is_finite();
            if *a && !(solved && regular(at(len2))) {
                (*a, *g) = (false, false);
            }
        }
        let inv = Batch::splat(1.0) / len2.root();
        let q_new = [n[0] * inv, n[1] * inv, n[2] * inv, n[3] * inv];
        let r_new = rotation(q_new);
        let m_new = rt_times(&r_new, f);
        q = Batch::select(&active, q_new, q);
        r = core::array::from_fn(|i| Batch::select(&active, r_new[i], r[i]));
        m = core::array::from_fn(|i| Batch::select(&active, m_new[i], m[i]));
    }
    // Still iterating after the last iteration: `newton` gives up, Horn's
    // method follows.
    for (g, a) in regular_lane.iter_mut().zip(active) {
        *g &= !a;
    }
    LaneRotations {
        r,
        m,
        q,
        regular: regular_lane,
    }
}

/// What [`closest_rotation_lanes`] returns, per lane.
#[cfg(feature = "polar")]
pub(crate) struct LaneRotations {
    /// The rotation `R` (rows).
    pub(crate) r: [[Batch; 3]; 3],
    /// `Rᵀ F`.
    pub(crate) m: [[Batch; 3]; 3],
    /// `R` as a unit quaternion `(w, x, y, z)`: the next warm start.
    pub(crate) q: [Batch; 4],
    /// Lanes that took the regular path; the others must be redone alone.
    pub(crate) regular: [bool; LANES],
}

/// Element forces of the polar method.
///
/// `cur` and `rest` are the current and rest edges `b−a, c−a, d−a` (m), `g0`
/// the rest world gradients (×6V₀, m²), `q` the warm-start rotation.
///
/// ```text
/// F̃  = Σ eᵢ g0ᵢᵀ,   F̃₀ = Σ rᵢ g0ᵢᵀ      (both 6V₀ F; F̃₀ = 6V₀ I up to round-off)
/// R  = closest rotation to F̃
/// H̃  = Rᵀ F̃ − F̃₀                         (unrotated displacement gradient)
/// fᵢ = R (−σ(H̃) g0ᵢ),   gᵢ = R g0ᵢ
/// ```
#[inline]
#[must_use]
pub(crate) fn forces(
    cur: &[Vec3; 3],
    rest: &[Vec3; 3],
    g0: &[Vec3; 3],
    lame: [f32; 2],
    q: &mut [f32; 4],
) -> ElementForces {
    let f = grad_h(cur, g0);
    let (r, m) = closest_rotation(&f, q);
    let k = kernel(&r, &m, rest, g0, lame);
    ElementForces {
        f: k.f,
        grad: k.grad,
        energy: k.energy,
        inverted: det3(cur[0], cur[1], cur[2]) < 0.0,
    }
}

/// [`forces`] once the rotation `r` and `m = Rᵀ F̃` are known, for one
/// element or one per lane.
#[inline(always)]
#[must_use]
pub(crate) fn kernel<T: Real>(
    r: &[[T; 3]; 3],
    m: &[[T; 3]; 3],
    rest: &[[T; 3]; 3],
    g0: &[[T; 3]; 3],
    lame: [T; 2],
) -> Kernel<T> {
    let f0 = grad_h(rest, g0);
    let mut h = *m;
    for (hr, f0r) in h.iter_mut().zip(f0.iter()) {
        for (hij, f0ij) in hr.iter_mut().zip(f0r.iter()) {
            *hij = *hij - *f0ij;
        }
    }
    let s = stress(&h, lame);
    let local = [
        neg_stress_times(&s, g0[0]),
        neg_stress_times(&s, g0[1]),
        neg_stress_times(&s, g0[2]),
    ];
    Kernel {
        f: [
            mat_vec(r, local[0]),
            mat_vec(r, local[1]),
            mat_vec(r, local[2]),
        ],
        grad: [mat_vec(r, g0[0]), mat_vec(r, g0[1]), mat_vec(r, g0[2])],
        energy: energy(&s, &h),
    }
}
