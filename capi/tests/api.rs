//! Misuse of the C API: every bad handle, pointer, index, size or value is a
//! status code, and the scene is unchanged after it.

use std::ptr::{null, null_mut};

use corofem_capi::*;

#[cfg(feature = "surface")]
mod common;

const NODES: [[f32; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
];
const TETS: [[u32; 4]; 2] = [[0, 1, 2, 3], [1, 2, 3, 4]];
const MAT: Material = Material {
    young: 1.0e4,
    poisson: 0.3,
    density: 1000.0,
};

/// A scene buffer on the heap (8-aligned) and its handle.
struct Fixture {
    buf: Vec<u64>,
    h: *mut SceneHandle,
}

impl Fixture {
    fn new(n: usize, t: usize) -> Self {
        let mut bytes = 0;
        // SAFETY: out-pointer to a local; the buffer outlives the handle.
        unsafe {
            assert_eq!(corofem_scene_bytes(n, t, &mut bytes), Status::Ok);
            let mut buf = vec![0u64; bytes.div_ceil(8)];
            let mut h = null_mut();
            let st = corofem_scene_init(buf.as_mut_ptr().cast(), bytes, n, t, &mut h);
            assert_eq!(st, Status::Ok);
            Self { buf, h }
        }
    }

    fn built() -> Self {
        let f = Self::new(8, 4);
        assert_eq!(f.build(&NODES, &TETS, 0).0, Status::Ok);
        f
    }

    fn build(&self, nodes: &[[f32; 3]], tets: &[[u32; 4]], flags: u32) -> (Status, usize) {
        let mut at = usize::MAX;
        // SAFETY: slices of the stated lengths, a local out-pointer.
        let st = unsafe {
            corofem_build(
                self.h,
                nodes.as_ptr().cast(),
                nodes.len(),
                tets.as_ptr().cast(),
                tets.len(),
                &MAT,
                flags,
                &mut at,
            )
        };
        (st, at)
    }

    fn hash(&self) -> u64 {
        let mut h = 0;
        // SAFETY: a live handle, a local out-pointer.
        assert_eq!(unsafe { corofem_state_hash(self.h, &mut h) }, Status::Ok);
        h
    }
}

#[test]
fn sizing_and_init() {
    let mut bytes = 0;
    // SAFETY: every pointer is null, a local, or a buffer of the stated size.
    unsafe {
        assert_eq!(corofem_scene_bytes(4, 1, null_mut()), Status::NullPointer);
        assert_eq!(
            corofem_scene_bytes(0, 1, &mut bytes),
            Status::InvalidArgument
        );
        assert_eq!(corofem_scene_bytes(65_537, 1, &mut bytes), Status::Capacity);
        assert_eq!(
            corofem_scene_bytes(10, usize::MAX / 64, &mut bytes),
            Status::Capacity
        );
        assert_eq!(corofem_scene_bytes(4, 1, &mut bytes), Status::Ok);
        let mut buf = vec![0u8; bytes + 8];
        let mut h = null_mut();
        // Too small by one byte, at every offset.
        for off in 0..8 {
            let p = buf.as_mut_ptr().add(off).cast();
            assert_eq!(
                corofem_scene_init(p, bytes - 1, 4, 1, &mut h),
                Status::BufferTooSmall
            );
            assert_eq!(
                corofem_scene_init(p, bytes, 4, 1, &mut h),
                Status::Ok,
                "offset {off}"
            );
            assert_eq!(corofem_scene_deinit(h), Status::Ok);
        }
        assert_eq!(
            corofem_scene_init(null_mut(), bytes, 4, 1, &mut h),
            Status::NullPointer
        );
        let p = buf.as_mut_ptr().cast();
        assert_eq!(
            corofem_scene_init(p, bytes, 4, 1, null_mut()),
            Status::NullPointer
        );
        // The handle's out-pointer inside the buffer itself.
        let inside = buf.as_mut_ptr().add(8).cast();
        assert_eq!(corofem_scene_init(p, bytes, 4, 1, inside), Status::Overlap);
    }
}

/// A scene with 1 grab slot and 1 load slot: 16 bytes per slot fewer than
/// a slot of each kind per node, and one node more than a slot holds is
/// `Capacity` with the scene unchanged.
#[test]
fn sized_slots_hold_what_they_say() {
    let (n, t) = (8, 4);
    let (mut every, mut sized) = (0, 0);
    // SAFETY: locals and a heap buffer of the stated size; a live handle.
    unsafe {
        assert_eq!(corofem_scene_bytes(n, t, &mut every), Status::Ok);
        assert_eq!(
            corofem_scene_bytes_sized(n, t, 1, 1, &mut sized),
            Status::Ok
        );
        assert_eq!(every - sized, (2 * n - 2) * 16);
        assert_eq!(
            corofem_scene_bytes_sized(n, t, n + 1, 0, &mut sized),
            Status::InvalidArgument
        );
        assert_eq!(
            corofem_scene_bytes_sized(n, t, 1, 1, &mut sized),
            Status::Ok
        );
        let mut buf = vec![0u64; sized.div_ceil(8)];
        let mut h = null_mut();
        let st = corofem_scene_init_sized(buf.as_mut_ptr().cast(), sized, n, t, 1, 1, &mut h);
        assert_eq!(st, Status::Ok);
        let f = Fixture { buf, h };
        assert_eq!(f.build(&NODES, &TETS, 0).0, Status::Ok);
        // Base fixed, node 4 grabbed, a force on node 3, one step.
        let held_and_pushed = |h| {
            assert_eq!(corofem_fix_nodes(h, [0u32, 1, 2].as_ptr(), 3), Status::Ok);
            assert_eq!(corofem_grab(h, [4u32].as_ptr(), 1, 100.0), Status::Ok);
            let force = [0.0f32, 0.0, -1.0];
            assert_eq!(corofem_set_force(h, 3, force.as_ptr()), Status::Ok);
            assert_eq!(corofem_step(h, null_mut()), Status::Ok);
        };
        held_and_pushed(f.h);
        assert_eq!(
            corofem_grab(f.h, [3u32, 4].as_ptr(), 2, 100.0),
            Status::Capacity
        );
        assert_eq!(
            corofem_set_force(f.h, 4, [1.0f32; 3].as_ptr()),
            Status::Capacity
        );
        // The grab and the force still act as before the refused calls:
        // a second scene set up without them ends with the same bits.
        assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        let g = Fixture::built();
        held_and_pushed(g.h);
        assert_eq!(corofem_step(g.h, null_mut()), Status::Ok);
        assert_eq!(f.hash(), g.hash());
    }
}

#[test]
fn bad_handles_are_refused() {
    let f = Fixture::built();
    let mut zeros = vec![0u64; 512];
    let garbage: *mut SceneHandle = zeros.as_mut_ptr().cast();
    // SAFETY: every handle points to readable memory of handle size or is null.
    unsafe {
        assert_eq!(corofem_step(null_mut(), null_mut()), Status::NullPointer);
        assert_eq!(corofem_step(garbage, null_mut()), Status::InvalidHandle);
        let misaligned = f.h.cast::<u8>().add(1).cast();
        assert_eq!(corofem_step(misaligned, null_mut()), Status::InvalidHandle);
        // A copy of a live scene's bytes is not a scene.
        let mut copy = f.buf.clone();
        let offset = f.h as usize - f.buf.as_ptr() as usize;
        let moved = copy.as_mut_ptr().cast::<u8>().add(offset).cast();
        assert_eq!(corofem_step(moved, null_mut()), Status::InvalidHandle);
        assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        assert_eq!(corofem_scene_deinit(f.h), Status::Ok);
        assert_eq!(corofem_step(f.h, null_mut()), Status::InvalidHandle);
        assert_eq!(corofem_scene_deinit(f.h), Status::InvalidHandle);
    }
}

#[test]
fn unbuilt_scene_refuses_work() {
    let f = Fixture::new(8, 4);
    let mut out = [0.0f32; 24];
    // SAFETY: a live handle and local buffers.
    unsafe {
        assert_eq!(corofem_step(f.h, null_mut()), Status::NotBuilt);
        assert_eq!(
            corofem_positions(f.h, out.as_mut_ptr(), 24),
            Status::NotBuilt
        );
        assert_eq!(corofem_grab(f.h, [0u32].as_ptr(), 1, 1.0), Status::NotBuilt);
        // Settings may be set before the build.
        let mut s = std::mem::zeroed();
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        assert_eq!(corofem_set_settings(f.h, &s), Status::Ok);
    }
}

#[test]
fn mesh_errors_name_the_culprit() {
    let f = Fixture::new(8, 4);
    let inverted = [[0, 1, 2, 3], [1, 3, 2, 4]];
    assert_eq!(f.build(&NODES, &inverted, 0), (Status::InvertedElement, 1));
    assert_eq!(
        f.build(&NODES, &inverted, COROFEM_BUILD_REORIENT).0,
        Status::Ok
    );
    assert_eq!(f.build(&NODES, &TETS, 2).0, Status::InvalidArgument);
    assert_eq!(f.build(&NODES, &[[0, 1, 2, 3]], 0), (Status::UnusedNode, 4));
    assert_eq!(
        f.build(&NODES, &[[0, 1, 2, 3], [1, 2, 3, 9]], 0),
        (Status::IndexOutOfRange, 1)
    );
    assert_eq!(
        f.build(&NODES, &[[0, 1, 2, 3], [1, 2, 2, 4]], 0),
        (Status::RepeatedNode, 1)
    );
    let mut flat = NODES;
    flat[4] = [0.5, 0.5, 0.0];
    assert_eq!(
        f.build(&flat, &[[0, 1, 2, 3], [0, 1, 2, 4]], 0),
        (Status::DegenerateElement, 1)
    );
    let mut nan = NODES;
    nan[2][1] = f32::NAN;
    assert_eq!(f.build(&nan, &TETS, 0), (Status::NonFiniteCoordinate, 2));
    assert_eq!(f.build(&NODES, &[], 0).0, Status::NoElements);
    let big = vec![[0u32, 1, 2, 3]; 5];
    assert_eq!(f.build(&NODES, &big, 0).0, Status::Capacity);
}

#[test]
fn bad_pointers_and_indices_leave_the_scene_unchanged() {
    let f = Fixture::built();
    // SAFETY: a live handle; pointers are null, locals, or deliberately
    // misaligned / inside the scene buffer (refused before any access).
    unsafe {
        assert_eq!(corofem_fix_nodes(f.h, [0u32, 1, 2].as_ptr(), 3), Status::Ok);
        assert_eq!(corofem_grab(f.h, [4u32].as_ptr(), 1, 100.0), Status::Ok);
        for _ in 0..3 {
            assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        }
        let before = f.hash();
        let mut out = [0.0f32; 16];
        assert_eq!(
            corofem_fix_nodes(f.h, [7u32].as_ptr(), 1),
            Status::IndexOutOfRange
        );
        assert_eq!(corofem_fix_nodes(f.h, null(), 1), Status::NullPointer);
        assert_eq!(corofem_fix_nodes(f.h, null(), 0), Status::Ok);
        assert_eq!(
            corofem_grab(f.h, [5u32].as_ptr(), 1, 1.0),
            Status::IndexOutOfRange
        );
        assert_eq!(
            corofem_grab(f.h, [4u32].as_ptr(), 1, -1.0),
            Status::InvalidArgument
        );
        assert_eq!(
            corofem_set_force(f.h, 9, [0.0f32; 3].as_ptr()),
            Status::IndexOutOfRange
        );
        assert_eq!(corofem_set_young(f.h, 2, 1.0), Status::IndexOutOfRange);
        assert_eq!(
            corofem_set_elasticity(f.h, 1.0e4, 0.5),
            Status::InvalidArgument
        );
        assert_eq!(
            corofem_set_elasticity(f.h, -1.0, 0.3),
            Status::InvalidArgument
        );
        assert_eq!(
            corofem_position(f.h, 5, out.as_mut_ptr()),
            Status::IndexOutOfRange
        );
        assert_eq!(
            corofem_positions(f.h, out.as_mut_ptr(), 14),
            Status::BufferTooSmall
        );
        assert_eq!(corofem_positions(f.h, out.as_mut_ptr(), 15), Status::Ok);
        let odd = out.as_mut_ptr().cast::<u8>().add(1).cast();
        assert_eq!(corofem_positions(f.h, odd, 15), Status::Misaligned);
        // Arrays inside the scene buffer.
        let inside = f.h.cast::<u8>().add(64).cast::<f32>();
        assert_eq!(corofem_positions(f.h, inside, 15), Status::Overlap);
        assert_eq!(corofem_fix_nodes(f.h, inside.cast(), 1), Status::Overlap);
        let nan = [0.0, f32::NAN, 0.0f32];
        let mut force = [7.0f32; 3];
        let mut stats = Stats::default();
        let st = corofem_step_haptic(f.h, nan.as_ptr(), force.as_mut_ptr(), &mut stats);
        assert_eq!(st, Status::InvalidArgument);
        assert_eq!(force, [7.0; 3], "outputs untouched on error");
        let st = corofem_step_haptic(f.h, [0.0f32; 3].as_ptr(), odd, &mut stats);
        assert_eq!(st, Status::Misaligned);
        // Two outputs in the same memory.
        let both = (&mut stats as *mut Stats).cast::<f32>();
        let st = corofem_step_haptic(f.h, [0.0f32; 3].as_ptr(), both, &mut stats);
        assert_eq!(st, Status::Overlap);
        assert_eq!(corofem_set_method(f.h, 5), Status::InvalidArgument);
        let mut s = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        let good = s;
        s.dt = 0.0;
        assert_eq!(corofem_set_settings(f.h, &s), Status::InvalidArgument);
        s = good;
        s.method = 99;
        assert_eq!(corofem_set_settings(f.h, &s), Status::InvalidArgument);
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        assert_eq!(s, good);
        assert_eq!(f.hash(), before, "no error changed the state");
        assert_eq!(corofem_positions(f.h, out.as_mut_ptr(), 15), Status::Ok);
        let mut stats2 = Stats::default();
        assert_eq!(corofem_last_stats(f.h, &mut stats2), Status::Ok);
        assert_eq!(stats2.steps, 3);
    }
}

#[test]
fn methods_and_ground_switch() {
    let f = Fixture::built();
    // SAFETY: a live handle and locals.
    unsafe {
        assert_eq!(corofem_fix_nodes(f.h, [0u32, 1, 2].as_ptr(), 3), Status::Ok);
        for m in [
            MethodCode::Qr,
            MethodCode::Polar,
            MethodCode::Linear,
            MethodCode::QrRestB,
            MethodCode::QrInvertible,
        ] {
            assert_eq!(corofem_set_method(f.h, m as u32), Status::Ok, "{m:?}");
            let mut s = std::mem::zeroed::<Settings>();
            assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
            assert_eq!(s.method, m as u32);
            assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        }
        // Every preconditioner code is accepted and read back; an unknown
        // one is refused and leaves the settings as they were.
        for p in [
            PreconditionerCode::TwoLevel,
            PreconditionerCode::BlockJacobi,
            PreconditionerCode::Mass,
        ] {
            let mut s = std::mem::zeroed::<Settings>();
            assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
            s.preconditioner = p as u32;
            assert_eq!(corofem_set_settings(f.h, &s), Status::Ok, "{p:?}");
            let mut back = std::mem::zeroed::<Settings>();
            assert_eq!(corofem_get_settings(f.h, &mut back), Status::Ok);
            assert_eq!(back.preconditioner, p as u32);
            assert_eq!(corofem_step(f.h, null_mut()), Status::Ok, "{p:?}");
        }
        let mut s = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        let before = s;
        s.preconditioner = 3;
        assert_eq!(corofem_set_settings(f.h, &s), Status::InvalidArgument);
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        assert_eq!(s, before);
        let up = [0.0f32, 0.0, 1.0];
        assert_eq!(corofem_set_ground(f.h, up.as_ptr(), -0.5), Status::Ok);
        assert_eq!(
            corofem_set_ground(f.h, [0.0f32; 3].as_ptr(), 0.0),
            Status::InvalidArgument
        );
        // A plane above the free nodes (at z = 1): the step is refused,
        // nothing moves.
        let before = f.hash();
        assert_eq!(corofem_set_ground(f.h, up.as_ptr(), 1.5), Status::Ok);
        assert_eq!(corofem_step(f.h, null_mut()), Status::BelowGround);
        assert_eq!(f.hash(), before);
        assert_eq!(corofem_set_ground(f.h, null(), 0.0), Status::Ok);
        assert_eq!(corofem_set_elasticity(f.h, 2.0e4, 0.25), Status::Ok);
        assert_eq!(corofem_reset_state(f.h), Status::Ok);
        let mut stats = Stats::default();
        assert_eq!(corofem_last_stats(f.h, &mut stats), Status::Ok);
        assert_eq!(stats.steps, 0);
    }
}

#[test]
fn a_step_that_blows_up_is_refused() {
    let f = Fixture::built();
    // SAFETY: a live handle and locals.
    unsafe {
        let mut s = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
        s.dt = 1.0e30;
        s.gravity = [0.0, 0.0, -1.0e30];
        assert_eq!(corofem_set_settings(f.h, &s), Status::Ok);
        let before = f.hash();
        assert_eq!(corofem_step(f.h, null_mut()), Status::Diverged);
        assert_eq!(f.hash(), before);
    }
}

#[test]
fn box_mesh_and_messages() {
    let mut nodes = [0.0f32; 3 * 27];
    let mut tets = [0u32; 4 * 48];
    let (mut n, mut t) = (0, 0);
    // SAFETY: local arrays of the stated lengths.
    unsafe {
        let size = [1.0f32; 3].as_ptr();
        let cells = [2u32; 3].as_ptr();
        assert_eq!(
            corofem_box_mesh_counts(cells, 6, &mut n, &mut t),
            Status::Ok
        );
        assert_eq!((n, t), (27, 48));
        let (np, tp) = (nodes.as_mut_ptr(), tets.as_mut_ptr());
        assert_eq!(
            corofem_box_mesh(size, cells, 6, np, 80, tp, 192, &mut n, &mut t),
            Status::BufferTooSmall
        );
        assert_eq!(
            corofem_box_mesh(size, cells, 6, np, 81, tp, 191, &mut n, &mut t),
            Status::BufferTooSmall
        );
        assert_eq!(
            corofem_box_mesh(size, cells, 7, np, 81, tp, 192, &mut n, &mut t),
            Status::InvalidArgument
        );
        assert_eq!(
            corofem_box_mesh(size, cells, 6, np, 81, tp, 192, null_mut(), null_mut()),
            Status::Ok
        );
        assert_eq!(nodes[3 * 26..], [1.0, 1.0, 1.0]);
        for code in -21..=1 {
            let s = std::ffi::CStr::from_ptr(corofem_status_str(code));
            assert!(!s.to_bytes().is_empty());
        }
        let ok = std::ffi::CStr::from_ptr(corofem_status_str(0));
        assert_eq!(ok.to_str().unwrap(), "ok");
    }
}

/// `corofem_set_positions` takes exactly the scene's node count of finite
/// positions, and refuses anything else with the scene unchanged.
#[test]
fn set_positions_checks_its_input() {
    let f = Fixture::built();
    let before = f.hash();
    let mut p = NODES;
    // SAFETY: a live handle; arrays of the stated lengths, or null.
    unsafe {
        assert_eq!(
            corofem_set_positions(f.h, p.as_ptr().cast(), 4),
            Status::InvalidArgument
        );
        assert_eq!(corofem_set_positions(f.h, null(), 5), Status::NullPointer);
        let odd = p.as_ptr().cast::<u8>().add(1).cast::<f32>();
        assert_eq!(corofem_set_positions(f.h, odd, 4), Status::Misaligned);
        let inside = f.h.cast::<u8>().add(64).cast::<f32>();
        assert_eq!(corofem_set_positions(f.h, inside, 5), Status::Overlap);
        p[1][0] = f32::INFINITY;
        assert_eq!(
            corofem_set_positions(f.h, p.as_ptr().cast(), 5),
            Status::InvalidArgument
        );
        assert_eq!(f.hash(), before);
        let unbuilt = Fixture::new(8, 4);
        assert_eq!(
            corofem_set_positions(unbuilt.h, NODES.as_ptr().cast(), 5),
            Status::NotBuilt
        );
        p = NODES;
        p[4] = [1.5, 1.0, 1.0];
        assert_eq!(corofem_set_positions(f.h, p.as_ptr().cast(), 5), Status::Ok);
        let mut x = [0.0f32; 3];
        assert_eq!(corofem_position(f.h, 4, x.as_mut_ptr()), Status::Ok);
        assert_eq!(x, [1.5, 1.0, 1.0]);
    }
}

/// Without the feature `surface` the surface functions are there, and say
/// so.
#[cfg(not(feature = "surface"))]
#[test]
fn surfaces_are_unsupported_without_the_feature() {
    let f = Fixture::built();
    let (mut bytes, mut scratch) = (0, 0);
    let mut out = [0.0f32; 3];
    // SAFETY: a live handle and locals; nothing is read or written.
    unsafe {
        assert_eq!(
            corofem_surface_bytes(1, 0, &mut bytes, &mut scratch),
            Status::Unsupported
        );
        let mut h = null_mut();
        let st = corofem_bind_surface(
            f.h,
            [0.1f32; 3].as_ptr(),
            1,
            null(),
            0,
            0.0,
            null_mut(),
            0,
            null_mut(),
            0,
            &mut h,
            null_mut(),
            null_mut(),
        );
        assert_eq!(st, Status::Unsupported);
        let st = corofem_update_surface(f.h, null(), out.as_mut_ptr(), 3, null_mut(), 0);
        assert_eq!(st, Status::Unsupported);
    }
}

/// Embedded surfaces through the C functions: binding, moving with the
/// body, normals, and every misuse.
#[cfg(feature = "surface")]
mod surface {
    use super::*;

    use crate::common::shared_mesh;

    /// A small tetrahedron inside `TETS[0]`, outward triangles.
    const SKIN: [[f32; 3]; 4] = [
        [0.1, 0.1, 0.1],
        [0.5, 0.1, 0.1],
        [0.1, 0.5, 0.1],
        [0.1, 0.1, 0.5],
    ];
    const SKIN_TRIS: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

    /// A surface buffer on the heap (8-aligned, 8 spare bytes so it can
    /// start at any offset), its scratch, and a handle once bound.
    struct Skin {
        buf: Vec<u64>,
        bytes: usize,
        scratch: Vec<u32>,
        h: *mut SurfaceHandle,
    }

    /// The result of one `corofem_bind_surface`.
    #[derive(Debug, PartialEq)]
    struct Bound {
        status: Status,
        stats: BindStats,
        at: usize,
    }

    const NO_STATS: BindStats = BindStats {
        inside: 77,
        outside: 77,
        max_distance: 77.0,
        farthest_vertex: 77,
    };

    impl Skin {
        fn new(vertices: usize, triangles: usize) -> Self {
            let (mut bytes, mut scratch) = (0, 0);
            // SAFETY: out-pointers to locals.
            let st =
                unsafe { corofem_surface_bytes(vertices, triangles, &mut bytes, &mut scratch) };
            assert_eq!(st, Status::Ok);
            Self {
                buf: vec![0u64; bytes.div_ceil(8) + 1],
                bytes,
                scratch: vec![0u32; scratch],
                h: null_mut(),
            }
        }

        /// Binds at byte offset `off` of the buffer; the handle is kept
        /// only on success.
        fn bind_at(
            &mut self,
            f: &Fixture,
            vertices: &[[f32; 3]],
            tris: &[[u32; 3]],
            reach: f32,
            off: usize,
        ) -> Bound {
            let mut h = null_mut();
            let mut stats = NO_STATS;
            let mut at = usize::MAX;
            // SAFETY: arrays of the stated lengths; the buffer has `bytes`
            // bytes from any offset below 8.
            let status = unsafe {
                corofem_bind_surface(
                    f.h,
                    vertices.as_ptr().cast(),
                    vertices.len(),
                    tris.as_ptr().cast(),
                    tris.len(),
                    reach,
                    self.buf.as_mut_ptr().cast::<u8>().add(off).cast(),
                    self.bytes,
                    self.scratch.as_mut_ptr(),
                    self.scratch.len(),
                    &mut h,
                    &mut stats,
                    &mut at,
                )
            };
            if status == Status::Ok {
                self.h = h;
            } else {
                assert!(h.is_null(), "no handle out on error");
                assert_eq!(stats, NO_STATS, "no statistics out on error");
            }
            Bound { status, stats, at }
        }

        fn bind(
            &mut self,
            f: &Fixture,
            vertices: &[[f32; 3]],
            tris: &[[u32; 3]],
            reach: f32,
        ) -> Bound {
            self.bind_at(f, vertices, tris, reach, 0)
        }
    }

    /// Positions and normals.
    type Frame = (Vec<[f32; 3]>, Vec<[f32; 3]>);

    /// The frame of a surface of `n` vertices, or the status.
    fn update(f: &Fixture, h: *const SurfaceHandle, n: usize) -> Result<Frame, Status> {
        let mut p = vec![[9.0f32; 3]; n];
        let mut q = vec![[9.0f32; 3]; n];
        // SAFETY: outputs of the stated lengths.
        let st = unsafe {
            corofem_update_surface(
                f.h,
                h,
                p.as_mut_ptr().cast(),
                3 * n,
                q.as_mut_ptr().cast(),
                3 * n,
            )
        };
        if st == Status::Ok {
            Ok((p, q))
        } else {
            assert!(
                p.iter().chain(&q).all(|v| *v == [9.0; 3]),
                "outputs untouched"
            );
            Err(st)
        }
    }

    /// One pointer to the byte after `p`: misaligned for anything larger.
    fn odd<T>(p: *const T) -> *const T {
        p.cast::<u8>().wrapping_add(1).cast()
    }

    fn odd_mut<T>(p: *mut T) -> *mut T {
        p.cast::<u8>().wrapping_add(1).cast()
    }

    /// The arguments of a `corofem_bind_surface` of 4 vertices and 4
    /// triangles, to vary one at a time.
    #[derive(Clone, Copy)]
    struct BindArgs {
        scene: *mut SceneHandle,
        vertices: *const [f32; 3],
        triangles: *const [u32; 3],
        reach: f32,
        buffer: *mut u8,
        bytes: usize,
        scratch: *mut u32,
        scratch_len: usize,
        out: *mut *mut SurfaceHandle,
    }

    impl BindArgs {
        /// The status; checks that the statistics and the culprit's index
        /// were not written.
        fn call(self) -> Status {
            let mut stats = NO_STATS;
            let mut at = usize::MAX;
            // SAFETY: every pointer is null, misaligned, inside another
            // buffer (all refused before any access), or an array of the
            // stated length.
            let st = unsafe {
                corofem_bind_surface(
                    self.scene,
                    self.vertices.cast(),
                    4,
                    self.triangles.cast(),
                    4,
                    self.reach,
                    self.buffer.cast(),
                    self.bytes,
                    self.scratch,
                    self.scratch_len,
                    self.out,
                    &mut stats,
                    &mut at,
                )
            };
            assert_eq!(
                (stats, at),
                (NO_STATS, usize::MAX),
                "{st:?}: outputs untouched"
            );
            st
        }
    }

    /// The arguments of a `corofem_update_surface`, to vary one at a time.
    #[derive(Clone, Copy)]
    struct UpdateArgs {
        scene: *mut SceneHandle,
        surface: *const SurfaceHandle,
        positions: *mut f32,
        positions_len: usize,
        normals: *mut f32,
        normals_len: usize,
    }

    impl UpdateArgs {
        fn call(self) -> Status {
            // SAFETY: as in `BindArgs::call`.
            unsafe {
                corofem_update_surface(
                    self.scene,
                    self.surface,
                    self.positions,
                    self.positions_len,
                    self.normals,
                    self.normals_len,
                )
            }
        }
    }

    type V3 = [f64; 3];

    fn sub(a: V3, b: V3) -> V3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn cross(a: V3, b: V3) -> V3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    fn dot(a: V3, b: V3) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn norm(a: V3) -> f64 {
        dot(a, a).sqrt()
    }

    fn wide(p: [f32; 3]) -> V3 {
        p.map(f64::from)
    }

    /// A detailed surface over a tetrahedral mesh: its boundary triangles
    /// (faces of one tetrahedron only, turned outward), each split into
    /// four at its edge midpoints, and the vertices pushed `offset` (m)
    /// along their normals, every other one outward (most of those then lie
    /// just outside the mesh) and the others inward.
    fn skin_of(
        nodes: &[[f32; 3]],
        tets: &[[u32; 4]],
        offset: f64,
    ) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        use std::collections::HashMap;
        let mut faces: HashMap<[u32; 3], ([u32; 3], usize)> = HashMap::new();
        for t in tets {
            for (k, face) in [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]
                .iter()
                .enumerate()
            {
                let mut f = face.map(|i| t[i]);
                let [a, b, c] = f.map(|i| wide(nodes[i as usize]));
                let away = sub(wide(nodes[t[k] as usize]), a);
                if dot(cross(sub(b, a), sub(c, a)), away) > 0.0 {
                    f.swap(1, 2);
                }
                let mut key = f;
                key.sort_unstable();
                faces.entry(key).or_insert((f, 0)).1 += 1;
            }
        }
        let mut boundary: Vec<[u32; 3]> = faces
            .values()
            .filter(|(_, c)| *c == 1)
            .map(|(f, _)| *f)
            .collect();
        boundary.sort_unstable();
        let mut index: HashMap<(u32, u32), u32> = HashMap::new();
        let mut verts: Vec<V3> = Vec::new();
        let mut vertex = |a: u32, b: u32, verts: &mut Vec<V3>| {
            let key = (a.min(b), a.max(b));
            *index.entry(key).or_insert_with(|| {
                let p = wide(nodes[a as usize]);
                let q = wide(nodes[b as usize]);
                verts.push([
                    0.5 * (p[0] + q[0]),
                    0.5 * (p[1] + q[1]),
                    0.5 * (p[2] + q[2]),
                ]);
                (verts.len() - 1) as u32
            })
        };
        let mut tris = Vec::new();
        for [a, b, c] in boundary {
            let (a2, b2, c2) = (
                vertex(a, a, &mut verts),
                vertex(b, b, &mut verts),
                vertex(c, c, &mut verts),
            );
            let (ab, bc, ca) = (
                vertex(a, b, &mut verts),
                vertex(b, c, &mut verts),
                vertex(c, a, &mut verts),
            );
            tris.extend([[a2, ab, ca], [ab, b2, bc], [ca, bc, c2], [ab, bc, ca]]);
        }
        let mut normals = vec![[0.0f64; 3]; verts.len()];
        for t in &tris {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            for &i in t {
                let m = &mut normals[i as usize];
                *m = [m[0] + n[0], m[1] + n[1], m[2] + n[2]];
            }
        }
        let out = verts
            .iter()
            .zip(&normals)
            .enumerate()
            .map(|(i, (p, n))| {
                let s = if i % 2 == 0 { offset } else { -offset } / norm(*n);
                [0, 1, 2].map(|k| (p[k] + s * n[k]) as f32)
            })
            .collect();
        (out, tris)
    }

    /// A scene of `nodes` and `tets` through the C functions.
    fn scene_of(nodes: &[[f32; 3]], tets: &[[u32; 4]]) -> Fixture {
        let f = Fixture::new(nodes.len(), tets.len());
        assert_eq!(f.build(nodes, tets, 0).0, Status::Ok);
        f
    }

    /// The Stanford bunny (fTetWild, 397 nodes, 1 027 tetrahedra, metres)
    /// with a detailed skin, its vertices 0.5 mm outside or inside its
    /// boundary, bound with a reach of 2 mm, then moved by an affine map
    /// set through `corofem_set_positions`: every vertex lands on `A v + t`
    /// within f32 round-off, the positions and normals are the Rust API's
    /// bit for bit, and the normals have unit length.
    #[test]
    fn a_skin_follows_an_affine_motion_of_the_bunny() {
        let Some(path) = shared_mesh("bunny_ftw_1k.tetmesh") else {
            return;
        };
        let mesh = corofem_io::read_mesh(&path).unwrap();
        let (nodes, tets) = corofem_io::to_core(&mesh, 1.0);
        let (verts, tris) = skin_of(&nodes, &tets, 0.5e-3);
        let reach = 2.0e-3;
        let n = verts.len();
        let f = scene_of(&nodes, &tets);
        let mut skin = Skin::new(n, tris.len());
        let bound = skin.bind(&f, &verts, &tris, reach);
        assert_eq!(bound.status, Status::Ok);
        let st = bound.stats;
        println!(
            "bunny skin: {n} vertices, {} triangles, {} B + {} B of scratch; {st:?}",
            tris.len(),
            skin.bytes,
            4 * skin.scratch.len()
        );
        assert_eq!((st.inside + st.outside) as usize, n);
        assert!(st.inside > 0 && st.outside > 0);
        assert!(st.max_distance > 0.0 && st.max_distance <= reach);

        // The Rust API on the same mesh: the reference, and the weights.
        let mut rust = corofem_core::VecScene::with_capacity(nodes.len(), tets.len());
        let material = corofem_core::Material {
            young: MAT.young,
            poisson: MAT.poisson,
            density: MAT.density,
        };
        rust.build(
            &nodes,
            &tets,
            &material,
            corofem_core::BuildOptions::default(),
        )
        .unwrap();
        let mut bindings = vec![corofem_core::SurfaceBinding::EMPTY; n];
        let mut scratch = vec![0u32; corofem_core::surface_scratch_len(n)];
        let rust_stats = rust
            .bind_surface(&verts, &tris, reach, &mut scratch, &mut bindings)
            .unwrap();
        assert_eq!(
            (
                rust_stats.inside,
                rust_stats.outside,
                rust_stats.max_distance
            ),
            (st.inside, st.outside, st.max_distance)
        );

        // At rest every vertex is where it was given, bit for bit.
        let (p, normals) = update(&f, skin.h, n).unwrap();
        assert_eq!(p, verts);
        for m in &normals {
            assert!((norm(wide(*m)) - 1.0).abs() < 1e-6, "{m:?}");
        }

        // An affine map: a rotation of 40° about (1, 2, 2)/3, a stretch and
        // a shear, and a translation larger than the bunny.
        let (c, s) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
        let k = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
        let rot: [V3; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let cross_term = match (i, j) {
                    (0, 1) => -k[2],
                    (0, 2) => k[1],
                    (1, 0) => k[2],
                    (1, 2) => -k[0],
                    (2, 0) => -k[1],
                    (2, 1) => k[0],
                    _ => 0.0,
                };
                let id = if i == j { c } else { 0.0 };
                id + s * cross_term + (1.0 - c) * k[i] * k[j]
            })
        });
        let stretch = [[1.2, 0.1, 0.0], [0.0, 0.8, -0.05], [0.0, 0.0, 1.1]];
        let a: [V3; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|l| rot[i][l] * stretch[l][j]).sum())
        });
        let t = [0.3, -0.1, 0.25];
        let map = |x: V3| -> V3 { std::array::from_fn(|i| dot(a[i], x) + t[i]) };
        let moved: Vec<[f32; 3]> = nodes
            .iter()
            .map(|x| map(wide(*x)).map(|c| c as f32))
            .collect();
        let before = f.hash();
        // SAFETY: a live handle and an array of the scene's node count.
        let st = unsafe { corofem_set_positions(f.h, moved.as_ptr().cast(), moved.len()) };
        assert_eq!(st, Status::Ok);
        assert_ne!(f.hash(), before);
        let (p, normals) = update(&f, skin.h, n).unwrap();

        // Bound on |p − (A v + t)| per coordinate. With exact weights the
        // update `v + Σ wᵢ uᵢ`, uᵢ = A xᵢ + t − xᵢ, is exactly A v + t
        // (Σ wᵢ = 1, Σ wᵢ xᵢ = v). In f32 (ε = 2⁻²³, each rounding ≤ ε/2 of
        // its result): the node positions set, ε/2 |xᵢ'|; the displacements
        // the scene keeps, ε/2 |uᵢ|; the weights stored as f32, ε/2 |wᵢ|;
        // the four multiply-adds, ε/2 each of |wᵢ uᵢ| and of the partial sum
        // ≤ |v| + Σ |wᵢ| |uᵢ|. With W = Σ |wᵢ| (1 inside, a little more for
        // the vertices extrapolated outside), X = max |xᵢ'|, U = max |uᵢ|:
        // error ≤ ε (W X / 2 + 3.5 W U + 2 |v|), so 8 ε W (X + U + |v|) has
        // a margin of more than 2 (and the weights' own f64 error, ~1e-16 ×
        // the element's aspect, is far below).
        let eps = f64::from(f32::EPSILON);
        let mut worst = 0.0f64;
        for (i, b) in bindings.iter().enumerate() {
            let w_sum: f64 = b.weights().iter().map(|w| f64::from(w.abs())).sum();
            let x_max = b
                .nodes()
                .iter()
                .map(|&j| norm(wide(moved[j as usize])))
                .fold(0.0, f64::max);
            let u_max = b
                .nodes()
                .iter()
                .map(|&j| norm(sub(wide(moved[j as usize]), wide(nodes[j as usize]))))
                .fold(0.0, f64::max);
            let v = wide(verts[i]);
            let tol = 8.0 * eps * w_sum * (x_max + u_max + norm(v));
            let want = map(v);
            let err = (0..3)
                .map(|k| (f64::from(p[i][k]) - want[k]).abs())
                .fold(0.0, f64::max);
            assert!(err <= tol, "vertex {i}: error {err:e} m > {tol:e} m");
            worst = worst.max(err / tol);
        }
        println!("affine motion: worst error {worst:.3} of the bound");

        // The Rust API gives the same bits, positions and normals.
        rust.set_positions(&moved).unwrap();
        let mut rp = vec![[0.0f32; 3]; n];
        rust.update_surface(&bindings, &mut rp).unwrap();
        let mut rn = vec![[0.0f32; 3]; n];
        corofem_core::vertex_normals(&rp, &tris, &mut rn).unwrap();
        assert_eq!(p, rp);
        assert_eq!(normals, rn);
        for m in &normals {
            assert!((norm(wide(*m)) - 1.0).abs() < 1e-6, "{m:?}");
        }

        // The surface belongs to the mesh: a second scene of the same mesh
        // moves it, and so does this one rebuilt; another mesh refuses it.
        let g = scene_of(&nodes, &tets);
        // SAFETY: a live handle and an array of the scene's node count.
        let st = unsafe { corofem_set_positions(g.h, moved.as_ptr().cast(), moved.len()) };
        assert_eq!(st, Status::Ok);
        assert_eq!(update(&g, skin.h, n).unwrap().0, p);
        let scaled: Vec<[f32; 3]> = nodes.iter().map(|x| x.map(|c| 1.5 * c)).collect();
        assert_eq!(g.build(&scaled, &tets, 0).0, Status::Ok);
        assert_eq!(update(&g, skin.h, n), Err(Status::InvalidHandle));
        assert_eq!(g.build(&nodes, &tets, 0).0, Status::Ok);
        assert_eq!(update(&g, skin.h, n).unwrap().0, verts, "rebuilt: at rest");
    }

    /// A skin on the liver as the C example scales it, bound at every
    /// buffer offset: the same bindings wherever the buffer starts.
    #[test]
    fn a_skin_of_the_liver_binds_at_any_address() {
        let Some(path) = shared_mesh("sofa_liver.tetmesh") else {
            return;
        };
        let mesh = corofem_io::read_mesh(&path).unwrap();
        let (nodes, tets) = corofem_io::to_core(&mesh, 0.03);
        let (verts, tris) = skin_of(&nodes, &tets, 0.0);
        let f = scene_of(&nodes, &tets);
        let mut skin = Skin::new(verts.len(), tris.len());
        let mut first = None;
        for off in 0..8 {
            let bound = skin.bind_at(&f, &verts, &tris, 1.0e-3, off);
            assert_eq!(bound.status, Status::Ok, "offset {off}");
            let out = update(&f, skin.h, verts.len()).unwrap();
            assert_eq!(out.0, verts);
            assert_eq!(*first.get_or_insert(out.clone()), out);
        }
    }

    #[test]
    fn bad_binds_change_nothing() {
        let f = Fixture::built();
        let mut good = Skin::new(4, 4);
        assert_eq!(good.bind(&f, &SKIN, &SKIN_TRIS, 0.0).status, Status::Ok);
        let (rest, _) = update(&f, good.h, 4).unwrap();
        assert_eq!(rest, SKIN);
        // SAFETY: a live handle; locals.
        unsafe {
            assert_eq!(corofem_fix_nodes(f.h, [0u32, 1, 2].as_ptr(), 3), Status::Ok);
            assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        }
        let moved = update(&f, good.h, 4).unwrap();
        let before = f.hash();

        // Errors in the arguments: nothing changes, the buffer included.
        let mut skin = Skin::new(4, 4);
        let mut h = null_mut();
        let ok = BindArgs {
            scene: f.h,
            vertices: SKIN.as_ptr().cast(),
            triangles: SKIN_TRIS.as_ptr().cast(),
            reach: 0.0,
            buffer: skin.buf.as_mut_ptr().cast(),
            bytes: skin.bytes,
            scratch: skin.scratch.as_mut_ptr(),
            scratch_len: skin.scratch.len(),
            out: &mut h,
        };
        let unbuilt = Fixture::new(8, 4);
        let mut zeros = vec![0u64; 512];
        let in_scene = f.h.cast::<u8>().wrapping_add(64);
        let in_buf = ok.buffer.wrapping_add(64);
        let pristine = skin.buf.clone();
        let check = |what: &str, want: Status, args: BindArgs| {
            assert_eq!(args.call(), want, "{what}");
            assert!(h.is_null(), "{what}: no handle out");
            assert_eq!(skin.buf, pristine, "{what}: the buffer is untouched");
            assert_eq!(f.hash(), before, "{what}: the scene is unchanged");
        };
        // `ok` with some arguments replaced.
        macro_rules! bind {
            ($what:expr, $want:ident, $($field:ident: $value:expr),+) => {
                check($what, Status::$want, BindArgs { $($field: $value),+, ..ok })
            };
        }
        bind!("null scene", NullPointer, scene: null_mut());
        bind!("garbage scene", InvalidHandle, scene: zeros.as_mut_ptr().cast());
        bind!("unbuilt scene", NotBuilt, scene: unbuilt.h);
        bind!("null vertices", NullPointer, vertices: null());
        bind!("null triangles", NullPointer, triangles: null());
        bind!("null buffer", NullPointer, buffer: null_mut());
        bind!("null scratch", NullPointer, scratch: null_mut());
        bind!("null handle out", NullPointer, out: null_mut());
        bind!("misaligned vertices", Misaligned, vertices: odd(ok.vertices));
        bind!("misaligned triangles", Misaligned, triangles: odd(ok.triangles));
        // One value fewer, so that the misaligned array stays inside the scratch.
        let short = ok.scratch_len - 1;
        bind!("misaligned scratch", Misaligned, scratch: odd_mut(ok.scratch), scratch_len: short);
        bind!("misaligned handle out", Misaligned, out: odd_mut(ok.out));
        bind!("buffer one byte short", BufferTooSmall, bytes: ok.bytes - 1);
        bind!("scratch one value short", BufferTooSmall, scratch_len: ok.scratch_len - 1);
        bind!("buffer in the scene", Overlap, buffer: in_scene);
        bind!("scratch in the scene", Overlap, scratch: in_scene.cast());
        bind!("scratch in the buffer", Overlap, scratch: in_buf.cast());
        bind!("vertices in the buffer", Overlap, vertices: in_buf.cast());
        bind!("handle out in the buffer", Overlap, out: in_buf.cast());
        bind!("negative reach", InvalidArgument, reach: -1.0);
        bind!("NaN reach", InvalidArgument, reach: f32::NAN);
        bind!("infinite reach", InvalidArgument, reach: f32::INFINITY);

        // Errors in the surface: typed, the culprit named, the scene
        // unchanged; the buffer then holds no surface.
        let mut nan = SKIN;
        nan[2][1] = f32::NAN;
        let mut far = SKIN;
        far[3] = [0.0, 0.0, 3.0];
        let cases = [
            (nan, SKIN_TRIS, 0.0, Status::NonFiniteCoordinate, 2),
            (far, SKIN_TRIS, 1.0, Status::VertexTooFar, 3),
            (
                SKIN,
                [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 4]],
                0.0,
                Status::IndexOutOfRange,
                3,
            ),
            (
                SKIN,
                [[0, 2, 1], [0, 1, 1], [0, 3, 2], [1, 2, 3]],
                0.0,
                Status::DegenerateTriangle,
                1,
            ),
        ];
        for (verts, tris, reach, want, at) in cases {
            assert_eq!(skin.bind(&f, &SKIN, &SKIN_TRIS, 0.0).status, Status::Ok);
            let old = skin.h;
            let got = skin.bind(&f, &verts, &tris, reach);
            assert_eq!((got.status, got.at), (want, at), "{want:?}");
            assert_eq!(f.hash(), before, "{want:?}: the scene is unchanged");
            assert_eq!(update(&f, old, 4), Err(Status::InvalidHandle), "{want:?}");
            assert_eq!(
                update(&f, good.h, 4),
                Ok(moved.clone()),
                "{want:?}: other surfaces unchanged"
            );
        }
        // Collinear corners, and a vertex 2 m out with the reach 1 m.
        let mut flat = SKIN;
        flat[3] = [0.3, 0.1, 0.1];
        let got = skin.bind(&f, &flat, &[[0, 1, 3]], 0.0);
        assert_eq!((got.status, got.at), (Status::DegenerateTriangle, 0));
        let mut far = SKIN;
        far[1] = [-2.0, 0.0, 0.0];
        let got = skin.bind(&f, &far, &SKIN_TRIS, 1.0);
        assert_eq!((got.status, got.at), (Status::VertexTooFar, 1));
        // Within its reach the same vertex binds, 2 m out.
        let got = skin.bind(&f, &far, &SKIN_TRIS, 2.5);
        assert_eq!(got.status, Status::Ok);
        assert_eq!(
            (
                got.stats.inside,
                got.stats.outside,
                got.stats.farthest_vertex
            ),
            (3, 1, 1)
        );
        assert!((got.stats.max_distance - 2.0).abs() < 1e-6);
        assert_eq!(f.hash(), before);

        let (mut bytes, mut scratch) = (0, 0);
        // SAFETY: out-pointers to locals, or null.
        unsafe {
            assert_eq!(
                corofem_surface_bytes(u32::MAX as usize + 1, 0, &mut bytes, &mut scratch),
                Status::Capacity
            );
            assert_eq!(
                corofem_surface_bytes(4, 4, null_mut(), &mut scratch),
                Status::NullPointer
            );
            assert_eq!(
                corofem_surface_bytes(4, 4, &mut bytes, null_mut()),
                Status::NullPointer
            );
            let both: *mut usize = &mut bytes;
            assert_eq!(corofem_surface_bytes(4, 4, both, both), Status::Overlap);
            assert_eq!(
                corofem_surface_bytes(0, 0, &mut bytes, &mut scratch),
                Status::Ok
            );
            assert_eq!(scratch, 2);
        }
    }

    #[test]
    fn bad_updates_write_nothing() {
        let f = Fixture::built();
        let mut skin = Skin::new(4, 4);
        assert_eq!(skin.bind(&f, &SKIN, &SKIN_TRIS, 0.0).status, Status::Ok);
        let h = skin.h;
        // SAFETY: a live handle; locals.
        unsafe {
            assert_eq!(corofem_fix_nodes(f.h, [0u32, 1, 2].as_ptr(), 3), Status::Ok);
            assert_eq!(corofem_step(f.h, null_mut()), Status::Ok);
        }
        let before = f.hash();
        let (p, n) = update(&f, h, 4).unwrap();
        assert_ne!(p, SKIN, "the body moved");
        let mut out = [[9.0f32; 3]; 8];
        let mut nrm = [[9.0f32; 3]; 8];
        let ok = UpdateArgs {
            scene: f.h,
            surface: h,
            positions: out.as_mut_ptr().cast(),
            positions_len: 12,
            normals: nrm.as_mut_ptr().cast(),
            normals_len: 12,
        };
        let unbuilt = Fixture::new(8, 4);
        let other = Fixture::new(8, 4);
        let mut shifted = NODES;
        shifted[4][0] += 0.5;
        assert_eq!(other.build(&shifted, &TETS, 0).0, Status::Ok);
        let in_scene = f.h.cast::<u8>().wrapping_add(64).cast::<f32>();
        let in_skin = h.cast::<u8>().wrapping_add(64).cast::<f32>();
        let mut zeros = vec![0u64; 512];
        let check = |what: &str, want: Status, args: UpdateArgs| {
            assert_eq!(args.call(), want, "{what}");
            assert_eq!(out, [[9.0; 3]; 8], "{what}: positions untouched");
            assert_eq!(nrm, [[9.0; 3]; 8], "{what}: normals untouched");
            assert_eq!(f.hash(), before, "{what}: the scene is unchanged");
        };
        macro_rules! update {
            ($what:expr, $want:ident, $($field:ident: $value:expr),+) => {
                check($what, Status::$want, UpdateArgs { $($field: $value),+, ..ok })
            };
        }
        update!("null scene", NullPointer, scene: null_mut());
        update!("unbuilt scene", NotBuilt, scene: unbuilt.h);
        update!("another mesh's scene", InvalidHandle, scene: other.h);
        update!("null surface", NullPointer, surface: null());
        update!("garbage surface", InvalidHandle, surface: zeros.as_mut_ptr().cast());
        update!("misaligned surface", InvalidHandle, surface: odd(ok.surface));
        update!("a scene as the surface", InvalidHandle, surface: f.h.cast());
        update!("null positions", NullPointer, positions: null_mut());
        update!("misaligned positions", Misaligned, positions: odd_mut(ok.positions));
        update!("misaligned normals", Misaligned, normals: odd_mut(ok.normals));
        update!("positions short", BufferTooSmall, positions_len: 11);
        update!("normals short", BufferTooSmall, normals_len: 11);
        update!("positions in the scene", Overlap, positions: in_scene);
        update!("positions in the surface", Overlap, positions: in_skin);
        update!("normals in the surface", Overlap, normals: in_skin);
        update!("normals over the positions", Overlap, normals: ok.positions.wrapping_add(9));
        // Larger outputs are fine, and the normals optional.
        let no_normals = UpdateArgs {
            positions_len: 24,
            normals: null_mut(),
            normals_len: 0,
            ..ok
        };
        assert_eq!(no_normals.call(), Status::Ok);
        assert_eq!(out[..4], p[..]);
        assert_eq!(out[4..], [[9.0; 3]; 4]);
        assert_eq!(nrm, [[9.0; 3]; 8]);
        assert_eq!(
            UpdateArgs {
                normals_len: 13,
                ..ok
            }
            .call(),
            Status::Ok
        );
        assert_eq!(nrm[..4], n[..]);
        // A copy of the surface's bytes is not a surface; a dead scene
        // moves nothing.
        let mut copy = skin.buf.clone();
        let offset = h as usize - skin.buf.as_ptr() as usize;
        let moved = copy.as_mut_ptr().cast::<u8>().wrapping_add(offset);
        let copied = UpdateArgs {
            surface: moved.cast(),
            ..ok
        };
        assert_eq!(copied.call(), Status::InvalidHandle);
        // SAFETY: a live handle.
        assert_eq!(unsafe { corofem_scene_deinit(f.h) }, Status::Ok);
        assert_eq!(ok.call(), Status::InvalidHandle);
    }
}

