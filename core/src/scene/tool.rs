//! The haptic tool's grab (feature `tool`).

use crate::error::Parameter;
use crate::math::{add, Vec3};
use crate::tool::ToolState;

impl<S: crate::Storage> crate::Scene<S> {
    /// Grabs `nodes` with the tool: a spring of total stiffness `stiffness`
    /// (N/m) between their centroid and the tool target, which starts at that
    /// centroid. Replaces any previous grab. Listing a node twice grabs it
    /// once. Each grabbed node takes one of the storage's grab slots; more
    /// distinct nodes than slots is [`Error::TooManyGrabbed`](crate::Error::TooManyGrabbed),
    /// and on every error nothing changes.
    pub fn grab(&mut self, nodes: &[u32], stiffness: f32) -> Result<(), crate::Error> {
        use crate::storage::{GRABBED, LISTED};
        let n_nodes = self.hdr.n_nodes;
        if let Some(&i) = nodes.iter().find(|&&i| i as usize >= n_nodes) {
            return Err(crate::Error::NodeOutOfRange { node: i });
        }
        if nodes.is_empty() {
            return Err(crate::Error::InvalidParameter {
                parameter: Parameter::ToolNodes,
            });
        }
        if !(stiffness >= 0.0 && stiffness.is_finite()) {
            return Err(crate::Error::InvalidParameter {
                parameter: Parameter::ToolStiffness,
            });
        }
        let p = self.store.parts_mut();
        let all = p.nodes.get_mut(..n_nodes).unwrap_or_default();
        let mut count = 0;
        for &i in nodes {
            if let Some(n) = all.get_mut(i as usize) {
                count += usize::from(n.flags & LISTED == 0);
                n.flags |= LISTED;
            }
        }
        if count > p.grabs.len() {
            for n in all.iter_mut() {
                n.flags &= !LISTED;
            }
            return Err(crate::Error::TooManyGrabbed {
                count,
                capacity: p.grabs.len(),
            });
        }
        let mut sum = [0.0f32; 3];
        for n in all.iter_mut() {
            n.flags &= !GRABBED;
            if n.flags & LISTED != 0 {
                n.flags = (n.flags & !LISTED) | GRABBED;
                sum = add(sum, n.position());
            }
        }
        let centroid = crate::math::scale(sum, 1.0 / count as f32);
        // One entry per grabbed node, in node order (what the step's walk
        // over the nodes expects).
        let grabbed = all
            .iter()
            .enumerate()
            .filter(|(_, n)| n.flags & GRABBED != 0);
        for (slot, (i, n)) in p.grabs.iter_mut().zip(grabbed) {
            *slot = crate::storage::NodeEntry {
                node: i as u32,
                value: crate::math::sub(n.position(), centroid),
            };
        }
        self.hdr.tool = ToolState {
            k_node: stiffness / count as f32,
            target: centroid,
            count: count as u32,
        };
        // A new spring: its energy is not work the guard can account for.
        self.hdr.forget_energy();
        Ok(())
    }

    /// Lets go of the grabbed nodes.
    pub fn release(&mut self) {
        let v = self.view();
        for n in v.nodes.iter_mut() {
            n.flags &= !crate::storage::GRABBED;
        }
        v.hdr.tool = ToolState::NONE;
        v.hdr.forget_energy();
    }

    /// Whether the tool holds nodes.
    #[must_use]
    pub fn is_grabbing(&self) -> bool {
        self.hdr.tool.active()
    }

    /// Where the tool pulls the grabbed nodes' centroid (m).
    #[must_use]
    pub fn tool_target(&self) -> Vec3 {
        self.hdr.tool.target
    }

    /// Moves the tool target (m). A non-finite target is
    /// [`Parameter::ToolTarget`] and nothing changes.
    pub fn set_tool_target(&mut self, target: Vec3) -> Result<(), crate::Error> {
        if !crate::math::is_finite3(target) {
            return Err(crate::Error::InvalidParameter {
                parameter: Parameter::ToolTarget,
            });
        }
        self.hdr.tool.target = target;
        Ok(())
    }

    /// One haptic-loop step: moves the tool target to `target` (m), steps,
    /// and returns the statistics with the force the body exerts on the tool
    /// (`StepStats::tool_force`, N) — what the device renders. On any error
    /// the target stays where it was, like the rest of the state.
    pub fn step_haptic(&mut self, target: Vec3) -> Result<crate::StepStats, crate::StepError> {
        self.with_target(target, Self::step)
    }

    /// Moves the tool target to `target` (m) and steps with `step`; puts the
    /// target back if the step fails.
    #[inline(always)]
    fn with_target(
        &mut self,
        target: Vec3,
        step: impl FnOnce(&mut Self) -> Result<crate::StepStats, crate::StepError>,
    ) -> Result<crate::StepStats, crate::StepError> {
        let previous = self.hdr.tool.target;
        // A step input, so a step error (`set_tool_target` says `Error`).
        self.set_tool_target(target)
            .map_err(|_| crate::StepError::NonFiniteInput)?;
        let stepped = step(self);
        if stepped.is_err() {
            self.hdr.tool.target = previous;
        }
        stepped
    }
}
