//! One implicit Euler step (Baraff–Witkin, linearised at the current state).
//!
//! ```text
//! (M + h C + h² K) Δv = h (f₀ − h K v),   f₀ = f_el(x) + f_ext − C v,   C = α_M M + α_K K
//! x ← x + h (v + Δv),   v ← v + Δv
//! ```
//!
//! Expanded, with `A = (1 + h α_M) M + h (α_K + h) K` (plus `h² k/n` on nodes
//! the tool holds):
//!
//! ```text
//! b = h (f_el + f_ext + m g − α_M M v) + h (α_K + h) (−K v)
//! ```
//!
//! The step is a pipeline of named stages over one [`Ctx`], in the order
//! the maths needs them (after Box2D v3's solver stages). Each stage is a
//! function of its own room; a model whose feature is off compiles its
//! stage to nothing, so the orchestrator ([`step_inline`]) reads the same in
//! every build. The stages, their rooms and what each does are the table of
//! the crate's documentation ("The step", lib.rs).

mod end;
mod guess;
mod rhs;
mod solve;

use crate::backend::Backend;
use crate::contact::Ground;
use crate::math::{scale, Vec3};
use crate::pass;
use crate::settings::{Settings, StepStats};
use crate::state::{Header, View};
use crate::StepError;

/// The step, compiled once in this crate (`Scene::step` of every storage
/// type calls it, so a crate that steps scenes does not compile its own
/// copy) for each instruction set the target has: with AVX2 where the scene
/// asks for it (or for the best) and the CPU has it, else with the target's
/// baseline.
pub(crate) fn step(v: View<'_>) -> Result<StepStats, StepError> {
    #[cfg(target_arch = "x86_64")]
    if v.hdr.isa != crate::state::IsaChoice::Baseline {
        if let Some(avx2) = crate::backend::Avx2::new() {
            // The whole step inlined into one function compiled for AVX2.
            return avx2.call(
                #[inline(always)]
                || step_inline(avx2, v),
            );
        }
    }
    step_with(crate::backend::BASELINE, v)
}

/// The step with the backend `b`, where the compiler chooses what to
/// inline (forcing the step inline here measured one instruction per
/// tetrahedron-step more on a Cortex-M4F).
fn step_with<B: Backend>(b: B, v: View<'_>) -> Result<StepStats, StepError> {
    step_inline(b, v)
}

/// What every stage reads: the settings and the constants of the step.
#[derive(Clone, Copy)]
pub(crate) struct Ctx {
    pub(crate) s: Settings,
    /// The time step `h`.
    pub(crate) h: f32,
    /// `1 + h α_M`: the mass term's factor in `A`.
    pub(crate) mass_coef: f32,
    /// `h (α_K + h)`: the stiffness term's factor in `A`.
    pub(crate) k_coef: f32,
    /// `[λ/E, μ/E]` of the body.
    pub(crate) per_young: [f32; 2],
    /// Some node is fixed.
    pub(crate) any_fixed: bool,
    /// The free-fall velocity change `h g / (1 + h α_M)` of a body no node
    /// of which is fixed (zero for the others): the guess's uniform part.
    pub(crate) fall: Vec3,
    /// The method's `K` annihilates rotations about the current shape
    /// (`Qr`, `QrInvertible`, whose `B` is that of the current shape), as
    /// every method's annihilates translations.
    pub(crate) rotations: bool,
    /// The ground and its friction.
    pub(crate) ground: Ground,
    /// Nothing holds the body: no fixed node, tool or contact (set by the
    /// detect stage).
    pub(crate) isolated: bool,
    /// The body at the step's start, with its inertia, and its
    /// [`wave`](crate::rigid::wave) `(c h / L)²`, where the detect stage
    /// needed them (the nodes do not move until the commit: every later
    /// stage's body at the start is this one, bit for bit).
    #[cfg(feature = "ground")]
    pub(crate) start: Option<(crate::rigid::Rigid, f32)>,
    /// The ground's contact is the whole body's (`contact::whole`): a body
    /// that moves as one over the step, that nothing but the ground can
    /// hold, near the plane (set by the detect stage).
    #[cfg(feature = "ground")]
    pub(crate) whole: bool,
}

