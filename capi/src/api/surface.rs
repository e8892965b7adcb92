//! Embedded surfaces (feature `surface`): their size, their binding to the
//! mesh and their motion with the body.

#[cfg(feature = "surface")]
use super::built;
use super::status;
use crate::arena::SceneHandle;
#[cfg(feature = "surface")]
use crate::ptr::{disjoint, input, out, out_opt, output, span};
use crate::status::{Failure, Status};
#[cfg(feature = "surface")]
use crate::surface;
use crate::surface::SurfaceHandle;
use crate::types::BindStats;

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
