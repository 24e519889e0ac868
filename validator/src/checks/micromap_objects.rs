//! `VK_EXT_opacity_micromap` micromap objects: `vkCreateMicromapEXT`,
//! `vkDestroyMicromapEXT`, the copies and (de)serializations on the device
//! and on the host, the property queries, `vkGetMicromapBuildSizesEXT`,
//! `vkGetDeviceMicromapCompatibilityEXT`, and the micromap rules of
//! `vkCmdBeginQuery*`.

use ommcheck_vuids::vuid::{
    vkCmdBeginQuery as begin_query, vkCmdBeginQueryIndexedEXT as begin_query_indexed,
    vkCmdCopyMemoryToMicromapEXT as cmd_from_memory, vkCmdCopyMicromapEXT as cmd_copy,
    vkCmdCopyMicromapToMemoryEXT as cmd_to_memory, vkCmdWriteMicromapsPropertiesEXT as cmd_write,
    vkCopyMemoryToMicromapEXT as host_from_memory, vkCopyMicromapEXT as host_copy,
    vkCopyMicromapToMemoryEXT as host_to_memory, vkCreateMicromapEXT as create,
    vkDestroyMicromapEXT as destroy, vkGetDeviceMicromapCompatibilityEXT as compatibility,
    vkGetMicromapBuildSizesEXT as build_sizes, vkWriteMicromapsPropertiesEXT as host_write,
    VkCopyMemoryToMicromapInfoEXT as from_memory_info, VkCopyMicromapInfoEXT as copy_info,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info, VkMicromapBuildSizesInfoEXT as sizes_info,
    VkMicromapCreateInfoEXT as create_info, VkMicromapVersionInfoEXT as version_info,
};
use ommcheck_vuids::Vuid;

use crate::checks::common::{self, CommandBufferVuids};
use crate::checks::provenance;
use crate::checks::Coverage;
use crate::checks::{Ctx, Validator};
use crate::model::micromap_objects::*;
use crate::model::values::*;
use crate::model::Handle;
use crate::model::{CommandBuffer, MicromapBuildInfo};
use crate::report::count as count_of;
use crate::report::{ObjectRef, Report};
use crate::state::execution::{ExecEvent, ReadRule};
use crate::state::{HostRange, MemoryBinding, Micromap};

pub const COVERAGE: Coverage = Coverage {
    module: "micromap_objects",
    enforced: &[
        create_info::buffer_07435,
        create_info::buffer_07436,
        create_info::buffer_parameter,
        create_info::bufferDeviceAddressMultiDevice_11617,
        create_info::createFlags_parameter,
        create_info::deviceAddress_07433,
        create_info::deviceAddress_parameter,
        create_info::micromapCaptureReplay_11616,
        create_info::offset_07437,
        create_info::offset_07438,
        create_info::pNext_pNext,
        create_info::sType_sType,
        create_info::type_parameter,
        create::device_parameter,
        create::device_queuecount,
        create::micromap_11615,
        create::pAllocator_parameter,
        create::pCreateInfo_parameter,
        create::pMicromap_parameter,
        destroy::device_parameter,
        destroy::micromap_07442,
        destroy::micromap_07443,
        destroy::micromap_11619,
        destroy::micromap_parameter,
        destroy::pAllocator_parameter,
        copy_info::dst_parameter,
        copy_info::mode_07531,
        copy_info::mode_07533,
        copy_info::pNext_pNext,
        copy_info::sType_sType,
        copy_info::src_parameter,
        to_memory_info::mode_07542,
        to_memory_info::mode_parameter,
        to_memory_info::pNext_pNext,
        to_memory_info::sType_sType,
        to_memory_info::src_parameter,
        from_memory_info::dst_parameter,
        from_memory_info::mode_07548,
        from_memory_info::mode_parameter,
        from_memory_info::pNext_pNext,
        from_memory_info::sType_sType,
        cmd_copy::buffer_07529,
        cmd_copy::buffer_07530,
        cmd_copy::commandBuffer_cmdpool,
        cmd_copy::commandBuffer_parameter,
        cmd_copy::commandBuffer_recording,
        cmd_copy::pInfo_parameter,
        cmd_copy::renderpass,
        cmd_copy::suspended,
        cmd_copy::videocoding,
        cmd_to_memory::buffer_07539,
        cmd_to_memory::commandBuffer_cmdpool,
        cmd_to_memory::commandBuffer_parameter,
        cmd_to_memory::commandBuffer_recording,
        cmd_to_memory::pInfo_07536,
        cmd_to_memory::pInfo_07537,
        cmd_to_memory::pInfo_parameter,
        cmd_to_memory::renderpass,
        cmd_to_memory::suspended,
        cmd_to_memory::videocoding,
        cmd_from_memory::buffer_07546,
        cmd_from_memory::commandBuffer_cmdpool,
        cmd_from_memory::commandBuffer_parameter,
        cmd_from_memory::commandBuffer_recording,
        cmd_from_memory::pInfo_07543,
        cmd_from_memory::pInfo_07544,
        cmd_from_memory::pInfo_parameter,
        cmd_from_memory::renderpass,
        cmd_from_memory::suspended,
        cmd_from_memory::videocoding,
        host_copy::buffer_07558,
        host_copy::buffer_07559,
        host_copy::buffer_07561,
        host_copy::buffer_07562,
        host_copy::deferredOperation_parameter,
        host_copy::device_parameter,
        host_copy::micromapHostCommands_07560,
        host_copy::pInfo_parameter,
        host_to_memory::buffer_07568,
        host_to_memory::buffer_07572,
        host_to_memory::deferredOperation_parameter,
        host_to_memory::device_parameter,
        host_to_memory::micromapHostCommands_07571,
        host_to_memory::pInfo_07569,
        host_to_memory::pInfo_07570,
        host_to_memory::pInfo_parameter,
        host_from_memory::buffer_07565,
        host_from_memory::buffer_07567,
        host_from_memory::deferredOperation_parameter,
        host_from_memory::device_parameter,
        host_from_memory::micromapHostCommands_07566,
        host_from_memory::pInfo_07563,
        host_from_memory::pInfo_07564,
        host_from_memory::pInfo_parameter,
        cmd_write::buffer_07527,
        cmd_write::commandBuffer_cmdpool,
        cmd_write::commandBuffer_parameter,
        cmd_write::commandBuffer_recording,
        cmd_write::micromapCount_arraylength,
        cmd_write::pMicromaps_07502,
        cmd_write::pMicromaps_parameter,
        cmd_write::query_07528,
        cmd_write::queryPool_07525,
        cmd_write::queryPool_parameter,
        cmd_write::queryType_07503,
        cmd_write::renderpass,
        cmd_write::suspended,
        cmd_write::videocoding,
        host_write::buffer_07577,
        host_write::buffer_07579,
        host_write::dataSize_07576,
        host_write::dataSize_arraylength,
        host_write::device_parameter,
        host_write::micromapCount_arraylength,
        host_write::micromapHostCommands_07578,
        host_write::pData_parameter,
        host_write::pMicromaps_07502,
        host_write::pMicromaps_parameter,
        host_write::queryType_07503,
        host_write::queryType_10071,
        host_write::queryType_10072,
        host_write::queryType_parameter,
        build_sizes::buildType_parameter,
        build_sizes::device_07440,
        build_sizes::device_parameter,
        build_sizes::micromap_11618,
        build_sizes::pBuildInfo_parameter,
        build_sizes::pSizeInfo_parameter,
        sizes_info::pNext_pNext,
        sizes_info::sType_sType,
        compatibility::device_parameter,
        compatibility::micromap_11666,
        compatibility::pCompatibility_parameter,
        compatibility::pVersionInfo_parameter,
        version_info::pNext_pNext,
        version_info::pVersionData_parameter,
        version_info::sType_sType,
        begin_query::queryType_08972,
        begin_query_indexed::queryType_08972,
        copy_info::commonparent,
        destroy::micromap_parent,
        host_write::pMicromaps_parent,
        cmd_write::commonparent,
        host_copy::deferredOperation_parent,
        host_to_memory::deferredOperation_parent,
        host_from_memory::deferredOperation_parent,
        host_copy::deferredOperation_03678,
        host_to_memory::deferredOperation_03678,
        host_from_memory::deferredOperation_03678,
        from_memory_info::dst_07550,
        from_memory_info::src_07547,
    ],
    not_decidable: &[],
};

impl Validator {
    /// A host copy's read of micromap `pInfo->src` (absent without an
    /// info): it must be constructed by work the host has seen complete.
    fn host_src_constructed(
        &self,
        function: &'static str,
        vuid: Vuid,
        src: Option<Handle>,
    ) -> Report {
        let reads: Vec<_> = src
            .map(|src| ("pInfo->src".to_string(), src))
            .into_iter()
            .collect();
        self.host_reads_constructed(function, vuid, &reads)
    }
}

/// The non-NULL micromaps of `pMicromaps` within `micromapCount`, with their indices.
fn listed_handles(list: &MicromapList) -> impl Iterator<Item = (usize, Handle)> + '_ {
    let count = usize::try_from(list.count).unwrap_or(usize::MAX);
    list.handles
        .iter()
        .flatten()
        .take(count)
        .enumerate()
        .filter(|(_, h)| **h != 0)
        .map(|(k, h)| (k, *h))
}

