//! The exported C functions. Each checks its handle and pointers, calls the
//! core (which returns `Result`s and never panics) and returns a status code.
//!
//! Common contract of every function taking pointers (the part no check can
//! see): a non-null pointer points to memory valid for the stated number of
//! values, not used by another thread during the call; a scene handle is
//! used by one thread at a time and its buffer stays allocated and in place
//! while it is used.

use core::ffi::c_char;

use corofem_core::{BoxMesh, BuildOptions, Vec3};

use crate::arena::{self, SceneHandle, Slots};
use crate::coupling::Coupling;
#[cfg(feature = "probe")]
use crate::probe;
use crate::probe::ProbesHandle;
use crate::ptr::{disjoint, get, input, out, out_opt, output, span};
use crate::status::{Failure, Status};
#[cfg(feature = "surface")]
use crate::surface;
use crate::surface::SurfaceHandle;
use crate::types::{
    method_from_code, BindStats, Material, Settings, Stats, COROFEM_BUILD_REORIENT,
};

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

/// Writes to `*out_bytes` how many bytes a scene of up to `max_nodes` nodes
/// (1 to 65 536) and `max_tets` tetrahedra (≥ 1) needs. The size holds
/// everything (handle, nodes, solver scratch, elements) and a few bytes of
/// slack, so a buffer of that size works at any address.
///
/// # Safety
///
/// `out_bytes` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_scene_bytes(
    max_nodes: usize,
    max_tets: usize,
    out_bytes: *mut usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract for `out_bytes`.
        let o = unsafe { out(out_bytes, None)? };
        *o = arena::scene_bytes(max_nodes, max_tets, Slots::every_node(max_nodes))?;
        Ok(())
    })())
}

/// `corofem_scene_bytes` for a scene whose tool holds at most `max_grabbed`
/// nodes at once and on which at most `max_loaded` nodes carry a constant
/// force (each at most `max_nodes`; 16 bytes per slot, against a slot of
/// each kind per node in `corofem_scene_bytes`). A grab or a force beyond
/// them is then `COROFEM_STATUS_CAPACITY`.
///
/// # Safety
///
/// `out_bytes` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_scene_bytes_sized(
    max_nodes: usize,
    max_tets: usize,
    max_grabbed: usize,
    max_loaded: usize,
    out_bytes: *mut usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract for `out_bytes`.
        let o = unsafe { out(out_bytes, None)? };
        let slots = Slots {
            grabs: max_grabbed,
            loads: max_loaded,
        };
        *o = arena::scene_bytes(max_nodes, max_tets, slots)?;
        Ok(())
    })())
}

/// Initialises an empty scene of up to `max_nodes` nodes and `max_tets`
/// tetrahedra in the caller's `buffer` of `buffer_bytes` bytes (at least
/// `corofem_scene_bytes`) and writes its handle to `*out_scene`. The handle
/// points inside the buffer; the buffer must stay in place, unused by
/// anything else, while the scene lives. Nothing is allocated. Any node can
/// be grabbed or loaded (`corofem_scene_init_sized` reserves fewer slots).
///
/// # Safety
///
/// `buffer` is null or valid for writes of `buffer_bytes` bytes;
/// `out_scene` is null or writable and outside the buffer.
#[no_mangle]
pub unsafe extern "C" fn corofem_scene_init(
    buffer: *mut core::ffi::c_void,
    buffer_bytes: usize,
    max_nodes: usize,
    max_tets: usize,
    out_scene: *mut *mut SceneHandle,
) -> Status {
    let slots = Slots::every_node(max_nodes);
    // SAFETY: the caller's contract, passed on.
    unsafe { init_with(buffer, buffer_bytes, max_nodes, max_tets, slots, out_scene) }
}

/// `corofem_scene_init` with at most `max_grabbed` grabbed and `max_loaded`
/// loaded nodes (see `corofem_scene_bytes_sized`, which sizes the buffer).
///
/// # Safety
///
/// As `corofem_scene_init`.
#[no_mangle]
pub unsafe extern "C" fn corofem_scene_init_sized(
    buffer: *mut core::ffi::c_void,
    buffer_bytes: usize,
    max_nodes: usize,
    max_tets: usize,
    max_grabbed: usize,
    max_loaded: usize,
    out_scene: *mut *mut SceneHandle,
) -> Status {
    let slots = Slots {
        grabs: max_grabbed,
        loads: max_loaded,
    };
    // SAFETY: the caller's contract, passed on.
    unsafe { init_with(buffer, buffer_bytes, max_nodes, max_tets, slots, out_scene) }
}

