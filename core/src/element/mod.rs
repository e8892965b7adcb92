//! Tetrahedral elements: the per-element storage and the force kernel of each
//! method. Each method is a cargo feature, so a firmware image that uses one
//! method carries only that kernel.

mod block;
pub(crate) mod formulation;
pub(crate) mod hform;
#[cfg(feature = "linear")]
pub(crate) mod linear;
#[cfg(any(feature = "polar", feature = "qr-invertible"))]
pub(crate) mod polar;
pub(crate) mod qr;
#[cfg(any(feature = "polar", feature = "two-level", feature = "qr-invertible"))]
pub(crate) mod rotation;

pub(crate) use block::{block_and_lane, lane3, Batch};
pub use block::{element_blocks, ElementBlock};

use crate::math::{add, Real, Vec3};

#[cfg(not(any(
    feature = "qr",
    feature = "polar",
    feature = "linear",
    feature = "qr-rest-b",
    feature = "qr-invertible"
)))]
compile_error!(
    "corofem: enable at least one element method feature: `qr-invertible`, `qr`, `polar`, \
     `linear` or `qr-rest-b`"
);

/// How an element separates rotation from deformation.
///
/// Every variant exists in every build; each method's kernel is compiled in
/// by the cargo feature of the same name ([`Method::feature`]), so a firmware
/// image carries only the kernels it uses. Selecting a method that is not
/// compiled in is [`Error::MethodNotCompiled`](crate::Error::MethodNotCompiled)
/// and leaves the scene unchanged; [`Method::COMPILED`] lists the others.
// The discriminants are explicit because an all-zero `Settings` (the header
// of a `static` scene, see `state::Header`) holds `Qr`: its bits are zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The paper's method: QR frame, `B` recomputed from the current shape every
    /// step (no ghost forces, no ghost torques). The default where
    /// `qr-invertible` is not compiled in. Feature `qr`.
    /// Its forces
    /// on an inverted element are not the gradient of an energy: with many
    /// elements inverted and light damping they feed energy in, and a body
    /// can stay folded (docs/reliability.md); [`Method::QrInvertible`] is
    /// the same where no element inverts.
    Qr = 0,
    /// Polar decomposition of the deformation gradient with `det R = +1`, also
    /// for inverted elements; about 30% more work than `Qr`. Feature `polar`.
    Polar = 1,
    /// No rotation: small-displacement linear elasticity (a rotated body
    /// grows). Feature `linear`.
    Linear = 2,
    /// QR rotation with `B` frozen at rest, as SOFA's default: a demonstration
    /// of the ghost torques that `Qr` avoids, for comparisons. Feature
    /// `qr-rest-b`.
    QrRestB = 3,
    /// `Qr`, with inverted elements (QR's local `zd < 0`) taking the rotation
    /// closest to their deformation gradient instead, `det R = +1` (Irving,
    /// Teran and Fedkiw 2004: the smallest singular value changes sign),
    /// which pushes them back through themselves with the forces of an
    /// energy. Elements that are not inverted get `Qr`'s bits, and while
    /// none is, its cost (a block of elements with an inverted one is
    /// finished element by element); the step keeps the linear and angular momentum of an isolated body
    /// exact as `Qr` does. The default where compiled in. Feature
    /// `qr-invertible` (which includes `qr`; a default feature).
    ///
    /// Measured (docs/reliability.md): it recovers a soft liver that `Qr`
    /// blows up on or leaves folded, at `Qr`'s cost while no element is
    /// inverted; but a body crushed flat and stiffened again settles with
    /// more residual strain than with `Qr` (worst edge 5.35 % against
    /// 2.06 %; `Polar` 5.75 %).
    QrInvertible = 4,
}

