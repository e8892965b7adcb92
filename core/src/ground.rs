//! Unilateral ground contact: nodes stay on the side `n·x ≥ offset` of a plane.
//!
//! Each step, a node that touches or is below the plane and is not moving
//! away is *held*: its normal velocity change is prescribed so that it ends
//! the step on the plane, and Baraff–Witkin filtering removes the normal from
//! the CG directions (an exact constraint, no penalty spring, so it is stable
//! at any time step). After the solve, the unfiltered residual gives each held
//! node's contact force; a node the plane would have to *pull* is released for
//! the next step. Nodes that were free but end a step below the plane lose
//! their inward normal velocity (a perfectly inelastic, frictionless
//! contact) and keep their position for that step.
//!
//! The next step holds them and pushes them out within its solve, so that
//! their neighbours move along: moved onto the plane alone after the solve,
//! a node would strain its elements by the depth it reached, energy that a
//! stiff body over long steps holds in spikes many times what a fall puts
//! in. The push's velocity only corrects positions: a second solve finds
//! the body's response to the push alone, and the step's velocity leaves it
//! out (a split impulse), so that a pushed node does not bounce off the
//! plane again. A landing node thus reads below the plane for one step, by
//! at most the distance it travels in that step.
//!
//! A body that no fixed node holds is also treated as a whole, where a
//! truncated solve cannot spread a contact through it (`step.rs`):
//! * **Carried.** A step with held nodes starts its solve from the rigid
//!   motion that gives them their prescribed normal velocity, not from the
//!   free fall: a resting body starts at rest and the solve finds its sag.
//! * **Landing.** Where a step ends with nodes below the plane, the body's
//!   rigid motion stops their inward velocity before each node still below
//!   is stopped alone (an inelastic rigid impact, never adding energy), for
//!   the share of the body that a pressure wave crosses in one step: all of
//!   a stiff body over a long step, none of a body without stiffness.

use crate::error::Parameter;
use crate::math::{axpy, dot, is_finite3, normalize, Vec3};

/// A ground plane: points with `normal · x ≥ offset` are outside it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Plane {
    /// Outward normal (any length > 0; normalised when set).
    pub normal: Vec3,
    /// Offset along the normal (m).
    pub offset: f32,
}

impl Plane {
    /// The ground `z ≥ 0`.
    pub const Z_UP: Self = Self {
        normal: [0.0, 0.0, 1.0],
        offset: 0.0,
    };

    /// The same plane with a unit normal, or `None` if it is not finite or the
    /// normal is zero. The offset is rescaled so the plane does not move.
    #[must_use]
    pub fn normalized(&self) -> Option<Plane> {
        if !is_finite3(self.normal) || !self.offset.is_finite() {
            return None;
        }
        let len2 = dot(self.normal, self.normal);
        let n = normalize(self.normal)?;
        let offset = self.offset / crate::math::sqrt(len2);
        offset.is_finite().then_some(Plane { normal: n, offset })
    }

    /// Signed distance of `x` from the plane (m), positive outside.
    #[inline]
    #[must_use]
    pub(crate) fn distance(&self, x: Vec3) -> f32 {
        dot(self.normal, x) - self.offset
    }

    /// The velocity change to prescribe along the normal for a held node at
    /// signed distance `dist` with velocity `v`, so that it ends a step of
    /// length `h` on the plane: `n·(v + Δv) = −dist / h`.
    #[inline]
    #[must_use]
    pub(crate) fn held_dv(&self, dist: f32, v: Vec3, h: f32) -> f32 {
        -dist / h - dot(self.normal, v)
    }

    /// Removes the normal component of `z` (the Baraff–Witkin filter).
    #[inline]
    #[must_use]
    pub(crate) fn filter(&self, z: Vec3) -> Vec3 {
        axpy(z, -dot(self.normal, z), self.normal)
    }

    /// `z` with its normal component replaced by `along`.
    #[inline]
    #[must_use]
    pub(crate) fn with_normal(&self, z: Vec3, along: f32) -> Vec3 {
        axpy(self.filter(z), along, self.normal)
    }

    /// Stops a node that ended a step below the plane: removes its inward
    /// normal velocity and keeps its position, which the next step's held
    /// rule takes back onto the plane. Returns the new velocity.
    #[inline]
    #[must_use]
    pub(crate) fn stop(&self, x: Vec3, v: Vec3) -> Vec3 {
        let vn = dot(self.normal, v);
        if self.distance(x) >= 0.0 || vn >= 0.0 {
            return v;
        }
        axpy(v, -vn, self.normal)
    }

    /// Whether a held node at `x`, at signed distance `dist`, is below the
    /// plane by more than the round-off of `dist` itself (4 ε times the
    /// magnitudes it is summed from): a node the step must push out, not
    /// one that rests on the plane.
    #[inline]
    #[must_use]
    pub(crate) fn pushes(&self, x: Vec3, dist: f32) -> bool {
        let size = self.normal[0].abs() * x[0].abs()
            + self.normal[1].abs() * x[1].abs()
            + self.normal[2].abs() * x[2].abs()
            + self.offset.abs();
        dist < -4.0 * f32::EPSILON * size
    }
}

impl<S: crate::Storage> crate::Scene<S> {
    /// Sets (or removes, with `None`) the ground plane. Nodes already below it
    /// are pushed out over the next steps.
    pub fn set_ground(&mut self, plane: Option<Plane>) -> Result<(), crate::Error> {
        self.hdr.ground = match plane {
            Some(p) => Some(p.normalized().ok_or(crate::Error::InvalidParameter {
                parameter: Parameter::Ground,
            })?),
            None => None,
        };
        self.hdr.forget_energy();
        Ok(())
    }

    /// The ground plane (normalised), if any.
    #[must_use]
    pub fn ground(&self) -> Option<Plane> {
        self.hdr.ground
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalisation_keeps_the_plane() {
        let p = Plane {
            normal: [0.0, 0.0, 2.0],
            offset: 1.0,
        }
        .normalized()
        .unwrap();
        assert_eq!(p.normal, [0.0, 0.0, 1.0]);
        assert_eq!(p.offset, 0.5);
        assert!(Plane {
            normal: [0.0; 3],
            offset: 0.0
        }
        .normalized()
        .is_none());
        assert!(Plane {
            normal: [0.0, 0.0, 1.0],
            offset: f32::NAN
        }
        .normalized()
        .is_none());
    }

    #[test]
    fn a_node_below_keeps_its_position_and_loses_its_inward_velocity() {
        let p = Plane::Z_UP;
        assert_eq!(p.stop([0.0, 0.0, -0.5], [1.0, 0.0, -2.0]), [1.0, 0.0, 0.0]);
        // Moving out already, or above the plane: unchanged.
        assert_eq!(p.stop([0.0, 0.0, -0.5], [1.0, 0.0, 2.0]), [1.0, 0.0, 2.0]);
        assert_eq!(p.stop([0.0, 0.0, 0.5], [1.0, 0.0, -2.0]), [1.0, 0.0, -2.0]);
    }

    #[test]
    fn only_a_depth_beyond_round_off_is_pushed_out() {
        let p = Plane {
            normal: [0.0, 0.0, 1.0],
            offset: 1.0,
        };
        // One ulp below a plane at z = 1 is round-off; a micrometre is not.
        let x = [0.0, 0.0, 1.0 - f32::EPSILON];
        assert!(!p.pushes(x, p.distance(x)));
        let x = [0.0, 0.0, 1.0 - 1e-6];
        assert!(p.pushes(x, p.distance(x)));
        assert!(!p.pushes([0.0, 0.0, 1.0], 0.0));
    }
}
