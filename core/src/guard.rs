//! The energy guard (feature `energy-guard`, `Settings::energy_guard`): the
//! body's energy at a step's start, measured against what the last step
//! left ([`Ledger`]), and the correction that takes an excess out of the
//! velocity's deformation part ([`Correction`]).

use crate::math::{add, dot, scale, Vec3};
use crate::rigid::{Motion, Rigid};
use crate::storage::{Node, NodeWork, FIXED};

/// The guard's tolerance, relative to the sum of the magnitudes of the
/// energy's terms (kinetic, elastic, `|(m g + f)·u|` per node): the energy
/// is three f32 sums over nodes or elements, recomputed each step, and a
/// gain below this is their rounding rather than energy the step made.
/// A gain taken for one by mistake costs little (the guard removes only
/// the measured excess); the bound keeps a step that makes no energy from
/// being touched at all, which keeps such runs' bits those of the
/// unguarded step: the web demo's and the determinism tests' hashed scenes
/// (with gravity and the ground) never trigger it.
pub(crate) const GUARD_ROUNDING: f32 = 16.0 * f32::EPSILON;

/// The energy guard's sums over the free nodes at the step's start.
#[derive(Clone, Copy, Default)]
pub(crate) struct Ledger {
    /// `Σ m |v|²`.
    pub(crate) kinetic2: f32,
    /// `−Σ (m g + f)·u`: gravity's and the loads' potential energy.
    pub(crate) potential: f32,
    /// `Σ |(m g + f)·u|`.
    pub(crate) magnitude: f32,
    /// The tool spring's energy `½ (k/n) Σ |a + o − x|²` over the grabbed
    /// nodes, with the tool's target `a` (`spring`) and with the target of
    /// the guard's reference (`spring_ref`). Zero without the tool.
    pub(crate) spring: f32,
    pub(crate) spring_ref: f32,
}

impl Ledger {
    #[inline(always)]
    pub(crate) fn add(&mut self, n: &Node, weight: Vec3, load: Vec3) {
        // Fixed nodes do not move (their velocity is zero): no energy.
        if n.flags & FIXED != 0 {
            return;
        }
        self.kinetic2 += n.mass * dot(n.v, n.v);
        let work = dot(weight, n.u) + dot(load, n.u);
        self.potential -= work;
        self.magnitude += work.abs();
    }

    /// A grabbed node's spring (stiffness `k`), stretched by `stretch`
    /// towards the tool's target and by `stretch_ref` towards the
    /// reference's.
    #[cfg(all(feature = "tool", feature = "energy-guard"))]
    #[inline(always)]
    pub(crate) fn spring(&mut self, k: f32, stretch: Vec3, stretch_ref: Vec3) {
        self.spring += 0.5 * k * dot(stretch, stretch);
        self.spring_ref += 0.5 * k * dot(stretch_ref, stretch_ref);
    }
}

/// The energy guard's correction of the velocity a step starts from. When
/// the body's energy (kinetic, elastic, the potential of gravity and the
/// loads, and the tool spring's) at a step's start exceeds what the last
/// step left, less the work of moving the tool's target in between, while
/// nothing else did work on the body (no ground held it, no call changed
/// the scene) and elements were inverted at either step's start, the
/// excess `X` is taken out of the velocity's
/// deformation part, `v ← v + δ` with `δ = (s − 1) (v − v_R)`, where `v_R`
/// is the rigid motion of the same linear and angular momentum (for a body
/// without fixed nodes; else `v_R = 0`) and `s² = 1 − X / KE_d`, `KE_d` the
/// deformation part's kinetic energy (at most all of it). `v − v_R` is
/// `M`-orthogonal to rigid motions, so the kinetic energy falls by exactly
/// `(1 − s²) KE_d` and the momentum is kept.
///
/// The step's state is not written before the step succeeds: starting
/// from `v + δ` is the same as keeping `v` and adding `M δ` to the
/// right-hand side (`A (y − δ) = b(v + δ)` with `b` linear in `v`:
/// `b(v + δ) = b(v) − h α_M M δ − h (α_K + h) K δ`, and `A δ` has the same
/// `K δ` term, leaving `A y = b(v) + M δ`), and the step's new velocity is
/// still `v + y`.
#[derive(Clone, Copy)]
pub(crate) struct Correction {
    body: Option<(Rigid, Motion)>,
    factor: f32,
    pub(crate) removed: f32,
}

impl Correction {
    pub(crate) fn new(
        nodes: &[Node],
        work: &[NodeWork],
        any_fixed: bool,
        excess: f32,
    ) -> Option<Self> {
        let body = if any_fixed {
            None
        } else {
            Rigid::new(nodes, true).map(|b| {
                // The fit refined once: the momentum of `v − v_R`, summed
                // again in f32, is what the correction would change.
                let m = b.fit(nodes, work, |n, _| scale(n.v, n.mass));
                let rest = b.fit(nodes, work, |n, _| scale(b.less_rigid(n, n.v, m), n.mass));
                (b, (add(m.0, rest.0), add(m.1, rest.1)))
            })
        };
        let mut deform2 = 0.0f32;
        for n in nodes.iter().filter(|n| n.flags & FIXED == 0) {
            let d = match &body {
                Some((b, m)) => b.less_rigid(n, n.v, *m),
                None => n.v,
            };
            deform2 += n.mass * dot(d, d);
        }
        let kinetic = 0.5 * deform2;
        if !(kinetic > 0.0 && kinetic.is_finite()) {
            return None;
        }
        let keep2 = (1.0 - excess / kinetic).max(0.0);
        let s = crate::math::sqrt(keep2);
        Some(Self {
            body,
            factor: s - 1.0,
            removed: (1.0 - s * s) * kinetic,
        })
    }

    /// `δ` at node `n` (zero at fixed nodes).
    #[inline(always)]
    pub(crate) fn delta(&self, n: &Node) -> Vec3 {
        if n.flags & FIXED != 0 {
            return [0.0; 3];
        }
        let d = match &self.body {
            Some((b, m)) => b.less_rigid(n, n.v, *m),
            None => n.v,
        };
        scale(d, self.factor)
    }
}
