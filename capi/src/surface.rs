//! An embedded surface inside memory the caller provides.
//!
//! ```text
//!  caller's buffer (any address, `corofem_surface_bytes` long)
//!  ┌─────┬────────────────┬───────────────────────┬──────────────────────┐
//!  │ pad │ SurfaceHandle  │ SurfaceBinding × V    │ [uint32_t; 3] × M    │
//!  │ 0–7 │ magic, buffer, │ 4 nodes, 4 weights,   │ the triangles, as    │
//!  │     │ mesh id, V, M  │ rest position (44 B)  │ validated at binding │
//!  └─────┴────────────────┴───────────────────────┴──────────────────────┘
//!        ▲ the handle: aligned to 8; the arrays follow at their own alignment
//! ```
//!
//! The buffer keeps its own copy of the triangles: the normals are computed
//! from them every frame, and a copy validated once cannot change between
//! frames (the caller's index array can be freed, or live in a GPU), so an
//! update never fails on them and never writes half its outputs.
//!
//! A surface is tied to the mesh it was bound to, not to a scene: the handle
//! records an id of that mesh (a hash of the positions and tetrahedra given
//! to `corofem_build`), and any scene built from the same mesh moves it. A
//! scene built from another mesh refuses it, since its bindings would name
//! other nodes.
//!
//! All the raw-pointer work on surface buffers is in this file.
//!
//! Without the feature `surface` only the handle's type is here, for the
//! functions' signatures, which then return `Status::Unsupported`.

#[cfg(feature = "surface")]
use core::alloc::Layout;
#[cfg(feature = "surface")]
use core::mem::size_of;
#[cfg(feature = "surface")]
use core::ptr;

#[cfg(feature = "surface")]
use corofem_core::{SurfaceBinding, Vec3};

#[cfg(feature = "surface")]
use crate::status::Status;

/// A live surface (a live scene is `0xC0FE_0001`).
#[cfg(feature = "surface")]
const MAGIC: u32 = 0xC0FE_0005;

/// The surface handle: the front of the caller's surface buffer. Opaque to C.
#[cfg_attr(not(feature = "surface"), allow(dead_code))]
pub struct SurfaceHandle {
    /// [`MAGIC`] while the surface is live; 0 while a bind into its buffer
    /// runs, and after one that failed.
    magic: u32,
    /// The address of this handle when it was made.
    this: usize,
    /// The caller's whole buffer `[start, end)`: output arrays must not
    /// overlap it.
    buffer: (usize, usize),
    /// The id of the mesh the surface was bound to ([`mesh_id`]).
    mesh: u64,
    /// Surface vertices (bindings).
    vertices: usize,
    /// Surface triangles.
    triangles: usize,
}

/// Where each part goes, relative to the aligned start.
#[cfg(feature = "surface")]
struct Plan {
    bindings: usize,
    triangles: usize,
    size: usize,
    align: usize,
}

#[cfg(feature = "surface")]
fn plan(vertices: usize, triangles: usize) -> Option<Plan> {
    let head = Layout::new::<SurfaceHandle>();
    let (l, b) = head
        .extend(Layout::array::<SurfaceBinding>(vertices).ok()?)
        .ok()?;
    let (l, t) = l.extend(Layout::array::<[u32; 3]>(triangles).ok()?).ok()?;
    Some(Plan {
        bindings: b,
        triangles: t,
        size: l.size(),
        align: l.align(),
    })
}

/// Bytes a buffer at any address needs for a surface of `vertices` vertices
/// and `triangles` triangles (plus `align − 1` bytes of slack), and the
/// length of the `u32` scratch binding needs. More vertices than `u32`
/// indexes, or sizes that do not fit, are [`Status::Capacity`].
#[cfg(feature = "surface")]
pub fn surface_bytes(vertices: usize, triangles: usize) -> Result<(usize, usize), Status> {
    if u32::try_from(vertices).is_err() {
        return Err(Status::Capacity);
    }
    let p = plan(vertices, triangles).ok_or(Status::Capacity)?;
    let bytes = p.size.checked_add(p.align - 1).ok_or(Status::Capacity)?;
    // `plan` holds 44 bytes per vertex within `isize::MAX`, so the
    // scratch's `3 vertices + 1` does not overflow.
    Ok((bytes, corofem_core::surface_scratch_len(vertices)))
}