/// The alignment of a device address that serialized data is read from or written to.
const SERIALIZED_DEVICE_ALIGNMENT: u64 = 256;
/// The alignment of a host address that serialized data is read from or written to.
const SERIALIZED_HOST_ALIGNMENT: u64 = 16;
/// The alignment `VkMicromapCreateInfoEXT::offset` needs.
const MICROMAP_OFFSET_ALIGNMENT: u64 = 256;
/// `sizeof(VkDeviceSize)`.
const DEVICE_SIZE_BYTES: u64 = 8;

/// The rules one host copy command states about the micromaps it touches.
struct HostMemoryVuids {
    host_visible: Vuid,
    single_instance: Vuid,
}

/// The implicit rules every host command states about its handles.
struct HostCallVuids {
    device: Vuid,
    deferred_operation: common::DeferredOperationVuids,
    host_commands: Vuid,
    info: Vuid,
}

impl Validator {
    /// `vkCreateMicromapEXT(device, pCreateInfo, pAllocator, pMicromap)`;
    /// `micromap` is `None` for a NULL `pMicromap`, else the handle the call
    /// returned, which is then tracked: the call's rules
    /// ([`Self::create_micromap_rules`]), then its record
    /// ([`Self::record_micromap`]).
    pub fn create_micromap(
        &mut self,
        device: Handle,
        info: Option<&MicromapCreateInfo>,
        allocator: Option<&AllocationCallbacks>,
        micromap: Option<Handle>,
    ) -> Report {
        let report = self.create_micromap_rules(device, info, allocator, micromap);
        if let (Some(info), Some(handle)) = (info, micromap) {
            self.record_micromap(handle, info, allocator.is_some());
        }
        report
    }

    /// The rules of `vkCreateMicromapEXT`, before the call (`micromap`:
    /// whether `pMicromap` is NULL, its value unread); records nothing.
    pub fn create_micromap_rules(
        &self,
        device: Handle,
        info: Option<&MicromapCreateInfo>,
        allocator: Option<&AllocationCallbacks>,
        micromap: Option<Handle>,
    ) -> Report {
        let mut ctx = self.ctx("vkCreateMicromapEXT");
        common::device_handle(&mut ctx, device, create::device_parameter);
        ctx.require(
            ctx.device.queue_count > 0,
            create::device_queuecount,
            || "device".into(),
            || "the device was created with no queues".into(),
        );
        micromap_feature(&mut ctx, create::micromap_11615);
        allocation_callbacks(&mut ctx, allocator, create::pAllocator_parameter);
        ctx.require(
            micromap.is_some(),
            create::pMicromap_parameter,
            || "pMicromap".into(),
            || "pMicromap is NULL".into(),
        );
        let Some(info) = info else {
            ctx.error(
                create::pCreateInfo_parameter,
                "pCreateInfo",
                "pCreateInfo is NULL",
            );
            return ctx.finish();
        };
        micromap_create_info(&mut ctx, info);
        ctx.finish()
    }

    /// Tracks the micromap `vkCreateMicromapEXT` created from `info`
    /// (`micromap`; 0: none, nothing is tracked), without checking the
    /// call: a layer runs [`Self::create_micromap_rules`] before calling
    /// down and records the handle the driver returned with this.
    pub fn record_micromap(
        &mut self,
        micromap: Handle,
        info: &MicromapCreateInfo,
        with_allocator: bool,
    ) {
        if micromap != 0 {
            let record = self.created_micromap(info, with_allocator);
            self.state.micromaps.insert(micromap, record);
        }
    }

    /// What the checker remembers of a micromap `info` created.
    fn created_micromap(&self, info: &MicromapCreateInfo, allocator: bool) -> Micromap {
        let buffer_address = self.state.device_address_in(info.buffer, info.offset);
        let device_address = if info.device_address != 0 {
            info.device_address
        } else {
            buffer_address.unwrap_or(0)
        };
        Micromap {
            buffer: info.buffer,
            offset: info.offset,
            size: info.size,
            ty: info.ty,
            create_flags: info.create_flags,
            device_address,
            allocator,
            built: None,
        }
    }

    /// `vkDestroyMicromapEXT(device, micromap, pAllocator)`; stops tracking
    /// the micromap: the rules ([`Self::destroy_micromap_rules`]), then the
    /// record ([`Self::record_micromap_destroyed`]).
    pub fn destroy_micromap(
        &mut self,
        device: Handle,
        micromap: Handle,
        allocator: Option<&AllocationCallbacks>,
    ) -> Report {
        let report = self.destroy_micromap_rules(device, micromap, allocator);
        self.record_micromap_destroyed(micromap);
        report
    }

    /// The rules of `vkDestroyMicromapEXT`, before the call; records nothing.
    pub fn destroy_micromap_rules(
        &self,
        device: Handle,
        micromap: Handle,
        allocator: Option<&AllocationCallbacks>,
    ) -> Report {
        let mut ctx = self.ctx("vkDestroyMicromapEXT");
        common::device_handle(&mut ctx, device, destroy::device_parameter);
        micromap_feature(&mut ctx, destroy::micromap_11619);
        allocation_callbacks(&mut ctx, allocator, destroy::pAllocator_parameter);
        common::other_device(&mut ctx, micromap, destroy::micromap_parent, "micromap");
        if micromap != 0 {
            if let Some(tracked) =
                tracked_micromap(&mut ctx, micromap, destroy::micromap_parameter, "micromap")
            {
                match (tracked.allocator, allocator.is_some()) {
                    (true, false) => {
                        ctx.error(
                            destroy::micromap_07442,
                            "pAllocator",
                            "the micromap was created with VkAllocationCallbacks, but pAllocator is NULL",
                        );
                    }
                    (false, true) => {
                        ctx.error(
                            destroy::micromap_07443,
                            "pAllocator",
                            "the micromap was created without VkAllocationCallbacks, but pAllocator is not NULL",
                        );
                    }
                    _ => {}
                }
            }
        }
        let mut report = ctx.finish();
        if micromap != 0 {
            report.extend(self.destroyed_in_flight(micromap));
        }
        report
    }

    /// Stops tracking `micromap`, which `vkDestroyMicromapEXT` destroyed.
    pub fn record_micromap_destroyed(&mut self, micromap: Handle) {
        self.state.micromaps.remove(&micromap);
        self.state.execution.forget(micromap);
        self.state.provenance.forget(micromap);
        self.state.driver.forget_micromap(micromap);
    }

    /// `vkCmdCopyMicromapEXT(commandBuffer, pInfo)`; `None` is a NULL
    /// `pInfo`: the rules ([`Self::cmd_copy_micromap_rules`]), then the
    /// record ([`Self::record_cmd_copy_micromap`]).
    pub fn cmd_copy_micromap(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapInfo>,
    ) -> Report {
        let report = self.cmd_copy_micromap_rules(command_buffer, info);
        self.record_cmd_copy_micromap(command_buffer, info);
        report
    }

    /// The rules of `vkCmdCopyMicromapEXT`; records nothing.
    pub fn cmd_copy_micromap_rules(
        &self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdCopyMicromapEXT");
        common::command_buffer(
            &mut ctx,
            command_buffer,
            &CommandBufferVuids {
                parameter: cmd_copy::commandBuffer_parameter,
                recording: cmd_copy::commandBuffer_recording,
                cmdpool: cmd_copy::commandBuffer_cmdpool,
                renderpass: Some(cmd_copy::renderpass),
                videocoding: Some(cmd_copy::videocoding),
                suspended: Some(cmd_copy::suspended),
            },
        );
        if let Some(info) = required_info(&mut ctx, info, cmd_copy::pInfo_parameter) {
            let (src, dst) = copy_micromap_info(&mut ctx, info);
            bound_to_device_memory(&mut ctx, src, cmd_copy::buffer_07529, "pInfo->src");
            bound_to_device_memory(&mut ctx, dst, cmd_copy::buffer_07530, "pInfo->dst");
        }
        ctx.finish()
    }

    /// Records the copy `vkCmdCopyMicromapEXT` put in `command_buffer`.
    pub fn record_cmd_copy_micromap(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapInfo>,
    ) {
        if let Some(info) = info {
            let events = [
                ExecEvent::Read {
                    object: info.src,
                    rule: ReadRule::CopySource,
                    location: "pInfo->src".into(),
                },
                ExecEvent::Construct { object: info.dst },
            ];
            self.record_execution(command_buffer, "vkCmdCopyMicromapEXT", events);
            provenance::record_copy(&mut self.state, info.src, info.dst);
        }
    }

    /// `vkCmdCopyMicromapToMemoryEXT(commandBuffer, pInfo)`: `dst` is a
    /// device address. The rules ([`Self::cmd_copy_micromap_to_memory_rules`]),
    /// then the record ([`Self::record_cmd_copy_micromap_to_memory`]).
    pub fn cmd_copy_micromap_to_memory(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) -> Report {
        let report = self.cmd_copy_micromap_to_memory_rules(command_buffer, info);
        self.record_cmd_copy_micromap_to_memory(command_buffer, info);
        report
    }

