//! Element passes: gather the four nodes of each element, do the local maths,
//! scatter-add the results into the nodes — in element order, so the sums are
//! the same on every target. (Element order is the order of the storage
//! slots, an interleaving of the scene's elements that every target shares:
//! `element::block::slot`.)
//!
//! Written once over a [`Backend`]: a block of elements is gathered into
//! lanes, computed on every lane at once and scattered with the backend's
//! moves; the step instantiates these passes once per instruction set.
//! One element at a time is the other path: on targets with one lane per
//! block (a Cortex-M4F), and for a lane whose batched kernel needs a
//! fallback (a degenerate QR frame, an irregular polar rotation search).

use crate::backend::{Backend, NodeU, NodeX0, Portable, Row, WorkD, WorkQ, WorkR};
use crate::element::formulation::{self, Edges, Formulation, LaneForces};
use crate::element::{self, hform, lane3, Batch, ElementBlock, ElementForces, Method};
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

/// Where a force pass puts each element's contributions, element after
/// element in element order, and where it reads the input of its stiffness
/// product.
pub(crate) trait Sink {
    /// Adds node `i`'s elastic force `f` (N).
    fn add_force(&mut self, i: usize, f: Vec3);
    /// Adds node `i`'s stiffness product `kv` (`−K w`, N).
    fn add_kv(&mut self, i: usize, kv: Vec3);
    /// Node `i`'s input `w` of the product `−K w` (zero out of range).
    fn kv_input(&self, i: usize) -> Vec3;

    /// [`Self::kv_input`] of a block's four corners, in lanes
    /// `[corner][component]`.
    #[inline(always)]
    fn kv_inputs<B: Backend>(&self, b: B, ids: &[[u16; LANES]; 4]) -> [[Batch; 3]; 4] {
        let _ = b;
        let mut out = [[Batch::splat(0.0); 3]; 4];
        for (corner, lanes) in out.iter_mut().zip(ids) {
            for (j, &i) in lanes.iter().enumerate() {
                Batch::put(corner, j, self.kv_input(usize::from(i)));
            }
        }
        out
    }

    /// Adds a whole block's contributions: the forces `f` on `b, c, d` of
    /// its lanes (node `a` getting `−(f_b + f_c + f_d)`), then, with
    /// `WITH_KV`, the `−K w` that `kv(w)` returns for the corners' inputs
    /// `w`. Each kind of sum in element order. Returns `false`, having done
    /// nothing, if the block's node indices are out of range.
    #[inline(always)]
    fn add_block<B: Backend, const WITH_KV: bool>(
        &mut self,
        b: B,
        ids: &[[u16; LANES]; 4],
        f: &[[Batch; 3]; 3],
        kv: impl FnOnce(&[[Batch; 3]; 4]) -> [[Batch; 3]; 3],
    ) -> bool {
        let node = |j: usize| ids.map(|c| c.get(j).copied().unwrap_or(0));
        for j in 0..LANES {
            scatter(node(j), &lane3(f, j), |i, v| self.add_force(i, v));
        }
        if WITH_KV {
            let kv = kv(&self.kv_inputs(b, ids));
            for j in 0..LANES {
                scatter(node(j), &lane3(&kv, j), |i, v| self.add_kv(i, v));
            }
        }
        true
    }
}

/// The step's sink: `r += f`, `q += −K d` of each node, the product's
/// input `d`; a block's sums go straight into the node work with the
/// backend's moves.
pub(crate) struct IntoWork<'a>(pub(crate) &'a mut [NodeWork]);

impl Sink for IntoWork<'_> {
    #[inline(always)]
    fn add_force(&mut self, i: usize, f: Vec3) {
        if let Some(w) = self.0.get_mut(i) {
            w.r = add(w.r, f);
        }
    }
    #[inline(always)]
    fn add_kv(&mut self, i: usize, kv: Vec3) {
        if let Some(w) = self.0.get_mut(i) {
            w.q = add(w.q, kv);
        }
    }
    #[inline(always)]
    fn kv_input(&self, i: usize) -> Vec3 {
        self.0.get(i).map_or([0.0; 3], |w| w.d)
    }
    #[inline(always)]
    fn kv_inputs<B: Backend>(&self, b: B, ids: &[[u16; LANES]; 4]) -> [[Batch; 3]; 4] {
        match b.corners::<NodeWork>(ids, self.0.len()) {
            Some(c) => inputs(b, self.0, &c),
            None => [[Batch::splat(0.0); 3]; 4],
        }
    }
    #[inline(always)]
    fn add_block<B: Backend, const WITH_KV: bool>(
        &mut self,
        b: B,
        ids: &[[u16; LANES]; 4],
        f: &[[Batch; 3]; 3],
        kv: impl FnOnce(&[[Batch; 3]; 4]) -> [[Batch; 3]; 3],
    ) -> bool {
        let Some(c) = b.corners::<NodeWork>(ids, self.0.len()) else {
            return false;
        };
        // The inputs before the forces go in: a row of `d` overlaps the
        // rows of `r` that the forces store, and a load that overlaps a
        // pending store only in part waits until the store has reached the
        // cache.
        let d = if WITH_KV {
            Some(inputs(b, self.0, &c))
        } else {
            None
        };
        add_to_nodes::<B, WorkR>(b, self.0, &c, f);
        if let Some(d) = d {
            add_to_nodes::<B, WorkQ>(b, self.0, &c, &kv(&d));
        }
        true
    }
}

