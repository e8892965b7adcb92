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
//! A body that nothing holds and that moves as one over the step turns by a
//! rigid rotation instead (`turn`, feature `free-rotation`).
//!
//! Pipeline: one element pass computes the elastic forces, refreshes the
//! world gradients and (fused) `−K v`; a node pass forms `b`, the
//! preconditioner and the constraints; CG runs element passes of `−K d`; a
//! last node pass checks the result is finite and applies it.

use crate::backend::Backend;
use crate::cg;
#[cfg(feature = "ground")]
use crate::ground::Contact;
#[cfg(feature = "ground")]
use crate::math::is_finite3;
use crate::math::{add, axpy, cross, dot, finite_probe, scale, solve3, sub, Vec3};
use crate::pass;
#[cfg(target_arch = "x86_64")]
use crate::scene::IsaChoice;
use crate::scene::View;
use crate::settings::StepStats;
#[cfg(any(feature = "tool", feature = "loads"))]
use crate::storage::Entries;
#[cfg(feature = "probe")]
use crate::storage::BOUNDARY;
#[cfg(feature = "tool")]
use crate::storage::GRABBED;
#[cfg(feature = "loads")]
use crate::storage::LOADED;
#[cfg(feature = "friction")]
use crate::storage::STUCK;
use crate::storage::{Node, NodeWork, FIXED};
#[cfg(feature = "ground")]
use crate::storage::{CONTACT, ON_GROUND, RELEASED};
#[cfg(feature = "two-level")]
use crate::Preconditioner;
use crate::StepError;

