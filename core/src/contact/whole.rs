//! The ground's contact with a body that moves as one over the step: its
//! impulses solved as Coulomb contact constraints on the body's rigid
//! motion.

use super::ground::{Contact, Plane};
use super::plane_fit::tangents;
use crate::math::{add, axpy, cross, dot, mat_vec, scale, solve3, sub, Mat3, Vec3};
use crate::rigid::{Rigid, Turn};
use crate::storage::{Node, NodeWork};

/// Sweeps of projected Gauss–Seidel over the contact rows, at most. Each
/// sweep is a pass over the nodes with a few dozen flops at each node near
/// the plane; the sweeps stop once no impulse moves by more than
/// [`TOLERANCE`] of the weight's impulse over the step.
const SWEEPS: u32 = 200;

/// The sweeps' end: the largest change of a node's impulse in a sweep, in
/// units of `M (|g| h + |v|)` (the impulse that stops the whole body):
/// well above f32's rounding of the sums (ε ≈ 1.2e-7 times the number of
/// terms), well below what moves a node by a rounding of its position.
const TOLERANCE: f32 = 1e-6;

/// Rounds of the candidate set: nodes that the rows' motion takes below
/// the plane join, at most this many times.
const ROUNDS: u32 = 4;

/// A contact row's per-node state, in the slots of [`NodeWork`] that the
/// step has spent by its end: the node's impulse so far in `dv` (`x` keeps the velocity change, the
/// next step's warm start), and in `r`
/// the bound on its normal velocity, whether it is a row, and its friction
/// coefficient.
#[inline(always)]
fn is_row(w: &NodeWork) -> bool {
    w.r[1] != 0.0
}

/// `r[1]` of a row that ends the step on the plane.
const TOUCHING: f32 = 2.0;

/// Whether node `w` ends the last [`solve`] on the plane, pressed by it
/// or touching it.
#[inline(always)]
pub(crate) fn touching(w: &NodeWork) -> bool {
    w.r[1] == TOUCHING
}

