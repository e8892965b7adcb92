//! Stepping a scene, with or without the tool's target, and the statistics
//! of the last step.

use super::{built, status, vec3};
use crate::arena::SceneHandle;
use crate::ptr::{disjoint, out, out_opt, span};
use crate::status::Status;
use crate::types::Stats;

/// Advances the scene by one step of `dt`; the statistics go to
/// `*out_stats` (may be null). Fixed cost per step with `cg_tolerance` 0.
/// On `COROFEM_STATUS_DIVERGED` the step was not applied.
///
/// # Safety
///
/// `scene` is a handle (or null); `out_stats` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_step(scene: *mut SceneHandle, out_stats: *mut Stats) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let o = unsafe { out_opt(out_stats, Some(s))? };
        let st = s.scene.step()?;
        record(s, st, o);
        Ok(())
    })())
}

/// One haptic-loop step: moves the tool target to `target` (3 floats, m),
/// steps, and writes the force the body exerts on the tool (3 floats, N) to
/// `out_force` (may be null) and the statistics to `*out_stats` (may be null).
///
/// # Safety
///
/// `scene` is a handle (or null); `target` points to 3 floats; the outputs
/// are null or writable (3 floats for `out_force`).
#[no_mangle]
pub unsafe extern "C" fn corofem_step_haptic(
    scene: *mut SceneHandle,
    target: *const f32,
    out_force: *mut f32,
    out_stats: *mut Stats,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        disjoint(&[span(out_force, 3), span(out_stats, 1)])?;
        // SAFETY: as above.
        let (t, of, os) = unsafe {
            (
                vec3(target, Some(s))?,
                out_opt(out_force.cast::<[f32; 3]>(), Some(s))?,
                out_opt(out_stats, Some(s))?,
            )
        };
        let st = s.scene.step_haptic(t)?;
        if let Some(f) = of {
            *f = st.tool_force;
        }
        record(s, st, os);
        Ok(())
    })())
}

pub(super) fn record(s: &mut SceneHandle, st: corofem_core::StepStats, out: Option<&mut Stats>) {
    s.steps = s.steps.wrapping_add(1);
    s.last = st;
    if let Some(o) = out {
        *o = stats(s);
    }
}

fn stats(s: &SceneHandle) -> Stats {
    Stats {
        steps: s.steps,
        time: s.scene.time(),
        cg_iterations: s.last.cg_iterations,
        cg_residual: s.last.cg_residual,
        inverted: s.last.inverted,
        contacts: s.last.contacts,
        tool_force: s.last.tool_force,
        energy_removed: s.last.energy_removed,
        support_force: s.last.support_force,
    }
}

/// Writes the statistics of the last step (zeros before the first).
///
/// # Safety
///
/// `scene` is a handle (or null); `out_stats` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_last_stats(
    scene: *mut SceneHandle,
    out_stats: *mut Stats,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let o = unsafe { out(out_stats, Some(s))? };
        *o = stats(s);
        Ok(())
    })())
}