/// The step, compiled once in this crate (`Scene::step` of every storage
/// type calls it, so a crate that steps scenes does not compile its own
/// copy) for each instruction set the target has: with AVX2 where the scene
/// asks for it (or for the best) and the CPU has it, else with the target's
/// baseline.
pub(crate) fn step(v: View<'_>) -> Result<StepStats, StepError> {
    #[cfg(target_arch = "x86_64")]
    if v.hdr.isa != IsaChoice::Baseline {
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

/// The step with the backend `b`: inlined where it is called, so that its
/// node loops are compiled for the instruction set of the function it is
/// inlined into.
#[inline(always)]
fn step_inline<B: Backend>(b: B, v: View<'_>) -> Result<StepStats, StepError> {
    let View {
        hdr,
        nodes,
        work,
        elems,
        n_elems,
        #[cfg(feature = "tool")]
        grabs,
        #[cfg(feature = "loads")]
        loads,
        #[cfg(feature = "two-level")]
        mut pre,
        #[cfg(feature = "probe")]
        probes,
    } = v;
    let s = hdr.settings;
    let per_young = hdr.per_young();
    let h = s.dt;
    let mass_coef = 1.0 + h * s.rayleigh_mass;
    let k_coef = h * (s.rayleigh_stiffness + h);
    #[cfg(feature = "tool")]
    let tool = hdr.tool;
    #[cfg(feature = "ground")]
    let ground = hdr.ground;
    #[cfg(feature = "friction")]
    let ground_friction = hdr.ground_friction;
    #[cfg(feature = "probe")]
    for p in probes.iter_mut() {
        p.next_force = [0.0; 3];
        p.next_contacts = 0;
    }
    #[cfg(feature = "probe")]
    let has_probes = !probes.is_empty();
    // Whether anything can hold a node: the ground or a probe.
    #[cfg(feature = "ground")]
    let obstacles = Obstacles::new(
        ground,
        #[cfg(feature = "friction")]
        ground_friction,
        #[cfg(feature = "probe")]
        probes,
    );
    // A copy, for the passes that write the probes' sums.
    #[cfg(feature = "ground")]
    let obstacles_any = obstacles.any();

    // The node and work slices cut to one length, so that a node index
    // checked against one is known to be in range of the other: the force
    // pass then scatters without checking again (on a Cortex-M4F, 21
    // instructions per tetrahedron-step fewer).
    // (`len` is at most either length: the slicing cannot panic, which the
    // firmware's link-time proof confirms.)
    let len = nodes.len().min(work.len());
    let (nodes, work) = (&mut nodes[..len], &mut work[..len]);

    // Initial guess. CG truncated after a few iterations scales each part of
    // the right-hand side differently, including the uniform part `h M g`,
    // so a falling body would feel a fraction of gravity. A uniform velocity
    // change is an exact eigenvector of A (K of a translation is zero, bit for
    // bit, since every element sees equal node values), so when no node is
    // fixed we start from the free-fall change `c = h g / (1 + h α_M)` and CG
    // only has the rest to do. Fixed bodies start from zero (or the warm start).
    //
    // The guess is made before the element pass, whose stiffness product
    // then takes `v + x₀`: `b − A x₀ = h f − h (h + α_K) K (v + x₀) − p x₀`
    // (`p` the node's mass term) costs no product of its own.
    let any_fixed = hdr.any_fixed;
    let fall = if any_fixed {
        [0.0; 3]
    } else {
        scale(s.gravity, h / mass_coef)
    };
    #[allow(unused_mut)] // only the ground counts held nodes
    let mut held = 0u32;
    // Held nodes below their plane beyond round-off, which the step pushes
    // out, and the nodes the ground holds (the others' are probes').
    #[cfg(feature = "ground")]
    let mut pushes = 0u32;
    #[cfg(feature = "ground")]
    let mut held_ground = 0u32;
    #[allow(unused_mut)] // only the ground and the tool set it
    let mut isolated = !any_fixed;
    // The grabbed nodes hold the body (a grab lists at least one node).
    #[cfg(feature = "tool")]
    if tool.active() {
        isolated = false;
    }
    // The held nodes: a pass of its own, before the guess, which depends
    // on whether any node is held.
    #[cfg(feature = "ground")]
    if obstacles_any {
        for (n, _w) in nodes.iter_mut().zip(work.iter_mut()) {
            // What held the node last step (not released, or it is skipped).
            let was = (n.flags & CONTACT != 0).then_some(n.contact);
            n.flags &= !CONTACT;
            // Between steps the flag says the node slid on `was` in the
            // last step and did not stop; within a step, it sticks.
            #[cfg(feature = "friction")]
            let slid = n.flags & STUCK != 0;
            #[cfg(feature = "friction")]
            {
                n.flags &= !STUCK;
            }
            // The planned drag, kept below only for a node that slides on.
            #[cfg(feature = "friction")]
            let drag = core::mem::replace(&mut _w.drag, [0.0; 3]);
            if n.flags & (FIXED | RELEASED) != 0 {
                continue;
            }
            let x = n.position();
            if let Some((id, c)) = obstacles.deepest(n, x, h, was) {
                n.flags |= CONTACT;
                n.contact = id;
                // A held node sticks unless it slid on the same obstacle
                // in the last step (and did not stop): a contact that the
                // static friction cannot hold is found by its impulse
                // (`Contact::drag_after_stick`), and slides from the next
                // step, with the kinetic friction force planned then.
                #[cfg(feature = "friction")]
                if slid && was == Some(id) {
                    _w.drag = drag;
                } else if c.friction.sticks() {
                    n.flags |= STUCK;
                }
                held += 1;
                held_ground += u32::from(id == ON_GROUND);
                pushes += u32::from(c.push(x).is_some());
                isolated = false;
            }
        }
    }
    // A body that the ground holds and nothing else: the guess's rigid part
    // is the plane's motion that gives the held nodes their prescribed
    // normal velocity change (`PlaneFit`), not the free fall. A resting
    // body then starts at rest, carried as a whole, and the solve has only
    // its deformation to find: the part a truncated solve resolves. (From
    // the free fall it would have to stop the whole body through the layer
    // above the held nodes.)
    // (The body's inertia at the step's start serves the landing below too:
    // the nodes do not move until the step is applied.)
    #[cfg(feature = "ground")]
    let resting = match ground {
        Some(_) if held_ground > 0 && !any_fixed => Rigid::new(nodes, true),
        _ => None,
    };
    // Nodes the ground pushes out, of a body it alone holds: the push is
    // the rigid lift that takes every held node at least to the plane
    // (`Lift`), not each node to the plane on its own.
    #[cfg(feature = "ground")]
    let lift = match (ground, &resting) {
        (Some(g), Some(body))
            if pushes > 0
                && held == held_ground
                && reach(body, elems, n_elems, per_young, h) >= 1.0 =>
        {
            Lift::new(g, body, nodes, h)
        }
        _ => None,
    };
    #[cfg(feature = "ground")]
    let depth = |n: &Node, dist: f32| lift.as_ref().map_or(dist, |l| l.depth(n, dist, h));
    #[cfg(feature = "ground")]
    let carried = match (ground, &resting) {
        (Some(g), Some(body)) => {
            let mut fit = PlaneFit::new(g.normal, body.c);
            let g = Contact::still(g);
            for n in nodes.iter().filter(|n| on_ground(n)) {
                let dv = g.held_dv(depth(n, g.distance(n.position())), n.v, h);
                fit.add(n.position(), n.mass, dv - dot(g.normal, fall));
            }
            fit.solve(body).map(|m| (fit, m))
        }
        _ => None,
    };
    // A warm guess with held normals can start the solve worse than no
    // guess (the normals are prescribed, and a truncated solve from there
    // cannot undo them): steps with ground contacts start cold. So does the
    // step after one whose solve had no energy certificate at its budget:
    // there the linearised step is far from the motion (a stiff body yanked
    // by the tool, elements turning over), the last velocity change is no
    // estimate of the next, and a guess carried from step to step keeps
    // the error in the modes a truncated solve leaves untouched (a liver
    // of E = 1e10 Pa pulled by a stiff tool gains 10⁶ to 10¹² times the
    // tool's work with the guess, at most 1.6 times without it).
    let warm = s.warm_start && held == 0 && !hdr.guess_stale;
    // An isolated body's rigid motions: translations, which `K` annihilates
    // bit for bit in every method, and, for `Qr`, whose `B` is that of the
    // current shape, rotations about the current shape too. The solve keeps
    // the exact step's response to these modes (the momentum), whatever the
    // preconditioner and however it is truncated: the mass preconditioner
    // does by itself; the others are made exact on them (`Rigid::finish`),
    // and only they need the body's inertia at every step.
    let rotations = matches!(s.method, crate::Method::Qr | crate::Method::QrInvertible);
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
    let fused = warm || (!isolated && (!any_fixed || held > 0));
    // Add the free fall to the guess and prescribe the held normals; the
    // product's input into `d`.
    let keep = warm && !isolated;
    // The bits of every guess component, sign bit shifted out, or-ed: zero
    // exactly when every component is ±0 (NaN counts as non-zero, as with
    // `!=`). Integer ors: on a Cortex-M4F, 15 instructions per node fewer
    // than three float comparisons.
    let mut nonzero = 0u32;
    for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
        w.r = [0.0; 3];
        w.q = [0.0; 3];
        // Without a ground or probes no node is held (flags left by an
        // earlier step).
        #[cfg(feature = "ground")]
        if !obstacles_any {
            n.flags &= !CONTACT;
            #[cfg(feature = "friction")]
            {
                n.flags &= !STUCK;
            }
        }
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
        #[cfg(feature = "ground")]
        if let Some((fit, m)) = &carried {
            w.x = add(w.x, fit.at(n.position(), *m));
        }
        #[cfg(feature = "ground")]
        if let Some(c) = obstacles.holding(n) {
            let dist = depth(n, c.distance(n.position()));
            w.x = c.with_normal(w.x, c.held_dv(dist, n.v, h));
            #[cfg(feature = "friction")]
            if n.flags & STUCK != 0 {
                w.x = c.stuck_dv(dist, n.v, h);
            }
        }
        nonzero |= (w.x[0].to_bits() | w.x[1].to_bits() | w.x[2].to_bits()) << 1;
        w.d = if fused { add(n.v, w.x) } else { n.v };
    }
    // `− p x₀` in the right-hand side: with the fused product, or for a
    // uniform guess that is not zero.
    let subtract = fused || (uniform && nonzero != 0);

    // Whether the last step started with inverted elements (the guard's
    // condition below).
    let was_inverted = hdr.inverted > 0;
    // Element pass: elastic forces into r, −K d into q.
    let totals = pass::forces::<B, true, true>(
        b,
        s.method,
        per_young,
        nodes,
        elems,
        n_elems,
        pass::IntoWork(work),
    );
    hdr.inverted = totals.inverted;

    // The preconditioner: node blocks of A from the gradients just
    // refreshed, the aggregates' rotations, and (after a change) the coarse
    // factor.
    #[cfg(feature = "two-level")]
    let kind = prepare(
        hdr, per_young, nodes, elems, n_elems, &mut pre, mass_coef, k_coef,
    );

    // Node pass: the residual `b − A x₀` and the preconditioner's scalars.
    #[cfg(feature = "tool")]
    let mut offsets = Entries::new(grabs);
    #[cfg(feature = "loads")]
    let mut forces = Entries::new(loads);
    // The guard's sums: twice the kinetic energy, the potential energy of
    // gravity and the loads (`−f·u`, constant forces), and its magnitude.
    let mut ledger = Ledger::default();
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let m = n.mass;
        let weight = scale(s.gravity, m);
        #[cfg(feature = "loads")]
        let (load, f_el) = {
            let load = forces.at(n.flags, LOADED);
            (load, add(w.r, load))
        };
        #[cfg(not(feature = "loads"))]
        let (load, f_el) = ([0.0; 3], w.r);
        ledger.add(n, weight, load);
        let mut f = add(f_el, weight);
        // A sliding node's kinetic friction, along its contact plane.
        #[cfg(feature = "friction")]
        if w.drag != [0.0; 3] {
            if let Some(c) = obstacles.holding(n) {
                w.drag = c.filter(w.drag);
                f = add(f, w.drag);
            }
        }
        f = axpy(f, -s.rayleigh_mass * m, n.v);
        #[allow(unused_mut)] // only the tool adds to it
        let mut p = mass_coef * m;
        #[cfg(feature = "tool")]
        if n.flags & GRABBED != 0 && tool.active() {
            // Implicit spring: f += k (anchor − x) − h k v, A += h² k.
            let k = tool.k_node;
            let offset = offsets.next();
            let stretch = sub(tool.anchor(offset), n.position());
            f = add(f, scale(stretch, k));
            #[cfg(feature = "energy-guard")]
            ledger.spring(
                k,
                stretch,
                sub(add(hdr.energy_target, offset), n.position()),
            );
            f = axpy(f, -h * k, n.v);
            p += h * h * k;
        }
        w.r = axpy(scale(f, h), k_coef, w.q);
        if n.flags & FIXED != 0 {
            w.inv_p = 0.0;
            continue;
        }
        w.inv_p = 1.0 / p;
        if subtract {
            w.r = axpy(w.r, -p, w.x);
        }
    }
    // The energy guard (`Correction`): the body's energy at the step's
    // start against the reference the last step left.
    let elastic = totals.energy;
    let own = 0.5 * ledger.kinetic2 + elastic + ledger.potential;
    let energy = own + ledger.spring;
    // The reference counts the tool spring's energy with the target of its
    // step. Moving the target since did work on the body, which the check
    // credits: it counts the spring with the reference's target, the energy
    // the body would have had the target stayed.
    let checked = own + ledger.spring_ref;
    #[allow(unused_mut)] // only the ground sets it
    let mut closed = true;
    let guard = cfg!(feature = "energy-guard") && s.energy_guard;
    #[cfg(feature = "energy-guard")]
    let reference = hdr.energy_known.then_some(hdr.energy_ref);
    #[cfg(not(feature = "energy-guard"))]
    let reference = None::<f32>;
    let size = 0.5 * ledger.kinetic2 + elastic.abs() + ledger.magnitude + ledger.spring_ref;
    // Only a step across which elements were inverted is corrected: there
    // `Qr`'s forces pump energy in. Elsewhere the energy measured is not one
    // that `Qr`'s forces conserve exactly either (its rotation is not the
    // polar one), and the converged implicit step itself moves it by a few
    // per cent of the kinetic energy per step in a swinging body (the
    // hanging liver of docs/bench.md): that is the scheme, not an error to
    // take out.
    let inverted = was_inverted || totals.inverted > 0;
    let correction = match reference {
        Some(r) if guard && closed && inverted && checked - r > GUARD_ROUNDING * size => {
            Correction::new(nodes, work, any_fixed, checked - r)
        }
        _ => None,
    };
    if let Some(c) = &correction {
        for (n, w) in nodes.iter().zip(work.iter_mut()) {
            if n.flags & FIXED == 0 {
                w.r = axpy(w.r, n.mass, c.delta(n));
            }
        }
    }
    let start = |n: &Node| match &correction {
        Some(c) => add(n.v, c.delta(n)),
        None => n.v,
    };
    #[cfg(feature = "two-level")]
    let rigid = if isolated && kind != Preconditioner::Mass {
        Rigid::new(nodes, rotations)
    } else {
        None
    };
    // The operator and the filter are closures marked, on x86,
    // `#[inline(always)]`, so that a host that compiles the step for another
    // instruction set (a `#[target_feature]` caller) gets them compiled for
    // it too; a closure left out of line would stay at the baseline.
    // Elsewhere one out-of-line copy saves flash. They are `Copy` (shared
    // references only) and passed by value wherever they go: called through
    // a reference, a closure runs inside the standard library's forwarding
    // function, which is compiled at the baseline, and every AVX2 intrinsic
    // inlined into it becomes a call.
    let nodes_ro: &[Node] = nodes;
    let elems_ro: &[crate::element::ElementBlock] = elems;
    let project = {
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        move |i: usize, z: Vec3| -> Vec3 {
            filter(
                #[cfg(feature = "ground")]
                obstacles,
                nodes_ro,
                i,
                z,
            )
        }
    };
    #[cfg(feature = "two-level")]
    let whole = (kind != Preconditioner::Mass).then_some(
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        |work: &mut [NodeWork]| match rigid {
            None => crate::precond::apply(nodes, work, &mut pre, |_, r| r, project),
            Some(body) => {
                // Rigid modes exact (`Rigid::finish`): P⁻¹ of the residual
                // less the rigid motion of its net force and torque. (Nothing
                // holds an isolated body, so `S r` is `r` here.)
                let force = body.fit(nodes_ro, work, |_, w| w.r);
                let input = |i: usize, r: Vec3| match nodes_ro.get(i) {
                    Some(n) => axpy(r, -n.mass, body.at(n, force)),
                    None => r,
                };
                crate::precond::apply(nodes_ro, work, &mut pre, input, project);
                body.finish(nodes_ro, work, mass_coef, force)
            }
        },
    );
    #[cfg(not(feature = "two-level"))]
    let whole = None::<fn(&mut [NodeWork]) -> f32>;
    // A d = (1 + h α_M) M d + h (α_K + h) K d (+ h² k/n d on grabbed nodes),
    // into q = 0; returns dᵀ A d.
    let apply = {
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        move |work: &mut [NodeWork]| {
            pass::stiffness(b, per_young, elems_ro, n_elems, work);
            let mut dq = 0.0f32;
            for (n, w) in nodes_ro.iter().zip(work.iter_mut()) {
                #[allow(unused_mut)] // only the tool adds to it
                let mut p = mass_coef * n.mass;
                #[cfg(feature = "tool")]
                if n.flags & GRABBED != 0 && tool.active() {
                    p += h * h * tool.k_node;
                }
                w.q = axpy(scale(w.d, p), -k_coef, w.q);
                dq += dot(w.d, w.q);
            }
            dq
        }
    };
    let outcome = cg::solve(
        work,
        s.cg_iterations,
        s.iteration_cap(),
        s.cg_tolerance,
        // The lumped-mass norm: the same measure for every preconditioner.
        true,
        project,
        whole,
        apply,
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        |work: &[NodeWork]| {
            certified(
                nodes,
                work,
                project,
                h * s.rayleigh_mass,
                correction.as_ref(),
            )
        },
    );
    if outcome.overflow {
        return Err(StepError::Diverged);
    }
    if !outcome.certified {
        galerkin(nodes, work, isolated, rotations, project, apply, start);
    }
    // `QrInvertible`'s inverted elements take the closest rotation, whose
    // stiffness product (with the rotated rest gradients) has a net torque:
    // the solve's angular momentum is then made the exact step's.
    if cfg!(feature = "qr-invertible")
        && isolated
        && totals.inverted > 0
        && s.method == crate::Method::QrInvertible
    {
        if let Some(body) = Rigid::new(nodes, true) {
            // The external torque about the centre of mass: the loads'
            // (gravity has none there), summed only on this rare path.
            #[allow(unused_mut)] // only the loads add to it
            let mut torque = [0.0f32; 3];
            #[cfg(feature = "loads")]
            {
                let mut forces = Entries::new(loads);
                for n in nodes.iter() {
                    let f = forces.at(n.flags, LOADED);
                    torque = add(torque, cross(sub(n.position(), body.c), f));
                }
            }
            keep_angular_momentum(&body, nodes, work, mass_coef, scale(torque, h));
        }
    }

    // A push out of the ground or a probe moves the held nodes inside
    // their plane onto it within the solve, and their neighbours with them;
    // the velocity it gives them only corrects positions, and `relax` takes
    // it out again.
    #[cfg(feature = "ground")]
    let relaxed = pushes > 0;
    #[cfg(not(feature = "ground"))]
    let relaxed = false;
    // The support's impulse over the step (the fixed nodes', the ground's)
    // and the fixed nodes' residuals, `−` their impulse (`relax` sums them
    // before its own solve takes the residuals).
    #[allow(unused_mut)] // only the ground adds to it
    let mut support = [0.0f32; 3];
    let mut fixed_r = [0.0f32; 3];
    #[cfg(feature = "ground")]
    if relaxed {
        #[cfg(feature = "two-level")]
        let whole = (kind != Preconditioner::Mass).then_some(
            #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
            |work: &mut [NodeWork]| {
                crate::precond::apply(nodes_ro, work, &mut pre, |_, r| r, project)
            },
        );
        #[cfg(not(feature = "two-level"))]
        let whole = None::<fn(&mut [NodeWork]) -> f32>;
        fixed_r = relax(
            obstacles,
            lift.as_ref(),
            h,
            nodes_ro,
            work,
            s,
            project,
            whole,
            apply,
        );
    }
    // Check, then apply. The new displacement and velocity (after the ground
    // stops landing nodes) go into the spent CG scratch `d` and `q`, and the
    // state is written only if they and the tool force are all finite.
    #[allow(unused_mut)] // only the tool adds to it
    let mut tool_force = [0.0f32; 3];
    // `probe` stays zero exactly while every value checked is finite
    // (`math::finite_probe`).
    let mut probe = 0.0f32;
    #[cfg(feature = "tool")]
    let mut offsets = Entries::new(grabs);
    #[cfg(feature = "ground")]
    let mut below = false;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let v = add(n.v, w.x);
        // After `relax`, positions move with the velocity change before it
        // (`dv`), the push out included.
        #[cfg(feature = "ground")]
        let u = axpy(n.u, h, if relaxed { add(n.v, w.dv) } else { v });
        #[cfg(not(feature = "ground"))]
        let u = axpy(n.u, h, v);
        // Held nodes end on the plane (below it by round-off at most, which
        // the next step holds again): only the others can land.
        #[cfg(feature = "ground")]
        if let Some(g) = ground {
            below |= !on_ground(n) && Contact::still(g).distance(add(n.x0, u)) < 0.0;
        }
        w.d = u;
        w.q = v;
    }
    // An isolated body turns over the step as a rigid rotation, not along
    // its tangents (`turn`). (`Linear`'s elements are not invariant under
    // rotations: its tangent update is the one that leaves them unstrained.)
    #[cfg(feature = "free-rotation")]
    if isolated && s.method != crate::Method::Linear {
        // The body at the step's start, with its inertia: the
        // preconditioner's when it has one (the nodes have not moved since).
        #[cfg(feature = "two-level")]
        let known = rigid.filter(|b| b.inertia.is_some());
        #[cfg(not(feature = "two-level"))]
        let known = None;
        let body = known.or_else(|| Rigid::new(nodes, true));
        let share = |body: &Rigid| reach(body, elems_ro, n_elems, per_young, h);
        #[allow(unused_variables)] // only the ground reads it
        let turned = turn(body, nodes, work, h, share);
        #[cfg(feature = "ground")]
        if let (true, Some(g)) = (turned, ground) {
            below = nodes
                .iter()
                .zip(work.iter())
                .any(|(n, w)| Contact::still(g).distance(add(n.x0, w.d)) < 0.0);
        }
    }
    // Nodes that end below the ground: the body's rigid motion first takes
    // them out (`impact`), then each node still below loses its inward
    // normal velocity (`Plane::stop`) and is pushed out by the next step.
    #[cfg(feature = "ground")]
    if let (Some(g), true, false) = (ground, below, any_fixed) {
        let share = |body: &Rigid| reach(body, elems_ro, n_elems, per_young, h);
        let body = match resting {
            Some(body) => Some(body),
            None => Rigid::new(nodes, true),
        };
        if let Some(body) = body {
            let resting = held_ground > 0;
            support = impact(g, h, s.gravity, resting, &body, nodes, work, share);
        }
    }
    // Nodes that end inside a probe lose their normal velocity into it,
    // relative to its own, the same way.
    #[cfg(feature = "probe")]
    let mut landed = false;
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let (u, v) = (w.d, w.q);
        #[cfg(feature = "ground")]
        let v = match ground {
            Some(g) => {
                let stopped = Contact::still(g).stop(add(n.x0, u), v, h);
                support = axpy(support, n.mass, sub(stopped, v));
                stopped
            }
            None => v,
        };
        #[cfg(feature = "probe")]
        let v = if has_probes && n.flags & BOUNDARY != 0 {
            let x = add(n.x0, u);
            let mut v = v;
            for p in probes.iter_mut() {
                if let Some(c) = p.inside(x) {
                    let stopped = c.stop(x, v, h);
                    p.next_force = axpy(p.next_force, -n.mass, sub(stopped, v));
                    landed = true;
                    v = stopped;
                }
            }
            v
        } else {
            v
        };
        // Friction moves held nodes' velocities and positions; a probe
        // moves its pushing nodes' positions onto its surface.
        #[cfg(feature = "friction")]
        let mut v = v;
        #[cfg(any(feature = "friction", feature = "probe"))]
        let mut u = u;
        // The constraint impulses are `−r` from the step's solve. After
        // `relax` (which kept the step's `Σ r` over the fixed nodes and
        // `n·r` of held nodes in `pull`), `r` is the push's residual `r_w`:
        // the velocity change kept, `dv − w`, has the residual of the step's
        // less the push's (`A (dv − w) = b − r_dv + r_w`), so its impulses
        // are the step's less the push's, which only moved positions.
        if n.flags & FIXED != 0 {
            fixed_r = if relaxed {
                sub(fixed_r, w.r)
            } else {
                add(fixed_r, w.r)
            };
        }
        #[cfg(feature = "ground")]
        if obstacles_any {
            let holding = Obstacles::new(
                ground,
                #[cfg(feature = "friction")]
                ground_friction,
                #[cfg(feature = "probe")]
                probes,
            )
            .holding(n);
            if let Some(c) = holding {
                // `pull` (the step's solve's, with the push) decides the
                // release; the impulse is that of the velocity kept.
                let along = dot(c.normal, w.r);
                let kept = if relaxed { w.pull - along } else { along };
                if !relaxed {
                    w.pull = along;
                }
                #[allow(unused_mut)] // only friction adds to it
                let mut impulse = scale(c.normal, -kept);
                // Friction. A sticking node's tangential impulse is its
                // residual's; beyond the static cone, the node slides from
                // the next step. A sliding node's is the kinetic force's
                // (in the solve's right-hand side); one that it stopped
                // (its velocity along the plane no longer against the
                // force) loses what is left of that velocity and sticks.
                #[cfg(feature = "friction")]
                {
                    let mut dv = [0.0; 3];
                    let next = if n.flags & STUCK != 0 {
                        let r = if relaxed { sub(w.reaction, w.r) } else { w.r };
                        impulse = scale(r, -1.0);
                        c.drag_after_stick(impulse, h)
                    } else if w.drag != [0.0; 3] {
                        impulse = axpy(impulse, h, w.drag);
                        let rel = c.sliding(v, h);
                        if dot(rel, w.drag) < 0.0 {
                            c.drag(scale(rel, -1.0), -kept, h)
                        } else {
                            dv = scale(rel, -1.0);
                            [0.0; 3]
                        }
                    } else {
                        [0.0; 3]
                    };
                    w.reaction = next;
                    impulse = axpy(impulse, n.mass, dv);
                    v = add(v, dv);
                    u = axpy(u, h, dv);
                }
                if n.contact == ON_GROUND {
                    support = add(support, impulse);
                }
                #[cfg(feature = "probe")]
                if let Some(p) = usize::from(n.contact)
                    .checked_sub(1)
                    .and_then(|k| probes.get_mut(k))
                {
                    p.next_force = sub(p.next_force, impulse);
                    p.next_contacts += 1;
                    // A node its contact still pushes (it stays held) ends
                    // on the curved surface, not outside it on the tangent
                    // plane: else the next step would find it off the probe
                    // and let it go for a step, in which the body's push
                    // drives it deep inside (a contact that flickers).
                    if w.pull <= 0.0 {
                        if let Some(off) = p.outside(add(n.x0, u)) {
                            u = sub(u, off);
                        }
                    }
                }
            }
        }
        #[cfg(feature = "tool")]
        if n.flags & GRABBED != 0 && tool.active() {
            // The body pulls the tool with minus the spring force.
            tool_force = add(
                tool_force,
                scale(sub(add(n.x0, u), tool.anchor(offsets.next())), tool.k_node),
            );
        }
        // The position x₀ + u is what a user reads: it must be finite too
        // (a node near f32::MAX plus a finite displacement can overflow,
        // found by fuzzing). A finite sum implies a finite u. (Written out
        // again rather than bound before the tool branch: the compiler shares
        // the sum either way, and the binding measured 6 instructions per
        // tet-step more on the Cortex-M4F.)
        probe = finite_probe(finite_probe(probe, add(n.x0, u)), v);
        w.d = u;
        w.q = v;
    }
    let support = sub(support, fixed_r);
    probe = finite_probe(finite_probe(probe, tool_force), support);
    #[cfg(feature = "probe")]
    for p in probes.iter() {
        probe = finite_probe(probe, p.next_force);
    }
    if probe != 0.0 {
        return Err(StepError::Diverged);
    }
    for (n, w) in nodes.iter_mut().zip(work.iter_mut()) {
        n.u = w.d;
        n.v = w.q;
        #[cfg(feature = "ground")]
        {
            // Release a held node whose contact would pull (`pull > 0`).
            n.flags &= !RELEASED;
            if n.flags & CONTACT != 0 && w.pull > 0.0 {
                n.flags |= RELEASED;
            }
            // A node that slides on keeps the kinetic force planned.
            #[cfg(feature = "friction")]
            {
                n.flags &= !STUCK;
                w.drag = [0.0; 3];
                if n.flags & (CONTACT | RELEASED) == CONTACT && w.reaction != [0.0; 3] {
                    n.flags |= STUCK;
                    w.drag = w.reaction;
                }
            }
        }
    }
    #[cfg(feature = "probe")]
    for p in probes.iter_mut() {
        p.commit(h);
    }
    #[cfg(feature = "two-level")]
    crate::precond::commit_rotations(pre.aggs);
    hdr.time += f64::from(h);
    hdr.guess_stale = outcome.iterations > s.cg_iterations || !outcome.certified;
    let removed = correction.map_or(0.0, |c| c.removed);
    // The ground does work on a body it holds or stops (the held normals'
    // prescribed velocities, the impact, the stop): a step with
    // contacts leaves no reference.
    #[cfg(feature = "ground")]
    if held > 0 || below {
        closed = false;
    }
    #[cfg(feature = "probe")]
    if landed {
        closed = false;
    }
    // Only with the guard: without it (a constant where the feature is
    // off) the energy's sums are not computed at all.
    #[cfg(feature = "energy-guard")]
    {
        hdr.energy_known = guard && closed;
        if guard {
            hdr.energy_ref = energy - removed;
            #[cfg(feature = "tool")]
            {
                hdr.energy_target = tool.target;
            }
        }
    }
    #[cfg(not(feature = "energy-guard"))]
    let _ = (closed, energy);
    Ok(StepStats {
        cg_iterations: outcome.iterations,
        galerkin: !outcome.certified,
        cg_residual: outcome.residual,
        inverted: totals.inverted,
        contacts: held,
        tool_force,
        support_force: scale(support, 1.0 / h),
        elastic_energy: if cfg!(feature = "diagnostics") {
            totals.energy
        } else {
            f32::NAN
        },
        energy_removed: removed,
    })
}

