//! Element passes: gather the four nodes of each element, do the local maths,
//! scatter-add the results into the nodes — in element order, so the sums are
//! the same on every target.

use crate::element::{self, hform, Element, Method};
use crate::math::{add, neg, sub, Vec3};
use crate::storage::{Node, NodeWork};

/// Totals of a force pass.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PassTotals {
    /// Elements with negative current volume.
    pub(crate) inverted: u32,
    /// Elastic energy (J), summed in element order.
    pub(crate) energy: f32,
}

/// The four nodes of an element, or `None` if an index is out of range —
/// impossible after `build` validated them, but the compiler cannot know, and
/// skipping the element is both panic-free and cheaper than a fallback value.
#[inline(always)]
fn gather<T: Copy>(slots: &[T], ids: [u16; 4]) -> Option<[T; 4]> {
    let get = |i: u16| slots.get(usize::from(i)).copied();
    Some([get(ids[0])?, get(ids[1])?, get(ids[2])?, get(ids[3])?])
}

/// `[xᵢ − x_a]` for `i = b, c, d`.
#[inline(always)]
fn diffs(x: &[Vec3; 4]) -> [Vec3; 3] {
    [sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0])]
}

/// Scatters `[f_b, f_c, f_d]` and `f_a = −(f_b + f_c + f_d)` to the four nodes
/// through `add_to(node, value)`, in the order a, b, c, d.
#[inline(always)]
fn scatter(ids: [u16; 4], f: &[Vec3; 3], mut add_to: impl FnMut(usize, Vec3)) {
    add_to(usize::from(ids[0]), neg(add(add(f[0], f[1]), f[2])));
    add_to(usize::from(ids[1]), f[0]);
    add_to(usize::from(ids[2]), f[1]);
    add_to(usize::from(ids[3]), f[2]);
}

/// Elastic forces of every element (and, with `WITH_KV`, the stiffness
/// product `−K v` of the velocities, fused into the same pass since it needs
/// the gradients just computed). With `COMMIT`, each element keeps its new
/// world gradients (and polar rotation); without, elements are left untouched.
///
/// `add_to(node, f_elastic, minus_k_v)` receives each contribution.
pub(crate) fn forces<const WITH_KV: bool, const COMMIT: bool>(
    method: Method,
    nodes: &[Node],
    elems: &mut [Element],
    mut add_to: impl FnMut(usize, Vec3, Vec3),
) -> PassTotals {
    let mut totals = PassTotals::default();
    for slot in elems.iter_mut() {
        let mut copy = *slot;
        let el = if COMMIT { slot } else { &mut copy };
        let ids = el.nodes;
        let Some(n) = gather(nodes, ids) else {
            continue;
        };
        let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
        let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
        let out = element::forces(method, el, &rest, &du);
        el.grad = out.grad;
        totals.inverted += u32::from(out.inverted);
        totals.energy += out.energy;
        let kv = if WITH_KV {
            hform::stiffness_product(&[n[0].v, n[1].v, n[2].v, n[3].v], &out.grad, el.lame)
        } else {
            [[0.0; 3]; 3]
        };
        let fa = neg(add(add(out.f[0], out.f[1]), out.f[2]));
        let kva = neg(add(add(kv[0], kv[1]), kv[2]));
        add_to(usize::from(ids[0]), fa, kva);
        add_to(usize::from(ids[1]), out.f[0], kv[0]);
        add_to(usize::from(ids[2]), out.f[1], kv[1]);
        add_to(usize::from(ids[3]), out.f[2], kv[2]);
    }
    totals
}

/// Stiffness product `q += −K d` with the gradients of the last force pass.
pub(crate) fn stiffness(elems: &[Element], work: &mut [NodeWork]) {
    for el in elems {
        let ids = el.nodes;
        let get = |i: u16| work.get(usize::from(i)).map(|w| w.d);
        let (Some(a), Some(b), Some(c), Some(d)) =
            (get(ids[0]), get(ids[1]), get(ids[2]), get(ids[3]))
        else {
            continue;
        };
        let x = [a, b, c, d];
        let kd = hform::stiffness_product(&x, &el.grad, el.lame);
        scatter(ids, &kd, |i, v| {
            if let Some(w) = work.get_mut(i) {
                w.q = add(w.q, v);
            }
        });
    }
}

/// Diagonal of the stiffness matrix, averaged over the three components of
/// each node, added into `diag`. For node `i` with world gradient `g` the
/// block diagonal is `λ' g gᵀ + μ' (|g|² I + g gᵀ)`, whose trace is
/// `(λ' + 2μ') |g|²`; node `a` has `g_a = −(g_b + g_c + g_d)`.
#[cfg(feature = "statics")]
pub(crate) fn stiffness_diagonal(elems: &[Element], mut add_to: impl FnMut(usize, f32)) {
    for el in elems {
        let g = el.grad;
        let ga = neg(add(add(g[0], g[1]), g[2]));
        let c = (el.lame[0] + 2.0 * el.lame[1]) * (1.0 / 3.0);
        let ids = el.nodes;
        for (id, gi) in ids.iter().zip([ga, g[0], g[1], g[2]]) {
            add_to(usize::from(*id), c * crate::math::dot(gi, gi));
        }
    }
}
