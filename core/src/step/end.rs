//! The step's end: the candidate state, the free turn, the landing, the
//! impulses, and the commit.
//!
//! From the candidates on, a node's new displacement and velocity are held
//! in [`NodeWork::end`], the CG's spent direction slots: the state is
//! written only once they, the tool force and the support are all finite.

use super::solve::Solved;
use super::Ctx;
use crate::contact::{self, Carry, Held, Probes};
use crate::element::ElementBlock;
use crate::math::{add, finite_probe, sub, Vec3};
use crate::state::{Header, Lists, PreSlots};
use crate::storage::{Node, NodeWork, FIXED};
use crate::StepError;

/// What the end stages found.
#[derive(Clone, Copy)]
pub(super) struct End {
    /// Some node that nothing held ends below the ground.
    below: bool,
    /// The ground's impulse of a landing body's rigid stop.
    support: Vec3,
    /// The nodes the ground presses in the whole body's contact.
    pub(super) pressed: u32,
}

/// The candidates stage: `v' = v + Δv` and `u' = u + h v'` of every node
/// (`contact::displaced` after a push), and whether a free node lands.
#[inline(always)]
pub(super) fn candidates(ctx: &Ctx, held: &Held, nodes: &[Node], work: &mut [NodeWork]) -> End {
    let relaxed = held.relaxed();
    let (h, ground) = (ctx.h, ctx.ground);
    let mut below = false;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let v = add(n.v, w.x);
        let u = contact::displaced(n, w, v, relaxed, h);
        below |= contact::lands(ground, n, u);
        w.set_end(u, v);
    }
    End {
        below,
        support: [0.0; 3],
        pressed: 0,
    }
}

/// The turn stage: an isolated body turns over the step as a rigid
/// rotation, not along its tangents (`turn::turn`, feature
/// `free-rotation`, [`Settings::free_rotation`](crate::Settings::free_rotation)). (`Linear`'s elements are
/// not invariant under rotations: its tangent update is the one that
/// leaves them unstrained.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn turn(
    ctx: &Ctx,
    solved: &Solved,
    end: &mut End,
    nodes: &[Node],
    elems: &[ElementBlock],
    n_elems: usize,
    work: &mut [NodeWork],
) {
    let _ = (ctx, solved, &end, nodes, elems, n_elems, &work);
    #[cfg(feature = "free-rotation")]
    if ctx.isolated && ctx.s.free_rotation && ctx.s.method != crate::Method::Linear {
        // The body at the step's start, with its inertia: the
        // preconditioner's when it has one (the nodes have not moved since).
        let known = solved.rigid.filter(|b| b.inertia.is_some());
        let body = known.or_else(|| crate::rigid::Rigid::new(nodes, true));
        let share = |body: &crate::rigid::Rigid| ctx.share(body, elems, n_elems);
        if crate::turn::turn(body, nodes, work, ctx.h, share) {
            end.below = contact::below(ctx.ground, nodes, work);
        }
    }
}

/// The impact stage (`contact::impact`): nodes that end below the ground,
/// of a body no fixed node holds: the body's rigid motion first takes them
/// out, then each node still below loses its inward normal velocity and is
/// pushed out by the next step.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn impact(
    ctx: &Ctx,
    held: &Held,
    carry: &Carry,
    end: &mut End,
    nodes: &[Node],
    elems: &[ElementBlock],
    n_elems: usize,
    work: &mut [NodeWork],
) {
    let _ = (ctx, held, carry, &end, nodes, elems, n_elems, &work);
    #[cfg(feature = "ground")]
    if let (Some(g), true, true, Some((body, _))) =
        (ctx.ground.plane, end.below, ctx.whole, ctx.start)
    {
        #[cfg(feature = "friction")]
        let mu = (
            ctx.ground.friction.static_coefficient(),
            ctx.ground.friction.kinetic_coefficient(),
        );
        #[cfg(not(feature = "friction"))]
        let mu = (0.0, 0.0);
        (end.support, end.pressed) =
            contact::whole::solve(g, mu, ctx.h, ctx.s.gravity, &body, nodes, work);
        return;
    }
    #[cfg(feature = "ground")]
    if let (Some(g), true, false) = (ctx.ground.plane, end.below, ctx.any_fixed) {
        let share = |body: &crate::rigid::Rigid| ctx.share(body, elems, n_elems);
        let body = match carry.resting() {
            Some(body) => Some(body),
            None => crate::rigid::Rigid::new(nodes, true),
        };
        if let Some(body) = body {
            let resting = held.ground > 0;
            end.support =
                contact::impact(g, ctx.h, ctx.s.gravity, resting, &body, nodes, work, share);
        }
    }
}

