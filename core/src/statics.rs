//! Static equilibrium: Newton iterations `K(x) Δx = f(x)` with a CG inner
//! solve, for the sag of a body under constant loads.
//!
//! The residual force is recomputed from the displacements at every Newton
//! iteration, which acts as iterative refinement: f32 CG alone stagnates on
//! stiff, slender bodies, while "accurate residual → CG to its tolerance →
//! update" converges. CG is preconditioned with the two-level
//! preconditioner of `K` (feature `two-level`, storage with room for it:
//! node blocks plus rigid-body modes of node aggregates, factorised again
//! at every Newton iteration), else with the stiffness diagonal (Jacobi,
//! one scalar per node). Fixed nodes and the tool spring hold the body; the
//! ground plays no part in a static solve.
//!
//! Stopping rules, checked after every Newton iteration:
//! - the out-of-balance force is at most `tolerance` of the load; or
//! - the update is at most `update_tolerance` of the displacement, and its
//!   CG solve reached `cg_tolerance`. In f32 the out-of-balance force of a
//!   stiff body has a round-off floor (see
//!   [`StaticSettings::update_tolerance`]); the update of a solved Newton
//!   system still goes to zero.

use crate::cg;
#[cfg(feature = "tool")]
use crate::math::sub;
use crate::math::{add, axpy, dot, is_finite3, scale, sqrt};
use crate::pass;
#[cfg(any(feature = "tool", feature = "loads"))]
use crate::storage::Entries;
#[cfg(feature = "loads")]
use crate::storage::LOADED;
use crate::storage::{NodeWork, Storage, FIXED};
use crate::{Error, Parameter, Scene};

/// Settings of a static solve.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StaticSettings {
    /// Most Newton iterations. Default 30.
    pub max_iterations: u32,
    /// Most CG iterations per Newton iteration. Default 400.
    pub cg_iterations: u32,
    /// Relative CG residual at which an inner solve stops. Default 1e-4.
    pub cg_tolerance: f32,
    /// Converged when the out-of-balance force is this fraction of the load
    /// (external forces, gravity and tool). Default 1e-5.
    pub tolerance: f32,
    /// Also converged when a Newton update moves the body by less than this
    /// fraction of its displacement (RMS over nodes) and its CG solve
    /// reached `cg_tolerance`. Default 1e-4.
    ///
    /// Needed because in f32 the co-rotational forces of a stiff body carry a
    /// noise floor: the local displacement is a small difference of O(edge)
    /// local coordinates, so its round-off is `ε·|edge|`, and the force
    /// residual stalls at about 1% of the load on a 10×2×2 beam with E = 1e9
    /// while the updates stall at 2–3e-5 of the displacement (measured with
    /// `cargo test -p corofem-host-tests --test host statics:: -- --nocapture`).
    pub update_tolerance: f32,
    /// Precondition CG with the two-level preconditioner of `K` (node
    /// blocks plus rigid-body modes of node aggregates) where the build has
    /// the feature `two-level` and the storage room for it; otherwise, and
    /// with `false`, with the stiffness diagonal. Default `true`.
    pub two_level: bool,
}

impl Default for StaticSettings {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            cg_iterations: 400,
            cg_tolerance: 1.0e-4,
            tolerance: 1.0e-5,
            update_tolerance: 1.0e-4,
            two_level: true,
        }
    }
}

/// One Newton iteration of a static solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NewtonStats {
    /// Iteration number, from 0.
    pub iteration: u32,
    /// Out-of-balance force before this iteration's update, relative to the load.
    pub residual: f32,
    /// CG iterations of this iteration's solve (0 when already converged).
    pub cg_iterations: u32,
    /// Final relative CG residual of this iteration's solve.
    pub cg_residual: f32,
    /// RMS of this iteration's update relative to the RMS displacement after it.
    pub update: f32,
    /// Inverted elements.
    pub inverted: u32,
    /// `residual ≤ tolerance` (then no update is made), or
    /// `update ≤ update_tolerance` with an inner solve that reached
    /// `cg_tolerance`.
    pub converged: bool,
}

