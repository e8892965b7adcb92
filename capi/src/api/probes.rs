//! Friction and probes: Coulomb friction on the ground (feature
//! `friction`), and rigid probes pressing on the body (feature `probe`):
//! their set in the caller's memory, their shapes, poses, friction and
//! forces, and the step with them.

use super::status;
#[cfg(feature = "probe")]
use super::step::record;
#[cfg(feature = "probe")]
use super::{built, vec3};
use crate::arena::{self, SceneHandle};
#[cfg(feature = "probe")]
use crate::probe;
use crate::probe::ProbesHandle;
#[cfg(feature = "probe")]
use crate::ptr::{disjoint, out, out_opt, span};
use crate::status::{Failure, Status};
use crate::types::Stats;

/// Sets Coulomb friction between the body and the ground: a static
/// coefficient (the ratio of tangential to normal contact impulse below
/// which a node sticks to the ground) and a kinetic one (the ratio while it
/// slides). Both finite and ≥ 0, the static one at least the kinetic one,
/// and the kinetic one > 0 if the static one is; `0, 0` (the default) is
/// frictionless. `COROFEM_STATUS_INVALID_ARGUMENT` otherwise, and nothing
/// changes. `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `friction`.
///
/// # Safety
///
/// `scene` is a handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_set_ground_friction(
    scene: *mut SceneHandle,
    static_coefficient: f32,
    kinetic_coefficient: f32,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { arena::scene(scene)? };
        set_ground_friction(s, static_coefficient, kinetic_coefficient)
    })())
}

#[cfg(feature = "friction")]
fn set_ground_friction(s: &mut SceneHandle, stick: f32, slide: f32) -> Result<(), Failure> {
    s.scene
        .set_ground_friction(corofem_core::Friction::new(stick, slide)?);
    Ok(())
}

#[cfg(not(feature = "friction"))]
fn set_ground_friction(_: &mut SceneHandle, _: f32, _: f32) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Writes to `*out_bytes` how many bytes a set of up to `max_probes` probes
/// (1 to 65 535) needs: a probe's shape, its pose at the start and the end
/// of the next step, its force and friction (100 bytes each, 92 without
/// `friction`), a header and a few bytes of slack, so that a buffer of that
/// size works at any address. `COROFEM_STATUS_UNSUPPORTED` if the library was built
/// without `probe`.
///
/// # Safety
///
/// `out_bytes` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_probes_bytes(max_probes: usize, out_bytes: *mut usize) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { probes_bytes(max_probes, out_bytes) })
}

/// Refuses arrays (byte spans from [`span`]; null ones are ignored) that
/// overlap the probe buffer, whose header and probes the call holds
/// references to.
#[cfg(feature = "probe")]
pub(super) fn outside(set: &probe::Probes<'_>, parts: &[(usize, usize)]) -> Result<(), Status> {
    if parts
        .iter()
        .any(|&(a, n)| a != 0 && set.overlaps::<u8>(a, n))
    {
        return Err(Status::Overlap);
    }
    Ok(())
}

#[cfg(feature = "probe")]
unsafe fn probes_bytes(max_probes: usize, out_bytes: *mut usize) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let o = unsafe { out(out_bytes, None)? };
    *o = probe::probes_bytes(max_probes)?;
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn probes_bytes(_: usize, _: *mut usize) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Initialises an empty set of up to `max_probes` probes in the caller's
/// `buffer` of `buffer_bytes` bytes (at least `corofem_probes_bytes`, at any
/// address) and writes its handle, which points into the buffer, to
/// `*out_probes`. The buffer must stay in place, unused by anything else,
/// while the set is used; initialising it again empties it. A set belongs
/// to no scene: `corofem_step_probes` steps a scene with it. Nothing is
/// allocated. `COROFEM_STATUS_UNSUPPORTED` if the library was built without
/// `probe`.
///
/// # Safety
///
/// `buffer` is null or valid for writes of `buffer_bytes` bytes;
/// `out_probes` is null or writable and outside the buffer.
#[no_mangle]
pub unsafe extern "C" fn corofem_probes_init(
    buffer: *mut core::ffi::c_void,
    buffer_bytes: usize,
    max_probes: usize,
    out_probes: *mut *mut ProbesHandle,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { probes_init(buffer.cast(), buffer_bytes, max_probes, out_probes) })
}