/// The product inputs `d` of the four corners of the block `c`, in lanes.
#[inline(always)]
fn inputs<B: Backend>(b: B, work: &[NodeWork], c: &B::Corners<NodeWork>) -> [[Batch; 3]; 4] {
    let mut d = gather4::<B, WorkD>(b, work, c);
    b.fence(&mut d);
    d
}

/// Any other sink: functions `add_force(i, f)` and `add_kv(i, kv)`, and
/// the product's inputs by node.
#[cfg(any(feature = "statics", feature = "diagnostics", test))]
pub(crate) struct Each<'a, F, K>(pub(crate) F, pub(crate) K, pub(crate) &'a [Vec3]);

#[cfg(any(feature = "statics", feature = "diagnostics", test))]
impl<F: FnMut(usize, Vec3), K: FnMut(usize, Vec3)> Sink for Each<'_, F, K> {
    #[inline(always)]
    fn add_force(&mut self, i: usize, f: Vec3) {
        (self.0)(i, f);
    }
    #[inline(always)]
    fn add_kv(&mut self, i: usize, kv: Vec3) {
        (self.1)(i, kv);
    }
    #[inline(always)]
    fn kv_input(&self, i: usize) -> Vec3 {
        self.2.get(i).copied().unwrap_or([0.0; 3])
    }
}

/// Adds each element's `[f_b, f_c, f_d]` (lanes) and node `a`'s share
/// `−(f_b + f_c + f_d)` into the field `R` of its four nodes, in element
/// order: the sums of [`scatter`], with its bits.
#[inline(always)]
fn add_to_nodes<B: Backend, R: Row<Slot = NodeWork>>(
    b: B,
    work: &mut [NodeWork],
    c: &B::Corners<NodeWork>,
    f: &[[Batch; 3]; 3],
) {
    // Node a's share in lanes too, before the fence (after it, LLVM
    // computed it half in 4-wide, half in 2-wide pieces).
    let mut fa = [share_of_a(f), f[0], f[1], f[2]];
    b.fence(&mut fa);
    b.scatter::<R>(work, c, &fa);
}

/// References to the four nodes of an element, or `None` if an index is out
/// of range — impossible after `build` validated them, but the compiler
/// cannot know, and skipping the element is both panic-free and cheaper than
/// a fallback value. Nothing is read until it is used (copies of the nodes
/// made here were loaded up front and spilled on a Cortex-M4F).
#[inline(always)]
fn gather<T>(slots: &[T], ids: [u16; 4]) -> Option<[&T; 4]> {
    let get = |i: u16| slots.get(usize::from(i));
    Some([get(ids[0])?, get(ids[1])?, get(ids[2])?, get(ids[3])?])
}

/// `[xᵢ − x_a]` for `i = b, c, d`, for one element or one per lane.
#[inline(always)]
fn diffs<T: Real>(x: &[[T; 3]; 4]) -> [[T; 3]; 3] {
    [sub(x[1], x[0]), sub(x[2], x[0]), sub(x[3], x[0])]
}

/// Node `a`'s share `−(f_b + f_c + f_d)` of an element's `[f_b, f_c, f_d]`,
/// which makes the element's net contribution zero exactly.
#[inline(always)]
pub(crate) fn share_of_a<T: Real>(f: &[[T; 3]; 3]) -> [T; 3] {
    neg(add(add(f[0], f[1]), f[2]))
}

/// Scatters `[f_b, f_c, f_d]` and `f_a = −(f_b + f_c + f_d)` to the four nodes
/// through `add_to(node, value)`, in the order a, b, c, d.
#[inline(always)]
fn scatter(ids: [u16; 4], f: &[Vec3; 3], mut add_to: impl FnMut(usize, Vec3)) {
    add_to(usize::from(ids[0]), share_of_a(f));
    add_to(usize::from(ids[1]), f[0]);
    add_to(usize::from(ids[2]), f[1]);
    add_to(usize::from(ids[3]), f[2]);
}

/// Field `R` of the four corners of the block `c`, in lanes:
/// `[corner][component]`.
#[inline(always)]
fn gather4<B: Backend, R: Row>(
    b: B,
    slots: &[R::Slot],
    c: &B::Corners<R::Slot>,
) -> [[Batch; 3]; 4] {
    [
        b.gather::<R>(slots, c, 0),
        b.gather::<R>(slots, c, 1),
        b.gather::<R>(slots, c, 2),
        b.gather::<R>(slots, c, 3),
    ]
}