/// The ground's contact with a body no fixed node, tool or probe holds and
/// that a pressure wave crosses within the step ([`crate::rigid::share`]
/// is 1): each node that ends the free step near or below the plane is a
/// contact row, whose impulse `λ` (normal `λₙ ≥ 0`, tangential
/// `|λₜ| ≤ μ λₙ`) moves the body rigidly, by `(Σ λ / M, I⁻¹ Σ r × λ)`.
/// The rows are solved by projected Gauss–Seidel (the sequential impulses
/// of Box2D's contact solver, without its softening: a stiff body's
/// contacts are hard):
///
/// * **Non-penetration.** A node's normal velocity after the motion ends
///   it on or above the plane: `n·v' ≥ n·v − d/h`, `d` its distance from
///   the plane at the free step's end. Complementary: `λₙ > 0` only where
///   the node ends on the plane.
/// * **Coulomb.** A node's tangential velocity after the motion is zero
///   where `|λₜ| ≤ μs λₙ` holds it; where that cannot, it slides, with
///   `|λₜ| = μk λₙ` against its slip (a row found sliding in a sweep is
///   bounded by `μk` from then on).
///
/// The deformation the impulses would cause is left out: the body answers
/// them as a whole within the step (the share 1), and its strain under its
/// own weight, `g L / c²`, is below the strain `(g h²)/L` of a node moved by
/// a step's fall. Nodes that the motion would take below the plane join as
/// rows, at most [`ROUNDS`] times. The motion is applied as the impact's
/// is (`contact::impact`): positions turned about the centre of mass at the
/// step's end by the Cayley rotation, shape unchanged. Returns the impulse
/// of the ground and the number of nodes that end on the plane.
///
/// `work` holds the step's end ([`NodeWork::end`]); `body` is the body at
/// the step's start, with its inertia; `mu` the static and kinetic
/// coefficients (zero without friction).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve(
    g: Plane,
    mu: (f32, f32),
    h: f32,
    gravity: Vec3,
    body: &Rigid,
    nodes: &[Node],
    work: &mut [NodeWork],
) -> (Vec3, u32) {
    let Some(inertia) = body.inertia else {
        return ([0.0; 3], 0);
    };
    let Some(inv_inertia) = invert(&inertia) else {
        return ([0.0; 3], 0);
    };
    let plane = Contact::still(g);
    let n = g.normal;
    let (t1, t2) = tangents(n);
    let inv_mass = body.inv_mass;
    // Nodes that the free step ends below the plane are rows from the
    // start; those the motion takes below join later. The same pass finds
    // the impulse scale: what stops the body falling at its fastest node's
    // speed plus a step's gravity.
    let mut speed2 = 0.0f32;
    for (node, w) in nodes.iter().zip(work.iter_mut()) {
        let (u, v) = w.end();
        speed2 = speed2.max(dot(v, v));
        w.dv = [0.0; 3];
        let d = plane.distance(add(node.x0, u));
        w.r = if d < 0.0 {
            bound(n, v, d, h, mu.0)
        } else {
            [0.0; 3]
        };
    }
    let scale_impulse =
        (crate::math::sqrt(dot(gravity, gravity)) * h + crate::math::sqrt(speed2)) / inv_mass;
    let tol = TOLERANCE * scale_impulse;
    let (mut dv, mut dw) = ([0.0f32; 3], [0.0f32; 3]);
    let rows = Rows {
        n,
        t: (t1, t2),
        c: body.c,
        inv_mass,
        inv_inertia,
        kinetic: mu.1,
    };
    for _ in 0..ROUNDS {
        // The rows, linked in node order.
        let mut head = END;
        for (i, w) in work.iter_mut().enumerate().rev() {
            if is_row(w) {
                w.inv_p = f32::from_bits(head);
                head = i as u32;
            }
        }
        for _ in 0..SWEEPS {
            let mut change = 0.0f32;
            let mut i = head;
            while let (Some(node), Some(w)) = (nodes.get(i as usize), work.get_mut(i as usize)) {
                change = change.max(rows.sweep(node, w, &mut dv, &mut dw));
                i = w.inv_p.to_bits();
            }
            if !(change > tol) {
                break;
            }
        }
        // Nodes the motion takes below the plane join.
        let mut joined = 0u32;
        for (node, w) in nodes.iter().zip(work.iter_mut()) {
            if is_row(w) {
                continue;
            }
            let (u, v) = w.end();
            let r = sub(node.position(), body.c);
            let d = plane.distance(add(node.x0, u));
            if d + h * dot(n, add(dv, cross(dw, r))) < 0.0 {
                w.r = bound(n, v, d, h, mu.0);
                w.dv = [0.0; 3];
                joined += 1;
            }
        }
        if joined == 0 {
            break;
        }
    }
    if !(dot(dv, dv) + dot(dw, dw) > 0.0) || !crate::math::is_finite3(add(dv, dw)) {
        return ([0.0; 3], 0);
    }
    // The motion applied: u' = u + h (dv + dw × y) with y about the centre
    // of mass at the step's end, the rotation made exact (Cayley).
    let mut mc = [0.0f32; 3];
    for (node, w) in nodes.iter().zip(work.iter()) {
        mc = axpy(mc, node.mass, add(node.x0, w.end().0));
    }
    let c = scale(mc, inv_mass);
    let turn = Turn::cayley(scale(dw, h));
    let shift = scale(dv, h);
    let (mut impulse, mut pressed) = ([0.0f32; 3], 0u32);
    for (node, w) in nodes.iter().zip(work.iter_mut()) {
        let r = sub(node.position(), body.c);
        let (u, v) = w.end();
        let ry = turn.apply(sub(add(node.x0, u), c));
        let v2 = add(v, add(dv, cross(dw, r)));
        w.set_end(sub(add(add(c, ry), shift), node.x0), v2);
        if is_row(w) {
            impulse = add(impulse, w.dv);
            // On the plane: pressed, or left there by the motion (a flat
            // face's nodes share its weight in any of many ways; those
            // given none still touch). The sweeps stop with each row's
            // impulse known to `tol`, so its end to `h tol` times its
            // response: a gap within that, or within the position's
            // rounding, touches.
            let gap = h * (dot(n, v2) - w.r[0]);
            if dot(n, w.dv) > 0.0
                || gap <= g.rounding(add(node.x0, u)) + h * tol * rows.response(r, n)
            {
                w.r[1] = TOUCHING;
                pressed += 1;
            }
        }
    }
    (impulse, pressed)
}

