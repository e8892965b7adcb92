//! The scene's ground and its friction (feature `ground`).

use crate::contact::ground::Plane;
use crate::error::Parameter;
#[cfg(feature = "friction")]
use crate::Friction;

impl<S: crate::Storage> crate::Scene<S> {
    /// Sets (or removes, with `None`) the ground plane. Nodes already below it
    /// are pushed out over the next steps.
    pub fn set_ground(&mut self, plane: Option<Plane>) -> Result<(), crate::Error> {
        self.hdr.ground = match plane {
            Some(p) => Some(p.normalized().ok_or(crate::Error::InvalidParameter {
                parameter: Parameter::Ground,
            })?),
            None => None,
        };
        self.hdr.forget_energy();
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
        self.hdr.ground_friction = friction;
        self.hdr.forget_energy();
    }

    /// The friction between the body and the ground.
    #[cfg(feature = "friction")]
    #[must_use]
    pub fn ground_friction(&self) -> Friction {
        self.hdr.ground_friction
    }
}
