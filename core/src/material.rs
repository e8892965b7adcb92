//! Isotropic linear-elastic material: Young's modulus, Poisson ratio, density.

pub(crate) use crate::element::lame;
use crate::error::{Error, Parameter};

/// An isotropic material, entered as engineers measure it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Material {
    /// Young's modulus `E`, Pa (`≥ 0`; 0 means no elastic force). Default 1e6.
    pub young: f32,
    /// Poisson ratio `ν`, dimensionless, in `[0, 0.5)`. Default 0.3.
    pub poisson: f32,
    /// Density `ρ`, kg/m³ (`> 0`). Default 1000.
    pub density: f32,
}

impl Default for Material {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Material {
    /// The documented defaults, usable in `const` context.
    pub const DEFAULT: Self = Self {
        young: 1.0e6,
        poisson: 0.3,
        density: 1000.0,
    };

    /// Checks the ranges: `E ≥ 0`, `0 ≤ ν < 0.5`, `ρ > 0`, all finite.
    pub fn validate(&self) -> Result<(), Error> {
        validate_young(self.young)?;
        validate_poisson(self.poisson)?;
        if !(self.density > 0.0 && self.density.is_finite()) {
            return Err(Error::InvalidParameter {
                parameter: Parameter::Density,
            });
        }
        Ok(())
    }
}

pub(crate) fn validate_young(young: f32) -> Result<(), Error> {
    if young >= 0.0 && young.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            parameter: Parameter::Young,
        })
    }
}

pub(crate) fn validate_poisson(poisson: f32) -> Result<(), Error> {
    if (0.0..0.5).contains(&poisson) {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            parameter: Parameter::Poisson,
        })
    }
}

/// Lamé coefficients per unit Young's modulus for Poisson ratio `ν`:
/// `λ/E = ν/((1+ν)(1−2ν))`, `μ/E = 1/(2(1+ν))`.
#[must_use]
pub(crate) fn lame_per_young(poisson: f32) -> [f32; 2] {
    let nu = poisson;
    [
        nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        1.0 / (2.0 * (1.0 + nu)),
    ]
}

/// An element's stiffness `E / (36 V₀)` (Pa/m³), where `six_v0 = 6 V₀` (m³).
/// It folds the `1/(6V₀)` of `B` twice and the volume of the energy integral
/// `V₀` into one factor.
#[must_use]
pub(crate) fn element_stiffness(young: f32, six_v0: f32) -> f32 {
    // 1/(36 V₀) = 1/(6 · 6V₀)
    young / (6.0 * six_v0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lame_matches_textbook() {
        // E = 1, ν = 0.25: λ = 0.25/(1.25·0.5) = 0.4, μ = 1/2.5 = 0.4.
        let [l, m] = lame_per_young(0.25);
        assert!((l - 0.4).abs() < 1e-7 && (m - 0.4).abs() < 1e-7); // f32 round-off
    }

    #[test]
    fn validation_names_the_field() {
        let bad = Material {
            poisson: 0.5,
            ..Material::DEFAULT
        };
        assert_eq!(
            bad.validate(),
            Err(Error::InvalidParameter {
                parameter: Parameter::Poisson
            })
        );
        let bad = Material {
            young: -1.0,
            ..Material::DEFAULT
        };
        assert_eq!(
            bad.validate(),
            Err(Error::InvalidParameter {
                parameter: Parameter::Young
            })
        );
        let bad = Material {
            density: 0.0,
            ..Material::DEFAULT
        };
        assert_eq!(
            bad.validate(),
            Err(Error::InvalidParameter {
                parameter: Parameter::Density
            })
        );
        let bad = Material {
            young: f32::NAN,
            ..Material::DEFAULT
        };
        assert!(bad.validate().is_err());
        assert!(Material {
            young: 0.0,
            ..Material::DEFAULT
        }
        .validate()
        .is_ok());
    }
}
