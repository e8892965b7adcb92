//! The push out of an obstacle taken back out of the velocity (a split
//! impulse).

use super::lift::Lift;
use super::Obstacles;
use crate::cg;
use crate::math::{add, dot, finite_probe, scale, sub, Vec3};
use crate::storage::{Node, NodeWork, FIXED};

crate::backend::isa_inline!(
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
    #[allow(clippy::too_many_arguments)] // the step's parts, as `cg::solve` takes them
    pub(crate) fn relax(
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
);
