//! The coarse space of the two-level preconditioner: the Galerkin operator
//! `Φᵀ A Φ` of the aggregates' rigid modes, inverted once (Cholesky, the
//! inverse of the factor, its Gram matrix), and its product per solve, in
//! blocks of eight entries.

use super::*;

/// Adds `Σ_k a_k b_k` over whole blocks into eight partial sums, one per
/// lane, each summed in block order: the same operations on every target,
/// which a vector unit runs side by side.
#[inline(always)]
pub(super) fn lanes_dot(acc: &mut [f32; CHUNK], a: &[CoarseBlock], b: &[CoarseBlock]) {
    for (x, y) in a.iter().zip(b) {
        // Indices, not zipped lanes: the form LLVM is surest to keep in
        // whole vector registers.
        #[allow(clippy::needless_range_loop)]
        for l in 0..CHUNK {
            acc[l] += x.m[l] * y.m[l];
        }
    }
}

/// The sum of the partial sums, lane after lane. (A tree of pairs would be
/// shorter, but LLVM then splits the sums of `lanes_dot` into pairs.)
#[inline(always)]
pub(super) fn lanes_sum(a: [f32; CHUNK]) -> f32 {
    a.iter().fold(0.0, |s, x| s + x)
}

/// `z += s x` over whole blocks (lanes independent).
#[inline(always)]
pub(super) fn axpy_blocks(z: &mut [CoarseBlock], s: f32, x: &[CoarseBlock]) {
    for (zb, xb) in z.iter_mut().zip(x) {
        #[allow(clippy::needless_range_loop)] // as in `lanes_dot`
        for l in 0..CHUNK {
            zb.m[l] += s * xb.m[l];
        }
    }
}

/// Row `r` of a matrix of rows of `stride` blocks.
#[inline(always)]
pub(super) fn row(mat: &[CoarseBlock], stride: usize, r: usize) -> &[CoarseBlock] {
    let start = r.saturating_mul(stride);
    mat.get(start..start.saturating_add(stride))
        .unwrap_or_default()
}

/// Row `r` of a matrix of rows of `stride` blocks, to write.
#[inline(always)]
pub(super) fn row_mut(mat: &mut [CoarseBlock], stride: usize, r: usize) -> &mut [CoarseBlock] {
    let start = r.saturating_mul(stride);
    mat.get_mut(start..start.saturating_add(stride))
        .unwrap_or_default()
}

/// The blocks of a row up to and including column `c`.
#[inline(always)]
pub(super) fn upto(row: &[CoarseBlock], c: usize) -> &[CoarseBlock] {
    row.get(..c / CHUNK + 1).unwrap_or(row)
}

/// Entry `k` of a row of blocks (0 past its end).
#[inline(always)]
pub(super) fn get(v: &[CoarseBlock], k: usize) -> f32 {
    v.get(k / CHUNK)
        .and_then(|b| b.m.get(k % CHUNK))
        .copied()
        .unwrap_or(0.0)
}

/// Entry `k` of a row of blocks, to write.
#[inline(always)]
pub(super) fn get_mut(v: &mut [CoarseBlock], k: usize) -> Option<&mut f32> {
    v.get_mut(k / CHUNK)?.m.get_mut(k % CHUNK)
}

/// `y ← A_c⁻¹ y = Σ_j y_j S_j` with the rows `S_j` of the inverse
/// (`factor`), into the vector after the matrix, then back: updates whose
/// lanes are independent, six rows (an aggregate's) per pass over the
/// vector, each lane summed in row order. (Triangular solves with the
/// Cholesky factor do as much arithmetic, but each unknown waits for the
/// ones before it.)
#[inline(always)]
pub(super) fn coarse_solve(aggs: &mut [Aggregate], coarse: &mut [CoarseBlock]) {
    let dim = aggs.len() * 6;
    let st = stride(dim);
    let Some((mat, rest)) = coarse.split_at_mut_checked(dim * st) else {
        return;
    };
    let z = rest.get_mut(..st).unwrap_or_default();
    for b in z.iter_mut() {
        *b = CoarseBlock::EMPTY;
    }
    // The rows zipped with the vector's blocks: no bounds check in the
    // inner loop.
    let mut rows = mat
        .chunks_exact(st.max(1))
        .zip(aggs.iter().flat_map(|a| a.y));
    loop {
        let mut next = || rows.next();
        let (Some((r0, y0)), Some((r1, y1)), Some((r2, y2))) = (next(), next(), next()) else {
            break;
        };
        let (Some((r3, y3)), Some((r4, y4)), Some((r5, y5))) = (next(), next(), next()) else {
            break;
        };
        let lanes = z.iter_mut().zip(r0).zip(r1).zip(r2).zip(r3).zip(r4).zip(r5);
        for ((((((zb, x0), x1), x2), x3), x4), x5) in lanes {
            let mut acc = zb.m;
            #[allow(clippy::needless_range_loop)] // as in `lanes_dot`
            for l in 0..CHUNK {
                acc[l] += y0 * x0.m[l];
                acc[l] += y1 * x1.m[l];
                acc[l] += y2 * x2.m[l];
                acc[l] += y3 * x3.m[l];
                acc[l] += y4 * x4.m[l];
                acc[l] += y5 * x5.m[l];
            }
            zb.m = acc;
        }
    }
    for (k, a) in aggs.iter_mut().enumerate() {
        for (r, y) in a.y.iter_mut().enumerate() {
            *y = get(z, 6 * k + r);
        }
    }
}

