//! The solve: the preconditioner, the system's operator and filter, CG with
//! its certificate and Galerkin fallback, the momentum fix and the push's
//! relaxation.

use super::Ctx;
use crate::backend::{isa_inline, Backend};
use crate::cg::{self, CgOutcome};
use crate::contact::{Carry, Held, Obstacles, Probes};
use crate::element::ElementBlock;
use crate::guard::Correction;
use crate::math::{add, axpy, dot, scale, sub, Vec3};
use crate::pass;
use crate::rigid::Rigid;
use crate::settings::Preconditioner;
use crate::state::{Header, Lists, PreSlots};
use crate::storage::{Node, NodeWork};
use crate::StepError;

/// The prepare stage: makes the preconditioner's data current for this
/// step (`precond::prepare`) and returns the one to use; the lumped mass
/// without the feature `two-level`.
#[inline(always)]
pub(super) fn prepare(
    hdr: &mut Header,
    ctx: &Ctx,
    nodes: &[Node],
    elems: &[ElementBlock],
    n_elems: usize,
    pre: &mut PreSlots<'_>,
) -> Preconditioner {
    let _ = (&hdr, ctx, nodes, elems, n_elems, &pre);
    #[cfg(feature = "two-level")]
    return crate::precond::prepare(
        hdr,
        ctx.per_young,
        nodes,
        elems,
        n_elems,
        &mut pre.parts,
        ctx.mass_coef,
        ctx.k_coef,
    );
    #[cfg(not(feature = "two-level"))]
    Preconditioner::Mass
}

/// The system the solves run on: the filter `S` of held normals and
/// sticking nodes, and the operator `A`.
///
/// Both are closures marked, on x86, `#[inline(always)]`, so that a host
/// that compiles the step for another instruction set (a
/// `#[target_feature]` caller) gets them compiled for it too; a closure
/// left out of line would stay at the baseline. Elsewhere one out-of-line
/// copy saves flash. They are `Copy` (shared references only) and passed by
/// value wherever they go: called through a reference, a closure runs
/// inside the standard library's forwarding function, which is compiled at
/// the baseline, and every AVX2 intrinsic inlined into it becomes a call.
pub(super) struct System<P, A> {
    pub(super) project: P,
    pub(super) apply: A,
}

/// The system of this step: `S` from the obstacles, and
/// `A d = (1 + h α_M) M d + h (α_K + h) K d` (`+ h² k/n d` on grabbed
/// nodes) into `q = 0`, returning `dᵀ A d`.
#[inline(always)]
pub(super) fn system<'a, B: Backend + 'a>(
    b: B,
    hdr: &Header,
    ctx: &Ctx,
    probes: &'a Probes<'_>,
    nodes: &'a [Node],
    elems: &'a [ElementBlock],
    n_elems: usize,
) -> System<impl Fn(usize, Vec3) -> Vec3 + Copy + 'a, impl FnMut(&mut [NodeWork]) -> f32 + Copy + 'a>
{
    let obstacles = Obstacles::new(ctx.ground, probes);
    let spring = hdr.spring();
    let (h, mass_coef, k_coef, per_young) = (ctx.h, ctx.mass_coef, ctx.k_coef, ctx.per_young);
    let project = isa_inline!(move |i: usize, z: Vec3| -> Vec3 { obstacles.filter(nodes, i, z) });
    let apply = isa_inline!(move |work: &mut [NodeWork]| {
        pass::stiffness(b, per_young, elems, n_elems, work);
        let mut dq = 0.0f32;
        for (n, w) in nodes.iter().zip(work.iter_mut()) {
            let mut p = mass_coef * n.mass;
            if spring.holds(n) {
                p += h * h * spring.k();
            }
            w.q = axpy(scale(w.d, p), -k_coef, w.q);
            dq += dot(w.d, w.q);
        }
        dq
    });
    System { project, apply }
}

/// What the solve stage gives the stages after it.
pub(super) struct Solved {
    pub(super) outcome: CgOutcome,
    /// The isolated body at the step's start, with its inertia, when the
    /// preconditioner needed it (the nodes have not moved since).
    #[cfg_attr(not(feature = "free-rotation"), allow(dead_code))]
    pub(super) rigid: Option<Rigid>,
    /// Iterations of the solves after the contact set changed (`cone`).
    pub(super) again: u32,
    /// Free nodes the ground caught in the rounds (`cone`).
    pub(super) caught: u32,
}