    /// The rules of `vkCmdCopyMicromapToMemoryEXT`; records nothing.
    pub fn cmd_copy_micromap_to_memory_rules(
        &self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdCopyMicromapToMemoryEXT");
        common::command_buffer(
            &mut ctx,
            command_buffer,
            &CommandBufferVuids {
                parameter: cmd_to_memory::commandBuffer_parameter,
                recording: cmd_to_memory::commandBuffer_recording,
                cmdpool: cmd_to_memory::commandBuffer_cmdpool,
                renderpass: Some(cmd_to_memory::renderpass),
                videocoding: Some(cmd_to_memory::videocoding),
                suspended: Some(cmd_to_memory::suspended),
            },
        );
        if let Some(info) = required_info(&mut ctx, info, cmd_to_memory::pInfo_parameter) {
            let src = copy_micromap_to_memory_info(&mut ctx, info);
            bound_to_device_memory(&mut ctx, src, cmd_to_memory::buffer_07539, "pInfo->src");
            serialized_device_address(
                &mut ctx,
                info.dst,
                cmd_to_memory::pInfo_07536,
                cmd_to_memory::pInfo_07537,
                "pInfo->dst.deviceAddress",
            );
            crate::checks::driver_sizes::serialized_size_fits(&mut ctx, info, false);
        }
        ctx.finish()
    }

    /// Records the serialization `vkCmdCopyMicromapToMemoryEXT` put in
    /// `command_buffer`.
    pub fn record_cmd_copy_micromap_to_memory(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) {
        if let Some(info) = info {
            let read = ExecEvent::Read {
                object: info.src,
                rule: ReadRule::SerializeSource,
                location: "pInfo->src".into(),
            };
            self.record_execution(command_buffer, "vkCmdCopyMicromapToMemoryEXT", [read]);
            let function = "vkCmdCopyMicromapToMemoryEXT";
            provenance::record_micromap_serialization(
                &mut self.state,
                function,
                false,
                info.src,
                info.dst,
            );
        }
    }

    /// `vkCmdCopyMemoryToMicromapEXT(commandBuffer, pInfo)`: `src` is a
    /// device address. The rules ([`Self::cmd_copy_memory_to_micromap_rules`]),
    /// then the record ([`Self::record_cmd_copy_memory_to_micromap`]).
    pub fn cmd_copy_memory_to_micromap(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMemoryToMicromapInfo>,
    ) -> Report {
        let report = self.cmd_copy_memory_to_micromap_rules(command_buffer, info);
        self.record_cmd_copy_memory_to_micromap(command_buffer, info);
        report
    }

    /// The rules of `vkCmdCopyMemoryToMicromapEXT`; records nothing.
    pub fn cmd_copy_memory_to_micromap_rules(
        &self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMemoryToMicromapInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdCopyMemoryToMicromapEXT");
        common::command_buffer(
            &mut ctx,
            command_buffer,
            &CommandBufferVuids {
                parameter: cmd_from_memory::commandBuffer_parameter,
                recording: cmd_from_memory::commandBuffer_recording,
                cmdpool: cmd_from_memory::commandBuffer_cmdpool,
                renderpass: Some(cmd_from_memory::renderpass),
                videocoding: Some(cmd_from_memory::videocoding),
                suspended: Some(cmd_from_memory::suspended),
            },
        );
        if let Some(info) = required_info(&mut ctx, info, cmd_from_memory::pInfo_parameter) {
            let dst = copy_memory_to_micromap_info(&mut ctx, info);
            bound_to_device_memory(&mut ctx, dst, cmd_from_memory::buffer_07546, "pInfo->dst");
            crate::checks::driver_sizes::compatible_source(&mut ctx, info, false);
            serialized_device_address(
                &mut ctx,
                info.src,
                cmd_from_memory::pInfo_07543,
                cmd_from_memory::pInfo_07544,
                "pInfo->src.deviceAddress",
            );
            provenance::micromap_source(&mut ctx, false, info.src, info.dst);
        }
        ctx.finish()
    }

    /// Records the deserialization `vkCmdCopyMemoryToMicromapEXT` put in
    /// `command_buffer`.
    pub fn record_cmd_copy_memory_to_micromap(
        &mut self,
        command_buffer: &CommandBuffer,
        info: Option<&CopyMemoryToMicromapInfo>,
    ) {
        if let Some(info) = info {
            let construct = ExecEvent::Construct { object: info.dst };
            self.record_execution(command_buffer, "vkCmdCopyMemoryToMicromapEXT", [construct]);
            self.record_deserialization(false, info.src, info.dst, false);
        }
    }

    /// `vkCopyMicromapEXT(device, deferredOperation, pInfo)`: the rules
    /// ([`Self::copy_micromap_rules`]), then the record
    /// ([`Self::record_copy_micromap`]).
    pub fn copy_micromap(
        &mut self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMicromapInfo>,
    ) -> Report {
        let report = self.copy_micromap_rules(device, deferred_operation, info);
        self.record_copy_micromap(deferred_operation, info);
        report
    }

    /// The rules of `vkCopyMicromapEXT`, before the call; records nothing.
    pub fn copy_micromap_rules(
        &self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMicromapInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkCopyMicromapEXT");
        let vuids = HostCallVuids {
            device: host_copy::device_parameter,
            deferred_operation: common::DeferredOperationVuids {
                parameter: host_copy::deferredOperation_parameter,
                parent: host_copy::deferredOperation_parent,
                complete: Some(host_copy::deferredOperation_03678),
            },
            host_commands: host_copy::micromapHostCommands_07560,
            info: host_copy::pInfo_parameter,
        };
        if let Some(info) = host_call(&mut ctx, device, deferred_operation, info, &vuids) {
            let (src, dst) = copy_micromap_info(&mut ctx, info);
            let src_vuids = HostMemoryVuids {
                host_visible: host_copy::buffer_07558,
                single_instance: host_copy::buffer_07561,
            };
            let dst_vuids = HostMemoryVuids {
                host_visible: host_copy::buffer_07559,
                single_instance: host_copy::buffer_07562,
            };
            host_accessible(&mut ctx, src, &src_vuids, "pInfo->src");
            host_accessible(&mut ctx, dst, &dst_vuids, "pInfo->dst");
        }
        let mut report = ctx.finish();
        report.extend(self.host_src_constructed(
            "vkCopyMicromapEXT",
            host_copy::src_11670,
            info.map(|i| i.src),
        ));
        report
    }

    /// Records the copy `vkCopyMicromapEXT` made (or, deferred, is making).
    pub fn record_copy_micromap(
        &mut self,
        deferred_operation: Handle,
        info: Option<&CopyMicromapInfo>,
    ) {
        self.defer(deferred_operation);
        if let Some(info) = info {
            self.constructed_on_host(info.dst, deferred_operation);
            provenance::record_copy(&mut self.state, info.src, info.dst);
        }
    }

    /// `vkCopyMicromapToMemoryEXT(device, deferredOperation, pInfo)`: `dst`
    /// is a host address. The rules ([`Self::copy_micromap_to_memory_rules`]),
    /// then the record ([`Self::record_copy_micromap_to_memory`]).
    pub fn copy_micromap_to_memory(
        &mut self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) -> Report {
        let report = self.copy_micromap_to_memory_rules(device, deferred_operation, info);
        self.record_copy_micromap_to_memory(deferred_operation, info);
        report
    }

    /// The rules of `vkCopyMicromapToMemoryEXT`, before the call; records
    /// nothing.
    pub fn copy_micromap_to_memory_rules(
        &self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkCopyMicromapToMemoryEXT");
        let vuids = HostCallVuids {
            device: host_to_memory::device_parameter,
            deferred_operation: common::DeferredOperationVuids {
                parameter: host_to_memory::deferredOperation_parameter,
                parent: host_to_memory::deferredOperation_parent,
                complete: Some(host_to_memory::deferredOperation_03678),
            },
            host_commands: host_to_memory::micromapHostCommands_07571,
            info: host_to_memory::pInfo_parameter,
        };
        if let Some(info) = host_call(&mut ctx, device, deferred_operation, info, &vuids) {
            let src = copy_micromap_to_memory_info(&mut ctx, info);
            let src_vuids = HostMemoryVuids {
                host_visible: host_to_memory::buffer_07568,
                single_instance: host_to_memory::buffer_07572,
            };
            host_accessible(&mut ctx, src, &src_vuids, "pInfo->src");
            serialized_host_address(
                &mut ctx,
                info.dst,
                host_to_memory::pInfo_07569,
                host_to_memory::pInfo_07570,
                "pInfo->dst.hostAddress",
            );
            crate::checks::driver_sizes::serialized_size_fits(&mut ctx, info, true);
        }
        let mut report = ctx.finish();
        report.extend(self.host_src_constructed(
            "vkCopyMicromapToMemoryEXT",
            to_memory_info::src_07540,
            info.map(|i| i.src),
        ));
        report
    }