/// The guard's tolerance, relative to the sum of the magnitudes of the
/// energy's terms (kinetic, elastic, `|(m g + f)·u|` per node): the energy
/// is three f32 sums over nodes or elements, recomputed each step, and a
/// gain below this is their rounding rather than energy the step made.
/// A gain taken for one by mistake costs little (the guard removes only
/// the measured excess); the bound keeps a step that makes no energy from
/// being touched at all, which keeps such runs' bits those of the
/// unguarded step: the web demo's and the determinism tests' hashed scenes
/// (with gravity and the ground) never trigger it.
const GUARD_ROUNDING: f32 = 16.0 * f32::EPSILON;

/// The energy guard's sums over the free nodes at the step's start.
#[derive(Clone, Copy, Default)]
struct Ledger {
    /// `Σ m |v|²`.
    kinetic2: f32,
    /// `−Σ (m g + f)·u`: gravity's and the loads' potential energy.
    potential: f32,
    /// `Σ |(m g + f)·u|`.
    magnitude: f32,
    /// The tool spring's energy `½ (k/n) Σ |a + o − x|²` over the grabbed
    /// nodes, with the tool's target `a` (`spring`) and with the target of
    /// the guard's reference (`spring_ref`). Zero without the tool.
    spring: f32,
    spring_ref: f32,
}