/// Without the feature `probe` the probe functions are there and say so;
/// without `friction`, so do the friction setters.
#[cfg(not(feature = "probe"))]
#[test]
fn probes_are_unsupported_without_the_feature() {
    let f = Fixture::built();
    let mut bytes = 0;
    let mut buf = [0u64; 64];
    let mut p = null_mut();
    let (at, axis) = ([0.0f32, 0.0, 2.0], [0.0f32, 0.0, 1.0]);
    let mut force = [0.0f32; 3];
    // SAFETY: a live handle and locals; nothing is read or written.
    unsafe {
        assert_eq!(corofem_probes_bytes(1, &mut bytes), Status::Unsupported);
        let st = corofem_probes_init(buf.as_mut_ptr().cast(), 512, 1, &mut p);
        assert_eq!(st, Status::Unsupported);
        assert!(p.is_null());
        let st = corofem_probes_add_sphere(p, 0.1, at.as_ptr(), null_mut());
        assert_eq!(st, Status::Unsupported);
        let st = corofem_probes_add_capsule(p, 0.1, 0.1, at.as_ptr(), axis.as_ptr(), null_mut());
        assert_eq!(st, Status::Unsupported);
        assert_eq!(corofem_probes_count(p, &mut bytes), Status::Unsupported);
        let st = corofem_probe_move_to(p, 0, at.as_ptr(), null());
        assert_eq!(st, Status::Unsupported);
        let st = corofem_probe_place(p, 0, at.as_ptr(), null());
        assert_eq!(st, Status::Unsupported);
        assert_eq!(
            corofem_probe_set_friction(p, 0, 0.5, 0.5),
            Status::Unsupported
        );
        let st = corofem_probe_force(p, 0, force.as_mut_ptr(), null_mut());
        assert_eq!(st, Status::Unsupported);
        let st = corofem_step_probes(f.h, p, null_mut(), null_mut(), null_mut());
        assert_eq!(st, Status::Unsupported);
    }
}

