// The same cfg as the host tests (see there): the mesh tests of this crate
// need the third-party meshes too.
include!("../host-tests/build.rs");