/// The end of the rows' chain (in `NodeWork::inv_p`, the preconditioner's
/// slot, spent by the step's end, as the bits of the next row's index).
const END: u32 = u32::MAX >> 1;

/// The body's rows: the plane's frame and the body's rigid response.
struct Rows {
    n: Vec3,
    t: (Vec3, Vec3),
    c: Vec3,
    inv_mass: f32,
    inv_inertia: Mat3,
    kinetic: f32,
}

impl Rows {
    /// The body's velocity response at arm `r` to a unit impulse along `k`.
    #[inline(always)]
    fn response(&self, r: Vec3, k: Vec3) -> f32 {
        let rk = cross(r, k);
        self.inv_mass + dot(rk, mat_vec(&self.inv_inertia, rk))
    }

    /// One Gauss–Seidel update of the row at `node`: its friction, then
    /// its normal impulse, projected, with the body's motion `(dv, dw)`
    /// moved by the change. Returns the change's size (`|Δλ|₁`).
    #[inline(always)]
    fn sweep(&self, node: &Node, w: &mut NodeWork, dv: &mut Vec3, dw: &mut Vec3) -> f32 {
        let (n, (t1, t2)) = (self.n, self.t);
        let r = sub(node.position(), self.c);
        let v = add(w.end().1, add(*dv, cross(*dw, r)));
        let lambda = w.dv;
        let ln = dot(n, lambda);
        // Friction first, bounded by the normal impulse so far; the normal
        // row last (it matters most).
        let cone = w.r[2] * ln;
        let mut next = if cone > 0.0 {
            let lt = sub(lambda, scale(n, ln));
            let a = -dot(t1, v) / self.response(r, t1);
            let b = -dot(t2, v) / self.response(r, t2);
            let mut lt2 = add(lt, add(scale(t1, a), scale(t2, b)));
            let size2 = dot(lt2, lt2);
            if size2 > cone * cone {
                lt2 = scale(lt2, cone / crate::math::sqrt(size2));
                // Sliding: the kinetic bound from now on.
                w.r[2] = self.kinetic;
            }
            add(scale(n, ln), lt2)
        } else {
            scale(n, ln)
        };
        let moved = sub(next, lambda);
        let mut v2 = v;
        if moved != [0.0; 3] {
            (*dv, *dw) = push(*dv, *dw, moved, r, self.inv_mass, &self.inv_inertia);
            v2 = add(w.end().1, add(*dv, cross(*dw, r)));
        }
        let dn = (w.r[0] - dot(n, v2)) / self.response(r, n);
        let ln2 = (ln + dn).max(0.0);
        let step_n = ln2 - ln;
        if step_n != 0.0 {
            (*dv, *dw) = push(
                *dv,
                *dw,
                scale(n, step_n),
                r,
                self.inv_mass,
                &self.inv_inertia,
            );
            next = axpy(next, step_n, n);
        }
        let total = sub(next, lambda);
        w.dv = next;
        total[0].abs() + total[1].abs() + total[2].abs()
    }
}

/// The row of a node that ends the free step at distance `d` from the
/// plane (normal `n`) with velocity `v`: the bound on its normal velocity
/// that ends it on the plane, `n·v − d/h`, the row flag, and the friction
/// coefficient.
#[inline(always)]
fn bound(n: Vec3, v: Vec3, d: f32, h: f32, mu: f32) -> [f32; 3] {
    [dot(n, v) - d / h, 1.0, mu]
}

/// The rigid motion `(dv, dw)` after the impulse `p` at arm `r`.
#[inline(always)]
fn push(dv: Vec3, dw: Vec3, p: Vec3, r: Vec3, inv_mass: f32, inv_inertia: &Mat3) -> (Vec3, Vec3) {
    (
        axpy(dv, inv_mass, p),
        add(dw, mat_vec(inv_inertia, cross(r, p))),
    )
}

/// `m⁻¹` by three solves, `None` for a singular `m`.
fn invert(m: &Mat3) -> Option<Mat3> {
    let c0 = solve3(m, [1.0, 0.0, 0.0])?;
    let c1 = solve3(m, [0.0, 1.0, 0.0])?;
    let c2 = solve3(m, [0.0, 0.0, 1.0])?;
    Some([
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [c0[2], c1[2], c2[2]],
    ])
}