impl Ledger {
    #[inline(always)]
    fn add(&mut self, n: &Node, weight: Vec3, load: Vec3) {
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
    fn spring(&mut self, k: f32, stretch: Vec3, stretch_ref: Vec3) {
        self.spring += 0.5 * k * dot(stretch, stretch);
        self.spring_ref += 0.5 * k * dot(stretch_ref, stretch_ref);
    }
}

/// Makes the angular momentum of an isolated body's new velocity
/// `v' = v + Δv` (`Δv` in `x`) the exact step's: with internal forces and
/// products free of net torque, `(1 + h α_M) L' = L + h τ` about the centre
/// of mass (the guard's `δ` has no angular momentum). The difference is a
/// rotation about the centre of mass, `ω = I⁻¹ (Σ r × m (v' − v/(1 + h α_M))
/// − h τ/(1 + h α_M))`, taken out of `Δv`; the linear momentum is kept.
fn keep_angular_momentum(
    body: &Rigid,
    nodes: &[Node],
    work: &mut [NodeWork],
    mass_coef: f32,
    torque_h: Vec3,
) {
    let Some(inertia) = body.inertia else {
        return;
    };
    let decay = 1.0 - 1.0 / mass_coef;
    let (_, omega) = body.fit(nodes, work, |n, w| {
        scale(add(w.x, scale(n.v, decay)), n.mass)
    });
    let external = solve3(&inertia, scale(torque_h, 1.0 / mass_coef)).unwrap_or([0.0; 3]);
    let omega = sub(omega, external);
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        if n.flags & FIXED == 0 {
            w.x = sub(w.x, cross(omega, sub(n.position(), body.c)));
        }
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
struct Correction {
    body: Option<(Rigid, Motion)>,
    factor: f32,
    removed: f32,
}

impl Correction {
    fn new(nodes: &[Node], work: &[NodeWork], any_fixed: bool, excess: f32) -> Option<Self> {
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
    fn delta(&self, n: &Node) -> Vec3 {
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

/// The filter `S` of node `i`: the normal of its contact plane removed
/// from a held node. The obstacles are tested first: without them, the
/// loop reads no node flags.
#[inline(always)]
fn filter(
    #[cfg(feature = "ground")] obstacles: Obstacles<'_>,
    nodes: &[Node],
    i: usize,
    z: Vec3,
) -> Vec3 {
    #[cfg(feature = "ground")]
    if obstacles.any() {
        if let Some(n) = nodes.get(i) {
            // A sticking node's velocity is prescribed whole.
            #[cfg(feature = "friction")]
            if n.flags & STUCK != 0 {
                return [0.0; 3];
            }
            if let Some(c) = obstacles.holding(n) {
                return c.filter(z);
            }
        }
    }
    let _ = (i, nodes);
    z
}

/// What can hold a node during a step: the ground and the probes.
#[cfg(feature = "ground")]
#[derive(Clone, Copy)]
struct Obstacles<'a> {
    ground: Option<crate::ground::Plane>,
    #[cfg(feature = "friction")]
    ground_friction: crate::Friction,
    #[cfg(feature = "probe")]
    probes: &'a [crate::Probe],
    #[cfg(not(feature = "probe"))]
    probes: core::marker::PhantomData<&'a ()>,
}

#[cfg(feature = "ground")]
impl<'a> Obstacles<'a> {
    #[inline(always)]
    fn new(
        ground: Option<crate::ground::Plane>,
        #[cfg(feature = "friction")] ground_friction: crate::Friction,
        #[cfg(feature = "probe")] probes: &'a [crate::Probe],
    ) -> Self {
        Self {
            ground,
            #[cfg(feature = "friction")]
            ground_friction,
            #[cfg(feature = "probe")]
            probes,
            #[cfg(not(feature = "probe"))]
            probes: core::marker::PhantomData,
        }
    }

    #[inline(always)]
    fn any(&self) -> bool {
        #[cfg(feature = "probe")]
        if !self.probes.is_empty() {
            return true;
        }
        self.ground.is_some()
    }

    /// The ground's plane, with its friction.
    #[inline(always)]
    fn ground_contact(&self, g: crate::ground::Plane) -> Contact {
        #[cfg(feature = "friction")]
        return Contact {
            friction: self.ground_friction,
            ..Contact::still(g)
        };
        #[cfg(not(feature = "friction"))]
        Contact::still(g)
    }

    /// The contact plane of a node the step holds (`CONTACT`): the ground's,
    /// or its probe's, recomputed from the same positions and poses as when
    /// the node was found (so with the same bits).
    #[inline(always)]
    fn holding(&self, n: &Node) -> Option<Contact> {
        if n.flags & CONTACT == 0 {
            return None;
        }
        if n.contact == ON_GROUND {
            return self.ground.map(|g| self.ground_contact(g));
        }
        #[cfg(feature = "probe")]
        if let Some(p) = self.probes.get(usize::from(n.contact) - 1) {
            return Some(p.contact(n.position()));
        }
        None
    }

    /// The obstacle that holds a free node at `x` this step, and its plane:
    /// the ground if the node touches or is below it and is not moving
    /// away; a probe (for a node on the boundary) if the probe reaches it
    /// during the step and it is not moving away faster than the probe.
    /// Of several, the one the node ends deepest in. A node held last step
    /// (`was`) is held by a probe while it is within [`Probe::gap`] of its
    /// surface (where the last step left it, up to rounding and the probe's
    /// own turn), however the node moves: a node pressed by a moving probe
    /// moves with it, as fast as its plane up to rounding, and one pressed
    /// against a still probe stays on it; the contact force decides
    /// release. Whichever obstacle held it: a node touching the probe is
    /// held, and a caller that takes a probe out of the slice renumbers the
    /// ones after it.
    #[inline(always)]
    fn deepest(&self, n: &Node, x: Vec3, h: f32, was: Option<u16>) -> Option<(u16, Contact)> {
        let mut best: Option<(u16, Contact, f32)> = None;
        if let Some(g) = self.ground {
            let c = self.ground_contact(g);
            let dist = c.distance(x);
            if c.holds(dist, n.v, h) {
                best = Some((ON_GROUND, c, dist));
            }
        }
        #[cfg(feature = "probe")]
        if n.flags & BOUNDARY != 0 {
            // At most `MAX_PROBES`, checked by `step_with_probes`: the id
            // fits.
            for (k, p) in self.probes.iter().enumerate() {
                let c = p.contact(x);
                let dist = c.distance(x);
                let id = k as u16 + 1;
                let holds = c.holds(dist, n.v, h) || (was.is_some() && dist <= p.gap(x, n.v, h));
                if holds && best.is_none_or(|b| dist < b.2) {
                    best = Some((id, c, dist));
                }
            }
        }
        let _ = was; // only probes hold on by it
        best.map(|(id, c, _)| (id, c))
    }
}

/// Whether the ground holds `n` this step.
#[cfg(feature = "ground")]
#[inline(always)]
fn on_ground(n: &Node) -> bool {
    n.flags & CONTACT != 0 && n.contact == ON_GROUND
}

/// The rigid motions of an isolated body about its centre of mass `c` at
/// the step's start: translations, and with `rotations`, `ω × (p − c)`.
#[derive(Clone, Copy)]
struct Rigid {
    c: Vec3,
    inv_mass: f32,
    /// `I = Σ m (|p − c|² I − (p − c)(p − c)ᵀ)`, with rotations.
    inertia: Option<crate::math::Mat3>,
    /// `Σ m (p − c)`, zero but for round-off.
    first_moment: Vec3,
}

/// Adds a point mass `m` at `r` to the inertia `Σ m (|r|² I − r rᵀ)`.
#[inline(always)]
fn add_inertia(inertia: &mut crate::math::Mat3, m: f32, r: Vec3) {
    let r2 = dot(r, r);
    for (a, row) in inertia.iter_mut().enumerate() {
        for (b, iab) in row.iter_mut().enumerate() {
            let delta = if a == b { r2 } else { 0.0 };
            *iab += m * (delta - r[a] * r[b]);
        }
    }
}

/// A rigid motion `(v, ω)`.
type Motion = (Vec3, Vec3);

impl Rigid {
    /// `None` for a body without mass.
    fn new(nodes: &[Node], rotations: bool) -> Option<Self> {
        let (mut mass, mut mc) = (0.0f32, [0.0f32; 3]);
        for n in nodes {
            mass += n.mass;
            mc = axpy(mc, n.mass, n.position());
        }
        if !(mass > 0.0) {
            return None;
        }
        let c = scale(mc, 1.0 / mass);
        let mut inertia = [[0.0f32; 3]; 3];
        let mut first_moment = [0.0f32; 3];
        for n in nodes {
            let r = sub(n.position(), c);
            first_moment = axpy(first_moment, n.mass, r);
            add_inertia(&mut inertia, n.mass, r);
        }
        Some(Self {
            c,
            inv_mass: 1.0 / mass,
            inertia: rotations.then_some(inertia),
            first_moment,
        })
    }

    /// The rigid motion whose momentum is that of the field `f(node, work)`
    /// (a momentum per node, or a force): `v = Σ f / Σ m` and
    /// `ω = I⁻¹ Σ (p − c) × (f − m v)`, in one pass over the nodes.
    #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
    fn fit(
        &self,
        nodes: &[Node],
        work: &[NodeWork],
        f: impl Fn(&Node, &NodeWork) -> Vec3,
    ) -> Motion {
        let (mut lin, mut ang) = ([0.0f32; 3], [0.0f32; 3]);
        for (n, w) in nodes.iter().zip(work.iter()) {
            let fi = f(n, w);
            lin = add(lin, fi);
            if self.inertia.is_some() {
                ang = add(ang, cross(sub(n.position(), self.c), fi));
            }
        }
        let vel = scale(lin, self.inv_mass);
        let omega = self
            .inertia
            .and_then(|i| solve3(&i, sub(ang, cross(self.first_moment, vel))))
            .unwrap_or([0.0; 3]);
        (vel, omega)
    }

    /// The velocity of the centre of mass of the field `f(node, work)` (a
    /// momentum per node), and, with rotations, its angular momentum about
    /// `c` less the round-off of `Σ m (p − c)`: `I ω` of [`Rigid::fit`],
    /// whose loop this repeats (`fit` calling it measured 2 instructions
    /// per tet-step more on the Cortex-M4F, in images without this feature).
    #[cfg(feature = "free-rotation")]
    #[inline(always)]
    fn momenta(
        &self,
        nodes: &[Node],
        work: &[NodeWork],
        f: impl Fn(&Node, &NodeWork) -> Vec3,
    ) -> (Vec3, Vec3) {
        let (mut lin, mut ang) = ([0.0f32; 3], [0.0f32; 3]);
        for (n, w) in nodes.iter().zip(work.iter()) {
            let fi = f(n, w);
            lin = add(lin, fi);
            if self.inertia.is_some() {
                ang = add(ang, cross(sub(n.position(), self.c), fi));
            }
        }
        let vel = scale(lin, self.inv_mass);
        (vel, sub(ang, cross(self.first_moment, vel)))
    }

    /// The motion `m` at node `n`.
    #[inline(always)]
    fn at(&self, n: &Node, m: Motion) -> Vec3 {
        add(m.0, cross(m.1, sub(n.position(), self.c)))
    }

    /// `a` at node `n` less the rigid motion `m`.
    #[inline(always)]
    fn less_rigid(&self, n: &Node, a: Vec3, m: Motion) -> Vec3 {
        sub(a, self.at(n, m))
    }

    /// Completes a preconditioner `P` made exact on the rigid modes `R`:
    /// `z = Π P⁻¹ Πᵀ r + R (RᵀAR)⁻¹ Rᵀ r`, with `Π = I − R (RᵀMR)⁻¹ RᵀM`
    /// and `RᵀAR = (1 + h α_M) RᵀMR` (`K R = 0`). Both the rigid modes and
    /// their `M`-orthogonal complement are then invariant under `P⁻¹A`, so
    /// every CG iterate keeps the exact step's response to the rigid modes,
    /// as the mass preconditioner does. The caller has set every `q` to
    /// `P⁻¹ Πᵀ r`, that is `P⁻¹` of `rᵢ − mᵢ force(pᵢ)`, where `force` is the
    /// [`Rigid::fit`] of `r` (the rigid motion of the residual's net force
    /// and torque); this makes `q = z` and returns `rᵀz`.
    #[cfg(feature = "two-level")]
    #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
    fn finish(&self, nodes: &[Node], work: &mut [NodeWork], mass_coef: f32, force: Motion) -> f32 {
        // Π z̃ = z̃ less its rigid motion, plus the rigid modes' exact part.
        let kept = self.fit(nodes, work, |n, w| scale(w.q, n.mass));
        let mut rz = 0.0f32;
        for (n, w) in nodes.iter().zip(work.iter_mut()) {
            let z = self.less_rigid(n, w.q, kept);
            w.q = axpy(z, 1.0 / mass_coef, self.at(n, force));
            rz += dot(w.r, w.q);
        }
        rz
    }
}

/// The energy certificate of a truncated solve. Linearised at the current
/// state, a step that solves `A Δv = b − r` changes the kinetic plus elastic
/// energy by (with `v' = v + Δv`, the tool's spring counted with `K`)
///
/// ```text
/// h v'ᵀf_ext − v'ᵀr − ½ ΔvᵀMΔv − (h²/2 + h α_K) v'ᵀKv' − h α_M v'ᵀMv'
/// ```
///
/// (expand `v'ᵀ M Δv` with `M Δv = b − r − h α_M M Δv − h (α_K + h) K Δv`
/// and add `E(x + h v') − E(x) ≈ −h f_elᵀv' + ½ h² v'ᵀKv'`). The exact step
/// has `r = 0` and only dissipates; a truncated one is accepted when its
/// residual injects no more than the dissipation the step has anyway:
/// `−v'ᵀ S r ≤ ½ ΔvᵀMΔv + h α_M v'ᵀMv' + ε KE`. The `K` terms are left out
/// (they need another product; leaving out a dissipation only makes the test
/// stricter). `S` filters the held ground normals (the ground's force does
/// no work on a node it holds still); fixed nodes do not move.
/// `ε = f32::EPSILON`: the kinetic energy `KE`, a sum of f32 terms, is not
/// known more finely, so a finer test would reject round-off.
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
fn certified(
    nodes: &[Node],
    work: &[NodeWork],
    project: impl Fn(usize, Vec3) -> Vec3,
    h_alpha_m: f32,
    correction: Option<&Correction>,
) -> bool {
    let (mut inject, mut dissipate, mut kinetic) = (0.0f32, 0.0f32, 0.0f32);
    for (i, (n, w)) in nodes.iter().zip(work.iter()).enumerate() {
        if n.flags & FIXED != 0 {
            continue;
        }
        let v1 = add(n.v, w.x);
        // The step starts from the guard's velocity `v + δ`: `Δv = x − δ`.
        let (v0, dv) = match correction {
            Some(c) => {
                let delta = c.delta(n);
                (add(n.v, delta), sub(w.x, delta))
            }
            None => (n.v, w.x),
        };
        inject -= dot(v1, project(i, w.r));
        dissipate += n.mass * (0.5 * dot(dv, dv) + h_alpha_m * dot(v1, v1));
        kinetic += n.mass * dot(v0, v0);
    }
    inject <= dissipate + f32::EPSILON * 0.5 * kinetic
}

/// The Galerkin step that ends a solve without an energy certificate: the
/// solution is replaced by the best one (least energy norm of the error) in
/// `x₀ + span{P Δv, P v}`, where `P` takes the part that CG may change (the
/// filter `S` of held normals and fixed nodes, or for an isolated body, the
/// part without the rigid motion of the same momentum), and `x₀` keeps the
/// rest (held normals; for an isolated body, the rigid part, which the
/// preconditioners keep exact). The new residual is then orthogonal to both
/// directions (and, for an isolated body, still free of net force and
/// torque: `A` maps the `M`-orthogonal directions to forces without them),
/// so `v'ᵀ S r = 0`: the truncation adds no energy.
///
/// The second direction is made `A`-orthogonal to the first and multiplied
/// by `A` again rather than updated: where a stiff step all but stops the
/// deformation, `A P v` and `A P Δv` are nearly parallel and their
/// difference cancels to noise in f32. Three products with `A` in all.
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
fn galerkin(
    nodes: &[Node],
    work: &mut [NodeWork],
    isolated: bool,
    rotations: bool,
    project: impl Fn(usize, Vec3) -> Vec3,
    mut apply: impl FnMut(&mut [NodeWork]) -> f32,
    start: impl Fn(&Node) -> Vec3,
) {
    let rigid = if isolated {
        Rigid::new(nodes, rotations)
    } else {
        None
    };
    let none = ([0.0; 3], [0.0; 3]);
    let (fit_x, fit_v) = match rigid {
        Some(body) => (
            body.fit(nodes, work, |n, w| scale(w.x, n.mass)),
            body.fit(nodes, work, |n, _| scale(start(n), n.mass)),
        ),
        None => (none, none),
    };
    // `P a` at node `i`, with the rigid motion `fit` of the field `a`.
    let part = |i: usize, n: &Node, a: Vec3, fit: Motion| -> Vec3 {
        if n.flags & FIXED != 0 {
            return [0.0; 3];
        }
        match rigid {
            Some(body) => body.less_rigid(n, a, fit),
            None => project(i, a),
        }
    };
    // Along e = P Δv: Δv += a e, with a = eᵀr / eᵀAe. Since P is a
    // projection, P Δv is then (1 + a) e, with A-norm² (1 + a)² eᵀAe.
    for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
        w.d = part(i, n, w.x, fit_x);
        w.q = [0.0; 3];
    }
    let eae = apply(work);
    let e_norm = descend(work, eae).map_or(0.0, |a| (1.0 + a) * (1.0 + a) * eae);
    // Along f = P v, made A-orthogonal to e = P Δv.
    for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
        w.d = part(i, n, start(n), fit_v);
        w.q = [0.0; 3];
    }
    let mut faf = apply(work);
    if e_norm > 0.0 && e_norm.is_finite() && faf.is_finite() {
        let mut eaf = 0.0f32;
        for (i, (n, w)) in nodes.iter().zip(work.iter()).enumerate() {
            eaf += dot(part(i, n, w.x, fit_x), w.q);
        }
        let c = eaf / e_norm;
        if c != 0.0 && c.is_finite() {
            for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
                w.d = axpy(w.d, -c, part(i, n, w.x, fit_x));
                w.q = [0.0; 3];
            }
            faf = apply(work);
        }
    }
    descend(work, faf);
}

/// The exact line search along `d` (with `q = A d`, `dad = dᵀAd`):
/// `x += a d`, `r −= a q` with `a = dᵀr / dᵀAd`, after which `dᵀr = 0`.
/// Returns `a`, or `None` (nothing changed) for a direction without
/// positive, finite curvature.
fn descend(work: &mut [NodeWork], dad: f32) -> Option<f32> {
    if !(dad > 0.0 && dad.is_finite()) {
        return None;
    }
    let a = work.iter().fold(0.0f32, |s, w| s + dot(w.d, w.r)) / dad;
    for w in work.iter_mut() {
        w.x = axpy(w.x, a, w.d);
        w.r = axpy(w.r, -a, w.q);
    }
    Some(a)
}

/// Makes the preconditioner's data current for this step and returns the
/// preconditioner to use: the node blocks of `A`, the aggregates' rotations,
/// and, after anything that changed `A`'s rest value, the aggregates and
/// the coarse factor. `Mass` when the storage has no room for the one the
/// settings ask for (`Scene::set_settings` refuses that, so only a scene
/// whose defaults were never written reaches it).
#[cfg(feature = "two-level")]
#[allow(clippy::too_many_arguments)]
fn prepare(
    hdr: &mut crate::scene::Header,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &[crate::element::ElementBlock],
    n_elems: usize,
    pre: &mut crate::precond::Parts<'_>,
    mass_coef: f32,
    k_coef: f32,
) -> Preconditioner {
    use crate::precond;
    let mut kind = hdr.settings.preconditioner;
    if kind == Preconditioner::Mass || pre.blocks.len() != nodes.len() {
        return Preconditioner::Mass;
    }
    #[cfg(feature = "tool")]
    let tool = hdr.tool;
    let h = hdr.settings.dt;
    let two_level = kind == Preconditioner::TwoLevel;
    // The aggregation first: it moves the node slots around.
    if two_level && !hdr.coarse_ready {
        hdr.n_aggs = precond::aggregate(per_young, elems, n_elems, nodes, pre.blocks, pre.aggs);
    }
    // The aggregates in use (none for block-Jacobi): what `precond::apply`
    // works with.
    let n = pre.keep(if two_level { hdr.n_aggs } else { 0 });
    if n > 0 {
        precond::rotations(nodes, pre.blocks, pre.aggs);
    } else {
        kind = Preconditioner::BlockJacobi;
    }
    // Block-Jacobi's node blocks follow the state every step (with the
    // tool's spring); the two-level ones are prepared with the factor, in
    // their aggregate's frame, and turn with it.
    if n == 0 || !hdr.coarse_ready {
        precond::node_blocks(
            per_young,
            elems,
            n_elems,
            nodes,
            pre.blocks,
            mass_coef,
            k_coef,
            |_n| {
                #[cfg(feature = "tool")]
                if n == 0 && _n.flags & GRABBED != 0 && tool.active() {
                    return h * h * tool.k_node;
                }
                let _ = h;
                0.0
            },
        );
    }
    if n > 0 && !hdr.coarse_ready {
        precond::factor(per_young, elems, n_elems, nodes, pre, mass_coef, k_coef);
    }
    hdr.coarse_ready = true;
    kind
}

/// The rigid motions a frictionless plane can give a body: a velocity
/// `a n` along its normal and a rotation `θ × (p − c)` about an axis in the
/// plane (it exerts no tangential force and no torque about its normal).
/// [`PlaneFit::add`] collects, per node, the normal value `target` the
/// motion should take at `p`; [`PlaneFit::solve`] gives the motion whose
/// normal values fit the targets best in the mass-weighted least-squares
/// sense. Where the targets do not fix all three parameters (one or two
/// nodes), a small multiple of the motion's kinetic energy, added to the
/// misfit, picks the motion of least kinetic energy: for a single node,
/// the rigid body's response to an impulse there.
#[cfg(feature = "ground")]
#[derive(Clone, Copy)]
struct PlaneFit {
    n: Vec3,
    /// Two unit vectors spanning the plane, with `n` a right-handed frame.
    t: [Vec3; 2],
    c: Vec3,
    /// `Σ m φ φᵀ` and `Σ m φ target`, `φ = (1, t₀·s, t₁·s)`, `s = (p − c) × n`.
    ata: crate::math::Mat3,
    atb: Vec3,
    /// `Σ m` of the nodes added.
    mass: f32,
}

#[cfg(feature = "ground")]
impl PlaneFit {
    fn new(n: Vec3, c: Vec3) -> Self {
        // The coordinate axis least aligned with `n` gives the first tangent.
        let e = if n[0].abs() <= n[1].abs() && n[0].abs() <= n[2].abs() {
            [1.0, 0.0, 0.0]
        } else if n[1].abs() <= n[2].abs() {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        let t0 = crate::math::normalize(cross(n, e)).unwrap_or([0.0; 3]);
        Self {
            n,
            t: [t0, cross(n, t0)],
            c,
            ata: [[0.0; 3]; 3],
            atb: [0.0; 3],
            mass: 0.0,
        }
    }

    fn row(&self, p: Vec3) -> Vec3 {
        let s = cross(sub(p, self.c), self.n);
        [1.0, dot(self.t[0], s), dot(self.t[1], s)]
    }

    fn add(&mut self, p: Vec3, m: f32, target: f32) {
        let phi = self.row(p);
        for (row, pi) in self.ata.iter_mut().zip(phi) {
            for (a, pj) in row.iter_mut().zip(phi) {
                *a += m * pi * pj;
            }
        }
        self.atb = axpy(self.atb, m * target, phi);
        self.mass += m;
    }

    /// The fitted motion `(a, θ)`, `None` without nodes or for a singular
    /// system. `body` gives the kinetic-energy weight: `½ (M a² + θᵀ I θ)`,
    /// added with the factor `1e-3 · Σm / M`, small enough to leave a
    /// determined fit within 0.1 % and large enough for f32 to resolve it.
    fn solve(&self, body: &Rigid) -> Option<(f32, Vec3)> {
        if !(self.mass > 0.0) {
            return None;
        }
        let w = 1e-3 * self.mass * body.inv_mass;
        let mut m = self.ata;
        if let (Some(row), Some(inertia)) = (m.get_mut(0), body.inertia.as_ref()) {
            if let Some(a) = row.get_mut(0) {
                *a += w / body.inv_mass;
            }
            let it = [
                crate::math::mat_vec(inertia, self.t[0]),
                crate::math::mat_vec(inertia, self.t[1]),
            ];
            for (i, ti) in self.t.iter().enumerate() {
                for (j, itj) in it.iter().enumerate() {
                    if let Some(a) = m.get_mut(i + 1).and_then(|r| r.get_mut(j + 1)) {
                        *a += w * dot(*ti, *itj);
                    }
                }
            }
        }
        let x = solve3(&m, self.atb)?;
        let theta = axpy(scale(self.t[0], x[1]), x[2], self.t[1]);
        (x[0].is_finite() && is_finite3(theta)).then_some((x[0], theta))
    }

    /// The motion `(a, θ)` at `p`.
    #[inline(always)]
    fn at(&self, p: Vec3, (a, theta): (f32, Vec3)) -> Vec3 {
        axpy(cross(theta, sub(p, self.c)), a, self.n)
    }
}

/// Takes a push out of the ground back out of the velocity (a split
/// impulse). A held node below the plane at `dist < 0` is prescribed the
/// normal velocity `−dist/h`, which ends the step on the plane; the solve
/// moves its neighbours along, so the elements it shares do not take the
/// depth as strain. With a [`Lift`], the held nodes are prescribed the
/// lift's normal velocity where it exceeds their own push, and that part of
/// their velocity is a push too. That velocity only corrects a position:
/// kept, it would lift the node off the plane again, a bounce as high as
/// the depth, and a body resting on the ground would never come to rest. By
/// linearity the step's velocity change (`dv`) is the one without the push
/// plus the push's own response `w`, the solve of `A w = 0` (filtered) with
/// the pushed normals prescribed, which this solves with the step's budget
/// and preconditioner. The velocity keeps `dv − w`, and the positions `dv`.
/// Keeps `dv` and the step's contact impulses `n·r` (in `NodeWork`), and
/// leaves the new velocity change in `x`. It costs a second solve, in the
/// steps that push nodes out: those in which nodes landed the step before.
#[cfg(feature = "ground")]
#[allow(clippy::too_many_arguments)] // the step's parts, as `cg::solve` takes them
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
fn relax(
    obstacles: Obstacles<'_>,
    lift: Option<&Lift>,
    h: f32,
    nodes: &[Node],
    work: &mut [NodeWork],
    s: crate::Settings,
    project: impl Fn(usize, Vec3) -> Vec3 + Copy,
    whole: Option<impl FnMut(&mut [NodeWork]) -> f32>,
    mut apply: impl FnMut(&mut [NodeWork]) -> f32 + Copy,
) -> Vec3 {
    let mut fixed_r = [0.0f32; 3];
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        w.dv = w.x;
        if n.flags & FIXED != 0 {
            fixed_r = add(fixed_r, w.r);
        }
        let c = obstacles.holding(n);
        w.pull = c.map_or(0.0, |c| dot(c.normal, w.r));
        #[cfg(feature = "friction")]
        {
            w.reaction = w.r;
        }
        // The push: to the plane (`−dist/h`), or the lift's beyond the
        // node's own (for a node the plane holds without a push, the part
        // of its prescribed velocity beyond its own `−dist/h`).
        w.x = match c {
            Some(c) => {
                let x = n.position();
                let (own, pushed) = match c.push(x) {
                    Some(dist) => (dist, 0.0),
                    None => {
                        let dist = c.distance(x);
                        (dist, dist)
                    }
                };
                let dist = lift.map_or(own, |l| l.depth(n, own, h));
                let up = (pushed - dist) / h;
                if up != 0.0 {
                    scale(c.normal, up)
                } else {
                    [0.0; 3]
                }
            }
            None => [0.0; 3],
        };
        w.d = w.x;
        w.q = [0.0; 3];
    }
    // r = 0 − A w₀, unfiltered like the step's.
    let _ = apply(work);
    for w in work.iter_mut() {
        w.r = scale(w.q, -1.0);
    }
    let outcome = cg::solve(
        work,
        s.cg_iterations,
        s.cg_iterations,
        s.cg_tolerance,
        true,
        project,
        whole,
        apply,
        |_: &[NodeWork]| true,
    );
    // A push's solve that overflowed (a system beyond f32, which the step's
    // own solve has passed) leaves the push in the velocity.
    let mut probe = f32::from(u8::from(outcome.overflow));
    for w in work.iter_mut() {
        w.x = sub(w.dv, w.x);
        probe = finite_probe(probe, w.x);
    }
    if probe != 0.0 {
        // The push stays, and with it the step's impulses: no push
        // residual to take out of them.
        for w in work.iter_mut() {
            w.x = w.dv;
            w.r = [0.0; 3];
        }
    }
    fixed_r
}

/// The push out of the ground of a body that the ground alone holds, and
/// that moves as one over the step (its [`reach`] is 1), as one rigid
/// motion: the plane's ([`PlaneFit`]) of least kinetic energy
/// that moves every held node at least as far out as its own push
/// (`−dist/h` along the normal over the step, `dist` its distance to the
/// plane at the step's start).
///
/// Pushed each to the plane on its own, nodes that landed below it at
/// different depths (a stiff body rocking on a few points of a curved
/// side) are prescribed velocities that no rigid motion has: a truncated
/// solve moves their neighbours only partly along, and a stiff body, or
/// one with tiny elements, takes the difference as strain, whose energy
/// the next steps set free as motion. The lift instead raises the body as a
/// whole; held nodes it raises beyond their own push leave the plane. A
/// body that a pressure wave does not cross within the step answers a
/// push locally, and keeps the pushes node by node: lifted as a whole, a
/// soft body resting on many nodes would be tipped by the few that landed.
///
/// The motion is found by an active set: the node furthest below its
/// bound joins, and the motion of least kinetic energy through the joined
/// nodes' bounds is fitted again, at most three times (three nodes fix a
/// plane's motion). A node still below its bound after that keeps its own
/// push ([`Lift::depth`]).
#[cfg(feature = "ground")]
#[derive(Clone, Copy)]
struct Lift {
    fit: PlaneFit,
    motion: (f32, Vec3),
}

#[cfg(feature = "ground")]
impl Lift {
    fn new(g: crate::ground::Plane, body: &Rigid, nodes: &[Node], h: f32) -> Option<Self> {
        let c = Contact::still(g);
        let mut fit = PlaneFit::new(g.normal, body.c);
        let mut lift: Option<Self> = None;
        for _ in 0..3 {
            // The node furthest below its bound under the motion so far.
            let mut worst: Option<(f32, Vec3, f32, f32)> = None;
            for n in nodes.iter().filter(|n| on_ground(n)) {
                let p = n.position();
                let bound = -c.distance(p) / h;
                let short = bound - lift.as_ref().map_or(0.0, |l| l.up(p));
                if short > worst.map_or(0.0, |w| w.0) {
                    worst = Some((short, p, n.mass, bound));
                }
            }
            let Some((_, p, m, bound)) = worst else {
                break;
            };
            fit.add(p, m, bound);
            let Some(motion) = fit.solve(body) else {
                break;
            };
            lift = Some(Self { fit, motion });
        }
        lift
    }

