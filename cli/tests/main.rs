//! The tests of the `corofem` program, compiled as one test binary:
//! `cli` runs scenes and checks results and messages, `malformed` feeds it
//! broken files, `messages` checks the wording of the first errors a user
//! meets (`cargo test -p corofem-cli --test cli malformed::` runs one).

mod cli;
mod common;
mod malformed;
mod messages;
