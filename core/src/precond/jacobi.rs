//! The block-Jacobi part: the inverses of the 3×3 node blocks of `A`,
//! from the element gradients.

use super::*;

/// `s v` for a symmetric `s = [xx, yy, zz, xy, yz, zx]`.
#[inline(always)]
pub(super) fn sym_vec(s: &[f32; 6], v: Vec3) -> Vec3 {
    [
        s[0] * v[0] + s[3] * v[1] + s[5] * v[2],
        s[3] * v[0] + s[1] * v[1] + s[4] * v[2],
        s[5] * v[0] + s[4] * v[1] + s[2] * v[2],
    ]
}

/// The inverse of the symmetric positive definite `s`, or `None` when its
/// determinant is not a positive normal number.
pub(super) fn sym_inverse(s: &[f32; 6]) -> Option<[f32; 6]> {
    let [xx, yy, zz, xy, yz, zx] = *s;
    let cxx = yy * zz - yz * yz;
    let cyy = xx * zz - zx * zx;
    let czz = xx * yy - xy * xy;
    let cxy = zx * yz - xy * zz;
    let cyz = xy * zx - xx * yz;
    let czx = xy * yz - yy * zx;
    let det = xx * cxx + xy * cxy + zx * czx;
    if !(det >= f32::MIN_POSITIVE && det.is_finite()) {
        return None;
    }
    let inv = 1.0 / det;
    let out = [
        cxx * inv,
        cyy * inv,
        czz * inv,
        cxy * inv,
        cyz * inv,
        czx * inv,
    ];
    out.iter().all(|x| x.is_finite()).then_some(out)
}

/// Sets every node's `inv` to the inverse of its 3×3 block of
/// `A = mass_coef M + k_coef K` plus `extra(node)` on the diagonal (the tool's
/// spring); zero on fixed nodes. A block that cannot be inverted (not
/// reachable with a validated scene) falls back to the inverse of its
/// diagonal's mass part, or zero without one (a static solve's `A = K`).
#[allow(clippy::too_many_arguments)] // the step's state, passed apart so that each borrow stays narrow
pub(crate) fn node_blocks(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    mass_coef: f32,
    k_coef: f32,
    extra: impl Fn(&Node) -> f32,
) {
    for b in blocks.iter_mut() {
        b.inv = [0.0; 6];
    }
    each_element(per_young, elems, count, |n, g, [l, m]| {
        let lm = l + m;
        for (i, gi) in n.into_iter().zip(g) {
            if let Some(b) = blocks.get_mut(i) {
                let (x, y, z) = (gi[0], gi[1], gi[2]);
                let iso = m * dot(gi, gi);
                b.inv[0] += lm * x * x + iso;
                b.inv[1] += lm * y * y + iso;
                b.inv[2] += lm * z * z + iso;
                b.inv[3] += lm * x * y;
                b.inv[4] += lm * y * z;
                b.inv[5] += lm * z * x;
            }
        }
    });
    for (n, b) in nodes.iter().zip(blocks.iter_mut()) {
        if n.flags & FIXED != 0 {
            b.inv = [0.0; 6];
            continue;
        }
        let p = mass_coef * n.mass + extra(n);
        let mut s = b.inv.map(|x| k_coef * x);
        s[0] += p;
        s[1] += p;
        s[2] += p;
        let fallback = if p > 0.0 { 1.0 / p } else { 0.0 };
        b.inv = sym_inverse(&s).unwrap_or([fallback, fallback, fallback, 0.0, 0.0, 0.0]);
    }
}
