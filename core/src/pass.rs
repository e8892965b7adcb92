//! Element passes: gather the four nodes of each element, do the local maths,
//! scatter-add the results into the nodes — in element order, so the sums are
//! the same on every target.

#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
use crate::element::qr;
use crate::element::{self, hform, lane3, Batch, Element, ElementBlock, ElementForces, Method};
use crate::lanes::LANES;
use crate::math::Real;
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

/// Whole blocks of `count` elements, and the lanes used in the block after
/// them (0 when `count` is a multiple of [`LANES`]; always 0 with one lane,
/// so a Cortex-M4F's loop has no partial block to test for).
#[inline(always)]
fn split(count: usize) -> (usize, usize) {
    (count / LANES, count % LANES)
}

/// Elastic forces of the first `count` elements (and, with `WITH_KV`, the
/// stiffness product `−K v` of the velocities, fused into the same pass since
/// it needs the gradients just computed). With `COMMIT`, each element keeps
/// its new world gradients (and polar rotation); without, elements are left
/// untouched.
///
/// `add_to(node, f_elastic, minus_k_v)` receives each contribution, element
/// after element, in element order, whether or not elements are batched.
/// `per_young` is the body's [`lame_per_young`](crate::material::lame_per_young).
#[inline(always)]
pub(crate) fn forces<const WITH_KV: bool, const COMMIT: bool>(
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &mut [ElementBlock],
    count: usize,
    mut add_to: impl FnMut(usize, Vec3, Vec3),
) -> PassTotals {
    let mut totals = PassTotals::default();
    let (whole, tail) = split(count);
    for blk in elems.iter_mut().take(whole) {
        block::<WITH_KV, COMMIT>(
            method,
            per_young,
            nodes,
            blk,
            LANES,
            &mut add_to,
            &mut totals,
        );
    }
    if tail > 0 {
        if let Some(blk) = elems.get_mut(whole) {
            block::<WITH_KV, COMMIT>(
                method,
                per_young,
                nodes,
                blk,
                tail,
                &mut add_to,
                &mut totals,
            );
        }
    }
    totals
}

/// The force pass of the first `lanes` elements of a block, batched where
/// the method and the target allow it. A function rather than a closure: it
/// must be inlined at both of its calls, or a host that compiles the step for
/// another instruction set would run it compiled for the baseline.
#[inline(always)]
fn block<const WITH_KV: bool, const COMMIT: bool>(
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    blk: &mut ElementBlock,
    lanes: usize,
    add_to: &mut impl FnMut(usize, Vec3, Vec3),
    totals: &mut PassTotals,
) {
    match method {
        #[cfg(feature = "qr")]
        Method::Qr if LANES > 1 => {
            qr_block::<true, WITH_KV, COMMIT>(per_young, nodes, blk, lanes, add_to, totals);
        }
        #[cfg(feature = "qr-rest-b")]
        Method::QrRestB if LANES > 1 => {
            qr_block::<false, WITH_KV, COMMIT>(per_young, nodes, blk, lanes, add_to, totals);
        }
        _ => one_by_one::<WITH_KV, COMMIT>(method, per_young, nodes, blk, lanes, add_to, totals),
    }
}

/// The force pass of the first `lanes` elements of a block, one at a time
/// (every method; the QR methods on targets with one lane).
#[inline(always)]
fn one_by_one<const WITH_KV: bool, const COMMIT: bool>(
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    blk: &mut ElementBlock,
    lanes: usize,
    add_to: &mut impl FnMut(usize, Vec3, Vec3),
    totals: &mut PassTotals,
) {
    for j in 0..lanes {
        let mut el = blk.get(j);
        let Some(n) = gather(nodes, el.nodes) else {
            continue;
        };
        let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
        let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
        let out = element::forces(method, &mut el, per_young, &rest, &du);
        let vel = [n[0].v, n[1].v, n[2].v, n[3].v];
        finish::<WITH_KV>(&mut el, per_young, &out, &vel, add_to, totals);
        if COMMIT {
            blk.set_state(j, &el);
        }
    }
}

