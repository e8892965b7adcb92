//! Element passes: gather the four nodes of each element, do the local maths,
//! scatter-add the results into the nodes — in element order, so the sums are
//! the same on every target. (Element order, here and in `crate::rows`, is
//! the order of the storage slots, an interleaving of the scene's elements
//! that every target shares: `element::block::slot`.)

#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
use crate::element::qr;
use crate::element::{self, hform, lane3, Batch, ElementBlock, ElementForces, Method};
use crate::lanes::LANES;
use crate::math::Real;
use crate::math::{add, neg, sub, Vec3};
#[cfg(target_arch = "x86_64")]
use crate::rows::{Avx2, Moves, Sse2};
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
/// element in element order.
pub(crate) trait Sink {
    /// Adds node `i`'s elastic force `f` (N).
    fn add_force(&mut self, i: usize, f: Vec3);
    /// Adds node `i`'s stiffness product `kv` (`−K v`, N).
    fn add_kv(&mut self, i: usize, kv: Vec3);
    /// The node work, if this sink is [`IntoWork`] (which the x86_64 passes
    /// then write directly as rows, with the same sums).
    #[cfg(target_arch = "x86_64")]
    fn work(&mut self) -> Option<&mut [NodeWork]>;
}

/// The step's sink: `r += f`, `q += kv` of each node.
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
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn work(&mut self) -> Option<&mut [NodeWork]> {
        Some(self.0)
    }
}

/// Any other sink: functions `add_force(i, f)` and `add_kv(i, kv)`.
#[cfg(any(feature = "statics", feature = "diagnostics", test))]
pub(crate) struct Each<F, K>(pub(crate) F, pub(crate) K);

