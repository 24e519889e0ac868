//! Reading the structures of the pipeline, shader, synchronization and
//! feature/property calls into the model of [`crate::model::pipeline`]:
//! shader module code, the four pipeline create infos (flags, stages with
//! their module or chained code, specialization values, libraries),
//! `VkShaderCreateInfoEXT`, `VkDependencyInfo` (with the
//! `VkMemoryRangeBarriersInfoKHR` ash 0.38 lacks), `VkSubmitInfo2`,
//! `VkMemoryMarkerInfoAMD`, and the pNext chains of `vkCreateDevice` and
//! `vkGetPhysicalDeviceProperties2` (their structures, and the limits the
//! properties report).
//!
//! The bounds of the rest of [`crate::raw`] hold: arrays up to
//! [`MAX_ELEMENTS`](super::MAX_ELEMENTS) elements, chains up to
//! [`super::MAX_CHAIN`] structures with each address visited once, strings
//! up to [`MAX_NAME_BYTES`] bytes.

use std::ffi::{c_char, c_void};

use ash::vk;
use ommcheck_vuids::khr;

use super::generated::{pipeline_library_create_info, semaphore_submit_info, specialization_info};
use super::{bounded_len, bounded_units, chain, read_array};
use crate::device::Limits;
use crate::model::generated::PipelineCreateFlags2CreateInfo;
use crate::model::pipeline::{
    Barrier, ChainedStruct, DependencyInfo, MemoryMarkerInfo, MicromapStruct, PipelineCreateFlags,
    PipelineCreateInfo, ShaderCreateInfo, ShaderStage, SpecializationValue, SubmitInfo2,
    SHADER_CODE_TYPE_SPIRV, STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR,
};
use crate::model::Handle;
use crate::report::location::Locate;
use crate::report::{Finding, Severity};
use crate::rules;

/// The most bytes of an entry-point name read (the specification sets no
/// bound; real names are far shorter).
pub const MAX_NAME_BYTES: usize = 4096;

/// `VK_STRUCTURE_TYPE_MEMORY_RANGE_BARRIER_KHR` (extension 319, offset 5).
pub const STRUCTURE_TYPE_MEMORY_RANGE_BARRIER_KHR: i32 = 1_000_318_005;
/// `VK_STRUCTURE_TYPE_MEMORY_MARKER_INFO_AMD` (extension 319, offset 14).
pub const STRUCTURE_TYPE_MEMORY_MARKER_INFO_AMD: i32 = 1_000_318_014;

/// `VkMemoryRangeBarriersInfoKHR` (VK_KHR_device_address_commands), as
/// vk.xml declares it; newer than ash 0.38.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct MemoryRangeBarriersInfoKHR {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub memory_range_barrier_count: u32,
    pub p_memory_range_barriers: *const MemoryRangeBarrierKHR,
}

/// `VkMemoryRangeBarrierKHR`, as vk.xml declares it.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct MemoryRangeBarrierKHR {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub src_stage_mask: vk::PipelineStageFlags2,
    pub src_access_mask: vk::AccessFlags2,
    pub dst_stage_mask: vk::PipelineStageFlags2,
    pub dst_access_mask: vk::AccessFlags2,
    pub src_queue_family_index: u32,
    pub dst_queue_family_index: u32,
    pub address_range: khr::DeviceAddressRangeKHR,
    pub address_flags: khr::AddressCommandFlagsKHR,
}

/// `VkMemoryMarkerInfoAMD` (`vkCmdWriteMarkerToMemoryAMD`), as vk.xml
/// declares it; newer than ash 0.38.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct MemoryMarkerInfoAMD {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub stage: vk::PipelineStageFlags2,
    pub dst_range: khr::DeviceAddressRangeKHR,
    pub dst_flags: khr::AddressCommandFlagsKHR,
    pub marker: u32,
}

/// A copy of the structure of type `T` at `address`.
///
/// # Safety
/// `address` must point to a readable `T` (its sType said so).
unsafe fn structure<T: Copy>(address: *const c_void) -> T {
    // SAFETY: forwarded from the caller.
    unsafe { *address.cast::<T>() }
}

