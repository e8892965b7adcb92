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
//! truncated solve cannot spread a contact through it (`contact::carry`, `contact::impact`):
//! * **Carried.** A step with held nodes starts its solve from the rigid
//!   motion that gives them their prescribed normal velocity, not from the
//!   free fall: a resting body starts at rest and the solve finds its sag.
//! * **Landing.** Where a step ends with nodes below the plane, the body's
//!   rigid motion stops their inward velocity before each node still below
//!   is stopped alone (an inelastic rigid impact, never adding energy), for
//!   the share of the body that a pressure wave crosses in one step: all of
//!   a stiff body over a long step, none of a body without stiffness.

use crate::math::{axpy, dot, is_finite3, normalize, Vec3};
#[cfg(feature = "friction")]
use crate::math::{scale, sub};

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

    /// The rounding of the signed distance `normal · x − offset` of a point
    /// `x` (unit normal): 4 ε times the magnitudes it is summed from,
    /// `|x|₁ + |offset|`. A node within it of the plane lies on it.
    #[inline(always)]
    pub(crate) fn rounding(&self, x: Vec3) -> f32 {
        4.0 * f32::EPSILON * (x[0].abs() + x[1].abs() + x[2].abs() + self.offset.abs())
    }

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
}

/// Coulomb friction between the body and an obstacle (the ground, a probe):
/// a contact's tangential impulse is at most `μ` times its normal one.
///
/// * **Sticking.** A node that the obstacle holds and that does not slide
///   on it moves with the obstacle: its tangential velocity is prescribed
///   within the implicit step, like the normal, so a body at rest on a
///   slope stays exactly at rest, without creep or jitter. It keeps
///   sticking while its contact's tangential impulse, from the residual, is
///   within `static_coefficient` times the normal one.
/// * **Sliding.** Beyond that the node slides from the next step: a force of
///   `kinetic_coefficient` times its last normal force, against its sliding
///   velocity, in the step's solve. A node whose sliding the force stops
///   loses what is left of its sliding velocity and sticks again.
///
/// Both coefficients 0 ([`Friction::NONE`], the default) is a frictionless
/// contact, whose step is the same, bit for bit, as without the feature.
#[cfg(feature = "friction")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Friction {
    stick: f32,
    slide: f32,
}

#[cfg(feature = "friction")]
impl Friction {
    /// No friction.
    pub const NONE: Self = Self {
        stick: 0.0,
        slide: 0.0,
    };

    /// Coulomb friction with a static coefficient `static_coefficient` (the
    /// ratio of tangential to normal impulse below which a contact sticks)
    /// and a kinetic one `kinetic_coefficient` (the ratio while it slides).
    /// Both must be finite and ≥ 0, the static one at least the kinetic
    /// one, and the kinetic one > 0 if the static one is (a contact that
    /// slips slides on by its kinetic force): [`Parameter::Friction`](crate::Parameter::Friction)
    /// otherwise.
    pub fn new(static_coefficient: f32, kinetic_coefficient: f32) -> Result<Self, crate::Error> {
        let ok = static_coefficient.is_finite()
            && kinetic_coefficient.is_finite()
            && kinetic_coefficient >= 0.0
            && static_coefficient >= kinetic_coefficient
            && (kinetic_coefficient > 0.0 || static_coefficient == 0.0);
        if !ok {
            return Err(crate::Error::InvalidParameter {
                parameter: crate::error::Parameter::Friction,
            });
        }
        Ok(Self {
            stick: static_coefficient,
            slide: kinetic_coefficient,
        })
    }

    /// One coefficient `mu` for both sticking and sliding.
    pub fn coulomb(mu: f32) -> Result<Self, crate::Error> {
        Self::new(mu, mu)
    }

    /// The static coefficient.
    #[must_use]
    pub fn static_coefficient(&self) -> f32 {
        self.stick
    }

    /// The kinetic coefficient.
    #[must_use]
    pub fn kinetic_coefficient(&self) -> f32 {
        self.slide
    }

