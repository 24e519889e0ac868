//! KHR acceleration-structure builds as far as micromaps are concerned: the
//! entry points of the build commands, `VkAccelerationStructureBuildGeometryInfoKHR`,
//! KHR opacity micromaps (type OPACITY_MICROMAP, `VkAccelerationStructureGeometryMicromapDataKHR`),
//! their creation, size queries and copies. The triangle-geometry
//! attachments are checked in `accel_attach`.
//!
//! The catalog holds only micromap-related VUIDs, and the implicit
//! command-buffer VUIDs of the KHR acceleration-structure commands
//! (`-commandBuffer-recording`, `-cmdpool`, `-renderpass`, ...) are not among
//! them, so the `vkCmd*` entry points here take the command buffer without
//! checking it: there is no catalog VUID to cite.

use crate::state::execution::ExecEvent;
use std::fmt::{self, Display};
use std::sync::Arc;

use crate::Bytes;

use ommcheck_vuids::vuid::{
    vkCmdBuildAccelerationStructuresIndirectKHR as indirect,
    vkCmdBuildAccelerationStructuresKHR as cmd, vkCmdCopyAccelerationStructureKHR as cmd_copy,
    vkCmdCopyAccelerationStructureToMemoryKHR as cmd_to_memory,
    vkCmdCopyMemoryToAccelerationStructureKHR as cmd_from_memory,
    vkCopyAccelerationStructureKHR as host_copy, vkGetAccelerationStructureBuildSizesKHR as sizes,
    VkAccelerationStructureBuildGeometryInfoKHR as info_vuid,
    VkAccelerationStructureCreateInfo2KHR as create_info2,
    VkAccelerationStructureCreateInfoKHR as create_info,
    VkAccelerationStructureGeometryKHR as geometry_vuid,
    VkAccelerationStructureGeometryMicromapDataKHR as micromap_vuid,
    VkCopyAccelerationStructureToMemoryInfoKHR as to_memory_info,
    VkCopyMemoryToAccelerationStructureInfoKHR as from_memory_info,
    VkMicromapUsageKHR as usage_vuid,
};
use ommcheck_vuids::Vuid;

use crate::checks::common::{
    self, bytes_available, readable_entries, usage_counts_match_triangles, CleanRun, Tally,
    TriangleHistogram,
};
use crate::checks::index_scan::IndexMix;
use crate::checks::usage_counts::{self, PointerVuids};
use crate::checks::usage_keys::UsageKeys;
use crate::checks::{accel_attach, hygiene, provenance, serialized, Coverage};
use crate::checks::{Ctx, Validator};
use crate::device::Limits;
use crate::model::accel::*;
use crate::model::micromap::opacity_triangle_bytes;
use crate::model::values::FormatKind;
use crate::model::values::{
    acceleration_structure_type_name, build_acceleration_structure_mode_name, build_type_name,
    geometry_type_name, structure_type_name,
    BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
    OPACITY_MICROMAP_FORMAT_2_STATE, OPACITY_MICROMAP_FORMAT_4_STATE,
};
use crate::model::Handle;
use crate::model::{CommandBuffer, MicromapTriangle};
use crate::report::count as count_of;
use crate::report::location::{Index, Locate, Location, Text};
use crate::report::{Report, RuleId};
use crate::rules;
use crate::sim::decode::{MicromapContent, TriangleEntries};
use crate::state::{
    AccelerationStructure, BuildRecord, HostMemory, HostRange, OpacityAttachmentRecord, State,
    TriangleGeometryRecord,
};
use crate::tier::Tier;

pub const COVERAGE: Coverage = Coverage {
    module: "accel_build",
    enforced: &[
        info_vuid::flags_11558,
        info_vuid::flags_11562,
        info_vuid::flags_11709,
        info_vuid::flags_11710,
        info_vuid::flags_11711,
        info_vuid::format_11712,
        info_vuid::format_11713,
        info_vuid::geometryCount_11560,
        info_vuid::geometryType_11561,
        info_vuid::geometryType_11707,
        info_vuid::micromap_11559,
        info_vuid::subdivisionLevel_11564,
        info_vuid::subdivisionLevel_11565,
        info_vuid::subdivisionLevel_11566,
        info_vuid::subdivisionLevel_11567,
        info_vuid::type_11563,
        geometry_vuid::flags_11569,
        geometry_vuid::micromap_11568,
        geometry_vuid::pNext_pNext,
        micromap_vuid::count_11643,
        micromap_vuid::pUsageCounts_11642,
        micromap_vuid::pUsageCounts_parameter,
        micromap_vuid::ppUsageCounts_parameter,
        micromap_vuid::sType_sType,
        micromap_vuid::subdivisionLevel_11645,
        micromap_vuid::triangleArrayStride_11646,
        micromap_vuid::triangleArrayStride_11647,
        usage_vuid::format_parameter,
        cmd::dstAccelerationStructure_11547,
        cmd::micromap_11550,
        cmd::micromap_11551,
        cmd::micromap_11552,
        cmd::micromap_11553,
        cmd::micromap_11554,
        cmd::micromap_11555,
        cmd::micromap_11556,
        cmd::mode_11545,
        cmd::ppBuildRangeInfos_11543,
        cmd::ppBuildRangeInfos_11544,
        cmd::srcAccelerationStructure_11546,
        indirect::type_11557,
        sizes::buildType_11614,
        sizes::pMaxPrimitiveCounts_11612,
        sizes::pMaxPrimitiveCounts_11613,
        create_info::type_11600,
        create_info2::createFlags_11610,
        create_info2::createFlags_11611,
        create_info2::micromap_11609,
        cmd_to_memory::pInfo_11699,
        // The id names the other copy command; the catalog files it (like
        // the specification) under the one whose src is a device address.
        cmd_from_memory::VUID_vkCmdCopyAccelerationStructureToMemoryKHR_pInfo_11700,
        from_memory_info::src_11583,
        from_memory_info::dst_11584,
        from_memory_info::dst_11585,
        to_memory_info::src_11582,
        cmd_copy::src_11634,
        host_copy::src_11587,
    ],
    not_decidable: &[],
};

/// Flags a KHR opacity-micromap build may have (11562).
const MICROMAP_BUILD_FLAGS: u32 = BUILD_ALLOW_COMPACTION
    | BUILD_PREFER_FAST_TRACE
    | BUILD_PREFER_FAST_BUILD
    | BUILD_MICROMAP_LOSSY;

/// sTypes that may extend `VkAccelerationStructureGeometryKHR`.
const GEOMETRY_EXTENSIONS: [i32; 4] = [
    STRUCTURE_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_DATA_AMDX,
    STRUCTURE_TYPE_GEOMETRY_LINEAR_SWEPT_SPHERES_DATA_NV,
    STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA,
    STRUCTURE_TYPE_GEOMETRY_SPHERES_DATA_NV,
];

/// KHR micromap `data` and `triangleArray` addresses are multiples of this (11552).
const MICROMAP_INPUT_ALIGNMENT: u64 = 128;

/// Serialized KHR micromaps are aligned to this (11699, 11700).
const MICROMAP_SERIALIZATION_ALIGNMENT: u64 = 128;

