//! Kernels written with a 3×3 displacement gradient `H`: the stiffness product
//! of every method and the element forces of `Polar` and `Linear`.
//!
//! For isotropic `D` the product `Bᵀ D B` applied to nodal displacements `Δxᵢ`
//! needs no explicit `B`: with the (6V₀-scaled) gradients `gᵢ` of the shape
//! functions of nodes `b, c, d`,
//!
//! ```text
//! H   = Σ_{i=b,c,d} (Δxᵢ − Δx_a) gᵢᵀ              displacement gradient · 6V₀
//! σ   = λ' tr(H) I + μ' (H + Hᵀ)                  stress · 36V₀² / V₀ (λ', μ' = λ, μ / 36V₀)
//! Δfᵢ = −σ gᵢ  (i = b, c, d),   Δf_a = −(Δf_b + Δf_c + Δf_d)
//! ```
//!
//! This is exactly `−V₀ Bᵀ D B Δx` with `B = B̃ / (6V₀)`: the strain in Voigt
//! order `[εxx, εyy, εzz, γxy, γyz, γzx]` is `(H₀₀, H₁₁, H₂₂, H₀₁+H₁₀, H₁₂+H₂₁,
//! H₂₀+H₀₂)` and `Bᵢᵀ σ_Voigt = σ gᵢ`. About 27 + 27 + 7 multiplications.

use crate::math::{sub, Real};

/// A symmetric 3×3 stress `[sxx, syy, szz, sxy, syz, szx]` (scaled as above).
pub(crate) type Sym<T = f32> = [T; 6];

/// Where a kernel reads the gradients `g_b, g_c, g_d` from: an array, or
/// (the baseline x86_64 step, `crate::rows`) half of a block's lanes read
/// afresh from memory at each use, so that none is kept in a register.
pub(crate) trait Grads<T> {
    /// The gradient of node `i` (`b, c, d` for 0, 1, 2).
    fn at(&self, i: usize) -> [T; 3];
}

impl<T: Copy> Grads<T> for [[T; 3]; 3] {
    #[inline(always)]
    fn at(&self, i: usize) -> [T; 3] {
        self[i]
    }
}

/// `H = Σᵢ dᵢ gᵢᵀ` for the three edge vectors `d` and gradients `g` (rows of H
/// are components of `d`).
#[inline(always)]
#[must_use]
pub(crate) fn grad_h<T: Real>(d: &[[T; 3]; 3], g: &impl Grads<T>) -> [[T; 3]; 3] {
    // Written out, not as loops: with `g` read from memory at each use, LLVM
    // kept a loop over `r` and went through the stack.
    let e = |r, c| h_entry(d, g, r, c);
    [
        [e(0, 0), e(0, 1), e(0, 2)],
        [e(1, 0), e(1, 1), e(1, 2)],
        [e(2, 0), e(2, 1), e(2, 2)],
    ]
}

/// `H[r][c]` of [`grad_h`].
#[inline(always)]
fn h_entry<T: Real>(d: &[[T; 3]; 3], g: &impl Grads<T>, r: usize, c: usize) -> T {
    d[0][r] * g.at(0)[c] + d[1][r] * g.at(1)[c] + d[2][r] * g.at(2)[c]
}

/// Isotropic stress of the symmetric part of `H`:
/// `σ = λ' tr(H) I + μ' (H + Hᵀ)`, with `lame = [λ', μ']`.
#[inline(always)]
#[must_use]
pub(crate) fn stress<T: Real>(h: &[[T; 3]; 3], lame: [T; 2]) -> Sym<T> {
    let [l, m] = lame;
    let lt = l * (h[0][0] + h[1][1] + h[2][2]);
    let m2 = m + m;
    [
        lt + m2 * h[0][0],
        lt + m2 * h[1][1],
        lt + m2 * h[2][2],
        m * (h[0][1] + h[1][0]),
        m * (h[1][2] + h[2][1]),
        m * (h[2][0] + h[0][2]),
    ]
}

/// `−σ g` for a symmetric `σ`.
#[inline(always)]
#[must_use]
pub(crate) fn neg_stress_times<T: Real>(s: &Sym<T>, g: [T; 3]) -> [T; 3] {
    [
        -(s[0] * g[0] + s[3] * g[1] + s[5] * g[2]),
        -(s[3] * g[0] + s[1] * g[1] + s[4] * g[2]),
        -(s[5] * g[0] + s[4] * g[1] + s[2] * g[2]),
    ]
}

/// Energy `½ σ : ε` of the stress `s` and the gradient `h` it came from
/// (J, when `s` comes from [`stress`] with `[λ', μ']`).
#[cfg(any(feature = "polar", feature = "linear", feature = "qr-invertible"))]
#[inline(always)]
#[must_use]
pub(crate) fn energy<T: Real>(s: &Sym<T>, h: &[[T; 3]; 3]) -> T {
    T::splat(0.5)
        * (s[0] * h[0][0]
            + s[1] * h[1][1]
            + s[2] * h[2][2]
            + s[3] * (h[0][1] + h[1][0])
            + s[4] * (h[1][2] + h[2][1])
            + s[5] * (h[2][0] + h[0][2]))
}

/// The stiffness product of one element: `−K Δx` for the nodes `a, b, c, d`
/// given the node vectors `x` and world gradients `g` of `b, c, d`.
/// Returns the contributions to `b, c, d`; node `a` gets minus their sum.
#[inline(always)]
#[must_use]
pub(crate) fn stiffness_product<T: Real>(
    x: &[[T; 3]; 4],
    g: &[[T; 3]; 3],
    lame: [T; 2],
) -> [[T; 3]; 3] {
    product_forces(&product_stress(x, g, lame), g)
}

/// The stress of [`stiffness_product`]: `σ` of the node vectors `x`.
#[inline(always)]
#[must_use]
pub(crate) fn product_stress<T: Real>(x: &[[T; 3]; 4], g: &impl Grads<T>, lame: [T; 2]) -> Sym<T> {
    let d = [sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0])];
    stress(&grad_h(&d, g), lame)
}

/// The forces of [`stiffness_product`] from its stress `s`: `−σ gᵢ` for
/// `b, c, d`.
#[inline(always)]
#[must_use]
pub(crate) fn product_forces<T: Real>(s: &Sym<T>, g: &impl Grads<T>) -> [[T; 3]; 3] {
    [
        neg_stress_times(s, g.at(0)),
        neg_stress_times(s, g.at(1)),
        neg_stress_times(s, g.at(2)),
    ]
}