    /// Records the serialization `vkCopyMicromapToMemoryEXT` made: its
    /// deferred operation, which runs it until reported complete, and the
    /// serialization where it writes (`provenance`).
    pub fn record_copy_micromap_to_memory(
        &mut self,
        deferred_operation: Handle,
        info: Option<&CopyMicromapToMemoryInfo>,
    ) {
        self.defer(deferred_operation);
        if let Some(info) = info {
            let function = "vkCopyMicromapToMemoryEXT";
            provenance::record_micromap_serialization(
                &mut self.state,
                function,
                true,
                info.src,
                info.dst,
            );
        }
    }

    /// `vkCopyMemoryToMicromapEXT(device, deferredOperation, pInfo)`: `src`
    /// is a host address. The rules ([`Self::copy_memory_to_micromap_rules`],
    /// reading the host memory the application described), then the record
    /// ([`Self::record_copy_memory_to_micromap`]).
    pub fn copy_memory_to_micromap(
        &mut self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMemoryToMicromapInfo>,
    ) -> Report {
        let report = self.copy_memory_to_micromap_rules(device, deferred_operation, info, &[]);
        self.record_copy_memory_to_micromap(deferred_operation, info);
        report
    }

    /// The rules of `vkCopyMemoryToMicromapEXT`, before the call, with
    /// `read_for_call`, the host memory an adaptor read for it (see
    /// [`crate::state::HostMemory`]); records nothing.
    pub fn copy_memory_to_micromap_rules(
        &self,
        device: Handle,
        deferred_operation: Handle,
        info: Option<&CopyMemoryToMicromapInfo>,
        read_for_call: &[HostRange],
    ) -> Report {
        let mut ctx = self.ctx_reading("vkCopyMemoryToMicromapEXT", read_for_call);
        let vuids = HostCallVuids {
            device: host_from_memory::device_parameter,
            deferred_operation: common::DeferredOperationVuids {
                parameter: host_from_memory::deferredOperation_parameter,
                parent: host_from_memory::deferredOperation_parent,
                complete: Some(host_from_memory::deferredOperation_03678),
            },
            host_commands: host_from_memory::micromapHostCommands_07566,
            info: host_from_memory::pInfo_parameter,
        };
        if let Some(info) = host_call(&mut ctx, device, deferred_operation, info, &vuids) {
            let dst = copy_memory_to_micromap_info(&mut ctx, info);
            let dst_vuids = HostMemoryVuids {
                host_visible: host_from_memory::buffer_07565,
                single_instance: host_from_memory::buffer_07567,
            };
            host_accessible(&mut ctx, dst, &dst_vuids, "pInfo->dst");
            crate::checks::driver_sizes::compatible_source(&mut ctx, info, true);
            serialized_host_address(
                &mut ctx,
                info.src,
                host_from_memory::pInfo_07563,
                host_from_memory::pInfo_07564,
                "pInfo->src.hostAddress",
            );
            provenance::micromap_source(&mut ctx, true, info.src, info.dst);
        }
        ctx.finish()
    }

    /// Records the deserialization `vkCopyMemoryToMicromapEXT` made (or,
    /// deferred, is making).
    pub fn record_copy_memory_to_micromap(
        &mut self,
        deferred_operation: Handle,
        info: Option<&CopyMemoryToMicromapInfo>,
    ) {
        self.defer(deferred_operation);
        if let Some(info) = info {
            self.constructed_on_host(info.dst, deferred_operation);
            self.record_deserialization(true, info.src, info.dst, false);
        }
    }

    /// `vkCmdWriteMicromapsPropertiesEXT(commandBuffer, micromapCount,
    /// pMicromaps, queryType, queryPool, firstQuery)`.
    pub fn cmd_write_micromaps_properties(
        &mut self,
        command_buffer: &CommandBuffer,
        micromaps: &MicromapList,
        query_type: i32,
        query_pool: Handle,
        first_query: u32,
    ) -> Report {
        let report = self.cmd_write_micromaps_properties_rules(
            command_buffer,
            micromaps,
            query_type,
            query_pool,
            first_query,
        );
        self.record_cmd_write_micromaps_properties(
            command_buffer,
            micromaps,
            query_pool,
            first_query,
        );
        report
    }

    /// Records the property writes `vkCmdWriteMicromapsPropertiesEXT` put
    /// in `command_buffer`.
    pub fn record_cmd_write_micromaps_properties(
        &mut self,
        command_buffer: &CommandBuffer,
        micromaps: &MicromapList,
        query_pool: Handle,
        first_query: u32,
    ) {
        let reads = listed_handles(micromaps).map(|(k, object)| ExecEvent::Read {
            object,
            rule: ReadRule::PropertiesMicromap,
            location: format!("pMicromaps[{k}]"),
        });
        let write = ExecEvent::WriteQueries {
            pool: query_pool,
            first: first_query,
            count: micromaps.count,
        };
        let events: Vec<_> = reads.chain([write]).collect();
        self.record_execution(command_buffer, "vkCmdWriteMicromapsPropertiesEXT", events);
    }

    /// The rules of [`Self::cmd_write_micromaps_properties`]; records nothing.
    pub fn cmd_write_micromaps_properties_rules(
        &self,
        command_buffer: &CommandBuffer,
        micromaps: &MicromapList,
        query_type: i32,
        query_pool: Handle,
        first_query: u32,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdWriteMicromapsPropertiesEXT");
        common::command_buffer(
            &mut ctx,
            command_buffer,
            &CommandBufferVuids {
                parameter: cmd_write::commandBuffer_parameter,
                recording: cmd_write::commandBuffer_recording,
                cmdpool: cmd_write::commandBuffer_cmdpool,
                renderpass: Some(cmd_write::renderpass),
                videocoding: Some(cmd_write::videocoding),
                suspended: Some(cmd_write::suspended),
            },
        );
        // commandBuffer, queryPool and the micromaps must share one device.
        let foreign = std::iter::once(("queryPool".to_string(), query_pool))
            .chain(
                micromaps
                    .handles
                    .iter()
                    .flatten()
                    .enumerate()
                    .map(|(k, h)| (format!("pMicromaps[{k}]"), *h)),
            )
            .find(|(_, h)| {
                *h != 0
                    && ctx
                        .state
                        .is_some_and(|state| state.other_device_objects.contains(h))
            });
        if let Some((location, handle)) = foreign {
            common::other_device(&mut ctx, handle, cmd_write::commonparent, &location);
        }
        let listed = micromap_list(
            &mut ctx,
            micromaps,
            cmd_write::micromapCount_arraylength,
            cmd_write::pMicromaps_parameter,
        );
        properties_query_type(&mut ctx, query_type, cmd_write::queryType_07503);
        for &(k, micromap) in &listed {
            let at = format!("pMicromaps[{k}]");
            bound_to_device_memory(&mut ctx, Some(micromap), cmd_write::buffer_07527, &at);
            compactable(
                &mut ctx,
                micromap,
                query_type,
                cmd_write::pMicromaps_07502,
                &at,
            );
        }
        let Some(state) = ctx.state else {
            return ctx.finish();
        };
        let Some(pool) = state.query_pools.get(&query_pool) else {
            ctx.error(
                cmd_write::queryPool_parameter,
                "queryPool",
                format!("{query_pool:#x} is not a VkQueryPool created on this device"),
            );
            return ctx.finish();
        };
        let (pool_type, pool_count) = (pool.query_type, pool.query_count);
        ctx.require(
            pool_type == query_type,
            cmd_write::queryPool_07525,
            || "queryPool".into(),
            || {
                format!(
                    "the pool was created with queryType {}, not {}",
                    query_type_name(pool_type),
                    query_type_name(query_type)
                )
            },
        );
        let end = u64::from(first_query) + u64::from(micromaps.count);
        ctx.require(
            end <= u64::from(pool_count),
            cmd_write::query_07528,
            || "firstQuery".into(),
            || {
                format!(
                    "firstQuery {first_query} + micromapCount {} = {end} exceeds the pool's {}",
                    micromaps.count,
                    count_of(pool_count, "query", "queries")
                )
            },
        );
        ctx.finish()
    }

    /// `vkWriteMicromapsPropertiesEXT(device, micromapCount, pMicromaps,
    /// queryType, dataSize, pData, stride)`; `data` is the host address
    /// `pData` (0: NULL). It changes nothing the checker tracks: its rules
    /// ([`Self::write_micromaps_properties_rules`]) are the whole call.
    pub fn write_micromaps_properties(
        &mut self,
        device: Handle,
        micromaps: &MicromapList,
        query_type: i32,
        data_size: u64,
        data: u64,
        stride: u64,
    ) -> Report {
        self.write_micromaps_properties_rules(
            device, micromaps, query_type, data_size, data, stride,
        )
    }