/// Whole blocks of `count` elements, and the lanes used in the block after
/// them (0 when `count` is a multiple of [`LANES`]; always 0 with one lane,
/// so a Cortex-M4F's loop has no partial block to test for).
#[inline(always)]
fn split(count: usize) -> (usize, usize) {
    (count / LANES, count % LANES)
}

/// Elastic forces of the first `count` elements (and, with `WITH_KV`, the
/// stiffness product `−K w` of the sink's inputs `w`, fused into the same
/// pass since it needs the gradients just computed). With `COMMIT`, each element keeps
/// its new world gradients (and polar rotation); without, elements are left
/// untouched.
///
/// `sink` receives each contribution, element after element, in element
/// order, whether or not elements are batched. `per_young` is the body's
/// [`lame_per_young`](crate::material::lame_per_young). Node vectors move
/// with the backend `b`; every backend gives the same bits.
#[inline(always)]
pub(crate) fn forces<B: Backend, const WITH_KV: bool, const COMMIT: bool>(
    b: B,
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &mut [ElementBlock],
    count: usize,
    sink: impl Sink,
) -> PassTotals {
    let mut pass = ForcePass {
        b,
        method,
        per_young,
        nodes,
        sink,
        totals: PassTotals::default(),
    };
    let (whole, tail) = split(count);
    for blk in elems.iter_mut().take(whole) {
        pass.block::<WITH_KV, COMMIT>(blk, LANES);
    }
    if tail > 0 {
        if let Some(blk) = elems.get_mut(whole) {
            pass.block::<WITH_KV, COMMIT>(blk, tail);
        }
    }
    pass.totals
}

/// [`forces`] without `−K v`, for the static solver (`commit`: the elements
/// keep their new gradients) and the diagnostics (elements untouched), with
/// the baseline backend: not generic, so compiled once in this crate rather
/// than in every crate that calls a generic `Scene<S>` method using it; the
/// contributions go through a `dyn` callback (this pass is not in the step).
#[cfg(any(feature = "statics", feature = "diagnostics"))]
pub(crate) fn forces_outside_step(
    commit: bool,
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &mut [ElementBlock],
    count: usize,
    add_to: &mut dyn FnMut(usize, Vec3),
) -> PassTotals {
    let b = crate::backend::BASELINE;
    let sink = Each(add_to, |_, _| {}, &[]);
    if commit {
        forces::<_, false, true>(b, method, per_young, nodes, elems, count, sink)
    } else {
        forces::<_, false, false>(b, method, per_young, nodes, elems, count, sink)
    }
}

/// What every block of a force pass shares.
struct ForcePass<'a, B, S> {
    /// How node vectors move.
    b: B,
    method: Method,
    /// The body's [`lame_per_young`](crate::material::lame_per_young).
    per_young: [f32; 2],
    nodes: &'a [Node],
    /// Where the contributions go, see [`forces`].
    sink: S,
    totals: PassTotals,
}