    /// Whether a contact sticks at all (a static coefficient > 0).
    #[inline(always)]
    pub(crate) fn sticks(&self) -> bool {
        self.stick > 0.0
    }
}

/// The half-space a node in contact must end a step in, `normal · x ≥
/// offset`, and how far its plane moves out along the normal over the step
/// (`lift`, m): a node's distance from the plane at the step's start is its
/// distance at the end plus `lift`. The ground's plane does not move; a
/// probe's does ([`crate::Probe`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Contact {
    /// Unit normal, out of the obstacle.
    pub(crate) normal: Vec3,
    pub(crate) offset: f32,
    pub(crate) lift: f32,
    /// How far the obstacle moves over the step where it holds the node
    /// (m): a sticking node moves as far along the plane.
    #[cfg(feature = "friction")]
    pub(crate) travel: Vec3,
    #[cfg(feature = "friction")]
    pub(crate) friction: Friction,
}

impl Contact {
    /// The ground's plane, which does not move (frictionless; the step
    /// gives held nodes the ground's friction).
    #[inline(always)]
    pub(crate) fn still(g: Plane) -> Self {
        Self {
            normal: g.normal,
            offset: g.offset,
            lift: 0.0,
            #[cfg(feature = "friction")]
            travel: [0.0; 3],
            #[cfg(feature = "friction")]
            friction: Friction::NONE,
        }
    }

    /// Signed distance of `x` from the plane at the step's end (m),
    /// positive outside.
    #[inline]
    #[must_use]
    pub(crate) fn distance(&self, x: Vec3) -> f32 {
        dot(self.normal, x) - self.offset
    }

    /// Whether a node with velocity `v` at the end distance `dist` is held:
    /// it touches or is inside the plane and does not move away from it
    /// faster than the plane moves (`lift / h`), beyond the rounding of
    /// `n·v` (4 ε times the magnitudes it is summed from). A node that
    /// [`Contact::stop`] left inside a tilted plane or a probe keeps a
    /// normal velocity of that rounding, of either sign; without the
    /// allowance half of them would go free and sink further in.
    #[inline]
    #[must_use]
    pub(crate) fn holds(&self, dist: f32, v: Vec3, h: f32) -> bool {
        let away = dot(self.normal, v) - self.lift / h;
        let size = v[0].abs() + v[1].abs() + v[2].abs() + (self.lift / h).abs();
        dist <= 0.0 && away <= 4.0 * f32::EPSILON * size
    }

    /// The velocity change to prescribe along the normal for a held node at
    /// end distance `dist` with velocity `v`, so that it ends a step of
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

    /// The velocity change to prescribe to a sticking node held at end
    /// distance `dist` with velocity `v`: along the plane, to the
    /// obstacle's velocity; along the normal, [`Contact::held_dv`].
    #[cfg(feature = "friction")]
    #[inline]
    #[must_use]
    pub(crate) fn stuck_dv(&self, dist: f32, v: Vec3, h: f32) -> Vec3 {
        self.with_normal(
            sub(scale(self.travel, 1.0 / h), v),
            self.held_dv(dist, v, h),
        )
    }

    /// The velocity along the plane of a node with velocity `v`, relative
    /// to the obstacle's over a step of length `h`.
    #[cfg(feature = "friction")]
    #[inline]
    #[must_use]
    pub(crate) fn sliding(&self, v: Vec3, h: f32) -> Vec3 {
        self.filter(sub(v, scale(self.travel, 1.0 / h)))
    }

    /// The kinetic friction force (N) for the next step of a node that
    /// stuck in a step of length `h` with the contact impulse `impulse`
    /// (the obstacle's on the node): zero while the impulse is within the
    /// static cone (the node sticks on), else the kinetic force along the
    /// tangential impulse (the node slides).
    #[cfg(feature = "friction")]
    #[inline]
    #[must_use]
    pub(crate) fn drag_after_stick(&self, impulse: Vec3, h: f32) -> Vec3 {
        let press = dot(self.normal, impulse);
        let t = self.filter(impulse);
        let cone = self.friction.stick * press;
        if !(press > 0.0) || dot(t, t) <= cone * cone {
            return [0.0; 3];
        }
        self.drag(t, press, h)
    }