impl Validator {
    /// `vkCmdBuildAccelerationStructuresKHR(commandBuffer, infoCount, pInfos, ppBuildRangeInfos)`;
    /// `build_range_infos[i]` is `ppBuildRangeInfos[i]` (None, or missing:
    /// NULL). Its rules ([`Self::cmd_build_acceleration_structures_rules`]),
    /// then its record ([`Self::record_cmd_build_acceleration_structures`]),
    /// which here reuses what the rules found in the index buffers they
    /// read in full instead of reading them again.
    pub fn cmd_build_acceleration_structures(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> Report {
        let (report, index_mixes) = self.cmd_build_rules_reading(infos, build_range_infos);
        self.record_cmd_builds(command_buffer, infos, build_range_infos, &index_mixes);
        report
    }

    /// The rules of `vkCmdBuildAccelerationStructuresKHR`; records nothing.
    pub fn cmd_build_acceleration_structures_rules(
        &self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> Report {
        // No catalog VUID to cite for the command buffer (see the module doc).
        let _ = command_buffer;
        self.cmd_build_rules_reading(infos, build_range_infos).0
    }

    /// Records the builds `vkCmdBuildAccelerationStructuresKHR` put in
    /// `command_buffer`.
    pub fn record_cmd_build_acceleration_structures(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) {
        self.record_cmd_builds(command_buffer, infos, build_range_infos, &[]);
    }

    /// The rules of the device build, and the index buffers they read in
    /// full, for its record.
    fn cmd_build_rules_reading(
        &self,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> (Report, Vec<IndexMix>) {
        let mut ctx = self.ctx(BuildCommand::Cmd.function());
        builds(&mut ctx, BuildCommand::Cmd, infos, Some(build_range_infos));
        let index_mixes = std::mem::take(&mut ctx.index_mixes);
        crate::report::objects::acceleration_builds(&mut ctx.report, infos);
        (ctx.finish(), index_mixes)
    }

    /// [`Self::record_cmd_build_acceleration_structures`], with what the
    /// rules found in the index buffers they read (`index_mixes`, which are
    /// not read again).
    fn record_cmd_builds(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
        index_mixes: &[IndexMix],
    ) {
        record_builds(&mut self.state, self.tier, infos, build_range_infos, None);
        self.record_micromap_geometry_after_checks(infos, build_range_infos, index_mixes);
        self.record_acceleration_structure_builds(
            command_buffer,
            BuildCommand::Cmd.function(),
            infos,
            false,
        );
    }

    /// `vkCmdBuildAccelerationStructuresIndirectKHR(commandBuffer, infoCount, pInfos,
    /// pIndirectDeviceAddresses, pIndirectStrides, ppMaxPrimitiveCounts)`:
    /// its rules ([`Self::cmd_build_acceleration_structures_indirect_rules`]),
    /// then its record ([`Self::record_cmd_build_acceleration_structures_indirect`]).
    pub fn cmd_build_acceleration_structures_indirect(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        indirect_device_addresses: &[u64],
        indirect_strides: &[u32],
        max_primitive_counts: &[Option<Vec<u32>>],
    ) -> Report {
        let report = self.cmd_build_acceleration_structures_indirect_rules(
            command_buffer,
            infos,
            indirect_device_addresses,
            indirect_strides,
            max_primitive_counts,
        );
        self.record_cmd_build_acceleration_structures_indirect(command_buffer, infos);
        report
    }

    /// The rules of `vkCmdBuildAccelerationStructuresIndirectKHR`; records
    /// nothing.
    pub fn cmd_build_acceleration_structures_indirect_rules(
        &self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        indirect_device_addresses: &[u64],
        indirect_strides: &[u32],
        max_primitive_counts: &[Option<Vec<u32>>],
    ) -> Report {
        // The indirect arguments carry no micromap rule, and the command
        // buffer has no catalog VUID (see the module doc).
        let _ = (
            command_buffer,
            indirect_device_addresses,
            indirect_strides,
            max_primitive_counts,
        );
        let mut ctx = self.ctx(BuildCommand::Indirect.function());
        builds(&mut ctx, BuildCommand::Indirect, infos, None);
        crate::report::objects::acceleration_builds(&mut ctx.report, infos);
        ctx.finish()
    }

    /// Records the builds `vkCmdBuildAccelerationStructuresIndirectKHR`
    /// put in `command_buffer` (their ranges are the GPU's to read).
    pub fn record_cmd_build_acceleration_structures_indirect(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
    ) {
        record_builds(&mut self.state, self.tier, infos, &[], None);
        // Primitive counts live in device memory: no index buffer is read.
        self.record_micromap_geometry(infos, &[]);
        self.record_acceleration_structure_builds(
            command_buffer,
            BuildCommand::Indirect.function(),
            infos,
            true,
        );
    }

    /// `vkBuildAccelerationStructuresKHR(device, deferredOperation, infoCount, pInfos, ppBuildRangeInfos)`:
    /// its rules ([`Self::build_acceleration_structures_rules`]), then its
    /// record ([`Self::record_acceleration_structures_built`]), reading the
    /// host memory the application described.
    pub fn build_acceleration_structures(
        &mut self,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> Report {
        let report = self.build_acceleration_structures_rules(infos, build_range_infos, &[]);
        self.record_acceleration_structures_built(infos, build_range_infos, &[]);
        report
    }

    /// The rules of `vkBuildAccelerationStructuresKHR`, before the call,
    /// with `read_for_call`, the host memory an adaptor read for it (see
    /// [`HostMemory`]); records nothing.
    pub fn build_acceleration_structures_rules(
        &self,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
        read_for_call: &[HostRange],
    ) -> Report {
        let mut ctx = self.ctx_reading(BuildCommand::Host.function(), read_for_call);
        builds(&mut ctx, BuildCommand::Host, infos, Some(build_range_infos));
        crate::report::objects::acceleration_builds(&mut ctx.report, infos);
        ctx.finish()
    }

    /// Records what `vkBuildAccelerationStructuresKHR` built, reading its
    /// inputs in the host memory the application described and
    /// `read_for_call` (as its rules did).
    pub fn record_acceleration_structures_built(
        &mut self,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
        read_for_call: &[HostRange],
    ) {
        record_builds(
            &mut self.state,
            self.tier,
            infos,
            build_range_infos,
            Some(read_for_call),
        );
        self.record_micromap_geometry_reading(infos, build_range_infos, &[], read_for_call);
        for info in infos {
            self.constructed_on_host(info.dst_acceleration_structure, 0);
        }
    }

    /// `vkGetAccelerationStructureBuildSizesKHR(device, buildType, pBuildInfo,
    /// pMaxPrimitiveCounts, pSizeInfo)`; `max_primitive_counts` None is NULL.
    /// Addresses, `mode` and the handles of `build_info` are ignored by the
    /// command, so only its structure is checked.
    pub fn get_acceleration_structure_build_sizes(
        &mut self,
        build_type: i32,
        build_info: &BuildGeometryInfo,
        max_primitive_counts: Option<&[u32]>,
    ) -> Report {
        let mut ctx = self.ctx("vkGetAccelerationStructureBuildSizesKHR");
        build_geometry_info(&mut ctx, InfoAt::Pointer, build_info);
        if build_info.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
            ctx.require(
                build_type == BUILD_TYPE_DEVICE,
                sizes::buildType_11614,
                || "buildType".into(),
                || {
                    format!("{} is not VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, for an opacity micromap", build_type_name(build_type))
                },
            );
            ctx.require(
                max_primitive_counts.is_none(),
                sizes::pMaxPrimitiveCounts_11613,
                || "pMaxPrimitiveCounts".into(),
                || "is not NULL, for an opacity micromap".into(),
            );
        } else if build_info.geometry_count != 0 {
            let needed = build_info.geometry_count;
            ctx.require(
                max_primitive_counts.is_some_and(|counts| counts.len() as u64 >= u64::from(needed)),
                sizes::pMaxPrimitiveCounts_11612,
                || "pMaxPrimitiveCounts".into(),
                || match max_primitive_counts {
                    None => format!("is NULL, but pBuildInfo->geometryCount is {needed}"),
                    Some(counts) => format!(
                        "points to {} values, not pBuildInfo->geometryCount = {needed}",
                        counts.len()
                    ),
                },
            );
        }
        ctx.finish()
    }

    /// `vkCreateAccelerationStructureKHR(device, pCreateInfo, pAllocator,
    /// pAccelerationStructure)`; `acceleration_structure` is the handle the
    /// call returned (0: none), which is then tracked: the call's rules
    /// ([`Self::create_acceleration_structure_rules`]), then its record
    /// ([`Self::record_acceleration_structure_created`]).
    pub fn create_acceleration_structure(
        &mut self,
        info: &AccelerationStructureCreateInfo,
        acceleration_structure: Handle,
    ) -> Report {
        let report = self.create_acceleration_structure_rules(info);
        self.record_acceleration_structure_created(info, acceleration_structure);
        report
    }

    /// The rules of `vkCreateAccelerationStructureKHR`, before the call;
    /// records nothing.
    pub fn create_acceleration_structure_rules(
        &self,
        info: &AccelerationStructureCreateInfo,
    ) -> Report {
        let mut ctx = self.ctx("vkCreateAccelerationStructureKHR");
        ctx.require(
            info.ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            create_info::type_11600,
            || "pCreateInfo->type".into(),
            || "is VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR, which only vkCreateAccelerationStructure2KHR creates".into(),
        );
        ctx.finish()
    }

    /// Tracks the structure `vkCreateAccelerationStructureKHR` created
    /// (`acceleration_structure`; 0: none, nothing is tracked).
    pub fn record_acceleration_structure_created(
        &mut self,
        info: &AccelerationStructureCreateInfo,
        acceleration_structure: Handle,
    ) {
        if acceleration_structure == 0 {
            return;
        }
        let buffer_start = self.state.device_address_in(info.buffer, info.offset);
        let record = AccelerationStructure {
            ty: info.ty,
            created_with_2: false,
            buffer: info.buffer,
            offset: info.offset,
            size: info.size,
            address_range: buffer_start
                .and_then(|start| Some((start, start.checked_add(info.size)?))),
            built: None,
        };
        self.state
            .acceleration_structures
            .insert(acceleration_structure, record);
    }

    /// `vkCreateAccelerationStructure2KHR(device, pCreateInfo, pAllocator,
    /// pAccelerationStructure)`; `acceleration_structure` as for
    /// [`Self::create_acceleration_structure`]: the rules
    /// ([`Self::create_acceleration_structure2_rules`]), then the record
    /// ([`Self::record_acceleration_structure2_created`]).
    pub fn create_acceleration_structure2(
        &mut self,
        info: &AccelerationStructureCreateInfo2,
        acceleration_structure: Handle,
    ) -> Report {
        let report = self.create_acceleration_structure2_rules(info);
        self.record_acceleration_structure2_created(info, acceleration_structure);
        report
    }

    /// The rules of `vkCreateAccelerationStructure2KHR`, before the call;
    /// records nothing.
    pub fn create_acceleration_structure2_rules(
        &self,
        info: &AccelerationStructureCreateInfo2,
    ) -> Report {
        let mut ctx = self.ctx("vkCreateAccelerationStructure2KHR");
        if info.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
            ctx.require(
                ctx.device.features.micromap_khr,
                create_info2::micromap_11609,
                || "pCreateInfo->type".into(),
                || "an opacity micromap needs the VkPhysicalDeviceOpacityMicromapFeaturesKHR::micromap feature, which is not enabled".into(),
            );
            for (bit, name, vuid) in [
                (
                    CREATE_DESCRIPTOR_BUFFER_CAPTURE_REPLAY_BIT_EXT,
                    "VK_ACCELERATION_STRUCTURE_CREATE_DESCRIPTOR_BUFFER_CAPTURE_REPLAY_BIT_EXT",
                    create_info2::createFlags_11610,
                ),
                (
                    CREATE_MOTION_BIT_NV,
                    "VK_ACCELERATION_STRUCTURE_CREATE_MOTION_BIT_NV",
                    create_info2::createFlags_11611,
                ),
            ] {
                ctx.require(
                    info.create_flags & bit == 0,
                    vuid,
                    || "pCreateInfo->createFlags".into(),
                    || {
                        format!(
                            "{:#x} includes {name}, for an opacity micromap",
                            info.create_flags
                        )
                    },
                );
            }
        }
        ctx.finish()
    }

    /// Tracks the structure `vkCreateAccelerationStructure2KHR` created
    /// (`acceleration_structure`; 0: none, nothing is tracked).
    pub fn record_acceleration_structure2_created(
        &mut self,
        info: &AccelerationStructureCreateInfo2,
        acceleration_structure: Handle,
    ) {
        if acceleration_structure == 0 {
            return;
        }
        let backing = self
            .state
            .buffers_at(info.address)
            .next()
            .and_then(|(handle, b)| Some((handle, info.address.checked_sub(b.device_address?)?)));
        let (buffer, offset) = backing.unwrap_or((0, 0));
        let record = AccelerationStructure {
            ty: info.ty,
            created_with_2: true,
            buffer,
            offset,
            size: info.size,
            address_range: info
                .address
                .checked_add(info.size)
                .map(|end| (info.address, end)),
            built: None,
        };
        self.state
            .acceleration_structures
            .insert(acceleration_structure, record);
    }

    /// `vkCmdCopyAccelerationStructureKHR(commandBuffer, pInfo)`: its rules
    /// ([`Self::cmd_copy_acceleration_structure_rules`]), then its record
    /// ([`Self::record_cmd_copy_acceleration_structure`]).
    pub fn cmd_copy_acceleration_structure(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &CopyAccelerationStructureInfo,
    ) -> Report {
        let report = self.cmd_copy_acceleration_structure_rules(info);
        self.record_cmd_copy_acceleration_structure(command_buffer, info);
        report
    }

    /// The rules of `vkCmdCopyAccelerationStructureKHR`: its one micromap
    /// rule (11634) asks what a deserialized source's micromaps were
    /// deserialized from (`provenance`).
    pub fn cmd_copy_acceleration_structure_rules(
        &self,
        info: &CopyAccelerationStructureInfo,
    ) -> Report {
        let mut ctx = self.ctx("vkCmdCopyAccelerationStructureKHR");
        provenance::deserialized_micromaps(&mut ctx, info.src, cmd_copy::src_11634, "pInfo->src");
        ctx.finish()
    }

    /// Records the copy `vkCmdCopyAccelerationStructureKHR` put in
    /// `command_buffer`.
    pub fn record_cmd_copy_acceleration_structure(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &CopyAccelerationStructureInfo,
    ) {
        record_copy(&mut self.state, info);
        let construct = ExecEvent::Construct { object: info.dst };
        self.record_execution(
            command_buffer,
            "vkCmdCopyAccelerationStructureKHR",
            [construct],
        );
    }

    /// `vkCopyAccelerationStructureKHR(device, deferredOperation, pInfo)`, as
    /// [`Self::cmd_copy_acceleration_structure`] on the host (its rules:
    /// [`Self::copy_acceleration_structure_rules`], its record:
    /// [`Self::record_copy_acceleration_structure`]).
    pub fn copy_acceleration_structure(&mut self, info: &CopyAccelerationStructureInfo) -> Report {
        let report = self.copy_acceleration_structure_rules(info);
        self.record_copy_acceleration_structure(info);
        report
    }

    /// The rules of `vkCopyAccelerationStructureKHR` (11587, as
    /// [`Self::cmd_copy_acceleration_structure_rules`] for 11634).
    pub fn copy_acceleration_structure_rules(
        &self,
        info: &CopyAccelerationStructureInfo,
    ) -> Report {
        let mut ctx = self.ctx("vkCopyAccelerationStructureKHR");
        provenance::deserialized_micromaps(&mut ctx, info.src, host_copy::src_11587, "pInfo->src");
        ctx.finish()
    }

    /// Records the copy `vkCopyAccelerationStructureKHR` made.
    pub fn record_copy_acceleration_structure(&mut self, info: &CopyAccelerationStructureInfo) {
        record_copy(&mut self.state, info);
        self.constructed_on_host(info.dst, 0);
    }

    /// `vkCmdCopyAccelerationStructureToMemoryKHR(commandBuffer, pInfo)`:
    /// serializing an opacity micromap needs 128-byte alignment. It
    /// changes nothing the checker tracks: its rules are the whole call.
    pub fn cmd_copy_acceleration_structure_to_memory(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &CopyAccelerationStructureToMemoryInfo,
    ) -> Report {
        let _ = command_buffer;
        let mut ctx = self.ctx("vkCmdCopyAccelerationStructureToMemoryKHR");
        let micromap_source = ctx
            .state
            .and_then(|state| state.acceleration_structures.get(&info.src))
            .is_some_and(|src| built_type(src) == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP);
        if micromap_source {
            common::aligned(
                &mut ctx,
                info.dst,
                MICROMAP_SERIALIZATION_ALIGNMENT,
                cmd_to_memory::pInfo_11699,
                "pInfo->dst.deviceAddress",
            );
        }
        provenance::serialization_source(&mut ctx, info.src);
        let report = ctx.finish();
        self.record_structure_serialization(
            "vkCmdCopyAccelerationStructureToMemoryKHR",
            false,
            info.src,
            info.dst,
        );
        report
    }

    /// `vkCmdCopyMemoryToAccelerationStructureKHR(commandBuffer, pInfo)`:
    /// deserializing an opacity micromap needs 128-byte alignment, and the
    /// blocks of a bottom-level serialized header are checked where its
    /// contents are known (see `serialized`); what the destination holds
    /// afterwards is whatever was serialized, so its recorded build is
    /// forgotten. Its rules
    /// ([`Self::cmd_copy_memory_to_acceleration_structure_rules`]), then its
    /// record ([`Self::record_cmd_copy_memory_to_acceleration_structure`]).
    pub fn cmd_copy_memory_to_acceleration_structure(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &CopyMemoryToAccelerationStructureInfo,
    ) -> Report {
        let report = self.cmd_copy_memory_to_acceleration_structure_rules(command_buffer, info);
        self.record_cmd_copy_memory_to_acceleration_structure(command_buffer, info);
        report
    }

    /// The rules of `vkCmdCopyMemoryToAccelerationStructureKHR`; records
    /// nothing.
    pub fn cmd_copy_memory_to_acceleration_structure_rules(
        &self,
        command_buffer: &CommandBuffer,
        info: &CopyMemoryToAccelerationStructureInfo,
    ) -> Report {
        // No catalog VUID to cite for the command buffer (see the module doc).
        let _ = command_buffer;
        let mut ctx = self.ctx("vkCmdCopyMemoryToAccelerationStructureKHR");
        // Only an opacity micromap deserializes into a structure created as
        // one, so the destination's creation type tells what src holds.
        let micromap_destination = ctx
            .state
            .and_then(|state| state.acceleration_structures.get(&info.dst))
            .is_some_and(|dst| dst.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP);
        if micromap_destination {
            common::aligned(
                &mut ctx,
                info.src,
                MICROMAP_SERIALIZATION_ALIGNMENT,
                cmd_from_memory::VUID_vkCmdCopyAccelerationStructureToMemoryKHR_pInfo_11700,
                "pInfo->src.deviceAddress",
            );
        }
        serialized::check(&mut ctx, false, info);
        ctx.finish()
    }

    /// Records the deserialization `vkCmdCopyMemoryToAccelerationStructureKHR`
    /// put in `command_buffer`: the destination's recorded build is
    /// forgotten.
    pub fn record_cmd_copy_memory_to_acceleration_structure(
        &mut self,
        command_buffer: &CommandBuffer,
        info: &CopyMemoryToAccelerationStructureInfo,
    ) {
        forget_deserialized(&mut self.state, info);
        self.record_deserialization(false, info.src, info.dst, true);
        let construct = ExecEvent::Construct { object: info.dst };
        self.record_execution(
            command_buffer,
            "vkCmdCopyMemoryToAccelerationStructureKHR",
            [construct],
        );
    }

    /// `vkCopyAccelerationStructureToMemoryKHR(device, deferredOperation, pInfo)`:
    /// the host serialization. Its one micromap rule (11582, on the info
    /// structure) asks what a deserialized source's micromaps were
    /// deserialized from (`provenance`), and the 128-byte alignment of
    /// serialized opacity micromaps (11699) is stated for the device command
    /// only. The serialization is recorded where it writes.
    pub fn copy_acceleration_structure_to_memory(
        &mut self,
        info: &CopyAccelerationStructureToMemoryInfo,
    ) -> Report {
        let mut ctx = self.ctx("vkCopyAccelerationStructureToMemoryKHR");
        provenance::serialization_source(&mut ctx, info.src);
        let report = ctx.finish();
        self.record_structure_serialization(
            "vkCopyAccelerationStructureToMemoryKHR",
            true,
            info.src,
            info.dst,
        );
        report
    }

    /// `vkCopyMemoryToAccelerationStructureKHR(device, deferredOperation, pInfo)`:
    /// the host deserialization, whose serialized header is host memory
    /// (11583, 11584, 11585); what the destination holds afterwards is
    /// whatever was serialized, so its recorded build is forgotten. The
    /// rules ([`Self::copy_memory_to_acceleration_structure_rules`]), then
    /// the record ([`Self::record_copy_memory_to_acceleration_structure`]).
    pub fn copy_memory_to_acceleration_structure(
        &mut self,
        info: &CopyMemoryToAccelerationStructureInfo,
    ) -> Report {
        let report = self.copy_memory_to_acceleration_structure_rules(info, &[]);
        self.record_copy_memory_to_acceleration_structure(info);
        report
    }

    /// The rules of `vkCopyMemoryToAccelerationStructureKHR`, before the
    /// call, with `read_for_call`, the host memory an adaptor read for it
    /// (see [`HostMemory`]); records nothing.
    pub fn copy_memory_to_acceleration_structure_rules(
        &self,
        info: &CopyMemoryToAccelerationStructureInfo,
        read_for_call: &[HostRange],
    ) -> Report {
        let mut ctx = self.ctx_reading("vkCopyMemoryToAccelerationStructureKHR", read_for_call);
        serialized::check(&mut ctx, true, info);
        ctx.finish()
    }

    /// Forgets the build of the structure `vkCopyMemoryToAccelerationStructureKHR`
    /// deserialized into, and links it to what the bytes were serialized from.
    pub fn record_copy_memory_to_acceleration_structure(
        &mut self,
        info: &CopyMemoryToAccelerationStructureInfo,
    ) {
        forget_deserialized(&mut self.state, info);
        self.record_deserialization(true, info.src, info.dst, true);
    }

    /// `vkWriteAccelerationStructuresPropertiesKHR(device,
    /// accelerationStructureCount, pAccelerationStructures, queryType,
    /// dataSize, pData, stride)`. No micromap rule names it: a KHR opacity
    /// micromap's sizes are queried like any acceleration structure's.
    pub fn write_acceleration_structures_properties(
        &mut self,
        structures: &[Handle],
        query_type: i32,
        data_size: u64,
        stride: u64,
    ) -> Report {
        let _ = (structures, query_type, data_size, stride);
        self.ctx("vkWriteAccelerationStructuresPropertiesKHR")
            .finish()
    }
}

/// A deserialization leaves in its destination a build the checker did not
/// see.
fn forget_deserialized(state: &mut State, info: &CopyMemoryToAccelerationStructureInfo) {
    if let Some(dst) = state.acceleration_structures.get_mut(&info.dst) {
        dst.built = None;
    }
    state.original_attachments.remove(&info.dst);
}

/// The type an acceleration structure was built with, or (not built through
/// the checker) created with.
fn built_type(structure: &AccelerationStructure) -> i32 {
    structure.built.as_ref().map_or(structure.ty, |b| b.ty)
}

/// A clone or compaction gives the destination the source's build and its
/// original attachments.
fn record_copy(state: &mut State, info: &CopyAccelerationStructureInfo) {
    if info.mode != COPY_MODE_CLONE && info.mode != COPY_MODE_COMPACT {
        return;
    }
    let built = state
        .acceleration_structures
        .get(&info.src)
        .and_then(|src| src.built.clone());
    if let Some(dst) = state.acceleration_structures.get_mut(&info.dst) {
        dst.built = built;
    }
    match state.original_attachments.get(&info.src).cloned() {
        Some(attachments) => state.original_attachments.insert(info.dst, attachments),
        None => state.original_attachments.remove(&info.dst),
    };
    provenance::record_copy(state, info.src, info.dst);
}

/// Remembers what each build made of its destination, and (for
/// `accel_attach`'s update rules) the attachments of original builds: a
/// micromap build's content (its triangle array as read, its data shared
/// with the memory holding it), and a bottom-level build's triangles
/// geometries with their build ranges, for the simulator. `host`: the
/// addresses are host addresses, and this is what an adaptor read of host
/// memory for the call (see [`HostMemory`]).
/// Contents (the micromap's triangles and data) are recorded only from the
/// content tier up: below it nothing is decoded, so a build costs the same
/// whatever its size.
fn record_builds(
    state: &mut State,
    tier: Tier,
    infos: &[BuildGeometryInfo],
    ranges: &[Option<Vec<BuildRangeInfo>>],
    host: Option<&[HostRange]>,
) {
    provenance::record_structure_builds(state, infos);
    accel_attach::record_original_attachments(state, infos);
    for (i, info) in infos.iter().enumerate() {
        if !state
            .acceleration_structures
            .contains_key(&info.dst_acceleration_structure)
        {
            continue;
        }
        let info_ranges = ranges.get(i).and_then(Option::as_ref);
        let content = info
            .geometries_read()
            .find_map(|(_, g)| g.micromap.as_ref())
            .filter(|_| tier >= Tier::Content)
            .and_then(|data| {
                let host = host.map(|read_for_call| state.host_memory(read_for_call));
                micromap_content(state, host, data)
            })
            .map(Arc::new);
        let geometries = info
            .geometries_read()
            .map(|(g, geometry)| {
                geometry_record(geometry, info_ranges.and_then(|r| r.get(g)).copied())
            })
            .collect();
        if let Some(dst) = state
            .acceleration_structures
            .get_mut(&info.dst_acceleration_structure)
        {
            dst.built = Some(BuildRecord {
                flags: info.flags,
                ty: info.ty,
                triangle_count: micromap_triangle_count(info),
                content,
                geometries,
                host: host.is_some(),
                // A KHR micromap's usage counts are not kept: its pictures
                // have no histogram (docs/pictures.md).
                usage_counts: Vec::new(),
            });
        }
    }
}

/// A micromap geometry's triangle array as far as it is readable (at most
/// Σcount entries, a stride below 8 or not a multiple of 4 reads none:
/// 11646/11647 report it) and its data, shared.
pub(crate) fn micromap_content(
    state: &State,
    host: Option<HostMemory<'_>>,
    data: &GeometryMicromapData,
) -> Option<MicromapContent> {
    let total = data.usage_counts.total();
    let stride = data.triangle_array_stride;
    if total == 0 || stride < MicromapTriangle::SIZE || !stride.is_multiple_of(4) {
        return None;
    }
    let (memory, array_start) = contents_from(state, host, data.triangle_array)?;
    let array_len = memory.get(array_start..)?.len();
    // As many entries as the array's bytes hold, never more than the counts
    // say: a view of the bytes, not a copy.
    let readable = readable_entries(array_len as u64, stride).min(total);
    let triangles = TriangleEntries::shared(memory, array_start, stride, readable)?;
    let (bytes, start) = contents_from(state, host, data.data).unwrap_or_else(|| (Bytes::new(), 0));
    Some(MicromapContent::at(triangles, bytes, start))
}

/// What the simulator needs of one geometry: a triangles geometry's data,
/// flags, build range and opacity attachment.
fn geometry_record(
    geometry: &Geometry,
    range: Option<BuildRangeInfo>,
) -> Option<TriangleGeometryRecord> {
    let GeometryData::Triangles(t) = &geometry.geometry else {
        return None;
    };
    let opacity = match (&t.opacity_khr, &t.opacity_ext) {
        (Some(a), _) => Some(OpacityAttachmentRecord {
            khr: true,
            index_type: a.index_type,
            index_buffer: a.index_buffer,
            index_stride: a.index_stride,
            base_triangle: a.base_triangle,
            micromap: a.micromap,
        }),
        (None, Some(a)) => Some(OpacityAttachmentRecord {
            khr: false,
            index_type: a.index_type,
            index_buffer: a.index_buffer,
            index_stride: a.index_stride,
            base_triangle: a.base_triangle,
            micromap: a.micromap,
        }),
        (None, None) => None,
    };
    Some(TriangleGeometryRecord {
        flags: geometry.flags,
        vertex_format: t.vertex_format,
        vertex_data: t.vertex_data,
        vertex_stride: t.vertex_stride,
        max_vertex: t.max_vertex,
        index_type: t.index_type,
        index_data: t.index_data,
        transform_data: t.transform_data,
        range,
        opacity,
    })
}

/// The number of micromap triangles a build describes: the sum of its
/// micromap geometries' usage counts.
fn micromap_triangle_count(info: &BuildGeometryInfo) -> u64 {
    info.geometries_read()
        .filter_map(|(_, g)| g.micromap.as_ref())
        .map(|m| m.usage_counts.total())
        .fold(0, u64::saturating_add)
}

/// The checks every build command shares: each info, its command's own
/// rules, each micromap geometry's inputs, each geometry's attachments (in
/// `accel_attach`), and rules across infos.
pub(crate) fn builds(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    infos: &[BuildGeometryInfo],
    ranges: Option<&[Option<Vec<BuildRangeInfo>>]>,
) {
    for (i, info) in infos.iter().enumerate() {
        build_geometry_info(ctx, InfoAt::Element(i), info);
        let info_ranges = ranges.map(|r| r.get(i).and_then(Option::as_ref));
        match command {
            BuildCommand::Cmd => cmd_rules(ctx, i, info, info_ranges.flatten()),
            BuildCommand::Indirect => ctx.require(
                info.ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                indirect::type_11557,
                || format!("pInfos[{i}].type"),
                || "is VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR, which indirect builds cannot build".into(),
            ),
            BuildCommand::Host => {}
        }
        let member = info.geometry_member();
        for (g, geometry) in info.geometries_read() {
            let at = geometry_at(InfoAt::Element(i), member, g);
            if let Some(micromap) = &geometry.micromap {
                micromap_inputs(ctx, command, micromap_at(at), info, micromap);
            }
            let range = info_ranges.flatten().and_then(|r| r.get(g));
            match &geometry.geometry {
                GeometryData::Triangles(triangles) => {
                    accel_attach::triangles(ctx, command, at, info, triangles, range)
                }
                GeometryData::Instances(instances) => {
                    accel_attach::instances(ctx, command, at, info, instances, range)
                }
                GeometryData::Aabbs(_) | GeometryData::None => {}
            }
        }
    }
    accel_attach::across_infos(ctx, command, infos);
}

/// Where a `VkAccelerationStructureBuildGeometryInfoKHR` is, as the start
/// of its members' locations: `pInfos[i].` in the build commands,
/// `pBuildInfo->` in the size query: the root of the [`Location`]s of its
/// members.
#[derive(Clone, Copy)]
pub(crate) enum InfoAt {
    Element(usize),
    Pointer,
}

impl Display for InfoAt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InfoAt::Element(i) => write!(f, "pInfos[{i}]."),
            InfoAt::Pointer => f.write_str("pBuildInfo->"),
        }
    }
}