    /// The rules of `vkWriteMicromapsPropertiesEXT`; records nothing.
    pub fn write_micromaps_properties_rules(
        &self,
        device: Handle,
        micromaps: &MicromapList,
        query_type: i32,
        data_size: u64,
        data: u64,
        stride: u64,
    ) -> Report {
        let mut report = self.write_micromaps_properties_parameters(
            device, micromaps, query_type, data_size, data, stride,
        );
        let reads: Vec<_> = listed_handles(micromaps)
            .map(|(k, handle)| (format!("pMicromaps[{k}]"), handle))
            .collect();
        report.extend(self.host_reads_constructed(
            "vkWriteMicromapsPropertiesEXT",
            host_write::pMicromaps_11671,
            &reads,
        ));
        report
    }

    /// The rules of [`Self::write_micromaps_properties`] but 11671.
    fn write_micromaps_properties_parameters(
        &self,
        device: Handle,
        micromaps: &MicromapList,
        query_type: i32,
        data_size: u64,
        data: u64,
        stride: u64,
    ) -> Report {
        let mut ctx = self.ctx("vkWriteMicromapsPropertiesEXT");
        common::device_handle(&mut ctx, device, host_write::device_parameter);
        host_commands_feature(&mut ctx, host_write::micromapHostCommands_07578);
        for (k, handle) in micromaps.handles.iter().flatten().enumerate() {
            common::other_device(
                &mut ctx,
                *handle,
                host_write::pMicromaps_parent,
                &format!("pMicromaps[{k}]"),
            );
        }
        let listed = micromap_list(
            &mut ctx,
            micromaps,
            host_write::micromapCount_arraylength,
            host_write::pMicromaps_parameter,
        );
        ctx.require(
            QUERY_TYPES.contains(&query_type),
            host_write::queryType_parameter,
            || "queryType".into(),
            || format!("{query_type} is not a VkQueryType value"),
        );
        let size_query = properties_query_type(&mut ctx, query_type, host_write::queryType_07503);
        let vuids = HostMemoryVuids {
            host_visible: host_write::buffer_07577,
            single_instance: host_write::buffer_07579,
        };
        for &(k, micromap) in &listed {
            let at = format!("pMicromaps[{k}]");
            host_accessible(&mut ctx, Some(micromap), &vuids, &at);
            compactable(
                &mut ctx,
                micromap,
                query_type,
                host_write::pMicromaps_07502,
                &at,
            );
        }
        written_data(&mut ctx, micromaps.count, data_size, data, stride);
        if size_query {
            device_size_results(&mut ctx, data_size, data, stride);
        }
        ctx.finish()
    }

    /// `vkGetMicromapBuildSizesEXT(device, buildType, pBuildInfo, pSizeInfo)`.
    pub fn get_micromap_build_sizes(
        &mut self,
        device: Handle,
        build_type: i32,
        build_info: Option<&MicromapBuildInfo>,
        size_info: Option<&MicromapBuildSizesInfo>,
    ) -> Report {
        let mut ctx = self.ctx("vkGetMicromapBuildSizesEXT");
        common::device_handle(&mut ctx, device, build_sizes::device_parameter);
        micromap_feature(&mut ctx, build_sizes::micromap_11618);
        let physical_devices = ctx.device.physical_device_count;
        ctx.require(
            physical_devices <= 1 || ctx.device.features.buffer_device_address_multi_device,
            build_sizes::device_07440,
            || "device".into(),
            || format!("the device has {physical_devices} physical devices but bufferDeviceAddressMultiDevice is not enabled"),
        );
        ctx.require(
            ACCELERATION_STRUCTURE_BUILD_TYPES.contains(&build_type),
            build_sizes::buildType_parameter,
            || "buildType".into(),
            || format!("{build_type} is not a VkAccelerationStructureBuildTypeKHR value"),
        );
        ctx.require(
            build_info.is_some(),
            build_sizes::pBuildInfo_parameter,
            || "pBuildInfo".into(),
            || "pBuildInfo is NULL".into(),
        );
        if let Some(info) = build_info {
            // The size query sees the build info's own rules; addresses and
            // contents are ignored by the command.
            crate::checks::micromap_build::build_info(
                &mut ctx,
                "pBuildInfo",
                info,
                crate::checks::micromap_build::Side::SizeQuery,
            );
        }
        match size_info {
            Some(sizes) => structure_header(
                &mut ctx,
                Header {
                    s_type: sizes.s_type,
                    next: &sizes.next,
                    expected: STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT,
                    expected_name: "VK_STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT",
                    s_type_vuid: sizes_info::sType_sType,
                    next_vuid: sizes_info::pNext_pNext,
                    at: "pSizeInfo",
                },
            ),
            None => {
                ctx.error(
                    build_sizes::pSizeInfo_parameter,
                    "pSizeInfo",
                    "pSizeInfo is NULL",
                );
            }
        }
        ctx.finish()
    }

    /// `vkGetDeviceMicromapCompatibilityEXT(device, pVersionInfo,
    /// pCompatibility)`; `compatibility` says whether `pCompatibility` is
    /// non-NULL.
    pub fn get_device_micromap_compatibility(
        &mut self,
        device: Handle,
        version: Option<&MicromapVersionInfo>,
        compatibility: bool,
    ) -> Report {
        let mut ctx = self.ctx("vkGetDeviceMicromapCompatibilityEXT");
        common::device_handle(&mut ctx, device, compatibility::device_parameter);
        micromap_feature(&mut ctx, compatibility::micromap_11666);
        ctx.require(
            compatibility,
            compatibility::pCompatibility_parameter,
            || "pCompatibility".into(),
            || "pCompatibility is NULL".into(),
        );
        let Some(version) = version else {
            ctx.error(
                compatibility::pVersionInfo_parameter,
                "pVersionInfo",
                "pVersionInfo is NULL",
            );
            return ctx.finish();
        };
        structure_header(
            &mut ctx,
            Header {
                s_type: version.s_type,
                next: &version.next,
                expected: STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT,
                expected_name: "VK_STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT",
                s_type_vuid: version_info::sType_sType,
                next_vuid: version_info::pNext_pNext,
                at: "pVersionInfo",
            },
        );
        match &version.version_data {
            None => {
                ctx.error(
                    version_info::pVersionData_parameter,
                    "pVersionInfo->pVersionData",
                    "pVersionData is NULL",
                );
            }
            Some(bytes) if bytes.len() < 2 * UUID_SIZE => {
                ctx.error(
                    version_info::pVersionData_parameter,
                    "pVersionInfo->pVersionData",
                    format!(
                        "points to {} bytes, not 2 × VK_UUID_SIZE = {}",
                        bytes.len(),
                        2 * UUID_SIZE
                    ),
                );
            }
            Some(_) => {}
        }
        ctx.finish()
    }

    /// `vkCmdBeginQuery(commandBuffer, queryPool, query, flags)`: the
    /// micromap rule only (the pool must not be a micromap size pool).
    pub fn cmd_begin_query(
        &mut self,
        _command_buffer: &CommandBuffer,
        query_pool: Handle,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdBeginQuery");
        not_a_micromap_pool(&mut ctx, query_pool, begin_query::queryType_08972);
        ctx.finish()
    }

    /// `vkCmdBeginQueryIndexedEXT(commandBuffer, queryPool, query, flags,
    /// index)`: the micromap rule only.
    pub fn cmd_begin_query_indexed(
        &mut self,
        _command_buffer: &CommandBuffer,
        query_pool: Handle,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdBeginQueryIndexedEXT");
        not_a_micromap_pool(&mut ctx, query_pool, begin_query_indexed::queryType_08972);
        ctx.finish()
    }
}

fn micromap_feature(ctx: &mut Ctx<'_>, vuid: Vuid) {
    ctx.require(ctx.device.features.micromap_ext, vuid, String::new, || {
        "the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromap feature is not enabled".into()
    });
}

fn host_commands_feature(ctx: &mut Ctx<'_>, vuid: Vuid) {
    ctx.require(
        ctx.device.features.micromap_host_commands,
        vuid,
        String::new,
        || "the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromapHostCommands feature is not enabled".into(),
    );
}

/// A non-NULL `pAllocator` must point to valid callbacks.
fn allocation_callbacks(ctx: &mut Ctx<'_>, allocator: Option<&AllocationCallbacks>, vuid: Vuid) {
    if let Some(defect) = allocator.and_then(AllocationCallbacks::defect) {
        ctx.error(vuid, "pAllocator", defect);
    }
}

/// The `pInfo` of a command, reporting `vuid` when it is NULL.
fn required_info<'i, T>(ctx: &mut Ctx<'_>, info: Option<&'i T>, vuid: Vuid) -> Option<&'i T> {
    if info.is_none() {
        ctx.error(vuid, "pInfo", "pInfo is NULL");
    }
    info
}

/// The checks every host copy begins with: the device, the host-commands
/// feature, the deferred operation and `pInfo`.
fn host_call<'i, T>(
    ctx: &mut Ctx<'_>,
    device: Handle,
    deferred_operation: Handle,
    info: Option<&'i T>,
    vuids: &HostCallVuids,
) -> Option<&'i T> {
    common::device_handle(ctx, device, vuids.device);
    host_commands_feature(ctx, vuids.host_commands);
    common::deferred_operation(ctx, deferred_operation, &vuids.deferred_operation);
    required_info(ctx, info, vuids.info)
}

