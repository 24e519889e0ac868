//! The `Validator` entry points a layer calls for the micromap and
//! acceleration-structure commands that copy, serialize, query and size
//! (the builds are in [`super`] and [`super::accel`]), and for the indirect
//! build as a layer receives it. Each reads the ash structure behind a
//! pointer into the owned model and runs the check of the same name.
//!
//! The bounds of [`crate::raw`] hold: arrays up to [`MAX_ELEMENTS`]
//! elements, pNext chains walked as `chain` walks them. Device
//! addresses stay numbers; the host memory read here is a deserialization's
//! serialized header at its host address, for that call alone.

use ash::vk;
use ash::vk::Handle as _;

use super::accel::HostRead;
use super::generated::{
    copy_acceleration_structure_info, copy_acceleration_structure_to_memory_info,
    copy_memory_to_acceleration_structure_info, copy_memory_to_micromap_info, copy_micromap_info,
    copy_micromap_to_memory_info,
};
use super::{
    bounded_len, chain_s_types, micromap_build_info, read_array, MAX_ELEMENTS, MAX_HOST_BYTES,
};
use crate::model::accel::CopyMemoryToAccelerationStructureInfo;
use crate::model::micromap_objects::{
    CopyMemoryToMicromapInfo, MicromapBuildSizesInfo, MicromapList, MicromapVersionInfo,
};
use crate::model::CommandBuffer;
use crate::model::Handle;
use crate::report::{Finding, Report};
use crate::state::HostRange;
use crate::Validator;

/// The bytes of serialized micromap data that say its version: the driver
/// UUID and the compatibility data, 2 × `VK_UUID_SIZE`.
const MICROMAP_VERSION_SIZE: u64 = 32;

/// Reads the structure at `info` with `read`; None for NULL.
///
/// # Safety
/// A non-NULL `info` must point to a readable `T`.
unsafe fn optional<T, M>(info: *const T, read: impl FnOnce(&T) -> M) -> Option<M> {
    // SAFETY: forwarded from the caller.
    unsafe { info.as_ref() }.map(read)
}

/// Reads one command's info structure into the model; what it cannot
/// read goes to the findings.
type ReadInfo<T, M> = unsafe fn(&T, &'static str, &'static str, &mut Vec<Finding>) -> M;

/// Reads the info at `info` (None for NULL) with `read` and runs `check`
/// on the model; the reading's findings come first. `check` is given the
/// findings too, for what it reads itself (a deserialization's header).
///
/// # Safety
/// A non-NULL `info` must be valid as `read` requires.
unsafe fn read_then_check<T, M>(
    info: *const T,
    function: &'static str,
    read: ReadInfo<T, M>,
    check: impl FnOnce(Option<&M>, &mut Vec<Finding>) -> Report,
) -> Report {
    let mut findings = Vec::new();
    // SAFETY: forwarded from the caller.
    let model = unsafe { optional(info, |i| read(i, function, "pInfo", &mut findings)) };
    let report = check(model.as_ref(), &mut findings);
    with_findings(findings, report)
}