/// Keeps an element's new gradients, counts it, and hands its forces (and
/// `−K v` of the node velocities `vel`) to `add_to`.
#[inline(always)]
fn finish<const WITH_KV: bool>(
    el: &mut Element,
    per_young: [f32; 2],
    out: &ElementForces,
    vel: &[Vec3; 4],
    add_to: &mut impl FnMut(usize, Vec3, Vec3),
    totals: &mut PassTotals,
) {
    let kv = if WITH_KV {
        hform::stiffness_product(vel, &out.grad, el.lame(per_young))
    } else {
        [[0.0; 3]; 3]
    };
    el.grad = out.grad;
    tally(out, totals);
    emit(el.nodes, &out.f, &kv, add_to);
}

/// Adds an element's energy and inversion to the totals.
#[inline(always)]
fn tally(out: &ElementForces, totals: &mut PassTotals) {
    totals.inverted += u32::from(out.inverted);
    totals.energy += out.energy;
}

/// Hands `[f_b, f_c, f_d]` and `f_a = −(f_b + f_c + f_d)` (and the same of
/// `kv`) to the four nodes, in the order a, b, c, d.
#[inline(always)]
fn emit(ids: [u16; 4], f: &[Vec3; 3], kv: &[Vec3; 3], add_to: &mut impl FnMut(usize, Vec3, Vec3)) {
    let fa = neg(add(add(f[0], f[1]), f[2]));
    let kva = neg(add(add(kv[0], kv[1]), kv[2]));
    add_to(usize::from(ids[0]), fa, kva);
    add_to(usize::from(ids[1]), f[0], kv[0]);
    add_to(usize::from(ids[2]), f[1], kv[1]);
    add_to(usize::from(ids[3]), f[2], kv[2]);
}

