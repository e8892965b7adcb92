//! The haptic virtual coupling ([`Coupling`]).

use crate::error::{Error, Parameter};
use crate::math::{add, dot, is_finite3, scale, sub, Vec3};
use crate::Probe;

/// What the body-stiffness estimate keeps of itself per period: a time
/// constant of 100 periods (0.1 s at 1 kHz).
const FORGET: f32 = 0.99;

/// Haptic virtual coupling: a spring and a damper between a haptic device
/// and a probe, so that a device of modest damping renders a stiff body
/// without buzzing.
///
/// A device that moved the probe itself (`Probe::move_to` its position)
/// and rendered the probe's force would feel the body's stiffness through
/// a loop sampled at 1 kHz. On a stiff body that loop is not passive: the
/// force is held over a period while the device moves, and the device
/// gains energy from each contact until it buzzes. The coupling (Colgate,
/// Stanley and Brown, "Issues in the haptic display of tool use", IROS
/// 1995) puts a spring of stiffness `k` and a damper `b` between the
/// device and a *proxy*: the probe, given a mass `m`. The device feels the
/// spring, never more than `k`; the proxy feels the spring and the body.
///
/// Each period, [`Coupling::drive`] advances the proxy by one step of
/// length `h` (the scene's `dt`), implicit in the spring and the damper,
/// under the body's force on the probe `f̄` and with its stiffness there
/// `k_b` (both below):
///
/// ```text
/// (m + h b + h² (k + k_b)) v' = m v + h (k (x_d − x) + b v_d + f̄)
/// x' = x + h v'
/// device force = k (x' − x_d) + b (v' − v_d)
/// ```
///
/// with `x_d`, `v_d` the device's position and velocity and `x`, `v` the
/// proxy's. It moves the probe to `x'` for the next step and returns the
/// force to render on the device. The spring and damper are implicit, so
/// they are stable at any `k` and `b`.
///
/// The body's force is the last step's, known only after the proxy has
/// moved: against a stiff body a proxy driven by it alone overshoots, the
/// body lets go, and the two chatter at half the loop's rate. Two things
/// keep the proxy quiet:
/// - `f̄` is the body's force averaged over the last two steps, which
///   removes that half-rate mode;
/// - the body's stiffness at the probe, `k_b`, is estimated from the
///   force's change along the proxy's motion between periods in contact,
///   and the proxy's step is implicit in it too (`h² k_b` joins
///   `m + h b + h² k`), so the proxy moves towards where the spring and
///   the body balance instead of past it.
///
/// docs/library.md, "Haptic coupling", gives how to choose `k`, `b` and
/// `m` for a device, and what was measured.
///
/// Only positions are coupled: a capsule's axis is the caller's to set
/// ([`Probe::move_to`] with the probe's new position), and no torque is
/// rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Coupling {
    stiffness: f32,
    damping: f32,
    mass: f32,
    /// The proxy's velocity at the end of the last period (m/s).
    velocity: Vec3,
    /// The force the last period rendered on the device (N).
    force: Vec3,
    /// The body's stiffness at the probe (N/m), estimated from the force
    /// change along the proxy's motion between periods in contact.
    body_stiffness: f32,
    /// The body's force on the probe in the step before the last (N).
    previous_force: Vec3,
    /// The proxy's position and the body's force on it at the start of the
    /// last period in which the probe held nodes (the force zero before
    /// the first).
    last_position: Vec3,
    last_force: Vec3,
}

