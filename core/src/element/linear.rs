//! The `Linear` method: small-displacement elasticity with no rotation, the
//! baseline that shows why co-rotation is needed (a rotated body grows).
//!
//! ```text
//! H̃ = Σ (uᵢ − u_a) g0ᵢᵀ,   fᵢ = −σ(H̃) g0ᵢ
//! ```

use super::hform::{energy, grad_h, neg_stress_times, stress};
use super::ElementForces;
use crate::math::{det3, Vec3};

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
    let h = grad_h(du, g0);
    let s = stress(&h, lame);
    ElementForces {
        f: [
            neg_stress_times(&s, g0[0]),
            neg_stress_times(&s, g0[1]),
            neg_stress_times(&s, g0[2]),
        ],
        grad: *g0,
        energy: energy(&s, &h),
        inverted: det3(cur[0], cur[1], cur[2]) < 0.0,
    }
}
