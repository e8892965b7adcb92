//! The web demo's scripted scene gives the same bits on the host as in the
//! browser's wasm module.
//!
//! The scene is defined once, in `corofem_test_scenes::web` (`hash_script`:
//! every built-in body, every method, ground, clamp, picking, a tool drag, a
//! release), which the web demo uses too, so this test runs the very code the
//! wasm module runs. The expected hash is stored once, in
//! `test-scenes/src/web_hash_script.txt`: this test asserts it for x86_64, and
//! `examples/web/test/hash.test.mjs` (run by `.ci/web.sh`) asserts it for the
//! wasm module in Node. A changed hash means changed results: if the change
//! is intended, store the new value and say why in the commit.

use corofem_test_scenes::web as demo;

#[test]
fn web_demo_scene_hash_matches_the_stored_value() {
    let got = demo::hash_script().expect("the scripted scene runs");
    eprintln!("web demo hash_script: {got:#018x}");
    assert_eq!(got, demo::hash_script().unwrap(), "not repeatable");
    assert_eq!(
        Some(got),
        demo::expected_hash(),
        "hash_script() = {got:#018x}, test-scenes/src/web_hash_script.txt holds {}",
        demo::EXPECTED_HASH.trim()
    );
}
