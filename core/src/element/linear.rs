//! The `Linear` method: small-displacement elasticity with no rotation, the
//! baseline that shows why co-rotation is needed (a rotated body grows).
//!
//! ```text
//! H̃ = Σ (uᵢ − u_a) g0ᵢᵀ,   fᵢ = −σ(H̃) g0ᵢ
//! ```

use super::hform::{energy, grad_h, neg_stress_times, stress};
use super::{ElementForces, Kernel};
use crate::math::{det3, Real, Vec3};

/// Forces, gradients (the rest ones) and energy for displacement differences
/// `du` (m) and rest gradients `g0` (×6V₀, m²), for one element or one
/// element per lane.
#[inline(always)]
#[must_use]
pub(crate) fn kernel<T: Real>(du: &[[T; 3]; 3], g0: &[[T; 3]; 3], lame: [T; 2]) -> Kernel<T> {
    let h = grad_h(du, g0);
    let s = stress(&h, lame);
    Kernel {
        f: [
            neg_stress_times(&s, g0[0]),
            neg_stress_times(&s, g0[1]),
            neg_stress_times(&s, g0[2]),
        ],
        grad: *g0,
        energy: energy(&s, &h),
    }
}

/// Element forces for displacement differences `du` (m), rest gradients `g0`
/// (×6V₀, m²) and current edges `cur` (m, only for the inversion flag).
#[inline]
#[must_use]
pub(crate) fn forces(
    du: &[Vec3; 3],
    cur: &[Vec3; 3],
    g0: &[Vec3; 3],
    lame: [f32; 2],
) -> ElementForces {
    let k = kernel(du, g0, lame);
    ElementForces {
        f: k.f,
        grad: k.grad,
        energy: k.energy,
        inverted: det3(cur[0], cur[1], cur[2]) < 0.0,
    }
}