#[cfg(not(feature = "friction"))]
#[test]
fn friction_is_unsupported_without_the_feature() {
    let f = Fixture::built();
    let before = f.hash();
    // SAFETY: a live handle.
    unsafe {
        assert_eq!(
            corofem_set_ground_friction(f.h, 0.5, 0.5),
            Status::Unsupported
        );
    }
    assert_eq!(f.hash(), before);
}

/// Without the feature `coupling` the coupling functions are there and say
/// so, and write nothing.
#[cfg(not(feature = "coupling"))]
#[test]
fn coupling_is_unsupported_without_the_feature() {
    // SAFETY: a zeroed struct of plain integers.
    let mut c: Coupling = unsafe { std::mem::zeroed() };
    let before = c;
    let (at, velocity) = ([0.0f32, 0.0, 2.0], [0.0f32; 3]);
    let (mut force, mut x) = ([7.0f32; 3], 7.0f32);
    // SAFETY: locals; nothing is read or written.
    unsafe {
        assert_eq!(
            corofem_coupling_init(&mut c, 1000.0, 2.0, 0.01),
            Status::Unsupported
        );
        let st = corofem_coupling_drive(
            &mut c,
            null_mut(),
            0,
            at.as_ptr(),
            velocity.as_ptr(),
            0.001,
            force.as_mut_ptr(),
        );
        assert_eq!(st, Status::Unsupported);
        assert_eq!(corofem_coupling_reset(&mut c), Status::Unsupported);
        let st = corofem_coupling_device_force(&c, force.as_mut_ptr());
        assert_eq!(st, Status::Unsupported);
        assert_eq!(
            corofem_coupling_body_stiffness(&c, &mut x),
            Status::Unsupported
        );
        let st = corofem_coupling_proxy_velocity(&c, force.as_mut_ptr());
        assert_eq!(st, Status::Unsupported);
        let st = corofem_coupling_parameters(&c, &mut x, null_mut(), null_mut());
        assert_eq!(st, Status::Unsupported);
    }
    assert_eq!(c, before);
    assert_eq!((force, x), ([7.0; 3], 7.0));
}

