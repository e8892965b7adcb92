//! The web demo's scripted scene gives the same bits on the host as in the
//! browser's wasm module.
//!
//! The scene is defined once, in `examples/web/src/demo.rs` (`hash_script`:
//! every built-in body, every method, ground, clamp, picking, a tool drag, a
//! release). That file is included here as a module, so this test runs the
//! very code the wasm module runs. The expected hash is stored once, in
//! `examples/web/hash_script.txt`: this test asserts it for x86_64, and
//! `examples/web/test/hash.test.mjs` (run by `.ci/web.sh`) asserts it for the
//! wasm module in Node. A changed hash means changed results: if the change
//! is intended, store the new value and say why in the commit.

// Only part of the demo's API is used here.
#[allow(dead_code)]
#[path = "../../examples/web/src/demo.rs"]
mod demo;

#[test]
fn web_demo_scene_hash_matches_the_stored_value() {
    let got = demo::hash_script().expect("the scripted scene runs");
    eprintln!("web demo hash_script: {got:#018x}");
    assert_eq!(got, demo::hash_script().unwrap(), "not repeatable");
    assert_eq!(
        Some(got),
        demo::expected_hash(),
        "hash_script() = {got:#018x}, examples/web/hash_script.txt holds {}",
        demo::EXPECTED_HASH.trim()
    );
}