/// Reads `micromapCount` handles at `micromaps` (at most [`MAX_ELEMENTS`]).
///
/// # Safety
/// A non-NULL `micromaps` must point to `count` handles.
unsafe fn micromap_list(
    count: u32,
    micromaps: *const vk::MicromapEXT,
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> MicromapList {
    // SAFETY: forwarded from the caller.
    let handles = unsafe { read_array(micromaps, count, function, "pMicromaps", findings) };
    MicromapList {
        count,
        handles: handles.map(|list| list.into_iter().map(vk::Handle::as_raw).collect()),
    }
}

impl Validator {
    /// Checks `vkCmdCopyMicromapEXT(commandBuffer, pInfo)` as a layer receives it.
    ///
    /// # Safety
    /// A non-NULL `info` must point to a `VkCopyMicromapInfoEXT` with a
    /// well-formed pNext chain.
    pub unsafe fn cmd_copy_micromap_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyMicromapInfoEXT<'_>,
    ) -> Report {
        let function = "vkCmdCopyMicromapEXT";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(info, function, copy_micromap_info, |model, _| {
                self.cmd_copy_micromap(command_buffer, model)
            })
        }
    }

    /// Checks `vkCopyMicromapEXT(device, deferredOperation, pInfo)`.
    ///
    /// # Safety
    /// As [`Self::cmd_copy_micromap_raw`].
    pub unsafe fn copy_micromap_raw(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info: *const vk::CopyMicromapInfoEXT<'_>,
    ) -> Report {
        let (device, deferred) = (device.as_raw(), deferred_operation.as_raw());
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(info, "vkCopyMicromapEXT", copy_micromap_info, |model, _| {
                self.copy_micromap(device, deferred, model)
            })
        }
    }

    /// Checks `vkCmdCopyMicromapToMemoryEXT(commandBuffer, pInfo)`.
    ///
    /// # Safety
    /// A non-NULL `info` must point to a `VkCopyMicromapToMemoryInfoEXT`
    /// with a well-formed pNext chain.
    pub unsafe fn cmd_copy_micromap_to_memory_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyMicromapToMemoryInfoEXT<'_>,
    ) -> Report {
        let function = "vkCmdCopyMicromapToMemoryEXT";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(info, function, copy_micromap_to_memory_info, |model, _| {
                self.cmd_copy_micromap_to_memory(command_buffer, model)
            })
        }
    }

    /// Checks `vkCopyMicromapToMemoryEXT(device, deferredOperation, pInfo)`.
    ///
    /// # Safety
    /// As [`Self::cmd_copy_micromap_to_memory_raw`].
    pub unsafe fn copy_micromap_to_memory_raw(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info: *const vk::CopyMicromapToMemoryInfoEXT<'_>,
    ) -> Report {
        let (device, deferred) = (device.as_raw(), deferred_operation.as_raw());
        let function = "vkCopyMicromapToMemoryEXT";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(info, function, copy_micromap_to_memory_info, |model, _| {
                self.copy_micromap_to_memory(device, deferred, model)
            })
        }
    }

    /// Checks `vkCmdCopyMemoryToMicromapEXT(commandBuffer, pInfo)`.
    ///
    /// # Safety
    /// A non-NULL `info` must point to a `VkCopyMemoryToMicromapInfoEXT`
    /// with a well-formed pNext chain.
    pub unsafe fn cmd_copy_memory_to_micromap_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyMemoryToMicromapInfoEXT<'_>,
    ) -> Report {
        let function = "vkCmdCopyMemoryToMicromapEXT";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(info, function, copy_memory_to_micromap_info, |model, _| {
                self.cmd_copy_memory_to_micromap(command_buffer, model)
            })
        }
    }

    /// Checks `vkCopyMemoryToMicromapEXT(device, deferredOperation, pInfo)`:
    /// the serialized data's version, its first `MICROMAP_VERSION_SIZE`
    /// bytes at `pInfo->src.hostAddress`, is read for this call.
    ///
    /// # Safety
    /// As [`Self::cmd_copy_memory_to_micromap_raw`], and a non-NULL
    /// `src.hostAddress` must point to serialized micromap data as the API
    /// requires, whose header is at least `MICROMAP_VERSION_SIZE`
    /// readable bytes.
    pub unsafe fn copy_memory_to_micromap_raw(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info: *const vk::CopyMemoryToMicromapInfoEXT<'_>,
    ) -> Report {
        let (device, deferred) = (device.as_raw(), deferred_operation.as_raw());
        let function = "vkCopyMemoryToMicromapEXT";
        let check = |model: Option<&CopyMemoryToMicromapInfo>, findings: &mut Vec<Finding>| {
            let read = model.map(|m| HostRead {
                address: m.src,
                extent: Some(MICROMAP_VERSION_SIZE),
                location: "pInfo->src.hostAddress".into(),
            });
            // SAFETY: the caller guarantees the version bytes are readable.
            unsafe {
                self.with_host_read(read, function, findings, |v, read_for_call| {
                    let report =
                        v.copy_memory_to_micromap_rules(device, deferred, model, read_for_call);
                    v.record_copy_memory_to_micromap(deferred, model);
                    report
                })
            }
        };
        // SAFETY: forwarded from the caller.
        unsafe { read_then_check(info, function, copy_memory_to_micromap_info, check) }
    }

    /// Runs `check` with `read` (where given) read as host memory for this
    /// call alone, handed to it beside the state, which never keeps it.
    ///
    /// # Safety
    /// As [`Self::read_host_range`] for `read`.
    unsafe fn with_host_read(
        &mut self,
        read: Option<HostRead>,
        function: &'static str,
        findings: &mut Vec<Finding>,
        check: impl FnOnce(&mut Self, &[HostRange]) -> Report,
    ) -> Report {
        let mut read_for_call = Vec::new();
        if let Some(read) = read {
            // SAFETY: forwarded from the caller.
            unsafe { self.read_host_range(&read, function, findings, &mut read_for_call) };
        }
        check(self, &read_for_call)
    }

    /// Checks `vkCmdWriteMicromapsPropertiesEXT(commandBuffer,
    /// micromapCount, pMicromaps, queryType, queryPool, firstQuery)`.
    ///
    /// # Safety
    /// A non-NULL `micromaps` must point to `micromap_count` handles.
    pub unsafe fn cmd_write_micromaps_properties_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        micromap_count: u32,
        micromaps: *const vk::MicromapEXT,
        query_type: vk::QueryType,
        query_pool: vk::QueryPool,
        first_query: u32,
    ) -> Report {
        let mut findings = Vec::new();
        let function = "vkCmdWriteMicromapsPropertiesEXT";
        // SAFETY: forwarded from the caller.
        let list = unsafe { micromap_list(micromap_count, micromaps, function, &mut findings) };
        let report = self.cmd_write_micromaps_properties(
            command_buffer,
            &list,
            query_type.as_raw(),
            vk::Handle::as_raw(query_pool),
            first_query,
        );
        with_findings(findings, report)
    }

    /// Checks `vkWriteMicromapsPropertiesEXT(device, micromapCount,
    /// pMicromaps, queryType, dataSize, pData, stride)`; `pData` is only
    /// looked at as an address, never written or read.
    ///
    /// # Safety
    /// A non-NULL `micromaps` must point to `micromap_count` handles.
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn write_micromaps_properties_raw(
        &mut self,
        device: vk::Device,
        micromap_count: u32,
        micromaps: *const vk::MicromapEXT,
        query_type: vk::QueryType,
        data_size: usize,
        data: *const std::ffi::c_void,
        stride: usize,
    ) -> Report {
        let mut findings = Vec::new();
        let function = "vkWriteMicromapsPropertiesEXT";
        // SAFETY: forwarded from the caller.
        let list = unsafe { micromap_list(micromap_count, micromaps, function, &mut findings) };
        let report = self.write_micromaps_properties(
            vk::Handle::as_raw(device),
            &list,
            query_type.as_raw(),
            data_size as u64,
            data.addr() as u64,
            stride as u64,
        );
        with_findings(findings, report)
    }

    /// Checks `vkGetMicromapBuildSizesEXT(device, buildType, pBuildInfo,
    /// pSizeInfo)`; the command ignores the build's addresses and contents.
    ///
    /// # Safety
    /// A non-NULL `build_info` must be valid as for
    /// [`super::micromap_build_info`], a non-NULL `size_info` must point to a
    /// `VkMicromapBuildSizesInfoEXT` with a well-formed pNext chain.
    pub unsafe fn get_micromap_build_sizes_raw(
        &mut self,
        device: vk::Device,
        build_type: vk::AccelerationStructureBuildTypeKHR,
        build_info: *const vk::MicromapBuildInfoEXT<'_>,
        size_info: *const vk::MicromapBuildSizesInfoEXT<'_>,
    ) -> Report {
        let mut findings = Vec::new();
        let function = "vkGetMicromapBuildSizesEXT";
        // SAFETY: forwarded from the caller.
        let build = unsafe {
            optional(build_info, |i| {
                micromap_build_info(i, function, "pBuildInfo", &mut findings)
            })
        };
        // SAFETY: forwarded from the caller.
        let sizes = unsafe {
            optional(size_info, |i| MicromapBuildSizesInfo {
                s_type: i.s_type.as_raw(),
                // SAFETY: forwarded from the caller.
                next: chain_s_types(i.p_next, function, "pSizeInfo", &mut findings),
            })
        };
        let report = self.get_micromap_build_sizes(
            vk::Handle::as_raw(device),
            build_type.as_raw(),
            build.as_ref(),
            sizes.as_ref(),
        );
        with_findings(findings, report)
    }

    /// Checks `vkGetDeviceMicromapCompatibilityEXT(device, pVersionInfo,
    /// pCompatibility)`: `2 × VK_UUID_SIZE` bytes of `pVersionData` are read,
    /// the length the API gives it.
    ///
    /// # Safety
    /// A non-NULL `version_info` must point to a `VkMicromapVersionInfoEXT`
    /// with a well-formed pNext chain and a `pVersionData` NULL or readable
    /// for `2 × VK_UUID_SIZE` bytes.
    pub unsafe fn get_device_micromap_compatibility_raw(
        &mut self,
        device: vk::Device,
        version_info: *const vk::MicromapVersionInfoEXT<'_>,
        compatibility: *const vk::AccelerationStructureCompatibilityKHR,
    ) -> Report {
        let mut findings = Vec::new();
        let function = "vkGetDeviceMicromapCompatibilityEXT";
        // SAFETY: forwarded from the caller.
        let version = unsafe {
            optional(version_info, |i| MicromapVersionInfo {
                s_type: i.s_type.as_raw(),
                // SAFETY: forwarded from the caller.
                next: chain_s_types(i.p_next, function, "pVersionInfo", &mut findings),
                // SAFETY: the API defines pVersionData as 2 × VK_UUID_SIZE bytes.
                version_data: i.p_version_data.as_ref().map(|bytes| bytes.to_vec()),
            })
        };
        let report = self.get_device_micromap_compatibility(
            vk::Handle::as_raw(device),
            version.as_ref(),
            !compatibility.is_null(),
        );
        with_findings(findings, report)
    }

    /// Tracks the query pool `vkCreateQueryPool` returned (its type and
    /// count decide the micromap query rules).
    ///
    /// # Safety
    /// `info` must point to a `VkQueryPoolCreateInfo` (or be NULL).
    pub unsafe fn record_query_pool_raw(
        &mut self,
        info: *const vk::QueryPoolCreateInfo<'_>,
        query_pool: vk::QueryPool,
    ) {
        // SAFETY: forwarded from the caller.
        if let Some(info) = unsafe { info.as_ref() } {
            self.create_query_pool_from(info, query_pool);
        }
    }

    /// Forgets a query pool `vkDestroyQueryPool` destroyed.
    pub fn forget_query_pool(&mut self, query_pool: Handle) {
        self.state.query_pools.remove(&query_pool);
        self.state.execution.forget_query_pool(query_pool);
    }

    /// Checks `vkCmdCopyAccelerationStructureKHR(commandBuffer, pInfo)`; a
    /// NULL `pInfo` is not checked (no micromap rule concerns it).
    ///
    /// # Safety
    /// A non-NULL `info` must point to a `VkCopyAccelerationStructureInfoKHR`
    /// with a well-formed pNext chain.
    pub unsafe fn cmd_copy_acceleration_structure_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyAccelerationStructureInfoKHR<'_>,
    ) -> Report {
        let function = "vkCmdCopyAccelerationStructureKHR";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_acceleration_structure_info,
                |model, _| {
                    unchecked_if_none(model, |m| {
                        self.cmd_copy_acceleration_structure(command_buffer, m)
                    })
                },
            )
        }
    }

    /// Checks `vkCopyAccelerationStructureKHR(device, deferredOperation, pInfo)`.
    ///
    /// # Safety
    /// As [`Self::cmd_copy_acceleration_structure_raw`].
    pub unsafe fn copy_acceleration_structure_raw(
        &mut self,
        info: *const vk::CopyAccelerationStructureInfoKHR<'_>,
    ) -> Report {
        let function = "vkCopyAccelerationStructureKHR";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_acceleration_structure_info,
                |model, _| unchecked_if_none(model, |m| self.copy_acceleration_structure(m)),
            )
        }
    }

    /// Checks `vkCmdCopyAccelerationStructureToMemoryKHR(commandBuffer, pInfo)`.
    ///
    /// # Safety
    /// A non-NULL `info` must point to a
    /// `VkCopyAccelerationStructureToMemoryInfoKHR` with a well-formed pNext chain.
    pub unsafe fn cmd_copy_acceleration_structure_to_memory_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyAccelerationStructureToMemoryInfoKHR<'_>,
    ) -> Report {
        let function = "vkCmdCopyAccelerationStructureToMemoryKHR";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_acceleration_structure_to_memory_info,
                |model, _| {
                    unchecked_if_none(model, |m| {
                        self.cmd_copy_acceleration_structure_to_memory(command_buffer, m)
                    })
                },
            )
        }
    }

    /// Checks `vkCopyAccelerationStructureToMemoryKHR(device,
    /// deferredOperation, pInfo)`.
    ///
    /// # Safety
    /// As [`Self::cmd_copy_acceleration_structure_to_memory_raw`].
    pub unsafe fn copy_acceleration_structure_to_memory_raw(
        &mut self,
        info: *const vk::CopyAccelerationStructureToMemoryInfoKHR<'_>,
    ) -> Report {
        let function = "vkCopyAccelerationStructureToMemoryKHR";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_acceleration_structure_to_memory_info,
                |model, _| {
                    unchecked_if_none(model, |m| self.copy_acceleration_structure_to_memory(m))
                },
            )
        }
    }

    /// Checks `vkCmdCopyMemoryToAccelerationStructureKHR(commandBuffer, pInfo)`.
    ///
    /// # Safety
    /// A non-NULL `info` must point to a
    /// `VkCopyMemoryToAccelerationStructureInfoKHR` with a well-formed pNext chain.
    pub unsafe fn cmd_copy_memory_to_acceleration_structure_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info: *const vk::CopyMemoryToAccelerationStructureInfoKHR<'_>,
    ) -> Report {
        let function = "vkCmdCopyMemoryToAccelerationStructureKHR";
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_memory_to_acceleration_structure_info,
                |model, _| {
                    unchecked_if_none(model, |m| {
                        self.cmd_copy_memory_to_acceleration_structure(command_buffer, m)
                    })
                },
            )
        }
    }

    /// Checks `vkCopyMemoryToAccelerationStructureKHR(device,
    /// deferredOperation, pInfo)`: the serialized header at
    /// `pInfo->src.hostAddress` is read as far as its blocks reach, within
    /// the serialized size it states and at most [`MAX_HOST_BYTES`].
    ///
    /// # Safety
    /// A non-NULL `info` must point to a
    /// `VkCopyMemoryToAccelerationStructureInfoKHR` with a well-formed pNext
    /// chain whose non-NULL `src.hostAddress` points to serialized data as
    /// the API requires: a header of at least 56 bytes, readable for the
    /// serialized size the header states.
    pub unsafe fn copy_memory_to_acceleration_structure_raw(
        &mut self,
        info: *const vk::CopyMemoryToAccelerationStructureInfoKHR<'_>,
    ) -> Report {
        let function = "vkCopyMemoryToAccelerationStructureKHR";
        let check = |model: Option<&CopyMemoryToAccelerationStructureInfo>,
                     findings: &mut Vec<Finding>| {
            let Some(model) = model else {
                return Report::default();
            };
            let read = usize::try_from(model.src)
                .ok()
                .filter(|&src| src != 0)
                .map(|src| HostRead {
                    address: model.src,
                    // SAFETY: forwarded from the caller.
                    extent: Some(unsafe { serialized_header_extent(src) }),
                    location: "pInfo->src.hostAddress".into(),
                });
            // SAFETY: the caller guarantees the header is readable for the
            // extent, which lies within the size it states.
            unsafe {
                self.with_host_read(read, function, findings, |v, read_for_call| {
                    let report =
                        v.copy_memory_to_acceleration_structure_rules(model, read_for_call);
                    v.record_copy_memory_to_acceleration_structure(model);
                    report
                })
            }
        };
        // SAFETY: forwarded from the caller.
        unsafe {
            read_then_check(
                info,
                function,
                copy_memory_to_acceleration_structure_info,
                check,
            )
        }
    }

    /// Checks `vkCmdBuildAccelerationStructuresIndirectKHR(commandBuffer,
    /// infoCount, pInfos, pIndirectDeviceAddresses, pIndirectStrides,
    /// ppMaxPrimitiveCounts)` as a layer receives it: at most
    /// [`MAX_ELEMENTS`] infos; `ppMaxPrimitiveCounts[i]` is read for
    /// `pInfos[i].geometryCount` counts (at most [`MAX_ELEMENTS`]).
    ///
    /// # Safety
    /// Non-NULL arrays must be valid for `info_count` elements, each info
    /// valid as for [`super::accel::build_geometry_info`] and each non-NULL
    /// `ppMaxPrimitiveCounts[i]` for `pInfos[i].geometryCount` counts.
    pub unsafe fn cmd_build_acceleration_structures_indirect_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        indirect_device_addresses: *const vk::DeviceAddress,
        indirect_strides: *const u32,
        max_primitive_counts: *const *const u32,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        unsafe {
            self.cmd_build_acceleration_structures_indirect_raw_kept(
                command_buffer,
                info_count,
                infos,
                indirect_device_addresses,
                indirect_strides,
                max_primitive_counts,
            )
        }
        .0
    }

    /// As [`Self::cmd_build_acceleration_structures_indirect_raw`], and the
    /// build as read (see
    /// [`Self::cmd_build_acceleration_structures_indirect_ash_kept`]).
    ///
    /// # Safety
    /// As [`Self::cmd_build_acceleration_structures_indirect_raw`].
    pub unsafe fn cmd_build_acceleration_structures_indirect_raw_kept(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        indirect_device_addresses: *const vk::DeviceAddress,
        indirect_strides: *const u32,
        max_primitive_counts: *const *const u32,
    ) -> (Report, crate::build_inputs::DeviceBuild) {
        let function = "vkCmdBuildAccelerationStructuresIndirectKHR";
        let mut findings = Vec::new();
        let len = bounded_len(info_count, function, "pInfos", &mut findings);
        /// `len` elements at a non-NULL `pointer`, else none.
        ///
        /// # Safety
        /// A non-NULL `pointer` must be valid for `len` elements.
        unsafe fn slice<'a, T>(pointer: *const T, len: usize) -> &'a [T] {
            if pointer.is_null() {
                &[]
            } else {
                // SAFETY: forwarded from the caller.
                unsafe { std::slice::from_raw_parts(pointer, len) }
            }
        }
        // SAFETY: the caller guarantees `info_count` elements; `len <= info_count`.
        let (infos, addresses, strides, count_pointers) = unsafe {
            (
                slice(infos, len),
                slice(indirect_device_addresses, len),
                slice(indirect_strides, len),
                slice(max_primitive_counts, len),
            )
        };
        let max_counts: Vec<&[u32]> = count_pointers
            .iter()
            .zip(infos)
            .map(|(&counts, info)| {
                let n = (info.geometry_count as usize).min(MAX_ELEMENTS);
                // SAFETY: the caller guarantees geometryCount counts at a
                // non-NULL pointer; `n` is at most that.
                unsafe { slice(counts, n) }
            })
            .collect();
        // SAFETY: forwarded from the caller.
        let (report, build) = unsafe {
            self.cmd_build_acceleration_structures_indirect_ash_kept(
                command_buffer,
                infos,
                addresses,
                strides,
                &max_counts,
            )
        };
        (with_findings(findings, report), build)
    }
}