// Methods: functions rather than closures, inlined at each call, so that in
// a step compiled for another instruction set (a `#[target_feature]`
// function) they are compiled for it too.
impl<B: Backend, S: Sink> ForcePass<'_, B, S> {
    /// The first `lanes` elements of a block: batched where the target
    /// allows it and the block is whole, else one at a time (the partial
    /// block after the whole ones: a few elements once per pass, which
    /// keeps the lane count of the batched pass a constant).
    #[inline(always)]
    fn block<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) {
        let whole = LANES > 1 && lanes == LANES;
        // Whole blocks run the method's formulation in lanes; one lane per
        // block (a Cortex-M4F), the partial block, or a method not compiled
        // in (refused by `set_settings`, so never reached) run one element
        // at a time, which handles every method.
        let visit = Lanes::<'_, '_, B, S, WITH_KV, COMMIT> { pass: self, blk };
        if !(whole && formulation::visit(visit.pass.method, visit)) {
            self.one_by_one::<WITH_KV, COMMIT>(self.method, blk, 0..lanes);
        }
    }

    /// [`Self::batched`] out of line, one function per kernel and
    /// instruction set ([`Backend::call`]). Inlining every method's batched
    /// pass into the step would make one function so large that LLVM's loop
    /// passes take minutes over it; one call per block of eight elements
    /// costs nothing measurable.
    #[inline(always)]
    fn lanes<K: Formulation, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
    ) {
        self.b.call(
            #[inline(always)]
            || self.batched::<K, WITH_KV, COMMIT>(blk),
        );
    }

    /// The elements in `lanes` of a block, one at a time with `method`
    /// (every method; all elements on targets with one lane), each from its
    /// nodes (skipped if a node index is out of range).
    #[inline(always)]
    fn one_by_one<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        method: Method,
        blk: &mut ElementBlock,
        lanes: core::ops::Range<usize>,
    ) {
        let nodes = self.nodes;
        for j in lanes {
            let Some(n) = gather(nodes, blk.nodes(j)) else {
                continue;
            };
            let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
            let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
            self.alone::<WITH_KV, COMMIT>(method, blk, j, &rest, &du);
        }
    }

    /// Element `j` of a block alone with `method`, from its rest edges and
    /// displacement differences; with `WITH_KV`, the product's inputs are
    /// read once the forces are out (loaded where they are used, they are
    /// not kept in registers through the force kernel).
    #[inline(always)]
    fn alone<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        method: Method,
        blk: &mut ElementBlock,
        j: usize,
        rest: &[Vec3; 3],
        du: &[Vec3; 3],
    ) {
        let mut el = blk.get(j);
        let out = element::forces(method, &mut el, self.per_young, rest, du);
        el.grad = out.grad;
        // The forces first, then `−K v`: the two go to different sums, so
        // the order between them changes no bits, and the forces' registers
        // are free again for the product (on a Cortex-M4F, the fused version
        // spilled).
        self.emit_forces(&out, el.nodes);
        if WITH_KV {
            let input = el.nodes.map(|i| self.sink.kv_input(usize::from(i)));
            let kv = hform::stiffness_product(&input, &out.grad, el.lame(self.per_young));
            self.emit_kv(el.nodes, &kv);
        }
        if COMMIT {
            blk.set_state(j, &el);
        }
    }

    /// A whole block of elements, all at once with kernel `K`.
    ///
    /// Runs the kernel on every lane ([`Self::kernel`]) and hands the
    /// block's results to the sink, which gathers the product's inputs
    /// for `−K w`. Lanes are independent and see the same operations, so the
    /// bits are those of one element at a time. If the kernel marks a lane
    /// irregular, [`Self::lane_by_lane`] does the block instead.
    #[inline(always)]
    fn batched<K: Formulation, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
    ) {
        let b = self.b;
        let Some((lame, out)) = self.kernel::<K>(blk) else {
            // A node index out of range (impossible after `build`): the
            // elements that have all their nodes, alone.
            self.one_by_one::<WITH_KV, COMMIT>(self.method, blk, 0..LANES);
            return;
        };
        // Only this test reads the flags here: the lane-by-lane finish
        // computes them again (kept for it, as bytes, they cost the common
        // case about 60 instructions per block).
        if !out.regular.iter().all(|&r| r)
            || !self.sink.add_block::<B, WITH_KV>(
                b,
                &blk.nodes,
                &out.k.f,
                #[inline(always)]
                |input: &[[Batch; 3]; 4]| hform::stiffness_product(input, &out.k.grad, lame),
            )
        {
            self.lane_by_lane::<K, WITH_KV, COMMIT>(blk);
            return;
        }
        for (volume, energy) in out.volume.0.iter().zip(out.k.energy.0) {
            self.totals.inverted += u32::from(*volume < 0.0);
            self.totals.energy += energy;
        }
        if COMMIT {
            // Row by row: the whole 288 bytes at once was a `memmove` call.
            for (dst, src) in blk.grad.iter_mut().zip(&out.k.grad) {
                *dst = *src;
            }
            #[cfg(feature = "polar")]
            if K::ROTATES {
                blk.rot = out.rot;
            }
        }
    }

    /// Kernel `K` on every lane of a whole block: the block's `[λ', μ']`
    /// and the kernel's results; `None` if a node index is out of range.
    ///
    /// The edges are gathered corner by corner, so that only they stay live
    /// (gathering the rest positions, displacements and velocities of all
    /// four corners first kept 36 vectors live, and the pass was bound by
    /// its stores to the stack).
    #[inline(always)]
    fn kernel<K: Formulation>(&self, blk: &ElementBlock) -> Option<([Batch; 2], LaneForces)> {
        let (b, nodes) = (self.b, self.nodes);
        let at = b.corners::<Node>(&blk.nodes, nodes.len())?;
        let (_rest, _du, cur) = gather_edges(b, nodes, &at);
        // (The edges a kernel does not read are not computed: all of this
        // is inlined.)
        let edges = Edges {
            #[cfg(feature = "polar")]
            rest: _rest,
            #[cfg(feature = "linear")]
            du: _du,
            cur,
        };
        let lame = crate::material::lame(blk.stiffness, self.per_young);
        let out = K::run(&edges, blk, lame);
        Some((lame, out))
    }

    /// A whole block with kernel `K`, finished lane by lane in element
    /// order: a lane the kernel marks irregular is redone alone with its
    /// method's one-element kernel, the others take the kernel's results.
    #[inline(always)]
    fn lane_by_lane<K: Formulation, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
    ) {
        let b = self.b;
        let Some((lame, out)) = self.kernel::<K>(blk) else {
            self.one_by_one::<WITH_KV, COMMIT>(self.method, blk, 0..LANES);
            return;
        };
        let kv = if WITH_KV {
            hform::stiffness_product(&self.sink.kv_inputs(b, &blk.nodes), &out.k.grad, lame)
        } else {
            [[Batch::splat(0.0); 3]; 3]
        };
        for j in 0..LANES {
            if !out.regular.get(j).copied().unwrap_or(false) {
                self.one_by_one::<WITH_KV, COMMIT>(K::METHOD, blk, j..j + 1);
                continue;
            }
            let lane = |v: Batch| v.0.get(j).copied().unwrap_or(0.0);
            let f = ElementForces {
                f: lane3(&out.k.f, j),
                grad: lane3(&out.k.grad, j),
                energy: lane(out.k.energy),
                inverted: lane(out.volume) < 0.0,
            };
            if COMMIT {
                blk.set_grad(j, &f.grad);
                #[cfg(feature = "polar")]
                if K::ROTATES {
                    Batch::put(&mut blk.rot, j, Batch::lane(&out.rot, j));
                }
            }
            let ids = blk.nodes(j);
            self.emit_forces(&f, ids);
            if WITH_KV {
                self.emit_kv(ids, &lane3(&kv, j));
            }
        }
    }

    /// Counts an element's energy and inversion, and hands `[f_b, f_c, f_d]`
    /// and `f_a = −(f_b + f_c + f_d)` to the four nodes `ids`, in the order
    /// a, b, c, d.
    #[inline(always)]
    fn emit_forces(&mut self, out: &ElementForces, ids: [u16; 4]) {
        self.totals.inverted += u32::from(out.inverted);
        self.totals.energy += out.energy;
        let sink = &mut self.sink;
        scatter(ids, &out.f, |i, v| sink.add_force(i, v));
    }

    /// Hands an element's `−K v` to its four nodes `ids` as
    /// [`Self::emit_forces`] does its forces.
    #[inline(always)]
    fn emit_kv(&mut self, ids: [u16; 4], kv: &[Vec3; 3]) {
        let sink = &mut self.sink;
        scatter(ids, kv, |i, v| sink.add_kv(i, v));
    }
}