impl Coupling {
    /// A coupling of spring `stiffness` (N/m, finite and positive),
    /// `damping` (N·s/m, finite and ≥ 0) and proxy mass `proxy_mass` (kg,
    /// finite and positive), its proxy at rest. Anything else is refused
    /// with `Parameter::Coupling`.
    pub fn new(stiffness: f32, damping: f32, proxy_mass: f32) -> Result<Self, Error> {
        let ok = stiffness > 0.0
            && stiffness.is_finite()
            && damping >= 0.0
            && damping.is_finite()
            && proxy_mass > 0.0
            && proxy_mass.is_finite();
        if !ok {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Coupling,
            });
        }
        Ok(Self::at_rest(stiffness, damping, proxy_mass))
    }

    /// The coupling with its proxy at rest, knowing nothing of the body.
    fn at_rest(stiffness: f32, damping: f32, mass: f32) -> Self {
        Self {
            stiffness,
            damping,
            mass,
            velocity: [0.0; 3],
            force: [0.0; 3],
            body_stiffness: 0.0,
            previous_force: [0.0; 3],
            last_position: [0.0; 3],
            last_force: [0.0; 3],
        }
    }

    /// The spring's stiffness (N/m).
    #[must_use]
    pub fn stiffness(&self) -> f32 {
        self.stiffness
    }

    /// The damper's coefficient (N·s/m).
    #[must_use]
    pub fn damping(&self) -> f32 {
        self.damping
    }

    /// The proxy's mass (kg).
    #[must_use]
    pub fn proxy_mass(&self) -> f32 {
        self.mass
    }

    /// The proxy's velocity (m/s) at the end of the last period.
    #[must_use]
    pub fn proxy_velocity(&self) -> Vec3 {
        self.velocity
    }

    /// The force the last [`Coupling::drive`] returned (N).
    #[must_use]
    pub fn device_force(&self) -> Vec3 {
        self.force
    }

    /// Stops the proxy and forgets the rendered force and what it learnt
    /// of the body: for a probe that was just [placed](Probe::place)
    /// somewhere else.
    pub fn reset(&mut self) {
        *self = Self::at_rest(self.stiffness, self.damping, self.mass);
    }

    /// One period of the haptic loop, before the scene's step: the device
    /// is at `device` (m) moving at `device_velocity` (m/s); the proxy,
    /// `probe`, starts where the last step left it
    /// ([`Probe::position`]) and is pushed by what the body exerted on it
    /// there ([`Probe::force`]). Moves the probe for the next step
    /// ([`Probe::move_to`], its axis kept) and returns the force to render
    /// on the device (N). `dt` is the scene's step (s).
    ///
    /// Refused, with the coupling and the probe unchanged, for a device
    /// state that is not finite or a result that overflows
    /// (`Parameter::DeviceState`), or a `dt` that is not finite and > 0
    /// (`Parameter::Dt`).
    pub fn drive(
        &mut self,
        probe: &mut Probe,
        device: Vec3,
        device_velocity: Vec3,
        dt: f32,
    ) -> Result<Vec3, Error> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Dt,
            });
        }
        let refused = Error::InvalidParameter {
            parameter: Parameter::DeviceState,
        };
        if !(is_finite3(device) && is_finite3(device_velocity)) {
            return Err(refused);
        }
        let (k, b, h) = (self.stiffness, self.damping, dt);
        let x = probe.position();
        let touching = probe.contacts() > 0;
        let body = if touching {
            self.estimate(x, probe.force())
        } else {
            FORGET * self.body_stiffness
        };
        // m v + h (k (x_d − x) + b v_d + f̄), with the body's force
        // averaged over the last two steps.
        let f = scale(add(probe.force(), self.previous_force), 0.5);
        let push = add(add(scale(sub(device, x), k), scale(device_velocity, b)), f);
        let momentum = add(scale(self.velocity, self.mass), scale(push, h));
        let v = scale(momentum, 1.0 / (self.mass + h * b + h * h * (k + body)));
        let next = add(x, scale(v, h));
        let force = add(
            scale(sub(next, device), k),
            scale(sub(v, device_velocity), b),
        );
        if !(is_finite3(v) && is_finite3(next) && is_finite3(force)) {
            return Err(refused);
        }
        probe.move_to(next, probe.axis()).map_err(|_| refused)?;
        self.velocity = v;
        self.force = force;
        self.body_stiffness = body;
        self.previous_force = probe.force();
        if touching {
            self.last_position = x;
            self.last_force = probe.force();
        }
        Ok(force)
    }

    /// The body's stiffness at the probe (N/m) for a period that starts
    /// at `x` with the body's force `f` on the probe: the largest secant
    /// stiffness `−Δf·Δx / |Δx|²` since the last periods in contact,
    /// forgotten at [`FORGET`] per period, so that it follows a body that
    /// softens and lets go of a spike. Between periods in which the proxy
    /// moved less than 0.1 µm the secant is rounding (a position of 3 cm is
    /// rounded to 2e-9 m), and the estimate only decays.
    fn estimate(&self, x: Vec3, f: Vec3) -> f32 {
        let kept = FORGET * self.body_stiffness;
        if self.last_force == [0.0; 3] {
            return kept;
        }
        let dx = sub(x, self.last_position);
        let moved = dot(dx, dx);
        if moved <= 1e-14 {
            return kept;
        }
        let secant = -dot(sub(f, self.last_force), dx) / moved;
        // (An overflow to infinity would freeze the proxy for good.)
        if secant > kept && secant.is_finite() {
            secant
        } else {
            kept
        }
    }

    /// The body's stiffness at the probe (N/m) that the last period used;
    /// out of contact it decays by 1 % per period.
    #[must_use]
    pub fn body_stiffness(&self) -> f32 {
        self.body_stiffness
    }
}
