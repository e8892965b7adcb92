//! The CG's stiffness product `q += −K d` in hand-written FPU assembly for
//! bare-metal Arm hard-float targets (feature `fpu-product`; Cortex-M4F/M7).
//!
//! The element kernel is [`hform::stiffness_product`](crate::element::hform)
//! and the scatter of [`pass`](crate::pass)'s `product_one_by_one`, operation
//! for operation in the same order, so the bits are the same (the firmware
//! checks compare the state hash with the host's, built with and without this
//! feature). What the compiler cannot emit from Rust is `vldm`/`vstm`: it
//! loads and stores every float alone. Here an element's stiffness and
//! gradients (10 consecutive floats) arrive in one `vldm`, each node's `d`
//! in one, and its `q` in one `vldm` and one `vstm`: 13 loads and stores
//! per element and CG iteration instead of 46.
//!
//! A multiply-add `x + a·b` (37 per element) is one `vmla` (the product and
//! the sum each rounded, as in Rust: not fused), or with feature
//! `_fpu-product-vmul` a `vmul` into a scratch register and a `vadd`. On a
//! Cortex-M4 `vmla` takes 3 cycles and the pair 2 (TRM, table 7-1): `vmla`
//! gives the fewest instructions, the pair the fewest cycles. The compiler
//! makes the same choice for the Rust code: `vmla` for a generic
//! `thumbv7em` build, the pair with `-C target-cpu=cortex-m4`.
//!
//! Registers (single precision):
//!
//! ```text
//! s16        stiffness E/(36 V₀)        s30, s31   λ/E, μ/E (loop-invariant)
//! s17..s19   g_b (world gradient)       s0..s2     d_a, then H row 0 [h00 h01 h02]
//! s20..s22   g_c                        s3..s11    d_b, d_c, d_d, then the edges e = d − d_a
//! s23..s25   g_d                        s12..s15, s26, s27   H rows 1, 2 [h10 h11 h12 h20 h21 h22]
//! s28, s29   λ', μ'                     s29, s0    scratch of the `vmul` + `vadd` pairs
//! ```
//!
//! then the stress `[sxx syy szz sxy syz szx] = s5 s6 s3 s7 s8 s9`, the
//! products `p = σ g` of b, c, d in `s10..s12`, `s13..s15`, `s26..s28`, and
//! `Δq_a = −((−p_b − p_c) − p_d)` (the Rust code's `share_of_a` of `−p`).

#![allow(unsafe_code)] // one inline assembly block; its safety is argued below

use core::mem::{offset_of, size_of};

use crate::element::ElementBlock;
use crate::lanes::LANES;
use crate::storage::NodeWork;

/// `d += a · b`, the product rounded and then the sum, with scratch register
/// `t`: one `vmla`.
#[cfg(not(feature = "_fpu-product-vmul"))]
macro_rules! mac {
    ($d:literal, $a:literal, $b:literal, $t:literal) => {
        concat!("vmla.f32 ", $d, ", ", $a, ", ", $b)
    };
}

/// `d += a · b` as `t = a · b; d = d + t` (feature `_fpu-product-vmul`).
#[cfg(feature = "_fpu-product-vmul")]
macro_rules! mac {
    ($d:literal, $a:literal, $b:literal, $t:literal) => {
        concat!(
            "vmul.f32 ",
            $t,
            ", ",
            $a,
            ", ",
            $b,
            "\n",
            "vadd.f32 ",
            $d,
            ", ",
            $d,
            ", ",
            $t
        )
    };
}

/// Byte offset of the stiffness in a block; the gradients follow it.
const STIFFNESS: usize = offset_of!(ElementBlock, stiffness);

