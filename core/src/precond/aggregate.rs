//! The aggregates of the two-level preconditioner: compact groups of free
//! nodes, seeded by recursive coordinate bisection of the rest positions and
//! grown over the mesh (Lloyd rounds), with their rest moments.

use super::*;

/// Rounds of seeding and growth (`grow`): each round moves every seed to
/// the node nearest its aggregate's centroid (Lloyd's algorithm, on the
/// mesh), which evens out the aggregates the first round leaves.
pub(super) const LLOYD_ROUNDS: usize = 3;

/// A new aggregate: not turned.
pub(super) const FRESH: Aggregate = Aggregate {
    rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    q_step: IDENTITY,
    q: IDENTITY,
    ..Aggregate::EMPTY
};

/// Splits the free nodes into at most `aggs.len()` aggregates: recursive
/// coordinate bisection of their rest positions (ties broken by node index,
/// so the result does not depend on the sort) places one seed per part,
/// and the seeds grow over the mesh into connected aggregates (`grow`).
/// Computes each one's rest centroid and second moment; returns the number
/// of aggregates used. Deterministic: only comparisons and sums in node
/// order.
pub(crate) fn aggregate(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    elems_count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    aggs: &mut [Aggregate],
) -> usize {
    let len = nodes.len().min(blocks.len());
    let blocks = blocks.get_mut(..len).unwrap_or_default();
    let mut free = 0usize;
    for (i, b) in blocks.iter_mut().enumerate() {
        b.aggregate = NONE;
        b.order = i as u32;
    }
    // Free nodes first, in node order: swapping the order fields of slots
    // `free` and `i` (slot `i` still holds order `i` when it is reached).
    for (i, n) in nodes.iter().enumerate().take(len) {
        if n.flags & FIXED == 0 {
            let displaced = blocks.get(free).map_or(0, |b| b.order);
            if let Some(b) = blocks.get_mut(free) {
                b.order = i as u32;
            }
            if let Some(b) = blocks.get_mut(i) {
                b.order = displaced;
            }
            free += 1;
        }
    }
    // The swaps above keep free nodes in node order but scramble the rest;
    // only the free part matters.
    let count = aggregates_for(free, aggs.len());
    if free == 0 || count == 0 {
        return 0;
    }
    bisect(nodes, blocks.get_mut(..free).unwrap_or_default(), 0, count);
    // Back to node order: the order fields are a permutation.
    heap_sort(blocks, |a, b| a.order < b.order);
    let aggs = &mut aggs[..count];
    for a in aggs.iter_mut() {
        *a = FRESH;
    }
    moments(nodes, blocks, aggs);
    for _ in 0..LLOYD_ROUNDS {
        grow(per_young, elems, elems_count, nodes, blocks, aggs);
        moments(nodes, blocks, aggs);
    }
    count
}

/// Each aggregate's mass-weighted rest centroid `c₀` and second moment
/// `S₀ = Σ m (x₀ − c₀)(x₀ − c₀)ᵀ`, summed in node order.
pub(super) fn moments(nodes: &[Node], blocks: &[NodeBlock], aggs: &mut [Aggregate]) {
    // The mass is summed in `s0[0][0]` until the division.
    for a in aggs.iter_mut() {
        a.c0 = [0.0; 3];
        a.s0 = [[0.0; 3]; 3];
    }
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            a.c0 = add(a.c0, n.x0.map(|x| x * n.mass));
            a.s0[0][0] += n.mass;
        }
    }
    for a in aggs.iter_mut() {
        let m = a.s0[0][0];
        a.c0 = if m > 0.0 {
            a.c0.map(|x| x / m)
        } else {
            [0.0; 3]
        };
        a.s0 = [[0.0; 3]; 3];
    }
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            let p = sub(n.x0, a.c0);
            for (row, pk) in a.s0.iter_mut().zip(p) {
                for (s, pj) in row.iter_mut().zip(p) {
                    *s += n.mass * pk * pj;
                }
            }
        }
    }
}