/// Probes and friction through the C functions: every bad input is a
/// status code and changes neither the scene nor the probes.
#[cfg(all(feature = "probe", feature = "friction"))]
mod probes {
    use super::*;

    /// A probe set in a heap buffer (8-aligned) and its handle.
    struct Set {
        /// Owns the memory the handle points into.
        _buf: Vec<u64>,
        p: *mut ProbesHandle,
    }

    impl Set {
        fn new(capacity: usize) -> Self {
            let mut bytes = 0;
            // SAFETY: out-pointers to locals; the buffer outlives the handle.
            unsafe {
                assert_eq!(corofem_probes_bytes(capacity, &mut bytes), Status::Ok);
                let mut buf = vec![0u64; bytes.div_ceil(8)];
                let mut p = null_mut();
                let st = corofem_probes_init(buf.as_mut_ptr().cast(), bytes, capacity, &mut p);
                assert_eq!(st, Status::Ok);
                Self { _buf: buf, p }
            }
        }

        fn count(&self) -> usize {
            let mut n = usize::MAX;
            // SAFETY: a live handle, a local out-pointer.
            assert_eq!(unsafe { corofem_probes_count(self.p, &mut n) }, Status::Ok);
            n
        }

        fn force(&self, i: usize) -> ([f32; 3], u32) {
            let (mut f, mut c) = ([0.0f32; 3], 0u32);
            // SAFETY: a live handle, local out-pointers.
            let st = unsafe { corofem_probe_force(self.p, i, f.as_mut_ptr(), &mut c) };
            assert_eq!(st, Status::Ok);
            (f, c)
        }
    }

