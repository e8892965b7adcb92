//! The exported C functions. Each checks its handle and pointers, calls the
//! core (which returns `Result`s and never panics) and returns a status code.
//!
//! Common contract of every function taking pointers (the part no check can
//! see): a non-null pointer points to memory valid for the stated number of
//! values, not used by another thread during the call; a scene handle is
//! used by one thread at a time and its buffer stays allocated and in place
//! while it is used.
//!
//! One module a noun, in the header's order:
//!
//! - this module: `corofem_status_str`, and the helpers the others share
//!   (the status of a result, a required `float[3]`, a built scene);
//! - `scene`: a scene's memory and life cycle (`corofem_scene_bytes`,
//!   `corofem_scene_init`, `corofem_scene_deinit`), the generated box mesh,
//!   `corofem_build` and `corofem_counts`;
//! - `settings`: the step settings, the element method and the elasticity;
//! - `constraints`: fixed nodes, constant forces, the ground plane and the
//!   tool's grab and target;
//! - `step`: `corofem_step`, `corofem_step_haptic` and the last step's
//!   statistics;
//! - `state`: positions and velocities, the state hash, the reset to rest;
//! - `surface`: embedded surfaces (feature `surface`);
//! - `probes`: ground friction (feature `friction`) and probe sets, their
//!   friction and the step with them (feature `probe`);
//! - `coupling`: the haptic virtual coupling (feature `coupling`).

use core::ffi::c_char;

use corofem_core::Vec3;

use crate::arena::{self, SceneHandle};
use crate::ptr::get;
use crate::status::{Failure, Status};

// cbindgen writes the functions into the header in the order it meets
// them: this module's first, then each module's in the order they are
// declared here (the blank lines keep rustfmt from sorting them).
mod scene;

mod settings;

mod constraints;

mod step;

mod state;

mod surface;

mod probes;

mod coupling;

pub use self::constraints::*;
pub use self::coupling::*;
pub use self::probes::*;
pub use self::scene::*;
pub use self::settings::*;
pub use self::state::*;
pub use self::step::*;
pub use self::surface::*;

/// The status of an inner result.
fn status(r: Result<(), Failure>) -> Status {
    match r {
        Ok(()) => Status::Ok,
        Err(f) => f.status,
    }
}

/// Three floats from a required pointer.
///
/// # Safety
///
/// `p` is null or points to 3 readable floats.
unsafe fn vec3(p: *const f32, guard: Option<&SceneHandle>) -> Result<Vec3, Status> {
    // SAFETY: forwarded contract.
    unsafe { get(p.cast::<[f32; 3]>(), guard) }
}

/// A built scene.
///
/// # Safety
///
/// As [`arena::scene`].
unsafe fn built<'a>(h: *mut SceneHandle) -> Result<&'a mut SceneHandle, Status> {
    // SAFETY: forwarded contract.
    let s = unsafe { arena::scene(h)? };
    if s.built {
        Ok(s)
    } else {
        Err(Status::NotBuilt)
    }
}

/// The message of a status code: a static NUL-terminated string, never null.
#[no_mangle]
pub extern "C" fn corofem_status_str(status: i32) -> *const c_char {
    Status::message_ptr(status)
}