/// Where one geometry of an info is: `pInfos[i].pGeometries[g]` (or
/// `ppGeometries[g]`).
pub(crate) type GeometryAt = Location<Location<InfoAt, Text<'static>>, Index>;

/// Geometry `index` of the info at `info`, in its member `member`
/// (`pGeometries` or `ppGeometries`).
pub(crate) fn geometry_at(info: InfoAt, member: &'static str, index: usize) -> GeometryAt {
    info.text(member).index(index)
}

/// Where a geometry's `VkAccelerationStructureGeometryMicromapDataKHR` is.
type MicromapAt = Location<GeometryAt, Text<'static>>;

fn micromap_at(geometry: GeometryAt) -> MicromapAt {
    geometry.text(".pNext<VkAccelerationStructureGeometryMicromapDataKHR>")
}

/// `vkCmdBuildAccelerationStructuresKHR`'s own rules for `pInfos[i]`, with
/// `ppBuildRangeInfos[i]` (None: NULL).
fn cmd_rules(
    ctx: &mut Ctx<'_>,
    i: usize,
    info: &BuildGeometryInfo,
    ranges: Option<&Vec<BuildRangeInfo>>,
) {
    let opacity_micromap = info.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP;
    if opacity_micromap {
        ctx.require(
            info.mode == BUILD_ACCELERATION_STRUCTURE_MODE_BUILD,
            cmd::mode_11545,
            || format!("pInfos[{i}].mode"),
            || {
                format!(
                    "{} is not VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR, for an opacity micromap",
                    build_acceleration_structure_mode_name(info.mode)
                )
            },
        );
        ctx.require(
            info.src_acceleration_structure == 0,
            cmd::srcAccelerationStructure_11546,
            || format!("pInfos[{i}].srcAccelerationStructure"),
            || {
                format!(
                    "{:#x} is not VK_NULL_HANDLE, for an opacity micromap",
                    info.src_acceleration_structure
                )
            },
        );
        let dst_type = ctx
            .state
            .and_then(|state| {
                state
                    .acceleration_structures
                    .get(&info.dst_acceleration_structure)
            })
            .map(|dst| dst.ty);
        if let Some(ty) = dst_type {
            ctx.require(
                ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP
                    || ty == ACCELERATION_STRUCTURE_TYPE_GENERIC,
                cmd::dstAccelerationStructure_11547,
                || format!("pInfos[{i}].dstAccelerationStructure"),
                || format!("was created with type {}, not VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR or VK_ACCELERATION_STRUCTURE_TYPE_GENERIC_KHR", acceleration_structure_type_name(ty)),
            );
        }
    }
    let has_type = |ty: i32| info.geometries_read().any(|(_, g)| g.geometry_type == ty);
    if has_type(GEOMETRY_TYPE_MICROMAP) {
        ctx.require(
            ranges.is_none(),
            cmd::ppBuildRangeInfos_11544,
            || format!("ppBuildRangeInfos[{i}]"),
            || format!("is not NULL, but pInfos[{i}] has micromap geometry"),
        );
    } else if !opacity_micromap && !has_type(GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX) {
        let needed = info.geometry_count;
        ctx.require(
            ranges.is_some_and(|r| r.len() as u64 >= u64::from(needed)),
            cmd::ppBuildRangeInfos_11543,
            || format!("ppBuildRangeInfos[{i}]"),
            || match ranges {
                None => format!("is NULL, but pInfos[{i}].geometryCount is {needed}"),
                Some(r) => format!(
                    "points to {} range infos, not pInfos[{i}].geometryCount = {needed}",
                    r.len()
                ),
            },
        );
    }
}

