//! The haptic virtual coupling as a plain C struct.
//!
//! A coupling is small plain data (19 floats: three parameters, the
//! proxy's velocity, the rendered force and what it learnt of the body) and
//! points to nothing, so C declares it where it likes, on the stack, in a
//! static or inside its own device struct, and initialises it with
//! `corofem_coupling_init`:
//!
//! ```text
//!  corofem_coupling (80 bytes, aligned to 4)
//!  ┌───────┬──────────────────────────────────────────────────┐
//!  │ magic │ the core's `Coupling`, 19 × 4 bytes              │
//!  └───────┴──────────────────────────────────────────────────┘
//! ```
//!
//! The scene and the probe sets live in buffers the caller sizes with a
//! `…_bytes` call because their size depends on the mesh or the number of
//! probes; a coupling's size is fixed, so a sizing call and a buffer would
//! only be two more steps for the caller and two more ways to get them
//! wrong. Its size is the core's `Coupling`'s, checked at compile time: a
//! core that changes it changes this struct, and the header with it.
//!
//! Unlike a scene or a probe set, a coupling holds no address, so a copy
//! is a coupling in the same state (to save one and restore it, say). The
//! magic word tells an initialised coupling from memory that never was one
//! (zeroed or stale), which is refused as `Status::InvalidHandle`.
//!
//! Without the feature `coupling` only the struct is here, for the
//! functions' signatures, which then return `Status::Unsupported`.

use crate::ptr::Plain;
#[cfg(feature = "coupling")]
use crate::status::Status;

/// "COFE" — an initialised coupling (a live scene is `0xC0FE_0001`, a
/// probe set `0xC0FE_0007`).
#[cfg(feature = "coupling")]
const MAGIC: u32 = 0xC0FE_0009;

/// A haptic virtual coupling: a spring and a damper between a haptic
/// device and a probe that becomes its proxy, with a mass. Declare one
/// anywhere (80 bytes, aligned to 4, no pointers inside; a copy is the
/// same coupling) and initialise it with `corofem_coupling_init`. Opaque:
/// read it through the `corofem_coupling_*` functions.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coupling {
    /// Set by `corofem_coupling_init`: other values are refused as
    /// `COROFEM_STATUS_INVALID_HANDLE`.
    magic: u32,
    /// The coupling's state.
    state: [u32; 19],
}

// SAFETY: a `repr(C)` struct of integers only: every bit pattern is valid.
unsafe impl Plain for Coupling {}

// The state holds the core's coupling exactly, at an alignment it accepts.
#[cfg(feature = "coupling")]
const _: () = {
    use core::mem::{align_of, size_of};
    assert!(size_of::<corofem_core::Coupling>() == size_of::<[u32; 19]>());
    assert!(align_of::<corofem_core::Coupling>() <= align_of::<[u32; 19]>());
};

#[cfg(feature = "coupling")]
impl Coupling {
    /// An initialised coupling holding `c`.
    pub fn new(c: corofem_core::Coupling) -> Self {
        let mut s = Self {
            magic: MAGIC,
            state: [0; 19],
        };
        s.store(c);
        s
    }

    /// The core's coupling, or [`Status::InvalidHandle`] for a struct that
    /// `corofem_coupling_init` did not initialise.
    pub fn load(&self) -> Result<corofem_core::Coupling, Status> {
        if self.magic != MAGIC {
            return Err(Status::InvalidHandle);
        }
        // SAFETY: `state` is as large as a `Coupling` and aligned for it
        // (checked above). Every field of the core's `Coupling` is an `f32`
        // (core/src/coupling.rs), so any bits read as one; these were
        // written by `store`, or copied from a struct it wrote.
        Ok(unsafe { self.state.as_ptr().cast::<corofem_core::Coupling>().read() })
    }

    /// Keeps `c` as the coupling's state.
    pub fn store(&mut self, c: corofem_core::Coupling) {
        // SAFETY: as in `load`: room and alignment for a `Coupling`, and
        // `state` is borrowed mutably here alone.
        unsafe {
            self.state
                .as_mut_ptr()
                .cast::<corofem_core::Coupling>()
                .write(c);
        }
    }
}