/// The forces of the step, from its impulses.
#[derive(Clone, Copy)]
pub(super) struct Forces {
    /// The tool's force on the body's grabbed nodes, reversed: what the body
    /// pulls the tool with (N).
    pub(super) tool: Vec3,
    /// The support's impulse over the step (the fixed nodes', the
    /// ground's).
    pub(super) support: Vec3,
    /// Nothing did work on the body: no obstacle held or stopped it (the
    /// held normals' prescribed velocities, the impact, the stop).
    pub(super) closed: bool,
}

/// The impulses stage: each node's landing (`contact::land`), its contact
/// and friction impulse (`contact::impulse`), the fixed nodes' and the
/// tool's forces; then the check that everything the step would write is
/// finite. Refuses the step ([`StepError::Diverged`]) where it is not.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn impulses(
    hdr: &Header,
    ctx: &Ctx,
    held: &Held,
    lists: &Lists<'_>,
    probes: &mut Probes<'_>,
    end: End,
    fixed_r: Vec3,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Result<Forces, StepError> {
    let relaxed = held.relaxed();
    let ground = ctx.ground;
    let spring = hdr.spring();
    let mut support = end.support;
    let mut fixed_r = fixed_r;
    #[allow(unused_mut)] // only the tool adds to it
    let mut tool = [0.0f32; 3];
    #[cfg(feature = "tool")]
    let mut offsets = crate::storage::Entries::new(lists.grabs);
    let _ = lists;
    let mut landed = false;
    // The momentum the contacts' impulses at the cone left the body with
    // (`contact::impulse`), given to it as a whole below.
    let mut spread = [0.0f32; 3];
    // `probe` stays zero exactly while every value checked is finite
    // (`math::finite_probe`).
    let mut probe = 0.0f32;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let (u, v) = w.end();
        let (v, lands) = contact::land(ground, probes, n, u, v, &mut support);
        landed |= lands;
        // After `relax` (which kept the step's `Σ r` over the fixed nodes),
        // `r` is the push's residual, whose impulses only moved positions.
        if n.flags & FIXED != 0 {
            fixed_r = if relaxed {
                sub(fixed_r, w.r)
            } else {
                add(fixed_r, w.r)
            };
        }
        let (u, v) = contact::impulse(
            ground,
            probes,
            n,
            w,
            (u, v),
            relaxed,
            &mut support,
            &mut spread,
        );
        #[cfg(feature = "tool")]
        if spring.holds(n) {
            // The body pulls the tool with minus the spring force.
            let stretch = sub(add(n.x0, u), spring.anchor(offsets.next()));
            tool = add(tool, crate::math::scale(stretch, spring.k()));
        }
        // The position x₀ + u is what a user reads: it must be finite too
        // (a node near f32::MAX plus a finite displacement can overflow,
        // found by fuzzing). A finite sum implies a finite u. (Written out
        // again rather than bound before the tool branch: the compiler shares
        // the sum either way, and the binding measured 6 instructions per
        // tet-step more on the Cortex-M4F.)
        probe = finite_probe(finite_probe(probe, add(n.x0, u)), v);
        w.set_end(u, v);
    }
    let _ = spring;
    #[cfg(feature = "friction")]
    if spread != [0.0; 3] {
        probe = contact::spread(spread, ctx.h, nodes, work, probe);
    }
    let support = sub(support, fixed_r);
    probe = finite_probe(finite_probe(probe, tool), support);
    probe = contact::finite(probes, probe);
    if probe != 0.0 {
        return Err(StepError::Diverged);
    }
    Ok(Forces {
        tool,
        support,
        closed: held.held == 0 && !end.below && !landed,
    })
}

/// The commit stage: the new state, the contacts' flags for the next step,
/// the probes' forces, and the aggregates' rotations.
#[inline(always)]
pub(super) fn commit(
    ctx: &Ctx,
    pressed: u32,
    nodes: &mut [Node],
    work: &mut [NodeWork],
    probes: &mut Probes<'_>,
    pre: &mut PreSlots<'_>,
    h: f32,
) {
    #[cfg(feature = "ground")]
    if let (true, Some(g)) = (ctx.whole, ctx.ground.plane) {
        for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
            (n.u, n.v) = w.end();
            contact::commit_whole(n, w, g.normal, pressed > 0);
        }
    } else {
        for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
            (n.u, n.v) = w.end();
            contact::commit(n, w);
        }
    }
    #[cfg(not(feature = "ground"))]
    {
        let _ = (ctx, pressed);
        for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
            (n.u, n.v) = w.end();
            contact::commit(n, w);
        }
    }
    contact::commit_probes(probes, h);
    let _ = &pre;
    #[cfg(feature = "two-level")]
    crate::precond::commit_rotations(pre.parts.aggs);
}