/// The rules of `VkAccelerationStructureBuildGeometryInfoKHR` and the
/// structures it points to, which the build commands and the size query
/// share; `prefix` is `pInfos[i].` or `pBuildInfo->`.
fn build_geometry_info(ctx: &mut Ctx<'_>, prefix: InfoAt, info: &BuildGeometryInfo) {
    build_flags(ctx, prefix, info);
    micromap_type(ctx, prefix, info);
    let lossy = info.flags & BUILD_MICROMAP_LOSSY != 0;
    let member = info.geometry_member();
    for (g, geometry) in info.geometries_read() {
        let at = geometry_at(prefix, member, g);
        geometry_rules(ctx, at, geometry);
        if let Some(micromap) = &geometry.micromap {
            micromap_data(ctx, micromap_at(at), micromap, lossy);
        }
    }
}

/// The build flags' micromap rules.
fn build_flags(ctx: &mut Ctx<'_>, prefix: InfoAt, info: &BuildGeometryInfo) {
    let flags = info.flags;
    let features = &ctx.device.features;
    let (ext_micromap, any_micromap) = (
        features.micromap_ext,
        features.micromap_ext || features.micromap_khr,
    );
    let at = || format!("{prefix}flags");
    ctx.require(
        flags & BUILD_MICROMAP_LOSSY == 0 || info.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        info_vuid::type_11563,
        || format!("{prefix}type"),
        || format!("{} is not VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR, but flags include VK_BUILD_ACCELERATION_STRUCTURE_MICROMAP_LOSSY_BIT_KHR", acceleration_structure_type_name(info.ty)),
    );
    if info.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
        let outside = flags & !MICROMAP_BUILD_FLAGS;
        ctx.require(
            outside == 0,
            info_vuid::flags_11562,
            at,
            || format!("{flags:#x} has bits {outside:#x} an opacity micromap build may not have (only ALLOW_COMPACTION, PREFER_FAST_TRACE, PREFER_FAST_BUILD, MICROMAP_LOSSY)"),
        );
    }
    let update = flags & BUILD_ALLOW_OPACITY_MICROMAP_UPDATE != 0;
    let data_update = flags & BUILD_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT != 0;
    ctx.require(
        !(update && data_update),
        info_vuid::flags_11558,
        at,
        || format!("{flags:#x} has both ALLOW_OPACITY_MICROMAP_UPDATE and ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT"),
    );
    ctx.require(
        !data_update || ext_micromap,
        info_vuid::flags_11709,
        at,
        || "ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT is set, but the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromap feature is not enabled".into(),
    );
    for (bit, name, vuid) in [
        (
            BUILD_ALLOW_OPACITY_MICROMAP_UPDATE,
            "ALLOW_OPACITY_MICROMAP_UPDATE",
            info_vuid::flags_11710,
        ),
        (
            BUILD_ALLOW_DISABLE_OPACITY_MICROMAPS,
            "ALLOW_DISABLE_OPACITY_MICROMAPS",
            info_vuid::flags_11711,
        ),
    ] {
        ctx.require(flags & bit == 0 || any_micromap, vuid, at, || {
            format!("{name} is set, but neither the KHR nor the EXT micromap feature is enabled")
        });
    }
}