/// The QR force pass of the first `lanes` elements of a block, all at once.
///
/// Gathers the elements' edges (and velocities) into lanes, runs the QR
/// kernel on every lane with the block's own rest coordinates and
/// stiffnesses, then finishes the elements in order exactly as the
/// one-by-one path does. Lanes are independent and see the same operations,
/// so the bits are those of the one-by-one path. A lane whose frame needs a
/// fallback (a collapsed edge or a flat triangle, [`qr::frame`]) is redone
/// alone; unused lanes are computed and ignored.
#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
#[inline(always)]
fn qr_block<const CURRENT_B: bool, const WITH_KV: bool, const COMMIT: bool>(
    per_young: [f32; 2],
    nodes: &[Node],
    blk: &mut ElementBlock,
    lanes: usize,
    add_to: &mut impl FnMut(usize, Vec3, Vec3),
    totals: &mut PassTotals,
) {
    let zero = Batch::splat(0.0);
    // Gather rest positions, displacements (and velocities) corner by corner
    // into lanes. A lane whose node index is out of range (ruled out by
    // `build`) is marked absent and not finished.
    let mut x0 = [[zero; 3]; 4];
    let mut u = [[zero; 3]; 4];
    let mut vel = [[zero; 3]; 4];
    let mut present = [false; LANES];
    for p in present.iter_mut().take(lanes) {
        *p = true;
    }
    for (k, ids) in blk.nodes.iter().enumerate() {
        for (j, (id, p)) in ids.iter().zip(present.iter_mut()).enumerate().take(lanes) {
            let Some(n) = nodes.get(usize::from(*id)) else {
                *p = false;
                continue;
            };
            Batch::put(&mut x0[k], j, n.x0);
            Batch::put(&mut u[k], j, n.u);
            if WITH_KV {
                Batch::put(&mut vel[k], j, n.v);
            }
        }
    }
    // Rest edges and displacement differences, lane by lane as `diffs`.
    let rest = [sub(x0[1], x0[0]), sub(x0[2], x0[0]), sub(x0[3], x0[0])];
    let du = [sub(u[1], u[0]), sub(u[2], u[0]), sub(u[3], u[0])];
    // The kernel on every lane at once, with `[λ', μ']` formed as
    // `crate::material::lame` forms them.
    let lame = [
        Batch::splat(per_young[0]) * blk.stiffness,
        Batch::splat(per_young[1]) * blk.stiffness,
    ];
    let cur = [
        add(rest[0], du[0]),
        add(rest[1], du[1]),
        add(rest[2], du[2]),
    ];
    let (fr, [n1, n3]) = qr::frame_regular(cur[0], cur[1], cur[2]);
    let k = qr::in_frame::<Batch, CURRENT_B>(&fr, &blk.rest, lame);
    let kv = if WITH_KV {
        hform::stiffness_product(&vel, &k.grad, lame)
    } else {
        [[zero; 3]; 3]
    };
    // Finish in element order.
    for j in 0..lanes {
        if !present.get(j).copied().unwrap_or(false) {
            continue;
        }
        let lane = |v: Batch| v.0.get(j).copied().unwrap_or(0.0);
        if qr::regular(lane(n1)) && qr::regular(lane(n3)) {
            let out = ElementForces {
                f: lane3(&k.f, j),
                grad: lane3(&k.grad, j),
                energy: lane(k.energy),
                inverted: lane(fr.local[5]) < 0.0,
            };
            if COMMIT {
                blk.set_grad(j, &out.grad);
            }
            tally(&out, totals);
            emit(blk.nodes(j), &out.f, &lane3(&kv, j), add_to);
        } else {
            // The fallback frame, and −K v with its gradients, alone.
            let mut el = blk.get(j);
            let c = lane3(&cur, j);
            let out = qr::forces::<CURRENT_B>(c[0], c[1], c[2], &el.rest, el.lame(per_young));
            let vel: [Vec3; 4] = core::array::from_fn(|m| Batch::lane(&vel[m], j));
            finish::<WITH_KV>(&mut el, per_young, &out, &vel, add_to, totals);
            if COMMIT {
                blk.set_state(j, &el);
            }
        }
    }
}

/// Stiffness product `q += −K d` of the first `count` elements, with the
/// gradients of the last force pass.
///
/// A block at a time: its gradients and stiffnesses are loaded as whole
/// lanes, the four nodes' `d` of each element gathered into lanes, the
/// product computed on every lane at once and scattered element after
/// element, so every node sum is in element order (the bits of one element
/// at a time). With array-of-structs elements the same batching bought ~2 %:
/// moving the gradients into lanes cost what the lanes saved.
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
pub(crate) fn stiffness(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    work: &mut [NodeWork],
) {
    let (whole, tail) = split(count);
    for blk in elems.iter().take(whole) {
        product_block(per_young, blk, LANES, work);
    }
    if tail > 0 {
        if let Some(blk) = elems.get(whole) {
            product_block(per_young, blk, tail, work);
        }
    }
}

