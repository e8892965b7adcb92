//! Measurement side of corofem: the f64 reference integrator, the benchmark
//! scenes and the error metrics. The `corofem-bench` binary writes the report
//! and, with `--page docs/bench.md`, the figures section of that page.

pub mod args;
pub mod page;
pub mod reference;
pub mod scenes;

pub use reference::{Model, RefSettings};
pub use scenes::SceneDef;
