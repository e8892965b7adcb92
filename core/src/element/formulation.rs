//! Element formulations: how a method computes a block of elements at
//! once, the seam a new method plugs into.
//!
//! A [`Formulation`] is the kernel of a method in lanes: from the block's
//! edges and rest data, each lane's forces, world gradients and energy, and
//! which lanes stand (a lane it marks irregular is redone by the method's
//! one-element kernel, [`super::forces`], which every method has). The
//! force pass (`crate::pass`) gathers the edges, runs the kernel [`visit`]
//! picks for the scene's method, and scatters the results; the stiffness
//! product works from the gradients the pass keeps, for every method. A new
//! method is a [`super::Method`] variant, its one-element kernel in
//! [`super::forces`], its formulation here and its arm in [`visit`]: the
//! passes and the step are unchanged.

#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
use super::qr;
use super::{Batch, ElementBlock, Method};
use crate::lanes::LANES;

/// What a force pass does with a whole block, given the formulation
/// [`visit`] picks.
pub(crate) trait Visit {
    /// Runs the block with formulation `F`.
    fn visit<F: Formulation>(self);
}

/// Calls `v` with the formulation of `method`; `false`, without calling it,
/// for a method that has none in this build.
#[inline(always)]
pub(crate) fn visit(method: Method, v: impl Visit) -> bool {
    match method {
        #[cfg(feature = "qr")]
        Method::Qr => v.visit::<QrLanes<true>>(),
        #[cfg(feature = "qr-rest-b")]
        Method::QrRestB => v.visit::<QrLanes<false>>(),
        #[cfg(feature = "qr-invertible")]
        Method::QrInvertible => v.visit::<QrInvertibleLanes>(),
        #[cfg(feature = "linear")]
        Method::Linear => v.visit::<LinearLanes>(),
        #[cfg(feature = "polar")]
        Method::Polar => v.visit::<PolarLanes>(),
        #[allow(unreachable_patterns)]
        _ => return false,
    }
    true
}

/// A force kernel run on every lane of a block at once.
pub(crate) trait Formulation {
    /// The method the kernel computes: a lane it marks irregular is redone
    /// by this method's one-element kernel alone. (With the block's runtime
    /// method instead, every batched pass would carry all four one-element
    /// kernels, and LLVM's loop passes, superlinear in the number of loops
    /// of a function, would make the build with every method very slow.)
    const METHOD: Method;
    /// Whether the kernel updates the elements' rotations (`Polar`).
    #[cfg(feature = "polar")]
    const ROTATES: bool = false;
    /// The kernel for the rest edges `rest`, displacement differences `du`
    /// and current edges `cur` (m) of the block's elements, with
    /// `lame = [λ', μ']`.
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces;
}

/// The edges `b − a, c − a, d − a` of a block's elements, in lanes (m):
/// current, and (for the kernels that use them) rest and displacement.
pub(crate) struct Edges {
    #[cfg(feature = "polar")]
    pub(crate) rest: [[Batch; 3]; 3],
    #[cfg(feature = "linear")]
    pub(crate) du: [[Batch; 3]; 3],
    pub(crate) cur: [[Batch; 3]; 3],
}

/// What a [`Formulation`] returns.
pub(crate) struct LaneForces {
    /// Forces, gradients and energy of every lane.
    pub(crate) k: super::Kernel<Batch>,
    /// A value with the sign of each lane's current volume; only the sign is
    /// used (QR's local `zd` in m, `6V` in m³ for the others).
    pub(crate) volume: Batch,
    /// Lanes whose result stands; the others are redone alone by
    /// [`super::forces`] (the QR frame's fallbacks, the polar rotation
    /// search's irregular paths).
    pub(crate) regular: [bool; LANES],
    /// The new rotations, if [`Formulation::ROTATES`].
    #[cfg(feature = "polar")]
    pub(crate) rot: [Batch; 4],
}
/// The QR kernel in lanes (`CURRENT_B` as in [`qr::forces`]).
#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
pub(crate) struct QrLanes<const CURRENT_B: bool>;

#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
impl<const CURRENT_B: bool> Formulation for QrLanes<CURRENT_B> {
    // (With one of the two methods compiled, only its kernel is used.)
    #[cfg(all(feature = "qr", feature = "qr-rest-b"))]
    const METHOD: Method = if CURRENT_B {
        Method::Qr
    } else {
        Method::QrRestB
    };
    #[cfg(not(feature = "qr-rest-b"))]
    const METHOD: Method = Method::Qr;
    #[cfg(not(feature = "qr"))]
    const METHOD: Method = Method::QrRestB;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let cur = &edges.cur;
        let (fr, [n1, n3]) = qr::frame_regular(cur[0], cur[1], cur[2]);
        // The frame is `qr::frame`'s exactly where neither squared length it
        // divided by needs a fallback.
        let mut regular = [false; LANES];
        for ((r, a), b) in regular.iter_mut().zip(n1.0).zip(n3.0) {
            // `&`, not `&&`: no branch, so the loop is vectorised.
            *r = qr::regular(a) & qr::regular(b);
        }
        LaneForces {
            k: qr::in_frame::<Batch, CURRENT_B>(&fr, &blk.rest, lame),
            volume: fr.local[5],
            regular,
            #[cfg(feature = "polar")]
            rot: blk.rot,
        }
    }
}

/// The `QrInvertible` kernel in lanes: `Qr`'s, with the inverted lanes
/// marked irregular, for [`super::forces`] to redo alone
/// ([`qr::forces_invertible`]).
#[cfg(feature = "qr-invertible")]
pub(crate) struct QrInvertibleLanes;

#[cfg(feature = "qr-invertible")]
impl Formulation for QrInvertibleLanes {
    const METHOD: Method = Method::QrInvertible;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let mut out = QrLanes::<true>::run(edges, blk, lame);
        for (r, zd) in out.regular.iter_mut().zip(out.volume.0) {
            *r &= zd >= 0.0;
        }
        out
    }
}

/// The linear kernel in lanes.
#[cfg(feature = "linear")]
pub(crate) struct LinearLanes;

#[cfg(feature = "linear")]
impl Formulation for LinearLanes {
    const METHOD: Method = Method::Linear;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let cur = &edges.cur;
        LaneForces {
            k: super::linear::kernel(&edges.du, &blk.rest_grad, lame),
            volume: crate::math::det3(cur[0], cur[1], cur[2]),
            regular: [true; LANES],
            #[cfg(feature = "polar")]
            rot: blk.rot,
        }
    }
}

/// The polar kernel in lanes: the rotation search of every lane at once
/// where it takes its regular path, the rest of the kernel in lanes.
#[cfg(feature = "polar")]
pub(crate) struct PolarLanes;

#[cfg(feature = "polar")]
impl Formulation for PolarLanes {
    const METHOD: Method = Method::Polar;
    const ROTATES: bool = true;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let cur = &edges.cur;
        let f = super::hform::grad_h(cur, &blk.rest_grad);
        let rot = super::polar::closest_rotation_lanes(&f, blk.rot);
        LaneForces {
            k: super::polar::kernel(&rot.r, &rot.m, &edges.rest, &blk.rest_grad, lame),
            volume: crate::math::det3(cur[0], cur[1], cur[2]),
            regular: rot.regular,
            rot: rot.q,
        }
    }
}
