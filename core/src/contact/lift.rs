//! The rigid push out of the ground of a body that the ground alone holds.

use super::ground::{Contact, Plane};
use super::on_ground;
use super::plane_fit::PlaneFit;
use crate::math::{dot, Vec3};
use crate::rigid::Rigid;
use crate::storage::Node;

/// The push out of the ground of a body that the ground alone holds, and
/// that moves as one over the step (its [`share`](crate::rigid::share) is 1), as one rigid
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
#[derive(Clone, Copy)]
pub(crate) struct Lift {
    fit: PlaneFit,
    motion: (f32, Vec3),
}

impl Lift {
    pub(crate) fn new(g: Plane, body: &Rigid, nodes: &[Node], h: f32) -> Option<Self> {
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
    pub(crate) fn depth(&self, n: &Node, dist: f32, h: f32) -> f32 {
        if on_ground(n) {
            dist.min(-h * self.up(n.position()))
        } else {
            dist
        }
    }
}
