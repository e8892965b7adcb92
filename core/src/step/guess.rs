//! The stages before the element pass: the contacts (detect, carry) and the
//! initial guess.

use super::Ctx;
use crate::contact::{self, Carry, Held, Obstacles, Probes};
use crate::element::ElementBlock;
use crate::math::{add, scale};
use crate::rigid::Rigid;
use crate::state::Header;
use crate::storage::{Node, NodeWork, FIXED};

/// The detect stage ([`contact::detect`]): the nodes the obstacles hold,
/// and with them whether the body is isolated (no fixed node, no tool, no
/// contact).
#[inline(always)]
pub(super) fn detect(
    hdr: &Header,
    probes: &mut Probes<'_>,
    nodes: &mut [Node],
    work: &mut [NodeWork],
    elems: &[ElementBlock],
    n_elems: usize,
    ctx: &mut Ctx,
) -> Held {
    contact::begin(probes);
    #[allow(unused_mut)] // only the ground scales the hold-on
    let mut ground = ctx.ground;
    let _ = (elems, n_elems);
    #[cfg(feature = "ground")]
    if ground.plane.is_some() && nodes.iter().any(contact::on_ground) {
        // The hold-on's speed, for a body stiff enough that a pressure
        // wave crosses it within the step (`ratio² = (c h / L)² > 1`):
        // a node brought back to the plane by its gap `δ` strains the
        // body by `δ / L`, which stays within the strain of its own
        // weight, `g L / c²`, for `δ ≤ g h² / ratio²` (`contact::HoldOn`).
        ctx.start = Rigid::new(nodes, true).map(|body| {
            let ratio2 = crate::rigid::wave(&body, elems, n_elems, ctx.per_young, ctx.h);
            (body, ratio2)
        });
        let ratio2 = ctx.start.map_or(0.0, |(_, r)| r);
        if ratio2 > 1.0 {
            ground.settle /= ratio2;
        }
    }
    // A body that moves as one over the step and that only the ground can
    // hold: its contact is solved whole (`contact::whole`).
    #[cfg(feature = "ground")]
    if contact::whole_candidate(ground, probes, hdr.spring().active(), ctx.any_fixed, nodes) {
        if ctx.start.is_none() {
            ctx.start = Rigid::new(nodes, true).map(|body| {
                let ratio2 = crate::rigid::wave(&body, elems, n_elems, ctx.per_young, ctx.h);
                (body, ratio2)
            });
        }
        ctx.whole = ctx.start.is_some_and(|(_, r)| r >= 1.0);
        if ctx.whole {
            contact::clear(nodes);
            ctx.isolated = true;
            return Held::default();
        }
    }
    let obstacles = Obstacles::new(ground, probes);
    let held = contact::detect(obstacles, nodes, work, ctx.h);
    // The grabbed nodes hold the body (a grab lists at least one node).
    ctx.isolated = !ctx.any_fixed && !hdr.spring().active() && held.held == 0;
    held
}

/// The carry stage ([`contact::carry`]).
#[inline(always)]
pub(super) fn carry(
    ctx: &Ctx,
    held: &Held,
    nodes: &[Node],
    elems: &[ElementBlock],
    n_elems: usize,
) -> Carry {
    let share = |body: &Rigid| ctx.share(body, elems, n_elems);
    #[cfg(feature = "ground")]
    let start = ctx.start.map(|(body, _)| body);
    #[cfg(not(feature = "ground"))]
    let start = None;
    contact::carry(
        ctx.ground,
        held,
        ctx.any_fixed,
        ctx.fall,
        start,
        nodes,
        share,
    )
}

/// What the guess stage decided, for the stages after it.
#[derive(Clone, Copy)]
pub(super) struct Guess {
    /// The right-hand side takes `− p x₀`: with the fused product, or for
    /// a uniform guess that is not zero.
    pub(super) subtract: bool,
}

