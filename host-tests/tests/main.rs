//! The host tests, one module per concern, compiled as one test binary:
//! the solver's generic code is instantiated and linked once instead of
//! once per file, and the two cores run the slow tests side by side.
//!
//! Run one concern with a filter on its module, e.g.
//! `cargo test --release -p corofem-host-tests --test host momentum:: -- --nocapture`.
//! `tests/layering.rs`, which reads the core's sources, is a binary of its own.

mod anisotropy;
mod bad_input;
mod cg_direct;
mod coupling;
mod determinism;
mod energy;
mod firmware_hash;
mod friction;
mod heapless;
mod hertz;
mod invariance;
mod laws;
mod momentum;
mod node_lists;
mod preconditioners;
mod probe;
mod properties;
mod reliability;
mod resting;
mod robustness;
mod static_scene;
mod statics;
mod stiffness_product;
mod surface;
mod tool;
mod vec_storage;
mod web_hash;