/// A micromap handle the call names; reports `vuid` when it is not tracked.
fn tracked_micromap<'s>(
    ctx: &mut Ctx<'s>,
    handle: Handle,
    vuid: Vuid,
    location: &str,
) -> Option<&'s Micromap> {
    let state = ctx.state?;
    let found = state.micromaps.get(&handle);
    if found.is_none() && !state.other_device_objects.contains(&handle) {
        ctx.error(
            vuid,
            location,
            format!("{handle:#x} is not a VkMicromapEXT created on this device"),
        )
        .objects
        .push(ObjectRef {
            ty: "VkMicromapEXT",
            handle,
        });
    }
    found
}

/// The memory a micromap's buffer is bound to: `None` when the buffer is not
/// tracked (nothing to decide), `Some(None)` when it is tracked but unbound.
fn backing_memory(ctx: &Ctx<'_>, micromap: &Micromap) -> Option<Option<MemoryBinding>> {
    ctx.state
        .and_then(|state| state.buffers.get(&micromap.buffer))
        .map(|b| b.memory)
}

/// The buffer a micromap was created on must be bound to device memory.
fn bound_to_device_memory(
    ctx: &mut Ctx<'_>,
    micromap: Option<&Micromap>,
    vuid: Vuid,
    location: &str,
) {
    let Some(micromap) = micromap else { return };
    if backing_memory(ctx, micromap) == Some(None) {
        let buffer = micromap.buffer;
        ctx.error(
            vuid,
            location,
            format!("its buffer VkBuffer {buffer:#x} is not bound to device memory"),
        );
    }
}

/// A host command reaches a micromap's memory through a host mapping: the
/// memory must be host-visible and of a single instance.
fn host_accessible(
    ctx: &mut Ctx<'_>,
    micromap: Option<&Micromap>,
    vuids: &HostMemoryVuids,
    location: &str,
) {
    let Some(micromap) = micromap else { return };
    let Some(memory) = backing_memory(ctx, micromap) else {
        return;
    };
    let buffer = micromap.buffer;
    ctx.require(
        memory.is_some_and(|m| m.host_visible),
        vuids.host_visible,
        || location.to_string(),
        || format!("its buffer VkBuffer {buffer:#x} is not bound to host-visible memory"),
    );
    ctx.require(
        !memory.is_some_and(|m| m.multi_instance),
        vuids.single_instance,
        || location.to_string(),
        || format!("its buffer VkBuffer {buffer:#x} is bound to memory allocated with multiple instances"),
    );
}

/// A structure's `sType` and `pNext` (which must be NULL).
struct Header<'a> {
    s_type: i32,
    next: &'a [i32],
    expected: i32,
    expected_name: &'static str,
    s_type_vuid: Vuid,
    next_vuid: Vuid,
    at: &'a str,
}

fn structure_header(ctx: &mut Ctx<'_>, header: Header<'_>) {
    let at = header.at;
    ctx.require(
        header.s_type == header.expected,
        header.s_type_vuid,
        || format!("{at}.sType"),
        || {
            format!(
                "{} is not {}",
                structure_type_name(header.s_type),
                header.expected_name
            )
        },
    );
    if let Some(s_type) = header.next.first() {
        ctx.error(
            header.next_vuid,
            format!("{at}.pNext"),
            format!(
                "pNext must be NULL, but it points to a structure with sType {}",
                structure_type_name(*s_type)
            ),
        );
    }
}

/// `mode` must be a `VkCopyMicromapModeEXT` value and the one the structure allows.
fn copy_mode(
    ctx: &mut Ctx<'_>,
    mode: i32,
    allowed: &[(i32, &str)],
    parameter: Option<Vuid>,
    required: Vuid,
) {
    let valid = (COPY_MICROMAP_MODE_CLONE_EXT..=COPY_MICROMAP_MODE_COMPACT_EXT).contains(&mode);
    if let (false, Some(vuid)) = (valid, parameter) {
        ctx.error(
            vuid,
            "pInfo->mode",
            format!("{mode} is not a VkCopyMicromapModeEXT value"),
        );
        return;
    }
    if !allowed.iter().any(|(m, _)| *m == mode) {
        let names: Vec<&str> = allowed.iter().map(|(_, name)| *name).collect();
        ctx.error(
            required,
            "pInfo->mode",
            format!(
                "{} is not {}",
                copy_micromap_mode_name(mode),
                names.join(" or ")
            ),
        );
    }
}

/// `VkCopyMicromapInfoEXT`; returns the tracked source and destination.
fn copy_micromap_info<'s>(
    ctx: &mut Ctx<'s>,
    info: &CopyMicromapInfo,
) -> (Option<&'s Micromap>, Option<&'s Micromap>) {
    structure_header(
        ctx,
        Header {
            s_type: info.s_type,
            next: &info.next,
            expected: STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT,
            expected_name: "VK_STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT",
            s_type_vuid: copy_info::sType_sType,
            next_vuid: copy_info::pNext_pNext,
            at: "pInfo",
        },
    );
    copy_mode(
        ctx,
        info.mode,
        &[
            (
                COPY_MICROMAP_MODE_COMPACT_EXT,
                "VK_COPY_MICROMAP_MODE_COMPACT_EXT",
            ),
            (
                COPY_MICROMAP_MODE_CLONE_EXT,
                "VK_COPY_MICROMAP_MODE_CLONE_EXT",
            ),
        ],
        None,
        copy_info::mode_07531,
    );
    if !common::other_device(ctx, info.src, copy_info::commonparent, "pInfo->src") {
        common::other_device(ctx, info.dst, copy_info::commonparent, "pInfo->dst");
    }
    let src = tracked_micromap(ctx, info.src, copy_info::src_parameter, "pInfo->src");
    let dst = tracked_micromap(ctx, info.dst, copy_info::dst_parameter, "pInfo->dst");
    // Compaction needs the source's build flags, known when the checker saw the build.
    let src_flags = src.and_then(|m| m.built.as_ref()).map(|b| b.flags);
    if let (COPY_MICROMAP_MODE_COMPACT_EXT, Some(flags)) = (info.mode, src_flags) {
        ctx.require(
            flags & BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT != 0,
            copy_info::mode_07533,
            || "pInfo->src".into(),
            || format!("mode is VK_COPY_MICROMAP_MODE_COMPACT_EXT, but src was built with flags {flags:#x}, without VK_BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT"),
        );
    }
    (src, dst)
}

/// `VkCopyMicromapToMemoryInfoEXT`; returns the tracked source.
fn copy_micromap_to_memory_info<'s>(
    ctx: &mut Ctx<'s>,
    info: &CopyMicromapToMemoryInfo,
) -> Option<&'s Micromap> {
    structure_header(
        ctx,
        Header {
            s_type: info.s_type,
            next: &info.next,
            expected: STRUCTURE_TYPE_COPY_MICROMAP_TO_MEMORY_INFO_EXT,
            expected_name: "VK_STRUCTURE_TYPE_COPY_MICROMAP_TO_MEMORY_INFO_EXT",
            s_type_vuid: to_memory_info::sType_sType,
            next_vuid: to_memory_info::pNext_pNext,
            at: "pInfo",
        },
    );
    copy_mode(
        ctx,
        info.mode,
        &[(
            COPY_MICROMAP_MODE_SERIALIZE_EXT,
            "VK_COPY_MICROMAP_MODE_SERIALIZE_EXT",
        )],
        Some(to_memory_info::mode_parameter),
        to_memory_info::mode_07542,
    );
    tracked_micromap(ctx, info.src, to_memory_info::src_parameter, "pInfo->src")
}

/// `VkCopyMemoryToMicromapInfoEXT`; returns the tracked destination.
fn copy_memory_to_micromap_info<'s>(
    ctx: &mut Ctx<'s>,
    info: &CopyMemoryToMicromapInfo,
) -> Option<&'s Micromap> {
    structure_header(
        ctx,
        Header {
            s_type: info.s_type,
            next: &info.next,
            expected: STRUCTURE_TYPE_COPY_MEMORY_TO_MICROMAP_INFO_EXT,
            expected_name: "VK_STRUCTURE_TYPE_COPY_MEMORY_TO_MICROMAP_INFO_EXT",
            s_type_vuid: from_memory_info::sType_sType,
            next_vuid: from_memory_info::pNext_pNext,
            at: "pInfo",
        },
    );
    copy_mode(
        ctx,
        info.mode,
        &[(
            COPY_MICROMAP_MODE_DESERIALIZE_EXT,
            "VK_COPY_MICROMAP_MODE_DESERIALIZE_EXT",
        )],
        Some(from_memory_info::mode_parameter),
        from_memory_info::mode_07548,
    );
    tracked_micromap(ctx, info.dst, from_memory_info::dst_parameter, "pInfo->dst")
}

/// A device address serialized data is read from or written to: valid, and
/// aligned to 256 bytes.
fn serialized_device_address(
    ctx: &mut Ctx<'_>,
    address: u64,
    valid: Vuid,
    aligned: Vuid,
    location: &str,
) {
    common::valid_device_address(ctx, address, valid, location);
    common::aligned(ctx, address, SERIALIZED_DEVICE_ALIGNMENT, aligned, location);
}

