//! The right-hand side, and the energy guard around it.

use super::Ctx;
use crate::contact::{Obstacles, Probes};
use crate::guard::{Correction, Ledger, GUARD_ROUNDING};
use crate::math::{add, axpy, scale};
use crate::state::{Header, Lists};
use crate::storage::{Node, NodeWork, FIXED};

/// The residual stage: `r = b − A x₀` from the elastic forces in `r` and
/// `−K d` in `q` that the element pass left, with gravity, the loads, the
/// tool's implicit spring and a sliding node's kinetic friction; and the
/// preconditioner's scalars `1/p`. Returns the guard's sums.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn residual(
    hdr: &Header,
    ctx: &Ctx,
    lists: &Lists<'_>,
    probes: &Probes<'_>,
    subtract: bool,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Ledger {
    let (s, h) = (ctx.s, ctx.h);
    let (mass_coef, k_coef) = (ctx.mass_coef, ctx.k_coef);
    let spring = hdr.spring();
    let obstacles = Obstacles::new(ctx.ground, probes);
    #[cfg(feature = "tool")]
    let mut offsets = crate::storage::Entries::new(lists.grabs);
    #[cfg(feature = "loads")]
    let mut forces = crate::storage::Entries::new(lists.loads);
    let _ = (lists, spring);
    // The guard's sums: twice the kinetic energy, the potential energy of
    // gravity and the loads (`−f·u`, constant forces), and its magnitude.
    let mut ledger = Ledger::default();
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let m = n.mass;
        let weight = scale(s.gravity, m);
        #[cfg(feature = "loads")]
        let (load, f_el) = {
            let load = forces.at(n.flags, crate::storage::LOADED);
            (load, add(w.r, load))
        };
        #[cfg(not(feature = "loads"))]
        let (load, f_el) = ([0.0; 3], w.r);
        ledger.add(n, weight, load);
        let mut f = add(f_el, weight);
        f = obstacles.drag(n, w, f);
        f = axpy(f, -s.rayleigh_mass * m, n.v);
        #[allow(unused_mut)] // only the tool adds to it
        let mut p = mass_coef * m;
        #[cfg(feature = "tool")]
        if spring.holds(n) {
            // Implicit spring: f += k (anchor − x) − h k v, A += h² k.
            let k = spring.k();
            let offset = offsets.next();
            let stretch = crate::math::sub(spring.anchor(offset), n.position());
            f = add(f, scale(stretch, k));
            #[cfg(feature = "energy-guard")]
            ledger.spring(
                k,
                stretch,
                crate::math::sub(add(hdr.energy_target, offset), n.position()),
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
    ledger
}

/// The body's energy at the step's start, as the guard measures it.
#[derive(Clone, Copy)]
pub(super) struct Energy {
    /// Kinetic, elastic, gravity's and the loads', and the tool spring's
    /// with its target.
    #[cfg_attr(not(feature = "energy-guard"), allow(dead_code))]
    pub(super) energy: f32,
    /// The same with the tool spring counted with the target of the
    /// reference: what the check compares.
    pub(super) checked: f32,
    /// The sum of the terms' magnitudes, the scale of their rounding.
    pub(super) size: f32,
}

/// The body's energy from the ledger and the elastic energy of the element
/// pass. The reference counts the tool spring's energy with the target of
/// its step. Moving the target since did work on the body, which the check
/// credits: it counts the spring with the reference's target, the energy
/// the body would have had the target stayed.
#[inline(always)]
pub(super) fn energy(ledger: &Ledger, elastic: f32) -> Energy {
    let own = 0.5 * ledger.kinetic2 + elastic + ledger.potential;
    Energy {
        energy: own + ledger.spring,
        checked: own + ledger.spring_ref,
        size: 0.5 * ledger.kinetic2 + elastic.abs() + ledger.magnitude + ledger.spring_ref,
    }
}

/// The guard stage (`Correction`): the body's energy at the step's start
/// against the reference the last step left; an excess is taken out of the
/// starting velocity, as `M δ` added to the right-hand side.
///
/// Only a step across which elements were inverted (`inverted`) is
/// corrected: there `Qr`'s forces pump energy in. Elsewhere the energy
/// measured is not one that `Qr`'s forces conserve exactly either (its
/// rotation is not the polar one), and the converged implicit step itself
/// moves it by a few per cent of the kinetic energy per step in a swinging
/// body (the hanging liver of docs/bench.md): that is the scheme, not an
/// error to take out.
#[inline(always)]
pub(super) fn guard(
    hdr: &Header,
    ctx: &Ctx,
    e: &Energy,
    inverted: bool,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> Option<Correction> {
    let guard = cfg!(feature = "energy-guard") && ctx.s.energy_guard;
    #[cfg(feature = "energy-guard")]
    let reference = hdr.energy_known.then_some(hdr.energy_ref);
    #[cfg(not(feature = "energy-guard"))]
    let reference = {
        let _ = hdr;
        None::<f32>
    };
    let correction = match reference {
        Some(r) if guard && inverted && e.checked - r > GUARD_ROUNDING * e.size => {
            Correction::new(nodes, work, ctx.any_fixed, e.checked - r)
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
    correction
}

/// The guard's reference for the next step: the energy less what the
/// correction removed, kept only while nothing else did work on the body
/// (`closed`). Only with the guard: without it (a constant where the
/// feature is off) the energy's sums are not computed at all.
#[inline(always)]
pub(super) fn remember(hdr: &mut Header, ctx: &Ctx, e: &Energy, closed: bool, removed: f32) {
    let _ = (&hdr, ctx, e, closed, removed);
    #[cfg(feature = "energy-guard")]
    {
        let guard = ctx.s.energy_guard;
        hdr.energy_known = guard && closed;
        if guard {
            hdr.energy_ref = e.energy - removed;
            #[cfg(feature = "tool")]
            {
                hdr.energy_target = hdr.spring().target();
            }
        }
    }
}