/// A whole block of a force pass, run with the formulation that
/// [`formulation::visit`] picks for the pass's method.
struct Lanes<'p, 'a, B, S, const WITH_KV: bool, const COMMIT: bool> {
    pass: &'p mut ForcePass<'a, B, S>,
    blk: &'p mut ElementBlock,
}

impl<B: Backend, S: Sink, const WITH_KV: bool, const COMMIT: bool> formulation::Visit
    for Lanes<'_, '_, B, S, WITH_KV, COMMIT>
{
    #[inline(always)]
    fn visit<F: Formulation>(self) {
        self.pass.lanes::<F, WITH_KV, COMMIT>(self.blk);
    }
}

/// Three edge vectors in lanes, `[edge][component]`.
type Edges3 = [[Batch; 3]; 3];

/// The edges `b − a, c − a, d − a` of a block's elements at `c`, in lanes:
/// rest (`x0`), displacement (`u`) and current (their sum), as
/// [`diffs`] and [`element::current_edges`] form them. Corner by corner, so
/// that only the edges stay live.
#[inline(always)]
fn gather_edges<B: Backend>(
    b: B,
    nodes: &[Node],
    c: &B::Corners<Node>,
) -> (Edges3, Edges3, Edges3) {
    let mut a = [
        b.gather::<NodeX0>(nodes, c, 0),
        b.gather::<NodeU>(nodes, c, 0),
    ];
    b.fence(&mut a);
    let [eb, ec, ed] = [
        edge(b, nodes, c, 1, &a),
        edge(b, nodes, c, 2, &a),
        edge(b, nodes, c, 3, &a),
    ];
    (
        [eb[0], ec[0], ed[0]],
        [eb[1], ec[1], ed[1]],
        [eb[2], ec[2], ed[2]],
    )
}

/// The rest, displacement and current edge from corner `a` to corner `k`
/// of the block `c` (`a` holds corner `a`'s rest position and
/// displacement).
#[inline(always)]
fn edge<B: Backend>(
    b: B,
    nodes: &[Node],
    c: &B::Corners<Node>,
    k: usize,
    a: &[[Batch; 3]; 2],
) -> [[Batch; 3]; 3] {
    let mut p = [
        b.gather::<NodeX0>(nodes, c, k),
        b.gather::<NodeU>(nodes, c, k),
    ];
    b.fence(&mut p);
    let (rest, du) = (sub(p[0], a[0]), sub(p[1], a[1]));
    [rest, du, add(rest, du)]
}