impl Ctx {
    /// The start body's [`wave`](crate::rigid::wave) `(c h / L)²` (0 for a
    /// body without mass), for a stage that needs it where the detect stage
    /// did not find it (`start` is `None`; else `wave_of` gives it without
    /// the body).
    #[inline(always)]
    pub(crate) fn wave(
        &self,
        nodes: &[crate::storage::Node],
        elems: &[crate::element::ElementBlock],
        n_elems: usize,
    ) -> f32 {
        crate::rigid::Rigid::new(nodes, true)
            .map_or(0.0, |body| self.wave_of(&body, elems, n_elems))
    }

    /// The [`wave`](crate::rigid::wave) of `body`, the start body: the
    /// detect stage's where it has one.
    #[inline(always)]
    fn wave_of(
        &self,
        body: &crate::rigid::Rigid,
        elems: &[crate::element::ElementBlock],
        n_elems: usize,
    ) -> f32 {
        #[cfg(feature = "ground")]
        if let Some((_, ratio2)) = self.start {
            return ratio2;
        }
        crate::rigid::wave(body, elems, n_elems, self.per_young, self.h)
    }

    /// The share of the start body `body` that moves as one over the step
    /// ([`share`](crate::rigid::share)), from the detect stage's wave where
    /// it has one.
    #[inline(always)]
    pub(crate) fn share(
        &self,
        body: &crate::rigid::Rigid,
        elems: &[crate::element::ElementBlock],
        n_elems: usize,
    ) -> f32 {
        crate::rigid::share(self.wave_of(body, elems, n_elems))
    }

    #[inline(always)]
    fn new(hdr: &Header) -> Self {
        let s = hdr.settings;
        let h = s.dt;
        let (mass_coef, k_coef) = hdr.coefficients();
        Self {
            s,
            h,
            mass_coef,
            k_coef,
            per_young: hdr.per_young(),
            any_fixed: hdr.any_fixed,
            fall: if hdr.any_fixed {
                [0.0; 3]
            } else {
                scale(s.gravity, h / mass_coef)
            },
            rotations: matches!(s.method, crate::Method::Qr | crate::Method::QrInvertible),
            ground: hdr.ground(),
            isolated: false,
            #[cfg(feature = "ground")]
            start: None,
            #[cfg(feature = "ground")]
            whole: false,
        }
    }
}

