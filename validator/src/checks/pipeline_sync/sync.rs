//! Synchronization: the four barrier structures (stage/access pairs on the
//! source and destination side) and every stage mask that must not name the
//! micromap-build stage while the micromap feature is off.

use ash::vk;
use ommcheck_vuids::vuid::{
    vkCmdResetEvent2 as reset_event, vkCmdWriteBufferMarker2AMD as buffer_marker,
    vkCmdWriteTimestamp2 as timestamp, VkBufferMemoryBarrier2 as buffer_barrier,
    VkImageMemoryBarrier2 as image_barrier, VkMemoryBarrier2 as memory_barrier,
    VkMemoryMarkerInfoAMD as marker_info, VkMemoryRangeBarrierKHR as range_barrier,
    VkSemaphoreSubmitInfo as semaphore_info,
};
use ommcheck_vuids::Vuid;

use crate::checks::{Ctx, Validator};
use crate::model::command::queue;
use crate::model::pipeline::*;
use crate::model::CommandBuffer;
use crate::model::Handle;
use crate::report::Report;
use crate::rules;

pub(super) const ENFORCED: &[Vuid] = &[
    memory_barrier::srcStageMask_11541,
    memory_barrier::dstStageMask_11541,
    memory_barrier::srcAccessMask_07454,
    memory_barrier::dstAccessMask_07454,
    memory_barrier::srcAccessMask_07457,
    memory_barrier::dstAccessMask_07457,
    memory_barrier::srcAccessMask_07458,
    memory_barrier::dstAccessMask_07458,
    buffer_barrier::srcStageMask_11541,
    buffer_barrier::dstStageMask_11541,
    buffer_barrier::srcAccessMask_07454,
    buffer_barrier::dstAccessMask_07454,
    buffer_barrier::srcAccessMask_07457,
    buffer_barrier::dstAccessMask_07457,
    buffer_barrier::srcAccessMask_07458,
    buffer_barrier::dstAccessMask_07458,
    image_barrier::srcStageMask_11541,
    image_barrier::dstStageMask_11541,
    image_barrier::srcAccessMask_07454,
    image_barrier::dstAccessMask_07454,
    image_barrier::srcAccessMask_07457,
    image_barrier::dstAccessMask_07457,
    image_barrier::srcAccessMask_07458,
    image_barrier::dstAccessMask_07458,
    range_barrier::srcStageMask_11541,
    range_barrier::dstStageMask_11541,
    range_barrier::srcAccessMask_07454,
    range_barrier::dstAccessMask_07454,
    range_barrier::srcAccessMask_07457,
    range_barrier::dstAccessMask_07457,
    range_barrier::srcAccessMask_07458,
    range_barrier::dstAccessMask_07458,
    semaphore_info::stageMask_11541,
    reset_event::stageMask_11541,
    timestamp::stage_11541,
    buffer_marker::stage_11541,
    marker_info::stage_11541,
];

/// The VUIDs of one side (source or destination) of one barrier structure.
struct SideVuids {
    micromap_stage: Vuid,
    shader_read: Vuid,
    micromap_write: Vuid,
    micromap_read: Vuid,
}

/// One barrier structure: its name in locations and the VUIDs of both sides.
struct BarrierVuids {
    src: SideVuids,
    dst: SideVuids,
}

macro_rules! barrier_vuids {
    ($m:ident) => {
        BarrierVuids {
            src: SideVuids {
                micromap_stage: $m::srcStageMask_11541,
                shader_read: $m::srcAccessMask_07454,
                micromap_write: $m::srcAccessMask_07457,
                micromap_read: $m::srcAccessMask_07458,
            },
            dst: SideVuids {
                micromap_stage: $m::dstStageMask_11541,
                shader_read: $m::dstAccessMask_07454,
                micromap_write: $m::dstAccessMask_07457,
                micromap_read: $m::dstAccessMask_07458,
            },
        }
    };
}

const MEMORY_BARRIER: BarrierVuids = barrier_vuids!(memory_barrier);
const BUFFER_BARRIER: BarrierVuids = barrier_vuids!(buffer_barrier);
const IMAGE_BARRIER: BarrierVuids = barrier_vuids!(image_barrier);
const RANGE_BARRIER: BarrierVuids = barrier_vuids!(range_barrier);

