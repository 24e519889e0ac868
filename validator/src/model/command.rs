//! The command buffer a `vkCmd*` call records into.

use serde::{Deserialize, Serialize};

use crate::model::Handle;

/// `VkQueueFlagBits` the checks read.
pub mod queue {
    pub const GRAPHICS: u32 = 0x1;
    pub const COMPUTE: u32 = 0x2;
    pub const TRANSFER: u32 = 0x4;
}

/// What the checks need to know about a command buffer at a `vkCmd*` call.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct CommandBuffer {
    pub handle: Handle,
    /// In the recording state (between vkBeginCommandBuffer and vkEndCommandBuffer).
    pub recording: bool,
    /// `VkQueueFlags` of the queue family of the pool it was allocated from.
    pub queue_flags: u32,
    /// Inside a render pass instance.
    pub in_render_pass: bool,
    /// Inside a video coding scope.
    pub in_video_coding: bool,
    /// Inside a suspended render pass instance (dynamic rendering).
    pub suspended: bool,
}

impl Default for CommandBuffer {
    /// A primary command buffer recording on a compute-capable queue, outside
    /// any render pass: where build commands belong.
    fn default() -> Self {
        Self {
            handle: 0xcb,
            recording: true,
            queue_flags: queue::GRAPHICS | queue::COMPUTE | queue::TRANSFER,
            in_render_pass: false,
            in_video_coding: false,
            suspended: false,
        }
    }
}

/// A semaphore wait or signal of a submission, as execution order reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct SemaphoreOp {
    pub semaphore: Handle,
    /// The timeline value (ignored for a binary semaphore).
    pub value: u64,
    /// A timeline semaphore (`VK_SEMAPHORE_TYPE_TIMELINE`), not a binary one.
    pub timeline: bool,
}

/// One batch of a queue submission (`VkSubmitInfo` or `VkSubmitInfo2`):
/// the semaphores it waits on, its command buffers in order, and the
/// semaphores it signals.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct SubmitBatch {
    pub waits: Vec<SemaphoreOp>,
    pub command_buffers: Vec<Handle>,
    pub signals: Vec<SemaphoreOp>,
}