/// [`stiffness`] for the first `lanes` elements of one block.
#[inline(always)]
fn product_block(per_young: [f32; 2], blk: &ElementBlock, lanes: usize, work: &mut [NodeWork]) {
    if LANES == 1 {
        // One element per block (a Cortex-M4F): plain scalar code; the lane
        // bookkeeping below measured 19 instructions more per element there.
        for j in 0..lanes {
            let el = blk.get(j);
            let get = |i: u16| work.get(usize::from(i)).map(|w| w.d);
            let ids = el.nodes;
            let (Some(a), Some(b), Some(c), Some(d)) =
                (get(ids[0]), get(ids[1]), get(ids[2]), get(ids[3]))
            else {
                continue;
            };
            let kd = hform::stiffness_product(&[a, b, c, d], &el.grad, el.lame(per_young));
            scatter(ids, &kd, |i, v| {
                if let Some(w) = work.get_mut(i) {
                    w.q = add(w.q, v);
                }
            });
        }
        return;
    }
    // Gather `d` corner by corner into lanes. A lane whose node index is out
    // of range (ruled out by `build`) is marked absent and not scattered.
    let mut x = [[Batch::splat(0.0); 3]; 4];
    let mut present = [false; LANES];
    for p in present.iter_mut().take(lanes) {
        *p = true;
    }
    for (xk, ids) in x.iter_mut().zip(&blk.nodes) {
        for (j, (id, p)) in ids.iter().zip(present.iter_mut()).enumerate().take(lanes) {
            match work.get(usize::from(*id)) {
                Some(w) => Batch::put(xk, j, w.d),
                None => *p = false,
            }
        }
    }
    let lame = [
        Batch::splat(per_young[0]) * blk.stiffness,
        Batch::splat(per_young[1]) * blk.stiffness,
    ];
    let kd = hform::stiffness_product(&x, &blk.grad, lame);
    for j in 0..lanes {
        if !present.get(j).copied().unwrap_or(false) {
            continue;
        }
        scatter(blk.nodes(j), &lane3(&kd, j), |i, v| {
            if let Some(w) = work.get_mut(i) {
                w.q = add(w.q, v);
            }
        });
    }
}