#[cfg(feature = "probe")]
unsafe fn probes_init(
    buffer: *mut u8,
    buffer_bytes: usize,
    max_probes: usize,
    out_probes: *mut *mut ProbesHandle,
) -> Result<(), Failure> {
    disjoint(&[span(buffer, buffer_bytes), span(out_probes, 1)])?;
    // SAFETY: the caller's contract for `out_probes`; checked before the
    // buffer is touched.
    let o = unsafe { out(out_probes, None)? };
    // SAFETY: the caller's contract for `buffer`.
    *o = unsafe { probe::init(buffer, buffer_bytes, max_probes)? };
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn probes_init(
    _: *mut u8,
    _: usize,
    _: usize,
    _: *mut *mut ProbesHandle,
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Adds a sphere of `radius` (m, finite, > 0) centred at `position` (3
/// floats, m) to the set and writes its index (0 for the first, then 1, …)
/// to `*out_index` (may be null). It starts frictionless and at rest where
/// it is made; its first step checks that it does not start inside the body
/// (`COROFEM_STATUS_PROBE_INSIDE_BODY`). `COROFEM_STATUS_CAPACITY` when the
/// set is full; `COROFEM_STATUS_INVALID_ARGUMENT` for a bad radius or a
/// position that is not finite; on error the set is unchanged.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `probe`.
///
/// # Safety
///
/// `probes` is a probe set handle (or null); `position` points to 3 floats;
/// `out_index` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_probes_add_sphere(
    probes: *mut ProbesHandle,
    radius: f32,
    position: *const f32,
    out_index: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on; a sphere is a capsule of
    // half length 0 (its axis is then unused).
    status(unsafe {
        add_capsule(
            probes,
            (radius, 0.0),
            position,
            [0.0f32, 0.0, 1.0].as_ptr(),
            out_index,
        )
    })
}

/// Adds a capsule to the set: the points within `radius` (m, finite, > 0)
/// of the segment of half length `half_length` (m, finite, ≥ 0) through
/// `position` (3 floats, m) along `axis` (3 floats, any length > 0), a
/// tool's shaft or a fingertip. Writes its index to `*out_index` (may be
/// null). As `corofem_probes_add_sphere` otherwise; a half length of 0 is a
/// sphere.
///
/// # Safety
///
/// `probes` is a probe set handle (or null); `position` and `axis` point to
/// 3 floats; `out_index` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_probes_add_capsule(
    probes: *mut ProbesHandle,
    radius: f32,
    half_length: f32,
    position: *const f32,
    axis: *const f32,
    out_index: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { add_capsule(probes, (radius, half_length), position, axis, out_index) })
}

#[cfg(feature = "probe")]
unsafe fn add_capsule(
    probes: *mut ProbesHandle,
    (radius, half_length): (f32, f32),
    position: *const f32,
    axis: *const f32,
    out_index: *mut usize,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let mut set = unsafe { probe::probes(probes)? };
    let (pos, ax, o) = (span(position, 3), span(axis, 3), span(out_index, 1));
    outside(&set, &[pos, ax, o])?;
    disjoint(&[o, pos])?;
    disjoint(&[o, ax])?;
    // SAFETY: as above; outside the probe buffer, the output apart from
    // the inputs.
    let (p, e, o) = unsafe {
        (
            vec3(position, None)?,
            vec3(axis, None)?,
            out_opt(out_index, None)?,
        )
    };
    let made = corofem_core::Probe::capsule(radius, half_length, p, e)?;
    let i = set.add(made)?;
    if let Some(o) = o {
        *o = i;
    }
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn add_capsule(
    _: *mut ProbesHandle,
    _: (f32, f32),
    _: *const f32,
    _: *const f32,
    _: *mut usize,
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Writes the number of probes in the set to `*out_count`.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `probe`.
///
/// # Safety
///
/// `probes` is a probe set handle (or null); `out_count` is null or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_probes_count(
    probes: *mut ProbesHandle,
    out_count: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { probes_count(probes, out_count) })
}