/// Stiffness product `q += −K d` of the first `count` elements, with the
/// gradients of the last force pass, node vectors moved with the backend
/// `b` (every backend gives the same bits).
///
/// A block at a time: its gradients and stiffnesses are loaded as whole
/// lanes, the four nodes' `d` of each element gathered into lanes, the
/// product computed on every lane at once and scattered element after
/// element, so every node sum is in element order (the bits of one element
/// at a time).
#[inline(always)]
pub(crate) fn stiffness<B: Backend>(
    b: B,
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    work: &mut [NodeWork],
) {
    if LANES == 1 {
        product_one_by_one(per_young, elems.get(..count).unwrap_or(&[]), work);
        return;
    }
    let (whole, tail) = split(count);
    for blk in elems.iter().take(whole) {
        if let Some(c) = b.corners::<NodeWork>(&blk.nodes, work.len()) {
            product_block(b, per_young, blk, &c, work);
        }
    }
    if tail > 0 {
        // The last block, partly used, with the portable moves: once per
        // product, and the same bits.
        let blk = elems.get(whole);
        if let Some((blk, c)) =
            blk.zip(blk.and_then(|blk| Portable::partial(&blk.nodes, tail, work.len())))
        {
            product_block(Portable, per_young, blk, &c, work);
        }
    }
}

/// The stiffness product of one-element blocks in FPU assembly (see
/// `product_one_by_one` below for the Rust one it replaces).
#[cfg(all(
    feature = "fpu-product",
    target_arch = "arm",
    target_os = "none",
    target_abi = "eabihf"
))]
use crate::backend::fpu_product::product as product_one_by_one;

/// [`stiffness`] with one element per block (a Cortex-M4F): plain scalar
/// code over a slice of exactly the used blocks. The four node indices are
/// checked once, together; the indexing after the check compiles to no
/// check at all (the firmware's link-time proof fails if one remains). A
/// specialised copy of the product because it pays: [`product_block`] over
/// the portable backend with one lane costs about 45 instructions more per
/// tetrahedron and CG iteration on a Cortex-M4F, in lane bookkeeping this
/// loop does not need (QEMU, the firmware built without `fpu-product`).
///
/// With feature `fpu-product` on bare-metal Arm hard-float targets,
/// `crate::backend::fpu_product::product` takes its place (the same operations in
/// assembly, imported under this name above); the firmware's builds without
/// that feature run this one, with the same hash.
#[cfg(not(all(
    feature = "fpu-product",
    target_arch = "arm",
    target_os = "none",
    target_abi = "eabihf"
)))]
#[inline(always)]
fn product_one_by_one(per_young: [f32; 2], blocks: &[ElementBlock], work: &mut [NodeWork]) {
    for blk in blocks {
        let el = blk.get(0);
        let [a, b, c, d] = el.nodes.map(usize::from);
        let n = work.len();
        if a >= n || b >= n || c >= n || d >= n {
            continue;
        }
        let x = [work[a].d, work[b].d, work[c].d, work[d].d];
        let kd = hform::stiffness_product(&x, &el.grad, el.lame(per_young));
        work[a].q = add(work[a].q, share_of_a(&kd));
        work[b].q = add(work[b].q, kd[0]);
        work[c].q = add(work[c].q, kd[1]);
        work[d].q = add(work[d].q, kd[2]);
    }
}

/// [`stiffness`] compiled once in this crate with the baseline backend, for
/// the static solver and the diagnostics (generic `Scene<S>` methods that
/// would otherwise compile the product into every crate calling them).
#[cfg(any(feature = "statics", feature = "diagnostics"))]
pub(crate) fn stiffness_outside_step(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    work: &mut [NodeWork],
) {
    stiffness(crate::backend::BASELINE, per_young, elems, count, work);
}

/// The gradients of chunk `h` of a block, through the backend (which may
/// have them read from memory at each use: [`Backend::reread`]).
struct ChunkGrads<'a, B> {
    b: B,
    h: usize,
    grad: &'a [[Batch; 3]; 3],
}

impl<B: Backend> hform::Grads<B::Chunk> for ChunkGrads<'_, B> {
    #[inline(always)]
    fn at(&self, i: usize) -> [B::Chunk; 3] {
        let b = self.b;
        let Some(g) = b.reread(self.grad).get(i) else {
            return [B::Chunk::splat(0.0); 3];
        };
        [
            b.chunk(&g[0], self.h),
            b.chunk(&g[1], self.h),
            b.chunk(&g[2], self.h),
        ]
    }
}

/// [`stiffness`] for the lanes of one block at `c`, a chunk of lanes at a
/// time ([`Backend::Chunk`]).
#[inline(always)]
fn product_block<B: Backend>(
    b: B,
    per_young: [f32; 2],
    blk: &ElementBlock,
    c: &B::Corners<NodeWork>,
    work: &mut [NodeWork],
) {
    const {
        assert!(
            B::CHUNKS == 1 || B::CHUNKS == 2,
            "a block is one or two chunks"
        )
    };
    let lame = crate::material::lame(blk.stiffness, per_young);
    // Chunk by chunk, written out rather than looped, so that each chunk's
    // lanes are constants where its code is compiled.
    product_chunk(b, 0, lame, blk, c, work);
    if B::CHUNKS == 2 {
        product_chunk(b, 1, lame, blk, c, work);
    }
}

