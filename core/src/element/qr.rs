//! The QR frame of Nesme, Payan and Faure (2005) and the element forces of
//! the `Qr` and `QrRestB` methods.
//!
//! Frame from the current edges `ab, ac, ad` (rows of `R`, world → local):
//!
//! ```text
//! e1 = ab / |ab|,   e3 = (e1 × ac) / |e1 × ac|,   e2 = e3 × e1
//! ```
//!
//! In that frame `a = 0`, `b = (xb, 0, 0)`, `c = (xc, yc, 0)`, `d = (xd, yd, zd)`
//! with `xb > 0`, `yc ≥ 0`, and `6V = xb·yc·zd`: the element is inverted
//! exactly when `zd < 0`.

use super::{ElementForces, Kernel};
use crate::math::{cross, dot, normalize, scale, Real, Vec3};

/// Local coordinates `[xb, xc, yc, xd, yd, zd]` of `b, c, d` in the QR frame, m.
pub(crate) type Local<T = f32> = [T; 6];

/// The QR frame (rows `e1, e2, e3`) and the local coordinates of one element
/// (or of one element per lane).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame<T = f32> {
    pub(crate) e: [[T; 3]; 3],
    pub(crate) local: Local<T>,
}

/// The frame of a regular element, without fallbacks, and the squared lengths
/// `|ab|²` and `|e1 × ac|²` it divided by: the frame is the one [`frame`]
/// returns exactly when both are [`regular`].
#[inline(always)]
#[must_use]
pub(crate) fn frame_regular<T: Real>(ab: [T; 3], ac: [T; 3], ad: [T; 3]) -> (Frame<T>, [T; 2]) {
    let one = T::splat(1.0);
    let n1 = dot(ab, ab);
    let e1 = scale(ab, one / n1.root());
    let c = cross(e1, ac);
    let n3 = dot(c, c);
    let e3 = scale(c, one / n3.root());
    (with_axes(e1, e3, ab, ac, ad), [n1, n3])
}

/// The frame with first and third axes `e1`, `e3` (unit, orthogonal):
/// `e2 = e3 × e1` and the local coordinates of the edges `ab, ac, ad`.
#[inline(always)]
#[must_use]
fn with_axes<T: Real>(e1: [T; 3], e3: [T; 3], ab: [T; 3], ac: [T; 3], ad: [T; 3]) -> Frame<T> {
    let e2 = cross(e3, e1);
    Frame {
        e: [e1, e2, e3],
        local: [
            dot(e1, ab),
            dot(e1, ac),
            dot(e2, ac),
            dot(e1, ad),
            dot(e2, ad),
            dot(e3, ad),
        ],
    }
}

pub(crate) use crate::math::regular;

/// Builds the QR frame of the edges `ab, ac, ad` (m).
///
/// Never fails: a collapsed edge or a flat triangle `abc` falls back to a
/// deterministic choice (first `ad` instead of `ac`, then a coordinate axis),
/// so forces stay finite for any input, including fully crushed elements.
#[inline(always)]
#[must_use]
pub(crate) fn frame(ab: Vec3, ac: Vec3, ad: Vec3) -> Frame {
    let (fr, [n1, n3]) = frame_regular(ab, ac, ad);
    if regular(n1) && regular(n3) {
        return fr;
    }
    let e1 = match normalize(ab) {
        Some(e) => e,
        None => normalize(ac).unwrap_or([1.0, 0.0, 0.0]),
    };
    let e3 = match normalize(cross(e1, ac)) {
        Some(e) => e,
        None => match normalize(cross(e1, ad)) {
            Some(e) => e,
            None => any_perpendicular(e1),
        },
    };
    with_axes(e1, e3, ab, ac, ad)
}