/// The rules tying the build's type to its geometries.
fn micromap_type(ctx: &mut Ctx<'_>, prefix: InfoAt, info: &BuildGeometryInfo) {
    let member = info.geometry_member();
    if info.ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
        for (g, geometry) in info.geometries_read() {
            ctx.require(
                geometry.geometry_type != GEOMETRY_TYPE_MICROMAP,
                info_vuid::geometryType_11707,
                || format!("{prefix}{member}[{g}].geometryType"),
                || format!("is VK_GEOMETRY_TYPE_MICROMAP_KHR, but the build's type is {}, not OPACITY_MICROMAP", info.ty),
            );
        }
        return;
    }
    ctx.require(
        ctx.device.features.micromap_khr,
        info_vuid::micromap_11559,
        || format!("{prefix}type"),
        || "is OPACITY_MICROMAP, but the VkPhysicalDeviceOpacityMicromapFeaturesKHR::micromap feature is not enabled".into(),
    );
    ctx.require(
        info.geometry_count == 1,
        info_vuid::geometryCount_11560,
        || format!("{prefix}geometryCount"),
        || format!("is {}, not 1, for an opacity micromap", info.geometry_count),
    );
    for (g, geometry) in info.geometries_read() {
        ctx.require(
            geometry.geometry_type == GEOMETRY_TYPE_MICROMAP,
            info_vuid::geometryType_11561,
            || format!("{prefix}{member}[{g}].geometryType"),
            || {
                format!(
                    "is {}, not VK_GEOMETRY_TYPE_MICROMAP_KHR, in an opacity micromap build",
                    geometry_type_name(geometry.geometry_type)
                )
            },
        );
    }
}

