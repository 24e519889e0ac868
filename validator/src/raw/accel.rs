//! Reading `VkAccelerationStructureBuildGeometryInfoKHR` and the structures
//! it points to (geometries, their pNext chains, the triangles' opacity and
//! displacement attachments, build ranges, host instances) into the owned
//! model of [`crate::model::accel`], and the `Validator` entry points of the
//! KHR acceleration-structure commands that take ash structures.
//!
//! The same bounds as the rest of [`crate::raw`] hold: arrays are read up to
//! [`MAX_ELEMENTS`] elements (geometries up to [`MAX_GEOMETRIES`]), pNext chains up to [`MAX_CHAIN`](super::MAX_CHAIN) structures
//! with each address visited once, host memory up to [`MAX_HOST_BYTES`] per
//! array; what is cut is reported ([`rules::READ_BOUND`],
//! [`rules::PNEXT_CHAIN`]). Device addresses are numbers, never pointers:
//! only host commands (`vkBuildAccelerationStructuresKHR`) read memory at an
//! address, and only where the API itself describes the extent.

use ash::vk;
use ommcheck_vuids::khr;

use super::generated::acceleration_structure_create_info;
pub(crate) use super::generated::build_geometry_info;
use super::{bounded_len, chain_s_types, element_bound, read_array, MAX_ELEMENTS, MAX_HOST_BYTES};
use crate::build_inputs::indirect::IndirectRanges;
use crate::build_inputs::{geometry_reads, DeviceBuild, Extent, ReadKind};
use crate::model::accel::{
    AccelerationStructureCreateInfo, AccelerationStructureCreateInfo2, BuildGeometryInfo,
    BuildRangeInfo, Geometry, GeometryData, Instance, InstancesData,
    ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL,
};
use crate::model::CommandBuffer;
use crate::report::location::Locate;
use crate::report::{Finding, Report, Severity};
use crate::rules;
use crate::state::HostRange;
use crate::Validator;

const CMD_BUILD: &str = "vkCmdBuildAccelerationStructuresKHR";
const CMD_BUILD_INDIRECT: &str = "vkCmdBuildAccelerationStructuresIndirectKHR";
const HOST_BUILD: &str = "vkBuildAccelerationStructuresKHR";

/// `VK_BUILD_ACCELERATION_STRUCTURE_MOTION_BIT_NV`: the instances of such a
/// build are `VkAccelerationStructureMotionInstanceNV`, not read here.
const BUILD_MOTION_NV: u32 = vk::BuildAccelerationStructureFlagsKHR::MOTION_NV.as_raw();

/// The value of a `VkDeviceOrHostAddressConstKHR`: a device address for
/// device commands, a host pointer's address for host commands. The host
/// member's provenance is exposed as well, so a host command may turn the
/// number back into a pointer (`std::ptr::with_exposed_provenance`).
pub(crate) fn address(value: &vk::DeviceOrHostAddressConstKHR) -> u64 {
    // SAFETY: both members are plain data for which any initialised bits
    // are valid (a u64, and a pointer, here only exposed, never read
    // through); the union is 8 bytes on every target, so `device_address`
    // gives the whole value.
    let (number, pointer) = unsafe { (value.device_address, value.host_address) };
    let _ = pointer.expose_provenance();
    number
}

/// [`address`] for the mutable `VkDeviceOrHostAddressKHR`.
pub(crate) fn scratch_address(value: &vk::DeviceOrHostAddressKHR) -> u64 {
    // SAFETY: as in `address`.
    let (number, pointer) = unsafe { (value.device_address, value.host_address) };
    let _ = pointer.expose_provenance();
    number
}

/// The most geometries read from one build geometry info (and build ranges
/// from one `ppBuildRangeInfos` element). Tighter than [`MAX_ELEMENTS`]: each
/// geometry's model is some 600 bytes, and 2^16 geometries (more than any
/// real build holds) keep one info's model near 40 MB.
/// Small under cargo-fuzz, as [`MAX_ELEMENTS`] is.
pub const MAX_GEOMETRIES: u32 = if cfg!(fuzzing) { 1 << 6 } else { 1 << 16 };