/// A unit vector perpendicular to the unit vector `e`: `e` crossed with the
/// coordinate axis least aligned with it.
fn any_perpendicular(e: Vec3) -> Vec3 {
    let (ax, ay, az) = (e[0].abs(), e[1].abs(), e[2].abs());
    let axis = if ax <= ay && ax <= az {
        [1.0, 0.0, 0.0]
    } else if ay <= az {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    normalize(cross(e, axis)).unwrap_or([0.0, 0.0, 1.0])
}

/// Shape-function gradients of `b, c, d` in the local frame, scaled by `6V`:
/// `[[βb, γb, δb], [βc, γc, δc], [βd, γd, δd]]` (m²).
///
/// The table of Nesme, Payan and Faure (2005), corrected: the paper prints
/// `γb`, `δb`, `δd` with the wrong sign (the formulas below are the right
/// ones; `host-tests/tests/cg_direct.rs` checks them against an independent
/// assembly). Seven products; `βc = βd = γd = 0` by construction and node
/// `a` is minus the sum of the others (partition of unity):
///
/// ```text
/// βb =  yc·zd   γb = −xc·zd   δb = xc·yd − yc·xd
///               γc =  xb·zd   δc = −xb·yd
///                             δd =  xb·yc
/// ```
#[inline(always)]
#[must_use]
pub(crate) fn local_gradients<T: Real>(l: &Local<T>) -> [[T; 3]; 3] {
    let [xb, xc, yc, xd, yd, zd] = *l;
    let zero = T::splat(0.0);
    [
        [yc * zd, -(xc * zd), xc * yd - yc * xd],
        [zero, xb * zd, -(xb * yd)],
        [zero, zero, xb * yc],
    ]
}

/// Element forces with the QR frame. `rest` holds the rest local coordinates
/// (computed by [`frame`] from the rest edges, so the rest shape is an exact
/// equilibrium in f32); `lame = [λ', μ'] = [λ, μ] / (36 V₀)`.
///
/// With `CURRENT_B = true` (`Qr`) the gradients come from the current shape,
/// which makes the net torque vanish; with `false` (`QrRestB`, SOFA's default)
/// they are frozen at rest and ghost torques appear.
#[inline(always)]
#[must_use]
pub(crate) fn forces<const CURRENT_B: bool>(
    ab: Vec3,
    ac: Vec3,
    ad: Vec3,
    rest: &Local,
    lame: [f32; 2],
) -> ElementForces {
    from_frame::<CURRENT_B>(&frame(ab, ac, ad), rest, lame)
}

/// [`forces`] once the frame is known.
#[inline(always)]
#[must_use]
fn from_frame<const CURRENT_B: bool>(fr: &Frame, rest: &Local, lame: [f32; 2]) -> ElementForces {
    let k = in_frame::<f32, CURRENT_B>(fr, rest, lame);
    ElementForces {
        f: k.f,
        grad: k.grad,
        energy: k.energy,
        inverted: fr.local[5] < 0.0,
    }
}

/// [`forces`] of `Method::QrInvertible`: `Qr`'s where the element is not
/// inverted; an inverted one takes the forces, energy and product
/// gradients of the rotation closest to its deformation gradient (the
/// polar method's kernel, with `det R = +1`).
///
/// The polar kernel runs in the element's rest QR frame: rest edges
/// `(xb, 0, 0), (xc, yc, 0), (xd, yd, zd)` and their gradients
/// [`local_gradients`]. The elastic response is isotropic, so the forces
/// are the world frame's (the closest rotation absorbs the rest frame).
/// The rotation search starts cold (Horn's method): an element inverts
/// rarely, and the method keeps no rotation per element.
///
/// The product's gradients are the polar kernel's (`R g₀`): the
/// linearisation of its forces. `Qr`'s gradients of the inverted shape
/// instead (free of net torque, but not the forces' derivative) let a
/// tumbling bunny landing on the ground gain 1.4 kJ of elastic energy and
/// end with 19 elements inverted. The product's net torque is the step's
/// to correct (`rigid::keep_angular_momentum`).
#[cfg(feature = "qr-invertible")]
#[inline(always)]
#[must_use]
pub(crate) fn forces_invertible(
    ab: Vec3,
    ac: Vec3,
    ad: Vec3,
    rest: &Local,
    lame: [f32; 2],
) -> ElementForces {
    let fr = frame(ab, ac, ad);
    // The test of `from_frame`'s `inverted` (a NaN coordinate takes QR's path).
    if !(fr.local[5] < 0.0) {
        return from_frame::<true>(&fr, rest, lame);
    }
    let [xb, xc, yc, xd, yd, zd] = *rest;
    let rest_edges = [[xb, 0.0, 0.0], [xc, yc, 0.0], [xd, yd, zd]];
    let g0 = local_gradients(rest);
    let mut q = super::rotation::IDENTITY;
    let polar = super::polar::forces(&[ab, ac, ad], &rest_edges, &g0, lame, &mut q);
    ElementForces {
        inverted: true,
        ..polar
    }
}

/// `Rᵀ f = fx e1 + fy e2 + fz e3` for the frame rows `e`.
#[inline(always)]
#[must_use]
fn to_world<T: Real>(e: &[[T; 3]; 3], f: [T; 3]) -> [T; 3] {
    let [e1, e2, e3] = e;
    [
        f[0] * e1[0] + f[1] * e2[0] + f[2] * e3[0],
        f[0] * e1[1] + f[1] * e2[1] + f[2] * e3[1],
        f[0] * e1[2] + f[1] * e2[2] + f[2] * e3[2],
    ]
}

/// The QR kernel once the frame is known (the frame's local coordinates are
/// the current shape).
///
/// Flops: frame ≈ 30, gradients 7, strain 10, stress 7, local forces 18,
/// rotation to world 27, world gradients 18.
#[inline(always)]
#[must_use]
pub(crate) fn in_frame<T: Real, const CURRENT_B: bool>(
    fr: &Frame<T>,
    rest: &Local<T>,
    lame: [T; 2],
) -> Kernel<T> {
    let l = fr.local;
    // Local displacement u = current − rest local coordinates. By construction
    // u_a = 0, u_b = (ubx, 0, 0), u_c = (ucx, ucy, 0).
    let ubx = l[0] - rest[0];
    let ucx = l[1] - rest[1];
    let ucy = l[2] - rest[2];
    let udx = l[3] - rest[3];
    let udy = l[4] - rest[4];
    let udz = l[5] - rest[5];
    let g = if CURRENT_B {
        local_gradients(&l)
    } else {
        local_gradients(rest)
    };
    let ([bb, gb, db], [_, gc, dc], [_, _, dd]) = (g[0], g[1], g[2]);
    // Strain ε̃ = B̃ u (Voigt, engineering shear) with the zero entries dropped.
    let exx = bb * ubx;
    let eyy = gc * ucy;
    let ezz = dd * udz;
    let gxy = gb * ubx + gc * ucx;
    let gyz = dc * ucy + dd * udy;
    let gzx = db * ubx + dc * ucx + dd * udx;
    // Stress σ̃ = D' ε̃.
    let [lam, mu] = lame;
    let lt = lam * (exx + eyy + ezz);
    let m2 = mu + mu;
    let s = [
        lt + m2 * exx,
        lt + m2 * eyy,
        lt + m2 * ezz,
        mu * gxy,
        mu * gyz,
        mu * gzx,
    ];
    let energy = T::splat(0.5)
        * (s[0] * exx + s[1] * eyy + s[2] * ezz + s[3] * gxy + s[4] * gyz + s[5] * gzx);
    // Local forces fᵢ = −B̃ᵢᵀ σ̃ with B̃ᵢᵀσ = (βσxx + γσxy + δσzx, γσyy + βσxy + δσyz, δσzz + γσyz + βσzx).
    let fb = [
        -(bb * s[0] + gb * s[3] + db * s[5]),
        -(gb * s[1] + bb * s[3] + db * s[4]),
        -(db * s[2] + gb * s[4] + bb * s[5]),
    ];
    let fc = [
        -(gc * s[3] + dc * s[5]),
        -(gc * s[1] + dc * s[4]),
        -(dc * s[2] + gc * s[4]),
    ];
    let fd = [-(dd * s[5]), -(dd * s[4]), -(dd * s[2])];
    // Back to world: Rᵀ f = fx e1 + fy e2 + fz e3.
    let [_, e2, e3] = fr.e;
    // World gradients gᵢ = Rᵀ (βᵢ, γᵢ, δᵢ), skipping the zero entries.
    let grad = [
        to_world(&fr.e, g[0]),
        [
            gc * e2[0] + dc * e3[0],
            gc * e2[1] + dc * e3[1],
            gc * e2[2] + dc * e3[2],
        ],
        scale(e3, dd),
    ];
    Kernel {
        f: [
            to_world(&fr.e, fb),
            to_world(&fr.e, fc),
            to_world(&fr.e, fd),
        ],
        grad,
        energy,
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the formulas
mod tests {
    use super::*;
    use crate::math::sub;

    const A: Vec3 = [0.1, -0.2, 0.05];
    const B: Vec3 = [1.3, 0.1, -0.2];
    const C: Vec3 = [0.2, 1.1, 0.3];
    const D: Vec3 = [0.4, 0.3, 1.2];

    #[test]
    fn frame_is_orthonormal_and_local_coordinates_reproduce_edges() {
        let (ab, ac, ad) = (sub(B, A), sub(C, A), sub(D, A));
        let f = frame(ab, ac, ad);
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                // f32 round-off of a normalisation.
                assert!((dot(f.e[i], f.e[j]) - want).abs() < 1e-6);
            }
        }
        let [xb, xc, yc, xd, yd, zd] = f.local;
        assert!(xb > 0.0 && yc >= 0.0 && zd > 0.0);
        // 6V = det[ab, ac, ad].
        let six_v = crate::math::det3(ab, ac, ad);
        assert!((xb * yc * zd - six_v).abs() < 1e-5 * six_v.abs());
        let _ = (xc, xd, yd);
    }

    #[test]
    fn gradients_match_a_symbolic_derivation() {
        // The gradient of the linear shape function Nᵢ is the row i of the
        // inverse of the local edge matrix; 6V·∇N must match the table.
        let f = frame(sub(B, A), sub(C, A), sub(D, A));
        let [xb, xc, yc, xd, yd, zd] = f.local;
        let g = local_gradients(&f.local);
        let six_v = xb * yc * zd;
        // Check ∇Nᵢ · (xⱼ − x_a) = δᵢⱼ for j = b, c, d.
        let pts = [[xb, 0.0, 0.0], [xc, yc, 0.0], [xd, yd, zd]];
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { six_v } else { 0.0 };
                assert!((dot(g[i], pts[j]) - want).abs() < 1e-5); // f32 round-off, O(1) entries
            }
        }
    }

    #[test]
    fn rest_shape_is_an_exact_equilibrium() {
        let (ab, ac, ad) = (sub(B, A), sub(C, A), sub(D, A));
        let rest = frame(ab, ac, ad).local;
        let out = forces::<true>(ab, ac, ad, &rest, [1.0e5, 2.0e5]);
        assert_eq!(out.f, [[0.0; 3]; 3]);
        assert_eq!(out.energy, 0.0);
    }

    #[test]
    fn degenerate_input_stays_finite() {
        let z = [0.0; 3];
        let rest = frame(sub(B, A), sub(C, A), sub(D, A)).local;
        for (ab, ac, ad) in [(z, z, z), (B, B, B), (B, scale(B, 2.0), z), (z, C, D)] {
            let out = forces::<true>(ab, ac, ad, &rest, [1.0, 1.0]);
            for v in out.f.iter().chain(out.grad.iter()) {
                assert!(crate::math::is_finite3(*v));
            }
        }
    }
}
