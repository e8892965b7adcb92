//! The step settings, the element method and the material's elasticity.

use super::{built, status};
use crate::arena::{self, SceneHandle};
use crate::ptr::{get, out};
use crate::status::Status;
use crate::types::{method_from_code, Settings};

/// Writes the default settings (no scene needed): QR with inverted elements
/// turned back (`qr-invertible`), dt = 1 ms, the two-level preconditioner with
/// 4 CG iterations from a warm start, no early stop, no damping, gravity
/// −9.81 m/s² along z, the energy guard and free rotation on; what the
/// library lacks replaced by what it has (QR, the lumped mass with 5
/// iterations from a cold start, the guard or free rotation off).
///
/// # Safety
///
/// `out_settings` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_settings_default(out_settings: *mut Settings) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let o = unsafe { out(out_settings, None)? };
        *o = Settings::from_core(&corofem_core::Settings::new().compiled());
        Ok(())
    })())
}

/// Writes the scene's settings.
///
/// # Safety
///
/// `scene` is a handle (or null); `out_settings` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_get_settings(
    scene: *mut SceneHandle,
    out_settings: *mut Settings,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { arena::scene(scene)? };
        // SAFETY: as above.
        let o = unsafe { out(out_settings, Some(s))? };
        *o = Settings::from_core(s.scene.settings());
        Ok(())
    })())
}

/// Validates and sets the step settings (before or after the build).
///
/// # Safety
///
/// `scene` is a handle (or null); `settings` is null or readable.
#[no_mangle]
pub unsafe extern "C" fn corofem_set_settings(
    scene: *mut SceneHandle,
    settings: *const Settings,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { arena::scene(scene)? };
        // SAFETY: as above.
        let c = unsafe { get(settings, Some(s))? };
        s.scene.set_settings(c.to_core()?)?;
        Ok(())
    })())
}

/// Sets the element method (`COROFEM_METHOD_*`).
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_set_method(scene: *mut SceneHandle, method: u32) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { arena::scene(scene)? };
        s.scene.set_method(method_from_code(method)?)?;
        Ok(())
    })())
}

/// Sets Young's modulus (Pa, ≥ 0) of every element and the Poisson ratio
/// (0 ≤ ν < 0.5) of the built scene. The density is fixed at the build
/// (it sets the masses).
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_set_elasticity(
    scene: *mut SceneHandle,
    young: f32,
    poisson: f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        // Checked as a pair before either is set: an error changes nothing.
        s.scene.set_elasticity(young, poisson)?;
        Ok(())
    })())
}

/// Sets Young's modulus (Pa, ≥ 0) of one element.
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_set_young(
    scene: *mut SceneHandle,
    element: u32,
    young: f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        s.scene.set_young(element as usize, young)?;
        Ok(())
    })())
}
