//! The commands that write buffer memory, which route 1 follows
//! ([`crate::shadow`]), and this layer's intercept table for them and for
//! the commands that tell a submission is complete, which route 2 waits
//! for ([`crate::completion`]). The table is made from the list that makes
//! the next layer's functions for these commands ([`memory_commands`]),
//! with those GPU readback records with ([`crate::readback`]).

#![allow(unsafe_code)]

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;

use crate::commands::{self, Recorded};
use crate::dispatch::next_fns::{memory_commands, DeviceFns};
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::{aliased_intercepts, as_void, device_and, guarded};
use crate::read;
use crate::shadow::Transfer;

// The completion commands' intercepts, found by the names of their fields.
use crate::completion::*;

macro_rules! intercept_table {
    (
        intercepted { $($field:ident: $pfn:ty = $name:literal;)* }
        called { $($called:tt)* }
    ) => {
        /// This layer's function for an intercepted command of this table:
        /// the function named like its field in `MemoryFns`, here or in
        /// [`crate::completion`].
        pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
            $(if name == $name {
                return as_void($field as $pfn);
            })*
            None
        }
    };
}
memory_commands!(intercept_table);

/// Records a command that writes buffer memory (from the content tier on),
/// then records it below.
fn transfer_command<F: Copy>(
    function: &'static str,
    command_buffer: vk::CommandBuffer,
    pick: fn(&DeviceFns) -> Option<F>,
    transfer: impl FnOnce(&DeviceState) -> Transfer,
    call_down: impl FnOnce(F),
) {
    guarded(function, (), || {
        let Some((data, next)) = device_and(command_buffer, pick) else {
            return;
        };
        keep_transfer(&data, command_buffer, transfer);
        call_down(next);
    })
}

fn keep_transfer(
    data: &DeviceData,
    command_buffer: vk::CommandBuffer,
    transfer: impl FnOnce(&DeviceState) -> Transfer,
) {
    let transfer = {
        let state = data.state();
        if !state.reads_contents() {
            return;
        }
        transfer(&state)
    };
    let model = commands::model(command_buffer);
    commands::keep(
        command_buffer,
        &model,
        Recorded::Transfer(Arc::new(transfer)),
    );
}

/// A command that runs shaders was recorded: shaders may write any buffer
/// through its device address, so what transfers made known is forgotten
/// when it runs.
pub fn shaders_run(data: &DeviceData, command_buffer: vk::CommandBuffer) {
    keep_transfer(data, command_buffer, |_| Transfer::Unknown);
}

/// A copy's regions as `(src offset, dst offset, size)`.
fn copy_regions<'a>(regions: impl IntoIterator<Item = &'a vk::BufferCopy>) -> Vec<(u64, u64, u64)> {
    regions
        .into_iter()
        .map(|r| (r.src_offset, r.dst_offset, r.size))
        .collect()
}

unsafe extern "system" fn cmd_copy_buffer(
    command_buffer: vk::CommandBuffer,
    src: vk::Buffer,
    dst: vk::Buffer,
    count: u32,
    regions: *const vk::BufferCopy,
) {
    transfer_command(
        "vkCmdCopyBuffer",
        command_buffer,
        |f| f.memory.cmd_copy_buffer,
        |_| Transfer::Copy {
            src: src.as_raw(),
            dst: dst.as_raw(),
            // SAFETY: `regions` holds `count` regions (the API's requirement).
            regions: copy_regions(unsafe { read::array(regions, count) }),
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, src, dst, count, regions) },
    );
}

/// The transfer of a `VkCopyBufferInfo2`.
///
/// # Safety
/// A non-NULL `info` must be valid as `vkCmdCopyBuffer2` requires.
unsafe fn copy2(info: *const vk::CopyBufferInfo2<'_>) -> Transfer {
    // SAFETY: forwarded from the caller.
    let Some(info) = (unsafe { info.as_ref() }) else {
        return Transfer::Unknown;
    };
    // SAFETY: `pRegions` holds `regionCount` regions (the caller's guarantee).
    let regions = unsafe { read::array(info.p_regions, info.region_count) };
    Transfer::Copy {
        src: info.src_buffer.as_raw(),
        dst: info.dst_buffer.as_raw(),
        regions: regions
            .iter()
            .map(|r| (r.src_offset, r.dst_offset, r.size))
            .collect(),
    }
}