/// Both scene initialisations.
///
/// # Safety
///
/// As `corofem_scene_init`.
unsafe fn init_with(
    buffer: *mut core::ffi::c_void,
    buffer_bytes: usize,
    max_nodes: usize,
    max_tets: usize,
    slots: Slots,
    out_scene: *mut *mut SceneHandle,
) -> Status {
    status((|| {
        if out_scene.is_null() {
            return Err(Status::NullPointer.into());
        }
        if out_scene as usize % core::mem::align_of::<*mut SceneHandle>() != 0 {
            return Err(Status::Misaligned.into());
        }
        let start = buffer as usize;
        let o = out_scene as usize;
        if o < start.saturating_add(buffer_bytes)
            && o.saturating_add(core::mem::size_of::<*mut SceneHandle>()) > start
        {
            return Err(Status::Overlap.into());
        }
        // SAFETY: the caller's contract for `buffer`.
        let h = unsafe { arena::init(buffer.cast(), buffer_bytes, max_nodes, max_tets, slots)? };
        // SAFETY: non-null, aligned, outside the buffer, writable by contract.
        unsafe { out_scene.write(h) };
        Ok(())
    })())
}

/// Ends a scene: every later call with this handle returns
/// `COROFEM_STATUS_INVALID_HANDLE`, and the buffer may be reused or freed.
///
/// # Safety
///
/// `scene` is null or a handle whose buffer is still allocated.
#[no_mangle]
pub unsafe extern "C" fn corofem_scene_deinit(scene: *mut SceneHandle) -> Status {
    status((|| {
        // SAFETY: the caller's contract for `scene`.
        unsafe { arena::scene(scene)? }.kill();
        Ok(())
    })())
}

/// Writes the node and tetrahedron counts of a generated box of
/// `cells[0] × cells[1] × cells[2]` cubes split into `tets_per_cell` (5 or 6)
/// tetrahedra each.
///
/// # Safety
///
/// `cells` points to 3 `uint32_t`; the outputs are null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_box_mesh_counts(
    cells: *const u32,
    tets_per_cell: u32,
    out_nodes: *mut usize,
    out_tets: *mut usize,
) -> Status {
    status((|| {
        disjoint(&[span(out_nodes, 1), span(out_tets, 1)])?;
        // SAFETY: the caller's contract for every pointer.
        let (cells, on, ot) = unsafe {
            (
                get(cells.cast::<[u32; 3]>(), None)?,
                out(out_nodes, None)?,
                out(out_tets, None)?,
            )
        };
        let mesh = box_mesh(&[1.0; 3], cells, tets_per_cell)?;
        *on = mesh.node_count();
        *ot = mesh.tet_count();
        Ok(())
    })())
}

fn box_mesh(size: &Vec3, cells: [u32; 3], tets_per_cell: u32) -> Result<BoxMesh, Status> {
    if !(tets_per_cell == 5 || tets_per_cell == 6) || cells.contains(&0) {
        return Err(Status::InvalidArgument);
    }
    let mesh = BoxMesh {
        size: *size,
        cells,
        tets_per_cell: tets_per_cell as u8,
    };
    if mesh.node_count() == usize::MAX || mesh.tet_count() == usize::MAX {
        return Err(Status::Capacity);
    }
    Ok(mesh)
}

