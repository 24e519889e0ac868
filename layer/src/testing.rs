//! Hooks for the layer's own tests.

use std::cell::Cell;

thread_local! {
    static PANIC_IN_NEXT_CHECK: Cell<bool> = const { Cell::new(false) };
}

/// Makes the next check this thread runs panic, so tests can see that the
/// panic becomes one error message and never crosses the FFI boundary.
#[doc(hidden)]
pub fn panic_in_next_check() {
    PANIC_IN_NEXT_CHECK.set(true);
}

/// Panics if a test asked for it (see [`panic_in_next_check`]).
pub(crate) fn panic_if_asked() {
    if PANIC_IN_NEXT_CHECK.replace(false) {
        panic!("a panic injected by ommcheck's test hook");
    }
}