impl Validator {
    /// `vkCmdPipelineBarrier2(commandBuffer, pDependencyInfo)`.
    pub fn cmd_pipeline_barrier2(
        &mut self,
        command_buffer: &CommandBuffer,
        dependency_info: &DependencyInfo,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdPipelineBarrier2");
        dependency(
            &mut ctx,
            command_buffer.queue_flags,
            "pDependencyInfo",
            dependency_info,
        );
        ctx.finish()
    }

    /// `vkCmdSetEvent2(commandBuffer, event, pDependencyInfo)`.
    pub fn cmd_set_event2(
        &mut self,
        command_buffer: &CommandBuffer,
        event: Handle,
        dependency_info: &DependencyInfo,
    ) -> Report {
        let _ = event;
        let mut ctx = self.ctx("vkCmdSetEvent2");
        dependency(
            &mut ctx,
            command_buffer.queue_flags,
            "pDependencyInfo",
            dependency_info,
        );
        ctx.finish()
    }

    /// `vkCmdWaitEvents2(commandBuffer, eventCount, pEvents, pDependencyInfos)`.
    pub fn cmd_wait_events2(
        &mut self,
        command_buffer: &CommandBuffer,
        events: &[Handle],
        dependency_infos: &[DependencyInfo],
    ) -> Report {
        let _ = events;
        let mut ctx = self.ctx("vkCmdWaitEvents2");
        for (i, info) in dependency_infos.iter().enumerate() {
            let at = format!("pDependencyInfos[{i}]");
            dependency(&mut ctx, command_buffer.queue_flags, &at, info);
        }
        ctx.finish()
    }

    /// `vkQueueSubmit2(queue, submitCount, pSubmits, fence)`.
    pub fn queue_submit2(&mut self, submits: &[SubmitInfo2]) -> Report {
        let mut ctx = self.ctx("vkQueueSubmit2");
        for (i, submit) in submits.iter().enumerate() {
            for (member, infos) in [
                ("pWaitSemaphoreInfos", &submit.wait_semaphore_infos),
                ("pSignalSemaphoreInfos", &submit.signal_semaphore_infos),
            ] {
                for (k, info) in infos.iter().enumerate() {
                    no_micromap_stage(
                        &mut ctx,
                        info.stage_mask,
                        semaphore_info::stageMask_11541,
                        &format!("pSubmits[{i}].{member}[{k}].stageMask"),
                    );
                }
            }
        }
        ctx.finish()
    }

    /// `vkCmdResetEvent2(commandBuffer, event, stageMask)`.
    pub fn cmd_reset_event2(
        &mut self,
        command_buffer: &CommandBuffer,
        event: Handle,
        stage_mask: u64,
    ) -> Report {
        let _ = (command_buffer, event);
        self.stage_only(
            "vkCmdResetEvent2",
            stage_mask,
            reset_event::stageMask_11541,
            "stageMask",
        )
    }

    /// `vkCmdWriteTimestamp2(commandBuffer, stage, queryPool, query)`.
    pub fn cmd_write_timestamp2(
        &mut self,
        command_buffer: &CommandBuffer,
        stage: u64,
        query_pool: Handle,
        query: u32,
    ) -> Report {
        let _ = (command_buffer, query_pool, query);
        self.stage_only(
            "vkCmdWriteTimestamp2",
            stage,
            timestamp::stage_11541,
            "stage",
        )
    }

    /// `vkCmdWriteBufferMarker2AMD(commandBuffer, stage, dstBuffer, dstOffset, marker)`.
    pub fn cmd_write_buffer_marker2_amd(
        &mut self,
        command_buffer: &CommandBuffer,
        stage: u64,
        dst_buffer: Handle,
        dst_offset: u64,
        marker: u32,
    ) -> Report {
        let _ = (command_buffer, dst_buffer, dst_offset, marker);
        self.stage_only(
            "vkCmdWriteBufferMarker2AMD",
            stage,
            buffer_marker::stage_11541,
            "stage",
        )
    }