impl Default for Method {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Method {
    /// The method of this build's defaults (`Settings::compiled` of
    /// `Settings::new`): `QrInvertible` when compiled in, else `Qr`,
    /// otherwise the first compiled method.
    #[cfg(feature = "qr-invertible")]
    pub const DEFAULT: Method = Method::QrInvertible;
    /// The method of this build's defaults (`Settings::compiled` of
    /// `Settings::new`): `QrInvertible` when compiled in, else `Qr`,
    /// otherwise the first compiled method.
    #[cfg(all(not(feature = "qr-invertible"), feature = "qr"))]
    pub const DEFAULT: Method = Method::Qr;
    /// The method of this build's defaults (`Settings::compiled` of
    /// `Settings::new`): `QrInvertible` when compiled in, else `Qr`,
    /// otherwise the first compiled method.
    #[cfg(all(not(feature = "qr"), feature = "polar"))]
    pub const DEFAULT: Method = Method::Polar;
    /// The method of this build's defaults (`Settings::compiled` of
    /// `Settings::new`): `QrInvertible` when compiled in, else `Qr`,
    /// otherwise the first compiled method.
    #[cfg(all(not(feature = "qr"), not(feature = "polar"), feature = "linear"))]
    pub const DEFAULT: Method = Method::Linear;
    /// The method of this build's defaults (`Settings::compiled` of
    /// `Settings::new`): `QrInvertible` when compiled in, else `Qr`,
    /// otherwise the first compiled method.
    #[cfg(all(
        not(feature = "qr"),
        not(feature = "polar"),
        not(feature = "linear"),
        feature = "qr-rest-b"
    ))]
    pub const DEFAULT: Method = Method::QrRestB;

    /// Every method, compiled in or not, in a fixed order.
    pub const VARIANTS: [Method; 5] = [
        Method::Qr,
        Method::Polar,
        Method::Linear,
        Method::QrRestB,
        Method::QrInvertible,
    ];

    /// The methods compiled into this build, in the order of
    /// [`Method::VARIANTS`]: those a scene accepts.
    pub const COMPILED: &'static [Method] = &[
        #[cfg(feature = "qr")]
        Method::Qr,
        #[cfg(feature = "polar")]
        Method::Polar,
        #[cfg(feature = "linear")]
        Method::Linear,
        #[cfg(feature = "qr-rest-b")]
        Method::QrRestB,
        #[cfg(feature = "qr-invertible")]
        Method::QrInvertible,
    ];

    /// Whether this build has the method's kernel (its cargo feature,
    /// [`Method::feature`], is on).
    #[must_use]
    pub const fn is_compiled(self) -> bool {
        match self {
            Method::Qr => cfg!(feature = "qr"),
            Method::Polar => cfg!(feature = "polar"),
            Method::Linear => cfg!(feature = "linear"),
            Method::QrRestB => cfg!(feature = "qr-rest-b"),
            Method::QrInvertible => cfg!(feature = "qr-invertible"),
        }
    }

    /// The method itself if it is compiled in, else [`Method::DEFAULT`].
    /// Free where every method or a single one is compiled in (the identity,
    /// or a constant).
    #[inline(always)]
    #[must_use]
    pub(crate) const fn compiled_or_default(self) -> Method {
        if self.is_compiled() {
            self
        } else {
            Method::DEFAULT
        }
    }

    /// The scene-file name: `"qr"`, `"polar"`, `"linear"`, `"qr-rest-b"` or
    /// `"qr-invertible"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Method::Qr => "qr",
            Method::Polar => "polar",
            Method::Linear => "linear",
            Method::QrRestB => "qr-rest-b",
            Method::QrInvertible => "qr-invertible",
        }
    }

    /// The cargo feature of `corofem` that compiles the method in: its
    /// [`name`](Method::name).
    #[must_use]
    pub const fn feature(self) -> &'static str {
        self.name()
    }

    /// The method with this scene-file name, compiled in or not (check
    /// [`Method::is_compiled`], or let the scene refuse it).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Method> {
        Method::VARIANTS.into_iter().find(|m| m.name() == name)
    }
}

/// What a force kernel returns for one element.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ElementForces {
    /// World forces on `b, c, d` (N); node `a` gets minus their sum, which
    /// makes the element's net force zero exactly.
    pub(crate) f: [Vec3; 3],
    /// World gradients of the shape functions of `b, c, d`, scaled by `6V₀`
    /// (m²), for the stiffness product.
    pub(crate) grad: [Vec3; 3],
    /// Elastic energy (J).
    pub(crate) energy: f32,
    /// Current signed volume is negative.
    pub(crate) inverted: bool,
}