/// The solve stage: CG from the guess, with the energy certificate, and the
/// Galerkin step where the certificate did not hold. An isolated body's
/// rigid modes are kept exact by every preconditioner but the mass
/// (`Rigid::finish`). Refuses a system beyond f32 (an overflow).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn solve<P, A>(
    sys: &System<P, A>,
    ctx: &Ctx,
    kind: Preconditioner,
    pre: &mut PreSlots<'_>,
    correction: Option<&Correction>,
    iterations: u32,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Result<Solved, StepError>
where
    P: Fn(usize, Vec3) -> Vec3 + Copy,
    A: FnMut(&mut [NodeWork]) -> f32 + Copy,
{
    let (project, apply) = (sys.project, sys.apply);
    let s = ctx.s;
    let mass_coef = ctx.mass_coef;
    let start = |n: &Node| match correction {
        Some(c) => add(n.v, c.delta(n)),
        None => n.v,
    };
    let rigid = if cfg!(feature = "two-level") && ctx.isolated && kind != Preconditioner::Mass {
        Rigid::new(nodes, ctx.rotations)
    } else {
        None
    };
    #[cfg(feature = "two-level")]
    let whole = crate::precond::whole(kind, rigid, nodes, &mut pre.parts, project, mass_coef);
    #[cfg(not(feature = "two-level"))]
    let whole = {
        let _ = (&pre, mass_coef);
        None::<fn(&mut [NodeWork]) -> f32>
    };
    let outcome = cg::solve(
        work,
        iterations,
        s.iteration_cap(),
        s.cg_tolerance,
        // The lumped-mass norm: the same measure for every preconditioner.
        true,
        project,
        whole,
        apply,
        isa_inline!(|work: &[NodeWork]| {
            cg::certified(nodes, work, project, ctx.h * s.rayleigh_mass, correction)
        }),
    );
    if outcome.overflow {
        return Err(StepError::Diverged);
    }
    if !outcome.certified {
        cg::galerkin(
            nodes,
            work,
            ctx.isolated,
            ctx.rotations,
            project,
            apply,
            start,
        );
    }
    Ok(Solved {
        outcome,
        rigid,
        again: 0,
        caught: 0,
    })
}

/// The cone stage (`contact::cone`): the friction state made Coulomb's
/// for the impulses the solve computed. While a round changes a node, the
/// solve goes on from where it stopped with the new state, at most
/// [`Settings::contact_rounds`](crate::Settings::contact_rounds) times.
/// Without the feature `friction` nothing changes and this is nothing.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn cone<B: Backend>(
    b: B,
    hdr: &Header,
    ctx: &Ctx,
    probes: &Probes<'_>,
    kind: Preconditioner,
    pre: &mut PreSlots<'_>,
    correction: Option<&Correction>,
    solved: &mut Solved,
    nodes: &mut [Node],
    elems: &[ElementBlock],
    n_elems: usize,
    work: &mut [NodeWork],
) -> Result<(), StepError> {
    // A body that a pressure wave crosses within the step (`(c h / L)² >
    // 1`) moves as a whole in it: a change at one contact changes every
    // contact's impulse, which a round's solve then takes twice the
    // iterations to carry through it. Such a body's landings are stopped
    // whole after the solve (`contact::impact`); a softer one's nodes are
    // caught by a ground with friction within the rounds (`contact::cone`).
    // Found once, where a node is to be caught or a round's solve needs it.
    // (The detect stage's, where it found the start body: free.)
    #[cfg(feature = "ground")]
    let mut stiff = ctx.start.map(|(_, ratio2)| ratio2 > 1.0);
    #[cfg(not(feature = "ground"))]
    let mut stiff: Option<bool> = None;
    let mut iterations = ctx.s.cg_iterations;
    for _ in 0..ctx.s.contact_rounds {
        // A pass over the nodes for a catch only while the stiffness is
        // unknown, so that a body none of whose nodes lands pays no pass
        // over the elements for it.
        #[cfg(feature = "friction")]
        if stiff.is_none()
            && !ctx.isolated
            && crate::contact::any_catchable(Obstacles::new(ctx.ground, probes), nodes, work, ctx.h)
        {
            stiff = Some(ctx.wave(nodes, elems, n_elems) > 1.0);
        }
        let catch = !ctx.isolated && stiff == Some(false);
        let obstacles = Obstacles::new(ctx.ground, probes);
        let round = crate::contact::cone(obstacles, nodes, work, ctx.h, catch);
        solved.caught += round.caught;
        if round.changed == 0 {
            break;
        }
        if *stiff.get_or_insert_with(|| ctx.wave(nodes, elems, n_elems) > 1.0) {
            iterations = ctx.s.cg_iterations.saturating_mul(2);
        }
        let mut sys = system(b, hdr, ctx, probes, nodes, elems, n_elems);
        if round.moved > 0 {
            // r = b − A x with the moved x: r −= A d.
            for w in work.iter_mut() {
                w.q = [0.0; 3];
            }
            let _ = (sys.apply)(work);
            for w in work.iter_mut() {
                w.r = sub(w.r, w.q);
            }
        }
        let again = solve(&sys, ctx, kind, pre, correction, iterations, nodes, work)?;
        solved.again += again.outcome.iterations;
        solved.outcome.residual = again.outcome.residual;
        solved.outcome.certified &= again.outcome.certified;
    }
    Ok(())
}