    /// `vkCmdWriteMarkerToMemoryAMD(commandBuffer, pInfo)`.
    pub fn cmd_write_marker_to_memory_amd(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &MemoryMarkerInfo,
    ) -> Report {
        let _ = command_buffer;
        self.stage_only(
            "vkCmdWriteMarkerToMemoryAMD",
            info.stage,
            marker_info::stage_11541,
            "pInfo.stage",
        )
    }

    fn stage_only(
        &mut self,
        function: &'static str,
        stage_mask: u64,
        vuid: Vuid,
        location: &str,
    ) -> Report {
        let mut ctx = self.ctx(function);
        no_micromap_stage(&mut ctx, stage_mask, vuid, location);
        ctx.finish()
    }
}

/// Every barrier of a `VkDependencyInfo` at `at`, recorded in a command
/// buffer whose pool's queue family has `queue_flags`.
fn dependency(ctx: &mut Ctx<'_>, queue_flags: u32, at: &str, info: &DependencyInfo) {
    let lists = [
        ("pMemoryBarriers", &info.memory_barriers, &MEMORY_BARRIER),
        (
            "pBufferMemoryBarriers",
            &info.buffer_memory_barriers,
            &BUFFER_BARRIER,
        ),
        (
            "pImageMemoryBarriers",
            &info.image_memory_barriers,
            &IMAGE_BARRIER,
        ),
        (
            "pNext<VkMemoryRangeBarriersInfoKHR>.pMemoryRangeBarriers",
            &info.memory_range_barriers,
            &RANGE_BARRIER,
        ),
    ];
    for (member, barriers, vuids) in lists {
        for (i, barrier) in barriers.iter().enumerate() {
            let base = format!("{at}.{member}[{i}]");
            let sides = [
                (
                    barrier.src_stage_mask,
                    barrier.src_access_mask,
                    &vuids.src,
                    "src",
                ),
                (
                    barrier.dst_stage_mask,
                    barrier.dst_access_mask,
                    &vuids.dst,
                    "dst",
                ),
            ];
            for (stage_mask, access_mask, side_vuids, side) in sides {
                let masks = SideMasks {
                    stage_mask,
                    access_mask,
                    queue_flags,
                };
                barrier_side(ctx, masks, side_vuids, &base, side);
            }
        }
    }
}

/// The masks of one side of a barrier, and the queue family it runs on.
#[derive(Clone, Copy)]
struct SideMasks {
    stage_mask: u64,
    access_mask: u64,
    queue_flags: u32,
}

/// The stages among those these rules name that a queue family with
/// `queue_flags` supports (vk.xml's `syncsupport`): what ALL_COMMANDS
/// stands for there. The build stages and the compute and ray-tracing
/// shaders need VK_QUEUE_COMPUTE_BIT; the graphics shader stages need
/// VK_QUEUE_GRAPHICS_BIT.
fn all_commands_on(queue_flags: u32) -> u64 {
    let compute_stages = STAGE_ACCELERATION_STRUCTURE_BUILD
        | STAGE_MICROMAP_BUILD
        | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
        | vk::PipelineStageFlags2::RAY_TRACING_SHADER_KHR.as_raw();
    let mut stages = 0;
    if queue_flags & queue::COMPUTE != 0 {
        stages |= compute_stages;
    }
    if queue_flags & queue::GRAPHICS != 0 {
        stages |= STAGE_ALL_GRAPHICS | (STAGES_SHADER & !compute_stages);
    }
    stages
}

