//! The haptic virtual coupling (feature `coupling`): its initialisation,
//! the drive of its proxy probe each period, its reset and its getters.

use corofem_core::Vec3;

use super::status;
#[cfg(feature = "coupling")]
use super::{probes::outside, vec3};
use crate::coupling::Coupling;
#[cfg(feature = "coupling")]
use crate::probe;
use crate::probe::ProbesHandle;
#[cfg(feature = "coupling")]
use crate::ptr::{disjoint, get};
use crate::ptr::{out, out_opt, span};
use crate::status::{Failure, Status};

/// Initialises the haptic virtual coupling `*coupling` (a
/// `corofem_coupling` of the caller's: on the stack, static, anywhere) with
/// a spring of `stiffness` (N/m, finite, > 0), a damper of `damping`
/// (N·s/m, finite, ≥ 0) and a proxy of `proxy_mass` (kg, finite, > 0), its
/// proxy at rest. The README's "Haptic coupling" section gives how to
/// choose them for a device (for example 1000 N/m, 2 N·s/m, 0.01 kg).
/// Initialising it again starts it afresh. `COROFEM_STATUS_INVALID_ARGUMENT`
/// for a parameter out of range, with `*coupling` unchanged.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a writable `corofem_coupling`.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_init(
    coupling: *mut Coupling,
    stiffness: f32,
    damping: f32,
    proxy_mass: f32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { coupling_init(coupling, stiffness, damping, proxy_mass) })
}

#[cfg(feature = "coupling")]
unsafe fn coupling_init(
    coupling: *mut Coupling,
    stiffness: f32,
    damping: f32,
    proxy_mass: f32,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract; checked before the parameters, so a
    // bad pointer is reported as such.
    let c = unsafe { out(coupling, None)? };
    *c = Coupling::new(corofem_core::Coupling::new(stiffness, damping, proxy_mass)?);
    Ok(())
}

#[cfg(not(feature = "coupling"))]
unsafe fn coupling_init(_: *mut Coupling, _: f32, _: f32, _: f32) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// One period of the haptic loop, before `corofem_step_probes`: the device
/// is at `device_position` (3 floats, m) moving at `device_velocity` (3
/// floats, m/s); probe `index` of the set is the coupling's proxy. Advances
/// the proxy by one step of `dt` (s, the scene's time step) under the
/// coupling's spring and damper and the force the body exerted on it in the
/// last steps, moves the probe there (`corofem_probe_move_to`, its axis
/// kept), and writes the force to render on the device (3 floats, N) to
/// `out_force` (may be null; `corofem_coupling_device_force` reads it
/// again). The step that follows moves the body against the probe.
///
/// `COROFEM_STATUS_INVALID_ARGUMENT` for a device state that is not finite,
/// a `dt` that is not finite and > 0, or a result that overflows;
/// `COROFEM_STATUS_INDEX_OUT_OF_RANGE` for an index the set does not hold;
/// `COROFEM_STATUS_INVALID_HANDLE` for a coupling never initialised; on
/// every error neither the coupling nor the probes change and nothing is
/// written. `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a `corofem_coupling`; `probes` is a
/// probe set handle (or null); the device's position and velocity point to
/// 3 floats each; `out_force` is null or writable for 3 floats. The
/// coupling and `out_force` lie outside the probe buffer, apart from each
/// other and from the inputs.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_drive(
    coupling: *mut Coupling,
    probes: *mut ProbesHandle,
    index: usize,
    device_position: *const f32,
    device_velocity: *const f32,
    dt: f32,
    out_force: *mut f32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe {
        coupling_drive(
            coupling,
            (probes, index),
            (device_position, device_velocity),
            dt,
            out_force,
        )
    })
}

#[cfg(feature = "coupling")]
unsafe fn coupling_drive(
    coupling: *mut Coupling,
    (probes, index): (*mut ProbesHandle, usize),
    (position, velocity): (*const f32, *const f32),
    dt: f32,
    out_force: *mut f32,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let mut set = unsafe { probe::probes(probes)? };
    let (c, x, v, o) = (
        span(coupling, 1),
        span(position, 3),
        span(velocity, 3),
        span(out_force, 3),
    );
    outside(&set, &[c, x, v, o])?;
    // What is written apart from everything else (the inputs may share
    // memory: they are only read).
    disjoint(&[c, x, o])?;
    disjoint(&[c, v, o])?;
    // SAFETY: as above; outside the probe buffer, the written ones apart
    // from each other and from the inputs, which are copied first.
    let (x, v, c, o) = unsafe {
        (
            vec3(position, None)?,
            vec3(velocity, None)?,
            out(coupling, None)?,
            out_opt(out_force.cast::<[f32; 3]>(), None)?,
        )
    };
    let mut state = c.load()?;
    let probe = set.get(index)?;
    // The core changes neither the coupling nor the probe on error; the
    // state is stored back only on success.
    let force = state.drive(probe, x, v, dt)?;
    c.store(state);
    if let Some(o) = o {
        *o = force;
    }
    Ok(())
}

#[cfg(not(feature = "coupling"))]
unsafe fn coupling_drive(
    _: *mut Coupling,
    _: (*mut ProbesHandle, usize),
    _: (*const f32, *const f32),
    _: f32,
    _: *mut f32,
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Stops the coupling's proxy and forgets the rendered force and what it
/// learnt of the body, keeping its parameters: for a proxy that was just
/// placed somewhere else (`corofem_probe_place`).
/// `COROFEM_STATUS_INVALID_HANDLE` for a coupling never initialised.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a writable `corofem_coupling`.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_reset(coupling: *mut Coupling) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { coupling_reset(coupling) })
}

