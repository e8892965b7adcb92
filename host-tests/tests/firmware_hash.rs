//! The firmware example's scene on the host: the same code
//! (`corofem_test_scenes::firmware`) that runs on the Cortex-M4F in QEMU
//! and in the wasm module. Each size prints one
//! `firmware-scene` line; `.ci/firmware.sh` compares their hashes with the
//! firmware's and the wasm module's, which must be bit-identical.

use corofem_test_scenes::firmware as scene;

fn run(cells: [u32; 3]) -> scene::Outcome {
    let mesh = scene::mesh(cells);
    let (n, t) = (mesh.node_count(), mesh.tet_count());
    let mut nodes = vec![[0.0f32; 3]; n];
    let mut tets = vec![[0u32; 4]; t];
    let mut s = corofem::VecScene::with_capacity(n, t);
    let start = scene::setup(&mut s, cells, &mut nodes, &mut tets).expect("scene builds");
    let out = scene::run(&mut s, start, |s, target| s.step_haptic(target)).expect("steps");
    println!(
        "firmware-scene cells={}x{}x{} nodes={n} tets={t} hash={:#018x} peak_push={:.4} N final_force=[{:.4}, {:.4}, {:.4}] N",
        cells[0],
        cells[1],
        cells[2],
        out.hash,
        out.peak_push,
        out.final_force[0],
        out.final_force[1],
        out.final_force[2],
    );
    out
}

#[test]
fn firmware_scene_is_plausible_at_every_size() {
    for cells in scene::SIZES {
        let out = run(cells);
        assert_eq!(scene::check(&out), Ok(()), "{cells:?}: {out:?}");
    }
}

#[test]
fn firmware_scene_golden_hash() {
    // Recorded on x86_64 (rustc 1.95); the firmware (thumbv7em-none-eabihf,
    // with and without `fpu-sqrt`) and wasm32 print the same value.
    let out = run(scene::REFERENCE);
    assert_eq!(out.hash, 0x70cc_9f3f_9a04_7405, "{:#018x}", out.hash);
}