/// Prepares the two-level preconditioner at the current state: turns every
/// node block (`node_blocks`, world frame) into its aggregate's frame,
/// `D_local = R_aᵀ D R_a`, then assembles the Galerkin coarse operator
/// `Φᵀ A Φ` with the aggregates' rotations and the elements' gradients, and
/// inverts it in place: `A_c = L Lᵀ` (`cholesky`), `W = L⁻¹` (`invert`),
/// `A_c⁻¹ = Wᵀ W` (`gram`), each `O(dim³)` at `dim = 6 n`. An unknown whose
/// pivot falls to round-off of its diagonal (the rotations of an aggregate
/// of one node, or of nodes on a line) is dropped: its row and column of
/// the inverse are zero.
pub(crate) fn factor(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    p: &mut Parts<'_>,
    mass_coef: f32,
    k_coef: f32,
) {
    let n = p.aggs.len();
    let Some(coarse) = p.coarse.get_mut(..coarse_blocks_for(n)) else {
        return;
    };
    for b in coarse.iter_mut() {
        *b = CoarseBlock::EMPTY;
    }
    let dim = 6 * n;
    let st = stride(dim);
    let aggs = &*p.aggs;
    for b in p.blocks.iter_mut() {
        if let Some(a) = aggs.get(b.aggregate as usize) {
            // D⁻¹ turns like D: (Rᵀ D R)⁻¹ = Rᵀ D⁻¹ R.
            let [xx, yy, zz, xy, yz, zx] = b.inv;
            let d = [[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]];
            let l = mat_mul(&transpose(&a.rot), &mat_mul(&d, &a.rot));
            b.inv = [l[0][0], l[1][1], l[2][2], l[0][1], l[1][2], l[2][0]];
        }
    }
    let blocks = &*p.blocks;
    // Node i's modes: Φᵢ = R [I, −[pᵢ]×].
    let frame = |i: usize| -> Option<(usize, Mat3, Mat3)> {
        let b = blocks.get(i)?;
        let a = aggs.get(b.aggregate as usize)?;
        let node = nodes.get(i)?;
        Some((b.aggregate as usize, a.rot, skew(sub(node.x0, a.c0))))
    };
    // Adds the 6×6 `[I; [pᵢ]×] L [I, −[p_j]×]` for L = Rᵢᵀ K_ij R_j to block
    // (aᵢ, a_j) of the lower block triangle (the upper one is its transpose).
    let mut add_block = |ai: usize, aj: usize, l: &Mat3, pi: &Mat3, pj: &Mat3| {
        if aj > ai {
            return;
        }
        let lp = mat_mul(l, pj); // L [p_j]×
        let pl = mat_mul(pi, l); // [pᵢ]× L
        let plp = mat_mul(pi, &lp); // [pᵢ]× L [p_j]×
                                    // Entry (r, c) of the block, on or below the diagonal of the matrix.
        let mut add = |r: usize, c: usize, x: f32| {
            let (i, j) = (6 * ai + r, 6 * aj + c);
            if j <= i {
                if let Some(e) = get_mut(row_mut(coarse, st, i), j) {
                    *e += x;
                }
            }
        };
        for r in 0..3 {
            for c in 0..3 {
                add(r, c, l[r][c]);
                add(r, 3 + c, -lp[r][c]);
                add(3 + r, c, pl[r][c]);
                add(3 + r, 3 + c, -plp[r][c]);
            }
        }
    };
    each_element(per_young, elems, count, |ids, g, [l, m]| {
        let f: [Option<(usize, Mat3, Mat3)>; 4] = ids.map(frame);
        for (i, fi) in f.iter().enumerate() {
            let Some((ai, ri, pi)) = fi else { continue };
            for (j, fj) in f.iter().enumerate() {
                let Some((aj, rj, pj)) = fj else { continue };
                if aj > ai {
                    continue;
                }
                let (gi, gj) = (g[i], g[j]);
                let gg = m * dot(gi, gj);
                let k: Mat3 = core::array::from_fn(|r| {
                    core::array::from_fn(|c| {
                        k_coef
                            * (l * gi[r] * gj[c]
                                + m * gj[r] * gi[c]
                                + if r == c { gg } else { 0.0 })
                    })
                });
                let lmat = mat_mul(&transpose(ri), &mat_mul(&k, rj));
                add_block(*ai, *aj, &lmat, pi, pj);
            }
        }
    });
    // Mass: (1 + h α_M) m Φᵢᵀ Φᵢ = c m [I, −[p]×; [p]×, −[p]×[p]×].
    for (i, node) in nodes.iter().enumerate() {
        if let Some((a, _, pi)) = frame(i) {
            let eye: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            let cm = mass_coef * node.mass;
            let l = eye.map(|row| row.map(|x| x * cm));
            add_block(a, a, &l, &pi, &pi);
        }
    }
    let (mat, tmp) = coarse.split_at_mut((dim * st).min(coarse.len()));
    cholesky(mat, dim);
    invert(mat, tmp, dim);
    gram(mat, tmp, dim);
}

