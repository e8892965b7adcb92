//! What holds and pushes the body: fixed nodes, constant forces, the ground
//! plane and the haptic tool's grab.

use corofem_core::Vec3;

use super::{built, status, vec3};
use crate::arena::{self, SceneHandle};
use crate::ptr::{input, out};
use crate::status::{Failure, Status};

/// Fixes `count` nodes (they stop and stay where they are).
///
/// # Safety
///
/// `scene` is a handle (or null); `nodes` holds `count` indices (may be
/// null when `count` is 0).
#[no_mangle]
pub unsafe extern "C" fn corofem_fix_nodes(
    scene: *mut SceneHandle,
    nodes: *const u32,
    count: usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let nodes = unsafe { input(nodes, count, Some(s))? };
        s.scene.fix_nodes(nodes)?;
        Ok(())
    })())
}

/// Frees every fixed node.
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_unfix_all(scene: *mut SceneHandle) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        unsafe { built(scene)? }.scene.unfix_all();
        Ok(())
    })())
}

/// Sets the constant external force on one node (3 floats, N).
///
/// # Safety
///
/// `scene` is a handle (or null); `force` points to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_set_force(
    scene: *mut SceneHandle,
    node: u32,
    force: *const f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let f = unsafe { vec3(force, Some(s))? };
        s.scene.set_force(node, f)?;
        Ok(())
    })())
}

/// Removes every external force.
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_clear_forces(scene: *mut SceneHandle) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        unsafe { built(scene)? }.scene.clear_forces();
        Ok(())
    })())
}

/// Sets the ground plane `normal · x ≥ offset` (normal: 3 floats, any
/// length > 0; offset in m), or removes it when `normal` is null.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `ground`.
/// The body must start on or above it: the next step returns
/// `COROFEM_STATUS_BELOW_GROUND`, changing nothing, while a free node is
/// below it (so does the first step after the body is built, moved, reset
/// or unfixed).
///
/// # Safety
///
/// `scene` is a handle (or null); `normal` is null or points to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_set_ground(
    scene: *mut SceneHandle,
    normal: *const f32,
    offset: f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { arena::scene(scene)? };
        let plane = if normal.is_null() {
            None
        } else {
            // SAFETY: as above.
            Some(unsafe { vec3(normal, Some(s))? })
        };
        set_ground(s, plane, offset)
    })())
}

#[cfg(feature = "ground")]
fn set_ground(s: &mut SceneHandle, normal: Option<Vec3>, offset: f32) -> Result<(), Failure> {
    let plane = normal.map(|normal| corofem_core::Plane { normal, offset });
    s.scene.set_ground(plane)?;
    Ok(())
}

#[cfg(not(feature = "ground"))]
fn set_ground(_: &mut SceneHandle, _: Option<Vec3>, _: f32) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Grabs `count` nodes with the haptic tool: a spring of total stiffness
/// `stiffness` (N/m, ≥ 0) pulls their centroid towards the tool target,
/// which starts at that centroid. Replaces any previous grab.
///
/// # Safety
///
/// `scene` is a handle (or null); `nodes` holds `count` indices.
#[no_mangle]
pub unsafe extern "C" fn corofem_grab(
    scene: *mut SceneHandle,
    nodes: *const u32,
    count: usize,
    stiffness: f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let nodes = unsafe { input(nodes, count, Some(s))? };
        s.scene.grab(nodes, stiffness)?;
        Ok(())
    })())
}

/// Lets go of the grabbed nodes.
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_release(scene: *mut SceneHandle) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        unsafe { built(scene)? }.scene.release();
        Ok(())
    })())
}

/// Writes the tool target (3 floats, m).
///
/// # Safety
///
/// `scene` is a handle (or null); `out_target` is writable for 3 floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_tool_target(
    scene: *mut SceneHandle,
    out_target: *mut f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let o = unsafe { out(out_target.cast::<[f32; 3]>(), Some(s))? };
        *o = s.scene.tool_target();
        Ok(())
    })())
}