/// Diagonal of the stiffness matrix of the first `count` elements, averaged
/// over the three components of each node, added into `diag`. For node `i`
/// with world gradient `g` the block diagonal is
/// `λ' g gᵀ + μ' (|g|² I + g gᵀ)`, whose trace is `(λ' + 2μ') |g|²`; node `a`
/// has `g_a = −(g_b + g_c + g_d)`.
#[cfg(feature = "statics")]
pub(crate) fn stiffness_diagonal(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    mut add_to: impl FnMut(usize, f32),
) {
    for e in 0..count {
        let Some(blk) = elems.get(e / LANES) else {
            break;
        };
        let el = blk.get(e % LANES);
        let g = el.grad;
        let ga = neg(add(add(g[0], g[1]), g[2]));
        let [l, m] = el.lame(per_young);
        let c = (l + 2.0 * m) * (1.0 / 3.0);
        for (id, gi) in el.nodes.iter().zip([ga, g[0], g[1], g[2]]) {
            add_to(usize::from(*id), c * crate::math::dot(gi, gi));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::qr;

    /// Twenty elements (two whole batches of eight and four left over) over
    /// a shared cloud of nodes, some of them crushed flat or to a point so
    /// that their lanes need the frame's fallbacks: the batched pass must
    /// give every node the bits of the element-by-element computation.
    #[test]
    fn batched_forces_are_the_bits_of_one_by_one() {
        // Poisson ratio 0.3: λ/E = 0.3/(1.3·0.4), μ/E = 1/2.6.
        const PER_YOUNG: [f32; 2] = [0.576_923_1, 0.384_615_4];
        let mut nodes = [Node::EMPTY; 12];
        for (i, n) in nodes.iter_mut().enumerate() {
            let t = i as f32;
            n.x0 = [0.3 * t, (0.7 * t).sin(), (1.3 * t).cos()];
            n.u = [0.01 * (2.1 * t).sin(), 0.02 * (0.4 * t).cos(), 0.015 * t];
            n.v = [(0.9 * t).cos(), 0.5, -(0.2 * t)];
        }
        // Nodes 10 and 11 sit on node 0: elements using them are crushed.
        nodes[10].x0 = nodes[0].x0;
        nodes[10].u = nodes[0].u;
        nodes[11].x0 = nodes[0].x0;
        nodes[11].u = nodes[0].u;
        let mut elems = [Element::EMPTY; 20];
        for (e, el) in elems.iter_mut().enumerate() {
            let k = e as u16;
            el.nodes = match e {
                3 => [0, 10, 11, 5],  // a = b = c: collapsed edge and triangle
                9 => [0, 10, 4, 7],   // a = b: collapsed edge
                17 => [0, 11, 10, 0], // all four on one point
                _ => [k % 10, (k + 3) % 10, (k + 5) % 10, (k + 8) % 10],
            };
            el.rest = qr::frame([1.0, 0.1, 0.0], [0.2, 0.9, 0.1], [0.1, 0.2, 1.1]).local;
            el.stiffness = 1.0e4 + 10.0 * e as f32;
        }
        let run = |batched: bool| {
            let mut f = [[0.0f32; 3]; 12];
            let mut kv = [[0.0f32; 3]; 12];
            let mut els = elems;
            let add_to = |i: usize, a: Vec3, b: Vec3| {
                f[i] = add(f[i], a);
                kv[i] = add(kv[i], b);
            };
            let totals = if batched {
                // Three blocks of eight (on x86/AArch64): two whole, one with
                // four lanes used.
                let mut blocks = [ElementBlock::EMPTY; crate::element_blocks(20)];
                for (e, el) in els.iter().enumerate() {
                    blocks[e / LANES].set(e % LANES, el);
                }
                let totals =
                    forces::<true, true>(Method::Qr, PER_YOUNG, &nodes, &mut blocks, 20, add_to);
                for (e, el) in els.iter_mut().enumerate() {
                    *el = blocks[e / LANES].get(e % LANES);
                }
                // The stiffness product by blocks against one element at a
                // time, with the gradients just kept.
                let mut work = [NodeWork::EMPTY; 12];
                let mut alone = [[0.0f32; 3]; 12];
                for (i, w) in work.iter_mut().enumerate() {
                    let t = i as f32;
                    w.d = [(1.7 * t).sin(), 0.2 * t, (0.3 * t).cos()];
                }
                stiffness(PER_YOUNG, &blocks, 20, &mut work);
                for el in els.iter() {
                    let x = el.nodes.map(|i| work[usize::from(i)].d);
                    let kd = hform::stiffness_product(&x, &el.grad, el.lame(PER_YOUNG));
                    scatter(el.nodes, &kd, |i, v| alone[i] = add(alone[i], v));
                }
                assert_eq!(
                    work.map(|w| w.q.map(f32::to_bits)),
                    alone.map(|v| v.map(f32::to_bits))
                );
                assert!(alone.iter().any(|v| *v != [0.0; 3]));
                totals
            } else {
                let mut add_to = add_to;
                let mut totals = PassTotals::default();
                for el in els.iter_mut() {
                    let n = gather(&nodes, el.nodes).expect("in range");
                    let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
                    let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
                    let out = element::forces(Method::Qr, el, PER_YOUNG, &rest, &du);
                    let vel = [n[0].v, n[1].v, n[2].v, n[3].v];
                    finish::<true>(el, PER_YOUNG, &out, &vel, &mut add_to, &mut totals);
                }
                totals
            };
            (f, kv, els.map(|e| e.grad), totals.energy, totals.inverted)
        };
        let (batched, alone) = (run(true), run(false));
        for v in batched.0.iter().chain(&batched.1) {
            assert!(crate::math::is_finite3(*v));
        }
        assert_eq!(
            batched.0.map(|v| v.map(f32::to_bits)),
            alone.0.map(|v| v.map(f32::to_bits))
        );
        assert_eq!(
            batched.1.map(|v| v.map(f32::to_bits)),
            alone.1.map(|v| v.map(f32::to_bits))
        );
        assert_eq!(batched.2, alone.2);
        assert_eq!(batched.3.to_bits(), alone.3.to_bits());
        assert_eq!(batched.4, alone.4);
        // The crushed elements did go through the fallback: not every force is zero.
        assert!(batched.0.iter().any(|v| *v != [0.0; 3]));
    }
}