/// `check` of a model that was read; nothing for a NULL info (no micromap
/// rule concerns these commands' NULL `pInfo`).
fn unchecked_if_none<M>(model: Option<&M>, check: impl FnOnce(&M) -> Report) -> Report {
    model.map_or_else(Report::default, check)
}

/// The reader's findings first, then the check's.
fn with_findings(findings: Vec<Finding>, report: Report) -> Report {
    let mut out = Report::from(findings);
    out.extend(report);
    out
}

/// The bytes of the serialized header at host address `src` that the
/// checks read: the 56 bytes every header has, and for a block-based
/// (bottom-level) header its blocks, as far as they lie inside the
/// serialized size the header states (offset 32) and [`MAX_HOST_BYTES`].
///
/// # Safety
/// `src` must point to serialized acceleration-structure data: at least 56
/// readable bytes, and readable for the serialized size the header states.
unsafe fn serialized_header_extent(src: usize) -> u64 {
    const FIXED: u64 = 56;
    let base = std::ptr::with_exposed_provenance::<u8>(src);
    // SAFETY: only called with `offset + 8` within the readable bytes.
    let word = |offset: u64| unsafe { base.add(offset as usize).cast::<u64>().read_unaligned() };
    let bound = word(32).clamp(FIXED, MAX_HOST_BYTES);
    let packed = word(48);
    if packed >> 32 != 0xFFFF_FFFF {
        return FIXED;
    }
    let mut at = FIXED;
    for _ in 0..(packed & 0xFFFF_FFFF) {
        let Some(header_end) = at.checked_add(16).filter(|end| *end <= bound) else {
            return at;
        };
        let addresses = word(at + 8);
        match addresses
            .checked_mul(8)
            .and_then(|n| header_end.checked_add(n))
            .filter(|end| *end <= bound)
        {
            Some(end) => at = end,
            None => return bound,
        }
    }
    at
}