/// Forces, gradients and energy of an element, or of one element per lane
/// (`T` = [`Batch`]): what a force kernel computes before the inversion test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kernel<T> {
    /// World forces on `b, c, d` (N).
    pub(crate) f: [[T; 3]; 3],
    /// World gradients of `b, c, d`, scaled by `6V₀` (m²).
    pub(crate) grad: [[T; 3]; 3],
    /// Elastic energy (J).
    pub(crate) energy: T,
}

/// One element's data as a value: what an [`ElementBlock`] keeps in each lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Element {
    /// Node indices `a, b, c, d`.
    pub(crate) nodes: [u16; 4],
    /// Rest local coordinates `[xb, xc, yc, xd, yd, zd]` in the QR frame (m).
    pub(crate) rest: qr::Local,
    /// `E / (36 V₀)` (Pa/m³): this element's Young's modulus over `36 V₀`.
    /// With the body's Poisson ratio it gives the Lamé coefficients the
    /// kernels use, [`Element::lame`].
    pub(crate) stiffness: f32,
    /// World gradients of `b, c, d` from the last force evaluation (m²).
    pub(crate) grad: [Vec3; 3],
    /// Rest world gradients of `b, c, d` (m²).
    #[cfg(any(feature = "polar", feature = "linear"))]
    pub(crate) rest_grad: [Vec3; 3],
    /// Polar rotation (quaternion `w, x, y, z`), the warm start of the next step.
    #[cfg(feature = "polar")]
    pub(crate) rot: [f32; 4],
}

impl Element {
    /// An unused slot.
    #[cfg(test)]
    pub(crate) const EMPTY: Self = Self {
        nodes: [0; 4],
        rest: [0.0; 6],
        stiffness: 0.0,
        grad: [[0.0; 3]; 3],
        #[cfg(any(feature = "polar", feature = "linear"))]
        rest_grad: [[0.0; 3]; 3],
        #[cfg(feature = "polar")]
        rot: rotation::IDENTITY,
    };

    /// `6 V₀` (m³), from the rest local coordinates: `xb·yc·zd`.
    #[must_use]
    pub(crate) fn six_v0(&self) -> f32 {
        self.rest[0] * self.rest[2] * self.rest[5]
    }

    /// `[λ', μ'] = [λ, μ] / (36 V₀)` (Pa/m³) for the body's
    /// [`lame_per_young`](crate::material::lame_per_young) `per_young`.
    #[inline(always)]
    #[must_use]
    pub(crate) fn lame(&self, per_young: [f32; 2]) -> [f32; 2] {
        lame(self.stiffness, per_young)
    }
}

/// Evaluates the forces of one element with `method`, given its rest edges
/// `b−a, c−a, d−a` and the displacement differences `uᵢ − u_a` (m). The
/// current edges are formed as rest edge + displacement difference, which
/// keeps full f32 accuracy far from the origin.
#[inline(always)]
#[must_use]
pub(crate) fn forces(
    method: Method,
    el: &mut Element,
    per_young: [f32; 2],
    rest: &[Vec3; 3],
    du: &[Vec3; 3],
) -> ElementForces {
    let lame = el.lame(per_young);
    let cur = current_edges(rest, du);
    // A scene never holds a method that is not compiled in (`Settings::validate`
    // refuses it), and the step must not panic all the same: such a method
    // is mapped to the default one, which costs nothing where every method
    // or a single one is compiled in.
    match method.compiled_or_default() {
        #[cfg(feature = "qr")]
        Method::Qr => qr::forces::<true>(cur[0], cur[1], cur[2], &el.rest, lame),
        #[cfg(feature = "qr-rest-b")]
        Method::QrRestB => qr::forces::<false>(cur[0], cur[1], cur[2], &el.rest, lame),
        #[cfg(feature = "qr-invertible")]
        Method::QrInvertible => qr::forces_invertible(cur[0], cur[1], cur[2], &el.rest, lame),
        #[cfg(feature = "polar")]
        Method::Polar => polar::forces(&cur, rest, &el.rest_grad, lame, &mut el.rot),
        #[cfg(feature = "linear")]
        Method::Linear => linear::forces(du, &cur, &el.rest_grad, lame),
        // Unreachable: `compiled_or_default` returns a compiled method, and
        // `Method::DEFAULT` is one. Recursing with it ends at its own arm.
        #[allow(unreachable_patterns)] // every method compiled in
        _ => forces(Method::DEFAULT, el, per_young, rest, du),
    }
}

