//! Stepping with the instruction set of the CPU at hand.
//!
//! The core is `no_std` and cannot detect CPU features. On x86_64 it compiles
//! its step twice: for the target's baseline (SSE2, [`Scene::step`]) and for
//! AVX2 ([`Scene::step_avx2`], unsafe to call without AVX2). [`step`] detects
//! AVX2 once per process and calls the latter when it can. Both run the same
//! IEEE operations in the same order (Rust never contracts to FMA and the
//! `fma` feature is not enabled), so the bits are those of the baseline
//! build; `fast_step_has_the_bits_of_the_baseline` in
//! `host-tests/tests/determinism.rs` checks it for every method.
//!
//! Why AVX2 and not AVX-512, which this machine also has: with the core's
//! batches of 8 elements, AVX-512 measured no faster than AVX2 (docs/bench.md).

use corofem::{Scene, StepError, StepStats, Storage, Vec3};

/// The instruction set [`step`] uses: `"avx2"` when the CPU has AVX2 (and
/// the environment variable `COROFEM_ISA` is not `baseline`), else
/// `"baseline"`. Decided once per process.
#[must_use]
pub fn instruction_set() -> &'static str {
    if use_avx2() {
        "avx2"
    } else {
        "baseline"
    }
}

/// AVX2 detected and not turned off by `COROFEM_ISA=baseline` (cached).
fn use_avx2() -> bool {
    static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVX2.get_or_init(|| {
        let off = std::env::var("COROFEM_ISA").is_ok_and(|v| v == "baseline");
        #[cfg(target_arch = "x86_64")]
        let has = std::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let has = false;
        has && !off
    })
}

/// One [`Scene::step`], compiled for AVX2 when the CPU has it (detected at
/// run time), with the bits of the baseline build.
pub fn step<S: Storage>(scene: &mut Scene<S>) -> Result<StepStats, StepError> {
    dispatch(scene, None)
}

/// One [`Scene::step_haptic`] (tool target in m; the reaction force is in the
/// statistics), compiled for AVX2 when the CPU has it.
pub fn step_haptic<S: Storage>(scene: &mut Scene<S>, target: Vec3) -> Result<StepStats, StepError> {
    dispatch(scene, Some(target))
}

/// `step` (no target) or `step_haptic`, with AVX2 when [`use_avx2`].
#[allow(unsafe_code)] // calling the core's AVX2 step
fn dispatch<S: Storage>(
    scene: &mut Scene<S>,
    target: Option<Vec3>,
) -> Result<StepStats, StepError> {
    #[cfg(target_arch = "x86_64")]
    if use_avx2() {
        // SAFETY: `use_avx2()` is true only after
        // `is_x86_feature_detected!("avx2")` returned true.
        return unsafe {
            match target {
                Some(x) => scene.step_haptic_avx2(x),
                None => scene.step_avx2(),
            }
        };
    }
    match target {
        Some(x) => scene.step_haptic(x),
        None => scene.step(),
    }
}