    /// The fixture's scene with its base (nodes 0, 1, 2 at z = 0) fixed,
    /// without gravity (this soft metre-sized body would sag away from the
    /// probe): node 3 at (0, 0, 1) and node 4 at (1, 1, 1) are free.
    fn scene() -> Fixture {
        fixed_base_without_gravity(Fixture::built())
    }

    /// `f` with nodes 0, 1 and 2 fixed and gravity off.
    fn fixed_base_without_gravity(f: Fixture) -> Fixture {
        // SAFETY: a live handle and locals.
        unsafe {
            let st = corofem_fix_nodes(f.h, [0u32, 1, 2].as_ptr(), 3);
            assert_eq!(st, Status::Ok);
            let mut s = std::mem::zeroed::<Settings>();
            assert_eq!(corofem_get_settings(f.h, &mut s), Status::Ok);
            s.gravity = [0.0; 3];
            assert_eq!(corofem_set_settings(f.h, &s), Status::Ok);
        }
        f
    }

    /// A sphere of 0.2 m, 0.1 m above node 3.
    const ABOVE: [f32; 3] = [0.0, 0.0, 1.3];
    const R: f32 = 0.2;

    /// Steps `f` with `set`, its probe 0 pressing node 3 down by 1 mm a
    /// step from `ABOVE` (it touches at step 100): the good sequence both
    /// twins of the tests run.
    fn press(f: &Fixture, set: &Set, steps: u32) {
        for k in 1..=steps {
            let at = [ABOVE[0], ABOVE[1], ABOVE[2] - 0.001 * k as f32];
            // SAFETY: live handles and locals.
            unsafe {
                let st = corofem_probe_move_to(set.p, 0, at.as_ptr(), null());
                assert_eq!(st, Status::Ok);
                let st = corofem_step_probes(f.h, set.p, null_mut(), null_mut(), null_mut());
                assert_eq!(st, Status::Ok, "step {k}");
            }
        }
    }