/// The parts of a surface buffer before binding: the aligned handle's
/// address and the binding and triangle slots, initialised.
#[cfg(feature = "surface")]
pub struct Slots<'a> {
    handle: *mut SurfaceHandle,
    start: usize,
    end: usize,
    /// The binding slots, one per vertex.
    pub bindings: &'a mut [SurfaceBinding],
    /// The triangle slots.
    pub triangles: &'a mut [[u32; 3]],
}

/// Lays out a surface of `vertices` vertices and `triangles` triangles in
/// `buffer`: a surface bound there before is refused from then on, and the
/// slots are initialised for [`Slots::finish`].
///
/// # Safety
///
/// `buffer` is valid for writes of `bytes` bytes, and nothing else uses
/// that memory while the surface lives; `bytes` is at least
/// [`surface_bytes`]`(vertices, triangles)`.
#[cfg(feature = "surface")]
pub unsafe fn slots<'a>(
    buffer: *mut u8,
    bytes: usize,
    vertices: usize,
    triangles: usize,
) -> Result<Slots<'a>, Status> {
    if buffer.is_null() {
        return Err(Status::NullPointer);
    }
    let (need, _) = surface_bytes(vertices, triangles)?;
    let p = plan(vertices, triangles).ok_or(Status::Capacity)?;
    let start = buffer as usize;
    let end = start.checked_add(bytes).ok_or(Status::InvalidArgument)?;
    if bytes < need {
        return Err(Status::BufferTooSmall);
    }
    let pad = start.wrapping_neg() & (p.align - 1);
    // SAFETY: `pad + p.size <= need <= bytes`, so every pointer below stays
    // inside the caller's buffer; each is aligned for its type because
    // `plan` laid the parts out from an address aligned to `p.align`. The
    // magic number is written through a raw pointer before anything is
    // read, so a buffer that never held a surface is fine.
    unsafe {
        let base = buffer.add(pad);
        let handle = base.cast::<SurfaceHandle>();
        ptr::addr_of_mut!((*handle).magic).write(0);
        let b = base.add(p.bindings).cast::<SurfaceBinding>();
        let t = base.add(p.triangles).cast::<[u32; 3]>();
        for i in 0..vertices {
            b.add(i).write(SurfaceBinding::EMPTY);
        }
        for i in 0..triangles {
            t.add(i).write([0; 3]);
        }
        // Initialised, disjoint from each other and from the handle;
        // `'a` stands for "until the caller frees the buffer".
        Ok(Slots {
            handle,
            start,
            end,
            bindings: core::slice::from_raw_parts_mut(b, vertices),
            triangles: core::slice::from_raw_parts_mut(t, triangles),
        })
    }
}

#[cfg(feature = "surface")]
impl Slots<'_> {
    /// Writes the handle of a bound surface and returns it.
    pub fn finish(self, mesh: u64) -> *mut SurfaceHandle {
        let h = SurfaceHandle {
            magic: MAGIC,
            this: self.handle as usize,
            buffer: (self.start, self.end),
            mesh,
            vertices: self.bindings.len(),
            triangles: self.triangles.len(),
        };
        // SAFETY: `slots` made `handle` aligned, inside the buffer and
        // disjoint from the slots.
        unsafe { self.handle.write(h) };
        self.handle
    }
}

/// A live surface: its header, and the caller's pointer to it, through
/// which the arrays that follow it are reached (a reference to the header
/// covers the header only).
#[cfg(feature = "surface")]
pub struct Surface<'a> {
    head: &'a SurfaceHandle,
    ptr: *const SurfaceHandle,
}