/// A host address serialized data is read from or written to: not NULL,
/// inside the host memory the application described (when it described
/// any), and aligned to 16 bytes.
fn serialized_host_address(
    ctx: &mut Ctx<'_>,
    address: u64,
    valid: Vuid,
    aligned: Vuid,
    location: &str,
) {
    if address == 0 {
        ctx.error(valid, location, "the host address is NULL");
    } else if ctx
        .host()
        .is_some_and(|host| host.describes_all() && host.bytes_from(address).is_none())
    {
        ctx.error(
            valid,
            location,
            format!("{address:#x} is outside the host memory the application described"),
        );
    } else if ctx
        .host()
        .is_some_and(|host| host.bytes_from(address).is_some())
    {
        ctx.checked(&[valid.into()]);
    } else {
        common::unreadable(ctx, true, address, &[valid.into()], location);
    }
    common::aligned(ctx, address, SERIALIZED_HOST_ALIGNMENT, aligned, location);
}

/// `micromapCount` and `pMicromaps`: returns the tracked micromaps with their
/// indices.
fn micromap_list<'s>(
    ctx: &mut Ctx<'s>,
    list: &MicromapList,
    arraylength: Vuid,
    parameter: Vuid,
) -> Vec<(usize, &'s Micromap)> {
    ctx.require(
        list.count > 0,
        arraylength,
        || "micromapCount".into(),
        || "micromapCount is 0".into(),
    );
    let Some(handles) = &list.handles else {
        if list.count > 0 {
            ctx.error(parameter, "pMicromaps", "pMicromaps is NULL");
        }
        return Vec::new();
    };
    if handles.len() as u64 != u64::from(list.count) {
        ctx.error(
            parameter,
            "pMicromaps",
            format!(
                "points to {} handles, not micromapCount = {}",
                handles.len(),
                list.count
            ),
        );
    }
    let mut tracked = Vec::new();
    for (k, handle) in handles.iter().enumerate() {
        if let Some(micromap) =
            tracked_micromap(ctx, *handle, parameter, &format!("pMicromaps[{k}]"))
        {
            tracked.push((k, micromap));
        }
    }
    tracked
}

/// `queryType` must be one of the two micromap size queries; returns whether it is.
fn properties_query_type(ctx: &mut Ctx<'_>, query_type: i32, vuid: Vuid) -> bool {
    let ok = query_type == QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT
        || query_type == QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT;
    ctx.require(ok, vuid, || "queryType".into(), || {
        format!("{query_type} is neither VK_QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT nor VK_QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT")
    });
    ok
}

/// A compacted-size query needs micromaps built with ALLOW_COMPACTION;
/// decided when the checker saw the build.
fn compactable(
    ctx: &mut Ctx<'_>,
    micromap: &Micromap,
    query_type: i32,
    vuid: Vuid,
    location: &str,
) {
    let Some(build) = &micromap.built else { return };
    if query_type == QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT
        && build.flags & BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT == 0
    {
        ctx.error(
            vuid,
            location,
            format!("queryType is VK_QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT, but the micromap was built with flags {:#x}, without VK_BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT", build.flags),
        );
    }
}

/// `dataSize` and `pData` of `vkWriteMicromapsPropertiesEXT`: room for one
/// result per micromap, in memory the application owns.
fn written_data(ctx: &mut Ctx<'_>, count: u32, data_size: u64, data: u64, stride: u64) {
    ctx.require(
        data_size > 0,
        host_write::dataSize_arraylength,
        || "dataSize".into(),
        || "dataSize is 0".into(),
    );
    let needed = u128::from(count) * u128::from(stride);
    ctx.require(
        u128::from(data_size) >= needed,
        host_write::dataSize_07576,
        || "dataSize".into(),
        || format!("{data_size} is less than micromapCount {count} × stride {stride} = {needed}"),
    );
    if data == 0 {
        if data_size > 0 {
            ctx.error(host_write::pData_parameter, "pData", "pData is NULL");
        }
    } else if ctx
        .host()
        .is_some_and(|host| host.describes_all() && host.read(data, data_size).is_none())
    {
        ctx.error(
            host_write::pData_parameter,
            "pData",
            format!(
                "[{data:#x}, +{data_size}) is not inside the host memory the application described"
            ),
        );
    } else if ctx
        .host()
        .is_some_and(|host| host.read(data, data_size).is_some())
    {
        ctx.checked(&[host_write::pData_parameter.into()]);
    } else {
        common::unreadable(
            ctx,
            true,
            data,
            &[host_write::pData_parameter.into()],
            "pData",
        );
    }
}

/// Size queries write `VkDeviceSize` values: stride and `pData` must fit them.
fn device_size_results(ctx: &mut Ctx<'_>, data_size: u64, data: u64, stride: u64) {
    ctx.require(
        stride.is_multiple_of(DEVICE_SIZE_BYTES),
        host_write::queryType_10071,
        || "stride".into(),
        || format!("{stride} is not a multiple of sizeof(VkDeviceSize) = 8"),
    );
    if data_size < DEVICE_SIZE_BYTES {
        ctx.error(
            host_write::queryType_10072,
            "dataSize",
            format!("{data_size} bytes cannot hold a VkDeviceSize"),
        );
    } else if !data.is_multiple_of(DEVICE_SIZE_BYTES) {
        ctx.error(
            host_write::queryType_10072,
            "pData",
            format!("{data:#x} is not aligned for a VkDeviceSize (8 bytes)"),
        );
    }
}

/// `VkMicromapCreateInfoEXT`.
fn micromap_create_info(ctx: &mut Ctx<'_>, info: &MicromapCreateInfo) {
    structure_header(
        ctx,
        Header {
            s_type: info.s_type,
            next: &info.next,
            expected: STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT,
            expected_name: "VK_STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT",
            s_type_vuid: create_info::sType_sType,
            next_vuid: create_info::pNext_pNext,
            at: "pCreateInfo",
        },
    );
    ctx.require(
        info.ty == MICROMAP_TYPE_OPACITY_MICROMAP_EXT
            || info.ty == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV,
        create_info::type_parameter,
        || "pCreateInfo->type".into(),
        || format!("{} is not a VkMicromapTypeEXT value", info.ty),
    );
    ctx.require(
        info.create_flags & !MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT == 0,
        create_info::createFlags_parameter,
        || "pCreateInfo->createFlags".into(),
        || {
            format!(
                "{:#x} has bits outside VkMicromapCreateFlagBitsEXT",
                info.create_flags
            )
        },
    );
    capture_replay(ctx, info);
    common::aligned(
        ctx,
        info.offset,
        MICROMAP_OFFSET_ALIGNMENT,
        create_info::offset_07438,
        "pCreateInfo->offset",
    );
    backing_buffer(ctx, info);
}

/// The capture-replay flag, its features, and the replayed address.
fn capture_replay(ctx: &mut Ctx<'_>, info: &MicromapCreateInfo) {
    let replay = info.create_flags & MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT != 0;
    let features = &ctx.device.features;
    let (capture_replay, multi_device) = (
        features.micromap_capture_replay,
        features.buffer_device_address_multi_device,
    );
    if replay {
        ctx.require(
            capture_replay,
            create_info::micromapCaptureReplay_11616,
            || "pCreateInfo->createFlags".into(),
            || "VK_MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT is set but the micromapCaptureReplay feature is not enabled".into(),
        );
        ctx.require(
            ctx.device.physical_device_count <= 1 || multi_device,
            create_info::bufferDeviceAddressMultiDevice_11617,
            || "pCreateInfo->createFlags".into(),
            || "VK_MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT is set on a multi-device device without the bufferDeviceAddressMultiDevice feature".into(),
        );
    }
    if info.device_address != 0 {
        ctx.require(
            replay,
            create_info::deviceAddress_07433,
            || "pCreateInfo->deviceAddress".into(),
            || format!("{:#x} is not 0, but createFlags lacks VK_MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT", info.device_address),
        );
        common::valid_device_address(
            ctx,
            info.device_address,
            create_info::deviceAddress_parameter,
            "pCreateInfo->deviceAddress",
        );
    }
}

/// The buffer the micromap lives in: tracked, usable for micromap storage,
/// not sparse-resident, and large enough.
fn backing_buffer(ctx: &mut Ctx<'_>, info: &MicromapCreateInfo) {
    let handle = info.buffer;
    let Some(state) = ctx.state else {
        return;
    };
    let Some(buffer) = state.buffers.get(&handle) else {
        ctx.error(
            create_info::buffer_parameter,
            "pCreateInfo->buffer",
            format!("{handle:#x} is not a VkBuffer created on this device"),
        );
        return;
    };
    let (usage, flags, size) = (buffer.usage, buffer.create_flags, buffer.size);
    ctx.require(
        usage & BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT != 0,
        create_info::buffer_07435,
        || "pCreateInfo->buffer".into(),
        || format!("VkBuffer {handle:#x} has usage {usage:#x}, without VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT"),
    );
    ctx.require(
        flags & BUFFER_CREATE_SPARSE_RESIDENCY_BIT == 0,
        create_info::buffer_07436,
        || "pCreateInfo->buffer".into(),
        || format!("VkBuffer {handle:#x} was created with VK_BUFFER_CREATE_SPARSE_RESIDENCY_BIT"),
    );
    let end = info.offset.checked_add(info.size);
    ctx.require(
        end.is_some_and(|end| end <= size),
        create_info::offset_07437,
        || "pCreateInfo->offset".into(),
        || {
            format!(
                "offset {} + size {} exceeds the buffer's size {size}",
                info.offset, info.size
            )
        },
    );
}