/// Reads `pInfos` (at most [`MAX_ELEMENTS`] of them).
///
/// # Safety
/// As [`build_geometry_info`] for each element.
unsafe fn build_geometry_infos(
    infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> Vec<BuildGeometryInfo> {
    let count = u32::try_from(infos.len()).unwrap_or(u32::MAX);
    let len = bounded_len(count, function, "pInfos", findings);
    infos
        .iter()
        .take(len)
        .enumerate()
        // SAFETY: forwarded from the caller.
        .map(|(i, info)| unsafe {
            build_geometry_info(info, function, "pInfos".index(i), findings)
        })
        .collect()
}

/// Reads `ppBuildRangeInfos` for the first `count` infos: element `i` is
/// NULL (None; also when `pointers` is shorter) or points to
/// `infos[i].geometryCount` range infos (at most [`MAX_GEOMETRIES`]).
///
/// # Safety
/// Each non-NULL `pointers[i]` must be valid for `infos[i].geometryCount`
/// elements, as the API requires.
unsafe fn read_build_range_infos(
    infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
    count: usize,
    pointers: &[*const vk::AccelerationStructureBuildRangeInfoKHR],
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> Vec<Option<Vec<BuildRangeInfo>>> {
    infos
        .iter()
        .take(count)
        .enumerate()
        .map(|(i, info)| {
            let pointer = pointers.get(i).copied().unwrap_or(std::ptr::null());
            let location = "ppBuildRangeInfos".index(i);
            let count = if pointer.is_null() {
                info.geometry_count
            } else {
                let names = ["geometryCount", "geometries"];
                element_bound(
                    info.geometry_count,
                    MAX_GEOMETRIES,
                    names,
                    function,
                    location,
                    findings,
                )
            };
            // SAFETY: forwarded from the caller; at most geometryCount
            // elements are read.
            let ranges = unsafe { read_array(pointer, count, function, location, findings) };
            ranges.map(|list| {
                list.into_iter()
                    .map(|range| BuildRangeInfo::from_members(&range))
                    .collect()
            })
        })
        .collect()
}

/// One `VkAccelerationStructureInstanceKHR` in the model.
fn instance(raw: &vk::AccelerationStructureInstanceKHR) -> Instance {
    Instance {
        transform: raw.transform.matrix,
        instance_custom_index: raw.instance_custom_index_and_mask.low_24(),
        mask: raw.instance_custom_index_and_mask.high_8(),
        instance_shader_binding_table_record_offset: raw
            .instance_shader_binding_table_record_offset_and_flags
            .low_24(),
        flags: raw
            .instance_shader_binding_table_record_offset_and_flags
            .high_8(),
        // SAFETY: both members of the reference union (a device address
        // and a non-dispatchable handle) are 64-bit integers; any bits are
        // valid, and a handle's raw value is its bits.
        acceleration_structure_reference: unsafe {
            raw.acceleration_structure_reference.device_handle
        },
    }
}

/// Reads the instances of an instances geometry of a host build, as the
/// API consumes them: `range.primitiveCount` (at most [`MAX_ELEMENTS`])
/// `VkAccelerationStructureInstanceKHR` from the host address `data +
/// range.primitiveOffset`, or with `arrayOfPointers` that many host
/// pointers from there, each to one instance (a NULL element reads as a
/// default instance, which no rule looks at: mask 0, no flags, no
/// reference). A NULL `data`, or `data + primitiveOffset` past 2^64, is
/// not read (None).
///
/// # Safety
/// `data + range.primitiveOffset` must be a host address readable as the
/// API describes it for `range.primitiveCount` primitives.
unsafe fn host_instances(
    data: &InstancesData,
    range: &BuildRangeInfo,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> Option<Vec<Instance>> {
    if data.data == 0 {
        return None;
    }
    // The instances (or pointers) start primitiveOffset bytes after data;
    // the bytes before them need not be readable.
    let start = data.data.checked_add(u64::from(range.primitive_offset))?;
    let address = usize::try_from(start).ok()?;
    let count = range.primitive_count;
    let len = bounded_len(count, function, location, findings);
    let list = if data.array_of_pointers {
        let pointers = std::ptr::with_exposed_provenance::<
            *const vk::AccelerationStructureInstanceKHR,
        >(address);
        (0..len)
            .map(|k| {
                // SAFETY: the caller guarantees `count` readable pointers at
                // `data + primitiveOffset`, and `k < len <= count`; unaligned
                // reads tolerate a misaligned array.
                let pointer = unsafe { pointers.add(k).read_unaligned() };
                if pointer.is_null() {
                    return Instance::default();
                }
                // SAFETY: a non-NULL element points to one instance.
                instance(&unsafe { pointer.read_unaligned() })
            })
            .collect()
    } else {
        let array =
            std::ptr::with_exposed_provenance::<vk::AccelerationStructureInstanceKHR>(address);
        (0..len)
            // SAFETY: the caller guarantees `count` readable instances at
            // `data + primitiveOffset`, and `k < len <= count`.
            .map(|k| instance(&unsafe { array.add(k).read_unaligned() }))
            .collect()
    };
    Some(list)
}

/// A host range the checks may read: where, how many bytes (None: the
/// extent overflows), and what it is called in findings.
pub(super) struct HostRead {
    pub(super) address: u64,
    pub(super) extent: Option<u64>,
    pub(super) location: String,
}

/// The host ranges of a host build whose extent the API describes: each
/// micromap geometry's triangle array, and each EXT or KHR opacity
/// attachment's index buffer for its geometry's `primitiveCount`. Micromap
/// `data` is not among them (its extent comes from the triangle entries,
/// which may be wrong), nor are instances (read through their pointers, see
/// [`read_host_instances`]) or vertex, index and transform data (no check
/// reads them).
fn host_reads(
    i: usize,
    info: &BuildGeometryInfo,
    ranges: Option<&Vec<BuildRangeInfo>>,
) -> Vec<HostRead> {
    geometry_reads(i, info, ranges)
        .into_iter()
        .filter_map(|read| {
            let extent = match (read.kind, read.extent) {
                (ReadKind::TriangleArray | ReadKind::OpacityIndices, Extent::Bytes(n)) => Some(n),
                (ReadKind::TriangleArray | ReadKind::OpacityIndices, Extent::Overflow) => None,
                _ => return None,
            };
            Some(HostRead {
                address: read.address,
                extent,
                location: read.location,
            })
        })
        .collect()
}

impl Validator {
    /// Copies the host range `read` describes into `read_for_call`, the
    /// host memory read for this call alone (unless the application
    /// described it or it was read already), so the call's checks and
    /// record can read it; a range longer than [`MAX_HOST_BYTES`] is
    /// reported and not read.
    ///
    /// # Safety
    /// A non-zero `read.address` must be a host pointer readable for
    /// `read.extent` bytes.
    pub(super) unsafe fn read_host_range(
        &self,
        read: &HostRead,
        function: &'static str,
        findings: &mut Vec<Finding>,
        read_for_call: &mut Vec<HostRange>,
    ) {
        if read.address == 0 || read.extent == Some(0) {
            return;
        }
        let extent = read.extent.filter(|&n| n <= MAX_HOST_BYTES);
        let Some(extent) = extent else {
            let size = read
                .extent
                .map_or_else(|| "more than 2^64".to_string(), |n| n.to_string());
            findings.push(Finding::new(
                &rules::READ_BOUND,
                Severity::Warning,
                function,
                read.location.clone(),
                format!("the array spans {size} bytes, more than ommcheck reads ({MAX_HOST_BYTES}); its contents are not checked"),
            ));
            return;
        };
        let (Ok(address), Ok(len)) = (usize::try_from(read.address), usize::try_from(extent))
        else {
            return; // Not a pointer on this target.
        };
        if address.checked_add(len).is_none()
            || self
                .state
                .host_memory(read_for_call)
                .read(read.address, extent)
                .is_some()
        {
            return;
        }
        // SAFETY: the caller guarantees `len` readable bytes at `address`;
        // `len` is at most MAX_HOST_BYTES and the range does not wrap.
        let bytes = unsafe {
            std::slice::from_raw_parts(std::ptr::with_exposed_provenance::<u8>(address), len)
        };
        read_for_call.push(HostRange {
            address: read.address,
            // A copy: the application may change or free the memory after the call.
            bytes: crate::Bytes::copy_from_slice(bytes),
        });
    }

    /// Checks `vkCmdBuildAccelerationStructuresKHR(commandBuffer, infoCount,
    /// pInfos, ppBuildRangeInfos)` called with the ash structures a program
    /// would hand the driver; `build_range_infos[i]` is `ppBuildRangeInfos[i]`
    /// (a missing element reads as NULL). Device addresses are not
    /// dereferenced: memory contents are read only from buffers whose
    /// contents the validator was given.
    ///
    /// # Safety
    /// `infos` must be valid as for [`build_geometry_info`], and each
    /// non-NULL `build_range_infos[i]` valid for `infos[i].geometryCount`
    /// elements.
    pub unsafe fn cmd_build_acceleration_structures_ash(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
        build_range_infos: &[*const vk::AccelerationStructureBuildRangeInfoKHR],
    ) -> Report {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe { build_geometry_infos(infos, CMD_BUILD, &mut findings) };
        // SAFETY: forwarded from the caller.
        let ranges = unsafe {
            read_build_range_infos(
                infos,
                model.len(),
                build_range_infos,
                CMD_BUILD,
                &mut findings,
            )
        };
        let mut report = Report::from(findings);
        report.extend(self.cmd_build_acceleration_structures(command_buffer, &model, &ranges));
        report
    }

    /// Checks `vkCmdBuildAccelerationStructuresKHR(commandBuffer, infoCount,
    /// pInfos, ppBuildRangeInfos)` as a layer receives it: at most
    /// [`MAX_ELEMENTS`] infos are read; a NULL `pInfos` reads as no infos,
    /// a NULL `ppBuildRangeInfos` as NULL elements.
    ///
    /// # Safety
    /// Non-NULL `infos` and `build_range_infos` must be valid for
    /// `info_count` elements, each as for
    /// [`Self::cmd_build_acceleration_structures_ash`].
    pub unsafe fn cmd_build_acceleration_structures_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        build_range_infos: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        unsafe {
            self.cmd_build_acceleration_structures_raw_kept(
                command_buffer,
                info_count,
                infos,
                build_range_infos,
            )
        }
        .0
    }

    /// As [`Self::cmd_build_acceleration_structures_raw`], and returns the
    /// build as read, to check its contents when the command buffer is
    /// submitted ([`Validator::check_device_build_contents`]).
    ///
    /// # Safety
    /// As [`Self::cmd_build_acceleration_structures_raw`].
    pub unsafe fn cmd_build_acceleration_structures_raw_kept(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        build_range_infos: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
    ) -> (Report, DeviceBuild) {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let (infos, ranges) = unsafe {
            raw_arrays(
                info_count,
                infos,
                build_range_infos,
                CMD_BUILD,
                &mut findings,
            )
        };
        // SAFETY: forwarded from the caller.
        let model = unsafe { build_geometry_infos(infos, CMD_BUILD, &mut findings) };
        // SAFETY: forwarded from the caller.
        let ranges =
            unsafe { read_build_range_infos(infos, model.len(), ranges, CMD_BUILD, &mut findings) };
        let mut report = Report::from(findings);
        // The caller reads the build's device memory at submission and
        // reports there what it cannot read.
        let later = std::mem::replace(&mut self.device_contents_later, true);
        report.extend(self.cmd_build_acceleration_structures(command_buffer, &model, &ranges));
        self.device_contents_later = later;
        let build = DeviceBuild::AccelerationStructures {
            infos: model,
            ranges,
            indirect: false,
            indirect_ranges: Vec::new(),
        };
        (report, build)
    }

    /// Checks `vkBuildAccelerationStructuresKHR(device, deferredOperation,
    /// infoCount, pInfos, ppBuildRangeInfos)` as a layer receives it (see
    /// [`Self::cmd_build_acceleration_structures_raw`] and
    /// [`Self::build_acceleration_structures_ash`]).
    ///
    /// # Safety
    /// As [`Self::cmd_build_acceleration_structures_raw`], with the host
    /// addresses readable as for [`Self::build_acceleration_structures_ash`].
    pub unsafe fn build_acceleration_structures_raw(
        &mut self,
        info_count: u32,
        infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        build_range_infos: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
    ) -> Report {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let (infos, ranges) = unsafe {
            raw_arrays(
                info_count,
                infos,
                build_range_infos,
                HOST_BUILD,
                &mut findings,
            )
        };
        // SAFETY: forwarded from the caller.
        let report = unsafe { self.build_acceleration_structures_ash(infos, ranges) };
        let mut out = Report::from(findings);
        out.extend(report);
        out
    }

    /// Checks `vkCmdBuildAccelerationStructuresIndirectKHR(commandBuffer,
    /// infoCount, pInfos, pIndirectDeviceAddresses, pIndirectStrides,
    /// ppMaxPrimitiveCounts)` called with ash structures; as ash's own
    /// wrapper does, `max_primitive_counts[i]` holds `pInfos[i].geometryCount`
    /// counts.
    ///
    /// # Safety
    /// `infos` must be valid as for [`build_geometry_info`].
    pub unsafe fn cmd_build_acceleration_structures_indirect_ash(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
        indirect_device_addresses: &[vk::DeviceAddress],
        indirect_strides: &[u32],
        max_primitive_counts: &[&[u32]],
    ) -> Report {
        // SAFETY: forwarded from the caller.
        unsafe {
            self.cmd_build_acceleration_structures_indirect_ash_kept(
                command_buffer,
                infos,
                indirect_device_addresses,
                indirect_strides,
                max_primitive_counts,
            )
        }
        .0
    }

    /// As [`Self::cmd_build_acceleration_structures_indirect_ash`], and the
    /// build as read, for an adaptor that checks what it reads in device
    /// memory later: its build ranges are in device memory, so the build
    /// has none but where they are (`pIndirectDeviceAddresses[i]`,
    /// `pIndirectStrides[i]`): [`DeviceBuild::content_reads`] lists the
    /// range infos and, to the end of their buffers, the opacity indices
    /// and instances they decide the extent of (micromap geometries are
    /// read as in a direct build), and the check of the contents decodes
    /// them. Device memory it cannot read now is the caller's to report.
    ///
    /// # Safety
    /// As [`Self::cmd_build_acceleration_structures_indirect_ash`].
    pub unsafe fn cmd_build_acceleration_structures_indirect_ash_kept(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
        indirect_device_addresses: &[vk::DeviceAddress],
        indirect_strides: &[u32],
        max_primitive_counts: &[&[u32]],
    ) -> (Report, DeviceBuild) {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe { build_geometry_infos(infos, CMD_BUILD_INDIRECT, &mut findings) };
        let max_counts: Vec<Option<Vec<u32>>> = max_primitive_counts
            .iter()
            .take(MAX_ELEMENTS)
            .map(|counts| Some(counts.iter().take(MAX_ELEMENTS).copied().collect()))
            .collect();
        let mut report = Report::from(findings);
        let later = std::mem::replace(&mut self.device_contents_later, true);
        report.extend(self.cmd_build_acceleration_structures_indirect(
            command_buffer,
            &model,
            indirect_device_addresses,
            indirect_strides,
            &max_counts,
        ));
        self.device_contents_later = later;
        let ranges = vec![None; model.len()];
        // Where the GPU reads each info's range infos; an info past the
        // addresses or strides given has none (and its inputs whose extent
        // they decide are not placed).
        let indirect_ranges = indirect_device_addresses
            .iter()
            .zip(indirect_strides)
            .take(model.len())
            .map(|(&address, &stride)| IndirectRanges {
                address,
                stride: u64::from(stride),
            })
            .collect();
        let build = DeviceBuild::AccelerationStructures {
            infos: model,
            ranges,
            indirect: true,
            indirect_ranges,
        };
        (report, build)
    }

    /// Checks `vkBuildAccelerationStructuresKHR(device, deferredOperation,
    /// infoCount, pInfos, ppBuildRangeInfos)` called with ash structures
    /// whose addresses are host pointers. Read as the API describes them:
    /// the instances of instances geometries (`primitiveCount` of them, or
    /// of pointers to them, from `data + primitiveOffset`; not for
    /// MOTION_NV builds, whose instances are another structure), each
    /// micromap geometry's triangle array
    /// (`(Σ usage counts − 1) × triangleArrayStride + 8` bytes) and each EXT
    /// or KHR opacity attachment's index buffer
    /// (`(primitiveCount − 1) × indexStride + index size` bytes). Micromap data is read only where the validator
    /// was given host ranges for it, because its extent comes from the
    /// triangle entries, which may be wrong.
    ///
    /// # Safety
    /// As [`Self::cmd_build_acceleration_structures_ash`], and every host
    /// address above readable for the extent given, as the API requires.
    pub unsafe fn build_acceleration_structures_ash(
        &mut self,
        infos: &[vk::AccelerationStructureBuildGeometryInfoKHR<'_>],
        build_range_infos: &[*const vk::AccelerationStructureBuildRangeInfoKHR],
    ) -> Report {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let mut model = unsafe { build_geometry_infos(infos, HOST_BUILD, &mut findings) };
        // SAFETY: forwarded from the caller.
        let ranges = unsafe {
            read_build_range_infos(
                infos,
                model.len(),
                build_range_infos,
                HOST_BUILD,
                &mut findings,
            )
        };
        // Host memory read for this call is this call's alone: the
        // application may change or free it once the call returns.
        let mut read_for_call = Vec::new();
        for (i, info) in model.iter_mut().enumerate() {
            let info_ranges = ranges.get(i).and_then(Option::as_ref);
            // SAFETY: forwarded from the caller (host instance addresses).
            unsafe { read_host_instances(i, info, info_ranges, &mut findings) };
            for read in host_reads(i, info, info_ranges) {
                // SAFETY: the caller guarantees each described host range
                // is readable for its extent.
                unsafe {
                    self.read_host_range(&read, HOST_BUILD, &mut findings, &mut read_for_call)
                };
            }
        }
        let mut report = Report::from(findings);
        report.extend(self.build_acceleration_structures_rules(&model, &ranges, &read_for_call));
        self.record_acceleration_structures_built(&model, &ranges, &read_for_call);
        report
    }

    /// Checks `vkGetAccelerationStructureBuildSizesKHR(device, buildType,
    /// pBuildInfo, pMaxPrimitiveCounts, pSizeInfo)`; a non-NULL
    /// `max_primitive_counts` is read for `pBuildInfo->geometryCount` counts.
    ///
    /// # Safety
    /// `build_info` must be valid as for [`build_geometry_info`] (its
    /// addresses are ignored), and a non-NULL `max_primitive_counts` valid
    /// for `geometryCount` elements.
    pub unsafe fn get_acceleration_structure_build_sizes_ash(
        &mut self,
        build_type: vk::AccelerationStructureBuildTypeKHR,
        build_info: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        max_primitive_counts: *const u32,
    ) -> Report {
        let function = "vkGetAccelerationStructureBuildSizesKHR";
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let mut model =
            unsafe { build_geometry_info(build_info, function, "pBuildInfo", &mut findings) };
        // SAFETY: forwarded from the caller.
        let counts = unsafe {
            read_array(
                max_primitive_counts,
                build_info.geometry_count,
                function,
                "pMaxPrimitiveCounts",
                &mut findings,
            )
        };
        // A count past the read bound was cut (with a warning); the counts
        // read are all the check may compare, or it would call the array
        // short for holding more values than ommcheck reads.
        if let Some(read) = &counts {
            let read = u32::try_from(read.len()).unwrap_or(u32::MAX);
            if build_info.geometry_count > read {
                model.geometry_count = model.geometry_count.min(read);
            }
        }
        let mut report = Report::from(findings);
        report.extend(self.get_acceleration_structure_build_sizes(
            build_type.as_raw(),
            &model,
            counts.as_deref(),
        ));
        report
    }

    /// Checks `vkCreateAccelerationStructureKHR` with the ash create info;
    /// `acceleration_structure` is the handle the call returned (null:
    /// none): [`Self::create_acceleration_structure_rules_ash`], then
    /// [`Self::record_acceleration_structure_created_ash`].
    ///
    /// # Safety
    /// `info`'s pNext chain must be well formed (cycles and length are tolerated).
    pub unsafe fn create_acceleration_structure_ash(
        &mut self,
        info: &vk::AccelerationStructureCreateInfoKHR<'_>,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        let report = unsafe { self.create_acceleration_structure_rules_ash(info) };
        self.record_acceleration_structure_created_ash(info, acceleration_structure);
        report
    }

    /// The rules of `vkCreateAccelerationStructureKHR` with the ash create
    /// info, before the call; records nothing.
    ///
    /// # Safety
    /// `info`'s pNext chain must be well formed (cycles and length are tolerated).
    pub unsafe fn create_acceleration_structure_rules_ash(
        &self,
        info: &vk::AccelerationStructureCreateInfoKHR<'_>,
    ) -> Report {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe {
            acceleration_structure_create_info(
                info,
                "vkCreateAccelerationStructureKHR",
                "pCreateInfo",
                &mut findings,
            )
        };
        let mut report = Report::from(findings);
        report.extend(self.create_acceleration_structure_rules(&model));
        report
    }

    /// Tracks the structure `vkCreateAccelerationStructureKHR` created from
    /// `info` (null: none). Reads the members only, not the pNext chain.
    pub fn record_acceleration_structure_created_ash(
        &mut self,
        info: &vk::AccelerationStructureCreateInfoKHR<'_>,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) {
        self.record_acceleration_structure_created(
            &AccelerationStructureCreateInfo::from_members(info),
            vk::Handle::as_raw(acceleration_structure),
        );
    }

    /// Checks `vkCreateAccelerationStructure2KHR` with the generated
    /// `VkAccelerationStructureCreateInfo2KHR`; `acceleration_structure` as
    /// for [`Self::create_acceleration_structure_ash`].
    ///
    /// # Safety
    /// `info`'s pNext chain must be well formed (cycles and length are tolerated).
    pub unsafe fn create_acceleration_structure2_ash(
        &mut self,
        info: &khr::AccelerationStructureCreateInfo2KHR,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        let report = unsafe { self.create_acceleration_structure2_rules_ash(info) };
        self.record_acceleration_structure2_created_ash(info, acceleration_structure);
        report
    }

    /// The rules of `vkCreateAccelerationStructure2KHR`, before the call;
    /// records nothing.
    ///
    /// # Safety
    /// `info`'s pNext chain must be well formed (cycles and length are tolerated).
    pub unsafe fn create_acceleration_structure2_rules_ash(
        &self,
        info: &khr::AccelerationStructureCreateInfo2KHR,
    ) -> Report {
        let mut findings = Vec::new();
        let model = AccelerationStructureCreateInfo2 {
            // SAFETY: forwarded from the caller.
            next: unsafe {
                chain_s_types(
                    info.p_next,
                    "vkCreateAccelerationStructure2KHR",
                    "pCreateInfo",
                    &mut findings,
                )
            },
            ..AccelerationStructureCreateInfo2::from_members(info)
        };
        let mut report = Report::from(findings);
        report.extend(self.create_acceleration_structure2_rules(&model));
        report
    }

    /// Tracks the structure `vkCreateAccelerationStructure2KHR` created from
    /// `info` (null: none). Reads the members only, not the pNext chain.
    pub fn record_acceleration_structure2_created_ash(
        &mut self,
        info: &khr::AccelerationStructureCreateInfo2KHR,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) {
        self.record_acceleration_structure2_created(
            &AccelerationStructureCreateInfo2::from_members(info),
            vk::Handle::as_raw(acceleration_structure),
        );
    }
}

/// `pInfos` and `ppBuildRangeInfos` of a build command as slices of at most
/// [`MAX_ELEMENTS`] elements (empty for NULL).
///
/// # Safety
/// Non-NULL `infos` and `ranges` must be valid for `count` elements, and
/// stay so for `'a`.
unsafe fn raw_arrays<'a, 'b>(
    count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'b>,
    ranges: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> (
    &'a [vk::AccelerationStructureBuildGeometryInfoKHR<'b>],
    &'a [*const vk::AccelerationStructureBuildRangeInfoKHR],
) {
    let len = bounded_len(count, function, "pInfos", findings);
    let infos = if infos.is_null() {
        &[][..]
    } else {
        // SAFETY: the caller guarantees `count` readable elements; `len <= count`.
        unsafe { std::slice::from_raw_parts(infos, len) }
    };
    let ranges = if ranges.is_null() {
        &[][..]
    } else {
        // SAFETY: the caller guarantees `count` readable pointers; `len <= count`.
        unsafe { std::slice::from_raw_parts(ranges, len) }
    };
    (infos, ranges)
}

/// Fills the instances of the instances geometries of host build `i` (the
/// geometries the implementation reads: `pGeometries`, else `ppGeometries`),
/// where the build range gives their count.
///
/// # Safety
/// Each instances geometry's `data + primitiveOffset` must be a host
/// address readable as the API describes it for its range's `primitiveCount`.
unsafe fn read_host_instances(
    i: usize,
    info: &mut BuildGeometryInfo,
    ranges: Option<&Vec<BuildRangeInfo>>,
    findings: &mut Vec<Finding>,
) {
    // Only top-level builds take instances (a bottom-level one with
    // instances geometry breaks a VUID, and its data need not be readable);
    // MOTION_NV builds take VkAccelerationStructureMotionInstanceNV, not
    // modelled.
    if info.ty != ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL || info.flags & BUILD_MOTION_NV != 0 {
        return;
    }
    let (member, geometries): (&str, Vec<(usize, &mut Geometry)>) =
        if let Some(list) = info.geometries.as_mut() {
            ("pGeometries", list.iter_mut().enumerate().collect())
        } else if let Some(list) = info.geometry_pointers.as_mut() {
            (
                "ppGeometries",
                list.iter_mut()
                    .enumerate()
                    .filter_map(|(g, geometry)| geometry.as_mut().map(|geometry| (g, geometry)))
                    .collect(),
            )
        } else {
            return;
        };
    for (g, geometry) in geometries {
        let GeometryData::Instances(data) = &mut geometry.geometry else {
            continue;
        };
        let Some(range) = ranges.and_then(|r| r.get(g)) else {
            continue;
        };
        let location = format!("pInfos[{i}].{member}[{g}].geometry.instances.data");
        // SAFETY: forwarded from the caller.
        data.instances = unsafe { host_instances(data, range, HOST_BUILD, &location, findings) };
    }
}

#[cfg(test)]
mod tests {
    use std::ffi::c_void;

    use super::*;
    use crate::model::accel::{
        ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, GEOMETRY_TYPE_TRIANGLES, INDEX_TYPE_NONE,
        INDEX_TYPE_UINT16,
    };
    use crate::raw::generated::geometry as read_geometry;
    use crate::raw::MAX_CHAIN;
    use crate::{Device, Profile};
    use ommcheck_vuids::vuid;

    fn validator() -> Validator {
        Validator::new(Device::with_everything(Profile::SpecMinimum))
    }

    fn usage_khr(count: u32, subdivision_level: u32, format: i32) -> khr::MicromapUsageKHR {
        khr::MicromapUsageKHR {
            count,
            subdivision_level,
            format: vk::OpacityMicromapFormatEXT::from_raw(format),
        }
    }

    fn triangles_geometry(p_next: *const c_void) -> vk::AccelerationStructureGeometryKHR<'static> {
        vk::AccelerationStructureGeometryKHR {
            geometry_type: vk::GeometryTypeKHR::TRIANGLES,
            geometry: vk::AccelerationStructureGeometryDataKHR {
                triangles: vk::AccelerationStructureGeometryTrianglesDataKHR {
                    p_next,
                    vertex_format: vk::Format::R32G32B32_SFLOAT,
                    vertex_stride: 12,
                    max_vertex: 2,
                    index_type: vk::IndexType::NONE_KHR,
                    ..Default::default()
                },
            },
            ..Default::default()
        }
    }

    fn rule_count(findings: &[Finding], id: &str) -> usize {
        findings.iter().filter(|f| f.rule.as_str() == id).count()
    }

    #[test]
    fn null_geometry_pointers_with_a_count_read_as_null() {
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            geometry_count: 3,
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: both geometry pointers are NULL.
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        assert_eq!(model.geometry_count, 3);
        assert!(model.geometries.is_none() && model.geometry_pointers.is_none());
        assert!(findings.is_empty(), "{findings:?}");

        // NULL elements of ppGeometries stay None; the others are read.
        let geometry = triangles_geometry(std::ptr::null());
        let pointers = [std::ptr::null(), &geometry as *const _, std::ptr::null()];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            geometry_count: 3,
            pp_geometries: pointers.as_ptr(),
            ..Default::default()
        };
        // SAFETY: ppGeometries holds 3 pointers, NULL or to a live geometry.
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        let list = model.geometry_pointers.expect("ppGeometries was read");
        assert_eq!(list.len(), 3);
        assert!(list[0].is_none() && list[2].is_none());
        let read = list[1].as_ref().expect("element 1 is not NULL");
        assert_eq!(read.geometry_type, GEOMETRY_TYPE_TRIANGLES);
        let GeometryData::Triangles(triangles) = &read.geometry else {
            panic!("not triangles: {:?}", read.geometry);
        };
        assert_eq!((triangles.max_vertex, triangles.vertex_stride), (2, 12));
        assert!(findings.is_empty(), "{findings:?}");
    }

    #[test]
    fn cyclic_geometry_pnext_chain_is_cut_and_reported() {
        let mut a = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1),
            ..Default::default()
        };
        let b = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(2),
            p_next: &a,
            ..Default::default()
        };
        a.p_next = &b;
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: (&a as *const vk::BaseInStructure<'_>).cast(),
            geometry_type: vk::GeometryTypeKHR::AABBS,
            ..Default::default()
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            geometry_count: 1,
            p_geometries: &geometry,
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: the geometry's chain is two live structures pointing at each other.
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        let geometries = model.geometries.expect("pGeometries was read");
        assert_eq!(geometries[0].next, [1, 2]);
        // The union is all zero bytes: an aabbs member with sType 0.
        assert_eq!(
            geometries[0].geometry,
            GeometryData::Aabbs(crate::model::accel::AabbsData {
                s_type: 0,
                ..Default::default()
            })
        );
        assert_eq!(findings.len(), 1, "{findings:?}");
        assert_eq!(findings[0].rule.as_str(), rules::PNEXT_CHAIN.id);
        assert_eq!(findings[0].location, "pInfos[0].pGeometries[0].pNext");
    }

    #[test]
    fn cyclic_triangles_pnext_chain_is_cut_and_reported() {
        let mut ext = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
            index_type: vk::IndexType::UINT16,
            index_stride: 2,
            base_triangle: 5,
            ..Default::default()
        };
        // The EXT structure points back at itself.
        ext.p_next =
            (&mut ext as *mut vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>).cast();
        let geometry = triangles_geometry(
            (&ext as *const vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>).cast(),
        );
        let mut findings = Vec::new();
        // SAFETY: the triangles' chain is one live structure pointing at itself.
        let model = unsafe { read_geometry(&geometry, "f", "g", &mut findings) };
        let GeometryData::Triangles(triangles) = &model.geometry else {
            panic!("not triangles");
        };
        let read = triangles.opacity_ext.as_ref().expect("EXT attachment read");
        assert_eq!(
            (read.index_type, read.index_stride, read.base_triangle),
            (INDEX_TYPE_UINT16, 2, 5)
        );
        assert!(triangles.next.is_empty());
        assert_eq!(findings.len(), 1, "{findings:?}");
        assert_eq!(findings[0].location, "g.geometry.triangles.pNext");
    }

    #[test]
    fn long_pnext_chain_is_cut() {
        let mut links = vec![vk::BaseInStructure::default(); MAX_CHAIN + 10];
        let first = links.as_mut_ptr();
        for k in 0..links.len() - 1 {
            // SAFETY: `k + 1 < links.len()`; all pointers derive from `first`.
            unsafe { (*first.add(k)).p_next = first.add(k + 1) };
        }
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: first.cast_const().cast(),
            geometry_type: vk::GeometryTypeKHR::from_raw(12345),
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: the chain is a list of live structures.
        let model = unsafe { read_geometry(&geometry, "f", "g", &mut findings) };
        assert_eq!(model.next.len(), MAX_CHAIN);
        // An unknown geometry type reads no union member.
        assert_eq!(model.geometry, GeometryData::None);
        assert_eq!(rule_count(&findings, rules::PNEXT_CHAIN.id), 1);
    }

    #[test]
    fn absurd_geometry_count_is_bounded() {
        let bound = MAX_GEOMETRIES as usize;
        let pointers: Vec<*const vk::AccelerationStructureGeometryKHR<'_>> =
            vec![std::ptr::null(); bound];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            geometry_count: u32::MAX,
            pp_geometries: pointers.as_ptr(),
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: only the first MAX_GEOMETRIES pointers are read, all of
        // them live (and NULL).
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        assert_eq!(model.geometry_pointers.map(|l| l.len()), Some(bound));
        assert_eq!(model.geometry_count, MAX_GEOMETRIES);
        assert_eq!(findings.len(), 1, "{findings:?}");
        assert_eq!(findings[0].rule.as_str(), rules::READ_BOUND.id);
        assert_eq!(findings[0].location, "pInfos[0].geometryCount");

        // The build ranges of such an info are read with the same bound.
        let ranges = vec![vk::AccelerationStructureBuildRangeInfoKHR::default(); bound];
        let mut findings = Vec::new();
        // SAFETY: only the first MAX_GEOMETRIES ranges are read, all live.
        let read =
            unsafe { read_build_range_infos(&[info], 1, &[ranges.as_ptr()], "f", &mut findings) };
        assert_eq!(read[0].as_ref().map(Vec::len), Some(bound));
        assert_eq!(rule_count(&findings, rules::READ_BOUND.id), 1);
    }

    #[test]
    fn micromap_geometry_is_read_end_to_end() {
        let usages = [usage_khr(3, 1, 2), usage_khr(1, 0, 1)];
        let micromap = khr::AccelerationStructureGeometryMicromapDataKHR {
            usage_counts_count: 2,
            p_usage_counts: usages.as_ptr(),
            data: 0x10000,
            triangle_array: 0x20000,
            triangle_array_stride: 4,
            ..Default::default()
        };
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: (&micromap as *const khr::AccelerationStructureGeometryMicromapDataKHR).cast(),
            geometry_type: khr::GEOMETRY_TYPE_MICROMAP_KHR,
            ..Default::default()
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            geometry_count: 1,
            p_geometries: &geometry,
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: every pointer points to live structures of the counts given.
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        let read = &model.geometries.as_ref().expect("read")[0];
        assert_eq!(read.geometry, GeometryData::None);
        assert!(read.next.is_empty());
        let data = read.micromap.as_ref().expect("micromap structure read");
        assert_eq!(
            (data.data, data.triangle_array, data.triangle_array_stride),
            (0x10000, 0x20000, 4)
        );
        assert_eq!(data.usage_counts.total(), 4);
        let (_, entries) = data.usage_counts.entries();
        assert_eq!(
            (entries[0].1.subdivision_level, entries[0].1.format),
            (1, 2)
        );

        let mut v = validator();
        // SAFETY: as above; ppBuildRangeInfos[0] is NULL.
        let report = unsafe {
            v.cmd_build_acceleration_structures_ash(
                &CommandBuffer::default(),
                &[info],
                &[std::ptr::null()],
            )
        };
        assert!(
            report.contains(
                vuid::VkAccelerationStructureGeometryMicromapDataKHR::triangleArrayStride_11646
            ),
            "{report}"
        );
        assert!(
            !report.contains(vuid::vkCmdBuildAccelerationStructuresKHR::ppBuildRangeInfos_11544),
            "{report}"
        );

        // The same call as a layer receives it: pInfos and a NULL ppBuildRangeInfos.
        let mut v = validator();
        // SAFETY: pInfos points to one info valid as above.
        let raw = unsafe {
            v.cmd_build_acceleration_structures_raw(
                &CommandBuffer::default(),
                1,
                &info,
                std::ptr::null(),
            )
        };
        // An adaptor reports what it cannot read at submission, so the raw
        // call leaves out the not-checked information the ash call gives.
        let decided: Vec<_> = report
            .findings
            .iter()
            .filter(|f| f.not_checked_cause().is_none())
            .cloned()
            .collect();
        assert_eq!(raw.findings, decided);
        // SAFETY: NULL arrays are not read.
        let null = unsafe {
            v.cmd_build_acceleration_structures_raw(
                &CommandBuffer::default(),
                5,
                std::ptr::null(),
                std::ptr::null(),
            )
        };
        assert!(null.findings.is_empty(), "{null}");
    }

    #[test]
    fn null_usage_count_pointer_of_a_micromap_geometry_is_reported() {
        let usage = usage_khr(2, 1, 2);
        let pointers = [&usage as *const khr::MicromapUsageKHR, std::ptr::null()];
        let micromap = khr::AccelerationStructureGeometryMicromapDataKHR {
            usage_counts_count: 2,
            pp_usage_counts: pointers.as_ptr(),
            triangle_array_stride: 8,
            ..Default::default()
        };
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: (&micromap as *const khr::AccelerationStructureGeometryMicromapDataKHR).cast(),
            geometry_type: khr::GEOMETRY_TYPE_MICROMAP_KHR,
            ..Default::default()
        };
        let geometry_pointers = [&geometry as *const vk::AccelerationStructureGeometryKHR<'_>];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            geometry_count: 1,
            pp_geometries: geometry_pointers.as_ptr(),
            ..Default::default()
        };
        let mut v = validator();
        // SAFETY: every pointer is NULL or points to live structures.
        let report = unsafe {
            v.get_acceleration_structure_build_sizes_ash(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                std::ptr::null(),
            )
        };
        assert!(
            report.contains(
                vuid::VkAccelerationStructureGeometryMicromapDataKHR::ppUsageCounts_parameter
            ),
            "{report}"
        );
    }

    /// A `geometryCount` past [`MAX_ELEMENTS`] with NULL geometries: the
    /// counts are read to the bound (a warning says so), and their array is
    /// not called short for it; the NULL geometries are still an error.
    #[test]
    #[cfg_attr(miri, ignore = "reads 2^20 values")]
    fn max_primitive_counts_past_the_read_bound_are_not_called_short() {
        let count = MAX_ELEMENTS as u32 + 1;
        let counts = vec![1u32; count as usize];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            geometry_count: count,
            ..Default::default()
        };
        let sizes = |max_primitive_counts: *const u32| {
            // SAFETY: `max_primitive_counts` is NULL or `counts`, which
            // holds geometryCount values; the geometries are NULL.
            unsafe {
                validator().get_acceleration_structure_build_sizes_ash(
                    vk::AccelerationStructureBuildTypeKHR::DEVICE,
                    &info,
                    max_primitive_counts,
                )
            }
        };
        let short = vuid::vkGetAccelerationStructureBuildSizesKHR::pMaxPrimitiveCounts_11612;
        let report = sizes(counts.as_ptr());
        assert_eq!(
            rule_count(&report.findings, rules::READ_BOUND.id),
            1,
            "{report}"
        );
        assert!(!report.contains(short), "{report}");
        // Short for real: NULL.
        let report = sizes(std::ptr::null());
        assert!(report.contains(short), "{report}");
    }

    #[test]
    fn khr_attachment_is_read_from_the_triangles_chain() {
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(424242),
            ..Default::default()
        };
        let attachment = khr::AccelerationStructureTrianglesOpacityMicromapKHR {
            p_next: (&unknown as *const vk::BaseInStructure<'_>)
                .cast_mut()
                .cast(),
            index_type: vk::IndexType::NONE_KHR,
            index_buffer: 0x4000,
            index_stride: 4,
            micromap: vk::Handle::from_raw(0x77),
            ..Default::default()
        };
        let geometry = triangles_geometry(
            (&attachment as *const khr::AccelerationStructureTrianglesOpacityMicromapKHR).cast(),
        );
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            geometry_count: 1,
            p_geometries: &geometry,
            ..Default::default()
        };
        let range = vk::AccelerationStructureBuildRangeInfoKHR {
            primitive_count: 1,
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: every pointer points to live structures.
        let model = unsafe { build_geometry_info(&info, "f", "pInfos[0]", &mut findings) };
        let GeometryData::Triangles(triangles) =
            &model.geometries.as_ref().expect("read")[0].geometry
        else {
            panic!("not triangles");
        };
        let read = triangles.opacity_khr.as_ref().expect("KHR attachment read");
        assert_eq!(
            (read.index_type, read.index_buffer, read.micromap),
            (INDEX_TYPE_NONE, 0x4000, 0x77)
        );
        assert_eq!(triangles.next, [424242]);
        assert_eq!(model.ty, ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL);

        let mut v = validator();
        // SAFETY: as above; the range pointer points to one range info.
        let report = unsafe {
            v.cmd_build_acceleration_structures_ash(&CommandBuffer::default(), &[info], &[&range])
        };
        assert!(
            report.contains(
                vuid::VkAccelerationStructureTrianglesOpacityMicromapKHR::indexBuffer_11571
            ),
            "{report}"
        );
        // The unknown sType chained after the attachment is reported too.
        assert!(
            report.contains(vuid::VkAccelerationStructureGeometryTrianglesDataKHR::pNext_pNext),
            "{report}"
        );
    }

    #[test]
    fn ext_and_nv_attachments_are_read() {
        let usages = [vk::MicromapUsageEXT {
            count: 4,
            subdivision_level: 1,
            format: 2,
        }];
        let nv = vk::AccelerationStructureTrianglesDisplacementMicromapNV {
            displacement_vector_format: vk::Format::R16G16B16A16_SFLOAT,
            displacement_vector_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: 0x9000,
            },
            index_type: vk::IndexType::UINT32,
            index_stride: 4,
            micromap: vk::Handle::from_raw(0x55),
            ..Default::default()
        };
        let ext = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
            p_next: (&nv as *const vk::AccelerationStructureTrianglesDisplacementMicromapNV<'_>)
                .cast_mut()
                .cast(),
            index_type: vk::IndexType::UINT32,
            index_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: 0x8000,
            },
            index_stride: 4,
            usage_counts_count: 1,
            p_usage_counts: usages.as_ptr(),
            micromap: vk::Handle::from_raw(0x66),
            ..Default::default()
        };
        let geometry = triangles_geometry(
            (&ext as *const vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>).cast(),
        );
        let mut findings = Vec::new();
        // SAFETY: every pointer points to live structures.
        let model = unsafe { read_geometry(&geometry, "f", "g", &mut findings) };
        let GeometryData::Triangles(triangles) = &model.geometry else {
            panic!("not triangles");
        };
        let ext = triangles.opacity_ext.as_ref().expect("EXT read");
        assert_eq!(
            (ext.index_buffer, ext.micromap, ext.usage_counts.total()),
            (0x8000, 0x66, 4)
        );
        let nv = triangles.displacement_nv.as_ref().expect("NV read");
        assert_eq!((nv.displacement_vector_buffer, nv.micromap), (0x9000, 0x55));
        assert_eq!(
            nv.displacement_vector_format,
            vk::Format::R16G16B16A16_SFLOAT.as_raw()
        );
        assert!(triangles.next.is_empty() && findings.is_empty());
    }

    #[test]
    fn host_build_reads_the_index_buffer_it_describes() {
        // Triangle 0 uses a special index, triangle 1 index 5: with no
        // micromap, only special indices may be read.
        let indices: [u32; 2] = [u32::MAX, 5];
        let attachment = khr::AccelerationStructureTrianglesOpacityMicromapKHR {
            index_type: vk::IndexType::UINT32,
            index_buffer: indices.as_ptr() as u64,
            index_stride: 4,
            ..Default::default()
        };
        let geometry = triangles_geometry(
            (&attachment as *const khr::AccelerationStructureTrianglesOpacityMicromapKHR).cast(),
        );
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            geometry_count: 1,
            p_geometries: &geometry,
            ..Default::default()
        };
        let range = vk::AccelerationStructureBuildRangeInfoKHR {
            primitive_count: 2,
            ..Default::default()
        };
        let mut v = validator();
        // SAFETY: the index buffer holds primitiveCount = 2 indices.
        let report = unsafe { v.build_acceleration_structures_ash(&[info], &[&range]) };
        let special_only: Vec<_> = report
            .findings
            .iter()
            .filter(|f| f.rule.as_str() == rules::NULL_MICROMAP_SPECIAL_ONLY.id)
            .collect();
        assert_eq!(special_only.len(), 1, "{report}");
        assert!(
            special_only[0].location.ends_with("indexBuffer[1]"),
            "{report}"
        );
        // Read during the call, forgotten after it.
        assert_eq!(
            v.state.host_memory(&[]).read(indices.as_ptr() as u64, 8),
            None
        );

        // The same build through the device command reads nothing at the
        // (host) address: it is no device address the checker knows.
        let mut v = validator();
        // SAFETY: as above.
        let report = unsafe {
            v.cmd_build_acceleration_structures_ash(&CommandBuffer::default(), &[info], &[&range])
        };
        assert!(
            !report.contains(&rules::NULL_MICROMAP_SPECIAL_ONLY),
            "{report}"
        );
        assert!(v.state.host_memory.is_empty());
    }

    #[test]
    fn host_triangle_array_is_described_and_bounded() {
        // Two entries (dataOffset, subdivisionLevel, format): level 1 and level 3.
        let entries: [u8; 16] = [0, 0, 0, 0, 1, 0, 2, 0, 0, 0, 0, 0, 3, 0, 2, 0];
        let usages = [usage_khr(2, 1, 2)];
        let micromap = khr::AccelerationStructureGeometryMicromapDataKHR {
            usage_counts_count: 1,
            p_usage_counts: usages.as_ptr(),
            triangle_array: entries.as_ptr() as u64,
            triangle_array_stride: 8,
            ..Default::default()
        };
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: (&micromap as *const khr::AccelerationStructureGeometryMicromapDataKHR).cast(),
            geometry_type: khr::GEOMETRY_TYPE_MICROMAP_KHR,
            ..Default::default()
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            geometry_count: 1,
            p_geometries: &geometry,
            ..Default::default()
        };
        let mut v = validator();
        // SAFETY: the triangle array holds the 2 entries the counts describe.
        let report = unsafe { v.build_acceleration_structures_ash(&[info], &[]) };
        assert_eq!(
            v.state.host_memory(&[]).read(entries.as_ptr() as u64, 16),
            None
        );
        // The counts claim two level-1 triangles; the array read from host
        // memory holds a level-3 one.
        assert!(report.contains(&rules::HISTOGRAM_MISMATCH), "{report}");

        // A stride that spans more than MAX_HOST_BYTES is reported, not read.
        let wide = khr::AccelerationStructureGeometryMicromapDataKHR {
            triangle_array_stride: MAX_HOST_BYTES,
            ..micromap
        };
        let geometry = vk::AccelerationStructureGeometryKHR {
            p_next: (&wide as *const khr::AccelerationStructureGeometryMicromapDataKHR).cast(),
            ..geometry
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            p_geometries: &geometry,
            ..info
        };
        let mut v = validator();
        // SAFETY: the bounded extent is never read.
        let report = unsafe { v.build_acceleration_structures_ash(&[info], &[]) };
        assert!(report.contains(&rules::READ_BOUND), "{report}");
        assert!(v.state.host_memory.is_empty());
    }

    #[test]
    fn host_instances_are_read_with_null_pointer_elements() {
        let instance = vk::AccelerationStructureInstanceKHR {
            transform: vk::TransformMatrixKHR { matrix: [1.0; 12] },
            instance_custom_index_and_mask: vk::Packed24_8::new(7, 0xff),
            instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(3, 0x30),
            acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                device_handle: 0xabc,
            },
        };
        let instances = [instance, instance];
        let geometry = vk::AccelerationStructureGeometryKHR {
            geometry_type: vk::GeometryTypeKHR::INSTANCES,
            geometry: vk::AccelerationStructureGeometryDataKHR {
                instances: vk::AccelerationStructureGeometryInstancesDataKHR {
                    data: vk::DeviceOrHostAddressConstKHR {
                        host_address: instances.as_ptr().cast(),
                    },
                    ..Default::default()
                },
            },
            ..Default::default()
        };
        let pointers = [
            &instance as *const vk::AccelerationStructureInstanceKHR,
            std::ptr::null(),
        ];
        let by_pointer = vk::AccelerationStructureGeometryKHR {
            geometry: vk::AccelerationStructureGeometryDataKHR {
                instances: vk::AccelerationStructureGeometryInstancesDataKHR {
                    array_of_pointers: vk::TRUE,
                    data: vk::DeviceOrHostAddressConstKHR {
                        host_address: pointers.as_ptr().cast(),
                    },
                    ..Default::default()
                },
            },
            ..geometry
        };
        let geometries = [geometry, by_pointer];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            geometry_count: 2,
            p_geometries: geometries.as_ptr(),
            ..Default::default()
        };
        let range = vk::AccelerationStructureBuildRangeInfoKHR {
            primitive_count: 2,
            ..Default::default()
        };
        let ranges = [range, range];
        let mut findings = Vec::new();
        // SAFETY: every pointer points to live structures.
        let mut model =
            unsafe { build_geometry_info(&info, HOST_BUILD, "pInfos[0]", &mut findings) };
        assert_eq!(model.ty, ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL);
        let model_ranges = vec![
            BuildRangeInfo {
                primitive_count: 2,
                ..Default::default()
            };
            2
        ];
        // SAFETY: each instances geometry holds primitiveCount = 2 instances (or pointers).
        unsafe { read_host_instances(0, &mut model, Some(&model_ranges), &mut findings) };
        let read: Vec<_> = model
            .geometries
            .expect("read")
            .into_iter()
            .map(|g| match g.geometry {
                GeometryData::Instances(data) => data.instances.expect("instances read"),
                other => panic!("not instances: {other:?}"),
            })
            .collect();
        let expected = Instance {
            transform: [1.0; 12],
            instance_custom_index: 7,
            mask: 0xff,
            instance_shader_binding_table_record_offset: 3,
            flags: 0x30,
            acceleration_structure_reference: 0xabc,
        };
        assert_eq!(read[0], [expected.clone(), expected.clone()]);
        assert_eq!(read[1], [expected, Instance::default()]);
        assert!(findings.is_empty(), "{findings:?}");

        // The device command leaves device instance data unread.
        let mut findings = Vec::new();
        // SAFETY: as above.
        let model = unsafe { build_geometry_info(&info, CMD_BUILD, "pInfos[0]", &mut findings) };
        assert!(model.geometries.expect("read").iter().all(|g| matches!(
            &g.geometry,
            GeometryData::Instances(InstancesData {
                instances: None,
                ..
            })
        )));

        // End to end: the instances (flags 0x30: FORCE_2_STATE | DISABLE)
        // reference a bottom-level structure built without
        // ALLOW_DISABLE_OPACITY_MICROMAPS.
        let mut v = validator();
        let blas = <vk::AccelerationStructureKHR as vk::Handle>::from_raw(0xabc);
        let create = vk::AccelerationStructureCreateInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            size: 0x1000,
            ..Default::default()
        };
        let blas_build = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            dst_acceleration_structure: blas,
            ..Default::default()
        };
        // SAFETY: no pNext chains, no geometries.
        unsafe {
            v.create_acceleration_structure_ash(&create, blas);
            v.build_acceleration_structures_ash(&[blas_build], &[]);
        }
        // SAFETY: as above; ppBuildRangeInfos[0] points to 2 range infos.
        let report = unsafe { v.build_acceleration_structures_ash(&[info], &[ranges.as_ptr()]) };
        let disable: Vec<_> = report
            .findings
            .iter()
            .filter(|f| f.rule == vuid::VkAccelerationStructureInstanceKHR::flags_11581.into())
            .collect();
        assert!(!disable.is_empty(), "{report}");
        assert!(
            disable[0]
                .location
                .starts_with("pInfos[0].pGeometries[0].geometry.instances.data[0]"),
            "{report}"
        );
    }

    #[test]
    fn host_instances_are_read_from_the_primitive_offset() {
        // The API consumes instances from data + primitiveOffset: the
        // second of two instances (or pointers) here, never the first.
        let instance = |index: u32| vk::AccelerationStructureInstanceKHR {
            transform: vk::TransformMatrixKHR { matrix: [0.0; 12] },
            instance_custom_index_and_mask: vk::Packed24_8::new(index, 0xff),
            instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(0, 0),
            acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                device_handle: 0,
            },
        };
        let instances = [instance(1), instance(2)];
        let pointers: [*const vk::AccelerationStructureInstanceKHR; 2] =
            [&instances[0], &instances[1]];
        let size = std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u32;
        for (array_of_pointers, offset) in [(false, size), (true, 8)] {
            let data: *const c_void = if array_of_pointers {
                pointers.as_ptr().cast()
            } else {
                instances.as_ptr().cast()
            };
            let geometry = vk::AccelerationStructureGeometryKHR {
                geometry_type: vk::GeometryTypeKHR::INSTANCES,
                geometry: vk::AccelerationStructureGeometryDataKHR {
                    instances: vk::AccelerationStructureGeometryInstancesDataKHR {
                        array_of_pointers: u32::from(array_of_pointers),
                        data: vk::DeviceOrHostAddressConstKHR { host_address: data },
                        ..Default::default()
                    },
                },
                ..Default::default()
            };
            let info = vk::AccelerationStructureBuildGeometryInfoKHR {
                ty: vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                geometry_count: 1,
                p_geometries: &geometry,
                ..Default::default()
            };
            let mut findings = Vec::new();
            // SAFETY: every pointer points to live structures.
            let mut model =
                unsafe { build_geometry_info(&info, HOST_BUILD, "pInfos[0]", &mut findings) };
            let ranges = vec![BuildRangeInfo {
                primitive_count: 1,
                primitive_offset: offset,
                ..Default::default()
            }];
            // SAFETY: one instance (or pointer) lies at data + primitiveOffset.
            unsafe { read_host_instances(0, &mut model, Some(&ranges), &mut findings) };
            let read = match &model.geometries.expect("read")[0].geometry {
                GeometryData::Instances(data) => data.instances.clone().expect("instances read"),
                other => panic!("not instances: {other:?}"),
            };
            assert_eq!(read.len(), 1);
            assert_eq!(
                read[0].instance_custom_index, 2,
                "pointers: {array_of_pointers}"
            );
            assert!(findings.is_empty(), "{findings:?}");
        }
    }

    #[test]
    fn create_info2_is_read() {
        let info = khr::AccelerationStructureCreateInfo2KHR {
            create_flags: vk::AccelerationStructureCreateFlagsKHR::MOTION_NV,
            address_range: khr::DeviceAddressRangeKHR {
                address: 0x10000,
                size: 0x1000,
            },
            ty: khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            ..Default::default()
        };
        let mut v = validator();
        // SAFETY: the pNext chain is NULL.
        let report = unsafe {
            v.create_acceleration_structure2_ash(&info, vk::AccelerationStructureKHR::null())
        };
        assert!(
            report.contains(vuid::VkAccelerationStructureCreateInfo2KHR::createFlags_11611),
            "{report}"
        );
        let info = vk::AccelerationStructureCreateInfoKHR {
            ty: khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            ..Default::default()
        };
        // SAFETY: the pNext chain is NULL.
        let report = unsafe {
            v.create_acceleration_structure_ash(&info, vk::AccelerationStructureKHR::null())
        };
        assert!(
            report.contains(vuid::VkAccelerationStructureCreateInfoKHR::type_11600),
            "{report}"
        );
    }
}