/// `VkAccelerationStructureGeometryKHR`: its pNext chain, and what micromap
/// geometry needs.
fn geometry_rules(ctx: &mut Ctx<'_>, at: GeometryAt, geometry: &Geometry) {
    for s_type in geometry
        .next
        .iter()
        .filter(|s| !GEOMETRY_EXTENSIONS.contains(s))
    {
        ctx.error(
            geometry_vuid::pNext_pNext,
            format!("{at}.pNext"),
            format!(
                "a structure with sType {} does not extend VkAccelerationStructureGeometryKHR",
                structure_type_name(*s_type)
            ),
        );
    }
    if geometry.geometry_type != GEOMETRY_TYPE_MICROMAP {
        return;
    }
    ctx.require(
        geometry.flags == 0,
        geometry_vuid::flags_11569,
        || format!("{at}.flags"),
        || format!("{:#x} is not 0, for micromap geometry", geometry.flags),
    );
    let chained = usize::from(geometry.micromap.is_some())
        + geometry
            .next
            .iter()
            .filter(|s| **s == STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA)
            .count();
    ctx.require(
        chained == 1,
        geometry_vuid::micromap_11568,
        || format!("{at}.pNext"),
        || format!("holds {chained} VkAccelerationStructureGeometryMicromapDataKHR structures, not exactly 1, for micromap geometry"),
    );
}

/// `VkAccelerationStructureGeometryMicromapDataKHR` at `at` and its usage
/// counts, in a build with or without the LOSSY flag.
fn micromap_data(ctx: &mut Ctx<'_>, at: MicromapAt, data: &GeometryMicromapData, lossy: bool) {
    ctx.require(
        data.s_type == STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA,
        micromap_vuid::sType_sType,
        || format!("{at}.sType"),
        || {
            format!(
                "{} is not VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MICROMAP_DATA_KHR",
                structure_type_name(data.s_type)
            )
        },
    );
    let stride = data.triangle_array_stride;
    ctx.require(
        stride >= MicromapTriangle::SIZE,
        micromap_vuid::triangleArrayStride_11646,
        || format!("{at}.triangleArrayStride"),
        || format!("{stride} is less than 8"),
    );
    ctx.require(
        stride.is_multiple_of(4),
        micromap_vuid::triangleArrayStride_11647,
        || format!("{at}.triangleArrayStride"),
        || format!("{stride} is not a multiple of 4"),
    );
    usage_counts::pointer_rules(ctx, at, &data.usage_counts, &USAGE_POINTERS);
    // The device outlives the context: its limits need no copy while the
    // context takes findings.
    let device = ctx.device;
    let limits = &device.limits;
    // Every rule of `usage_rules` runs for every entry, so where each entry
    // is a key the table allows, running them on one entry decides them as
    // running them on all would (see `UsageKeys::entries_to_check`).
    let keys = if lossy {
        UsageKeys::none().allow(
            OPACITY_MICROMAP_FORMAT_4_STATE,
            limits.max_opacity_lossy4_state_subdivision_level,
        )
    } else {
        UsageKeys::none()
            .allow(
                OPACITY_MICROMAP_FORMAT_2_STATE,
                limits.max_opacity2_state_subdivision_level,
            )
            .allow(
                OPACITY_MICROMAP_FORMAT_4_STATE,
                limits.max_opacity4_state_subdivision_level,
            )
    };
    // One pass finds the entries to check and sums the counts.
    let scan = keys.scan(&data.usage_counts);
    let total = scan.total;
    let max_triangles = limits.max_micromap_triangles;
    let member = data.usage_counts.member();
    ctx.require(
        total <= max_triangles,
        micromap_vuid::count_11643,
        || format!("{at}.{member}"),
        || format!("the counts sum to {total}, more than maxMicromapTriangles = {max_triangles}"),
    );
    for (k, usage) in scan.entries {
        let loc = at.member(member).index(k);
        usage_rules(
            ctx,
            loc,
            usage.format,
            usage.subdivision_level,
            lossy,
            limits,
        );
    }
}

