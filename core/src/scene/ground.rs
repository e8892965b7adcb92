//! The scene's ground and its friction (feature `ground`).

use crate::contact::ground::Plane;
use crate::error::Parameter;
use crate::math::dot;
use crate::storage::FIXED;
#[cfg(feature = "friction")]
use crate::Friction;
use crate::StepError;

impl<S: crate::Storage> crate::Scene<S> {
    /// Sets (or removes, with `None`) the ground plane. The body must not
    /// start below it: the next step refuses a free node below the plane
    /// with [`StepError::BelowGround`] (so does the first step after the
    /// body is built, moved by [`set_positions`](Self::set_positions) or
    /// [`set_displacements`](Self::set_displacements), reset, or freed by
    /// [`unfix_all`](Self::unfix_all)). Nodes the steps themselves take
    /// below it, landing, are pushed out.
    pub fn set_ground(&mut self, plane: Option<Plane>) -> Result<(), crate::Error> {
        let before = self.hdr.coefficients();
        self.hdr.ground = match plane {
            Some(p) => Some(p.normalized().ok_or(crate::Error::InvalidParameter {
                parameter: Parameter::Ground,
            })?),
            None => None,
        };
        self.hdr.coefficients_changed(before);
        self.hdr.forget_energy();
        self.hdr.placed();
        Ok(())
    }

    /// Refuses a step that would start with a free node below the ground,
    /// once after each placement (`Header::placed`). A node is below when
    /// its signed distance is negative by more than its rounding, 4 ε times
    /// the magnitudes it is summed from: a mesh whose bottom lies on the
    /// plane passes. Pushed out over a step instead, a node deep below
    /// strains its elements by its depth, or the body ends inside out.
    pub(crate) fn check_ground(&mut self) -> Result<(), StepError> {
        if !self.hdr.ground_unchecked {
            return Ok(());
        }
        if let Some(g) = self.hdr.ground {
            let below = self.nodes().iter().position(|n| {
                let x = n.position();
                n.flags & FIXED == 0 && dot(g.normal, x) - g.offset < -g.rounding(x)
            });
            if let Some(node) = below {
                // Below `MAX_NODES`, 2¹⁶.
                return Err(StepError::BelowGround { node: node as u32 });
            }
        }
        self.hdr.ground_unchecked = false;
        Ok(())
    }

    /// The ground plane (normalised), if any.
    #[must_use]
    pub fn ground(&self) -> Option<Plane> {
        self.hdr.ground
    }

    /// Sets the friction between the body and the ground ([`Friction`];
    /// none by default). Nodes that stuck keep sticking only while the new
    /// coefficients hold them.
    #[cfg(feature = "friction")]
    pub fn set_ground_friction(&mut self, friction: Friction) {
        let before = self.hdr.coefficients();
        self.hdr.ground_friction = friction;
        self.hdr.forget_energy();
        self.hdr.coefficients_changed(before);
    }

    /// The friction between the body and the ground.
    #[cfg(feature = "friction")]
    #[must_use]
    pub fn ground_friction(&self) -> Friction {
        self.hdr.ground_friction
    }
}