#[cfg(any(feature = "statics", feature = "diagnostics", test))]
impl<F: FnMut(usize, Vec3), K: FnMut(usize, Vec3)> Sink for Each<F, K> {
    #[inline(always)]
    fn add_force(&mut self, i: usize, f: Vec3) {
        (self.0)(i, f);
    }
    #[inline(always)]
    fn add_kv(&mut self, i: usize, kv: Vec3) {
        (self.1)(i, kv);
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn work(&mut self) -> Option<&mut [NodeWork]> {
        None
    }
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

/// Visits the slot of every corner `k` of every lane `j < lanes` of a
/// block, `put(k, j, slot)`, and returns which lanes are present: used, with
/// every node index in range (ruled out by `build`; an absent lane is
/// computed and neither finished nor scattered). Corner by corner, so that a
/// corner's lanes are filled one after the other.
#[inline(always)]
fn gather_corners<T>(
    slots: &[T],
    blk: &ElementBlock,
    lanes: usize,
    mut put: impl FnMut(usize, usize, &T),
) -> [bool; LANES] {
    // Compared lane by lane (written as a loop setting the first `lanes`
    // flags, it was a call to `memset` per block).
    let mut present: [bool; LANES] = core::array::from_fn(|j| j < lanes);
    for (k, ids) in blk.nodes.iter().enumerate() {
        for (j, (id, p)) in ids.iter().zip(present.iter_mut()).enumerate().take(lanes) {
            match slots.get(usize::from(*id)) {
                Some(slot) => put(k, j, slot),
                None => *p = false,
            }
        }
    }
    present
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
/// `sink` receives each contribution, element after element, in element
/// order, whether or not elements are batched. `per_young` is the body's
/// [`lame_per_young`](crate::material::lame_per_young). On x86_64, whole
/// blocks move node vectors as rows (`crate::rows`), with AVX2 if `AVX2`,
/// else with SSE2; same bits.
#[inline(always)]
pub(crate) fn forces<const WITH_KV: bool, const COMMIT: bool, const AVX2: bool>(
    method: Method,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &mut [ElementBlock],
    count: usize,
    sink: impl Sink,
) -> PassTotals {
    let mut pass = ForcePass::<_, AVX2> {
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
/// keep their new gradients) and the diagnostics (elements untouched): not
/// generic, so compiled once in this crate rather than in every crate that
/// calls a generic `Scene<S>` method using it; the contributions go through
/// a `dyn` callback (this pass is not in the step).
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
    let sink = Each(add_to, |_, _| {});
    if commit {
        forces::<false, true, false>(method, per_young, nodes, elems, count, sink)
    } else {
        forces::<false, false, false>(method, per_young, nodes, elems, count, sink)
    }
}

/// What every block of a force pass shares (`AVX2` as in [`forces`]).
struct ForcePass<'a, S, const AVX2: bool> {
    method: Method,
    /// The body's [`lame_per_young`](crate::material::lame_per_young).
    per_young: [f32; 2],
    nodes: &'a [Node],
    /// Where the contributions go, see [`forces`].
    sink: S,
    totals: PassTotals,
}

/// A force kernel run on every lane of a block at once.
trait LaneKernel {
    /// The method the kernel computes: a lane it marks irregular is redone
    /// by this method's one-element kernel alone. (With the block's runtime
    /// method instead, every batched pass carried all four one-element
    /// kernels, and the build with every method took LLVM over ten minutes
    /// on a 2.4 GHz core.)
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
struct Edges {
    #[cfg(feature = "polar")]
    rest: [[Batch; 3]; 3],
    #[cfg(feature = "linear")]
    du: [[Batch; 3]; 3],
    cur: [[Batch; 3]; 3],
}

/// What a [`LaneKernel`] returns.
struct LaneForces {
    /// Forces, gradients and energy of every lane.
    k: element::Kernel<Batch>,
    /// A value with the sign of each lane's current volume; only the sign is
    /// used (QR's local `zd` in m, `6V` in m³ for the others).
    volume: Batch,
    /// Lanes whose result stands; the others are redone alone by
    /// [`element::forces`] (the QR frame's fallbacks, the polar rotation
    /// search's irregular paths).
    regular: [bool; LANES],
    /// The new rotations, if [`LaneKernel::ROTATES`].
    #[cfg(feature = "polar")]
    rot: [Batch; 4],
}

/// The QR kernel in lanes (`CURRENT_B` as in [`qr::forces`]).
#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
struct QrLanes<const CURRENT_B: bool>;

#[cfg(any(feature = "qr", feature = "qr-rest-b"))]
impl<const CURRENT_B: bool> LaneKernel for QrLanes<CURRENT_B> {
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

/// The linear kernel in lanes.
#[cfg(feature = "linear")]
struct LinearLanes;

#[cfg(feature = "linear")]
impl LaneKernel for LinearLanes {
    const METHOD: Method = Method::Linear;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let cur = &edges.cur;
        LaneForces {
            k: element::linear::kernel(&edges.du, &blk.rest_grad, lame),
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
struct PolarLanes;

#[cfg(feature = "polar")]
impl LaneKernel for PolarLanes {
    const METHOD: Method = Method::Polar;
    const ROTATES: bool = true;
    #[inline(always)]
    fn run(edges: &Edges, blk: &ElementBlock, lame: [Batch; 2]) -> LaneForces {
        let cur = &edges.cur;
        let f = hform::grad_h(cur, &blk.rest_grad);
        let rot = element::polar::closest_rotation_lanes(&f, blk.rot);
        LaneForces {
            k: element::polar::kernel(&rot.r, &rot.m, &edges.rest, &blk.rest_grad, lame),
            volume: crate::math::det3(cur[0], cur[1], cur[2]),
            regular: rot.regular,
            rot: rot.q,
        }
    }
}

// Methods: functions rather than closures, inlined at each call, or a host
// that compiles the step for another instruction set would run them compiled
// for the baseline.
impl<S: Sink, const AVX2: bool> ForcePass<'_, S, AVX2> {
    /// The first `lanes` elements of a block, batched where the target
    /// allows it.
    #[inline(always)]
    fn block<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) {
        match self.method {
            #[cfg(feature = "qr")]
            Method::Qr if LANES > 1 => self.lanes::<QrLanes<true>, WITH_KV, COMMIT>(blk, lanes),
            #[cfg(feature = "qr-rest-b")]
            Method::QrRestB if LANES > 1 => {
                self.lanes::<QrLanes<false>, WITH_KV, COMMIT>(blk, lanes);
            }
            #[cfg(feature = "linear")]
            Method::Linear if LANES > 1 => {
                self.lanes::<LinearLanes, WITH_KV, COMMIT>(blk, lanes);
            }
            #[cfg(feature = "polar")]
            Method::Polar if LANES > 1 => {
                self.lanes::<PolarLanes, WITH_KV, COMMIT>(blk, lanes);
            }
            _ => self.one_by_one::<WITH_KV, COMMIT>(blk, lanes),
        }
    }

    /// [`Self::batched`] out of line, one function per kernel: compiled for
    /// AVX2 with `AVX2`, for the baseline otherwise. Inlining every method's
    /// batched pass into the step made one huge function that took LLVM
    /// minutes to compile (over eight with every feature, on a 2.4 GHz
    /// core; one minute now).
    #[inline(always)]
    fn lanes<K: LaneKernel, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            #[allow(unsafe_code)]
            // SAFETY: `AVX2` is true only in `step::step_avx2`, whose callers
            // promise a CPU with AVX2.
            unsafe {
                batched_avx2::<S, K, AVX2, WITH_KV, COMMIT>(self, blk, lanes);
            }
            return;
        }
        batched_baseline::<S, K, AVX2, WITH_KV, COMMIT>(self, blk, lanes);
    }

    /// The first `lanes` elements of a block, one at a time (every method;
    /// all of them on targets with one lane).
    #[inline(always)]
    fn one_by_one<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) {
        let nodes = self.nodes;
        for j in 0..lanes {
            let Some(n) = gather(nodes, blk.nodes(j)) else {
                continue;
            };
            let rest = diffs(&[n[0].x0, n[1].x0, n[2].x0, n[3].x0]);
            let du = diffs(&[n[0].u, n[1].u, n[2].u, n[3].u]);
            let vel = || [n[0].v, n[1].v, n[2].v, n[3].v];
            self.one::<WITH_KV, COMMIT>(self.method, blk, j, &rest, &du, vel);
        }
    }

    /// Element `j` of a block alone with `method`, from its rest edges, displacement
    /// differences and node velocities (`vel`, called only with `WITH_KV`,
    /// once the forces are out: loaded where they are used, they are not
    /// kept in registers through the force kernel).
    #[inline(always)]
    fn one<const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        method: Method,
        blk: &mut ElementBlock,
        j: usize,
        rest: &[Vec3; 3],
        du: &[Vec3; 3],
        vel: impl FnOnce() -> [Vec3; 4],
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
            let kv = hform::stiffness_product(&vel(), &out.grad, el.lame(self.per_young));
            self.emit_kv(el.nodes, &kv);
        }
        if COMMIT {
            blk.set_state(j, &el);
        }
    }