    #[test]
    fn a_probe_presses_and_reports_its_force() {
        let f = scene();
        let set = Set::new(1);
        let mut stats = Stats::default();
        // SAFETY: live handles and locals.
        unsafe {
            let st = corofem_probes_add_sphere(set.p, R, ABOVE.as_ptr(), null_mut());
            assert_eq!(st, Status::Ok);
            press(&f, &set, 150);
            assert_eq!(corofem_last_stats(f.h, &mut stats), Status::Ok);
        }
        let (force, contacts) = set.force(0);
        // Pressed 50 mm below node 3's rest height: the body pushes up.
        assert!(force[2] > 0.0 && contacts >= 1, "{force:?} {contacts}");
        assert_eq!(stats.contacts, contacts, "no ground: the probe's contacts");
        // Without gravity only the probe pushes the body (down): the fixed
        // base holds it up.
        assert!(stats.support_force[2] > 0.0, "{stats:?}");
    }

    #[test]
    fn bad_probe_inputs_change_nothing() {
        // Twins: `f`/`set` get every bad call between good ones, `g`/`twin`
        // only the good ones; they must end bit-identical.
        let (f, g) = (scene(), scene());
        let (set, twin) = (Set::new(2), Set::new(2));
        let nan = [0.0, f32::NAN, 0.0f32];
        let inf = [f32::INFINITY, 0.0, 0.0f32];
        let zero = [0.0f32; 3];
        let axis = [0.0f32, 0.0, 1.0];
        // SAFETY: live handles; pointers are null, locals, misaligned or
        // inside a buffer on purpose (refused before any access).
        unsafe {
            for s in [&set, &twin] {
                let st = corofem_probes_add_sphere(s.p, R, ABOVE.as_ptr(), null_mut());
                assert_eq!(st, Status::Ok);
            }
            press(&f, &set, 120);
            press(&g, &twin, 120);
            let (before, force) = (f.hash(), set.force(0));
            // 20 mm past first touch at step 100: in contact.
            assert!(force.0[2] > 0.0 && force.1 >= 1, "{force:?}");
            let mut i = 7usize;
            // Making probes: bad radius, half length, pose; null pointers.
            for r in [0.0, -0.1, f32::NAN, f32::INFINITY] {
                let st = corofem_probes_add_sphere(set.p, r, ABOVE.as_ptr(), &mut i);
                assert_eq!(st, Status::InvalidArgument, "radius {r}");
            }
            for hl in [-0.1, f32::NAN, f32::INFINITY] {
                let st =
                    corofem_probes_add_capsule(set.p, R, hl, ABOVE.as_ptr(), axis.as_ptr(), &mut i);
                assert_eq!(st, Status::InvalidArgument, "half length {hl}");
            }
            for (p, e) in [(nan, axis), (inf, axis), (ABOVE, zero), (ABOVE, nan)] {
                let st = corofem_probes_add_capsule(set.p, R, 0.1, p.as_ptr(), e.as_ptr(), &mut i);
                assert_eq!(st, Status::InvalidArgument, "{p:?} {e:?}");
            }
            let st = corofem_probes_add_sphere(set.p, R, null(), &mut i);
            assert_eq!(st, Status::NullPointer);
            let st = corofem_probes_add_sphere(null_mut(), R, ABOVE.as_ptr(), &mut i);
            assert_eq!(st, Status::NullPointer);
            // A handle that is not one: the scene's.
            let st = corofem_probes_add_sphere(f.h.cast(), R, ABOVE.as_ptr(), &mut i);
            assert_eq!(st, Status::InvalidHandle);
            // Inputs and outputs inside the probe buffer.
            let inside = set.p.cast::<u8>().add(64);
            let st = corofem_probes_add_sphere(set.p, R, inside.cast(), &mut i);
            assert_eq!(st, Status::Overlap);
            let st = corofem_probes_add_sphere(set.p, R, ABOVE.as_ptr(), inside.cast());
            assert_eq!(st, Status::Overlap);
            assert_eq!(i, 7, "no output written on error");
            assert_eq!(set.count(), 1);
            // Moving and placing: bad poses and indices.
            for (p, e) in [(nan, axis), (inf, axis), (ABOVE, zero), (ABOVE, inf)] {
                let st = corofem_probe_move_to(set.p, 0, p.as_ptr(), e.as_ptr());
                assert_eq!(st, Status::InvalidArgument, "{p:?} {e:?}");
                let st = corofem_probe_place(set.p, 0, p.as_ptr(), e.as_ptr());
                assert_eq!(st, Status::InvalidArgument, "{p:?} {e:?}");
            }
            let st = corofem_probe_move_to(set.p, 1, ABOVE.as_ptr(), null());
            assert_eq!(st, Status::IndexOutOfRange, "slot 1 holds no probe yet");
            let st = corofem_probe_place(set.p, usize::MAX, ABOVE.as_ptr(), null());
            assert_eq!(st, Status::IndexOutOfRange);
            let st = corofem_probe_move_to(set.p, 0, null(), null());
            assert_eq!(st, Status::NullPointer);
            // Friction: each rule of the coefficients.
            for (s, k) in [
                (0.3, 0.5),
                (0.5, 0.0),
                (-0.1, -0.1),
                (f32::NAN, 0.2),
                (0.5, f32::NAN),
                (f32::INFINITY, 0.5),
            ] {
                let st = corofem_probe_set_friction(set.p, 0, s, k);
                assert_eq!(st, Status::InvalidArgument, "{s} {k}");
                let st = corofem_set_ground_friction(f.h, s, k);
                assert_eq!(st, Status::InvalidArgument, "{s} {k}");
            }
            let st = corofem_probe_set_friction(set.p, 1, 0.5, 0.5);
            assert_eq!(st, Status::IndexOutOfRange);
            assert_eq!(
                corofem_set_ground_friction(null_mut(), 0.5, 0.5),
                Status::NullPointer
            );
            // Reading the force: misaligned, overlapping, out of range.
            let mut out = [0.0f32; 4];
            let odd = out.as_mut_ptr().cast::<u8>().add(1).cast::<f32>();
            let st = corofem_probe_force(set.p, 0, odd, null_mut());
            assert_eq!(st, Status::Misaligned);
            let both = out.as_mut_ptr().add(2).cast::<u32>();
            let st = corofem_probe_force(set.p, 0, out.as_mut_ptr(), both);
            assert_eq!(st, Status::Overlap);
            let st = corofem_probe_force(set.p, 1, out.as_mut_ptr(), null_mut());
            assert_eq!(st, Status::IndexOutOfRange);
            // Stepping: null and dead handles, overlapping outputs.
            let (mut pi, mut ni) = (7usize, 7usize);
            let st = corofem_step_probes(f.h, null_mut(), null_mut(), null_mut(), null_mut());
            assert_eq!(st, Status::NullPointer);
            let st = corofem_step_probes(null_mut(), set.p, null_mut(), null_mut(), null_mut());
            assert_eq!(st, Status::NullPointer);
            let st = corofem_step_probes(f.h, set.p, null_mut(), &mut pi, &mut pi);
            assert_eq!(st, Status::Overlap);
            let st = corofem_step_probes(f.h, set.p, inside.cast(), &mut pi, &mut ni);
            assert_eq!(st, Status::Overlap);
            // A second probe that starts inside the body (around node 3,
            // which probe 0 presses): named, and nothing moves.
            let at3 = [0.0f32, 0.0, 0.95];
            let st = corofem_probes_add_sphere(set.p, 0.1, at3.as_ptr(), &mut i);
            assert_eq!((st, i), (Status::Ok, 1));
            let st = corofem_step_probes(f.h, set.p, null_mut(), &mut pi, &mut ni);
            assert_eq!(st, Status::ProbeInsideBody);
            assert_eq!((pi, ni), (1, 3));
            assert_eq!(f.hash(), before, "no error changed the scene");
            assert_eq!(set.force(0), force, "nor the probe");
            // Placed wholly inside the first tetrahedron (0.14 from its
            // faces, 0.43 from its corners): no node, `SIZE_MAX`.
            let centroid = [0.25f32, 0.25, 0.25];
            let st = corofem_probe_place(set.p, 1, centroid.as_ptr(), null());
            assert_eq!(st, Status::Ok);
            let st = corofem_step_probes(f.h, set.p, null_mut(), &mut pi, &mut ni);
            assert_eq!(st, Status::ProbeInsideBody);
            assert_eq!((pi, ni), (1, usize::MAX));
            assert_eq!(f.hash(), before, "no error changed the scene");
            // Placed away from the body, it no longer is; the twin gets the
            // same probe there.
            let away = [5.0f32, 5.0, 5.0];
            assert_eq!(
                corofem_probe_place(set.p, 1, away.as_ptr(), null()),
                Status::Ok
            );
            let st = corofem_probes_add_sphere(twin.p, 0.1, away.as_ptr(), &mut i);
            assert_eq!((st, i), (Status::Ok, 1));
            // A full set refuses a third.
            let st = corofem_probes_add_sphere(set.p, R, away.as_ptr(), &mut i);
            assert_eq!(st, Status::Capacity);
            assert_eq!(set.count(), 2);
            // Friction set on both twins, then the same good steps.
            for (h, s) in [(f.h, &set), (g.h, &twin)] {
                assert_eq!(corofem_probe_set_friction(s.p, 0, 0.5, 0.3), Status::Ok);
                assert_eq!(corofem_set_ground_friction(h, 0.0, 0.0), Status::Ok);
            }
        }
        press(&f, &set, 150);
        press(&g, &twin, 150);
        assert_eq!(f.hash(), g.hash());
        assert_eq!(set.force(0), twin.force(0));
        assert_eq!(set.force(1), twin.force(1));
    }