/// The stage mask of one side, and the accesses it must cover.
fn barrier_side(ctx: &mut Ctx<'_>, masks: SideMasks, vuids: &SideVuids, base: &str, side: &str) {
    let SideMasks {
        stage_mask,
        access_mask,
        queue_flags,
    } = masks;
    let stage_at = || format!("{base}.{side}StageMask");
    no_micromap_stage(ctx, stage_mask, vuids.micromap_stage, &stage_at());
    // ALL_COMMANDS stands for the stages the queue family supports: on a
    // queue without compute it includes neither build stage.
    let on_queue = if stage_mask & STAGE_ALL_COMMANDS != 0 {
        all_commands_on(queue_flags)
    } else {
        0
    };
    let covers = |stages: u64| (stage_mask | on_queue) & stages != 0;
    let shader_read_stages =
        STAGE_ACCELERATION_STRUCTURE_BUILD | STAGE_MICROMAP_BUILD | STAGES_SHADER;
    let requirements = [
        (
            ACCESS_SHADER_READ,
            "VK_ACCESS_2_SHADER_READ_BIT",
            // 07454 names ALL_GRAPHICS and ALL_COMMANDS themselves.
            STAGE_ALL_GRAPHICS | STAGE_ALL_COMMANDS | shader_read_stages,
            "ALL_GRAPHICS, ALL_COMMANDS, ACCELERATION_STRUCTURE_BUILD, MICROMAP_BUILD or a shader stage",
            vuids.shader_read,
        ),
        (
            ACCESS_MICROMAP_WRITE,
            "VK_ACCESS_2_MICROMAP_WRITE_BIT_EXT",
            STAGE_MICROMAP_BUILD,
            "VK_PIPELINE_STAGE_2_MICROMAP_BUILD_BIT_EXT",
            vuids.micromap_write,
        ),
        (
            ACCESS_MICROMAP_READ,
            "VK_ACCESS_2_MICROMAP_READ_BIT_EXT",
            STAGE_MICROMAP_BUILD | STAGE_ACCELERATION_STRUCTURE_BUILD,
            "MICROMAP_BUILD or ACCELERATION_STRUCTURE_BUILD",
            vuids.micromap_read,
        ),
    ];
    for (access, access_name, stages, stages_name, vuid) in requirements {
        if access_mask & access != 0 && !covers(stages) {
            let on = if stage_mask & STAGE_ALL_COMMANDS != 0 {
                format!(
                    " (ALL_COMMANDS on a queue family with {})",
                    queue_flag_names(queue_flags)
                )
            } else {
                String::new()
            };
            ctx.error(
                vuid,
                stage_at(),
                format!("{stage_mask:#x} includes none of {stages_name}{on}, but {side}AccessMask {access_mask:#x} includes {access_name}"),
            );
        }
    }
    // A shader read whose only stage is ALL_COMMANDS satisfies 07454's
    // letter; on a queue where no stage can read through a shader it still
    // names an access no stage of the mask performs.
    let literal_shader_read = STAGE_ALL_GRAPHICS | shader_read_stages;
    if access_mask & ACCESS_SHADER_READ != 0
        && stage_mask & STAGE_ALL_COMMANDS != 0
        && stage_mask & literal_shader_read == 0
        && on_queue & shader_read_stages == 0
    {
        ctx.error(
            &rules::ACCESS_STAGE_ON_QUEUE,
            stage_at(),
            format!("{stage_mask:#x} is ALL_COMMANDS on a queue family with {}, none of whose stages can perform VK_ACCESS_2_SHADER_READ_BIT, which {side}AccessMask {access_mask:#x} includes", queue_flag_names(queue_flags)),
        );
    }
}

/// `VkQueueFlags` as names, for messages.
fn queue_flag_names(queue_flags: u32) -> String {
    let names: Vec<&str> = [
        (queue::GRAPHICS, "VK_QUEUE_GRAPHICS_BIT"),
        (queue::COMPUTE, "VK_QUEUE_COMPUTE_BIT"),
        (queue::TRANSFER, "VK_QUEUE_TRANSFER_BIT"),
    ]
    .into_iter()
    .filter(|(bit, _)| queue_flags & bit != 0)
    .map(|(_, name)| name)
    .collect();
    if names.is_empty() {
        format!("queueFlags {queue_flags:#x}")
    } else {
        names.join(" | ")
    }
}

/// 11541: without the EXT micromap feature no mask may name MICROMAP_BUILD.
fn no_micromap_stage(ctx: &mut Ctx<'_>, stage_mask: u64, vuid: Vuid, location: &str) {
    ctx.require(
        ctx.device.features.micromap_ext || stage_mask & STAGE_MICROMAP_BUILD == 0,
        vuid,
        || location.to_string(),
        || format!("{stage_mask:#x} contains VK_PIPELINE_STAGE_2_MICROMAP_BUILD_BIT_EXT, but the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromap feature is not enabled"),
    );
}