impl<S: Storage> Scene<S> {
    /// Moves the body to static equilibrium under its current loads, starting
    /// from the current shape, and zeroes the velocities. Calls
    /// `on_iteration` after every Newton iteration; returns the last one.
    pub fn solve_static(
        &mut self,
        cfg: &StaticSettings,
        mut on_iteration: impl FnMut(&NewtonStats),
    ) -> Result<NewtonStats, Error> {
        let checks = [
            (cfg.cg_iterations > 0, Parameter::StaticCgIterations),
            (cfg.cg_tolerance >= 0.0, Parameter::StaticCgTolerance),
            (cfg.tolerance >= 0.0, Parameter::StaticTolerance),
            (
                cfg.update_tolerance >= 0.0,
                Parameter::StaticUpdateTolerance,
            ),
        ];
        if let Some(&(_, parameter)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(Error::InvalidParameter { parameter });
        }
        let v = self.view();
        if v.elems.is_empty() {
            return Err(Error::NotBuilt);
        }
        let spring = v.hdr.spring();
        let held =
            v.nodes.iter().any(|n| n.flags & FIXED != 0) || (spring.active() && spring.k() > 0.0);
        if !held {
            return Err(Error::Unconstrained);
        }
        let s = v.hdr.settings;
        let per_young = v.hdr.per_young();
        let (nodes, work, elems, n_elems) = (v.nodes, v.work, v.elems, v.n_elems);
        #[cfg(feature = "tool")]
        let grabs = v.lists.grabs;
        #[cfg(feature = "loads")]
        let loads = v.lists.loads;
        // The two-level preconditioner of `K`, where the build and the
        // storage have it: aggregates of the free nodes now, the factor at
        // every Newton iteration (the tangent turns with the body). The
        // dynamic step's factor is of another matrix: it is prepared again.
        #[cfg(feature = "two-level")]
        let mut pre = {
            let mut pre = v.pre.parts;
            let n = if cfg.two_level && pre.blocks.len() == nodes.len() {
                v.hdr.invalidate_coarse();
                crate::precond::aggregate(per_young, elems, n_elems, nodes, pre.blocks, pre.aggs)
            } else {
                0
            };
            (pre.keep(n) > 0).then_some(pre)
        };
        let mut last = NewtonStats::default();
        for iteration in 0..cfg.max_iterations.max(1) {
            for w in work.iter_mut() {
                *w = NodeWork::EMPTY;
            }
            let totals = pass::forces_outside_step(
                true,
                s.method,
                per_young,
                nodes,
                elems,
                n_elems,
                &mut |i, f| {
                    if let Some(w) = work.get_mut(i) {
                        w.r = add(w.r, f);
                    }
                },
            );
            pass::stiffness_diagonal(per_young, elems, n_elems, |i, d| {
                if let Some(w) = work.get_mut(i) {
                    w.inv_p += d;
                }
            });
            // Out-of-balance force r = f_el + f_ext + m g (+ spring), and the load.
            let (mut r2, mut load2) = (0.0f32, 0.0f32);
            // The same sums in f64, used only when the f32 ones overflow.
            let (mut r2_wide, mut load2_wide) = (0.0f64, 0.0f64);
            #[cfg(feature = "tool")]
            let mut offsets = Entries::new(grabs);
            #[cfg(feature = "loads")]
            let mut forces = Entries::new(loads);
            for (n, w) in nodes.iter().zip(work.iter_mut()) {
                #[allow(unused_mut)] // only loads and the tool add to it
                let mut load = scale(s.gravity, n.mass);
                #[cfg(feature = "loads")]
                {
                    load = add(forces.at(n.flags, LOADED), load);
                }
                #[allow(unused_mut)] // only the tool adds to it
                let mut diag = w.inv_p;
                #[cfg(feature = "tool")]
                if spring.holds(n) {
                    load = add(
                        load,
                        scale(sub(spring.anchor(offsets.next()), n.position()), spring.k()),
                    );
                    diag += spring.k();
                }
                if n.flags & FIXED != 0 {
                    w.r = [0.0; 3];
                    w.inv_p = 0.0;
                    continue;
                }
                w.r = add(w.r, load);
                w.inv_p = if diag > 0.0 { 1.0 / diag } else { 0.0 };
                r2 += dot(w.r, w.r);
                load2 += dot(load, load);
                r2_wide += dot_wide(w.r, w.r);
                load2_wide += dot_wide(load, load);
            }
            let residual = norm_ratio(r2, load2, r2_wide, load2_wide);
            last = NewtonStats {
                iteration,
                residual,
                inverted: totals.inverted,
                converged: residual <= cfg.tolerance,
                ..NewtonStats::default()
            };
            if !last.converged {
                #[cfg(feature = "two-level")]
                if let Some(pre) = pre.as_mut() {
                    refactor(per_young, elems, n_elems, nodes, pre, spring);
                }
                #[cfg(feature = "two-level")]
                let whole = pre.as_mut().map(|pre| {
                    |work: &mut [NodeWork]| {
                        crate::precond::apply(nodes, work, pre, |_, r| r, |_, z| z)
                    }
                });
                #[cfg(not(feature = "two-level"))]
                let whole = None::<fn(&mut [NodeWork]) -> f32>;
                let apply = |work: &mut [NodeWork]| {
                    pass::stiffness_outside_step(per_young, elems, n_elems, work);
                    let mut dq = 0.0f32;
                    for (_n, w) in nodes.iter().zip(work.iter_mut()) {
                        // K d = −(−K d), plus the tool spring.
                        let mut q = scale(w.q, -1.0);
                        if spring.holds(_n) {
                            q = axpy(q, spring.k(), w.d);
                        }
                        w.q = q;
                        dq += dot(w.d, q);
                    }
                    dq
                };
                let out = cg::solve(
                    work,
                    cfg.cg_iterations,
                    cfg.cg_iterations,
                    cfg.cg_tolerance,
                    false,
                    |_, z| z,
                    whole,
                    apply,
                    |_: &[NodeWork]| true,
                );
                last.cg_iterations = out.iterations;
                last.cg_residual = out.residual;
                if out.overflow
                    || !nodes
                        .iter()
                        .zip(work.iter())
                        .all(|(n, w)| is_finite3(add(n.x0, add(n.u, w.x))))
                {
                    return Err(Error::StaticDiverged);
                }
                let (mut dx2, mut u2) = (0.0f32, 0.0f32);
                let (mut dx2_wide, mut u2_wide) = (0.0f64, 0.0f64);
                for (n, w) in nodes.iter_mut().zip(work.iter()) {
                    n.u = add(n.u, w.x);
                    dx2 += dot(w.x, w.x);
                    u2 += dot(n.u, n.u);
                    dx2_wide += dot_wide(w.x, w.x);
                    u2_wide += dot_wide(n.u, n.u);
                }
                last.update = norm_ratio(dx2, u2, dx2_wide, u2_wide);
                // A small update says Newton has reached its fixed point
                // only when the inner solve was solved: a stalled CG also
                // moves the body little.
                last.converged =
                    last.update <= cfg.update_tolerance && out.residual <= cfg.cg_tolerance;
            }
            on_iteration(&last);
            if last.converged {
                break;
            }
        }
        for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
            n.v = [0.0; 3];
            *w = NodeWork::EMPTY;
        }
        Ok(last)
    }
}

