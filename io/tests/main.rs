//! The readers' tests, one module per format or concern, compiled as one
//! test binary (`cargo test -p corofem-io --test readers vtk::` runs one).

mod common;
mod gmsh;
mod robustness;
mod stats;
mod tetmesh;
mod vtk;