/// Generates the box `[0, size[0]] × [0, size[1]] × [0, size[2]]` (m) of
/// `cells` cubes split into `tets_per_cell` (5 or 6) tetrahedra: node
/// positions into `nodes` (3 floats each, `nodes_len` floats of room) and
/// tetrahedra into `tets` (4 indices each, `tets_len` indices of room).
/// Node `(i, j, k)` has index `i + (cx+1)(j + (cy+1) k)`. The counts go to
/// `*out_nodes` and `*out_tets` (either may be null).
///
/// # Safety
///
/// `size` points to 3 floats, `cells` to 3 `uint32_t`; `nodes` and `tets`
/// are writable for their lengths; the outputs are null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_box_mesh(
    size: *const f32,
    cells: *const u32,
    tets_per_cell: u32,
    nodes: *mut f32,
    nodes_len: usize,
    tets: *mut u32,
    tets_len: usize,
    out_nodes: *mut usize,
    out_tets: *mut usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract for the inputs.
        let (size, cells) = unsafe { (vec3(size, None)?, get(cells.cast::<[u32; 3]>(), None)?) };
        let mesh = box_mesh(&size, cells, tets_per_cell)?;
        let (n, t) = (mesh.node_count(), mesh.tet_count());
        if nodes_len / 3 < n || tets_len / 4 < t {
            return Err(Status::BufferTooSmall.into());
        }
        disjoint(&[
            span(nodes, nodes_len),
            span(tets, tets_len),
            span(out_nodes, 1),
            span(out_tets, 1),
        ])?;
        // SAFETY: the caller's contract for the outputs; lengths in whole
        // vectors never exceed the lengths given.
        let (nodes, tets, on, ot) = unsafe {
            (
                output(nodes.cast::<[f32; 3]>(), nodes_len / 3, None)?,
                output(tets.cast::<[u32; 4]>(), tets_len / 4, None)?,
                out_opt(out_nodes, None)?,
                out_opt(out_tets, None)?,
            )
        };
        let (n, t) = mesh.generate(nodes, tets)?;
        if let Some(o) = on {
            *o = n;
        }
        if let Some(o) = ot {
            *o = t;
        }
        Ok(())
    })())
}

/// Builds the scene from `node_count` positions (3 floats each, m) and
/// `tet_count` tetrahedra (4 node indices each), with `material`; `flags`
/// is 0 or `COROFEM_BUILD_REORIENT`. Everything is validated before anything
/// is written: on error the scene is unchanged and, for errors that name an
/// element or a node, its index goes to `*out_where` (may be null).
/// Settings are kept; fixed nodes, forces, the tool and velocities are reset.
///
/// # Safety
///
/// `scene` is a handle (or null); `positions` holds `3 node_count` floats,
/// `tets` `4 tet_count` indices, `material` one struct; `out_where` is null
/// or writable. No array may lie inside the scene buffer.
#[no_mangle]
pub unsafe extern "C" fn corofem_build(
    scene: *mut SceneHandle,
    positions: *const f32,
    node_count: usize,
    tets: *const u32,
    tet_count: usize,
    material: *const Material,
    flags: u32,
    out_where: *mut usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract for every pointer.
        let s = unsafe { arena::scene(scene)? };
        let out_span = span(out_where, 1);
        disjoint(&[out_span, span(positions, node_count.saturating_mul(3))])?;
        disjoint(&[out_span, span(tets, tet_count.saturating_mul(4))])?;
        disjoint(&[out_span, span(material, 1)])?;
        // SAFETY: as above.
        let (pos, tets, mat, where_) = unsafe {
            (
                input(positions.cast::<[f32; 3]>(), node_count, Some(s))?,
                input(tets.cast::<[u32; 4]>(), tet_count, Some(s))?,
                get(material, Some(s))?,
                out_opt(out_where, Some(s))?,
            )
        };
        if flags & !COROFEM_BUILD_REORIENT != 0 {
            return Err(Status::InvalidArgument.into());
        }
        let options = BuildOptions {
            reorient: flags & COROFEM_BUILD_REORIENT != 0,
        };
        let material = corofem_core::Material {
            young: mat.young,
            poisson: mat.poisson,
            density: mat.density,
        };
        // The material first, as the core checks it first: a bad material
        // is `InvalidArgument` whatever the tetrahedron count.
        material.validate()?;
        if tets.len() > s.max_tets {
            return Err(Status::Capacity.into());
        }
        match s.scene.build(pos, tets, &material, options) {
            Ok(()) => {
                #[cfg(feature = "surface")]
                {
                    s.mesh = surface::mesh_id(pos, tets);
                }
                s.built = true;
                s.steps = 0;
                s.last = corofem_core::StepStats::default();
                Ok(())
            }
            Err(e) => {
                let f = Failure::from(e);
                if let (Some(w), Some(i)) = (where_, f.at) {
                    *w = i;
                }
                Err(f)
            }
        }
    })())
}

/// Writes the node and tetrahedron counts of the built scene.
///
/// # Safety
///
/// `scene` is a handle (or null); the outputs are null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_counts(
    scene: *mut SceneHandle,
    out_nodes: *mut usize,
    out_tets: *mut usize,
) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let s = unsafe { built(scene)? };
        disjoint(&[span(out_nodes, 1), span(out_tets, 1)])?;
        // SAFETY: as above.
        let (on, ot) = unsafe { (out_opt(out_nodes, Some(s))?, out_opt(out_tets, Some(s))?) };
        if let Some(o) = on {
            *o = s.scene.node_count();
        }
        if let Some(o) = ot {
            *o = s.scene.element_count();
        }
        Ok(())
    })())
}

