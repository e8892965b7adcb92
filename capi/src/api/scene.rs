//! A scene's memory and life cycle: its size, its initialisation in the
//! caller's buffer, its end, the generated box mesh, the build and the
//! counts.

use corofem_core::{BoxMesh, BuildOptions, Vec3};

use super::{built, status, vec3};
use crate::arena::{self, SceneHandle, Slots};
use crate::ptr::{disjoint, get, input, out, out_opt, output, span};
use crate::status::{Failure, Status};
#[cfg(feature = "surface")]
use crate::surface;
use crate::types::{Material, COROFEM_BUILD_REORIENT};

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
