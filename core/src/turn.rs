//! A free body's rotation over a step made a rotation (feature
//! `free-rotation`).

use crate::math::{add, axpy, cross, dot, scale, solve3, sub};
use crate::rigid::{add_inertia, Rigid, Turn};
use crate::storage::{Node, NodeWork};

/// The most fixed-point iterations of the rotation's midpoint in [`turn`]:
/// each one gains a factor of about `h |ω|/2` (at most ½ where it runs).
const TURN_ITERATIONS: u32 = 24;

/// Moves an isolated body over the step (its end state in
/// [`NodeWork::end`]) with its rotation made a rotation, not a step along the tangents.
///
/// `x' = x + h v'` moves a body spinning at `ω` along its tangents, which
/// stretches it by `(h |ω|)²/2` each step. A body that moves as one over
/// the step (`share`, the [`share`](crate::rigid::share) of a pressure wave, is 1) takes that
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
pub(crate) fn turn(
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
    let (vc, l) = body.momenta(nodes, work, |n, w| scale(w.end().1, n.mass));
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
        let v = w.end().1;
        let vr = sub(v, vc);
        let vd = sub(vr, cross(omega, y));
        let t = axpy(y, h, vd);
        let e = axpy(sub(r.apply(t), t), h, vd);
        let f = sub(r.apply(vr), vr);
        gained = axpy(gained, n.mass, add(cross(e, add(vr, f)), cross(y, f)));
        w.set_end(add(n.u, axpy(e, h, vc)), add(v, f));
        add_inertia(&mut inertia1, n.mass, add(y, e));
    }
    let Some(delta) = solve3(&inertia1, scale(gained, -1.0)) else {
        // Only a body whose inertia collapsed within the step: the turned
        // velocity keeps the momentum to first order.
        return true;
    };
    let c1 = axpy(body.c, h, vc);
    for (n, w) in nodes.iter().zip(work.iter_mut()) {
        let (u, v) = w.end();
        w.set_end(u, add(v, cross(delta, sub(add(n.x0, u), c1))));
    }
    true
}
