//! The haptic tool: a set of grabbed nodes pulled by a spring towards a
//! moving target — the coupling a haptic device renders.
//!
//! When nodes are grabbed, each gets its offset `oᵢ` from the grabbed nodes'
//! centroid, kept in the storage's grab slots (one 16-byte `NodeEntry` per
//! grabbed node, in node order; nodes not grabbed carry nothing). Node `i` is
//! then pulled towards `target + oᵢ` by a spring of stiffness `k / n` (n
//! grabbed nodes), so the total force on the body is `k (target − centroid)`
//! and the grabbed patch follows the target rigidly.
//!
//! The spring is treated implicitly: it enters the step's matrix as `h² k/n`
//! on the grabbed nodes and the right-hand side as `h (f − h k/n v)`, so a stiff
//! spring is as stable as the elastic forces at any time step. The force on the
//! tool is minus the spring force on the body at the end of the step.

use crate::math::{add, Vec3};

/// State of the tool.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ToolState {
    /// Spring stiffness per grabbed node, `k / n` (N/m); 0 when released.
    pub(crate) k_node: f32,
    /// Where the grabbed nodes' centroid is pulled to (m).
    pub(crate) target: Vec3,
    /// Number of grabbed nodes.
    pub(crate) count: u32,
}

impl ToolState {
    /// No tool.
    pub(crate) const NONE: Self = Self {
        k_node: 0.0,
        target: [0.0; 3],
        count: 0,
    };

    /// Whether nodes are grabbed.
    #[inline]
    #[must_use]
    pub(crate) fn active(&self) -> bool {
        self.count > 0
    }

    /// Anchor of a node with grab offset `offset`: `target + oᵢ` (m).
    #[inline]
    #[must_use]
    pub(crate) fn anchor(&self, offset: Vec3) -> Vec3 {
        add(self.target, offset)
    }
}