    /// The lift's velocity along the normal at `p`.
    #[inline(always)]
    fn up(&self, p: Vec3) -> f32 {
        dot(self.fit.n, self.fit.at(p, self.motion))
    }

    /// The depth below the plane that the push of node `n`, at `dist`
    /// from it, takes out: the lift's, where it raises a node the ground
    /// holds further than its own.
    #[inline(always)]
    fn depth(&self, n: &Node, dist: f32, h: f32) -> f32 {
        if on_ground(n) {
            dist.min(-h * self.up(n.position()))
        } else {
            dist
        }
    }
}

/// The weight of a held node in the fit of an impact, per unit mass, against
/// 1 for a node arriving: the ground already holds it, so the motion must
/// leave its normal velocity as it is (up to `1/HELD` of the arrivals'
/// misfit, well within f32 for the 3×3 system).
#[cfg(feature = "ground")]
const HELD: f32 = 1e4;

/// The rigid part of an impact on the ground, for a body that no fixed node
/// holds: where the solved step ends with nodes below the plane moving
/// inwards, the body's rigid motion stops them before each node still
/// below is stopped alone, so that a landing body stops as a whole instead
/// of having its lowest layer squashed onto the plane (the layer a
/// truncated solve leaves falling, and a long step moves deep into the
/// ground).
///
/// * **Which motion.** The plane's ([`PlaneFit`]) that stops the arriving
///   nodes' inward normal velocity, each node's counted as the smaller of
///   its own and that of the body's rigid motion there (the motion of its
///   momentum), so that a node's vibration is not taken for the body's
///   landing. Held nodes that the motion would push into the ground keep
///   their normal velocity; those it lifts may lift off.
/// * **How far.** The body's share `share(body)` that moves as one over the
///   step ([`reach`]): none without stiffness, all of a stiff one. Within
///   it, only as far as the energy falls: with `Δ` the motion, the kinetic
///   energy changes by `s Σ m v·Δ + ½ s² Σ m Δ²`, least at
///   `s = −Σ m v·Δ / Σ m Δ²`. For a body the ground held at the step's
///   start (`resting`), gravity's velocity over the step is its weight
///   pressing, which the elastic solve carries, not an impact: the lift's
///   potential energy `−h s Σ m g·Δ` counts too, which moves `v` to
///   `v − h g` in the sum.
/// * **Where.** It is added to the step's velocity change, so the
///   displacement moves by the motion over the step (`u' = u + h v'`): the
///   translation `h s a n` and the rotation by `h s θ` about the centre of
///   mass at the step's end, made exact (the Cayley rotation of `h s θ/2`,
///   orthogonal; added linearly, `y + h s θ × y` would stretch the body by
///   `|h s θ|²/2`). The shape, and so the elastic energy, do not change.
///
/// `work` holds the step's end: displacement in `d`, velocity in `q`;
/// `body` is the body at the step's start, with its inertia.
#[cfg(feature = "ground")]
#[allow(clippy::too_many_arguments)]
fn impact(
    g: crate::ground::Plane,
    h: f32,
    gravity: Vec3,
    resting: bool,
    body: &Rigid,
    nodes: &[Node],
    work: &mut [NodeWork],
    share: impl FnOnce(&Rigid) -> f32,
) -> Vec3 {
    let moving = body.fit(nodes, work, |n, w| scale(w.q, n.mass));
    // The nodes arriving, and the held nodes the motion would push into the
    // ground (weight `HELD`, target 0). An active set over at most three
    // fits: a held node joins once an earlier fit pushed it in, and stays.
    let frame = PlaneFit::new(g.normal, body.c);
    let mut fits: [Option<(f32, Vec3)>; 3] = [None; 3];
    let mut solved = None;
    let mut joined = 0u32;
    for k in 0..fits.len() {
        let mut stop = frame;
        let mut active = 0u32;
        for (n, w) in nodes.iter().zip(work.iter()) {
            let p = n.position();
            if on_ground(n) {
                let pushed = |f: &Option<(f32, Vec3)>| {
                    f.is_some_and(|f| dot(g.normal, frame.at(p, f)) < 0.0)
                };
                if fits.iter().take(k).any(pushed) {
                    stop.add(p, HELD * n.mass, 0.0);
                    active += 1;
                }
            } else {
                let vn = dot(g.normal, w.q).max(dot(g.normal, body.at(n, moving)));
                if vn < 0.0 && Contact::still(g).distance(add(n.x0, w.d)) < 0.0 {
                    stop.add(p, n.mass, -vn);
                }
            }
        }
        // The set only grows: the same count is the same set, the same fit.
        if k > 0 && active == joined {
            break;
        }
        joined = active;
        let fit = stop.solve(body);
        if let Some(f) = fits.get_mut(k) {
            *f = fit;
        }
        solved = fit.map(|m| (stop, m));
    }
    let Some((stop, m)) = solved else {
        return [0.0; 3];
    };
    let settle = if resting { scale(gravity, h) } else { [0.0; 3] };
    // The line search's sums, and the centre of mass at the step's end.
    let (mut along, mut norm2, mut mc) = (0.0f32, 0.0f32, [0.0f32; 3]);
    for (n, w) in nodes.iter().zip(work.iter()) {
        let dv = stop.at(n.position(), m);
        along += n.mass * dot(sub(w.q, settle), dv);
        norm2 += n.mass * dot(dv, dv);
        mc = axpy(mc, n.mass, add(n.x0, w.d));
    }
    // The share takes a pass over the elements: only for an impact.
    let s = -along / norm2;
    if !(s > 0.0 && s.is_finite()) {
        return [0.0; 3];
    }
    let s = s.min(share(body));
    if !(s > 0.0) {
        return [0.0; 3];
    }
    // R y = y + 2 w (q × y) + 2 q × (q × y), with the unit quaternion (w, q)
    // of the Cayley rotation.
    let c = scale(mc, body.inv_mass);
    let turn = Turn::cayley(scale(m.1, h * s));
    let shift = scale(g.normal, h * s * m.0);
    let mut impulse = [0.0f32; 3];
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let dv = scale(stop.at(n.position(), m), s);
        impulse = axpy(impulse, n.mass, dv);
        w.q = add(w.q, dv);
        let ry = turn.apply(sub(add(n.x0, w.d), c));
        w.d = sub(add(add(c, ry), shift), n.x0);
    }
    impulse
}

