//! Where buffers lie in device memory and where the application has
//! mapped memory: what the host can read of a buffer now (and a copy of it), and why not.
//! Submission (route 1), readback planning (route 2) and the driver's
//! answers all ask it, so it sits below them.

#![allow(unsafe_code)]

use foldhash::HashMap;
use ommcheck::model::Handle;
use ommcheck::raw::MAX_HOST_BYTES;

use super::DeviceState;
use crate::read;
use crate::report::CauseCounts;

/// Where buffers lie in device memory and where memory is mapped.
#[derive(Debug, Default)]
pub struct MemoryLayout {
    /// Buffer → (memory, offset in it) from vkBindBufferMemory(2).
    bound: HashMap<u64, (u64, u64)>,
    /// Memory → offset of its mapping (the host range is in `DeviceState::mappings`).
    mapped_at: HashMap<u64, u64>,
    /// The causes [`crate::report::CONTENTS_NOT_CHECKED`] was reported for
    /// on this device, each with the builds it kept from being checked
    /// (few causes: a list keeps them in the order first reported).
    not_checked: CauseCounts,
}

impl MemoryLayout {
    pub fn bind(&mut self, buffer: u64, memory: u64, offset: u64) {
        self.bound.insert(buffer, (memory, offset));
    }

    pub fn forget_buffer(&mut self, buffer: u64) {
        self.bound.remove(&buffer);
    }

    pub fn map(&mut self, memory: u64, offset: u64) {
        self.mapped_at.insert(memory, offset);
    }

    pub fn unmap(&mut self, memory: u64) {
        self.mapped_at.remove(&memory);
    }

    /// Counts one more build whose contents `cause` kept from being
    /// checked; true for the first of `cause` on this device, which is
    /// when [`crate::report::CONTENTS_NOT_CHECKED`] is reported (once per
    /// device and cause; [`Self::not_checked_counts`] gives the totals).
    pub fn first_report(&mut self, cause: &'static str) -> bool {
        self.first_report_of(cause, 1)
    }

    /// As [`Self::first_report`], counting `builds` builds (none, where
    /// the cause is reported for what it may keep from being checked but
    /// kept no build from it this time).
    pub fn first_report_of(&mut self, cause: &'static str, builds: u64) -> bool {
        self.not_checked.first_report_of(cause, builds)
    }

    /// Each cause of [`Self::first_report`] with the builds it counted, in
    /// the order first reported.
    pub fn not_checked_counts(&self) -> &[(&'static str, u64)] {
        self.not_checked.counts()
    }

    /// Whether `buffer`'s memory is mapped now.
    pub fn is_mapped(&self, buffer: u64) -> bool {
        self.bound
            .get(&buffer)
            .is_some_and(|(memory, _)| self.mapped_at.contains_key(memory))
    }
}

/// Why the bytes of one buffer could not be read at submission.
pub(crate) fn unreadable_reason(state: &DeviceState, buffer: Handle) -> &'static str {
    let Some(tracked) = state.validator.state().buffers.get(&buffer) else {
        return "the buffer holding them is not tracked";
    };
    let Some(binding) = tracked.memory else {
        return "the buffer holding them is not bound to memory";
    };
    if !binding.host_visible {
        return "the buffer holding them is bound to memory that is not host-visible (device-local), and no transfer the layer follows wrote them";
    }
    let mapped = state
        .memory_layout
        .bound
        .get(&buffer)
        .and_then(|(memory, _)| state.memory_layout.mapped_at.get(memory));
    match mapped {
        None => "the buffer holding them is bound to host-visible memory that is not mapped at submission, and no transfer the layer follows wrote them",
        Some(_) => "the mapping of the buffer's memory does not cover what the build reads",
    }
}

/// Where `[offset, offset + len)` of `buffer` lies in host memory the
/// application has mapped, if all of it does (at most [`MAX_HOST_BYTES`]).
pub(crate) fn mapped_address(
    state: &DeviceState,
    buffer: Handle,
    offset: u64,
    len: u64,
) -> Option<usize> {
    if len > MAX_HOST_BYTES {
        return None;
    }
    let size = state.validator.state().buffers.get(&buffer)?.size;
    if offset.checked_add(len)? > size {
        return None;
    }
    let &(memory, bound_at) = state.memory_layout.bound.get(&buffer)?;
    let &mapped_offset = state.memory_layout.mapped_at.get(&memory)?;
    let mapping = state.mappings.get(&memory)?;
    // The window's start inside the mapping.
    let into_mapping = bound_at.checked_add(offset)?.checked_sub(mapped_offset)?;
    if into_mapping.checked_add(len)? > mapping.len {
        return None;
    }
    let address = usize::try_from(mapping.address.checked_add(into_mapping)?).ok()?;
    address.checked_add(usize::try_from(len).ok()?)?;
    Some(address)
}

/// Whether the host can read `[offset, offset + len)` of `buffer` now.
pub fn host_can_read(state: &DeviceState, buffer: Handle, offset: u64, len: u64) -> bool {
    mapped_address(state, buffer, offset, len).is_some()
}

/// A copy of `[offset, offset + len)` of `buffer` from mapped memory.
pub(crate) fn mapped_window(
    state: &DeviceState,
    buffer: Handle,
    offset: u64,
    len: u64,
) -> Option<Vec<u8>> {
    let address = mapped_address(state, buffer, offset, len)?;
    // SAFETY: `[address, address + len)` lies inside the range vkMapMemory
    // returned for the buffer's memory (checked above), which stays mapped
    // until vkUnmapMemory or vkFreeMemory (both of which forget the mapping).
    Some(unsafe { read::mapped_bytes(address, usize::try_from(len).ok()?) }.to_vec())
}