/// Current edges `rest + du` (m), for one element or one per lane.
#[inline(always)]
#[must_use]
pub(crate) fn current_edges<T: Real>(rest: &[[T; 3]; 3], du: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    [
        add(rest[0], du[0]),
        add(rest[1], du[1]),
        add(rest[2], du[2]),
    ]
}

/// The coefficients `[λ', μ'] = [λ, μ] / (36 V₀)` (Pa/m³) used by the kernels,
/// from an element's [`element_stiffness`](crate::material::element_stiffness) and [`lame_per_young`](crate::material::lame_per_young).
/// For one element or one per lane.
#[inline(always)]
#[must_use]
pub(crate) fn lame<T: Real>(stiffness: T, per_young: [f32; 2]) -> [T; 2] {
    [
        T::splat(per_young[0]) * stiffness,
        T::splat(per_young[1]) * stiffness,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{scale, sub};

    /// At rest the stiffness product equals the derivative of the forces (the
    /// tangent stiffness has no geometric term there): central differences.
    #[test]
    fn stiffness_product_is_the_force_derivative_at_rest() {
        let x = [
            [0.1f32, -0.2, 0.05],
            [1.3, 0.1, -0.2],
            [0.2, 1.1, 0.3],
            [0.4, 0.3, 1.2],
        ];
        let rest = [sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0])];
        let fr = qr::frame(rest[0], rest[1], rest[2]);
        // Stiffness 1 with [λ/E, μ/E] = [1, 0.5]: λ' = 1, μ' = 0.5.
        let per_young = [1.0f32, 0.5];
        let lame = per_young;
        let mut el = Element {
            rest: fr.local,
            stiffness: 1.0,
            ..Element::EMPTY
        };
        let out = qr::forces::<true>(rest[0], rest[1], rest[2], &fr.local, lame);
        el.grad = out.grad;
        #[cfg(any(feature = "polar", feature = "linear"))]
        {
            el.rest_grad = out.grad;
        }
        let d = [
            [0.3f32, -0.1, 0.2],
            [-0.2, 0.4, 0.1],
            [0.1, 0.2, -0.3],
            [0.05, -0.25, 0.15],
        ];
        let kd = hform::stiffness_product(&d, &el.grad, lame);
        let eps = 1e-3f32;
        for &m in Method::COMPILED {
            let f_at = |s: f32| {
                let du = [
                    scale(sub(d[1], d[0]), s),
                    scale(sub(d[2], d[0]), s),
                    scale(sub(d[3], d[0]), s),
                ];
                forces(m, &mut el.clone(), per_young, &rest, &du).f
            };
            let (fp, fm) = (f_at(eps), f_at(-eps));
            for i in 0..3 {
                for k in 0..3 {
                    let fd = (fp[i][k] - fm[i][k]) / (2.0 * eps);
                    // Central difference error O(eps²) plus f32 round-off / eps.
                    assert!(
                        (fd - kd[i][k]).abs() < 2e-3,
                        "{m:?} node {i} comp {k}: fd {fd} vs K d {}",
                        kd[i][k]
                    );
                }
            }
        }
    }

    #[test]
    fn every_name_is_recognised_and_the_default_is_compiled() {
        for m in Method::VARIANTS {
            assert_eq!(Method::from_name(m.name()), Some(m));
            assert_eq!(m.is_compiled(), Method::COMPILED.contains(&m));
            assert!(m.compiled_or_default().is_compiled());
        }
        assert_eq!(Method::from_name("sofa"), None);
        assert!(Method::DEFAULT.is_compiled());
        // An all-zero `Settings` holds `Qr` (see `state::Header`).
        assert_eq!(Method::Qr as u8, 0);
    }
}