/// The Cayley rotation of `a`: by the angle `2 atan(|a|/2)` about `a`, as
/// the unit quaternion `(w, q)`, `q = w a/2`, `w = 1/√(1 + |a|²/4)`; for a
/// small `a`, the rotation by `a` to second order.
#[cfg(any(feature = "ground", feature = "free-rotation"))]
#[derive(Clone, Copy)]
struct Turn {
    w: f32,
    q: Vec3,
}

#[cfg(any(feature = "ground", feature = "free-rotation"))]
impl Turn {
    fn cayley(a: Vec3) -> Self {
        let half = scale(a, 0.5);
        let w = 1.0 / crate::math::sqrt(1.0 + dot(half, half));
        Self {
            w,
            q: scale(half, w),
        }
    }

    /// `R y = y + 2 w (q × y) + 2 q × (q × y)`.
    #[inline(always)]
    fn apply(&self, y: Vec3) -> Vec3 {
        let qy = cross(self.q, y);
        add(
            y,
            add(scale(qy, 2.0 * self.w), scale(cross(self.q, qy), 2.0)),
        )
    }

    #[cfg(feature = "free-rotation")]
    fn inverse(self) -> Self {
        Self {
            w: self.w,
            q: scale(self.q, -1.0),
        }
    }
}

/// The most fixed-point iterations of the rotation's midpoint in [`turn`]:
/// each one gains a factor of about `h |ω|/2` (at most ½ where it runs).
#[cfg(feature = "free-rotation")]
const TURN_ITERATIONS: u32 = 24;