#[cfg(feature = "probe")]
unsafe fn probes_count(probes: *mut ProbesHandle, out_count: *mut usize) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let set = unsafe { probe::probes(probes)? };
    outside(&set, &[span(out_count, 1)])?;
    // SAFETY: as above; outside the probe buffer.
    let o = unsafe { out(out_count, None)? };
    *o = set.count();
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn probes_count(_: *mut ProbesHandle, _: *mut usize) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Sets the pose probe `index` reaches at the end of the next step: its
/// centre `position` (3 floats, m; a capsule's segment midpoint) and, for a
/// capsule, its `axis` (3 floats, any length > 0; null keeps the current
/// one, as a sphere needs no axis). The step moves it there from where the
/// last step left it, sweeping the body's surface on the way. This is
/// where a haptic device's position goes each period.
/// `COROFEM_STATUS_INVALID_ARGUMENT` for a pose that is not finite or an
/// axis of zero length, `COROFEM_STATUS_INDEX_OUT_OF_RANGE` for an index
/// the set does not hold; on error the probe is unchanged.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `probe`.
///
/// # Safety
///
/// `probes` is a probe set handle (or null); `position` points to 3 floats,
/// `axis` is null or points to 3 floats.
#[no_mangle]
pub unsafe extern "C" fn corofem_probe_move_to(
    probes: *mut ProbesHandle,
    index: usize,
    position: *const f32,
    axis: *const f32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { set_pose(probes, index, position, axis, false) })
}

/// Places probe `index` at `position` and `axis` (as in
/// `corofem_probe_move_to`) now, without a sweep: the next step starts and
/// ends there, and checks, as a new probe's first step does, that it does
/// not start inside the body. For setting a scene up or taking a probe
/// away; a device's motion goes through `corofem_probe_move_to`.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `probe`.
///
/// # Safety
///
/// As `corofem_probe_move_to`.
#[no_mangle]
pub unsafe extern "C" fn corofem_probe_place(
    probes: *mut ProbesHandle,
    index: usize,
    position: *const f32,
    axis: *const f32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { set_pose(probes, index, position, axis, true) })
}

#[cfg(feature = "probe")]
unsafe fn set_pose(
    probes: *mut ProbesHandle,
    index: usize,
    position: *const f32,
    axis: *const f32,
    place: bool,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let mut set = unsafe { probe::probes(probes)? };
    outside(&set, &[span(position, 3), span(axis, 3)])?;
    // SAFETY: as above; read-only inputs outside the probe buffer.
    let (p, e) = unsafe {
        (
            vec3(position, None)?,
            if axis.is_null() {
                None
            } else {
                Some(vec3(axis, None)?)
            },
        )
    };
    let probe = set.get(index)?;
    let e = e.unwrap_or(probe.axis());
    // Both check the pose before changing the probe.
    if place {
        probe.place(p, e)?;
    } else {
        probe.move_to(p, e)?;
    }
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn set_pose(
    _: *mut ProbesHandle,
    _: usize,
    _: *const f32,
    _: *const f32,
    _: bool,
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Sets Coulomb friction between probe `index` and the body, as
/// `corofem_set_ground_friction` for the ground: a node the probe holds
/// sticks to it and is dragged along while its tangential impulse is within
/// `static_coefficient` times its normal one, and slides on it against a
/// force of `kinetic_coefficient` times its normal force beyond that.
/// `COROFEM_STATUS_INVALID_ARGUMENT` for bad coefficients,
/// `COROFEM_STATUS_INDEX_OUT_OF_RANGE` for an index the set does not hold;
/// on error the probe is unchanged. `COROFEM_STATUS_UNSUPPORTED` if the
/// library was built without `probe` or `friction`.
///
/// # Safety
///
/// `probes` is a probe set handle (or null).
#[no_mangle]
pub unsafe extern "C" fn corofem_probe_set_friction(
    probes: *mut ProbesHandle,
    index: usize,
    static_coefficient: f32,
    kinetic_coefficient: f32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { probe_friction(probes, index, static_coefficient, kinetic_coefficient) })
}

#[cfg(all(feature = "probe", feature = "friction"))]
unsafe fn probe_friction(
    probes: *mut ProbesHandle,
    index: usize,
    stick: f32,
    slide: f32,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let mut set = unsafe { probe::probes(probes)? };
    let probe = set.get(index)?;
    probe.set_friction(corofem_core::Friction::new(stick, slide)?);
    Ok(())
}

#[cfg(not(all(feature = "probe", feature = "friction")))]
unsafe fn probe_friction(_: *mut ProbesHandle, _: usize, _: f32, _: f32) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Writes the force the body exerted on probe `index` during the last step
/// (3 floats, N; friction included), what a haptic device renders, to
/// `out_force`, and the number of nodes it held to `*out_contacts`; either
/// may be null. Zero before the probe's first step.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `probe`.
///
/// # Safety
///
/// `probes` is a probe set handle (or null); `out_force` is null or
/// writable for 3 floats, `out_contacts` null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_probe_force(
    probes: *mut ProbesHandle,
    index: usize,
    out_force: *mut f32,
    out_contacts: *mut u32,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { probe_force(probes, index, out_force, out_contacts) })
}

