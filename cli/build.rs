// The same cfg as the host tests (see there): the shipped scenes on the
// third-party meshes are tested only where they are.
include!("../host-tests/build.rs");