    #[test]
    fn bad_probe_buffers_are_refused() {
        let mut bytes = 0;
        let mut buf = vec![0u64; 64];
        let mut p = null_mut();
        // SAFETY: locals and a buffer of the stated size, or pointers
        // refused before any access.
        unsafe {
            assert_eq!(corofem_probes_bytes(1, null_mut()), Status::NullPointer);
            assert_eq!(corofem_probes_bytes(0, &mut bytes), Status::InvalidArgument);
            assert_eq!(
                corofem_probes_bytes(usize::from(u16::MAX) + 1, &mut bytes),
                Status::Capacity
            );
            assert_eq!(corofem_probes_bytes(2, &mut bytes), Status::Ok);
            assert!(bytes <= 512, "two probes in {bytes} bytes");
            let b = buf.as_mut_ptr().cast::<core::ffi::c_void>();
            assert_eq!(
                corofem_probes_init(null_mut(), bytes, 2, &mut p),
                Status::NullPointer
            );
            assert_eq!(
                corofem_probes_init(b, bytes - 1, 2, &mut p),
                Status::BufferTooSmall
            );
            assert_eq!(
                corofem_probes_init(b, bytes, 2, null_mut()),
                Status::NullPointer
            );
            let out_inside = b.cast::<u8>().add(8).cast();
            assert_eq!(
                corofem_probes_init(b, bytes, 2, out_inside),
                Status::Overlap
            );
            assert!(p.is_null(), "no handle written on error");
            // At an odd address the same size works.
            let odd = b.cast::<u8>().add(1).cast();
            assert_eq!(corofem_probes_init(odd, bytes, 2, &mut p), Status::Ok);
            let at = [0.0f32, 0.0, 3.0];
            let st = corofem_probes_add_sphere(p, 0.1, at.as_ptr(), null_mut());
            assert_eq!(st, Status::Ok);
            // Initialising again empties the set.
            let mut n = 9;
            assert_eq!(corofem_probes_count(p, &mut n), Status::Ok);
            assert_eq!(n, 1);
            assert_eq!(corofem_probes_init(odd, bytes, 2, &mut p), Status::Ok);
            assert_eq!(corofem_probes_count(p, &mut n), Status::Ok);
            assert_eq!(n, 0);
            // A copy of the set elsewhere is not a set.
            let mut copy = buf.clone();
            let moved = copy
                .as_mut_ptr()
                .cast::<u8>()
                .add(p as usize - buf.as_ptr() as usize);
            assert_eq!(
                corofem_probes_count(moved.cast(), &mut n),
                Status::InvalidHandle
            );
        }
    }

    #[test]
    fn a_probe_set_inside_the_scene_buffer_is_refused() {
        // A scene buffer with spare room at its end, where a probe set
        // is made: the scene never uses it, but a step refuses the overlap.
        let (n, t) = (8, 4);
        let (mut bytes, mut pbytes) = (0, 0);
        // SAFETY: locals and buffers of the stated sizes.
        unsafe {
            assert_eq!(corofem_scene_bytes(n, t, &mut bytes), Status::Ok);
            assert_eq!(corofem_probes_bytes(1, &mut pbytes), Status::Ok);
            let total = bytes + pbytes + 8;
            let mut buf = vec![0u64; total.div_ceil(8)];
            let mut h = null_mut();
            let st = corofem_scene_init(buf.as_mut_ptr().cast(), total, n, t, &mut h);
            assert_eq!(st, Status::Ok);
            let f = Fixture { buf: Vec::new(), h };
            assert_eq!(f.build(&NODES, &TETS, 0).0, Status::Ok);
            let tail = buf.as_mut_ptr().cast::<u8>().add(bytes + 8);
            let mut p = null_mut();
            assert_eq!(
                corofem_probes_init(tail.cast(), pbytes, 1, &mut p),
                Status::Ok
            );
            let before = f.hash();
            let st = corofem_step_probes(h, p, null_mut(), null_mut(), null_mut());
            assert_eq!(st, Status::Overlap);
            assert_eq!(f.hash(), before);
            drop(f);
            drop(buf);
        }
    }

    /// The haptic coupling through the C functions: the Rust `Coupling`'s
    /// bits, and every bad input a status code that changes nothing.
    #[cfg(feature = "coupling")]
    mod coupling {
        use super::*;

        use corofem_core::{BuildOptions, Probe, VecScene};

        /// k = 1000 N/m, b = 2 N·s/m, m = 10 g (the README's example).
        const K: f32 = 1000.0;
        const B: f32 = 2.0;
        const M: f32 = 0.01;
        const DT: f32 = 0.001;
        /// The fixture's body scaled to 2 cm, so that its nodes weigh
        /// grams, as a haptic scene's do (a 10 g proxy against a node of
        /// tens of kilograms sees a wall), and a sphere of 4 mm 2 mm above
        /// node 3.
        const SCALE: f32 = 0.02;
        const RADIUS: f32 = 0.004;
        const START: [f32; 3] = [0.0, 0.0, SCALE + RADIUS + 0.002];

        /// The device's position and velocity at step `k`: from `START`
        /// down at 3 cm/s; the sphere's bottom reaches node 3's rest
        /// height at step 67.
        fn device(k: u32) -> ([f32; 3], [f32; 3]) {
            let at = [START[0], START[1], START[2] - 3.0e-5 * k as f32];
            (at, [0.0, 0.0, -0.03])
        }

        /// The body: the fixture's, scaled, its base fixed, no gravity.
        fn nodes() -> [[f32; 3]; 5] {
            NODES.map(|x| x.map(|c| c * SCALE))
        }

        fn body() -> Fixture {
            let f = Fixture::new(NODES.len(), TETS.len());
            assert_eq!(f.build(&nodes(), &TETS, 0).0, Status::Ok);
            super::fixed_base_without_gravity(f)
        }

        /// A coupling initialised with `K`, `B`, `M`.
        fn coupling() -> Coupling {
            // SAFETY: a zeroed struct of plain integers, then a local.
            let mut c: Coupling = unsafe { std::mem::zeroed() };
            // SAFETY: a local.
            let st = unsafe { corofem_coupling_init(&mut c, K, B, M) };
            assert_eq!(st, Status::Ok);
            c
        }

        /// Steps `f` and `set` with its probe 0 the proxy of `c`, the
        /// device at `device(k)` for `k` in `steps`: the forces rendered.
        fn drive(
            f: &Fixture,
            set: &Set,
            c: &mut Coupling,
            steps: std::ops::RangeInclusive<u32>,
        ) -> Vec<[f32; 3]> {
            let mut rendered = Vec::new();
            for k in steps {
                let (at, v) = device(k);
                let mut force = [f32::NAN; 3];
                // SAFETY: live handles and locals.
                unsafe {
                    let st = corofem_coupling_drive(
                        c,
                        set.p,
                        0,
                        at.as_ptr(),
                        v.as_ptr(),
                        DT,
                        force.as_mut_ptr(),
                    );
                    assert_eq!(st, Status::Ok, "drive {k}");
                    let st = corofem_step_probes(f.h, set.p, null_mut(), null_mut(), null_mut());
                    assert_eq!(st, Status::Ok, "step {k}");
                }
                rendered.push(force);
            }
            rendered
        }

        /// A set of one sphere of `RADIUS` at `START`.
        fn sphere() -> Set {
            let set = Set::new(1);
            // SAFETY: a live handle and a local.
            let st =
                unsafe { corofem_probes_add_sphere(set.p, RADIUS, START.as_ptr(), null_mut()) };
            assert_eq!(st, Status::Ok);
            set
        }

