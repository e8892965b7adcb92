//! The probe's path in the haptic loops' liver press, as
//! `capi/examples/haptic_loop.c`'s `probe_path`: the `rt_loop` example and
//! the loop tests (`capi/tests/haptic_loop.rs`, which check the Rust and C
//! loops step alike) both follow it.
#![no_std]

/// The sphere's centre at the end of step `step` (1-based), from `c0`
/// above the body to `b` at its deepest: down over 300 steps, 15 mm along
/// +x over 500, up over 300, back over 100 (a 1200-step cycle).
pub fn path(c0: [f32; 3], b: [f32; 3], step: u32) -> [f32; 3] {
    let slide = 0.015f32;
    let k = (step - 1) % 1200 + 1;
    let (s, side) = if k <= 300 {
        (k as f32 / 300.0, 0.0)
    } else if k <= 800 {
        (1.0, slide * ((k - 300) as f32 / 500.0))
    } else if k <= 1100 {
        ((1100 - k) as f32 / 300.0, slide)
    } else {
        (0.0, slide * ((1200 - k) as f32 / 100.0))
    };
    let mut c = [0.0f32; 3];
    for i in 0..3 {
        c[i] = c0[i] + (b[i] - c0[i]) * s;
    }
    c[0] += side;
    c
}
