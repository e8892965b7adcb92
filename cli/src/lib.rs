//! The scene-file side of the `corofem` program: a scene file (TOML, the
//! format of docs/scene-format.md) parsed and validated into a
//! [`scene_file::SceneSpec`], the tool's path over time, and the program's
//! error type.
//!
//! The program (`src/main.rs`) runs what this library reads; the fuzz
//! target `scene_file` (`fuzz/`) checks that whatever it accepts, the core
//! accepts too.

pub mod error;
pub mod scene_file;
pub mod tool_path;