/// The live surface behind a handle.
///
/// # Safety
///
/// `h` is null or points to at least `size_of::<SurfaceHandle>()` readable
/// bytes (a handle from [`Slots::finish`] whose buffer is still allocated,
/// or any other readable memory, which is then refused).
#[cfg(feature = "surface")]
pub unsafe fn surface<'a>(h: *const SurfaceHandle) -> Result<Surface<'a>, Status> {
    // SAFETY: the caller's contract.
    unsafe { crate::arena::check_stamp(h, MAGIC)? };
    // SAFETY: a live handle written by `finish` at this very address.
    let head = unsafe { &*h };
    Ok(Surface { head, ptr: h })
}

#[cfg(feature = "surface")]
crate::arena::stamped!(SurfaceHandle);

#[cfg(feature = "surface")]
impl Surface<'_> {
    /// The id of the mesh the surface was bound to.
    pub fn mesh(&self) -> u64 {
        self.head.mesh
    }

    /// The number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.head.vertices
    }

    /// Whether `len` elements of `T` at `addr` overlap the surface buffer.
    pub fn overlaps<T>(&self, addr: usize, len: usize) -> bool {
        let bytes = len.saturating_mul(size_of::<T>());
        let (start, end) = self.head.buffer;
        bytes > 0 && addr < end && addr.saturating_add(bytes) > start
    }

    /// The bindings and the triangles.
    pub fn parts(&self) -> (&[SurfaceBinding], &[[u32; 3]]) {
        let (n, m) = (self.head.vertices, self.head.triangles);
        let Some(p) = plan(n, m) else {
            return (&[], &[]);
        };
        let base = self.ptr.cast::<u8>();
        // SAFETY: a live handle: `finish` wrote it at the aligned start of
        // a buffer laid out by `plan` for these counts, with the slots
        // initialised; `ptr` is the caller's pointer into that buffer,
        // which stays allocated while the surface is used (the caller's
        // contract).
        unsafe {
            (
                core::slice::from_raw_parts(base.add(p.bindings).cast::<SurfaceBinding>(), n),
                core::slice::from_raw_parts(base.add(p.triangles).cast::<[u32; 3]>(), m),
            )
        }
    }
}

/// The id of a mesh: a 64-bit FNV-1a hash of the node and tetrahedron
/// counts, the bits of every coordinate and every index. Two builds from the
/// same arrays have the same id; bindings depend on nothing else.
#[cfg(feature = "surface")]
pub fn mesh_id(nodes: &[Vec3], tets: &[[u32; 4]]) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01B3;
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    let mut eat = |w: u64| h = (h ^ w).wrapping_mul(PRIME);
    eat(nodes.len() as u64);
    eat(tets.len() as u64);
    for p in nodes {
        for c in p {
            eat(u64::from(c.to_bits()));
        }
    }
    for t in tets {
        for &i in t {
            eat(u64::from(i));
        }
    }
    h
}

#[cfg(all(test, feature = "surface"))]
mod tests {
    use super::*;

    #[test]
    fn sizes_add_up() {
        let (b, s) = surface_bytes(10, 16).unwrap();
        let parts = size_of::<SurfaceHandle>()
            + 10 * size_of::<SurfaceBinding>()
            + 16 * size_of::<[u32; 3]>();
        assert_eq!(size_of::<SurfaceBinding>(), 44);
        assert!(b >= parts && b < parts + 8, "{b} vs {parts}");
        assert_eq!(s, 3 * 10 + 1);
        assert_eq!(surface_bytes(0, 0).unwrap().1, 2);
        assert_eq!(surface_bytes(usize::MAX / 8, 0), Err(Status::Capacity));
        assert_eq!(surface_bytes(1, usize::MAX / 8), Err(Status::Capacity));
    }

    #[test]
    fn mesh_ids_differ_with_any_bit() {
        let nodes = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let a = mesh_id(&nodes, &[[0, 1, 0, 1]]);
        assert_eq!(a, mesh_id(&nodes, &[[0, 1, 0, 1]]));
        assert_ne!(a, mesh_id(&nodes, &[[1, 0, 0, 1]]));
        assert_ne!(a, mesh_id(&[nodes[0], [-1.0, 0.0, 0.0]], &[[0, 1, 0, 1]]));
        assert_ne!(a, mesh_id(&nodes, &[]));
    }
}
