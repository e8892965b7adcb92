//! Small vector helpers on `[f32; 3]` and the math backend shim.
//!
//! The solver works on plain arrays so that hot loops stay simple, copyable and
//! easy for the compiler to vectorise. Every function here is a fixed sequence
//! of IEEE operations (no fused multiply-add), so results are bit-identical on
//! every target.
//!
//! The backend's only function is the square root, chosen here and nowhere
//! else, first match wins:
//!
//! 1. `fpu-sqrt` on a bare-metal Arm hard-float target: the FPU's `vsqrt.f32`;
//! 2. `libm` on x86 with SSE: the `sqrtss` instruction;
//! 3. `libm`: `libm::sqrtf`;
//! 4. `micromath`: its approximation (~6% relative error).
//!
//! The first three are correctly rounded, so they give the same bits. `libm`
//! wins over `micromath` when both are on: Cargo unites the features every
//! crate of a build asks for, and a feature enabled elsewhere must never make
//! the results less accurate without a word, so `micromath` applies only
//! where nothing enables `libm` (a build that wants it turns off the default
//! features everywhere). With neither, the crate does not compile.

#[cfg(not(any(feature = "libm", feature = "micromath")))]
compile_error!("corofem: enable a math backend feature: `libm` (accurate, default) or `micromath` (fast, approximate; `libm` wins when both are on)");

/// A 3-vector (components in the unit of what it holds: m, m/s, N, ...).
pub type Vec3 = [f32; 3];

/// Square root through the selected backend.
#[cfg(all(
    feature = "libm",
    not(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse"
    )),
    not(all(
        feature = "fpu-sqrt",
        target_arch = "arm",
        target_os = "none",
        target_abi = "eabihf"
    ))
))]
#[inline]
#[must_use]
pub(crate) fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Square root with SSE's `sqrtss` through the compiler's intrinsic (backend
/// `libm`, on x86 and x86_64). `libm::sqrtf` emits the same instruction, but
/// from inline assembly: the compiler can neither turn it into `sqrtps` across
/// the lanes of a batch nor give it the VEX encoding, and a legacy-SSE
/// instruction among AVX code costs an SSE/AVX state transition each time it
/// runs (a step built for AVX-512 becomes several times slower). IEEE 754
/// square roots are correctly rounded, so the bits are libm's.
#[cfg(all(
    feature = "libm",
    any(target_arch = "x86", target_arch = "x86_64"),
    target_feature = "sse"
))]
#[allow(unsafe_code)] // one SSE intrinsic
#[inline(always)]
#[must_use]
pub(crate) fn sqrt(x: f32) -> f32 {
    #[cfg(target_arch = "x86")]
    use core::arch::x86::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
    #[cfg(target_arch = "x86_64")]
    use core::arch::x86_64::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
    // SAFETY: the intrinsics need SSE, which `target_feature = "sse"` (part of
    // every x86_64 target) guarantees at compile time; they touch no memory.
    unsafe { _mm_cvtss_f32(_mm_sqrt_ss(_mm_set_ss(x))) }
}

/// Square root through the selected backend (`micromath` without `libm`:
/// ~6% relative error).
#[cfg(all(
    feature = "micromath",
    not(feature = "libm"),
    not(all(
        feature = "fpu-sqrt",
        target_arch = "arm",
        target_os = "none",
        target_abi = "eabihf"
    ))
))]
#[inline]
#[must_use]
pub(crate) fn sqrt(x: f32) -> f32 {
    micromath::F32Ext::sqrt(x)
}

