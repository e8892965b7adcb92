//! The rigid part of a body's landing on the ground.

use super::ground::{Contact, Plane};
use super::on_ground;
use super::plane_fit::PlaneFit;
use crate::math::{add, axpy, dot, scale, sub, Vec3};
use crate::rigid::{Rigid, Turn};
use crate::storage::{Node, NodeWork};

/// The weight of a held node in the fit of an impact, per unit mass, against
/// 1 for a node arriving: the ground already holds it, so the motion must
/// leave its normal velocity as it is (up to `1/HELD` of the arrivals'
/// misfit, well within f32 for the 3×3 system).
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
///   step ([`share`](crate::rigid::share)): none without stiffness, all of a stiff one. Within
///   it, only as far as the energy falls: with `Δ` the motion, the kinetic
///   energy changes by `s Σ m v·Δ + ½ s² Σ m Δ²`, least at
///   `s = −Σ m v·Δ / Σ m Δ²`. For a body the ground held at the step's
///   start (`resting`), gravity's velocity over the step is its weight
///   pressing, which the elastic solve carries, not an impact: the lift's
///   potential energy `−h s Σ m g·Δ` counts too, which moves `v` to
///   `v − h g` in the sum.
/// * **Only a push.** A motion whose momentum points into the ground
///   (`Σ m Δ·n ≤ 0`: a fit that stops an arriving edge by turning the body
///   about it while its centre moves down) is no impulse the ground can
///   give: then there is no rigid stop, and each node is stopped alone.
/// * **Where.** It is added to the step's velocity change, so the
///   displacement moves by the motion over the step (`u' = u + h v'`): the
///   translation `h s a n` and the rotation by `h s θ` about the centre of
///   mass at the step's end, made exact (the Cayley rotation of `h s θ/2`,
///   orthogonal; added linearly, `y + h s θ × y` would stretch the body by
///   `|h s θ|²/2`). The shape, and so the elastic energy, do not change.
///
/// `work` holds the step's end ([`NodeWork::end`]);
/// `body` is the body at the step's start, with its inertia.
#[allow(clippy::too_many_arguments)]
pub(crate) fn impact(
    g: Plane,
    h: f32,
    gravity: Vec3,
    resting: bool,
    body: &Rigid,
    nodes: &[Node],
    work: &mut [NodeWork],
    share: impl FnOnce(&Rigid) -> f32,
) -> Vec3 {
    let moving = body.fit(nodes, work, |n, w| scale(w.end().1, n.mass));
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
                let (u, v) = w.end();
                let vn = dot(g.normal, v).max(dot(g.normal, body.at(n, moving)));
                if vn < 0.0 && Contact::still(g).distance(add(n.x0, u)) < 0.0 {
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
    let mut pushes = 0.0f32;
    for (n, w) in nodes.iter().zip(work.iter()) {
        let dv = stop.at(n.position(), m);
        let (u, v) = w.end();
        along += n.mass * dot(sub(v, settle), dv);
        norm2 += n.mass * dot(dv, dv);
        pushes += n.mass * dot(g.normal, dv);
        mc = axpy(mc, n.mass, add(n.x0, u));
    }
    // The share takes a pass over the elements: only for an impact.
    let s = -along / norm2;
    if !(s > 0.0 && s.is_finite() && pushes > 0.0) {
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
        let (u, v) = w.end();
        let ry = turn.apply(sub(add(n.x0, u), c));
        w.set_end(sub(add(add(c, ry), shift), n.x0), add(v, dv));
    }
    impulse
}