/// The two-level preconditioner of the tangent stiffness `K` (with the
/// tool's spring on grabbed nodes) at the current state: the aggregates'
/// rotations, the node blocks and the coarse factor.
#[cfg(feature = "two-level")]
fn refactor(
    per_young: [f32; 2],
    elems: &[crate::element::ElementBlock],
    n_elems: usize,
    nodes: &[crate::storage::Node],
    pre: &mut crate::precond::Parts<'_>,
    spring: crate::state::Spring,
) {
    use crate::precond;
    precond::rotations(nodes, pre.blocks, pre.aggs);
    precond::node_blocks(
        per_young,
        elems,
        n_elems,
        nodes,
        pre.blocks,
        0.0,
        1.0,
        |n| if spring.holds(n) { spring.k() } else { 0.0 },
    );
    precond::factor(per_young, elems, n_elems, nodes, pre, 0.0, 1.0);
}

/// `a · b` in f64, for sums of squares that may overflow f32.
fn dot_wide(a: crate::math::Vec3, b: crate::math::Vec3) -> f64 {
    f64::from(a[0]) * f64::from(b[0])
        + f64::from(a[1]) * f64::from(b[1])
        + f64::from(a[2]) * f64::from(b[2])
}

/// `√a2 / √b2` for two sums of squares, as f32. The f32 sums give the usual
/// bits; when the f32 ratio is not finite (a sum overflowed: components
/// above ~1e19; or a huge residual over a zero load) the f64 sums give a
/// finite one instead (clamped to `f32::MAX` before the root).
fn norm_ratio(a2: f32, b2: f32, a2_wide: f64, b2_wide: f64) -> f32 {
    let ratio = sqrt(a2) / sqrt(b2).max(f32::MIN_POSITIVE);
    if ratio.is_finite() {
        return ratio;
    }
    let floor = f64::from(f32::MIN_POSITIVE) * f64::from(f32::MIN_POSITIVE);
    let q = a2_wide / b2_wide.max(floor);
    sqrt((q as f32).min(f32::MAX))
}