/// Chunk `h` of [`product_block`].
#[inline(always)]
fn product_chunk<B: Backend>(
    b: B,
    h: usize,
    lame: [Batch; 2],
    blk: &ElementBlock,
    c: &B::Corners<NodeWork>,
    work: &mut [NodeWork],
) {
    let mut x = [
        b.gather_chunk::<WorkD>(work, c, 0, h),
        b.gather_chunk::<WorkD>(work, c, 1, h),
        b.gather_chunk::<WorkD>(work, c, 2, h),
        b.gather_chunk::<WorkD>(work, c, 3, h),
    ];
    b.fence_chunk(&mut x);
    let grad = ChunkGrads {
        b,
        h,
        grad: &blk.grad,
    };
    let lame = [b.chunk(&lame[0], h), b.chunk(&lame[1], h)];
    let s = hform::product_stress(&x, &grad, lame);
    let kd = hform::product_forces(&s, &grad);
    let mut f = [share_of_a(&kd), kd[0], kd[1], kd[2]];
    b.fence_chunk(&mut f);
    b.scatter_chunk::<WorkQ>(work, c, h, &f);
}

/// Visits each of the first `count` elements with its node indices, its
/// world gradients `g_a … g_d` (`g_a = −(g_b + g_c + g_d)`) and its Lamé
/// coefficients `[λ', μ']`: for the passes that assemble parts of `K`
/// element by element, outside the step's hot loops.
#[cfg(any(feature = "statics", feature = "two-level"))]
pub(crate) fn each_element(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    mut f: impl FnMut([usize; 4], [Vec3; 4], [f32; 2]),
) {
    for e in 0..count {
        let Some(blk) = elems.get(e / LANES) else {
            break;
        };
        let el = blk.get(e % LANES);
        let g = el.grad;
        let ga = neg(add(add(g[0], g[1]), g[2]));
        f(
            el.nodes.map(usize::from),
            [ga, g[0], g[1], g[2]],
            el.lame(per_young),
        );
    }
}

