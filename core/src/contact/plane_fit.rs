//! The rigid motions a frictionless plane can give a body, fitted to
//! normal velocities at nodes: the carried guess, the lift and the impact.

use crate::math::{axpy, cross, dot, is_finite3, scale, solve3, sub, Vec3};
use crate::rigid::Rigid;

/// The rigid motions a frictionless plane can give a body: a velocity
/// `a n` along its normal and a rotation `θ × (p − c)` about an axis in the
/// plane (it exerts no tangential force and no torque about its normal).
/// [`PlaneFit::add`] collects, per node, the normal value `target` the
/// motion should take at `p`; [`PlaneFit::solve`] gives the motion whose
/// normal values fit the targets best in the mass-weighted least-squares
/// sense. Where the targets do not fix all three parameters (one or two
/// nodes), a small multiple of the motion's kinetic energy, added to the
/// misfit, picks the motion of least kinetic energy: for a single node,
/// the rigid body's response to an impulse there.
#[derive(Clone, Copy)]
pub(crate) struct PlaneFit {
    pub(crate) n: Vec3,
    /// Two unit vectors spanning the plane, with `n` a right-handed frame.
    t: [Vec3; 2],
    c: Vec3,
    /// `Σ m φ φᵀ` and `Σ m φ target`, `φ = (1, t₀·s, t₁·s)`, `s = (p − c) × n`.
    ata: crate::math::Mat3,
    atb: Vec3,
    /// `Σ m` of the nodes added.
    mass: f32,
}

/// Two orthogonal unit tangents of the plane with unit normal `n`: the
/// coordinate axis least aligned with `n`, crossed with it, and `n` crossed
/// with that.
pub(crate) fn tangents(n: Vec3) -> (Vec3, Vec3) {
    let e = if n[0].abs() <= n[1].abs() && n[0].abs() <= n[2].abs() {
        [1.0, 0.0, 0.0]
    } else if n[1].abs() <= n[2].abs() {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let t0 = crate::math::normalize(cross(n, e)).unwrap_or([0.0; 3]);
    (t0, cross(n, t0))
}

impl PlaneFit {
    pub(crate) fn new(n: Vec3, c: Vec3) -> Self {
        let (t0, t1) = tangents(n);
        Self {
            n,
            t: [t0, t1],
            c,
            ata: [[0.0; 3]; 3],
            atb: [0.0; 3],
            mass: 0.0,
        }
    }

    fn row(&self, p: Vec3) -> Vec3 {
        let s = cross(sub(p, self.c), self.n);
        [1.0, dot(self.t[0], s), dot(self.t[1], s)]
    }

    pub(crate) fn add(&mut self, p: Vec3, m: f32, target: f32) {
        let phi = self.row(p);
        for (row, pi) in self.ata.iter_mut().zip(phi) {
            for (a, pj) in row.iter_mut().zip(phi) {
                *a += m * pi * pj;
            }
        }
        self.atb = axpy(self.atb, m * target, phi);
        self.mass += m;
    }

    /// The fitted motion `(a, θ)`, `None` without nodes or for a singular
    /// system. `body` gives the kinetic-energy weight: `½ (M a² + θᵀ I θ)`,
    /// added with the factor `1e-3 · Σm / M`, small enough to leave a
    /// determined fit within 0.1 % and large enough for f32 to resolve it.
    pub(crate) fn solve(&self, body: &Rigid) -> Option<(f32, Vec3)> {
        if !(self.mass > 0.0) {
            return None;
        }
        let w = 1e-3 * self.mass * body.inv_mass;
        let mut m = self.ata;
        if let (Some(row), Some(inertia)) = (m.get_mut(0), body.inertia.as_ref()) {
            if let Some(a) = row.get_mut(0) {
                *a += w / body.inv_mass;
            }
            let it = [
                crate::math::mat_vec(inertia, self.t[0]),
                crate::math::mat_vec(inertia, self.t[1]),
            ];
            for (i, ti) in self.t.iter().enumerate() {
                for (j, itj) in it.iter().enumerate() {
                    if let Some(a) = m.get_mut(i + 1).and_then(|r| r.get_mut(j + 1)) {
                        *a += w * dot(*ti, *itj);
                    }
                }
            }
        }
        let x = solve3(&m, self.atb)?;
        let theta = axpy(scale(self.t[0], x[1]), x[2], self.t[1]);
        (x[0].is_finite() && is_finite3(theta)).then_some((x[0], theta))
    }

    /// The motion `(a, θ)` at `p`.
    #[inline(always)]
    pub(crate) fn at(&self, p: Vec3, (a, theta): (f32, Vec3)) -> Vec3 {
        axpy(cross(theta, sub(p, self.c)), a, self.n)
    }
}