#[cfg(feature = "probe")]
unsafe fn probe_force(
    probes: *mut ProbesHandle,
    index: usize,
    out_force: *mut f32,
    out_contacts: *mut u32,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let mut set = unsafe { probe::probes(probes)? };
    let outs = [span(out_force, 3), span(out_contacts, 1)];
    disjoint(&outs)?;
    outside(&set, &outs)?;
    // SAFETY: as above; outside the probe buffer and each other.
    let (of, oc) = unsafe {
        (
            out_opt(out_force.cast::<[f32; 3]>(), None)?,
            out_opt(out_contacts, None)?,
        )
    };
    let probe = set.get(index)?;
    if let Some(f) = of {
        *f = probe.force();
    }
    if let Some(c) = oc {
        *c = probe.contacts();
    }
    Ok(())
}

#[cfg(not(feature = "probe"))]
unsafe fn probe_force(
    _: *mut ProbesHandle,
    _: usize,
    _: *mut f32,
    _: *mut u32,
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Advances the scene by one step with every probe of the set pressing on
/// the body: each moves from where the last step left it to the pose set
/// by `corofem_probe_move_to`, the surface nodes it reaches are held on it
/// within the implicit solve (with its friction), and each gets the force
/// the body exerted on it (`corofem_probe_force`). The tool, if one is
/// grabbed, stays at its target, as in `corofem_step`. The statistics go to
/// `*out_stats` (may be null): `contacts` counts the nodes held by the
/// probes and the ground, `support_force` is what the fixed nodes and the
/// ground exerted.
///
/// On `COROFEM_STATUS_PROBE_INSIDE_BODY` a probe's first step (after it was
/// added or placed) would start with a node of the body's surface inside
/// it, or with the probe inside the body: the probe's index goes to
/// `*out_probe` and the node's to `*out_node`, `SIZE_MAX` for a probe
/// wholly inside the body (either may be null). On that error, on
/// `COROFEM_STATUS_DIVERGED` and on every other error, neither the scene
/// nor the probes change. `COROFEM_STATUS_UNSUPPORTED` if the library was
/// built without `probe`.
///
/// # Safety
///
/// `scene` is a handle (or null); `probes` is a probe set handle (or
/// null); the outputs are null or writable. The probe buffer lies outside
/// the scene buffer; no output lies inside either or overlaps another.
#[no_mangle]
pub unsafe extern "C" fn corofem_step_probes(
    scene: *mut SceneHandle,
    probes: *mut ProbesHandle,
    out_stats: *mut Stats,
    out_probe: *mut usize,
    out_node: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { step_probes(scene, probes, (out_stats, out_probe, out_node)) })
}

#[cfg(feature = "probe")]
unsafe fn step_probes(
    scene: *mut SceneHandle,
    probes: *mut ProbesHandle,
    (out_stats, out_probe, out_node): (*mut Stats, *mut usize, *mut usize),
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let (s, mut set) = unsafe { (built(scene)?, probe::probes(probes)?) };
    let (start, end) = set.buffer();
    if s.overlaps::<u8>(start, end - start) {
        return Err(Status::Overlap.into());
    }
    let outs = [span(out_stats, 1), span(out_probe, 1), span(out_node, 1)];
    disjoint(&outs)?;
    outside(&set, &outs)?;
    // SAFETY: as above; outside both buffers and each other.
    let (os, op, on) = unsafe {
        (
            out_opt(out_stats, Some(s))?,
            out_opt(out_probe, Some(s))?,
            out_opt(out_node, Some(s))?,
        )
    };
    match s.scene.step_with_probes(set.all()) {
        Ok(st) => {
            record(s, st, os);
            Ok(())
        }
        Err(e) => {
            if let corofem_core::StepError::ProbeInsideBody { probe, node } = e {
                if let Some(o) = op {
                    *o = probe as usize;
                }
                if let Some(o) = on {
                    *o = node.map_or(usize::MAX, |n| n as usize);
                }
            }
            Err(e.into())
        }
    }
}

#[cfg(not(feature = "probe"))]
unsafe fn step_probes(
    _: *mut SceneHandle,
    _: *mut ProbesHandle,
    _: (*mut Stats, *mut usize, *mut usize),
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}
