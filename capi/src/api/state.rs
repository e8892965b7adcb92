//! The body's state: positions and velocities read and written, the state
//! hash and the reset to rest.

use super::{built, status};
use crate::arena::SceneHandle;
use crate::ptr::{input, out, output};
use crate::status::Status;

/// Writes the current positions (m) of all nodes, 3 floats each, into `out`
/// of `out_len` floats (at least 3 × node count).
///
/// # Safety
///
/// `scene` is a handle (or null); `out` is writable for `out_len` floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_positions(
    scene: *mut SceneHandle,
    out: *mut f32,
    out_len: usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        if out_len / 3 < s.scene.node_count() {
            return Err(Status::BufferTooSmall.into());
        }
        // SAFETY: as above.
        let o = unsafe { output(out.cast::<[f32; 3]>(), out_len / 3, Some(s))? };
        for (slot, p) in o.iter_mut().zip(s.scene.positions()) {
            *slot = p;
        }
        Ok(())
    })())
}

/// Sets the current positions (m) of all nodes: `node_count` (the scene's
/// node count) positions of 3 floats each. Displacements follow as position
/// − rest; velocities are kept, and fixed nodes take the positions given
/// too (they then stay there). A count other than the scene's node count,
/// or a position that is not finite, is `COROFEM_STATUS_INVALID_ARGUMENT`
/// and changes nothing.
///
/// # Safety
///
/// `scene` is a handle (or null); `positions` holds `3 node_count` floats
/// and lies outside the scene buffer.
#[no_mangle]
pub unsafe extern "C" fn corofem_set_positions(
    scene: *mut SceneHandle,
    positions: *const f32,
    node_count: usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let p = unsafe { input(positions.cast::<[f32; 3]>(), node_count, Some(s))? };
        s.scene.set_positions(p)?;
        Ok(())
    })())
}

/// Writes the current velocities (m/s) of all nodes, 3 floats each, into
/// `out` of `out_len` floats (at least 3 × node count).
///
/// # Safety
///
/// `scene` is a handle (or null); `out` is writable for `out_len` floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_velocities(
    scene: *mut SceneHandle,
    out: *mut f32,
    out_len: usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        if out_len / 3 < s.scene.node_count() {
            return Err(Status::BufferTooSmall.into());
        }
        // SAFETY: as above.
        let o = unsafe { output(out.cast::<[f32; 3]>(), out_len / 3, Some(s))? };
        for (slot, v) in o.iter_mut().zip(s.scene.velocities()) {
            *slot = v;
        }
        Ok(())
    })())
}

/// Writes the current position (3 floats, m) of one node.
///
/// # Safety
///
/// `scene` is a handle (or null); `out` is writable for 3 floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_position(
    scene: *mut SceneHandle,
    node: u32,
    out_position: *mut f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let o = unsafe { out(out_position.cast::<[f32; 3]>(), Some(s))? };
        *o = s.scene.position(node).ok_or(Status::IndexOutOfRange)?;
        Ok(())
    })())
}

/// Writes a 64-bit FNV-1a hash of the bits of every displacement and
/// velocity: equal hashes mean bit-identical states (the same value the
/// Rust API's `Scene::state_hash` gives).
///
/// # Safety
///
/// `scene` is a handle (or null); `out_hash` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_state_hash(scene: *mut SceneHandle, out_hash: *mut u64) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // SAFETY: as above.
        let o = unsafe { out(out_hash, Some(s))? };
        *o = s.scene.state_hash();
        Ok(())
    })())
}

/// Back to the rest shape at rest (displacements, velocities, time and step
/// count zeroed; constraints, loads and the tool kept).
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_reset_state(scene: *mut SceneHandle) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        s.scene.reset_state();
        s.steps = 0;
        s.last = corofem_core::StepStats::default();
        Ok(())
    })())
}