/// Moves an isolated body over the step (end displacement in `d`, velocity
/// in `q`) with its rotation made a rotation, not a step along the tangents.
///
/// `x' = x + h v'` moves a body spinning at `ω` along its tangents, which
/// stretches it by `(h |ω|)²/2` each step. A body that moves as one over
/// the step (`share`, the [`reach`] of a pressure wave, is 1) takes that
/// stretch out again in the next step's solve: strain that no force asked
/// for, whose energy a stiff body holds as long as it spins (at 20 rad/s
/// with `dt` 10 ms, 2 % a step: for a nearly incompressible body, far more
/// than its kinetic energy). A body that a wave does not
/// cross within a step (soft, or a short step) is left to the tangents:
/// there the stretch is small, and over several steps its elastic forces
/// bend its parts' paths as they should; a body without stiffness is a
/// cloud of particles, which do fly along their tangents.
///
/// The new velocity `v'` is split into the rigid motion of its momentum,
/// `v_c + ω × y` about the centre of mass `c` (`y = x − c`), and the
/// deformation `v_d`, which has no momentum. The body moves to
///
/// ```text
/// y' = R (y + h v_d),   c' = c + h v_c,   v'' = v_c + R (v' − v_c) + δω × y'
/// ```
///
/// with `R` the Cayley rotation of `h ω_m`, and `δω` the rotation that
/// keeps the angular momentum `L` of `v'` (`I' δω = L − L_R`, `I'` the
/// inertia of `y'`, `L_R` that of the turned velocity: small, of the order
/// of `h |ω| |L|`). `ω_m` solves the implicit midpoint rule of a rigid
/// body's rotation, `ω_m = I⁻¹ (L + Rᵀ L)/2`, which makes `δω` give the
/// rigid part the angular velocity `I'⁻¹ L` and keeps the rigid body's
/// kinetic energy `½ Lᵀ I⁻¹ L` as well as `L` (in the body's frame it is the
/// implicit midpoint rule of Euler's equations, whose quadratic invariants
/// these are). So the step keeps the linear and angular momentum the solve
/// gave, and the rigid kinetic energy; the deformation moves as before,
/// turned with the body.
///
/// The changes from the tangent update are formed as such (`R a − a`, and
/// `L_R − L` from them), so that their round-off is that of small terms:
/// the momenta are kept to the tangent update's round-off.
///
/// Returns whether the body was moved: not when `(h |ω|)²` is below
/// `f32::EPSILON` (the stretch is then below the positions' round-off, and
/// the step keeps its tangent update's bits), nor when the body does not
/// move as one, nor for a body without mass or whose inertia is singular.
#[cfg(feature = "free-rotation")]
fn turn(
    body: Option<Rigid>,
    nodes: &[Node],
    work: &mut [NodeWork],
    h: f32,
    share: impl FnOnce(&Rigid) -> f32,
) -> bool {
    let Some(body) = body else {
        return false;
    };
    let Some(inertia) = body.inertia else {
        return false;
    };
    let (vc, l) = body.momenta(nodes, work, |n, w| scale(w.q, n.mass));
    let Some(omega) = solve3(&inertia, l) else {
        return false;
    };
    if !(h * h * dot(omega, omega) >= f32::EPSILON) || !(share(&body) >= 1.0) {
        return false;
    }
    // The midpoint's fixed point, from the tangent's `ω`; a change below
    // f32's resolution of `ω` ends it.
    let mut mid = omega;
    for _ in 0..TURN_ITERATIONS {
        let back = Turn::cayley(scale(mid, h)).inverse().apply(l);
        let Some(next) = solve3(&inertia, scale(add(l, back), 0.5)) else {
            return false;
        };
        let change = sub(next, mid);
        mid = next;
        if dot(change, change) <= f32::EPSILON * f32::EPSILON * dot(mid, mid) {
            break;
        }
    }
    let r = Turn::cayley(scale(mid, h));
    // Per node, with `v_r = v' − v_c` and `t = y + h v_d`: the position
    // moves by `e = y' − y = (R t − t) + h v_d` (plus `h v_c`), the velocity
    // by `f = R v_r − v_r`; `L_R − L = Σ m (e × v_r + y × f + e × f)`.
    let mut inertia1 = [[0.0f32; 3]; 3];
    let mut gained = [0.0f32; 3];
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let y = sub(n.position(), body.c);
        let vr = sub(w.q, vc);
        let vd = sub(vr, cross(omega, y));
        let t = axpy(y, h, vd);
        let e = axpy(sub(r.apply(t), t), h, vd);
        let f = sub(r.apply(vr), vr);
        gained = axpy(gained, n.mass, add(cross(e, add(vr, f)), cross(y, f)));
        w.d = add(n.u, axpy(e, h, vc));
        w.q = add(w.q, f);
        add_inertia(&mut inertia1, n.mass, add(y, e));
    }
    let Some(delta) = solve3(&inertia1, scale(gained, -1.0)) else {
        // Only a body whose inertia collapsed within the step: the turned
        // velocity keeps the momentum to first order.
        return true;
    };
    let c1 = axpy(body.c, h, vc);
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        w.q = add(w.q, cross(delta, sub(add(n.x0, w.d), c1)));
    }
    true
}