/// In-place Cholesky factorisation `A = L Lᵀ` of the symmetric matrix of
/// dimension `dim` whose lower triangle `mat` holds, row by row
/// (Cholesky–Banachiewicz: `L_ij = (A_ij − Σ_{k<j} L_ik L_jk) / L_jj`, each
/// sum over two row prefixes in lanes). A pivot at or below `dim · ε` of its
/// original diagonal drops its unknown: its column of `L` is zero.
pub(super) fn cholesky(mat: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    let floor = dim as f32 * f32::EPSILON;
    for i in 0..dim {
        let (above, rest) = mat.split_at_mut((i * st).min(mat.len()));
        let ri = row_mut(rest, st, 0);
        for j in 0..=i {
            // Σ_{k<j} L_ik L_jk: whole blocks, then the lanes of the last.
            let rj = if j < i { row(above, st, j) } else { &*ri };
            let whole = j / CHUNK;
            let mut acc = [0.0; CHUNK];
            lanes_dot(
                &mut acc,
                ri.get(..whole).unwrap_or_default(),
                rj.get(..whole).unwrap_or_default(),
            );
            if let (Some(x), Some(y)) = (ri.get(whole), rj.get(whole)) {
                for ((s, p), q) in acc.iter_mut().zip(x.m).zip(y.m).take(j % CHUNK) {
                    *s += p * q;
                }
            }
            let a = get(ri, j);
            let s = a - lanes_sum(acc);
            let l = if j == i {
                let ok = s > a.abs() * floor && s.is_finite();
                if ok {
                    sqrt(s)
                } else {
                    0.0
                }
            } else {
                let d = get(rj, j);
                if d > 0.0 {
                    s / d
                } else {
                    0.0
                }
            };
            if let Some(x) = get_mut(ri, j) {
                *x = l;
            }
        }
    }
}

/// Replaces the factor `L` in `mat` by `W = L⁻¹`, in place, row by row:
/// row `i` of `L W = I` gives `Wᵢ = (eᵢ − Σ_{k<i} L_ik W_k) / L_ii`, the
/// sum an update by the rows above, in the row `tmp`. A dropped unknown
/// (`L_ii = 0`) gets a zero row; its column is zero already. Entries past
/// the diagonal stay zero.
pub(super) fn invert(mat: &mut [CoarseBlock], tmp: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    for i in 0..dim {
        let (above, rest) = mat.split_at_mut((i * st).min(mat.len()));
        let ri = row_mut(rest, st, 0);
        let t = tmp.get_mut(..i / CHUNK + 1).unwrap_or_default();
        for b in t.iter_mut() {
            *b = CoarseBlock::EMPTY;
        }
        for k in 0..i {
            axpy_blocks(t, get(ri, k), upto(row(above, st, k), k));
        }
        let d = get(ri, i);
        let inv = if d > 0.0 { 1.0 / d } else { 0.0 };
        for (k, (b, tb)) in ri.iter_mut().zip(t.iter()).enumerate() {
            for (l, (x, s)) in b.m.iter_mut().zip(tb.m).enumerate() {
                let j = k * CHUNK + l;
                *x = if d > 0.0 && j < i {
                    -s * inv
                } else if j == i {
                    inv
                } else {
                    0.0
                };
            }
        }
    }
}

/// Replaces `W` (lower triangular, in `mat`) by the whole symmetric
/// `S = Wᵀ W = A⁻¹`, in place: row `i`'s lower part
/// `S_i,≤i = Σ_{k≥i} W_ki W_k,≤i` (an update by the rows below, in the row
/// `tmp`) needs only rows `k ≥ i` of `W`, so rows are replaced in order;
/// then the upper part is mirrored.
pub(super) fn gram(mat: &mut [CoarseBlock], tmp: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    for i in 0..dim {
        let t = tmp.get_mut(..i / CHUNK + 1).unwrap_or_default();
        for b in t.iter_mut() {
            *b = CoarseBlock::EMPTY;
        }
        for k in i..dim {
            let rk = row(mat, st, k);
            axpy_blocks(t, get(rk, i), upto(rk, i));
        }
        let ri = row_mut(mat, st, i);
        for (k, (b, tb)) in ri.iter_mut().zip(t.iter()).enumerate() {
            for (l, (x, s)) in b.m.iter_mut().zip(tb.m).enumerate() {
                *x = if k * CHUNK + l <= i { s } else { 0.0 };
            }
        }
    }
    for i in 0..dim {
        for j in 0..i {
            let s = get(row(mat, st, i), j);
            if let Some(x) = get_mut(row_mut(mat, st, j), i) {
                *x = s;
            }
        }
    }
}