/// `vkCmdCopyBuffer2(KHR)`.
unsafe fn copy_buffer2_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkCmdCopyBuffer2>,
    command_buffer: vk::CommandBuffer,
    info: *const vk::CopyBufferInfo2<'_>,
) {
    transfer_command(
        function,
        command_buffer,
        pick,
        // SAFETY: the application's copy info.
        |_| unsafe { copy2(info) },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, info) },
    );
}

/// `vkCmdCopyImageToBuffer2(KHR)`: what it writes is not followed.
unsafe fn copy_image_to_buffer2_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkCmdCopyImageToBuffer2>,
    command_buffer: vk::CommandBuffer,
    info: *const vk::CopyImageToBufferInfo2<'_>,
) {
    transfer_command(
        function,
        command_buffer,
        pick,
        |_| Transfer::Unknown,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, info) },
    );
}

aliased_intercepts! {
    copy_buffer2_with(command_buffer: vk::CommandBuffer, info: *const vk::CopyBufferInfo2<'_>) -> () {
        cmd_copy_buffer2 = "vkCmdCopyBuffer2", memory.cmd_copy_buffer2;
        cmd_copy_buffer2_khr = "vkCmdCopyBuffer2KHR", memory.cmd_copy_buffer2_khr;
    }
    copy_image_to_buffer2_with(command_buffer: vk::CommandBuffer, info: *const vk::CopyImageToBufferInfo2<'_>) -> () {
        cmd_copy_image_to_buffer2 = "vkCmdCopyImageToBuffer2", memory.cmd_copy_image_to_buffer2;
        cmd_copy_image_to_buffer2_khr = "vkCmdCopyImageToBuffer2KHR", memory.cmd_copy_image_to_buffer2_khr;
    }
}

/// The most bytes `vkCmdUpdateBuffer` may write (its `dataSize` limit).
const MAX_UPDATE: u64 = 65536;

unsafe extern "system" fn cmd_update_buffer(
    command_buffer: vk::CommandBuffer,
    dst: vk::Buffer,
    offset: u64,
    size: u64,
    bytes: *const std::ffi::c_void,
) {
    transfer_command(
        "vkCmdUpdateBuffer",
        command_buffer,
        |f| f.memory.cmd_update_buffer,
        |_| {
            if size > MAX_UPDATE {
                return Transfer::Unknown; // Invalid; what it writes is not followed.
            }
            // SAFETY: `pData` holds `dataSize` bytes (the API's requirement),
            // at most 65536 here.
            let bytes = unsafe { read::array(bytes.cast::<u8>(), size as u32) };
            Transfer::Update {
                dst: dst.as_raw(),
                offset,
                bytes: ommcheck::Bytes::copy_from_slice(bytes),
            }
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, dst, offset, size, bytes) },
    );
}

unsafe extern "system" fn cmd_fill_buffer(
    command_buffer: vk::CommandBuffer,
    dst: vk::Buffer,
    offset: u64,
    size: u64,
    value: u32,
) {
    transfer_command(
        "vkCmdFillBuffer",
        command_buffer,
        |f| f.memory.cmd_fill_buffer,
        |state| {
            // VK_WHOLE_SIZE fills to the end, rounded down to whole words.
            let size = if size == vk::WHOLE_SIZE {
                let buffer = state.validator.state().buffers.get(&dst.as_raw());
                buffer.map_or(0, |b| b.size.saturating_sub(offset) & !3)
            } else {
                size
            };
            Transfer::Fill {
                dst: dst.as_raw(),
                offset,
                size,
                value,
            }
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, dst, offset, size, value) },
    );
}

unsafe extern "system" fn cmd_copy_image_to_buffer(
    command_buffer: vk::CommandBuffer,
    image: vk::Image,
    layout: vk::ImageLayout,
    dst: vk::Buffer,
    count: u32,
    regions: *const vk::BufferImageCopy,
) {
    transfer_command(
        "vkCmdCopyImageToBuffer",
        command_buffer,
        |f| f.memory.cmd_copy_image_to_buffer,
        |_| Transfer::Unknown,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, image, layout, dst, count, regions) },
    );
}

#[allow(clippy::too_many_arguments)] // The command's own parameters.
unsafe extern "system" fn cmd_copy_query_pool_results(
    command_buffer: vk::CommandBuffer,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
    dst: vk::Buffer,
    offset: u64,
    stride: u64,
    flags: vk::QueryResultFlags,
) {
    transfer_command(
        "vkCmdCopyQueryPoolResults",
        command_buffer,
        |f| f.memory.cmd_copy_query_pool_results,
        |_| Transfer::Unknown,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe {
            next(
                command_buffer,
                pool,
                first,
                count,
                dst,
                offset,
                stride,
                flags,
            )
        },
    );
}