/// Makes every aggregate connected: keeps, of each part the bisection cut,
/// only the node nearest its centroid (the first in node order among equals)
/// as a seed, then grows the seeds over the mesh, one ring of elements per
/// round, each free node joining the lowest-numbered aggregate among its
/// labelled neighbours. A part of a non-convex body (two ears) is not one
/// rigid piece, and a coarse mode that moves both as one serves neither.
/// Free nodes no seed reaches (another piece of mesh, joined only through
/// fixed nodes) join the nearest seed. Deterministic: comparisons, and
/// minima that do not depend on the order of the elements.
pub(super) fn grow(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    aggs: &mut [Aggregate],
) {
    // Scratch: `apq[0][0]` the nearest squared distance to the centroid,
    // `apq[1]` the seed's position (both rebuilt every step by `rotations`).
    for a in aggs.iter_mut() {
        a.apq[0][0] = f32::INFINITY;
    }
    let dist = |n: &Node, c: Vec3| dot(sub(n.x0, c), sub(n.x0, c));
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            a.apq[0][0] = a.apq[0][0].min(dist(n, a.c0));
        }
    }
    for (n, b) in nodes.iter().zip(blocks.iter_mut()) {
        b.order = NONE;
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            if dist(n, a.c0) == a.apq[0][0] {
                b.order = b.aggregate;
                a.apq[1] = n.x0;
                // No distance is below zero: no other seed.
                a.apq[0][0] = -1.0;
            }
        }
    }
    let free = |i: usize| nodes.get(i).is_some_and(|n| n.flags & FIXED == 0);
    // Rounds: each labels at least one node, or is the last.
    for _ in 0..blocks.len() {
        for b in blocks.iter_mut() {
            b.aggregate = b.order;
        }
        each_element(per_young, elems, count, |ids, _, _| {
            for i in ids {
                if !free(i) || blocks.get(i).is_none_or(|b| b.aggregate != NONE) {
                    continue;
                }
                let Some(x) = nodes.get(i) else { continue };
                // The nearest seed among the labelled neighbours (then the
                // lowest label): ties of ring counts are common, and the
                // lowest label alone would starve the higher ones.
                let key = |label: u32| {
                    aggs.get(label as usize)
                        .map_or((f32::INFINITY, label), |a| (dist(x, a.apq[1]), label))
                };
                for j in ids {
                    let label = blocks.get(j).map_or(NONE, |b| b.aggregate);
                    if let Some(b) = blocks.get_mut(i) {
                        let (new, old) = (key(label), key(b.order));
                        if new.0 < old.0 || (new.0 == old.0 && new.1 < old.1) {
                            b.order = label;
                        }
                    }
                }
            }
        });
        if blocks.iter().all(|b| b.order == b.aggregate) {
            break;
        }
    }
    for (i, (n, b)) in nodes.iter().zip(blocks.iter_mut()).enumerate() {
        if b.aggregate == NONE && free(i) {
            let mut best = (f32::INFINITY, 0);
            for (k, a) in aggs.iter().enumerate() {
                let d = dist(n, a.apq[1]);
                if d < best.0 {
                    best = (d, k);
                }
            }
            b.aggregate = best.1 as u32;
        }
        b.order = i as u32;
    }
}

/// Assigns aggregates `first .. first + parts` to `slots` (whose `order`
/// fields name nodes): splits at the median of the longest axis of their
/// bounding box, in proportion to the parts on each side.
pub(super) fn bisect(nodes: &[Node], slots: &mut [NodeBlock], first: usize, parts: usize) {
    if parts <= 1 || slots.len() <= 1 {
        for s in slots.iter_mut() {
            s.aggregate = first as u32;
        }
        return;
    }
    let pos = |s: &NodeBlock| nodes.get(s.order as usize).map_or([0.0; 3], |n| n.x0);
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for s in slots.iter() {
        let p = pos(s);
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = sub(hi, lo);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let left = parts / 2;
    let mid = slots.len() * left / parts;
    // In 1 ..= len − 1 (len ≥ 2 here), written out: `clamp` asserts its
    // bounds, a panicking branch.
    let last = slots.len().saturating_sub(1);
    let mid = if mid < 1 {
        1
    } else if mid > last {
        last
    } else {
        mid
    };
    // The `mid` first slots in the order of the axis (ties by node index: a
    // total order, so the two sides are the same sets whatever the
    // algorithm). A full sort where a selection would do: it runs once per
    // preparation, and core's selection keeps panicking branches that a
    // firmware build must not link.
    let coord = |s: &NodeBlock| match (axis, pos(s)) {
        (0, [x, _, _]) => x,
        (1, [_, y, _]) => y,
        (_, [_, _, z]) => z,
    };
    heap_sort(slots, |a, b| {
        coord(a)
            .total_cmp(&coord(b))
            .then(a.order.cmp(&b.order))
            .is_lt()
    });
    let Some((l, r)) = slots.split_at_mut_checked(mid) else {
        return;
    };
    bisect(nodes, l, first, left);
    bisect(nodes, r, first + left, parts - left);
}

/// Sorts `s` by `less` (a strict order): heapsort, in place, `O(n log n)`,
/// every index checked by the loop conditions, so that no panicking branch
/// remains.
pub(super) fn heap_sort(s: &mut [NodeBlock], less: impl Fn(&NodeBlock, &NodeBlock) -> bool) {
    // Moves `s[root]` down the heap of the first `end` slots.
    let sift = |s: &mut [NodeBlock], mut root: usize, end: usize| {
        let end = end.min(s.len());
        loop {
            let mut child = 2 * root + 1;
            if child >= end {
                break;
            }
            if let (Some(a), Some(b)) = (s.get(child), s.get(child + 1)) {
                if child + 1 < end && less(a, b) {
                    child += 1;
                }
            }
            match (s.get(root), s.get(child)) {
                (Some(r), Some(c)) if less(r, c) => {}
                _ => break,
            }
            if root < s.len() && child < s.len() {
                s.swap(root, child);
            }
            root = child;
        }
    };
    let n = s.len();
    for start in (0..n / 2).rev() {
        sift(s, start, n);
    }
    for end in (1..n).rev() {
        if end < s.len() {
            s.swap(0, end);
        }
        sift(s, 0, end);
    }
}
