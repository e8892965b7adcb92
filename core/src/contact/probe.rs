//! Rigid probes: spheres and capsules that the body's surface cannot enter
//! (palpation with a finger or an instrument's tip and shaft).
//!
//! A probe is the caller's value ([`Probe`]), passed to
//! [`Scene::step_with_probes`](crate::Scene::step_with_probes) as a slice, so
//! a scene holds any number of them without a slot of its own: an array, a
//! `Vec` or a `heapless::Vec` serve alike, and probes may come and go
//! between steps (a node a probe held stays held by whichever probe it
//! touches, so taking one out of the slice, which renumbers the others,
//! does not let their nodes go). [`Probe::move_to`] sets the pose
//! the probe reaches at the end of the next step; the step moves it there
//! from where the last step left it and writes back the force the body
//! exerted on it ([`Probe::force`]), what a haptic device renders.
//!
//! **Contact is a constraint of the implicit step**, the ground's
//! ([`crate::Plane`]) with a plane per node: a boundary node that the probe
//! reaches during the step is held on the probe's tangent plane at the
//! step's end. Its normal velocity is prescribed, the normal is filtered out
//! of the solve, the contact impulse comes from the residual, and a contact
//! that would pull is released for the next step. A node whose contact
//! pushes ends the step on the probe's surface: sliding by `s` along the
//! tangent plane leaves it outside the curved surface by about `s² / 2r`,
//! and it is moved back along the normal, so that the next step finds it
//! touching and holds it again (a pressed node never goes free for a step,
//! which would let the body drive it deep into the probe). No penalty
//! spring: the step stays stable at any time step, and a stiff body does
//! not need a small one.
//!
//! **Fast tools are swept.** The plane of a node comes from where the probe
//! first touches it during the step, not from where it ends: each point of
//! the probe's axis moves on a straight line from its pose at the step's
//! start to its pose at the end, and a node that such a point's sphere
//! reaches on the way takes the normal at the time of that touch. A probe
//! that moves through a thin body in one step therefore pushes its nodes
//! ahead instead of leaving them behind it. (Exact for a sphere, or a
//! capsule, that translates; a turning capsule's points move on chords.)
//!
//! **A probe may not start inside the body.** A new or placed probe's
//! first step is refused (`StepError::ProbeInsideBody`, nothing changes)
//! if a boundary node is inside it: there is no side to push that node to
//! that a user would agree with. [`Probe::distance`] tells a caller where a
//! node is. Once stepping, a node that ends a step inside a probe (carried
//! in by its own motion, or by a release) is stopped and pushed out by the
//! next step, its neighbours moving along, without a bounce (the push only
//! corrects positions; `step::relax`), as the ground pushes out nodes below
//! it.
//!
//! Only nodes on the mesh's boundary (marked at `build`) touch probes. A
//! node is held by one obstacle at a time, the one it is deepest in: a node
//! squeezed between a probe and the ground follows the deeper.

use crate::contact::ground::Contact;
use crate::error::{Error, Parameter};
use crate::math::{add, axpy, cross, dot, is_finite3, normalize, scale, sqrt, sub, Vec3};

/// Most probes a step takes: a held node records its probe's index + 1 in
/// 16 bits.
pub const MAX_PROBES: usize = u16::MAX as usize;

/// A rigid probe: a sphere, or a capsule (the points within `radius` of a
/// segment of length `2 half_length` along a unit `axis`), with its pose at
/// the end of the next step and the force the body exerted on it in the
/// last one.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Probe {
    radius: f32,
    half_length: f32,
    /// The pose the next step ends at.
    position: Vec3,
    axis: Vec3,
    /// The pose the next step starts from (where the last step left it).
    start: Vec3,
    start_axis: Vec3,
    force: Vec3,
    contacts: u32,
    /// Whether the probe has not stepped since it was made or placed: its
    /// first step checks that it does not start inside the body.
    pub(crate) fresh: bool,
    /// The force and contacts being summed by a step, kept only if it
    /// succeeds.
    pub(crate) next_force: Vec3,
    pub(crate) next_contacts: u32,
    #[cfg(feature = "friction")]
    friction: crate::Friction,
}

impl Probe {
    /// A sphere of `radius` (m) centred at `position`.
    pub fn sphere(radius: f32, position: Vec3) -> Result<Self, Error> {
        Self::capsule(radius, 0.0, position, [0.0, 0.0, 1.0])
    }