    /// The first `lanes` elements of a block, all at once with kernel `K`.
    ///
    /// Gathers the elements' edges (and velocities) into lanes, runs the
    /// kernel on every lane with the block's own data, then finishes the
    /// elements in order exactly as the one-by-one path does. Lanes are
    /// independent and see the same operations, so the bits are those of the
    /// one-by-one path. A lane the kernel marks irregular is redone alone;
    /// unused lanes are computed and ignored.
    #[inline(always)]
    fn batched<K: LaneKernel, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) {
        let zero = Batch::splat(0.0);
        // Rest positions, displacements (and velocities) in lanes.
        let mut x0 = [[zero; 3]; 4];
        let mut u = [[zero; 3]; 4];
        let mut vel = [[zero; 3]; 4];
        let present = gather_corners(
            self.nodes,
            blk,
            lanes,
            #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
            |k, j, n: &Node| {
                if let (Some(x0), Some(u)) = (x0.get_mut(k), u.get_mut(k)) {
                    Batch::put(x0, j, n.x0);
                    Batch::put(u, j, n.u);
                }
                if let (true, Some(v)) = (WITH_KV, vel.get_mut(k)) {
                    Batch::put(v, j, n.v);
                }
            },
        );
        // The same operations as one element at a time, on every lane.
        let rest = diffs(&x0);
        let du = diffs(&u);
        let cur = element::current_edges(&rest, &du);
        let lame = crate::material::lame(blk.stiffness, self.per_young);
        let edges = Edges {
            #[cfg(feature = "polar")]
            rest,
            #[cfg(feature = "linear")]
            du,
            cur,
        };
        let out = K::run(&edges, blk, lame);
        let kv = if WITH_KV {
            hform::stiffness_product(&vel, &out.k.grad, lame)
        } else {
            [[zero; 3]; 3]
        };
        // Finish in element order.
        for j in 0..lanes {
            if !present.get(j).copied().unwrap_or(false) {
                continue;
            }
            if !out.regular.get(j).copied().unwrap_or(false) {
                // The lane's edges again, from its nodes: the same
                // subtractions, so the same bits, and the block's edges need
                // not be kept in memory for the rare lane that needs them.
                let corners = |x: &[[Batch; 3]; 4]| {
                    let l = |k: usize| Batch::lane(&x[k], j);
                    [l(0), l(1), l(2), l(3)]
                };
                let (rest, du) = (diffs(&corners(&x0)), diffs(&corners(&u)));
                self.one::<WITH_KV, COMMIT>(K::METHOD, blk, j, &rest, &du, || corners(&vel));
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

    /// A whole block whose lanes all take the kernel's regular path, written
    /// into the step's node work ([`IntoWork`]) with the row moves `M`
    /// (`crate::rows`): the same operations as [`Self::batched`] and the node
    /// sums of its per-lane finish, in their order. Returns whether it did;
    /// if not (another sink, a node index out of range, an irregular lane),
    /// it has changed nothing, and [`Self::batched`] does the block.
    ///
    /// The edges are formed corner by corner as the nodes are gathered and
    /// the velocities gathered after the kernel, so that only the current
    /// edges are live through it: gathering the rest positions,
    /// displacements and velocities of all four corners first kept 36
    /// vectors live, and the pass was bound by its stores to the stack.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn fast_block<M: Moves, K: LaneKernel, const WITH_KV: bool, const COMMIT: bool>(
        &mut self,
        blk: &mut ElementBlock,
        lanes: usize,
    ) -> bool {
        if lanes != LANES {
            return false;
        }
        let nodes = self.nodes;
        let Some(work) = self.sink.work() else {
            return false;
        };
        #[allow(unsafe_code)]
        // SAFETY: the callers of `fast_block::<M>` run on CPUs with `M`'s
        // instruction set.
        let Some((at, [_rest, _du, cur])) =
            (unsafe { crate::rows::gather_edges::<M>(nodes, &blk.nodes) })
        else {
            return false;
        };
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
        if !out.regular.iter().all(|&r| r) {
            return false;
        }
        #[allow(unsafe_code)]
        // SAFETY: as above.
        let done = unsafe {
            crate::rows::scatter_forces::<M, WITH_KV>(
                work,
                nodes,
                &at,
                &blk.nodes,
                &out.k.f,
                &out.k.grad,
                lame,
            )
        };
        if !done {
            return false;
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
        true
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

/// [`ForcePass::batched`] compiled for AVX2, out of line (see
/// [`ForcePass::lanes`]). The caller must run on a CPU with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn batched_avx2<
    S: Sink,
    K: LaneKernel,
    const AVX2: bool,
    const WITH_KV: bool,
    const COMMIT: bool,
>(
    pass: &mut ForcePass<'_, S, AVX2>,
    blk: &mut ElementBlock,
    lanes: usize,
) {
    if !pass.fast_block::<Avx2, K, WITH_KV, COMMIT>(blk, lanes) {
        pass.batched::<K, WITH_KV, COMMIT>(blk, lanes);
    }
}

/// [`ForcePass::batched`] out of line, one function per kernel, for the
/// baseline instruction set (on x86_64, whole blocks with the SSE2 row moves
/// first, as `batched_avx2` does with AVX2). Inlined into the step, the
/// four methods' batched passes made one function so large that LLVM's loop
/// passes took minutes over it; one call per block of eight elements costs
/// nothing measurable.
#[inline(never)]
fn batched_baseline<
    S: Sink,
    K: LaneKernel,
    const AVX2: bool,
    const WITH_KV: bool,
    const COMMIT: bool,
>(
    pass: &mut ForcePass<'_, S, AVX2>,
    blk: &mut ElementBlock,
    lanes: usize,
) {
    #[cfg(target_arch = "x86_64")]
    if pass.fast_block::<Sse2, K, WITH_KV, COMMIT>(blk, lanes) {
        return;
    }
    pass.batched::<K, WITH_KV, COMMIT>(blk, lanes);
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
pub(crate) fn stiffness<const AVX2: bool>(
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
        product_block::<AVX2>(per_young, blk, LANES, work);
    }
    if tail > 0 {
        if let Some(blk) = elems.get(whole) {
            product_block::<AVX2>(per_young, blk, tail, work);
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
use crate::fpu_product::product as product_one_by_one;

/// [`stiffness`] with one element per block (a Cortex-M4F): plain scalar
/// code over a slice of exactly the used blocks. The four node indices are
/// checked once, together; the indexing after the check compiles to no
/// check at all (the firmware's link-time proof fails if one remains). The
/// lane bookkeeping of [`product_block`] measured 19 instructions more per
/// element there, and a per-index `get` 3 more.
///
/// With feature `fpu-product` on bare-metal Arm hard-float targets,
/// `crate::fpu_product::product` takes its place (the same operations in
/// assembly, imported under this name below); the firmware's builds without
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

/// [`stiffness`] compiled once in this crate, for the static solver and the
/// diagnostics (generic `Scene<S>` methods that would otherwise compile the
/// product into every crate calling them).
#[cfg(any(feature = "statics", feature = "diagnostics"))]
pub(crate) fn stiffness_outside_step(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    work: &mut [NodeWork],
) {
    stiffness::<false>(per_young, elems, count, work);
}

/// [`stiffness`] for the first `lanes` elements of one block; on x86_64,
/// whole blocks move their node vectors as rows (`crate::rows`), with AVX2
/// if `AVX2`, else with SSE2; same bits.
#[inline(always)]
fn product_block<const AVX2: bool>(
    per_young: [f32; 2],
    blk: &ElementBlock,
    lanes: usize,
    work: &mut [NodeWork],
) {
    #[cfg(target_arch = "x86_64")]
    if lanes == LANES {
        #[allow(unsafe_code)]
        // SAFETY: `AVX2` is true only in `step::step_avx2`, whose callers
        // promise a CPU with AVX2; every x86_64 CPU has SSE2.
        let done = unsafe {
            if AVX2 {
                crate::rows::product_block_avx2(per_young, blk, work)
            } else {
                crate::rows::product_block_sse2(per_young, blk, work)
            }
        };
        if done {
            return;
        }
    }
    // `d` in lanes.
    let mut x = [[Batch::splat(0.0); 3]; 4];
    let present = gather_corners(
        work,
        blk,
        lanes,
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        |k, j, w: &NodeWork| {
            if let Some(xk) = x.get_mut(k) {
                Batch::put(xk, j, w.d);
            }
        },
    );
    let lame = crate::material::lame(blk.stiffness, per_young);
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
    use crate::element::{qr, Element};

    /// Twenty elements (two whole batches of eight and four left over) over
    /// a shared cloud of nodes, some of them crushed flat or to a point so
    /// that their lanes need the QR frame's fallbacks: for every method, the
    /// batched pass must give every node the bits of the element-by-element
    /// computation.
    #[test]
    fn batched_forces_are_the_bits_of_one_by_one() {
        for &method in Method::COMPILED {
            batched_against_one_by_one(method);
        }
    }

    fn batched_against_one_by_one(method: Method) {
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
        let run = |batched: bool| {
            let mut f = [[0.0f32; 3]; 12];
            let mut kv = [[0.0f32; 3]; 12];
            let mut els = elems;
            let totals = if batched {
                let add_f = |i: usize, a: Vec3| f[i] = add(f[i], a);
                let add_kv = |i: usize, b: Vec3| kv[i] = add(kv[i], b);
                // Three blocks of eight (on x86/AArch64): two whole, one with
                // four lanes used.
                let mut blocks = [ElementBlock::EMPTY; crate::element_blocks(20)];
                for (e, el) in els.iter().enumerate() {
                    blocks[e / LANES].set(e % LANES, el);
                }
                // Two passes: the second starts from the rotations the first
                // kept, where most polar lanes take the regular path.
                let (mut add_f, mut add_kv) = (add_f, add_kv);
                let sink = Each(&mut add_f, &mut add_kv);
                forces::<true, true, false>(method, PER_YOUNG, &nodes, &mut blocks, 20, sink);
                let sink = Each(add_f, add_kv);
                let totals =
                    forces::<true, true, false>(method, PER_YOUNG, &nodes, &mut blocks, 20, sink);
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
                stiffness::<false>(PER_YOUNG, &blocks, 20, &mut work);
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
                // Element after element with each method's own kernel, twice
                // as above; the totals are the second pass's.
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
