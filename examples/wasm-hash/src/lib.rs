//! The firmware example's scene (`corofem_test_scenes::firmware`, the very
//! same code) compiled to wasm32, for `hash.mjs` to run under node and CI to
//! compare its state hash with the firmware's and the host's.
//!
//! `no_std`, no allocator: the scene's storage is on the wasm stack.
#![no_std]

use corofem::{element_blocks, ElementBlock, Node, NodeEntry, NodeWork, Scene, SliceStorage};
use corofem_test_scenes::firmware as scene;

/// Node and element capacity: the largest of `scene::SIZES`.
const CAPACITY: (usize, usize) = {
    let (mut n, mut t, mut i) = (0, 0, 0);
    while i < scene::SIZES.len() {
        let m = scene::mesh(scene::SIZES[i]);
        if m.node_count() > n {
            n = m.node_count();
        }
        if m.tet_count() > t {
            t = m.tet_count();
        }
        i += 1;
    }
    (n, t)
};
const N: usize = CAPACITY.0;
const T: usize = CAPACITY.1;

/// Runs the scene of `cx × cy × cz` cells and returns `Scene::state_hash`
/// of its final state, or 0 if it does not fit, fails, or its results are
/// implausible (`scene::check`).
#[no_mangle]
pub extern "C" fn scene_hash(cx: u32, cy: u32, cz: u32) -> u64 {
    let mut nodes = [Node::EMPTY; N];
    let mut work = [NodeWork::EMPTY; N];
    let mut elems = [ElementBlock::EMPTY; element_blocks(T)];
    let mut grabs = [NodeEntry::EMPTY; scene::MAX_FACE_NODES];
    let mut mesh_nodes = [[0.0f32; 3]; N];
    let mut mesh_tets = [[0u32; 4]; T];
    let mut s = Scene::with_storage(
        SliceStorage::new(&mut nodes, &mut work, &mut elems).with_grabs(&mut grabs),
    );
    let Ok(start) = scene::setup(&mut s, [cx, cy, cz], &mut mesh_nodes, &mut mesh_tets) else {
        return 0;
    };
    match scene::run(&mut s, start, |s, target| s.step_haptic(target)) {
        Ok(out) if scene::check(&out).is_ok() => out.hash,
        _ => 0,
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    core::arch::wasm32::unreachable()
}
