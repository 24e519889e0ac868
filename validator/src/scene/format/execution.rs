//! The calls that give a scene its execution order: beginning command
//! buffers, submitting them, waiting for the work to complete, resetting
//! queries and joining deferred operations (`docs/scene-format.md`,
//! "Execution order").

use schemars::JsonSchema;
use serde::de::{self, Deserializer};
use serde::Deserialize;

use super::super::args::HandleArg;
use super::CommandBufferArg;

/// `VkSubmitInfo`: the command buffers a batch runs, with its semaphores.
/// `pWaitSemaphoreValues` / `pSignalSemaphoreValues` are those of a chained
/// `VkTimelineSemaphoreSubmitInfo`; a semaphore given a value other than 0
/// is taken to be a timeline semaphore.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct SubmitInfoDesc {
    #[serde(default)]
    pub p_wait_semaphores: Vec<HandleArg>,
    #[serde(default)]
    pub p_wait_semaphore_values: Vec<u64>,
    #[serde(default)]
    pub p_wait_dst_stage_mask: Vec<serde_json::Value>,
    #[serde(default)]
    pub p_command_buffers: Vec<CommandBufferArg>,
    #[serde(default)]
    pub p_signal_semaphores: Vec<HandleArg>,
    #[serde(default)]
    pub p_signal_semaphore_values: Vec<u64>,
}

/// `VkCommandBufferSubmitInfo`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct CommandBufferSubmitInfoDesc {
    pub command_buffer: CommandBufferArg,
    #[serde(default)]
    pub device_mask: u32,
}

/// `VkSemaphoreWaitInfo` of `vkWaitSemaphores`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct SemaphoreWaitInfoDesc {
    #[serde(default)]
    pub flags: u32,
    pub p_semaphores: Vec<HandleArg>,
    pub p_values: Vec<u64>,
}

/// `VkSemaphoreSignalInfo` of `vkSignalSemaphore`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct SemaphoreSignalInfoDesc {
    pub semaphore: HandleArg,
    pub value: u64,
}

/// The calls of execution order, each `{"call": NAME, ...parameters}`;
/// queues, fences and semaphores are named where first used.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(tag = "call", deny_unknown_fields, rename_all_fields = "camelCase")]
pub enum ExecutionCall {
    /// `vkBeginCommandBuffer(commandBuffer, pBeginInfo)`: what the command
    /// buffer recorded before is forgotten.
    #[serde(rename = "vkBeginCommandBuffer")]
    BeginCommandBuffer { command_buffer: CommandBufferArg },
    /// `vkEndCommandBuffer(commandBuffer)`.
    #[serde(rename = "vkEndCommandBuffer")]
    EndCommandBuffer { command_buffer: CommandBufferArg },
    /// `vkCmdExecuteCommands(commandBuffer, commandBufferCount, pCommandBuffers)`.
    #[serde(rename = "vkCmdExecuteCommands")]
    CmdExecuteCommands {
        command_buffer: CommandBufferArg,
        p_command_buffers: Vec<CommandBufferArg>,
    },
    /// `vkQueueSubmit(queue, submitCount, pSubmits, fence)`.
    #[serde(rename = "vkQueueSubmit")]
    QueueSubmit {
        #[serde(default)]
        queue: HandleArg,
        p_submits: Vec<SubmitInfoDesc>,
        #[serde(default)]
        fence: HandleArg,
    },
    /// `vkWaitForFences(device, fenceCount, pFences, waitAll, timeout)`,
    /// returning VK_SUCCESS.
    #[serde(rename = "vkWaitForFences")]
    WaitForFences {
        #[serde(default)]
        device: HandleArg,
        p_fences: Vec<HandleArg>,
        #[serde(default = "super::yes")]
        wait_all: bool,
        #[serde(default)]
        timeout: u64,
    },
    /// `vkResetFences(device, fenceCount, pFences)`.
    #[serde(rename = "vkResetFences")]
    ResetFences {
        #[serde(default)]
        device: HandleArg,
        p_fences: Vec<HandleArg>,
    },
    /// `vkQueueWaitIdle(queue)`, returning VK_SUCCESS.
    #[serde(rename = "vkQueueWaitIdle")]
    QueueWaitIdle {
        #[serde(default)]
        queue: HandleArg,
    },
    /// `vkDeviceWaitIdle(device)`, returning VK_SUCCESS.
    #[serde(rename = "vkDeviceWaitIdle")]
    DeviceWaitIdle {
        #[serde(default)]
        device: HandleArg,
    },
    /// `vkWaitSemaphores(device, pWaitInfo, timeout)`, returning VK_SUCCESS.
    #[serde(rename = "vkWaitSemaphores")]
    WaitSemaphores {
        #[serde(default)]
        device: HandleArg,
        p_wait_info: SemaphoreWaitInfoDesc,
        #[serde(default)]
        timeout: u64,
    },
    /// `vkSignalSemaphore(device, pSignalInfo)`.
    #[serde(rename = "vkSignalSemaphore")]
    SignalSemaphore {
        #[serde(default)]
        device: HandleArg,
        p_signal_info: SemaphoreSignalInfoDesc,
    },
    /// `vkDestroySemaphore(device, semaphore, pAllocator)`.
    #[serde(rename = "vkDestroySemaphore")]
    DestroySemaphore {
        #[serde(default)]
        device: HandleArg,
        semaphore: HandleArg,
    },
    /// `vkCmdResetQueryPool(commandBuffer, queryPool, firstQuery, queryCount)`.
    #[serde(rename = "vkCmdResetQueryPool")]
    CmdResetQueryPool {
        #[serde(default)]
        command_buffer: CommandBufferArg,
        query_pool: HandleArg,
        #[serde(default)]
        first_query: u32,
        query_count: u32,
    },
    /// `vkResetQueryPool(device, queryPool, firstQuery, queryCount)`.
    #[serde(rename = "vkResetQueryPool")]
    ResetQueryPool {
        #[serde(default)]
        device: HandleArg,
        query_pool: HandleArg,
        #[serde(default)]
        first_query: u32,
        query_count: u32,
    },
    /// `vkDeferredOperationJoinKHR(device, operation)` returning
    /// VK_SUCCESS: the operation's command has completed.
    #[serde(rename = "vkDeferredOperationJoinKHR")]
    DeferredOperationJoin {
        #[serde(default)]
        device: HandleArg,
        operation: HandleArg,
    },
}

/// The names of the calls of [`ExecutionCall`].
pub const EXECUTION_CALL_NAMES: [&str; 14] = [
    "vkBeginCommandBuffer",
    "vkEndCommandBuffer",
    "vkCmdExecuteCommands",
    "vkQueueSubmit",
    "vkWaitForFences",
    "vkResetFences",
    "vkQueueWaitIdle",
    "vkDeviceWaitIdle",
    "vkWaitSemaphores",
    "vkSignalSemaphore",
    "vkDestroySemaphore",
    "vkCmdResetQueryPool",
    "vkResetQueryPool",
    "vkDeferredOperationJoinKHR",
];

/// Reads an execution call named `name` from the rest of its object.
pub(super) fn execution_call<'de, D: Deserializer<'de>>(
    name: &str,
    rest: D,
) -> Result<ExecutionCall, D::Error> {
    // The tag was taken off; put it back for the tagged enum.
    let mut object = serde_json::Map::deserialize(rest)?;
    object.insert("call".into(), serde_json::Value::String(name.into()));
    ExecutionCall::deserialize(serde_json::Value::Object(object)).map_err(de::Error::custom)
}