#[cfg(test)]
mod tests {
    use super::serialized_header_extent;
    use crate::{Device, Profile, Validator};
    use ash::vk;
    use ommcheck_vuids::vuid::VkCopyMemoryToMicromapInfoEXT as from_memory_info;

    /// Deserializes, on the host, 40 bytes whose first 32 (the version) are
    /// `version`, after the driver answered incompatible for `[1; 32]`;
    /// whether 07549 was reported, and whether the bytes were forgotten.
    fn host_deserialization(version: u8) -> (bool, bool) {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        v.set_micromap_compatibility(
            &[1; 32],
            vk::AccelerationStructureCompatibilityKHR::INCOMPATIBLE,
        );
        let data = [version; 40];
        let info = vk::CopyMemoryToMicromapInfoEXT {
            src: vk::DeviceOrHostAddressConstKHR {
                host_address: data.as_ptr().cast(),
            },
            mode: vk::CopyMicromapModeEXT::DESERIALIZE,
            ..Default::default()
        };
        // SAFETY: a valid info whose source holds more than the 32 version bytes.
        let report = unsafe {
            v.copy_memory_to_micromap_raw(
                vk::Device::null(),
                vk::DeferredOperationKHR::null(),
                &info,
            )
        };
        let reported = report.contains(from_memory_info::src_07549);
        (reported, v.state().host_memory.is_empty())
    }