/// The step with the backend `b`: inlined where it is called, so that its
/// node loops are compiled for the instruction set of the function it is
/// inlined into. Each stage is a function of its room, in the order the
/// maths needs them (the table in this module's documentation).
#[inline(always)]
fn step_inline<B: Backend>(b: B, v: View<'_>) -> Result<StepStats, StepError> {
    let View {
        hdr,
        nodes,
        work,
        elems,
        n_elems,
        lists,
        mut pre,
        mut probes,
    } = v;
    let mut ctx = Ctx::new(hdr);
    let h = ctx.h;
    // The node and work slices cut to one length, so that a node index
    // checked against one is known to be in range of the other (the element
    // pass, out of line off x86, cuts its own again: on a Cortex-M4F its
    // scatter then checks once, 21 instructions per tetrahedron-step fewer).
    // (`len` is at most either length: the slicing cannot panic, which the
    // firmware's link-time proof confirms.)
    let len = nodes.len().min(work.len());
    let (nodes, work) = (&mut nodes[..len], &mut work[..len]);

    // What holds the body, and the guess the solve starts from.
    let held = guess::detect(hdr, &mut probes, nodes, work, elems, n_elems, &mut ctx);
    let carry = guess::carry(&ctx, &held, nodes, elems, n_elems);
    let guess = guess::guess(hdr, &ctx, &held, &carry, &probes, nodes, work);

    // Element pass: elastic forces into r, −K d into q.
    let was_inverted = hdr.inverted > 0;
    let totals = element_pass(b, &ctx, nodes, elems, n_elems, work);
    hdr.inverted = totals.inverted;

    // The preconditioner, the right-hand side, the energy guard.
    let kind = solve::prepare(hdr, &ctx, nodes, elems, n_elems, &mut pre);
    let ledger = rhs::residual(hdr, &ctx, &lists, &probes, guess.subtract, nodes, work);
    let energy = rhs::energy(&ledger, totals.energy);
    let inverted = was_inverted || totals.inverted > 0;
    let correction = rhs::guard(hdr, &ctx, &energy, inverted, nodes, work);

    // The solve, the momentum fix, the push's relaxation.
    let sys = solve::system(b, hdr, &ctx, &probes, nodes, elems, n_elems);
    let mut solved = solve::solve(
        &sys,
        &ctx,
        kind,
        &mut pre,
        correction.as_ref(),
        ctx.s.cg_iterations,
        nodes,
        work,
    )?;
    solve::cone(
        b,
        hdr,
        &ctx,
        &probes,
        kind,
        &mut pre,
        correction.as_ref(),
        &mut solved,
        nodes,
        elems,
        n_elems,
        work,
    )?;
    let sys = solve::system(b, hdr, &ctx, &probes, nodes, elems, n_elems);
    solve::keep_momentum(&ctx, totals.inverted, &lists, nodes, work);
    let fixed_r = solve::relax(
        &sys, &ctx, &held, &carry, kind, &probes, &mut pre, nodes, work,
    );

    // The step's end: the candidates, the free turn, the landing, the
    // impulses (refused unless finite).
    let mut end = end::candidates(&ctx, &held, nodes, work);
    end::turn(&ctx, &solved, &mut end, nodes, elems, n_elems, work);
    end::impact(&ctx, &held, &carry, &mut end, nodes, elems, n_elems, work);
    let pressed = end.pressed;
    let forces = end::impulses(
        hdr,
        &ctx,
        &held,
        &lists,
        &mut probes,
        end,
        fixed_r,
        nodes,
        work,
    )?;

    // Commit: the state, the contacts' flags, the guard's reference.
    end::commit(&ctx, pressed, nodes, work, &mut probes, &mut pre, h);
    let outcome = solved.outcome;
    hdr.time += f64::from(h);
    hdr.guess_stale = outcome.iterations > ctx.s.cg_iterations || !outcome.certified;
    let removed = correction.map_or(0.0, |c| c.removed);
    rhs::remember(hdr, &ctx, &energy, forces.closed, removed);
    Ok(StepStats {
        cg_iterations: outcome.iterations + solved.again,
        galerkin: !outcome.certified,
        cg_residual: outcome.residual,
        inverted: totals.inverted,
        contacts: held.held + solved.caught + pressed,
        tool_force: forces.tool,
        support_force: scale(forces.support, 1.0 / h),
        elastic_energy: if cfg!(feature = "diagnostics") {
            totals.energy
        } else {
            f32::NAN
        },
        energy_removed: removed,
    })
}

/// The element pass: elastic forces into `r`, `−K d` into `q`. Compiled as
/// a function of its own off x86 (its loop then gets the registers to
/// itself); inlined on x86 so that it is compiled for the step's
/// instruction set.
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
#[cfg_attr(not(any(target_arch = "x86", target_arch = "x86_64")), inline(never))]
fn element_pass<B: Backend>(
    b: B,
    ctx: &Ctx,
    nodes: &[crate::storage::Node],
    elems: &mut [crate::element::ElementBlock],
    n_elems: usize,
    work: &mut [crate::storage::NodeWork],
) -> pass::PassTotals {
    // One length, so that the scatter needs no second bounds check.
    let len = nodes.len().min(work.len());
    let (nodes, work) = (&nodes[..len], &mut work[..len]);
    pass::forces::<B, true, true>(
        b,
        ctx.s.method,
        ctx.per_young,
        nodes,
        elems,
        n_elems,
        pass::IntoWork(work),
    )
}