    /// A capsule of `radius` (m) around the segment of half length
    /// `half_length` (m) through `position` along `axis` (any length > 0;
    /// normalised). A half length of zero makes a sphere.
    pub fn capsule(
        radius: f32,
        half_length: f32,
        position: Vec3,
        axis: Vec3,
    ) -> Result<Self, Error> {
        // Both > 0 and finite, and their sum too (it bounds every distance
        // the contact test forms).
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::ProbeRadius,
            });
        }
        if !(half_length >= 0.0 && (radius + half_length).is_finite()) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::ProbeHalfLength,
            });
        }
        let axis = pose_axis(position, axis)?;
        Ok(Self {
            radius,
            half_length,
            position,
            axis,
            start: position,
            start_axis: axis,
            force: [0.0; 3],
            contacts: 0,
            fresh: true,
            next_force: [0.0; 3],
            next_contacts: 0,
            #[cfg(feature = "friction")]
            friction: crate::Friction::NONE,
        })
    }

    /// The same probe with `friction` between it and the body (none by
    /// default): a node it holds sticks to it and is dragged along, or
    /// slides on it ([`crate::Friction`]).
    #[cfg(feature = "friction")]
    #[must_use]
    pub fn with_friction(mut self, friction: crate::Friction) -> Self {
        self.friction = friction;
        self
    }

    /// Sets the friction between the probe and the body.
    #[cfg(feature = "friction")]
    pub fn set_friction(&mut self, friction: crate::Friction) {
        self.friction = friction;
    }

    /// The friction between the probe and the body.
    #[cfg(feature = "friction")]
    #[must_use]
    pub fn friction(&self) -> crate::Friction {
        self.friction
    }

    /// Sets the pose the probe reaches at the end of the next step: its
    /// centre (the segment's midpoint) and, for a capsule, its axis (any
    /// length > 0; a sphere ignores its direction). The step moves the probe
    /// there from where the last step left it. Refused, with the probe
    /// unchanged, for a pose that is not finite or an axis of zero length.
    pub fn move_to(&mut self, position: Vec3, axis: Vec3) -> Result<(), Error> {
        self.axis = pose_axis(position, axis)?;
        self.position = position;
        Ok(())
    }

    /// Places the probe at `position` and `axis` now, without a sweep: the
    /// next step starts and ends there (for setting a scene up).
    pub fn place(&mut self, position: Vec3, axis: Vec3) -> Result<(), Error> {
        self.move_to(position, axis)?;
        self.start = self.position;
        self.start_axis = self.axis;
        self.fresh = true;
        Ok(())
    }

    /// The centre the next step ends at (m).
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The unit axis the next step ends at.
    #[must_use]
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// The radius (m).
    #[must_use]
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Half the length of the capsule's segment (m); 0 for a sphere.
    #[must_use]
    pub fn half_length(&self) -> f32 {
        self.half_length
    }

    /// The force the body exerted on the probe during the last step (N),
    /// the impulse of its contacts over the step's length: what a haptic
    /// device renders. Zero before the first step.
    #[must_use]
    pub fn force(&self) -> Vec3 {
        self.force
    }

    /// Nodes the probe held during the last step.
    #[must_use]
    pub fn contacts(&self) -> u32 {
        self.contacts
    }

    /// Signed distance of `x` from the probe's surface at its pose
    /// ([`Probe::position`], [`Probe::axis`]): negative inside (m).
    #[must_use]
    pub fn distance(&self, x: Vec3) -> f32 {
        let a = self.axis_offset(x);
        sqrt(dot(a, a)) - self.radius
    }

    /// `x` less the point of the axis nearest to it, at the probe's pose.
    #[inline(always)]
    fn axis_offset(&self, x: Vec3) -> Vec3 {
        sub(x, self.nearest(self.position, self.axis, x))
    }

    /// The point of the segment at `c` along `e` nearest to `x`.
    #[inline(always)]
    fn nearest(&self, c: Vec3, e: Vec3, x: Vec3) -> Vec3 {
        axpy(c, self.along(c, e, x), e)
    }

    /// The segment parameter of the point nearest to `x`, in
    /// `[−half_length, half_length]`.
    #[inline(always)]
    fn along(&self, c: Vec3, e: Vec3, x: Vec3) -> f32 {
        let l = self.half_length;
        // `f32::clamp`'s arithmetic without its panic on `min > max`, which
        // the optimiser cannot rule out (`half_length ≥ 0` is checked when
        // the probe is made): a firmware's panic-freedom proof links.
        let mut t = dot(sub(x, c), e);
        if t < -l {
            t = -l;
        }
        if t > l {
            t = l;
        }
        t
    }

    /// The offset of the probe's supporting plane with unit normal `n` at
    /// the pose `(c, e)`: the largest `n · y` over the probe.
    #[inline(always)]
    fn support(&self, n: Vec3, c: Vec3, e: Vec3) -> f32 {
        dot(n, c) + self.half_length * dot(n, e).abs() + self.radius
    }

    /// The contact plane of a node at `x` (at the step's start): the
    /// probe's supporting plane at the step's end whose normal is the
    /// direction from the probe's axis to the node when the probe first
    /// touches it: at the step's start for a node already inside, else when
    /// the sphere around the axis point nearest to the node at the start,
    /// moving on a straight line to that point's place at the end, first
    /// reaches it; for a node it does not reach so, the direction at the
    /// end (the caller holds a node by its distance from the plane).
    pub(crate) fn contact(&self, x: Vec3) -> Contact {
        let r = self.radius;
        let (c0, e0, c1, e1) = (self.start, self.start_axis, self.position, self.axis);
        let s0 = self.along(c0, e0, x);
        let a0 = sub(x, axpy(c0, s0, e0));
        let a1 = sub(x, self.nearest(c1, e1, x));
        let d0 = dot(a0, a0);
        let r2 = r * r;
        let toward = if d0 <= r2 {
            // Inside at the start: pushed out along the end's normal.
            a1
        } else {
            // The point moves by `m`; it touches at the smallest `t` in
            // [0, 1] with |a0 − t m|² = r²: m² t² − 2 (a0·m) t + d0 − r² = 0.
            let m = sub(axpy(c1, s0, e1), axpy(c0, s0, e0));
            let mm = dot(m, m);
            let am = dot(a0, m);
            let disc = am * am - mm * (d0 - r2);
            let t = if am > 0.0 && disc >= 0.0 {
                // The smaller root, in the form without cancellation.
                (d0 - r2) / (am + sqrt(disc))
            } else {
                f32::INFINITY
            };
            if t <= 1.0 {
                sub(a0, scale(m, t))
            } else {
                a1
            }
        };
        let normal = normalize(toward)
            .or_else(|| normalize(sub(c1, c0)))
            .or_else(|| normalize(cross(e1, [1.0, 0.0, 0.0])))
            .unwrap_or([0.0, 1.0, 0.0]);
        // The axis point's travel over the step: how a sticking node moves.
        #[cfg(feature = "friction")]
        let travel = sub(axpy(c1, s0, e1), axpy(c0, s0, e0));
        self.plane(
            normal,
            #[cfg(feature = "friction")]
            travel,
        )
    }

    /// The probe's supporting plane with unit normal `normal` at the end
    /// pose, and how far it moves out over the step.
    #[inline(always)]
    fn plane(&self, normal: Vec3, #[cfg(feature = "friction")] travel: Vec3) -> Contact {
        let offset = self.support(normal, self.position, self.axis);
        let lift = offset - self.support(normal, self.start, self.start_axis);
        Contact {
            normal,
            offset,
            lift,
            #[cfg(feature = "friction")]
            travel,
            #[cfg(feature = "friction")]
            friction: self.friction,
        }
    }

    /// The plane a node at `x` at the step's end is inside of, if it is
    /// inside the probe there: the supporting plane at the nearest point,
    /// moving with the probe's motion over the step.
    pub(crate) fn inside(&self, x: Vec3) -> Option<Contact> {
        let a1 = self.axis_offset(x);
        if !(dot(a1, a1) < self.radius * self.radius) {
            return None;
        }
        let normal = normalize(a1)?;
        Some(self.plane(
            normal,
            #[cfg(feature = "friction")]
            [0.0; 3],
        ))
    }

    /// How far a node that the probe held over the step, ending at `x`,
    /// lies outside the probe's surface: the vector from the surface to
    /// `x` along the normal, or `None` on or inside it. A held node ends on
    /// the plane tangent where the step began; sliding along it by `s`
    /// leaves it outside the curved surface by about `s² / 2r`, and then
    /// outside the next step's contact plane too. (The step moves a node
    /// whose contact pushes back onto the surface by this vector.)
    pub(crate) fn outside(&self, x: Vec3) -> Option<Vec3> {
        let a = self.axis_offset(x);
        let d = sqrt(dot(a, a));
        (d > self.radius).then(|| scale(a, (d - self.radius) / d))
    }

    /// Keeps what a successful step summed and starts the next step where
    /// this one ended.
    pub(crate) fn commit(&mut self, h: f32) {
        self.force = scale(self.next_force, 1.0 / h);
        self.contacts = self.next_contacts;
        self.start = self.position;
        self.start_axis = self.axis;
        self.fresh = false;
    }

    /// The largest distance outside the probe at which a node it held last
    /// step is still held. The step moves a pushing node from its tangent
    /// plane onto the surface ([`Probe::outside`]); this allows for the
    /// drift that sliding by up to `h |v|` along a plane would leave,
    /// `(h |v|)² / 2r`, plus the rounding of the distance.
    pub(crate) fn gap(&self, x: Vec3, v: Vec3, h: f32) -> f32 {
        h * h * dot(v, v) / (2.0 * self.radius) + self.rounding(x, self.position)
    }

    /// Whether `x` is inside the probe at the step's start by more than the
    /// rounding of its distance: a node a fresh probe must not start in.
    pub(crate) fn starts_around(&self, x: Vec3) -> bool {
        let a = sub(x, self.nearest(self.start, self.start_axis, x));
        sqrt(dot(a, a)) - self.radius < -self.rounding(x, self.start)
    }

    /// Whether the probe's axis at the step's start (its centre, for a
    /// sphere) meets the tetrahedron with corners `p`, faces included: a
    /// probe lying inside the body with no boundary node in it has its axis
    /// in some element. The segment is clipped against the four face
    /// planes; each face's plane function `n·(x − p)` is affine along the
    /// segment, so the part inside is one interval of its parameter.
    /// Degenerate (zero-volume) tetrahedra meet nothing.
    pub(crate) fn axis_meets(&self, p: [Vec3; 4]) -> bool {
        let l = self.half_length;
        let a = axpy(self.start, -l, self.start_axis);
        let b = axpy(self.start, l, self.start_axis);
        let vol = dot(cross(sub(p[1], p[0]), sub(p[2], p[0])), sub(p[3], p[0]));
        if vol == 0.0 || !vol.is_finite() {
            return false;
        }
        // Face opposite corner i, through corners (i+1, i+2, i+3): its
        // normal points away from corner i when the tetrahedron is
        // positively oriented; `vol`'s sign flips it for an inverted one.
        let (mut lo, mut hi) = (0.0_f32, 1.0_f32);
        for i in 0..4 {
            let (q0, q1, q2) = (p[(i + 1) % 4], p[(i + 2) % 4], p[(i + 3) % 4]);
            let mut n = cross(sub(q1, q0), sub(q2, q0));
            if dot(n, sub(p[i], q0)) > 0.0 {
                n = scale(n, -1.0);
            }
            // Outside where f > 0.
            let fa = dot(n, sub(a, q0));
            let fb = dot(n, sub(b, q0));
            if fa > 0.0 && fb > 0.0 {
                return false;
            }
            if fa > 0.0 {
                // Enters at f = 0.
                let t = fa / (fa - fb);
                if t > lo {
                    lo = t;
                }
            } else if fb > 0.0 {
                let t = fa / (fa - fb);
                if t < hi {
                    hi = t;
                }
            }
        }
        lo <= hi
    }

    /// The rounding of a distance from `x` to the probe centred at `c`: 4 ε
    /// times the magnitudes it is formed from.
    fn rounding(&self, x: Vec3, c: Vec3) -> f32 {
        let size = x[0].abs()
            + x[1].abs()
            + x[2].abs()
            + c[0].abs()
            + c[1].abs()
            + c[2].abs()
            + self.half_length
            + self.radius;
        4.0 * f32::EPSILON * size
    }
}

/// A checked pose's unit axis.
fn pose_axis(position: Vec3, axis: Vec3) -> Result<Vec3, Error> {
    let bad = Error::InvalidParameter {
        parameter: Parameter::ProbePose,
    };
    if !is_finite3(position) || !is_finite3(axis) {
        return Err(bad);
    }
    let e = normalize(axis).ok_or(bad)?;
    // A position whose coordinates are finite but whose products with a
    // unit vector are not (near f32::MAX) is refused too.
    if dot(e, position).is_finite() && is_finite3(add(position, e)) {
        Ok(e)
    } else {
        Err(bad)
    }
}