/// A NUL-terminated string of at most [`MAX_NAME_BYTES`] bytes, lossily
/// decoded; empty for NULL, cut (with a warning) when no NUL comes first.
///
/// # Safety
/// A non-NULL `name` must point to a NUL-terminated string.
unsafe fn name(
    name: *const c_char,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> String {
    if name.is_null() {
        return String::new();
    }
    let mut bytes = Vec::new();
    for i in 0..MAX_NAME_BYTES {
        // SAFETY: the string is NUL-terminated and the loop stops at the
        // NUL, so every byte read is at or before it.
        let byte = unsafe { *name.add(i) } as u8;
        if byte == 0 {
            return String::from_utf8_lossy(&bytes).into_owned();
        }
        bytes.push(byte);
    }
    findings.push(Finding::new(
        &rules::READ_BOUND,
        Severity::Warning,
        function,
        location.to_string(),
        format!(
            "the name is longer than ommcheck reads ({MAX_NAME_BYTES} bytes); the rest is not read"
        ),
    ));
    String::from_utf8_lossy(&bytes).into_owned()
}

/// SPIR-V code counts in 4-byte words (for [`bounded_units`]).
const WORDS: (usize, &str) = (4, " words");

/// The SPIR-V words of a `VkShaderModuleCreateInfo` (`codeSize` bytes at
/// `pCode`; empty for NULL).
///
/// # Safety
/// A non-NULL `pCode` must be readable for `codeSize` bytes, as the API requires.
pub unsafe fn shader_module_code(
    info: &vk::ShaderModuleCreateInfo<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> Vec<u32> {
    if info.p_code.is_null() {
        return Vec::new();
    }
    let words = bounded_units(
        info.code_size,
        WORDS,
        "bytes of code",
        function,
        format!("{location}.codeSize"),
        findings,
    );
    // SAFETY: `pCode` is a `uint32_t*` readable for `codeSize` bytes (the
    // caller's guarantee), and `words * 4 <= codeSize`.
    unsafe { std::slice::from_raw_parts(info.p_code, words) }.to_vec()
}

/// The values a `VkSpecializationInfo` maps its constants to
/// ([`SpecializationValue::all`]).
///
/// # Safety
/// A non-NULL `info` must point to a `VkSpecializationInfo` whose arrays are
/// valid for their counts and sizes, as the API requires.
unsafe fn specialization(
    info: *const vk::SpecializationInfo<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> Vec<SpecializationValue> {
    // SAFETY: forwarded from the caller.
    let Some(info) = (unsafe { info.as_ref() }) else {
        return Vec::new();
    };
    // SAFETY: forwarded from the caller.
    let info = unsafe { specialization_info(info, function, location, findings) };
    SpecializationValue::all(&info)
}

/// Reads a `VkPipelineShaderStageCreateInfo`, with the code of a
/// `VkShaderModuleCreateInfo` chained to it.
///
/// # Safety
/// `stage` must be valid as the API requires: `pName` NUL-terminated, its
/// specialization info and pNext chain well formed (cycles and length are tolerated).
pub unsafe fn shader_stage(
    stage: &vk::PipelineShaderStageCreateInfo<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> ShaderStage {
    let mut code = None;
    // SAFETY: forwarded from the caller.
    for link in unsafe { chain(stage.p_next, function, location, findings) } {
        if link.s_type == vk::StructureType::SHADER_MODULE_CREATE_INFO.as_raw() {
            // SAFETY: the sType says the structure is a VkShaderModuleCreateInfo.
            let info: vk::ShaderModuleCreateInfo<'_> = unsafe { structure(link.address) };
            let at = format!("{location}.pNext<VkShaderModuleCreateInfo>");
            // SAFETY: its code is readable for codeSize bytes (the caller's guarantee).
            code = Some(unsafe { shader_module_code(&info, function, &at, findings) });
        }
    }
    ShaderStage {
        stage: stage.stage.as_raw(),
        module: vk::Handle::as_raw(stage.module),
        // SAFETY: forwarded from the caller.
        name: unsafe {
            name(
                stage.p_name,
                function,
                &format!("{location}.pName"),
                findings,
            )
        },
        code,
        // SAFETY: forwarded from the caller.
        specialization: unsafe {
            specialization(
                stage.p_specialization_info,
                function,
                &format!("{location}.pSpecializationInfo"),
                findings,
            )
        },
    }
}

/// Reads each of `count` elements of the array `member` at `array` with
/// `read`, which gets the element's location (`member[i]`); NULL reads as none.
///
/// # Safety
/// A non-NULL `array` must point to `count` readable elements, each valid
/// as `read` requires.
unsafe fn each<T, R>(
    array: *const T,
    count: u32,
    function: &'static str,
    member: &str,
    findings: &mut Vec<Finding>,
    mut read: impl FnMut(&T, &str, &mut Vec<Finding>) -> R,
) -> Vec<R> {
    if array.is_null() {
        return Vec::new();
    }
    let len = bounded_len(count, function, member, findings);
    // SAFETY: `count` elements are readable (the caller's guarantee); `len <= count`.
    let list = unsafe { std::slice::from_raw_parts(array, len) };
    list.iter()
        .enumerate()
        .map(|(i, element)| read(element, &format!("{member}[{i}]"), findings))
        .collect()
}

/// Reads `count` shader stages (NULL reads as none).
///
/// # Safety
/// A non-NULL `stages` must point to `count` stages valid as for [`shader_stage`].
unsafe fn shader_stages(
    stages: *const vk::PipelineShaderStageCreateInfo<'_>,
    count: u32,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> Vec<ShaderStage> {
    let member = format!("{location}.pStages");
    // SAFETY: forwarded from the caller (each stage valid for `shader_stage`).
    unsafe {
        each(
            stages,
            count,
            function,
            &member,
            findings,
            |stage, at, findings| shader_stage(stage, function, at, findings),
        )
    }
}

/// `flags` with the `VkPipelineCreateFlags2CreateInfo` and the
/// `VkPipelineLibraryCreateInfoKHR` of a pipeline create info's pNext chain.
///
/// # Safety
/// The chain at `next` must be well formed (cycles and length are
/// tolerated), a chained library info valid for its count.
unsafe fn flags_and_chained_libraries(
    flags: vk::PipelineCreateFlags,
    next: *const c_void,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> (PipelineCreateFlags, Option<Vec<Handle>>) {
    let mut create_flags = PipelineCreateFlags {
        flags: flags.as_raw(),
        flags2: None,
    };
    let mut chained_libraries = None;
    // SAFETY: forwarded from the caller.
    for link in unsafe { chain(next, function, location, findings) } {
        let s_type = vk::StructureType::from_raw(link.s_type);
        if s_type == vk::StructureType::PIPELINE_CREATE_FLAGS_2_CREATE_INFO_KHR {
            // SAFETY: the sType names the structure.
            let info = unsafe {
                &*link
                    .address
                    .cast::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>()
            };
            create_flags.flags2 = Some(PipelineCreateFlags2CreateInfo::from_members(info).flags);
        } else if s_type == vk::StructureType::PIPELINE_LIBRARY_CREATE_INFO_KHR {
            let at = location.text(".pNext<VkPipelineLibraryCreateInfoKHR>");
            // SAFETY: the sType names the structure, whose array is valid
            // for its count (the caller's guarantee).
            let info = unsafe {
                pipeline_library_create_info(&*link.address.cast(), function, at, findings)
            };
            chained_libraries = Some(info.libraries);
        }
    }
    (create_flags, chained_libraries)
}

/// Reads a `VkComputePipelineCreateInfo` (its one stage is `stage`).
///
/// # Safety
/// `info` must be valid as `vkCreateComputePipelines` requires (chains
/// well formed; cycles and length are tolerated).
pub unsafe fn compute_pipeline_info(
    info: &vk::ComputePipelineCreateInfo<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> PipelineCreateInfo {
    // SAFETY: forwarded from the caller.
    let (flags, _) = unsafe {
        flags_and_chained_libraries(info.flags, info.p_next, function, location, findings)
    };
    // SAFETY: forwarded from the caller.
    let stage = unsafe {
        shader_stage(
            &info.stage,
            function,
            &format!("{location}.stage"),
            findings,
        )
    };
    PipelineCreateInfo {
        flags,
        stages: vec![stage],
        libraries: None,
    }
}

/// A pipeline create info with `flags`, `pNext` and `pStages`.
pub trait StagedCreateInfo {
    fn parts(
        &self,
    ) -> (
        vk::PipelineCreateFlags,
        *const c_void,
        *const vk::PipelineShaderStageCreateInfo<'_>,
        u32,
    );
}

macro_rules! staged_create_info {
    ($($ty:ty),*) => {$(
        impl StagedCreateInfo for $ty {
            fn parts(
                &self,
            ) -> (
                vk::PipelineCreateFlags,
                *const c_void,
                *const vk::PipelineShaderStageCreateInfo<'_>,
                u32,
            ) {
                (self.flags, self.p_next, self.p_stages, self.stage_count)
            }
        }
    )*};
}

staged_create_info!(
    vk::GraphicsPipelineCreateInfo<'_>,
    vk::RayTracingPipelineCreateInfoKHR<'_>,
    vk::RayTracingPipelineCreateInfoNV<'_>
);

/// Reads a `VkGraphicsPipelineCreateInfo` (flags, stages, a chained
/// `VkPipelineLibraryCreateInfoKHR`) or a `VkRayTracingPipelineCreateInfoNV`
/// (flags and stages; NV pipelines have no libraries).
///
/// # Safety
/// `info` must be valid as its `vkCreate*Pipelines` requires: arrays valid
/// for their counts, chains well formed (cycles and length are tolerated).
pub unsafe fn staged_pipeline_info<T: StagedCreateInfo>(
    info: &T,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> PipelineCreateInfo {
    let (flags, next, stages, stage_count) = info.parts();
    // SAFETY: forwarded from the caller.
    let (flags, libraries) =
        unsafe { flags_and_chained_libraries(flags, next, function, location, findings) };
    PipelineCreateInfo {
        flags,
        // SAFETY: forwarded from the caller.
        stages: unsafe { shader_stages(stages, stage_count, function, location, findings) },
        libraries,
    }
}

/// Reads a `VkRayTracingPipelineCreateInfoKHR`: flags, stages and
/// `pLibraryInfo` (where its libraries are; a chained library info is not).
///
/// # Safety
/// `info` must be valid as `vkCreateRayTracingPipelinesKHR` requires.
pub unsafe fn ray_tracing_pipeline_info_khr(
    info: &vk::RayTracingPipelineCreateInfoKHR<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> PipelineCreateInfo {
    // SAFETY: forwarded from the caller.
    let read = unsafe { staged_pipeline_info(info, function, location, findings) };
    // SAFETY: a non-NULL pLibraryInfo points to a valid structure (the caller's guarantee).
    let libraries = unsafe { info.p_library_info.as_ref() }.map(|library_info| {
        let at = location.text(".pLibraryInfo");
        // SAFETY: forwarded from the caller.
        unsafe { pipeline_library_create_info(library_info, function, at, findings) }.libraries
    });
    PipelineCreateInfo { libraries, ..read }
}

/// A reader of one structure at a location (the pipeline create infos
/// above, [`dependency_info`]).
pub type StructReader<T, R> = unsafe fn(&T, &'static str, &str, &mut Vec<Finding>) -> R;

/// Reads `count` structures of the array parameter `member` (e.g.
/// `pCreateInfos`) at `array` with `read`; NULL reads as none.
///
/// # Safety
/// A non-NULL `array` must point to `count` structures valid as `read` requires.
pub unsafe fn structs<T, R>(
    array: *const T,
    count: u32,
    member: &str,
    read: StructReader<T, R>,
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> Vec<R> {
    // SAFETY: forwarded from the caller (each structure valid for `read`).
    unsafe {
        each(
            array,
            count,
            function,
            member,
            findings,
            |info, at, findings| read(info, function, at, findings),
        )
    }
}

/// Reads `count` `VkShaderCreateInfoEXT` (NULL reads as none). SPIR-V code
/// becomes words (read byte by byte, so an unaligned `pCode` is no
/// problem); other code types keep no code.
///
/// # Safety
/// A non-NULL `infos` must point to `count` structures valid as
/// `vkCreateShadersEXT` requires: `pCode` readable for `codeSize` bytes,
/// `pName` NUL-terminated, specialization info valid.
pub unsafe fn shader_create_infos(
    infos: *const vk::ShaderCreateInfoEXT<'_>,
    count: u32,
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> Vec<ShaderCreateInfo> {
    // SAFETY: forwarded from the caller.
    unsafe {
        each(
            infos,
            count,
            function,
            "pCreateInfos",
            findings,
            |info, at, findings| {
                let code_type = info.code_type.as_raw();
                let code = if code_type == SHADER_CODE_TYPE_SPIRV && !info.p_code.is_null() {
                    let words = bounded_units(
                        info.code_size,
                        WORDS,
                        "bytes of code",
                        function,
                        format!("{at}.codeSize"),
                        findings,
                    );
                    // SAFETY: `pCode` is readable for `codeSize` bytes (the caller's
                    // guarantee) and `words * 4 <= codeSize`.
                    let bytes = std::slice::from_raw_parts(info.p_code.cast::<u8>(), words * 4);
                    bytes
                        .chunks_exact(4)
                        .map(|w| u32::from_ne_bytes([w[0], w[1], w[2], w[3]]))
                        .collect()
                } else {
                    Vec::new()
                };
                ShaderCreateInfo {
                    flags: info.flags.as_raw(),
                    stage: info.stage.as_raw(),
                    code_type,
                    code,
                    name: name(info.p_name, function, &format!("{at}.pName"), findings),
                    specialization: specialization(
                        info.p_specialization_info,
                        function,
                        &format!("{at}.pSpecializationInfo"),
                        findings,
                    ),
                }
            },
        )
    }
}

/// A barrier structure: the four masks the micromap rules read.
trait BarrierMasks {
    fn masks(&self) -> Barrier;
}

macro_rules! barrier_masks {
    ($($ty:ty),*) => {$(
        impl BarrierMasks for $ty {
            fn masks(&self) -> Barrier {
                Barrier {
                    src_stage_mask: self.src_stage_mask.as_raw(),
                    src_access_mask: self.src_access_mask.as_raw(),
                    dst_stage_mask: self.dst_stage_mask.as_raw(),
                    dst_access_mask: self.dst_access_mask.as_raw(),
                }
            }
        }
    )*};
}

barrier_masks!(
    vk::MemoryBarrier2<'_>,
    vk::BufferMemoryBarrier2<'_>,
    vk::ImageMemoryBarrier2<'_>,
    MemoryRangeBarrierKHR
);

/// The masks of each barrier read (none for a NULL array).
fn barriers<T: BarrierMasks>(list: Option<Vec<T>>) -> Vec<Barrier> {
    list.unwrap_or_default().iter().map(T::masks).collect()
}

/// Reads a `VkDependencyInfo`, with the range barriers of a chained
/// `VkMemoryRangeBarriersInfoKHR`.
///
/// # Safety
/// `info` must be valid as the API requires: its arrays valid for their
/// counts, its pNext chain well formed (cycles and length are tolerated).
pub unsafe fn dependency_info(
    info: &vk::DependencyInfo<'_>,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> DependencyInfo {
    // SAFETY (the three arrays): each holds its count of elements (the caller's guarantee).
    let memory = unsafe {
        read_array(
            info.p_memory_barriers,
            info.memory_barrier_count,
            function,
            &format!("{location}.pMemoryBarriers"),
            findings,
        )
    };
    let buffer = unsafe {
        read_array(
            info.p_buffer_memory_barriers,
            info.buffer_memory_barrier_count,
            function,
            &format!("{location}.pBufferMemoryBarriers"),
            findings,
        )
    };
    let image = unsafe {
        read_array(
            info.p_image_memory_barriers,
            info.image_memory_barrier_count,
            function,
            &format!("{location}.pImageMemoryBarriers"),
            findings,
        )
    };
    let mut memory_range_barriers = Vec::new();
    // SAFETY: forwarded from the caller.
    for link in unsafe { chain(info.p_next, function, location, findings) } {
        if link.s_type != STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR {
            continue;
        }
        // SAFETY: the sType names the structure.
        let ranges: MemoryRangeBarriersInfoKHR = unsafe { structure(link.address) };
        let at = format!("{location}.pNext<VkMemoryRangeBarriersInfoKHR>.pMemoryRangeBarriers");
        // SAFETY: the array holds its count of elements (the caller's guarantee).
        let list = unsafe {
            read_array(
                ranges.p_memory_range_barriers,
                ranges.memory_range_barrier_count,
                function,
                &at,
                findings,
            )
        };
        memory_range_barriers.extend(barriers(list));
    }
    DependencyInfo {
        memory_barriers: barriers(memory),
        buffer_memory_barriers: barriers(buffer),
        image_memory_barriers: barriers(image),
        memory_range_barriers,
    }
}

/// Reads the semaphore operations of `count` `VkSubmitInfo2` (NULL reads as none).
///
/// # Safety
/// A non-NULL `submits` must point to `count` structures whose semaphore
/// arrays are valid for their counts, each structure's pNext chain well
/// formed (cycles and length are tolerated).
pub unsafe fn submit_infos(
    submits: *const vk::SubmitInfo2<'_>,
    count: u32,
    function: &'static str,
    findings: &mut Vec<Finding>,
) -> Vec<SubmitInfo2> {
    let semaphores = |infos, count, member: &str, findings: &mut Vec<Finding>| {
        // SAFETY: called below with a submit's semaphore array and its
        // count, which hold that many valid structures (the caller's guarantee).
        unsafe {
            each(
                infos,
                count,
                function,
                member,
                findings,
                |info, at, findings| semaphore_submit_info(info, function, at, findings),
            )
        }
    };
    // SAFETY: forwarded from the caller.
    unsafe {
        each(
            submits,
            count,
            function,
            "pSubmits",
            findings,
            |submit, at, findings| SubmitInfo2 {
                wait_semaphore_infos: semaphores(
                    submit.p_wait_semaphore_infos,
                    submit.wait_semaphore_info_count,
                    &format!("{at}.pWaitSemaphoreInfos"),
                    findings,
                ),
                signal_semaphore_infos: semaphores(
                    submit.p_signal_semaphore_infos,
                    submit.signal_semaphore_info_count,
                    &format!("{at}.pSignalSemaphoreInfos"),
                    findings,
                ),
            },
        )
    }
}

/// Reads a `VkMemoryMarkerInfoAMD`.
pub fn memory_marker_info(info: &MemoryMarkerInfoAMD) -> MemoryMarkerInfo {
    MemoryMarkerInfo {
        stage: info.stage.as_raw(),
        dst_address: info.dst_range.address,
        marker: info.marker,
    }
}

/// The structures of a feature or property pNext chain
/// (`VkDeviceCreateInfo`, `VkPhysicalDeviceProperties2`) as the feature
/// checks take them. A structure is known only by its sType here, so a
/// micromap structure given a wrong sType reads as another structure: the
/// `sType-sType` rules of chained structures cannot be decided from memory.
///
/// # Safety
/// The chain at `next` must be well formed (cycles and length are tolerated).
pub unsafe fn feature_chain(
    next: *const c_void,
    function: &'static str,
    location: &str,
    findings: &mut Vec<Finding>,
) -> Vec<ChainedStruct> {
    // SAFETY: forwarded from the caller.
    unsafe { chain(next, function, location, findings) }
        .into_iter()
        .map(|link| match MicromapStruct::from_s_type(link.s_type) {
            Some(which) => ChainedStruct::micromap(which),
            None => ChainedStruct::Other(link.s_type),
        })
        .collect()
}

/// `base` with the limits the property structures of a filled
/// `VkPhysicalDeviceProperties2` chain report. Where both the EXT and the
/// KHR opacity micromap properties report a subdivision level, the larger
/// is kept (the checks have one limit for both, and a layer must not reject
/// what one of the two APIs allows). A value below what the specification
/// requires of every device (0 from a driver that fills nothing, as the
/// Khronos mock driver does) is taken as not reported, and `base` keeps its
/// value.
///
/// # Safety
/// The chain at `next` must be well formed and filled by the implementation.
pub unsafe fn reported_limits(next: *const c_void, base: &Limits) -> Limits {
    let mut limits = base.clone();
    let mut subdivision: Option<(u32, u32)> = None;
    let mut merge = |two: u32, four: u32| {
        let (old_two, old_four) = subdivision.unwrap_or((0, 0));
        subdivision = Some((old_two.max(two), old_four.max(four)));
    };
    // SAFETY: forwarded from the caller; the findings (a cut chain) are not
    // the application's: the layer builds this chain itself.
    for link in unsafe {
        chain(
            next,
            "vkGetPhysicalDeviceProperties2",
            "pProperties",
            &mut Vec::new(),
        )
    } {
        let s_type = vk::StructureType::from_raw(link.s_type);
        // SAFETY (every arm): the sType names the structure at `link.address`.
        if s_type == vk::StructureType::PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_EXT {
            let p: vk::PhysicalDeviceOpacityMicromapPropertiesEXT<'_> =
                unsafe { structure(link.address) };
            merge(
                p.max_opacity2_state_subdivision_level,
                p.max_opacity4_state_subdivision_level,
            );
        } else if s_type == khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_KHR {
            let p: khr::PhysicalDeviceOpacityMicromapPropertiesKHR =
                unsafe { structure(link.address) };
            merge(
                p.max_opacity2_state_subdivision_level,
                p.max_opacity4_state_subdivision_level,
            );
            limits.max_opacity_lossy4_state_subdivision_level =
                p.max_opacity_lossy4_state_subdivision_level;
            limits.max_micromap_triangles = p.max_micromap_triangles;
        } else if s_type == vk::StructureType::PHYSICAL_DEVICE_DISPLACEMENT_MICROMAP_PROPERTIES_NV {
            let p: vk::PhysicalDeviceDisplacementMicromapPropertiesNV<'_> =
                unsafe { structure(link.address) };
            limits.max_displacement_micromap_subdivision_level =
                p.max_displacement_micromap_subdivision_level;
        } else if s_type == vk::StructureType::PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR
        {
            let p: vk::PhysicalDeviceAccelerationStructurePropertiesKHR<'_> =
                unsafe { structure(link.address) };
            limits.min_acceleration_structure_scratch_offset_alignment =
                p.min_acceleration_structure_scratch_offset_alignment;
        }
    }
    if let Some((two, four)) = subdivision {
        limits.max_opacity2_state_subdivision_level = two;
        limits.max_opacity4_state_subdivision_level = four;
    }
    // What the specification requires of every device; below it, a value
    // was not really reported.
    let minimum = crate::device::Profile::SpecMinimum.limits();
    let keep = |reported: u64, required: u64, base: u64| {
        if reported >= required {
            reported
        } else {
            base
        }
    };
    let keep32 = |reported: u32, required: u32, base: u32| {
        u32::try_from(keep(reported.into(), required.into(), base.into())).unwrap_or(base)
    };
    limits.max_opacity2_state_subdivision_level = keep32(
        limits.max_opacity2_state_subdivision_level,
        minimum.max_opacity2_state_subdivision_level,
        base.max_opacity2_state_subdivision_level,
    );
    limits.max_opacity4_state_subdivision_level = keep32(
        limits.max_opacity4_state_subdivision_level,
        minimum.max_opacity4_state_subdivision_level,
        base.max_opacity4_state_subdivision_level,
    );
    limits.max_opacity_lossy4_state_subdivision_level = keep32(
        limits.max_opacity_lossy4_state_subdivision_level,
        minimum.max_opacity_lossy4_state_subdivision_level,
        base.max_opacity_lossy4_state_subdivision_level,
    );
    limits.max_displacement_micromap_subdivision_level = keep32(
        limits.max_displacement_micromap_subdivision_level,
        minimum.max_displacement_micromap_subdivision_level,
        base.max_displacement_micromap_subdivision_level,
    );
    limits.max_micromap_triangles = keep(
        limits.max_micromap_triangles,
        minimum.max_micromap_triangles,
        base.max_micromap_triangles,
    );
    // A scratch alignment is a power of two no larger than 256.
    let alignment = limits.min_acceleration_structure_scratch_offset_alignment;
    if !alignment.is_power_of_two() || alignment > 256 {
        limits.min_acceleration_structure_scratch_offset_alignment =
            base.min_acceleration_structure_scratch_offset_alignment;
    }
    limits
}

/// Reads `count` handles of the array `member` (NULL reads as none).
///
/// # Safety
/// A non-NULL `array` must point to `count` handles.
pub unsafe fn handles<H: vk::Handle + Copy>(
    array: *const H,
    count: u32,
    function: &'static str,
    member: &str,
    findings: &mut Vec<Finding>,
) -> Vec<Handle> {
    // SAFETY: forwarded from the caller.
    unsafe { read_array(array, count, function, member, findings) }
        .unwrap_or_default()
        .into_iter()
        .map(vk::Handle::as_raw)
        .collect()
}

/// Reads `count` `VkShaderStageFlags` of the array `member` (NULL reads as none).
///
/// # Safety
/// A non-NULL `array` must point to `count` flags.
pub unsafe fn stage_flags(
    array: *const vk::ShaderStageFlags,
    count: u32,
    function: &'static str,
    member: &str,
    findings: &mut Vec<Finding>,
) -> Vec<u32> {
    // SAFETY: forwarded from the caller.
    unsafe { read_array(array, count, function, member, findings) }
        .unwrap_or_default()
        .into_iter()
        .map(vk::ShaderStageFlags::as_raw)
        .collect()
}

/// Whether a `VkDescriptorType` holds acceleration structures (KHR or NV).
fn holds_acceleration_structures(ty: vk::DescriptorType) -> bool {
    ty == vk::DescriptorType::ACCELERATION_STRUCTURE_KHR
        || ty == vk::DescriptorType::ACCELERATION_STRUCTURE_NV
}

/// The acceleration-structure bindings of a `VkDescriptorSetLayoutCreateInfo`:
/// `(binding, stageFlags)`.
///
/// # Safety
/// `pBindings` must be NULL or hold `bindingCount` bindings.
pub unsafe fn acceleration_structure_bindings(
    info: &vk::DescriptorSetLayoutCreateInfo<'_>,
    findings: &mut Vec<Finding>,
) -> Vec<(u32, u32)> {
    // SAFETY: forwarded from the caller.
    unsafe {
        read_array(
            info.p_bindings,
            info.binding_count,
            "vkCreateDescriptorSetLayout",
            "pCreateInfo->pBindings",
            findings,
        )
    }
    .unwrap_or_default()
    .iter()
    .filter(|b| holds_acceleration_structures(b.descriptor_type))
    .map(|b| (b.binding, b.stage_flags.as_raw()))
    .collect()
}

/// Acceleration structures one `VkWriteDescriptorSet` writes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AccelerationStructureWrite {
    pub dst_set: Handle,
    pub dst_binding: u32,
    pub dst_array_element: u32,
    /// From the chained `VkWriteDescriptorSetAccelerationStructure{KHR,NV}`.
    pub structures: Vec<Handle>,
}

/// The acceleration-structure writes among `count` `VkWriteDescriptorSet`
/// (other descriptor types are left out; NULL reads as none).
///
/// # Safety
/// A non-NULL `writes` must point to `count` structures valid as
/// `vkUpdateDescriptorSets` requires (chains well formed, arrays valid).
pub unsafe fn acceleration_structure_writes(
    writes: *const vk::WriteDescriptorSet<'_>,
    count: u32,
    findings: &mut Vec<Finding>,
) -> Vec<AccelerationStructureWrite> {
    let function = "vkUpdateDescriptorSets";
    // SAFETY: forwarded from the caller.
    let all = unsafe {
        each(
            writes,
            count,
            function,
            "pDescriptorWrites",
            findings,
            |write, at, findings| {
                if !holds_acceleration_structures(write.descriptor_type) {
                    return None;
                }
                let mut structures = Vec::new();
                for link in chain(write.p_next, function, at, findings) {
                    let s_type = vk::StructureType::from_raw(link.s_type);
                    // Both structures are {sType, pNext, count, handles}; the
                    // sType says which.
                    let (count, array) = if s_type
                        == vk::StructureType::WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR
                    {
                        let w: vk::WriteDescriptorSetAccelerationStructureKHR<'_> =
                            structure(link.address);
                        (
                            w.acceleration_structure_count,
                            w.p_acceleration_structures.cast::<u64>(),
                        )
                    } else if s_type
                        == vk::StructureType::WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_NV
                    {
                        let w: vk::WriteDescriptorSetAccelerationStructureNV<'_> =
                            structure(link.address);
                        (
                            w.acceleration_structure_count,
                            w.p_acceleration_structures.cast::<u64>(),
                        )
                    } else {
                        continue;
                    };
                    let member = format!("{at}.pNext.pAccelerationStructures");
                    structures.extend(
                        read_array(array, count, function, &member, findings).unwrap_or_default(),
                    );
                }
                Some(AccelerationStructureWrite {
                    dst_set: vk::Handle::as_raw(write.dst_set),
                    dst_binding: write.dst_binding,
                    dst_array_element: write.dst_array_element,
                    structures,
                })
            },
        )
    };
    all.into_iter().flatten().collect()
}

/// One `VkCopyDescriptorSet`: (srcSet, srcBinding, srcArrayElement), (dstSet,
/// dstBinding, dstArrayElement), descriptorCount.
pub type DescriptorCopy = ((Handle, u32, u32), (Handle, u32, u32), u32);

/// Reads `count` `VkCopyDescriptorSet` (NULL reads as none).
///
/// # Safety
/// A non-NULL `copies` must point to `count` structures.
pub unsafe fn descriptor_copies(
    copies: *const vk::CopyDescriptorSet<'_>,
    count: u32,
    findings: &mut Vec<Finding>,
) -> Vec<DescriptorCopy> {
    // SAFETY: forwarded from the caller.
    unsafe {
        read_array(
            copies,
            count,
            "vkUpdateDescriptorSets",
            "pDescriptorCopies",
            findings,
        )
    }
    .unwrap_or_default()
    .iter()
    .map(|c| {
        (
            (
                vk::Handle::as_raw(c.src_set),
                c.src_binding,
                c.src_array_element,
            ),
            (
                vk::Handle::as_raw(c.dst_set),
                c.dst_binding,
                c.dst_array_element,
            ),
            c.descriptor_count,
        )
    })
    .collect()
}

#[cfg(test)]
mod tests {
    use std::mem::{align_of, offset_of, size_of};

    use super::*;
    use crate::checks::pipeline_sync::spirv::build::TestModule;
    use crate::model::pipeline::{
        ACCESS_MICROMAP_WRITE, CREATE_RAY_TRACING_OPACITY_MICROMAP, STAGE_MICROMAP_BUILD,
    };
    use crate::raw::MAX_ELEMENTS;
    use crate::{Device, Profile, Validator};

    /// Offsets and sizes from vk.xml's member lists with C layout on a
    /// 64-bit target.
    #[test]
    #[cfg(target_pointer_width = "64")]
    fn declared_structures_match_the_c_layout() {
        assert_eq!(size_of::<MemoryRangeBarriersInfoKHR>(), 32);
        assert_eq!(align_of::<MemoryRangeBarriersInfoKHR>(), 8);
        assert_eq!(
            offset_of!(MemoryRangeBarriersInfoKHR, memory_range_barrier_count),
            16
        );
        assert_eq!(
            offset_of!(MemoryRangeBarriersInfoKHR, p_memory_range_barriers),
            24
        );
        assert_eq!(size_of::<MemoryRangeBarrierKHR>(), 80);
        assert_eq!(align_of::<MemoryRangeBarrierKHR>(), 8);
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, src_stage_mask), 16);
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, src_access_mask), 24);
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, dst_stage_mask), 32);
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, dst_access_mask), 40);
        assert_eq!(
            offset_of!(MemoryRangeBarrierKHR, src_queue_family_index),
            48
        );
        assert_eq!(
            offset_of!(MemoryRangeBarrierKHR, dst_queue_family_index),
            52
        );
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, address_range), 56);
        assert_eq!(offset_of!(MemoryRangeBarrierKHR, address_flags), 72);
        assert_eq!(size_of::<MemoryMarkerInfoAMD>(), 48);
        assert_eq!(offset_of!(MemoryMarkerInfoAMD, stage), 16);
        assert_eq!(offset_of!(MemoryMarkerInfoAMD, dst_range), 24);
        assert_eq!(offset_of!(MemoryMarkerInfoAMD, dst_flags), 40);
        assert_eq!(offset_of!(MemoryMarkerInfoAMD, marker), 44);
    }

    #[test]
    fn structure_types_follow_the_extension_number() {
        // VK_KHR_device_address_commands is extension 319: base 1000318000.
        assert_eq!(STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR, 1_000_318_004);
        assert_eq!(STRUCTURE_TYPE_MEMORY_RANGE_BARRIER_KHR, 1_000_318_005);
        assert_eq!(STRUCTURE_TYPE_MEMORY_MARKER_INFO_AMD, 1_000_318_014);
    }

    #[test]
    fn a_stage_reads_chained_code_name_and_specialization() {
        let words = TestModule {
            capability: true,
            ..Default::default()
        }
        .words();
        let code = vk::ShaderModuleCreateInfo::default().code(&words);
        let mut code = code;
        let entries = [
            vk::SpecializationMapEntry {
                constant_id: 7,
                offset: 4,
                size: 4,
            },
            // Past dataSize: left out.
            vk::SpecializationMapEntry {
                constant_id: 8,
                offset: 6,
                size: 4,
            },
        ];
        let data = [0u8, 0, 0, 0, 0x00, 0x04, 0, 0];
        let specialization = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(&data);
        // Chained by hand: ash 0.38's push_next breaks Stacked Borrows (it
        // keeps a shared pointer across a `&mut` reborrow), which Miri reports.
        let mut stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::RAYGEN_KHR)
            .name(c"main")
            .specialization_info(&specialization);
        stage.p_next = (&raw mut code).cast();
        let mut findings = Vec::new();
        // SAFETY: everything `stage` points to is alive.
        let read = unsafe { shader_stage(&stage, "f", "pStages[0]", &mut findings) };
        assert!(findings.is_empty());
        assert_eq!(read.stage, vk::ShaderStageFlags::RAYGEN_KHR.as_raw());
        assert_eq!(read.name, "main");
        assert_eq!(read.code.as_deref(), Some(&words[..]));
        assert_eq!(
            read.specialization,
            [SpecializationValue {
                constant_id: 7,
                value: 0x400
            }]
        );
    }

    #[test]
    fn flags2_and_libraries_come_from_the_chain() {
        let libraries = [<vk::Pipeline as vk::Handle>::from_raw(0x11)];
        let mut library_info = vk::PipelineLibraryCreateInfoKHR::default().libraries(&libraries);
        let mut flags2 = vk::PipelineCreateFlags2CreateInfoKHR::default().flags(
            vk::PipelineCreateFlags2KHR::from_raw(CREATE_RAY_TRACING_OPACITY_MICROMAP),
        );
        // Chained by hand: ash 0.38's push_next breaks Stacked Borrows (it
        // keeps a shared pointer across a `&mut` reborrow), which Miri reports.
        flags2.p_next = (&raw mut library_info).cast();
        let mut graphics =
            vk::GraphicsPipelineCreateInfo::default().flags(vk::PipelineCreateFlags::LIBRARY_KHR);
        graphics.p_next = (&raw mut flags2).cast();
        let mut findings = Vec::new();
        // SAFETY: the chain and arrays are alive; no stages.
        let read =
            unsafe { staged_pipeline_info(&graphics, "f", "pCreateInfos[0]", &mut findings) };
        assert!(findings.is_empty());
        assert_eq!(read.flags.effective(), CREATE_RAY_TRACING_OPACITY_MICROMAP);
        assert_eq!(read.libraries, Some(vec![0x11]));
        assert!(read.stages.is_empty());

        let library_info = vk::PipelineLibraryCreateInfoKHR::default().libraries(&libraries);
        let rt = vk::RayTracingPipelineCreateInfoKHR::default().library_info(&library_info);
        // SAFETY: as above.
        let read = unsafe { ray_tracing_pipeline_info_khr(&rt, "f", "x", &mut findings) };
        assert_eq!(
            (read.libraries, read.flags.flags2),
            (Some(vec![0x11]), None)
        );
        let plain = vk::RayTracingPipelineCreateInfoKHR::default();
        // SAFETY: no pointers.
        let read = unsafe { ray_tracing_pipeline_info_khr(&plain, "f", "x", &mut findings) };
        assert_eq!(read.libraries, None);
    }

    #[test]
    fn absurd_counts_and_null_arrays_are_bounded() {
        let mut findings = Vec::new();
        // SAFETY: NULL arrays are not read.
        let infos = unsafe {
            structs(
                std::ptr::null::<vk::ComputePipelineCreateInfo<'_>>(),
                u32::MAX,
                "pCreateInfos",
                compute_pipeline_info,
                "f",
                &mut findings,
            )
        };
        assert!(infos.is_empty() && findings.is_empty());
        let graphics = vk::GraphicsPipelineCreateInfo {
            stage_count: 3,
            ..Default::default()
        };
        // SAFETY: pStages is NULL.
        let read = unsafe { staged_pipeline_info(&graphics, "f", "x", &mut findings) };
        assert!(read.stages.is_empty());
        assert_eq!(
            bounded_units(usize::MAX, WORDS, "bytes of code", "f", "x", &mut findings),
            MAX_ELEMENTS
        );
        assert_eq!(findings[0].rule.as_str(), rules::READ_BOUND.id);
    }

    #[test]
    fn a_long_name_is_cut_and_reported() {
        let long = vec![b'a'; MAX_NAME_BYTES + 8];
        let mut with_nul = long.clone();
        with_nul.push(0);
        let mut findings = Vec::new();
        // SAFETY: `with_nul` is NUL-terminated.
        let read = unsafe { name(with_nul.as_ptr().cast(), "f", "pName", &mut findings) };
        assert_eq!(read.len(), MAX_NAME_BYTES);
        assert_eq!(findings.len(), 1);
    }

    #[test]
    fn shader_objects_read_unaligned_spirv_bytes() {
        let words = TestModule::default().words();
        let mut bytes = vec![0u8];
        bytes.extend(words.iter().flat_map(|w| w.to_ne_bytes()));
        let info = vk::ShaderCreateInfoEXT {
            code_type: vk::ShaderCodeTypeEXT::SPIRV,
            code_size: words.len() * 4,
            p_code: bytes[1..].as_ptr().cast(),
            p_name: c"main".as_ptr(),
            flags: vk::ShaderCreateFlagsEXT::from_raw(0x1000),
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: one live structure whose code and name are alive.
        let read = unsafe { shader_create_infos(&info, 1, "f", &mut findings) };
        assert_eq!(read.len(), 1);
        assert_eq!(read[0].code, words);
        assert_eq!((read[0].name.as_str(), read[0].flags), ("main", 0x1000));
    }

    #[test]
    fn dependency_info_reads_range_barriers_from_the_chain() {
        let range = MemoryRangeBarrierKHR {
            s_type: vk::StructureType::from_raw(STRUCTURE_TYPE_MEMORY_RANGE_BARRIER_KHR),
            p_next: std::ptr::null(),
            src_stage_mask: vk::PipelineStageFlags2::from_raw(STAGE_MICROMAP_BUILD),
            src_access_mask: vk::AccessFlags2::from_raw(ACCESS_MICROMAP_WRITE),
            dst_stage_mask: vk::PipelineStageFlags2::ALL_COMMANDS,
            dst_access_mask: vk::AccessFlags2::SHADER_READ,
            src_queue_family_index: 0,
            dst_queue_family_index: 0,
            address_range: khr::DeviceAddressRangeKHR::default(),
            address_flags: khr::AddressCommandFlagsKHR::default(),
        };
        let ranges = MemoryRangeBarriersInfoKHR {
            s_type: vk::StructureType::from_raw(STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR),
            p_next: std::ptr::null(),
            memory_range_barrier_count: 1,
            p_memory_range_barriers: &range,
        };
        let memory = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::from_raw(ACCESS_MICROMAP_WRITE))];
        let info = vk::DependencyInfo {
            p_next: (&ranges as *const MemoryRangeBarriersInfoKHR).cast(),
            ..vk::DependencyInfo::default().memory_barriers(&memory)
        };
        let mut findings = Vec::new();
        // SAFETY: the chain and arrays are alive.
        let read = unsafe { dependency_info(&info, "f", "pDependencyInfo", &mut findings) };
        assert!(findings.is_empty());
        assert_eq!(read.memory_barriers.len(), 1);
        assert_eq!(
            read.memory_range_barriers[0].src_stage_mask,
            STAGE_MICROMAP_BUILD
        );
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        let report = v.cmd_pipeline_barrier2(&Default::default(), &read);
        assert!(
            report.contains(ommcheck_vuids::vuid::VkMemoryBarrier2::srcAccessMask_07457),
            "{report}"
        );
    }

    #[test]
    fn submits_read_their_semaphores() {
        let wait = [vk::SemaphoreSubmitInfo::default()
            .stage_mask(vk::PipelineStageFlags2::from_raw(STAGE_MICROMAP_BUILD))];
        let submit = vk::SubmitInfo2::default().wait_semaphore_infos(&wait);
        let mut findings = Vec::new();
        // SAFETY: one live submit.
        let read = unsafe { submit_infos(&submit, 1, "f", &mut findings) };
        assert_eq!(
            read[0].wait_semaphore_infos[0].stage_mask,
            STAGE_MICROMAP_BUILD
        );
        assert!(read[0].signal_semaphore_infos.is_empty());
    }

    #[test]
    fn feature_chains_and_reported_limits() {
        let mut ext = vk::PhysicalDeviceOpacityMicromapPropertiesEXT {
            max_opacity2_state_subdivision_level: 12,
            max_opacity4_state_subdivision_level: 9,
            ..Default::default()
        };
        let mut khr_props = khr::PhysicalDeviceOpacityMicromapPropertiesKHR {
            max_opacity2_state_subdivision_level: 4,
            max_opacity4_state_subdivision_level: 10,
            max_opacity_lossy4_state_subdivision_level: 5,
            max_micromap_triangles: 1 << 30,
            ..Default::default()
        };
        // Chained by hand: ash 0.38's push_next breaks Stacked Borrows (it
        // keeps a shared pointer across a `&mut` reborrow), which Miri reports.
        khr_props.p_next = (&raw mut ext).cast();
        let properties = vk::PhysicalDeviceProperties2 {
            p_next: (&raw mut khr_props).cast(),
            ..Default::default()
        };
        let base = Profile::SpecMinimum.limits();
        // SAFETY: the chain holds two live structures.
        let limits = unsafe { reported_limits(properties.p_next, &base) };
        assert_eq!(limits.max_opacity2_state_subdivision_level, 12);
        assert_eq!(limits.max_opacity4_state_subdivision_level, 10);
        assert_eq!(limits.max_opacity_lossy4_state_subdivision_level, 5);
        assert_eq!(limits.max_micromap_triangles, 1 << 30);
        assert_eq!(
            limits.max_displacement_micromap_subdivision_level,
            base.max_displacement_micromap_subdivision_level
        );
        let mut findings = Vec::new();
        // SAFETY: as above.
        let chained =
            unsafe { feature_chain(properties.p_next, "f", "pProperties", &mut findings) };
        assert_eq!(
            chained,
            [
                ChainedStruct::micromap(MicromapStruct::OpacityMicromapPropertiesKhr),
                ChainedStruct::micromap(MicromapStruct::OpacityMicromapPropertiesExt),
            ]
        );
        // Properties chained to a device create info break its pNext rule.
        let report = Validator::new(Device::default()).create_device(&chained);
        assert!(
            report.contains(ommcheck_vuids::vuid::VkDeviceCreateInfo::pNext_pNext),
            "{report}"
        );
    }

    #[test]
    fn memory_marker_keeps_stage_and_address() {
        let info = MemoryMarkerInfoAMD {
            s_type: vk::StructureType::from_raw(STRUCTURE_TYPE_MEMORY_MARKER_INFO_AMD),
            p_next: std::ptr::null(),
            stage: vk::PipelineStageFlags2::from_raw(STAGE_MICROMAP_BUILD),
            dst_range: khr::DeviceAddressRangeKHR {
                address: 0x1000,
                size: 4,
            },
            dst_flags: khr::AddressCommandFlagsKHR::default(),
            marker: 7,
        };
        let read = memory_marker_info(&info);
        assert_eq!(
            (read.stage, read.dst_address, read.marker),
            (STAGE_MICROMAP_BUILD, 0x1000, 7)
        );
    }

    #[test]
    fn descriptor_writes_keep_only_acceleration_structures() {
        let structures = [
            <vk::AccelerationStructureKHR as vk::Handle>::from_raw(0xa1),
            <vk::AccelerationStructureKHR as vk::Handle>::from_raw(0xa2),
        ];
        let mut chained = vk::WriteDescriptorSetAccelerationStructureKHR::default()
            .acceleration_structures(&structures);
        let writes = [
            vk::WriteDescriptorSet {
                dst_set: <vk::DescriptorSet as vk::Handle>::from_raw(0x5e),
                dst_binding: 2,
                dst_array_element: 1,
                descriptor_count: 2,
                descriptor_type: vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
                // Chained by hand: ash 0.38's push_next breaks Stacked
                // Borrows (it keeps a shared pointer across a `&mut`
                // reborrow), which Miri reports.
                p_next: (&raw mut chained).cast(),
                ..Default::default()
            },
            vk::WriteDescriptorSet {
                descriptor_type: vk::DescriptorType::STORAGE_BUFFER,
                ..Default::default()
            },
        ];
        let mut findings = Vec::new();
        // SAFETY: two live writes; the first chains a live structure.
        let read = unsafe { acceleration_structure_writes(writes.as_ptr(), 2, &mut findings) };
        assert!(findings.is_empty());
        assert_eq!(
            read,
            [AccelerationStructureWrite {
                dst_set: 0x5e,
                dst_binding: 2,
                dst_array_element: 1,
                structures: vec![0xa1, 0xa2],
            }]
        );
        let bindings = [
            vk::DescriptorSetLayoutBinding::default()
                .binding(3)
                .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
                .stage_flags(vk::ShaderStageFlags::RAYGEN_KHR),
            vk::DescriptorSetLayoutBinding::default()
                .binding(4)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER),
        ];
        let layout = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: the bindings are alive.
        let read = unsafe { acceleration_structure_bindings(&layout, &mut findings) };
        assert_eq!(read, [(3, vk::ShaderStageFlags::RAYGEN_KHR.as_raw())]);
    }
}
