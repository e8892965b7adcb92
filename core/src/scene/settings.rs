//! The checks of [`Settings`]: every field's range, and that what they ask
//! for is compiled in.

use crate::error::{Error, Parameter};
use crate::math::is_finite3;
use crate::settings::Settings;

impl Settings {
    /// Checks every field's range (the error names the field) and that the
    /// method is compiled in.
    pub fn validate(&self) -> Result<(), Error> {
        if !self.method.is_compiled() {
            return Err(Error::MethodNotCompiled {
                method: self.method,
            });
        }
        let bad = |parameter| Err(Error::InvalidParameter { parameter });
        if !(self.dt > 0.0 && self.dt.is_finite()) {
            return bad(Parameter::Dt);
        }
        if self.cg_iterations == 0 {
            return bad(Parameter::CgIterations);
        }
        if !(self.cg_tolerance >= 0.0 && self.cg_tolerance.is_finite()) {
            return bad(Parameter::CgTolerance);
        }
        if !(self.rayleigh_mass >= 0.0 && self.rayleigh_mass.is_finite()) {
            return bad(Parameter::RayleighMass);
        }
        if !(self.rayleigh_stiffness >= 0.0 && self.rayleigh_stiffness.is_finite()) {
            return bad(Parameter::RayleighStiffness);
        }
        if !(self.friction_damping >= 0.0 && self.friction_damping.is_finite()) {
            return bad(Parameter::FrictionDamping);
        }
        if !is_finite3(self.gravity) {
            return bad(Parameter::Gravity);
        }
        if self.energy_guard && !cfg!(feature = "energy-guard") {
            return bad(Parameter::EnergyGuard);
        }
        if self.free_rotation && !cfg!(feature = "free-rotation") {
            return bad(Parameter::FreeRotation);
        }
        Ok(())
    }
}
