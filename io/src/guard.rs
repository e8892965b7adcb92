//! Running third-party parsers so that a panic inside them becomes an error.
//!
//! `mshio` 0.4 and `vtkio` 0.7 still contain `unwrap`s, `unimplemented!`s and
//! unchecked slicing that malformed files can reach (a mutation test of this crate
//! hit them in about one in ten corrupted `.vtu` files). [`catch_quietly`] runs such
//! a parser under `catch_unwind`. So that the user does not see a "thread panicked"
//! message before the clean [`MeshError`](crate::MeshError), the first call installs
//! a panic hook that stays silent while, and only while, the *current thread* is
//! inside `catch_quietly`; every other panic is passed on to the hook that was
//! installed before (by default the standard one).

use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// Whether the current thread is inside [`catch_quietly`].
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

static INSTALL_HOOK: Once = Once::new();

/// Runs `f`; returns `None` if it panicked (without printing the panic message).
pub(crate) fn catch_quietly<R>(f: impl FnOnce() -> R) -> Option<R> {
    INSTALL_HOOK.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let outer = QUIET.with(|q| q.replace(true));
    // The closures only read the input bytes, so no broken invariant can be observed
    // after a panic.
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(outer));
    result.ok()
}