        #[test]
        fn a_coupled_press_renders_the_rust_couplings_force() {
            let (f, set, mut c) = (body(), sphere(), coupling());
            // The same scene, probe and coupling through the Rust API.
            let material = corofem_core::Material {
                young: MAT.young,
                poisson: MAT.poisson,
                density: MAT.density,
            };
            let mut s = VecScene::with_capacity(NODES.len(), TETS.len());
            s.build(&nodes(), &TETS, &material, BuildOptions::default())
                .unwrap();
            s.fix_nodes(&[0, 1, 2]).unwrap();
            let settings = corofem_core::Settings {
                gravity: [0.0; 3],
                ..*s.settings()
            };
            s.set_settings(settings).unwrap();
            let mut probes = [Probe::sphere(RADIUS, START).unwrap()];
            let mut rust = corofem_core::Coupling::new(K, B, M).unwrap();
            let mut last = [0.0f32; 3];
            for k in 1..=200 {
                let rendered = drive(&f, &set, &mut c, k..=k)[0];
                let (at, v) = device(k);
                let force = rust.drive(&mut probes[0], at, v, DT).unwrap();
                s.step_with_probes(&mut probes).unwrap();
                let bits = |f: [f32; 3]| f.map(f32::to_bits);
                assert_eq!(bits(rendered), bits(force), "step {k}");
                assert_eq!(f.hash(), s.state_hash(), "step {k}");
                assert_eq!(set.force(0), (probes[0].force(), probes[0].contacts()));
                last = force;
            }
            // The device went 4 mm below node 3's rest height: the body
            // pushes the proxy back, and the spring pulls the device up.
            let (push, contacts) = set.force(0);
            assert!(push[2] > 0.0 && contacts >= 1, "{push:?} {contacts}");
            assert!(last[2] > 0.0, "{last:?}");
            // The getters read the Rust coupling's state.
            let (mut fo, mut v, mut body) = ([0.0f32; 3], [0.0f32; 3], 0.0f32);
            let (mut k, mut b, mut m) = (0.0f32, 0.0f32, 0.0f32);
            // SAFETY: an initialised coupling and locals.
            unsafe {
                assert_eq!(
                    corofem_coupling_device_force(&c, fo.as_mut_ptr()),
                    Status::Ok
                );
                assert_eq!(
                    corofem_coupling_proxy_velocity(&c, v.as_mut_ptr()),
                    Status::Ok
                );
                assert_eq!(corofem_coupling_body_stiffness(&c, &mut body), Status::Ok);
                let st = corofem_coupling_parameters(&c, &mut k, &mut b, &mut m);
                assert_eq!(st, Status::Ok);
            }
            assert_eq!(
                (fo, v, body),
                (
                    rust.device_force(),
                    rust.proxy_velocity(),
                    rust.body_stiffness()
                )
            );
            assert_eq!(fo, last);
            assert!(body > 0.0, "in contact, the body's stiffness is known");
            assert_eq!((k, b, m), (K, B, M));
            // Reset: the proxy stops and forgets, the parameters stay.
            // SAFETY: as above.
            unsafe {
                assert_eq!(corofem_coupling_reset(&mut c), Status::Ok);
                assert_eq!(
                    corofem_coupling_device_force(&c, fo.as_mut_ptr()),
                    Status::Ok
                );
                assert_eq!(corofem_coupling_body_stiffness(&c, &mut body), Status::Ok);
                let st = corofem_coupling_parameters(&c, &mut k, null_mut(), null_mut());
                assert_eq!(st, Status::Ok);
            }
            rust.reset();
            assert_eq!((fo, body, k), ([0.0; 3], 0.0, K));
            assert_eq!(rust, corofem_core::Coupling::new(K, B, M).unwrap());
            assert_eq!(c, coupling(), "a fresh coupling's bytes");
        }

        #[test]
        fn bad_coupling_inputs_change_nothing() {
            // Twins: `f`/`set`/`c` get every bad call between good ones,
            // `g`/`twin`/`d` only the good ones; they must end bit-identical.
            let (f, g) = (body(), body());
            let (set, twin) = (sphere(), sphere());
            let (mut c, mut d) = (coupling(), coupling());
            drive(&f, &set, &mut c, 1..=120);
            drive(&g, &twin, &mut d, 1..=120);
            let (before, kept, force) = (f.hash(), c, set.force(0));
            assert!(force.0[2] > 0.0 && force.1 >= 1, "in contact: {force:?}");
            let (at, v) = device(121);
            let nan = [0.0, f32::NAN, 0.0f32];
            let inf = [f32::INFINITY, 0.0, 0.0f32];
            let far = [0.0, 0.0, 1.0e38f32];
            let mut out = [7.0f32; 4];
            let o = out.as_mut_ptr();
            // SAFETY: live handles and an initialised coupling; pointers
            // are null, locals, misaligned, overlapping or inside the
            // probe buffer on purpose (refused before any access).
            unsafe {
                // Initialising: each parameter out of range.
                for (k, b, m) in [
                    (0.0, B, M),
                    (-1.0, B, M),
                    (f32::NAN, B, M),
                    (f32::INFINITY, B, M),
                    (K, -0.1, M),
                    (K, f32::NAN, M),
                    (K, f32::INFINITY, M),
                    (K, B, 0.0),
                    (K, B, -0.01),
                    (K, B, f32::NAN),
                    (K, B, f32::INFINITY),
                ] {
                    let st = corofem_coupling_init(&mut c, k, b, m);
                    assert_eq!(st, Status::InvalidArgument, "{k} {b} {m}");
                    assert_eq!(c, kept, "{k} {b} {m}");
                }
                assert_eq!(
                    corofem_coupling_init(null_mut(), K, B, M),
                    Status::NullPointer
                );
                let mut words = [0u32; 21];
                let odd = words.as_mut_ptr().cast::<u8>().add(1).cast::<Coupling>();
                assert_eq!(corofem_coupling_init(odd, K, B, M), Status::Misaligned);
                assert_eq!(words, [0; 21]);
                // Driving: a bad time step, device state or result.
                let call = |c: *mut Coupling,
                            p: *mut ProbesHandle,
                            i: usize,
                            x: *const f32,
                            v: *const f32,
                            dt: f32,
                            o: *mut f32| {
                    corofem_coupling_drive(c, p, i, x, v, dt, o)
                };
                let cp: *mut Coupling = &mut c;
                for dt in [0.0, -0.001, f32::NAN, f32::INFINITY] {
                    let st = call(cp, set.p, 0, at.as_ptr(), v.as_ptr(), dt, o);
                    assert_eq!(st, Status::InvalidArgument, "dt {dt}");
                }
                for (x, u) in [(nan, v), (inf, v), (at, nan), (at, inf), (far, v)] {
                    let st = call(cp, set.p, 0, x.as_ptr(), u.as_ptr(), DT, o);
                    assert_eq!(st, Status::InvalidArgument, "{x:?} {u:?}");
                }
                // Indices, null pointers, handles.
                let st = call(cp, set.p, 1, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::IndexOutOfRange);
                let st = call(null_mut(), set.p, 0, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::NullPointer);
                let st = call(cp, null_mut(), 0, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::NullPointer);
                let st = call(cp, set.p, 0, null(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::NullPointer);
                let st = call(cp, set.p, 0, at.as_ptr(), null(), DT, o);
                assert_eq!(st, Status::NullPointer);
                let st = call(cp, f.h.cast(), 0, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::InvalidHandle, "the scene is not a probe set");
                let mut zeroed: Coupling = std::mem::zeroed();
                let st = call(&mut zeroed, set.p, 0, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::InvalidHandle, "never initialised");
                // Misaligned, overlapping, inside the probe buffer.
                let odd_out = o.cast::<u8>().add(1).cast::<f32>();
                let st = call(cp, set.p, 0, at.as_ptr(), v.as_ptr(), DT, odd_out);
                assert_eq!(st, Status::Misaligned);
                let st = call(cp, set.p, 0, at.as_ptr(), v.as_ptr(), DT, cp.cast());
                assert_eq!(st, Status::Overlap, "the force over the coupling");
                let mut x = at;
                let st = call(cp, set.p, 0, x.as_ptr(), v.as_ptr(), DT, x.as_mut_ptr());
                assert_eq!(st, Status::Overlap, "the force over the position");
                let st = call(cp, set.p, 0, at.as_ptr(), cp.cast(), DT, o);
                assert_eq!(st, Status::Overlap, "the velocity inside the coupling");
                let inside = set.p.cast::<u8>().add(64);
                let st = call(cp, set.p, 0, at.as_ptr(), v.as_ptr(), DT, inside.cast());
                assert_eq!(st, Status::Overlap);
                let st = call(cp, set.p, 0, inside.cast(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::Overlap);
                let st = call(inside.cast(), set.p, 0, at.as_ptr(), v.as_ptr(), DT, o);
                assert_eq!(st, Status::Overlap, "the coupling inside the probe buffer");
                assert_eq!(x, at);
                assert_eq!(out, [7.0; 4], "no force written on error");
                // Reset and the getters.
                assert_eq!(corofem_coupling_reset(null_mut()), Status::NullPointer);
                assert_eq!(corofem_coupling_reset(&mut zeroed), Status::InvalidHandle);
                assert_eq!(zeroed, std::mem::zeroed(), "a refused reset writes nothing");
                let cc: *const Coupling = cp;
                assert_eq!(
                    corofem_coupling_device_force(null(), o),
                    Status::NullPointer
                );
                assert_eq!(
                    corofem_coupling_device_force(cc, null_mut()),
                    Status::NullPointer
                );
                assert_eq!(
                    corofem_coupling_device_force(&zeroed, o),
                    Status::InvalidHandle
                );
                assert_eq!(
                    corofem_coupling_device_force(cc, odd_out),
                    Status::Misaligned
                );
                assert_eq!(
                    corofem_coupling_device_force(cc, cp.cast()),
                    Status::Overlap
                );
                assert_eq!(
                    corofem_coupling_proxy_velocity(cc, cp.cast::<f32>().add(17)),
                    Status::Overlap
                );
                assert_eq!(
                    corofem_coupling_body_stiffness(cc, cp.cast()),
                    Status::Overlap
                );
                assert_eq!(
                    corofem_coupling_body_stiffness(&zeroed, o),
                    Status::InvalidHandle
                );
                let st = corofem_coupling_parameters(cc, o, o, null_mut());
                assert_eq!(st, Status::Overlap, "two parameters in one float");
                let st = corofem_coupling_parameters(cc, o, o.add(1), cp.cast());
                assert_eq!(st, Status::Overlap);
                assert_eq!(out, [7.0; 4], "no output written on error");
            }
            assert_eq!(c, kept, "no error changed the coupling");
            assert_eq!(f.hash(), before, "nor the scene");
            assert_eq!(set.force(0), force, "nor the probe");
            // Then the same good periods: the twins stay bit-identical
            // (a refused drive did not move the probe either).
            let ours = drive(&f, &set, &mut c, 121..=200);
            let theirs = drive(&g, &twin, &mut d, 121..=200);
            assert_eq!(ours, theirs);
            assert_eq!(c, d);
            assert_eq!(f.hash(), g.hash());
            assert_eq!(set.force(0), twin.force(0));
            // A copy is the same coupling.
            let mut copy = c;
            let (at, v) = device(201);
            let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
            // SAFETY: initialised couplings, live handles and locals.
            unsafe {
                let st = corofem_coupling_drive(
                    &mut copy,
                    set.p,
                    0,
                    at.as_ptr(),
                    v.as_ptr(),
                    DT,
                    a.as_mut_ptr(),
                );
                assert_eq!(st, Status::Ok);
                let st = corofem_coupling_drive(
                    &mut d,
                    twin.p,
                    0,
                    at.as_ptr(),
                    v.as_ptr(),
                    DT,
                    b.as_mut_ptr(),
                );
                assert_eq!(st, Status::Ok);
            }
            assert_eq!((a, copy), (b, d));
        }
    }
}