/// One `VkMicromapUsageKHR`'s format and subdivision level.
fn usage_rules(
    ctx: &mut Ctx<'_>,
    loc: impl Display + Copy,
    format: u32,
    level: u32,
    lossy: bool,
    limits: &Limits,
) {
    let two_state = format == OPACITY_MICROMAP_FORMAT_2_STATE;
    let four_state = format == OPACITY_MICROMAP_FORMAT_4_STATE;
    ctx.require(
        two_state || four_state,
        usage_vuid::format_parameter,
        || format!("{loc}.format"),
        || format!("{format} is not a VkOpacityMicromapFormatKHR value"),
    );
    ctx.require(
        !lossy || four_state,
        info_vuid::format_11712,
        || format!("{loc}.format"),
        || {
            format!(
                "{} is not VK_OPACITY_MICROMAP_FORMAT_4_STATE_KHR, in a MICROMAP_LOSSY build",
                FormatKind::OpacityKhr.name(format)
            )
        },
    );
    let max2 = limits.max_opacity2_state_subdivision_level;
    ctx.require(
        !two_state || level <= max2,
        micromap_vuid::subdivisionLevel_11645,
        || format!("{loc}.subdivisionLevel"),
        || format!("{level} exceeds maxOpacity2StateSubdivisionLevel = {max2}"),
    );
    if lossy {
        let max = limits.max_opacity_lossy4_state_subdivision_level;
        ctx.require(
            level <= max,
            info_vuid::subdivisionLevel_11565,
            || format!("{loc}.subdivisionLevel"),
            || format!("{level} exceeds maxOpacityLossy4StateSubdivisionLevel = {max}"),
        );
    } else {
        let max4 = limits.max_opacity4_state_subdivision_level;
        ctx.require(
            !four_state || level <= max4,
            info_vuid::subdivisionLevel_11564,
            || format!("{loc}.subdivisionLevel"),
            || format!("{level} exceeds maxOpacity4StateSubdivisionLevel = {max4}"),
        );
    }
}

/// `VkAccelerationStructureGeometryMicromapDataKHR`'s usage-count pointers
/// (11642).
const USAGE_POINTERS: PointerVuids = PointerVuids {
    one_of: micromap_vuid::pUsageCounts_11642,
    array: micromap_vuid::pUsageCounts_parameter,
    pointers: micromap_vuid::ppUsageCounts_parameter,
};

/// A micromap geometry's input memory: its addresses (device builds) and,
/// when the checker can read it, its triangle array.
fn micromap_inputs(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: MicromapAt,
    info: &BuildGeometryInfo,
    data: &GeometryMicromapData,
) {
    if command == BuildCommand::Cmd {
        for (address, member) in [
            (data.data, ".data"),
            (data.triangle_array, ".triangleArray"),
        ] {
            // Written out only for a finding.
            common::valid_device_address(
                ctx,
                address,
                cmd::micromap_11550,
                format_args!("{at}{member}"),
            );
            common::device_address_usage(
                ctx,
                address,
                BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
                "VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR",
                cmd::micromap_11551,
                format_args!("{at}{member}"),
            );
            common::aligned(
                ctx,
                address,
                MICROMAP_INPUT_ALIGNMENT,
                cmd::micromap_11552,
                format_args!("{at}{member}"),
            );
        }
        triangle_array_in_buffer(ctx, at, data);
    } else {
        common::triangle_array_holds_every_entry(
            ctx,
            format_args!("{at}.triangleArray"),
            (data.triangle_array, command.reads_host_memory()),
            data.triangle_array_stride,
            &data.usage_counts,
            FormatKind::OpacityKhr,
        );
    }
    TriangleArrayCheck {
        command,
        at,
        lossy: info.flags & BUILD_MICROMAP_LOSSY != 0,
        limits: ctx.device.limits.clone(),
    }
    .run(ctx, data);
}

/// 11554: `[triangleArray, triangleArray + stride * Σcount)` inside the
/// buffer `triangleArray` lies in (addresses inside no buffer are 11550's;
/// with no buffer address known, 11554 is reported not checked).
fn triangle_array_in_buffer(ctx: &mut Ctx<'_>, at: MicromapAt, data: &GeometryMicromapData) {
    let start = data.triangle_array;
    let Some(state) = ctx.state else {
        return;
    };
    let total = data.usage_counts.total();
    if total == 0 {
        return;
    }
    if state.buffers_at(start).next().is_none() {
        let rules = [cmd::micromap_11554.into()];
        common::unreadable(
            ctx,
            false,
            start,
            &rules,
            format_args!("{at}.triangleArray"),
        );
        return;
    }
    let len = u128::from(total) * u128::from(data.triangle_array_stride);
    let fits = u64::try_from(len).is_ok_and(|len| state.range_in_one_buffer(start, len));
    ctx.require(
        fits,
        cmd::micromap_11554,
        || format!("{at}.triangleArray"),
        || {
            let available = bytes_available(state, None, start).unwrap_or(0);
            let inside = readable_entries(available, data.triangle_array_stride).min(total);
            format!(
                "{} at stride {} ({len} bytes from {start:#x}) {} past the end of the buffer it lies in, {available} bytes from there ({} inside: {})",
                count_of(total, "entry", "entries"),
                data.triangle_array_stride,
                if total == 1 { "runs" } else { "run" },
                count_of(inside, "whole entry", "whole entries"),
                common::last_inside("entry", inside)
            )
        },
    );
}

/// The memory holding `address`, shared, and the offset of `address` in
/// it: in `host` memory where given, else in the tracked buffers.
fn contents_from(
    state: &State,
    host: Option<HostMemory<'_>>,
    address: u64,
) -> Option<(Bytes, usize)> {
    match host {
        Some(host) => host.contents_from(address),
        None => state.device_contents_from(address),
    }
}

/// The bytes from `address` to the end of the memory holding it, in `host`
/// memory where given, else in the tracked buffers.
fn bytes_from<'a>(
    state: &'a State,
    host: Option<HostMemory<'a>>,
    address: u64,
) -> Option<&'a [u8]> {
    match host {
        Some(host) => host.bytes_from(address),
        None => state.device_bytes_from(address),
    }
}

/// The triangle array's entries of one micromap geometry, read through the
/// tracked memory: formats and levels against the limits (11555, 11556,
/// 11566, 11567, 11713), each triangle's data inside the buffer (11553),
/// and the usage counts against the entries.
struct TriangleArrayCheck {
    command: BuildCommand,
    /// The micromap structure's location.
    at: MicromapAt,
    lossy: bool,
    limits: Limits,
}

impl TriangleArrayCheck {
    fn run(&self, ctx: &mut Ctx<'_>, data: &GeometryMicromapData) {
        // The bytes borrow the tracked state, not the context, so findings
        // can be reported while reading. Below the content tier nothing is read.
        let Some(state) = ctx.contents() else {
            return;
        };
        let total = data.usage_counts.total();
        let stride = data.triangle_array_stride;
        // A stride that breaks 11646/11647 is reported there; its entries
        // overlap, so reading them would only repeat that finding.
        if total == 0 || stride < MicromapTriangle::SIZE || !stride.is_multiple_of(4) {
            return;
        }
        let host = ctx.host().filter(|_| self.command.reads_host_memory());
        let data_available = bytes_available(state, host, data.data);
        let data_rule: RuleId = if self.command == BuildCommand::Cmd {
            cmd::micromap_11553.into()
        } else {
            (&rules::TRIANGLE_DATA_RANGE).into()
        };
        let entry_rules = self.entry_rules();
        let Some(array) = bytes_from(state, host, data.triangle_array) else {
            let mut skipped = entry_rules;
            skipped.push(data_rule);
            common::unreadable(
                ctx,
                host.is_some(),
                data.triangle_array,
                &skipped,
                format_args!("{}.triangleArray", self.at),
            );
            return;
        };
        ctx.checked(&entry_rules);
        if data_available.is_some() {
            ctx.checked(&[data_rule]);
        } else {
            common::unreadable(
                ctx,
                host.is_some(),
                data.data,
                &[data_rule],
                format_args!("{}.data", self.at),
            );
        }
        let mut tally = Tally::new();
        let mut histogram = TriangleHistogram::new();
        let mut read = 0u64;
        // The run of the last entry without a finding, in a tightly packed
        // array; blocks that leave it go one by one to their end.
        let mut run: Option<CleanRun> = None;
        let mut one_by_one_until = 0u64;
        let mut next = 0u64;
        // The loop ends at the end of `array`: each step advances >= 8 bytes.
        while next < total {
            if let Some(clean) = run.filter(|_| next >= one_by_one_until) {
                let clean_entries;
                (clean_entries, one_by_one_until) = clean.count(&mut histogram, array, next, total);
                read += clean_entries;
                next += clean_entries;
                if next >= total {
                    break;
                }
            }
            let m = next;
            next += 1;
            let entry = m
                .checked_mul(stride)
                .and_then(|offset| usize::try_from(offset).ok())
                .and_then(|offset| array.get(offset..offset.checked_add(8)?));
            let Some(bytes) = entry.and_then(|b| <[u8; 8]>::try_from(b).ok()) else {
                // The rest is past the end of the memory (11554 or our rule
                // says so from the buffer's size) or was not given to the checker.
                break;
            };
            read += 1;
            let triangle = MicromapTriangle::from_bytes(bytes);
            let (format, level) = (
                u32::from(triangle.format),
                u32::from(triangle.subdivision_level),
            );
            histogram.add(format, level, 1);
            let findings_before = (ctx.report.findings.len(), tally.failures());
            self.triangle_rules(ctx, &mut tally, m, format, level);
            if let Some(available) = data_available {
                self.data_in_range(ctx, &mut tally, m, &triangle, available);
            }
            if stride == MicromapTriangle::SIZE
                && findings_before == (ctx.report.findings.len(), tally.failures())
            {
                // data_in_range checks the range where the data has a size.
                let range = data_available
                    .zip(opacity_triangle_bytes(format, level))
                    .map(|(available, size)| (size, available));
                run = CleanRun::after(&triangle, range);
            }
        }
        tally.finish(ctx);
        // Information about the data itself, where the checker can read it
        // and the tier asks for it (blocks with a bad format or range are
        // skipped there).
        if ctx.hygiene {
            // The entries read, as a view of the array's bytes.
            let entries = contents_from(state, host, data.triangle_array)
                .and_then(|(memory, start)| TriangleEntries::shared(memory, start, stride, read));
            if let (Some(data_bytes), Some(entries)) = (bytes_from(state, host, data.data), entries)
            {
                hygiene::opacity_blocks(ctx, &self.at.to_string(), data_bytes, &entries);
            }
        }
        if read == total {
            usage_counts_match_triangles(
                ctx,
                &format!("{}.{}", self.at, data.usage_counts.member()),
                &data.usage_counts,
                &histogram.into_map(),
                FormatKind::OpacityKhr,
            );
        }
    }

