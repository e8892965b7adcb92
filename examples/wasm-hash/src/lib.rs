//! The firmware example's scene (`corofem_test_scenes::firmware`, the very
//! same code) compiled to wasm32, for `hash.mjs` to run under node and CI to
//! compare its state hash with the firmware's and the host's.
//!
//! `no_std`, no allocator: the scene's storage is on the wasm stack.
#![no_std]

use corofem::{
    coarse_blocks_for, element_blocks, Aggregate, CoarseBlock, ElementBlock, Node, NodeBlock,
    NodeEntry, NodeWork, Preconditioner, Scene, SliceStorage,
};
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
/// Aggregate capacity: the most the two-level preconditioner uses for any
/// of `scene::SIZES`.
const A: usize = {
    let (mut a, mut i) = (0, 0);
    while i < scene::SIZES.len() {
        let n = scene::aggregates(scene::SIZES[i]);
        if n > a {
            a = n;
        }
        i += 1;
    }
    a
};

/// Runs the scene of `cx × cy × cz` cells and returns `Scene::state_hash`
/// of its final state, or 0 if it does not fit, fails, or its results are
/// implausible (`scene::check`).
#[no_mangle]
pub extern "C" fn scene_hash(cx: u32, cy: u32, cz: u32) -> u64 {
    hash_with([cx, cy, cz], Preconditioner::Mass)
}

/// [`scene_hash`] with the two-level preconditioner
/// (`scene::settings_with(Preconditioner::TwoLevel)`).
#[no_mangle]
pub extern "C" fn scene_hash_two_level(cx: u32, cy: u32, cz: u32) -> u64 {
    hash_with([cx, cy, cz], Preconditioner::TwoLevel)
}

fn hash_with(cells: [u32; 3], pre: Preconditioner) -> u64 {
    let mut nodes = [Node::EMPTY; N];
    let mut work = [NodeWork::EMPTY; N];
    let mut elems = [ElementBlock::EMPTY; element_blocks(T)];
    let mut grabs = [NodeEntry::EMPTY; scene::MAX_FACE_NODES];
    let mut blocks = [NodeBlock::EMPTY; N];
    let mut aggs = [Aggregate::EMPTY; A];
    let mut coarse = [CoarseBlock::EMPTY; coarse_blocks_for(A)];
    let mut mesh_nodes = [[0.0f32; 3]; N];
    let mut mesh_tets = [[0u32; 4]; T];
    let mut s = Scene::with_storage(
        SliceStorage::new(&mut nodes, &mut work, &mut elems)
            .with_grabs(&mut grabs)
            .with_preconditioner(&mut blocks, &mut aggs, &mut coarse),
    );
    let Ok(start) = scene::setup_with(&mut s, cells, &mut mesh_nodes, &mut mesh_tets, pre) else {
        return 0;
    };
    match scene::run(&mut s, start, |s, target| s.step_haptic(target)) {
        Ok(out) if scene::check_with(&out, pre).is_ok() => out.hash,
        _ => 0,
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    core::arch::wasm32::unreachable()
}