/// How much of a body moves as one during a step of length `h`: the
/// distance `c h` a pressure wave travels, over the body's radius of
/// gyration `L = √(tr I / 2M)`, at most 1. `c² = (λ + 2μ) / ρ` with the
/// volume-weighted mean Young's modulus, `Σ E V / Σ V`, and `ρ = M / Σ V`:
/// `c² = (λ' + 2μ') Σ E V / M` (`λ'`, `μ'` per unit `E`). An element's
/// `E V` is its stored `E / (36 V₀)` times `(6 V₀)²`. The limit of the
/// rigid part of an impact: a body without stiffness (`c = 0`) takes none,
/// each node lands alone; a stiff body over a long step lands whole.
#[cfg(any(feature = "ground", feature = "free-rotation"))]
fn reach(
    body: &Rigid,
    elems: &[crate::element::ElementBlock],
    n_elems: usize,
    per_young: [f32; 2],
    h: f32,
) -> f32 {
    let mut ev = 0.0f32;
    // Unused lanes of the last block have zero stiffness.
    for blk in elems.iter().take(n_elems.div_ceil(crate::lanes::LANES)) {
        for j in 0..crate::lanes::LANES {
            let el = blk.get(j);
            ev += el.stiffness * el.six_v0() * el.six_v0();
        }
    }
    let Some(inertia) = body.inertia else {
        return 0.0;
    };
    let trace = inertia[0][0] + inertia[1][1] + inertia[2][2];
    // (c h / L)² = (λ' + 2μ') Σ E V h² / M · 2M / tr I.
    let ratio2 = (per_young[0] + 2.0 * per_young[1]) * ev * h * h * 2.0 / trace;
    if ratio2 >= 1.0 {
        1.0
    } else {
        crate::math::sqrt(ratio2.max(0.0))
    }
}