#[cfg(feature = "coupling")]
unsafe fn coupling_reset(coupling: *mut Coupling) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let c = unsafe { out(coupling, None)? };
    let mut state = c.load()?;
    state.reset();
    c.store(state);
    Ok(())
}

#[cfg(not(feature = "coupling"))]
unsafe fn coupling_reset(_: *mut Coupling) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Writes the force the last `corofem_coupling_drive` returned (3 floats,
/// N; zero after `corofem_coupling_init` and `corofem_coupling_reset`) to
/// `out_force`. `COROFEM_STATUS_INVALID_HANDLE` for a coupling never
/// initialised. `COROFEM_STATUS_UNSUPPORTED` if the library was built
/// without `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a `corofem_coupling`; `out_force` is
/// null or writable for 3 floats, apart from the coupling.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_device_force(
    coupling: *const Coupling,
    out_force: *mut f32,
) -> Status {
    status((|| {
        let o = span(out_force, 3);
        // SAFETY: the caller's contract; the output apart from the coupling.
        let (c, o) = unsafe { (snapshot(coupling, &[o])?, out(out_force.cast(), None)?) };
        *o = c.force;
        Ok(())
    })())
}

/// Writes to `*out_stiffness` the body's stiffness at the probe (N/m) that
/// the last `corofem_coupling_drive` used: estimated from the change of
/// the body's force along the proxy's motion while it touches, it decays
/// by 1 % a period out of contact, and is 0 after `corofem_coupling_init`
/// and `corofem_coupling_reset`. `COROFEM_STATUS_INVALID_HANDLE` for a
/// coupling never initialised. `COROFEM_STATUS_UNSUPPORTED` if the library
/// was built without `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a `corofem_coupling`; `out_stiffness`
/// is null or writable, apart from the coupling.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_body_stiffness(
    coupling: *const Coupling,
    out_stiffness: *mut f32,
) -> Status {
    status((|| {
        let o = span(out_stiffness, 1);
        // SAFETY: the caller's contract; the output apart from the coupling.
        let (c, o) = unsafe { (snapshot(coupling, &[o])?, out(out_stiffness, None)?) };
        *o = c.body_stiffness;
        Ok(())
    })())
}

/// Writes the proxy's velocity at the end of the last period (3 floats,
/// m/s) to `out_velocity`. `COROFEM_STATUS_INVALID_HANDLE` for a coupling
/// never initialised. `COROFEM_STATUS_UNSUPPORTED` if the library was
/// built without `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a `corofem_coupling`; `out_velocity` is
/// null or writable for 3 floats, apart from the coupling.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_proxy_velocity(
    coupling: *const Coupling,
    out_velocity: *mut f32,
) -> Status {
    status((|| {
        let o = span(out_velocity, 3);
        // SAFETY: the caller's contract; the output apart from the coupling.
        let (c, o) = unsafe { (snapshot(coupling, &[o])?, out(out_velocity.cast(), None)?) };
        *o = c.velocity;
        Ok(())
    })())
}

/// Writes the coupling's parameters as `corofem_coupling_init` took them:
/// the spring's stiffness (N/m) to `*out_stiffness`, the damper's
/// coefficient (N·s/m) to `*out_damping` and the proxy's mass (kg) to
/// `*out_proxy_mass`; any of them may be null.
/// `COROFEM_STATUS_INVALID_HANDLE` for a coupling never initialised.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `coupling`.
///
/// # Safety
///
/// `coupling` is null or points to a `corofem_coupling`; each output is
/// null or writable, apart from the coupling and from the others.
#[no_mangle]
pub unsafe extern "C" fn corofem_coupling_parameters(
    coupling: *const Coupling,
    out_stiffness: *mut f32,
    out_damping: *mut f32,
    out_proxy_mass: *mut f32,
) -> Status {
    status((|| {
        let outs = [out_stiffness, out_damping, out_proxy_mass];
        // SAFETY: the caller's contract; the outputs apart from the
        // coupling and from each other.
        let c = unsafe { snapshot(coupling, &outs.map(|p| span(p, 1)))? };
        for (p, x) in outs.into_iter().zip(c.parameters) {
            // SAFETY: as above.
            if let Some(o) = unsafe { out_opt(p, None)? } {
                *o = x;
            }
        }
        Ok(())
    })())
}

/// What the coupling's getters read.
#[cfg_attr(not(feature = "coupling"), allow(dead_code))]
struct Snapshot {
    force: Vec3,
    body_stiffness: f32,
    velocity: Vec3,
    /// Stiffness, damping, proxy mass.
    parameters: [f32; 3],
}

/// The state of an initialised coupling, after checking that `outs` (null
/// ones aside) overlap neither it nor each other.
///
/// # Safety
///
/// `coupling` is null or points to a readable `corofem_coupling`.
#[cfg(feature = "coupling")]
unsafe fn snapshot(coupling: *const Coupling, outs: &[(usize, usize)]) -> Result<Snapshot, Status> {
    disjoint(outs)?;
    for &o in outs {
        disjoint(&[span(coupling, 1), o])?;
    }
    // SAFETY: the caller's contract; copied out.
    let c = unsafe { get(coupling, None)? }.load()?;
    Ok(Snapshot {
        force: c.device_force(),
        body_stiffness: c.body_stiffness(),
        velocity: c.proxy_velocity(),
        parameters: [c.stiffness(), c.damping(), c.proxy_mass()],
    })
}

#[cfg(not(feature = "coupling"))]
unsafe fn snapshot(_: *const Coupling, _: &[(usize, usize)]) -> Result<Snapshot, Status> {
    Err(Status::Unsupported)
}