/// Writes the default settings (no scene needed): QR with inverted elements
/// turned back (`qr-invertible`), dt = 1 ms, the two-level preconditioner with
/// 4 CG iterations from a warm start, no early stop, no damping, gravity
/// −9.81 m/s² along z, the energy guard on.
///
/// # Safety
///
/// `out_settings` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_settings_default(out_settings: *mut Settings) -> Status {
    status((|| {
        // SAFETY: the caller's contract.
        let o = unsafe { out(out_settings, None)? };
        *o = Settings::from_core(&corofem_core::Settings::default());
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

fn record(s: &mut SceneHandle, st: corofem_core::StepStats, out: Option<&mut Stats>) {
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

/// Writes how many bytes a surface of `vertex_count` vertices and
/// `triangle_count` triangles needs to `*out_bytes`: 44 bytes per vertex
/// (its binding), 12 per triangle (a copy of it, for the normals), a header
/// and a few bytes of slack, so that a buffer of that size works at any
/// address. Writes to `*out_scratch_len` how many `uint32_t` of scratch
/// `corofem_bind_surface` needs (`3 vertex_count + 1`; 2 for none), memory
/// that is free again after the call. `COROFEM_STATUS_UNSUPPORTED` if the
/// library was built without `surface`.
///
/// # Safety
///
/// The outputs are null or writable.
#[no_mangle]
pub unsafe extern "C" fn corofem_surface_bytes(
    vertex_count: usize,
    triangle_count: usize,
    out_bytes: *mut usize,
    out_scratch_len: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe { surface_bytes(vertex_count, triangle_count, out_bytes, out_scratch_len) })
}

#[cfg(feature = "surface")]
unsafe fn surface_bytes(
    vertex_count: usize,
    triangle_count: usize,
    out_bytes: *mut usize,
    out_scratch_len: *mut usize,
) -> Result<(), Failure> {
    disjoint(&[span(out_bytes, 1), span(out_scratch_len, 1)])?;
    // SAFETY: the caller's contract for the outputs.
    let (ob, os) = unsafe { (out(out_bytes, None)?, out(out_scratch_len, None)?) };
    let (bytes, scratch) = surface::surface_bytes(vertex_count, triangle_count)?;
    *ob = bytes;
    *os = scratch;
    Ok(())
}

#[cfg(not(feature = "surface"))]
unsafe fn surface_bytes(_: usize, _: usize, _: *mut usize, _: *mut usize) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Binds a triangle surface to the built scene's mesh, once. Each of the
/// `vertex_count` vertices (3 floats each, m, in the mesh's rest
/// coordinates) is bound to the tetrahedron that contains it or, if it lies
/// outside the mesh, to the nearest tetrahedron within `reach` (m, finite,
/// ≥ 0; farther is `COROFEM_STATUS_VERTEX_TOO_FAR`). The `triangle_count`
/// triangles (3 vertex indices each) are checked (indices in range, three
/// distinct vertices, corners not collinear) and copied: the normals of
/// `corofem_update_surface` come from that copy.
///
/// The surface goes into `buffer` of `buffer_bytes` bytes (at least
/// `corofem_surface_bytes`, at any address) and its handle, which points
/// into it, to `*out_surface`. The buffer must stay in place, unused by
/// anything else, while the surface is used. `scratch` holds `scratch_len`
/// `uint32_t` (at least `corofem_surface_bytes`'s scratch length); it is
/// clobbered, and free again after the call. What the binding found goes to
/// `*out_stats` (may be null). Nothing is allocated. The scene is never
/// changed.
///
/// On an error in the surface itself (`COROFEM_STATUS_NON_FINITE_COORDINATE`
/// and `COROFEM_STATUS_VERTEX_TOO_FAR` name a vertex,
/// `COROFEM_STATUS_INDEX_OUT_OF_RANGE` and
/// `COROFEM_STATUS_DEGENERATE_TRIANGLE` a triangle, whose index goes to
/// `*out_where`, which may be null) the buffer holds no surface: a surface
/// bound in it before is refused from then on. Errors in the other
/// arguments (null, misaligned or overlapping pointers, small buffers, a
/// negative or non-finite reach, an unbuilt scene) change nothing.
/// `COROFEM_STATUS_UNSUPPORTED` if the library was built without `surface`.
///
/// # Safety
///
/// `scene` is a handle (or null); `vertices` holds `3 vertex_count` floats
/// and `triangles` `3 triangle_count` indices (either may be null when its
/// count is 0); `buffer` is null or valid for writes of `buffer_bytes`
/// bytes; `scratch` is writable for `scratch_len` values; the outputs are
/// null or writable. No array may lie inside the scene buffer, and no
/// written array may overlap another array.
#[no_mangle]
pub unsafe extern "C" fn corofem_bind_surface(
    scene: *mut SceneHandle,
    vertices: *const f32,
    vertex_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    reach: f32,
    buffer: *mut core::ffi::c_void,
    buffer_bytes: usize,
    scratch: *mut u32,
    scratch_len: usize,
    out_surface: *mut *mut SurfaceHandle,
    out_stats: *mut BindStats,
    out_where: *mut usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe {
        bind_surface(
            scene,
            (vertices, vertex_count),
            (triangles, triangle_count),
            reach,
            (buffer.cast(), buffer_bytes),
            (scratch, scratch_len),
            (out_surface, out_stats, out_where),
        )
    })
}

#[cfg(feature = "surface")]
unsafe fn bind_surface(
    scene: *mut SceneHandle,
    (vertices, n): (*const f32, usize),
    (triangles, m): (*const u32, usize),
    reach: f32,
    (buffer, buffer_bytes): (*mut u8, usize),
    (scratch, scratch_len): (*mut u32, usize),
    (out_surface, out_stats, out_where): (*mut *mut SurfaceHandle, *mut BindStats, *mut usize),
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let s = unsafe { built(scene)? };
    // The counts first: no slice is formed for a count that cannot be.
    let (bytes, need_scratch) = surface::surface_bytes(n, m)?;
    // Every array the call writes, each checked against every other and
    // against each input (inputs may overlap each other).
    let written = [
        span(buffer, buffer_bytes),
        span(scratch, scratch_len),
        span(out_surface, 1),
        span(out_stats, 1),
        span(out_where, 1),
    ];
    let [a, b, c, d, e] = written;
    disjoint(&[a, b, c, d, e, span(vertices, n.saturating_mul(3))])?;
    disjoint(&[a, b, c, d, e, span(triangles, m.saturating_mul(3))])?;
    // SAFETY: as above; every pointer is checked (null, alignment, size,
    // outside the scene buffer) before a slice is formed.
    let (vertices, triangles, scratch, os, ost, ow) = unsafe {
        (
            input(vertices.cast::<[f32; 3]>(), n, Some(s))?,
            input(triangles.cast::<[u32; 3]>(), m, Some(s))?,
            output(scratch, scratch_len, Some(s))?,
            out(out_surface, Some(s))?,
            out_opt(out_stats, Some(s))?,
            out_opt(out_where, Some(s))?,
        )
    };
    if buffer.is_null() {
        return Err(Status::NullPointer.into());
    }
    if s.overlaps::<u8>(buffer as usize, buffer_bytes) {
        return Err(Status::Overlap.into());
    }
    if buffer_bytes < bytes || scratch.len() < need_scratch {
        return Err(Status::BufferTooSmall.into());
    }
    // As the core checks it, but before the buffer is touched: an argument
    // error changes nothing.
    if !(reach >= 0.0) || !reach.is_finite() {
        return Err(Status::InvalidArgument.into());
    }
    // SAFETY: non-null, at least `bytes` long, outside the scene buffer and
    // every other array; valid for writes by the caller's contract.
    let slots = unsafe { surface::slots(buffer, buffer_bytes, n, m)? };
    match s
        .scene
        .bind_surface(vertices, triangles, reach, scratch, slots.bindings)
    {
        Ok(found) => {
            // Zipped, not `copy_from_slice`: the lengths are equal, and
            // nothing here can panic.
            for (slot, t) in slots.triangles.iter_mut().zip(triangles) {
                *slot = *t;
            }
            *os = slots.finish(s.mesh);
            if let Some(o) = ost {
                *o = BindStats {
                    inside: found.inside,
                    outside: found.outside,
                    max_distance: found.max_distance,
                    farthest_vertex: found.farthest_vertex,
                };
            }
            Ok(())
        }
        Err(e) => {
            let f = Failure::from(e);
            if let (Some(w), Some(i)) = (ow, f.at) {
                *w = i;
            }
            Err(f)
        }
    }
}

#[cfg(not(feature = "surface"))]
unsafe fn bind_surface(
    _: *mut SceneHandle,
    _: (*const f32, usize),
    _: (*const u32, usize),
    _: f32,
    _: (*mut u8, usize),
    _: (*mut u32, usize),
    _: (*mut *mut SurfaceHandle, *mut BindStats, *mut usize),
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

/// Moves a bound surface with the body: the current position of each
/// vertex (3 floats, m) into `out_positions` of `positions_len` floats (at
/// least 3 × its vertex count) and, when `out_normals` is not null, each
/// vertex's unit normal into `out_normals` of `normals_len` floats (as
/// many): the area-weighted mean of its triangles' normals, outward for
/// triangles counter-clockwise seen from outside; `0, 0, 0` for a vertex in
/// no triangle. Any scene built from the mesh the surface was bound to
/// moves it; a scene built from another mesh refuses it
/// (`COROFEM_STATUS_INVALID_HANDLE`). The scene is not changed, and on
/// error nothing is written. `COROFEM_STATUS_UNSUPPORTED` if the library
/// was built without `surface`.
///
/// # Safety
///
/// `scene` and `surface` are handles (or null); `out_positions` is writable
/// for `positions_len` floats, `out_normals` null or writable for
/// `normals_len` floats. Neither lies inside the scene or the surface
/// buffer, nor overlaps the other.
#[no_mangle]
pub unsafe extern "C" fn corofem_update_surface(
    scene: *mut SceneHandle,
    surface: *const SurfaceHandle,
    out_positions: *mut f32,
    positions_len: usize,
    out_normals: *mut f32,
    normals_len: usize,
) -> Status {
    // SAFETY: the caller's contract, passed on.
    status(unsafe {
        update_surface(
            scene,
            surface,
            (out_positions, positions_len),
            (out_normals, normals_len),
        )
    })
}

#[cfg(feature = "surface")]
unsafe fn update_surface(
    scene: *mut SceneHandle,
    surface: *const SurfaceHandle,
    (positions, positions_len): (*mut f32, usize),
    (normals, normals_len): (*mut f32, usize),
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let (s, surf) = unsafe { (built(scene)?, surface::surface(surface)?) };
    if surf.mesh() != s.mesh {
        return Err(Status::InvalidHandle.into());
    }
    let n = surf.vertex_count();
    let with_normals = !normals.is_null();
    if positions_len / 3 < n || (with_normals && normals_len / 3 < n) {
        return Err(Status::BufferTooSmall.into());
    }
    disjoint(&[span(positions, positions_len), span(normals, normals_len)])?;
    if surf.overlaps::<f32>(positions as usize, positions_len)
        || (with_normals && surf.overlaps::<f32>(normals as usize, normals_len))
    {
        return Err(Status::Overlap.into());
    }
    // SAFETY: as above; checked (null, alignment, size, outside the scene
    // buffer) before a slice is formed.
    let (p, nrm) = unsafe {
        (
            output(positions.cast::<[f32; 3]>(), positions_len / 3, Some(s))?,
            if with_normals {
                Some(output(
                    normals.cast::<[f32; 3]>(),
                    normals_len / 3,
                    Some(s),
                )?)
            } else {
                None
            },
        )
    };
    let (bindings, triangles) = surf.parts();
    let p = p.get_mut(..n).ok_or(Status::BufferTooSmall)?;
    // The bindings name nodes of this mesh and the triangles were checked
    // when bound: neither call can fail half-way.
    s.scene.update_surface(bindings, p)?;
    if let Some(nrm) = nrm {
        let nrm = nrm.get_mut(..n).ok_or(Status::BufferTooSmall)?;
        corofem_core::vertex_normals(p, triangles, nrm)?;
    }
    Ok(())
}

#[cfg(not(feature = "surface"))]
unsafe fn update_surface(
    _: *mut SceneHandle,
    _: *const SurfaceHandle,
    _: (*mut f32, usize),
    _: (*mut f32, usize),
) -> Result<(), Failure> {
    Err(Status::Unsupported.into())
}

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
fn outside(set: &probe::Probes<'_>, parts: &[(usize, usize)]) -> Result<(), Status> {
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
/// it: the probe's index goes to `*out_probe` and the node's to
/// `*out_node` (either may be null). On that error, on
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
                    *o = node as usize;
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
