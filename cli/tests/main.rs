//! The tests of the `corofem` program, compiled as one test binary:
//! `cli` runs scenes and checks results and messages, `malformed` feeds it
//! broken files, `messages` checks the wording of the first errors a user
//! meets, `docs` runs the README's and docs/scene-format.md's examples
//! (`cargo test -p corofem-cli --test cli malformed::` runs one).

mod cli;
mod common;
mod docs;
mod malformed;
mod messages;