// The layout the assembly assumes, checked at compile time: one element per
// block, the 9 gradients right after the stiffness, node indices 8 bytes at
// the start (reached with a negative offset from the stiffness), `q` right
// after `d` in a node's work slot.
const _: () = {
    assert!(LANES == 1);
    assert!(offset_of!(ElementBlock, grad) == STIFFNESS + 4);
    assert!(offset_of!(ElementBlock, nodes) == 0 && STIFFNESS >= 8 && STIFFNESS % 4 == 0);
    assert!(STIFFNESS <= 1020); // `ldrd`'s immediate offset
    assert!(offset_of!(NodeWork, q) == offset_of!(NodeWork, d) + 12);
    assert!(offset_of!(NodeWork, q) + 12 <= size_of::<NodeWork>());
    assert!(size_of::<ElementBlock>() <= 4095); // `add`'s (addw) immediate
};

/// `q += −K d` of every element of `blocks` (one element each), skipping an
/// element with a node index out of range of `work`, as `product_one_by_one`.
/// `per_young` is `[λ, μ] / E` of the body.
///
/// Never inlined: one copy of the ~600 bytes of code (inlined, each of the
/// CG's two calls of the operator got its own, +3.4 kB of flash).
#[inline(never)]
pub(crate) fn product(per_young: [f32; 2], blocks: &[ElementBlock], work: &mut [NodeWork]) {
    let range = blocks.as_ptr_range();
    let n = work.len();
    let d = work
        .as_mut_ptr()
        .cast::<u8>()
        .wrapping_add(offset_of!(NodeWork, d));
    // SAFETY:
    // * reads: `p` walks the blocks of `blocks` (from the first block's
    //   stiffness to one block past the last: compared with `end` before
    //   the first element and after each), reading that block's node indices (8 bytes at `p −
    //   STIFFNESS`) and its stiffness and gradients (40 bytes at `p`), all
    //   inside the block (layout checked above).
    // * node slots: each of the four indices is compared with `n =
    //   work.len()` before use (`bhs` skips the element, as the Rust code
    //   does), so `d + i · size_of::<NodeWork>()` addresses `work[i].d`;
    //   the 24 bytes of `d` and `q` lie inside the slot. Only `q` is
    //   written, through `work`, which is borrowed mutably here.
    // * alignment: blocks and slots are 4-aligned (f32 fields), as `ldrd`,
    //   `vldm` and `vstm` need.
    // * registers: every core register written is an operand, every FPU
    //   register written is declared clobbered (the compiler saves the
    //   callee-saved s16..s31); flags are clobbered (not `preserves_flags`);
    //   no stack is used.
    unsafe {
        core::arch::asm!(
            ".fpu fpv4-sp-d16",
            "vmov s30, s31, {a}, {b}",
            "cmp {p}, {end}",
            "beq 3f",
            "2:",
            // Node indices a | b << 16 and c | d << 16; each below n.
            "ldrd {a}, {c}, [{p}, #-{stiffness}]",
            "lsrs {b}, {a}, #16",
            "uxth {a}, {a}",
            "lsrs {dd}, {c}, #16",
            "uxth {c}, {c}",
            "cmp {a}, {n}",
            "ittt lo",
            "cmplo {b}, {n}",
            "cmplo {c}, {n}",
            "cmplo {dd}, {n}",
            "bhs 4f",
            // Slot addresses of `d` (`q` follows it).
            "mla {a}, {a}, {size}, {d}",
            "mla {b}, {b}, {size}, {d}",
            "mla {c}, {c}, {size}, {d}",
            "mla {dd}, {dd}, {size}, {d}",
            "vldmia {p}, {{s16-s25}}",
            "vldmia {a}!, {{s0-s2}}",
            "vldmia {b}!, {{s3-s5}}",
            "vldmia {c}!, {{s6-s8}}",
            "vldmia {dd}!, {{s9-s11}}",
            // Edges e_i = d_i − d_a (`sub(x[i], x[0])`).
            "vsub.f32 s3, s3, s0",
            "vsub.f32 s4, s4, s1",
            "vsub.f32 s5, s5, s2",
            "vsub.f32 s6, s6, s0",
            "vsub.f32 s7, s7, s1",
            "vsub.f32 s8, s8, s2",
            "vsub.f32 s9, s9, s0",
            "vsub.f32 s10, s10, s1",
            "vsub.f32 s11, s11, s2",
            // H[r][c] = (e_b[r] g_b[c] + e_c[r] g_c[c]) + e_d[r] g_d[c]
            // (`grad_h`; `vmla` rounds the product, then the sum).
            "vmul.f32 s0, s3, s17",
            mac!("s0", "s6", "s20", "s29"),
            mac!("s0", "s9", "s23", "s29"),
            "vmul.f32 s1, s3, s18",
            mac!("s1", "s6", "s21", "s29"),
            mac!("s1", "s9", "s24", "s29"),
            "vmul.f32 s2, s3, s19",
            mac!("s2", "s6", "s22", "s29"),
            mac!("s2", "s9", "s25", "s29"),
            "vmul.f32 s12, s4, s17",
            mac!("s12", "s7", "s20", "s29"),
            mac!("s12", "s10", "s23", "s29"),
            "vmul.f32 s13, s4, s18",
            mac!("s13", "s7", "s21", "s29"),
            mac!("s13", "s10", "s24", "s29"),
            "vmul.f32 s14, s4, s19",
            mac!("s14", "s7", "s22", "s29"),
            mac!("s14", "s10", "s25", "s29"),
            "vmul.f32 s15, s5, s17",
            mac!("s15", "s8", "s20", "s29"),
            mac!("s15", "s11", "s23", "s29"),
            "vmul.f32 s26, s5, s18",
            mac!("s26", "s8", "s21", "s29"),
            mac!("s26", "s11", "s24", "s29"),
            "vmul.f32 s27, s5, s19",
            mac!("s27", "s8", "s22", "s29"),
            mac!("s27", "s11", "s25", "s29"),
            // λ' = λ/E · stiffness, μ' = μ/E · stiffness (`material::lame`).
            "vmul.f32 s28, s30, s16",
            "vmul.f32 s29, s31, s16",
            // Stress (`stress`): lt = λ' ((h00 + h11) + h22), m2 = μ' + μ',
            // s_ii = lt + m2 h_ii, sxy = μ' (h01 + h10), syz = μ' (h12 + h21),
            // szx = μ' (h20 + h02).
            "vadd.f32 s3, s0, s13",
            "vadd.f32 s3, s3, s27",
            "vmul.f32 s3, s28, s3",
            "vadd.f32 s4, s29, s29",
            "vmul.f32 s5, s4, s0",
            "vadd.f32 s5, s5, s3",
            "vmul.f32 s6, s4, s13",
            "vadd.f32 s6, s6, s3",
            mac!("s3", "s4", "s27", "s0"),
            "vadd.f32 s7, s1, s12",
            "vmul.f32 s7, s29, s7",
            "vadd.f32 s8, s14, s26",
            "vmul.f32 s8, s29, s8",
            "vadd.f32 s9, s15, s2",
            "vmul.f32 s9, s29, s9",
            // p_i = σ g_i (`neg_stress_times` before its negation):
            // [(sxx gx + sxy gy) + szx gz, (sxy gx + syy gy) + syz gz,
            //  (szx gx + syz gy) + szz gz].
            "vmul.f32 s10, s5, s17",
            mac!("s10", "s7", "s18", "s29"),
            mac!("s10", "s9", "s19", "s29"),
            "vmul.f32 s11, s7, s17",
            mac!("s11", "s6", "s18", "s29"),
            mac!("s11", "s8", "s19", "s29"),
            "vmul.f32 s12, s9, s17",
            mac!("s12", "s8", "s18", "s29"),
            mac!("s12", "s3", "s19", "s29"),
            "vmul.f32 s13, s5, s20",
            mac!("s13", "s7", "s21", "s29"),
            mac!("s13", "s9", "s22", "s29"),
            "vmul.f32 s14, s7, s20",
            mac!("s14", "s6", "s21", "s29"),
            mac!("s14", "s8", "s22", "s29"),
            "vmul.f32 s15, s9, s20",
            mac!("s15", "s8", "s21", "s29"),
            mac!("s15", "s3", "s22", "s29"),
            "vmul.f32 s26, s5, s23",
            mac!("s26", "s7", "s24", "s29"),
            mac!("s26", "s9", "s25", "s29"),
            "vmul.f32 s27, s7, s23",
            mac!("s27", "s6", "s24", "s29"),
            mac!("s27", "s8", "s25", "s29"),
            "vmul.f32 s28, s9, s23",
            mac!("s28", "s8", "s24", "s29"),
            mac!("s28", "s3", "s25", "s29"),
            // Node a: q_a + share_of_a(−p) = q_a − ((−p_b − p_c) − p_d).
            "vneg.f32 s0, s10",
            "vsub.f32 s0, s0, s13",
            "vsub.f32 s0, s0, s26",
            "vneg.f32 s1, s11",
            "vsub.f32 s1, s1, s14",
            "vsub.f32 s1, s1, s27",
            "vneg.f32 s2, s12",
            "vsub.f32 s2, s2, s15",
            "vsub.f32 s2, s2, s28",
            "vldmia {a}, {{s3-s5}}",
            "vsub.f32 s3, s3, s0",
            "vsub.f32 s4, s4, s1",
            "vsub.f32 s5, s5, s2",
            "vstmia {a}, {{s3-s5}}",
            // Nodes b, c, d, in that order: q_i + (−p_i) = q_i − p_i.
            "vldmia {b}, {{s6-s8}}",
            "vsub.f32 s6, s6, s10",
            "vsub.f32 s7, s7, s11",
            "vsub.f32 s8, s8, s12",
            "vstmia {b}, {{s6-s8}}",
            "vldmia {c}, {{s0-s2}}",
            "vsub.f32 s0, s0, s13",
            "vsub.f32 s1, s1, s14",
            "vsub.f32 s2, s2, s15",
            "vstmia {c}, {{s0-s2}}",
            "vldmia {dd}, {{s3-s5}}",
            "vsub.f32 s3, s3, s26",
            "vsub.f32 s4, s4, s27",
            "vsub.f32 s5, s5, s28",
            "vstmia {dd}, {{s3-s5}}",
            "4:",
            "add {p}, {p}, #{block}",
            "cmp {p}, {end}",
            "bne 2b",
            "3:",
            p = inout(reg) range.start.cast::<u8>().wrapping_add(STIFFNESS) => _,
            end = in(reg) range.end.cast::<u8>().wrapping_add(STIFFNESS),
            d = in(reg) d,
            n = in(reg) n,
            size = in(reg) size_of::<NodeWork>(),
            // λ/E and μ/E come in as bits in `a` and `b` (moved to s30, s31).
            a = inout(reg) per_young[0].to_bits() => _,
            b = inout(reg) per_young[1].to_bits() => _,
            c = out(reg) _,
            dd = out(reg) _,
            stiffness = const STIFFNESS,
            block = const size_of::<ElementBlock>(),
            out("s0") _, out("s1") _, out("s2") _, out("s3") _,
            out("s4") _, out("s5") _, out("s6") _, out("s7") _,
            out("s8") _, out("s9") _, out("s10") _, out("s11") _,
            out("s12") _, out("s13") _, out("s14") _, out("s15") _,
            out("s16") _, out("s17") _, out("s18") _, out("s19") _,
            out("s20") _, out("s21") _, out("s22") _, out("s23") _,
            out("s24") _, out("s25") _, out("s26") _, out("s27") _,
            out("s28") _, out("s29") _, out("s30") _, out("s31") _,
            options(nostack),
        );
    }
}