    #[test]
    fn a_host_deserialization_reads_the_version_for_that_call() {
        assert_eq!(host_deserialization(1), (true, true));
        assert_eq!(host_deserialization(2), (false, true));
    }

    /// A header stating `size` bytes, block-based with `blocks` blocks, the
    /// first holding `addresses` addresses (of which `present` are written).
    fn header(size: u64, blocks: u32, addresses: u64, present: usize) -> Vec<u8> {
        let mut bytes = vec![0u8; 72 + 8 * present];
        bytes[32..40].copy_from_slice(&size.to_le_bytes());
        bytes[48..56].copy_from_slice(&(0xFFFF_FFFF_0000_0000 | u64::from(blocks)).to_le_bytes());
        bytes[64..72].copy_from_slice(&addresses.to_le_bytes());
        bytes
    }

    fn extent(bytes: &[u8]) -> u64 {
        // SAFETY: every header here is readable for the size it states.
        unsafe { serialized_header_extent(bytes.as_ptr().expose_provenance()) }
    }

    #[test]
    fn the_header_extent_ends_after_the_last_block() {
        assert_eq!(extent(&header(88, 1, 2, 2)), 88);
        // Not block-based: only the fixed 56 bytes.
        let mut top_level = header(80, 1, 1, 1);
        top_level[52..56].copy_from_slice(&[0; 4]);
        assert_eq!(extent(&top_level), 56);
    }

    #[test]
    fn counts_past_the_stated_size_stop_at_it() {
        // One block claiming 2^61 addresses, and a second block past the
        // stated size: neither is read beyond the 80 bytes.
        assert_eq!(extent(&header(80, 2, 1 << 61, 1)), 80);
        // A stated size below the fixed part still reads the fixed part.
        let short = header(8, 0, 0, 0);
        assert_eq!(extent(&short), 56);
    }
}
