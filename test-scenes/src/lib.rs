//! Scenes that several programs compute and whose state hashes must agree
//! bit for bit, defined once here so that every program runs the same code.
//!
//! | module | run by | compared by |
//! |---|---|---|
//! | [`firmware`] | the firmware in QEMU (`examples/firmware`), the wasm module of `examples/wasm-hash`, `host-tests/tests/firmware_hash.rs` | `.ci/firmware.sh` |
//! | `web` (feature `web`) | the web demo's wasm module (`examples/web`), `host-tests/tests/web_hash.rs` | the stored hash in `src/web_hash_script.txt` |
//!
//! Without the `web` feature the crate is `no_std` and allocation-free, as
//! the firmware needs.

#![cfg_attr(not(feature = "web"), no_std)]

pub mod firmware;
#[cfg(feature = "web")]
pub mod web;