/// Square root with the FPU's `vsqrt.f32` (feature `fpu-sqrt`, on bare-metal
/// Arm hard-float targets such as `thumbv7em-none-eabihf`; elsewhere the
/// feature does nothing). IEEE 754 requires a correctly rounded square root,
/// which is what `libm::sqrtf` computes in software (~50 instructions on a
/// Cortex-M4F), so the results are bit-identical to the `libm` backend, for
/// three instructions (vsqrt takes 14 cycles) instead.
#[cfg(all(
    feature = "fpu-sqrt",
    target_arch = "arm",
    target_os = "none",
    target_abi = "eabihf"
))]
#[allow(unsafe_code)] // one FPU instruction
#[inline]
#[must_use]
pub(crate) fn sqrt(x: f32) -> f32 {
    let mut bits = x.to_bits();
    // SAFETY: touches only the named registers (`s15` is declared clobbered),
    // no memory, no stack, no flags. The value goes through a core register
    // because rustc does not accept `sreg` operands on these targets (it does
    // not see the `vfp2` feature that the hard-float ABI implies);
    // `.fpu` tells the assembler the same.
    unsafe {
        core::arch::asm!(
            ".fpu fpv4-sp-d16",
            "vmov s15, {x}",
            "vsqrt.f32 s15, s15",
            "vmov {x}, s15",
            x = inout(reg) bits,
            out("s15") _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(bits)
}

/// What the vector helpers need of a number: IEEE arithmetic. `f32` and
/// [`Lanes`](crate::lanes::Lanes) in the step; `f64` only where a one-off
/// geometric query wants the digits (binding a surface, `surface.rs`).
pub(crate) trait Arith:
    Copy
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::Mul<Output = Self>
    + core::ops::Div<Output = Self>
    + core::ops::Neg<Output = Self>
{
}

impl<T> Arith for T where
    T: Copy
        + core::ops::Add<Output = T>
        + core::ops::Sub<Output = T>
        + core::ops::Mul<Output = T>
        + core::ops::Div<Output = T>
        + core::ops::Neg<Output = T>
{
}

/// A number the element kernels work on: `f32`, or
/// [`Lanes`](crate::lanes::Lanes) of independent `f32` values (one element per
/// lane). Every operation is the plain IEEE one, lane by lane, so a kernel
/// written once gives the same bits for an element whether it runs alone or
/// in a batch.
pub(crate) trait Real: Arith {
    /// Every lane set to `x`.
    fn splat(x: f32) -> Self;
    /// Square root through the selected backend, lane by lane.
    fn root(self) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn root(self) -> Self {
        sqrt(self)
    }
}

#[inline(always)]
#[must_use]
pub(crate) fn add<T: Arith>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
#[must_use]
pub(crate) fn sub<T: Arith>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
#[must_use]
pub(crate) fn scale<T: Arith>(a: [T; 3], s: T) -> [T; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline(always)]
#[must_use]
pub(crate) fn neg<T: Arith>(a: [T; 3]) -> [T; 3] {
    [-a[0], -a[1], -a[2]]
}

#[inline(always)]
#[must_use]
pub(crate) fn dot<T: Arith>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
#[must_use]
pub(crate) fn cross<T: Arith>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a + s b`.
#[inline(always)]
#[must_use]
pub(crate) fn axpy<T: Arith>(a: [T; 3], s: T, b: [T; 3]) -> [T; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

#[inline]
#[must_use]
pub(crate) fn is_finite3(a: Vec3) -> bool {
    a[0].is_finite() && a[1].is_finite() && a[2].is_finite()
}

/// `acc + a₀·0 + a₁·0 + a₂·0`: a running check that a sequence of vectors
/// is finite. `x·0` is `±0` for every finite `x` and NaN for `±∞` and NaN,
/// so a sum started at zero stays zero exactly while every vector is finite
/// and is NaN from the first one that is not (a NaN never leaves a sum). One
/// multiply-add per component instead of `is_finite`'s integer tests: on a
/// Cortex-M4F, 39 instructions per node checked become 6.
#[inline(always)]
#[must_use]
pub(crate) fn finite_probe(acc: f32, a: Vec3) -> f32 {
    acc + a[0] * 0.0 + a[1] * 0.0 + a[2] * 0.0
}

/// Unit vector along `a`, or `None` when `|a|²` is zero, subnormal or not finite.
#[inline]
#[must_use]
pub(crate) fn normalize(a: Vec3) -> Option<Vec3> {
    let n2 = dot(a, a);
    if regular(n2) {
        Some(scale(a, 1.0 / sqrt(n2)))
    } else {
        None
    }
}

/// A squared length that [`normalize`] divides by: normal and finite, i.e.
/// between the smallest normal and the largest finite `f32` (NaN is
/// neither). Two comparisons without a branch, so that a loop over lanes
/// is vectorised.
#[inline(always)]
#[must_use]
pub(crate) fn regular(n2: f32) -> bool {
    (f32::MIN_POSITIVE..=f32::MAX).contains(&n2)
}

/// Determinant of the 3×3 matrix with columns `a`, `b`, `c`: `a · (b × c)`.
#[inline]
#[must_use]
pub(crate) fn det3<T: Arith>(a: [T; 3], b: [T; 3], c: [T; 3]) -> T {
    dot(a, cross(b, c))
}

/// A 3×3 matrix stored by rows.
pub(crate) type Mat3 = [[f32; 3]; 3];

/// `M v`.
#[cfg(any(
    feature = "polar",
    feature = "qr-invertible",
    feature = "two-level",
    feature = "ground",
    test
))]
#[inline(always)]
#[must_use]
pub(crate) fn mat_vec<T: Arith>(m: &[[T; 3]; 3], v: [T; 3]) -> [T; 3] {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// Solves the 3×3 system `M x = b` by Cramer's rule; `None` when `M` is
/// singular to f32 precision (|det| below `1e-30` relative to the entries).
#[must_use]
pub(crate) fn solve3(m: &Mat3, b: Vec3) -> Option<Vec3> {
    let (x, det, limit) = cramer3(m, b);
    if !(det.abs() > limit) || !det.is_finite() {
        return None;
    }
    Some(x)
}

/// [`solve3`] without its test, for one system or one per lane: the
/// solution, `det M` and the limit `1e-30 |M|³` (Frobenius norm) that `|det|`
/// must exceed for the solution to stand.
#[inline(always)]
#[must_use]
pub(crate) fn cramer3<T: Real>(m: &[[T; 3]; 3], b: [T; 3]) -> ([T; 3], T, T) {
    let c0 = [m[0][0], m[1][0], m[2][0]];
    let c1 = [m[0][1], m[1][1], m[2][1]];
    let c2 = [m[0][2], m[1][2], m[2][2]];
    let det = det3(c0, c1, c2);
    let size = dot(m[0], m[0]) + dot(m[1], m[1]) + dot(m[2], m[2]);
    let limit = T::splat(1e-30) * size * size.root();
    let inv = T::splat(1.0) / det;
    let x = [
        det3(b, c1, c2) * inv,
        det3(c0, b, c2) * inv,
        det3(c0, c1, b) * inv,
    ];
    (x, det, limit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed() {
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
    }

    #[test]
    fn normalize_rejects_zero_and_nan() {
        assert!(normalize([0.0; 3]).is_none());
        assert!(normalize([f32::NAN, 0.0, 0.0]).is_none());
        assert!(normalize([1e-30, 0.0, 0.0]).is_none()); // |a|² underflows
        let n = normalize([3.0, 0.0, 4.0]).unwrap();
        assert_eq!(n, [0.6, 0.0, 0.8]);
    }

    #[test]
    fn finite_probe_stays_zero_exactly_until_a_value_is_not_finite() {
        let finite = [
            [0.0, -0.0, 1.0],
            [f32::MAX, -f32::MAX, f32::MIN_POSITIVE],
            [1e-45, -3.5, 7.0],
        ];
        let acc = finite.iter().fold(0.0, |acc, v| finite_probe(acc, *v));
        assert_eq!(acc, 0.0);
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            for k in 0..3 {
                let mut v = [1.0; 3];
                v[k] = bad;
                // Once non-finite, later finite vectors do not clear it.
                let acc = finite_probe(finite_probe(0.0, v), [2.0; 3]);
                assert!(acc.is_nan(), "{bad} at {k}");
            }
        }
    }

    /// `libm` wins over `micromath` when both are on: the square root is
    /// correctly rounded (`micromath`'s is not, by up to ~6%).
    #[cfg(feature = "libm")]
    #[test]
    fn libm_square_root_is_correctly_rounded() {
        for x in [2.0f32, 3.0, 0.5, 1.0e-3, 12345.678] {
            assert_eq!(sqrt(x), libm::sqrtf(x));
            let r = f64::from(sqrt(x));
            // Correctly rounded: within half an f32 ulp of the exact root.
            let exact = f64::from(x).sqrt();
            assert!((r - exact).abs() <= f64::from(f32::EPSILON) * exact * 0.5);
        }
    }

    #[test]
    fn solve3_solves_and_detects_singular() {
        let m = [[2.0, 0.0, 0.0], [0.0, 4.0, 1.0], [0.0, 1.0, 3.0]];
        let x = solve3(&m, [2.0, 5.0, 4.0]).unwrap();
        let r = mat_vec(&m, x);
        for k in 0..3 {
            // f32 round-off on O(1) entries.
            assert!((r[k] - [2.0, 5.0, 4.0][k]).abs() < 1e-5);
        }
        assert!(solve3(
            &[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
            [1.0; 3]
        )
        .is_none());
    }
}