    /// The kinetic friction force (N) along `along` (a direction in the
    /// plane, any length > 0; zero otherwise) for a node that the obstacle
    /// pressed with the normal impulse `press` over a step of length `h`:
    /// `μk press / h`, zero for `press ≤ 0`.
    #[cfg(feature = "friction")]
    #[inline]
    #[must_use]
    pub(crate) fn drag(&self, along: Vec3, press: f32, h: f32) -> Vec3 {
        let size = crate::math::sqrt(dot(along, along));
        if !(press > 0.0 && size > 0.0) {
            return [0.0; 3];
        }
        scale(along, self.friction.slide * press / (h * size))
    }

    /// Stops a node that ended a step inside the plane: removes its normal
    /// velocity into the obstacle, relative to the plane's (`lift / h`),
    /// and keeps its position, which the next step's held rule takes back
    /// onto the plane. Returns the new velocity.
    #[inline]
    #[must_use]
    pub(crate) fn stop(&self, x: Vec3, v: Vec3, h: f32) -> Vec3 {
        let vn = dot(self.normal, v) - self.lift / h;
        if self.distance(x) >= 0.0 || vn >= 0.0 {
            return v;
        }
        axpy(v, -vn, self.normal)
    }

    /// The distance below the plane at the step's start that a held node at
    /// `x` must be pushed out by, or `None` for a node within the round-off
    /// of its distance (4 ε times the magnitudes it is summed from) of the
    /// plane or outside it: one that rests on the plane, or that the plane
    /// reaches only by moving during the step.
    #[inline]
    #[must_use]
    pub(crate) fn push(&self, x: Vec3) -> Option<f32> {
        let dist = self.distance(x) + self.lift;
        let size = self.normal[0].abs() * x[0].abs()
            + self.normal[1].abs() * x[1].abs()
            + self.normal[2].abs() * x[2].abs()
            + (self.offset - self.lift).abs();
        (dist < -4.0 * f32::EPSILON * size).then_some(dist)
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
        let p = Contact::still(Plane::Z_UP);
        let h = 0.01;
        assert_eq!(
            p.stop([0.0, 0.0, -0.5], [1.0, 0.0, -2.0], h),
            [1.0, 0.0, 0.0]
        );
        // Moving out already, or above the plane: unchanged.
        assert_eq!(
            p.stop([0.0, 0.0, -0.5], [1.0, 0.0, 2.0], h),
            [1.0, 0.0, 2.0]
        );
        assert_eq!(
            p.stop([0.0, 0.0, 0.5], [1.0, 0.0, -2.0], h),
            [1.0, 0.0, -2.0]
        );
        // A plane moving out at 1 m/s gives a node inside it its speed.
        let moving = Contact { lift: h, ..p };
        assert_eq!(
            moving.stop([0.0, 0.0, -0.5], [1.0, 0.0, 0.0], h),
            [1.0, 0.0, 1.0]
        );
    }

    #[test]
    fn only_a_depth_beyond_round_off_is_pushed_out() {
        let p = Contact::still(Plane {
            normal: [0.0, 0.0, 1.0],
            offset: 1.0,
        });
        // One ulp below a plane at z = 1 is round-off; a micrometre is not.
        assert!(p.push([0.0, 0.0, 1.0 - f32::EPSILON]).is_none());
        assert!(p.push([0.0, 0.0, 1.0 - 1e-6]).is_some());
        assert!(p.push([0.0, 0.0, 1.0]).is_none());
        // A plane that moves into a node during the step does not push it
        // out of where it started.
        let moving = Contact { lift: 1e-3, ..p };
        assert!(moving.push([0.0, 0.0, 1.0 - 1e-6]).is_none());
        assert!(moving.push([0.0, 0.0, 0.99]).is_some());
    }
}