/// The guess stage. CG truncated after a few iterations scales each part
/// of the right-hand side differently, including the uniform part `h M g`,
/// so a falling body would feel a fraction of gravity. A uniform velocity
/// change is an exact eigenvector of A (K of a translation is zero, bit for
/// bit, since every element sees equal node values), so when no node is
/// fixed we start from the free-fall change `c = h g / (1 + h α_M)`
/// ([`Ctx::fall`]) and CG only has the rest to do. Fixed bodies start from
/// zero (or the warm start).
///
/// The guess is made before the element pass, whose stiffness product then
/// takes `v + x₀`: `b − A x₀ = h f − h (h + α_K) K (v + x₀) − p x₀` (`p`
/// the node's mass term) costs no product of its own. Leaves the guess in
/// `x` and the product's input in `d`, with `r` and `q` zero.
///
/// A warm guess with held normals can start the solve worse than no guess
/// (the normals are prescribed, and a truncated solve from there cannot
/// undo them): steps with contacts start cold, and so do those of a body
/// whose contact is solved whole (`contact::whole`: the solve's velocity
/// change, carried from step to step in a resting body, kept its
/// unconverged modes and strained the body more each step). So does the step after one
/// whose solve had no energy certificate at its budget: there the
/// linearised step is far from the motion (a stiff body yanked by the
/// tool, elements turning over), the last velocity change is no estimate of
/// the next, and a guess carried from step to step keeps the error in the
/// modes a truncated solve leaves untouched (a liver of E = 1e10 Pa pulled
/// by a stiff tool gains 10⁶ to 10¹² times the tool's work with the guess,
/// at most 1.6 times without it).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn guess(
    hdr: &Header,
    ctx: &Ctx,
    held: &Held,
    carry: &Carry,
    probes: &Probes<'_>,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Guess {
    let (h, isolated, fall) = (ctx.h, ctx.isolated, ctx.fall);
    #[cfg(feature = "ground")]
    let touching = held.held > 0 || ctx.whole;
    #[cfg(not(feature = "ground"))]
    let touching = held.held > 0;
    let warm = ctx.s.warm_start && !touching && !hdr.guess_stale;
    // An isolated body's rigid motions: translations, which `K` annihilates
    // bit for bit in every method, and, for `Qr`, whose `B` is that of the
    // current shape, rotations about the current shape too. The solve keeps
    // the exact step's response to these modes (the momentum), whatever the
    // preconditioner and however it is truncated: the mass preconditioner
    // does by itself; the others are made exact on them (`Rigid::finish`),
    // and only they need the body's inertia at every step.
    if warm && isolated {
        if let Some(body) = Rigid::new(nodes, true) {
            // The warm start keeps no momentum of its own; the free fall
            // adds the exact impulse of gravity below.
            let guess = body.fit(nodes, work, |n, w| scale(w.x, n.mass));
            for (n, w) in nodes.iter().zip(work.iter_mut()) {
                w.x = body.less_rigid(n, w.x, guess);
            }
        }
    }
    // A uniform guess needs no product at all (`K c = 0`).
    let uniform = isolated && !warm;
    // Whether the product takes `v + x₀`: for every guess but the uniform
    // one and the zero one of a fixed body without contacts.
    let fused = warm || (!isolated && (!ctx.any_fixed || held.held > 0));
    // Add the free fall to the guess and prescribe the held normals; the
    // product's input into `d`.
    let keep = warm && !isolated;
    let obstacles = Obstacles::new(ctx.ground, probes);
    // The bits of every guess component, sign bit shifted out, or-ed: zero
    // exactly when every component is ±0 (NaN counts as non-zero, as with
    // `!=`). Integer ors: on a Cortex-M4F, 15 instructions per node fewer
    // than three float comparisons.
    let mut nonzero = 0u32;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        w.r = [0.0; 3];
        w.q = [0.0; 3];
        if n.flags & FIXED != 0 {
            w.x = [0.0; 3];
            w.d = n.v;
            continue;
        }
        if !warm {
            w.x = [0.0; 3];
        }
        if !keep {
            w.x = add(w.x, fall);
        }
        w.x = carry.guess(obstacles, n, w.x, h);
        nonzero |= (w.x[0].to_bits() | w.x[1].to_bits() | w.x[2].to_bits()) << 1;
        w.d = if fused { add(n.v, w.x) } else { n.v };
    }
    Guess {
        subtract: fused || (uniform && nonzero != 0),
    }
}