    /// The rules that read the entries (formats, levels, the array's extent,
    /// the usage counts against them), as [`Self::triangle_rules`] applies them.
    fn entry_rules(&self) -> Vec<RuleId> {
        let mut read: Vec<RuleId> = Vec::new();
        if self.command == BuildCommand::Cmd {
            read.extend([
                RuleId::from(cmd::micromap_11555),
                cmd::micromap_11556.into(),
            ]);
        } else {
            read.push((&rules::TRIANGLE_ARRAY_RANGE).into());
        }
        if self.lossy {
            read.extend([
                RuleId::from(info_vuid::format_11713),
                info_vuid::subdivisionLevel_11567.into(),
            ]);
        } else {
            read.push(info_vuid::subdivisionLevel_11566.into());
        }
        read.push((&rules::HISTOGRAM_MISMATCH).into());
        read
    }

    /// One entry's format and subdivision level.
    fn triangle_rules(
        &self,
        ctx: &mut Ctx<'_>,
        tally: &mut Tally,
        m: u64,
        format: u32,
        level: u32,
    ) {
        let device_command = self.command == BuildCommand::Cmd;
        let two_state = format == OPACITY_MICROMAP_FORMAT_2_STATE;
        let four_state = format == OPACITY_MICROMAP_FORMAT_4_STATE;
        let limits = &self.limits;
        // The location and message are written out only for a shown finding.
        let mut fail = |rule: Vuid, member: &'static str, message: &dyn Fn() -> String| {
            tally.error(
                ctx,
                rule,
                self.at.member("triangleArray").index(m).member(member),
                message,
                "triangleArray",
            );
        };
        if device_command && !two_state && !four_state {
            fail(cmd::micromap_11555, "format", &|| {
                format!("{format} is not a VkOpacityMicromapFormatKHR value")
            });
        }
        let max2 = limits.max_opacity2_state_subdivision_level;
        if device_command && two_state && level > max2 {
            fail(cmd::micromap_11556, "subdivisionLevel", &|| {
                format!("{level} exceeds maxOpacity2StateSubdivisionLevel = {max2}")
            });
        }
        if self.lossy {
            if !four_state {
                fail(info_vuid::format_11713, "format", &|| {
                    format!("{} is not VK_OPACITY_MICROMAP_FORMAT_4_STATE_KHR, in a MICROMAP_LOSSY build", FormatKind::OpacityKhr.name(format))
                });
            }
            let max = limits.max_opacity_lossy4_state_subdivision_level;
            if level > max {
                fail(
                    info_vuid::subdivisionLevel_11567,
                    "subdivisionLevel",
                    &|| format!("{level} exceeds maxOpacityLossy4StateSubdivisionLevel = {max}"),
                );
            }
        } else {
            let max4 = limits.max_opacity4_state_subdivision_level;
            if four_state && level > max4 {
                fail(
                    info_vuid::subdivisionLevel_11566,
                    "subdivisionLevel",
                    &|| format!("{level} exceeds maxOpacity4StateSubdivisionLevel = {max4}"),
                );
            }
        }
    }

    /// The entry's `[dataOffset, dataOffset + triangleSize)` inside the
    /// `available` bytes from `data`.
    fn data_in_range(
        &self,
        ctx: &mut Ctx<'_>,
        tally: &mut Tally,
        m: u64,
        triangle: &MicromapTriangle,
        available: u64,
    ) {
        let (format, level) = (
            u32::from(triangle.format),
            u32::from(triangle.subdivision_level),
        );
        let Some(size) = opacity_triangle_bytes(format, level) else {
            return; // An invalid format or level is reported by the format and level rules.
        };
        let start = u64::from(triangle.data_offset);
        if start.checked_add(size).is_some_and(|end| end <= available) {
            return;
        }
        let message = || {
            format!("[{start}, {start} + {size}) runs past the end of the memory data points into ({available} bytes from data)")
        };
        let location = self
            .at
            .member("triangleArray")
            .index(m)
            .member("dataOffset");
        if self.command == BuildCommand::Cmd {
            tally.error(ctx, cmd::micromap_11553, location, message, "triangleArray");
        } else {
            tally.error(
                ctx,
                &rules::TRIANGLE_DATA_RANGE,
                location,
                message,
                "triangleArray",
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Device;

    /// A create call's rules record nothing, its record reports nothing,
    /// and the two together are the whole call.
    #[test]
    fn creating_is_rules_then_record() {
        let faulty = AccelerationStructureCreateInfo {
            ty: ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            size: 256,
            ..Default::default()
        };
        let mut v = Validator::new(Device::default());
        let rules = v.create_acceleration_structure_rules(&faulty);
        assert_eq!(rules.ids(), [create_info::type_11600.id()]);
        assert!(v.state().acceleration_structures.is_empty());
        v.record_acceleration_structure_created(&faulty, 9);
        assert_eq!(v.state().acceleration_structures[&9].size, 256);
        let mut whole = Validator::new(Device::default());
        assert_eq!(whole.create_acceleration_structure(&faulty, 9), rules);
        assert_eq!(
            whole.state().acceleration_structures,
            v.state().acceleration_structures
        );

        let opacity = AccelerationStructureCreateInfo2 {
            ty: ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            size: 128,
            ..Default::default()
        };
        let rules = v.create_acceleration_structure2_rules(&opacity);
        assert!(!rules.is_empty(), "the micromap feature is off: {rules}");
        assert!(!v.state().acceleration_structures.contains_key(&10));
        v.record_acceleration_structure2_created(&opacity, 10);
        assert!(v.state().acceleration_structures[&10].created_with_2);
    }

    /// A host build's and a host deserialization's rules record nothing
    /// (run twice, they report the same), and their records alone make of
    /// the state what the whole calls do.
    #[test]
    fn host_builds_and_deserializations_are_rules_then_record() {
        let mut v = Validator::new(Device::default());
        let create = AccelerationStructureCreateInfo {
            ty: ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
            size: 256,
            ..Default::default()
        };
        v.create_acceleration_structure(&create, 9);
        let tracked = |v: &Validator| format!("{:?}", v.state());
        let infos = [BuildGeometryInfo {
            ty: ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
            dst_acceleration_structure: 9,
            ..Default::default()
        }];
        let ranges = [Some(Vec::new())];
        let before = tracked(&v);
        let rules = v.build_acceleration_structures_rules(&infos, &ranges, &[]);
        assert_eq!(tracked(&v), before);
        assert_eq!(
            v.build_acceleration_structures_rules(&infos, &ranges, &[]),
            rules
        );
        let mut whole = v.clone();
        assert_eq!(whole.build_acceleration_structures(&infos, &ranges), rules);
        v.record_acceleration_structures_built(&infos, &ranges, &[]);
        assert!(v.state().acceleration_structures[&9].built.is_some());
        assert_eq!(tracked(&v), tracked(&whole));

        let deserialize = CopyMemoryToAccelerationStructureInfo {
            dst: 9,
            ..Default::default()
        };
        let before = tracked(&v);
        let rules = v.copy_memory_to_acceleration_structure_rules(&deserialize, &[]);
        assert_eq!(tracked(&v), before);
        assert_eq!(
            whole.copy_memory_to_acceleration_structure(&deserialize),
            rules
        );
        v.record_copy_memory_to_acceleration_structure(&deserialize);
        assert!(v.state().acceleration_structures[&9].built.is_none());
        assert_eq!(tracked(&v), tracked(&whole));
    }
}
