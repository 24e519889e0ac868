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

/// Records in `device`'s checked state that `acceleration_structure` was
/// built with `geometry`, as the acceleration-structure build intercepts
/// will once the layer has them; lets tests reach the draw, dispatch and
/// trace-rays rules. Returns false for an unknown device.
#[doc(hidden)]
pub fn seed_micromap_geometry(
    device: ash::vk::Device,
    acceleration_structure: u64,
    geometry: ommcheck::model::pipeline::MicromapGeometry,
) -> bool {
    let Some(data) = crate::dispatch::DEVICES.get(device) else {
        return false;
    };
    let mut state = data.state();
    let known = &mut state.validator.state_mut().micromap_geometry;
    known.insert(acceleration_structure, geometry);
    true
}
