//! Measurement side of corofem: the f64 reference integrator, the benchmark
//! scenes and the error metrics. The `corofem-bench` binary writes the report
//! (docs/bench.md).

pub mod args;
pub mod reference;
pub mod scenes;

pub use reference::{Model, RefSettings};
pub use scenes::SceneDef;