/// Diagonal of the stiffness matrix of the first `count` elements, averaged
/// over the three components of each node, added into `diag`. For node `i`
/// with world gradient `g` the block diagonal is
/// `λ' g gᵀ + μ' (|g|² I + g gᵀ)`, whose trace is `(λ' + 2μ') |g|²`.
#[cfg(feature = "statics")]
pub(crate) fn stiffness_diagonal(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    mut add_to: impl FnMut(usize, f32),
) {
    each_element(per_young, elems, count, |ids, g, [l, m]| {
        let c = (l + 2.0 * m) * (1.0 / 3.0);
        for (id, gi) in ids.into_iter().zip(g) {
            add_to(id, c * crate::math::dot(gi, gi));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::{qr, Element};

    /// Twenty elements (two whole batches of eight and four left over) over
    /// a shared cloud of nodes, some of them crushed flat or to a point so
    /// that their lanes need the QR frame's fallbacks: for every method and
    /// every backend of the target, into the step's node work or through
    /// callbacks, the batched pass must give every node the bits of the
    /// element-by-element computation.
    #[test]
    fn batched_forces_are_the_bits_of_one_by_one() {
        for &method in Method::COMPILED {
            batched_against_one_by_one(method);
        }
    }

    fn batched_against_one_by_one(method: Method) {
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
        let rest_edges = [[1.0, 0.1, 0.0], [0.2, 0.9, 0.1], [0.1, 0.2, 1.1]];
        let rest_frame = qr::frame(rest_edges[0], rest_edges[1], rest_edges[2]);
        let mut elems = [Element::EMPTY; 20];
        for (e, el) in elems.iter_mut().enumerate() {
            let k = e as u16;
            el.nodes = match e {
                3 => [0, 10, 11, 5],  // a = b = c: collapsed edge and triangle
                9 => [0, 10, 4, 7],   // a = b: collapsed edge
                17 => [0, 11, 10, 0], // all four on one point
                _ => [k % 10, (k + 3) % 10, (k + 5) % 10, (k + 8) % 10],
            };
            el.rest = rest_frame.local;
            el.stiffness = 1.0e4 + 10.0 * e as f32;
            #[cfg(any(feature = "polar", feature = "linear"))]
            {
                // The world gradients of the rest shape.
                let (ab, ac, ad) = (rest_edges[0], rest_edges[1], rest_edges[2]);
                el.rest_grad = qr::forces::<true>(ab, ac, ad, &rest_frame.local, PER_YOUNG).grad;
            }
        }
        let alone = {
            let mut f = [[0.0f32; 3]; 12];
            let mut kv = [[0.0f32; 3]; 12];
            let mut els = elems;
            let totals = {
                // Element after element with each method's own kernel, twice
                // as in `batched_run`; the totals are the second pass's.
                let mut totals = PassTotals::default();
                for _ in 0..2 {
                    totals = PassTotals::default();
                    for el in els.iter_mut() {
                        let n = gather(&nodes, el.nodes).expect("in range");
                        let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
                        let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
                        let out = element::forces(method, el, PER_YOUNG, &rest, &du);
                        let vel = [n[0].v, n[1].v, n[2].v, n[3].v];
                        let k_v = hform::stiffness_product(&vel, &out.grad, el.lame(PER_YOUNG));
                        el.grad = out.grad;
                        totals.inverted += u32::from(out.inverted);
                        totals.energy += out.energy;
                        scatter(el.nodes, &out.f, |i, v| f[i] = add(f[i], v));
                        scatter(el.nodes, &k_v, |i, v| kv[i] = add(kv[i], v));
                    }
                }
                totals
            };
            (f, kv, els, totals.energy, totals.inverted)
        };
        let mut runs = std::vec![
            batched_run(Portable, method, &nodes, elems, false),
            batched_run(Portable, method, &nodes, elems, true),
        ];
        #[cfg(target_arch = "x86_64")]
        {
            runs.push(batched_run(
                crate::backend::Sse2,
                method,
                &nodes,
                elems,
                false,
            ));
            runs.push(batched_run(
                crate::backend::Sse2,
                method,
                &nodes,
                elems,
                true,
            ));
            if let Some(avx2) = crate::backend::Avx2::new() {
                runs.push(batched_run(avx2, method, &nodes, elems, true));
            }
        }
        for batched in runs {
            compare(&batched, &alone);
        }
    }

    /// What a force pass gave: forces and `−K v` per node, the elements
    /// after it, its energy and inverted count.
    type Outcome = ([Vec3; 12], [Vec3; 12], [Element; 20], f32, u32);

    /// Poisson ratio 0.3: λ/E = 0.3/(1.3·0.4), μ/E = 1/2.6.
    const PER_YOUNG: [f32; 2] = [0.576_923_1, 0.384_615_4];

    /// Two force passes over `elems` in blocks with the backend `b`, into
    /// the node work (`into_work`, the step's sink) or through callbacks,
    /// then the stiffness product by blocks checked against one element at
    /// a time, with the gradients just kept.
    fn batched_run<B: Backend>(
        b: B,
        method: Method,
        nodes: &[Node; 12],
        elems: [Element; 20],
        into_work: bool,
    ) -> Outcome {
        let mut f = [[0.0f32; 3]; 12];
        let mut kv = [[0.0f32; 3]; 12];
        let mut els = elems;
        // Three blocks of eight (on x86/AArch64): two whole, one with
        // four lanes used.
        let mut blocks = [ElementBlock::EMPTY; crate::element_blocks(20)];
        for (e, el) in els.iter().enumerate() {
            blocks[e / LANES].set(e % LANES, el);
        }
        // Two passes: the second starts from the rotations the first
        // kept, where most polar lanes take the regular path.
        let mut totals = PassTotals::default();
        let mut work = [NodeWork::EMPTY; 12];
        let vel = nodes.map(|n| n.v);
        for _ in 0..2 {
            for (w, v) in work.iter_mut().zip(vel) {
                w.d = v;
            }
            totals = if into_work {
                let sink = IntoWork(&mut work);
                forces::<B, true, true>(b, method, PER_YOUNG, nodes, &mut blocks, 20, sink)
            } else {
                let add_f = |i: usize, a: Vec3| f[i] = add(f[i], a);
                let add_kv = |i: usize, v: Vec3| kv[i] = add(kv[i], v);
                let sink = Each(add_f, add_kv, &vel);
                forces::<B, true, true>(b, method, PER_YOUNG, nodes, &mut blocks, 20, sink)
            };
        }
        if into_work {
            for (i, w) in work.iter().enumerate() {
                (f[i], kv[i]) = (w.r, w.q);
            }
        }
        for (e, el) in els.iter_mut().enumerate() {
            *el = blocks[e / LANES].get(e % LANES);
        }
        let mut work = [NodeWork::EMPTY; 12];
        let mut alone = [[0.0f32; 3]; 12];
        for (i, w) in work.iter_mut().enumerate() {
            let t = i as f32;
            w.d = [(1.7 * t).sin(), 0.2 * t, (0.3 * t).cos()];
        }
        stiffness(b, PER_YOUNG, &blocks, 20, &mut work);
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
        (f, kv, els, totals.energy, totals.inverted)
    }

    /// Every result of `batched` has the bits of `alone`'s.
    fn compare(batched: &Outcome, alone: &Outcome) {
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