/// The momentum fix: `QrInvertible`'s inverted elements take the closest
/// rotation, whose stiffness product (with the rotated rest gradients) has
/// a net torque: the solve's angular momentum is then made the exact
/// step's (`rigid::keep_angular_momentum`).
#[inline(always)]
pub(super) fn keep_momentum(
    ctx: &Ctx,
    inverted: u32,
    lists: &Lists<'_>,
    nodes: &[Node],
    work: &mut [NodeWork],
) {
    let _ = lists;
    if cfg!(feature = "qr-invertible")
        && ctx.isolated
        && inverted > 0
        && ctx.s.method == crate::Method::QrInvertible
    {
        if let Some(body) = Rigid::new(nodes, true) {
            // The external torque about the centre of mass: the loads'
            // (gravity has none there), summed only on this rare path.
            #[allow(unused_mut)] // only the loads add to it
            let mut torque = [0.0f32; 3];
            #[cfg(feature = "loads")]
            {
                let mut forces = crate::storage::Entries::new(lists.loads);
                for n in nodes.iter() {
                    let f = forces.at(n.flags, crate::storage::LOADED);
                    let arm = crate::math::sub(n.position(), body.c);
                    torque = add(torque, crate::math::cross(arm, f));
                }
            }
            crate::rigid::keep_angular_momentum(
                &body,
                nodes,
                work,
                ctx.mass_coef,
                scale(torque, ctx.h),
            );
        }
    }
}

/// The relax stage (`contact::relax`): a push out of the ground or a probe
/// moves the held nodes inside their plane onto it within the solve, and
/// their neighbours with them; the velocity it gives them only corrects
/// positions, and the push's own solve takes it out again. Returns the
/// fixed nodes' residuals of the step's solve (`−` their impulse), which
/// `relax` sums before its own solve takes the residuals; zero when nothing
/// was pushed.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn relax<P, A>(
    sys: &System<P, A>,
    ctx: &Ctx,
    held: &Held,
    carry: &Carry,
    kind: Preconditioner,
    probes: &Probes<'_>,
    pre: &mut PreSlots<'_>,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Vec3
where
    P: Fn(usize, Vec3) -> Vec3 + Copy,
    A: FnMut(&mut [NodeWork]) -> f32 + Copy,
{
    let _ = (sys, ctx, carry, kind, probes, &pre, nodes, &work);
    #[cfg(feature = "ground")]
    if held.relaxed() {
        let project = sys.project;
        #[cfg(feature = "two-level")]
        let whole = crate::precond::whole(kind, None, nodes, &mut pre.parts, project, 0.0);
        #[cfg(not(feature = "two-level"))]
        let whole = None::<fn(&mut [NodeWork]) -> f32>;
        return crate::contact::relax(
            Obstacles::new(ctx.ground, probes),
            carry.lift(),
            ctx.h,
            nodes,
            work,
            ctx.s,
            project,
            whole,
            sys.apply,
        );
    }
    let _ = held;
    [0.0; 3]
}