/// `queryPool` of `vkCmdBeginQuery*` must not be a micromap size pool; a
/// pool the checker does not track is left to the pool's own rules.
fn not_a_micromap_pool(ctx: &mut Ctx<'_>, query_pool: Handle, vuid: Vuid) {
    let Some(pool) = ctx
        .state
        .and_then(|state| state.query_pools.get(&query_pool))
    else {
        return;
    };
    let query_type = pool.query_type;
    ctx.require(
        query_type != QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT
            && query_type != QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
        vuid,
        || "queryPool".into(),
        || {
            format!(
                "the pool was created with the micromap size query type {}, which cannot be begun",
                query_type_name(query_type)
            )
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{Device, Profile};
    use crate::state::Buffer;

    fn host_validator() -> Validator {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        v.state_mut().host_memory.push(crate::state::HostRange {
            address: 0x1000,
            bytes: crate::Bytes::from(vec![0u8; 64]),
        });
        v
    }

    #[test]
    fn data_size_product_does_not_overflow() {
        let mut v = host_validator();
        let list = MicromapList {
            count: u32::MAX,
            handles: None,
        };
        let report = v.write_micromaps_properties(1, &list, 0, 8, 0x1000, u64::MAX);
        assert!(report.contains(host_write::dataSize_07576));
    }

    #[test]
    fn offset_plus_size_overflow_is_out_of_range() {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        v.state_mut().buffers.insert(
            7,
            Buffer {
                size: u64::MAX,
                usage: BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT,
                ..Default::default()
            },
        );
        let info = MicromapCreateInfo {
            buffer: 7,
            offset: 256,
            size: u64::MAX,
            ..Default::default()
        };
        let report = v.create_micromap(1, Some(&info), None, Some(9));
        assert_eq!(report.ids(), [create_info::offset_07437.id()]);
    }

    #[test]
    fn pdata_must_lie_inside_described_host_memory() {
        let mut v = host_validator();
        let report = v.write_micromaps_properties(
            1,
            &MicromapList::default(),
            QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
            64,
            0x1008,
            8,
        );
        assert!(report.contains(host_write::pData_parameter));
        assert!(!report.contains(host_write::queryType_10072));
    }

    /// The state as text, to compare states (it has no `PartialEq`).
    fn tracked(v: &Validator) -> String {
        format!("{:?}", v.state())
    }

    /// Each micromap command's rules leave the state as it was (run twice,
    /// they report the same), and its record alone makes of the state what
    /// the whole call does.
    #[test]
    fn micromap_commands_are_rules_then_record() {
        let mut v = host_validator();
        v.state_mut().buffers.insert(
            7,
            Buffer {
                size: 4096,
                usage: BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT,
                ..Default::default()
            },
        );
        let create = MicromapCreateInfo {
            buffer: 7,
            size: 256,
            ..Default::default()
        };
        let (src, dst) = (0x51, 0x52);
        let command_buffer = CommandBuffer {
            handle: 3,
            recording: true,
            ..Default::default()
        };
        let copy = CopyMicromapInfo {
            src,
            dst,
            mode: COPY_MICROMAP_MODE_CLONE_EXT,
            ..Default::default()
        };
        let to_memory = CopyMicromapToMemoryInfo {
            src,
            dst: 0x1000,
            ..Default::default()
        };
        let from_memory = CopyMemoryToMicromapInfo {
            src: 0x1000,
            dst,
            ..Default::default()
        };
        let list = MicromapList {
            count: 1,
            handles: Some(vec![src]),
        };
        type Rules<'a> = Box<dyn Fn(&Validator) -> Report + 'a>;
        type Record<'a> = Box<dyn Fn(&mut Validator) + 'a>;
        type Whole<'a> = Box<dyn Fn(&mut Validator) -> Report + 'a>;
        let cb = &command_buffer;
        let commands: Vec<(&str, Rules, Record, Whole)> = vec![
            (
                "create",
                Box::new(|v| v.create_micromap_rules(1, Some(&create), None, Some(src))),
                Box::new(|v| v.record_micromap(src, &create, false)),
                Box::new(|v| v.create_micromap(1, Some(&create), None, Some(src))),
            ),
            (
                "create the second",
                Box::new(|v| v.create_micromap_rules(1, Some(&create), None, Some(dst))),
                Box::new(|v| v.record_micromap(dst, &create, false)),
                Box::new(|v| v.create_micromap(1, Some(&create), None, Some(dst))),
            ),
            (
                "cmd copy",
                Box::new(|v| v.cmd_copy_micromap_rules(cb, Some(&copy))),
                Box::new(|v| v.record_cmd_copy_micromap(cb, Some(&copy))),
                Box::new(|v| v.cmd_copy_micromap(cb, Some(&copy))),
            ),
            (
                "cmd copy to memory",
                Box::new(|v| v.cmd_copy_micromap_to_memory_rules(cb, Some(&to_memory))),
                Box::new(|v| v.record_cmd_copy_micromap_to_memory(cb, Some(&to_memory))),
                Box::new(|v| v.cmd_copy_micromap_to_memory(cb, Some(&to_memory))),
            ),
            (
                "cmd copy from memory",
                Box::new(|v| v.cmd_copy_memory_to_micromap_rules(cb, Some(&from_memory))),
                Box::new(|v| v.record_cmd_copy_memory_to_micromap(cb, Some(&from_memory))),
                Box::new(|v| v.cmd_copy_memory_to_micromap(cb, Some(&from_memory))),
            ),
            (
                "cmd write properties",
                Box::new(|v| v.cmd_write_micromaps_properties_rules(cb, &list, 0, 9, 0)),
                Box::new(|v| v.record_cmd_write_micromaps_properties(cb, &list, 9, 0)),
                Box::new(|v| v.cmd_write_micromaps_properties(cb, &list, 0, 9, 0)),
            ),
            (
                "host copy",
                Box::new(|v| v.copy_micromap_rules(1, 0, Some(&copy))),
                Box::new(|v| v.record_copy_micromap(0, Some(&copy))),
                Box::new(|v| v.copy_micromap(1, 0, Some(&copy))),
            ),
            (
                "host copy to memory",
                Box::new(|v| v.copy_micromap_to_memory_rules(1, 0, Some(&to_memory))),
                Box::new(|v| v.record_copy_micromap_to_memory(0, Some(&to_memory))),
                Box::new(|v| v.copy_micromap_to_memory(1, 0, Some(&to_memory))),
            ),
            (
                "host copy from memory",
                Box::new(|v| v.copy_memory_to_micromap_rules(1, 0, Some(&from_memory), &[])),
                Box::new(|v| v.record_copy_memory_to_micromap(0, Some(&from_memory))),
                Box::new(|v| v.copy_memory_to_micromap(1, 0, Some(&from_memory))),
            ),
            (
                "destroy",
                Box::new(|v| v.destroy_micromap_rules(1, dst, None)),
                Box::new(|v| v.record_micromap_destroyed(dst)),
                Box::new(|v| v.destroy_micromap(1, dst, None)),
            ),
        ];
        for (name, rules, record, whole) in &commands {
            let before = tracked(&v);
            let report = rules(&v);
            assert_eq!(tracked(&v), before, "{name}: the rules changed the state");
            assert_eq!(
                rules(&v),
                report,
                "{name}: the rules depend on more than the state"
            );
            let mut called = v.clone();
            assert_eq!(
                whole(&mut called),
                report,
                "{name}: the call reports its rules"
            );
            record(&mut v);
            assert_eq!(
                tracked(&v),
                tracked(&called),
                "{name}: the record is the call's"
            );
        }
        assert!(v.state().micromaps.contains_key(&src));
        assert!(!v.state().micromaps.contains_key(&dst), "destroyed");
    }

    /// The whole call is its rules, then its record.
    #[test]
    fn the_whole_call_reports_its_rules_and_leaves_its_record() {
        let info = MicromapCreateInfo {
            size: 256,
            ..Default::default()
        };
        let mut split = host_validator();
        let rules = split.create_micromap_rules(1, Some(&info), None, Some(5));
        split.record_micromap(5, &info, false);
        let mut whole = host_validator();
        assert_eq!(whole.create_micromap(1, Some(&info), None, Some(5)), rules);
        assert_eq!(tracked(&whole), tracked(&split));

        let rules = split.destroy_micromap_rules(1, 5, None);
        split.record_micromap_destroyed(5);
        assert_eq!(whole.destroy_micromap(1, 5, None), rules);
        assert_eq!(tracked(&whole), tracked(&split));
    }
}
