//! Hooks for the layer's own tests.

pub use crate::intercept::panic_in_next_check;
/// Which of the layer's own calls to the next layer this thread is making,
/// so a test's fake driver can fail the layer's calls and only those.
pub use crate::own_calls::in_progress as own_call_in_progress;

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

/// How many entries `device`'s checked state keeps for things an
/// application makes and destroys over and over: what command buffers
/// recorded, what fences stand for, what structures' builds put in them,
/// how objects were constructed. Tests make and destroy such objects
/// repeatedly and see these stay put. None for an unknown device.
#[doc(hidden)]
pub fn kept_per_object(device: ash::vk::Device) -> Option<[(&'static str, usize); 5]> {
    let data = crate::dispatch::DEVICES.get(device)?;
    let state = data.state();
    let tracked = state.validator.state();
    Some([
        ("recordings", tracked.execution.recordings.len()),
        ("fences", tracked.execution.fences.len()),
        ("micromap_geometry", tracked.micromap_geometry.len()),
        ("constructed", tracked.execution.constructed.len()),
        (
            "semaphore_signals",
            tracked.execution.timeline_signals.len() + tracked.execution.binary_signals.len(),
        ),
    ])
}
