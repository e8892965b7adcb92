//! Misuse of the C API: every bad handle, pointer, index, size or value is a
//! status code, and the scene is unchanged after it.

use std::ptr::{null, null_mut};

use corofem_capi::*;

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
        for code in -20..=1 {
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
