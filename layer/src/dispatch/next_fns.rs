//! The next layer's functions this layer calls, in tables by the commands
//! they serve. Every function is resolved when the instance or device is
//! created (later the loader's terminator may hand back this layer's own
//! functions) and kept as an `Option`, so a function the next layer lacks
//! is never called. The tables sit in [`super::DeviceData`], below every
//! intercept module that calls through them.

#![allow(unsafe_code)]

use ash::vk;
use ommcheck::raw::pipeline::MemoryMarkerInfoAMD;
use ommcheck::vuids::khr;

/// Resolves `$name` through `$gpa($handle, ...)` as a `$ty`, or None.
macro_rules! next_fn {
    ($gpa:expr, $handle:expr, $name:literal, $ty:ty) => {{
        // SAFETY: `$gpa` is the next layer's vkGet*ProcAddr, called with a
        // handle it created and a NUL-terminated name.
        let function = unsafe { ($gpa)($handle, $name.as_ptr()) };
        // SAFETY: the next layer returns the function of that name, whose
        // signature the Vulkan API fixes as `$ty`.
        function.map(|f| unsafe { std::mem::transmute::<unsafe extern "system" fn(), $ty>(f) })
    }};
}
pub(crate) use next_fn;

/// The next layer's instance functions.
pub struct InstanceFns {
    pub destroy_instance: Option<vk::PFN_vkDestroyInstance>,
    pub get_physical_device_memory_properties: Option<vk::PFN_vkGetPhysicalDeviceMemoryProperties>,
    pub get_physical_device_queue_family_properties:
        Option<vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties>,
    pub create_debug_utils_messenger: Option<vk::PFN_vkCreateDebugUtilsMessengerEXT>,
    pub destroy_debug_utils_messenger: Option<vk::PFN_vkDestroyDebugUtilsMessengerEXT>,
    pub create_debug_report_callback: Option<vk::PFN_vkCreateDebugReportCallbackEXT>,
    pub destroy_debug_report_callback: Option<vk::PFN_vkDestroyDebugReportCallbackEXT>,
    pub get_physical_device_properties2: Option<vk::PFN_vkGetPhysicalDeviceProperties2>,
    pub get_physical_device_properties2_khr: Option<vk::PFN_vkGetPhysicalDeviceProperties2>,
}

impl InstanceFns {
    pub fn load(gipa: vk::PFN_vkGetInstanceProcAddr, instance: vk::Instance) -> Self {
        Self {
            destroy_instance: next_fn!(
                gipa,
                instance,
                c"vkDestroyInstance",
                vk::PFN_vkDestroyInstance
            ),
            get_physical_device_memory_properties: next_fn!(
                gipa,
                instance,
                c"vkGetPhysicalDeviceMemoryProperties",
                vk::PFN_vkGetPhysicalDeviceMemoryProperties
            ),
            get_physical_device_queue_family_properties: next_fn!(
                gipa,
                instance,
                c"vkGetPhysicalDeviceQueueFamilyProperties",
                vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties
            ),
            create_debug_utils_messenger: next_fn!(
                gipa,
                instance,
                c"vkCreateDebugUtilsMessengerEXT",
                vk::PFN_vkCreateDebugUtilsMessengerEXT
            ),
            destroy_debug_utils_messenger: next_fn!(
                gipa,
                instance,
                c"vkDestroyDebugUtilsMessengerEXT",
                vk::PFN_vkDestroyDebugUtilsMessengerEXT
            ),
            create_debug_report_callback: next_fn!(
                gipa,
                instance,
                c"vkCreateDebugReportCallbackEXT",
                vk::PFN_vkCreateDebugReportCallbackEXT
            ),
            destroy_debug_report_callback: next_fn!(
                gipa,
                instance,
                c"vkDestroyDebugReportCallbackEXT",
                vk::PFN_vkDestroyDebugReportCallbackEXT
            ),
            get_physical_device_properties2: next_fn!(
                gipa,
                instance,
                c"vkGetPhysicalDeviceProperties2",
                vk::PFN_vkGetPhysicalDeviceProperties2
            ),
            get_physical_device_properties2_khr: next_fn!(
                gipa,
                instance,
                c"vkGetPhysicalDeviceProperties2KHR",
                vk::PFN_vkGetPhysicalDeviceProperties2
            ),
        }
    }
}

/// The next layer's device functions.
pub struct DeviceFns {
    pub destroy_device: Option<vk::PFN_vkDestroyDevice>,
    pub create_buffer: Option<vk::PFN_vkCreateBuffer>,
    pub destroy_buffer: Option<vk::PFN_vkDestroyBuffer>,
    pub allocate_memory: Option<vk::PFN_vkAllocateMemory>,
    pub free_memory: Option<vk::PFN_vkFreeMemory>,
    pub map_memory: Option<vk::PFN_vkMapMemory>,
    pub unmap_memory: Option<vk::PFN_vkUnmapMemory>,
    pub bind_buffer_memory: Option<vk::PFN_vkBindBufferMemory>,
    pub bind_buffer_memory2: Option<vk::PFN_vkBindBufferMemory2>,
    pub bind_buffer_memory2_khr: Option<vk::PFN_vkBindBufferMemory2>,
    pub get_buffer_device_address: Option<vk::PFN_vkGetBufferDeviceAddress>,
    pub get_buffer_device_address_khr: Option<vk::PFN_vkGetBufferDeviceAddress>,
    pub get_buffer_device_address_ext: Option<vk::PFN_vkGetBufferDeviceAddress>,
    pub create_deferred_operation: Option<vk::PFN_vkCreateDeferredOperationKHR>,
    pub destroy_deferred_operation: Option<vk::PFN_vkDestroyDeferredOperationKHR>,
    pub deferred_operation_join: Option<vk::PFN_vkDeferredOperationJoinKHR>,
    pub get_deferred_operation_result: Option<vk::PFN_vkGetDeferredOperationResultKHR>,
    pub create_micromap: Option<vk::PFN_vkCreateMicromapEXT>,
    pub destroy_micromap: Option<vk::PFN_vkDestroyMicromapEXT>,
    pub cmd_build_micromaps: Option<vk::PFN_vkCmdBuildMicromapsEXT>,
    pub build_micromaps: Option<vk::PFN_vkBuildMicromapsEXT>,
    /// Acceleration-structure, micromap copy and query commands.
    pub accel: AccelFns,
    /// Command pools and buffers, their state commands, and queue submission.
    pub commands: CommandFns,
    /// The pipeline, shader, synchronization and shader-running commands.
    pub pipe: PipeFns,
    /// Transfers, completion and what GPU readback records.
    pub memory: MemoryFns,
}

impl DeviceFns {
    pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
        Self {
            destroy_device: next_fn!(gdpa, device, c"vkDestroyDevice", vk::PFN_vkDestroyDevice),
            create_buffer: next_fn!(gdpa, device, c"vkCreateBuffer", vk::PFN_vkCreateBuffer),
            destroy_buffer: next_fn!(gdpa, device, c"vkDestroyBuffer", vk::PFN_vkDestroyBuffer),
            allocate_memory: next_fn!(gdpa, device, c"vkAllocateMemory", vk::PFN_vkAllocateMemory),
            free_memory: next_fn!(gdpa, device, c"vkFreeMemory", vk::PFN_vkFreeMemory),
            map_memory: next_fn!(gdpa, device, c"vkMapMemory", vk::PFN_vkMapMemory),
            unmap_memory: next_fn!(gdpa, device, c"vkUnmapMemory", vk::PFN_vkUnmapMemory),
            bind_buffer_memory: next_fn!(
                gdpa,
                device,
                c"vkBindBufferMemory",
                vk::PFN_vkBindBufferMemory
            ),
            bind_buffer_memory2: next_fn!(
                gdpa,
                device,
                c"vkBindBufferMemory2",
                vk::PFN_vkBindBufferMemory2
            ),
            bind_buffer_memory2_khr: next_fn!(
                gdpa,
                device,
                c"vkBindBufferMemory2KHR",
                vk::PFN_vkBindBufferMemory2
            ),
            get_buffer_device_address: next_fn!(
                gdpa,
                device,
                c"vkGetBufferDeviceAddress",
                vk::PFN_vkGetBufferDeviceAddress
            ),
            get_buffer_device_address_khr: next_fn!(
                gdpa,
                device,
                c"vkGetBufferDeviceAddressKHR",
                vk::PFN_vkGetBufferDeviceAddress
            ),
            get_buffer_device_address_ext: next_fn!(
                gdpa,
                device,
                c"vkGetBufferDeviceAddressEXT",
                vk::PFN_vkGetBufferDeviceAddress
            ),
            create_deferred_operation: next_fn!(
                gdpa,
                device,
                c"vkCreateDeferredOperationKHR",
                vk::PFN_vkCreateDeferredOperationKHR
            ),
            destroy_deferred_operation: next_fn!(
                gdpa,
                device,
                c"vkDestroyDeferredOperationKHR",
                vk::PFN_vkDestroyDeferredOperationKHR
            ),
            deferred_operation_join: next_fn!(
                gdpa,
                device,
                c"vkDeferredOperationJoinKHR",
                vk::PFN_vkDeferredOperationJoinKHR
            ),
            get_deferred_operation_result: next_fn!(
                gdpa,
                device,
                c"vkGetDeferredOperationResultKHR",
                vk::PFN_vkGetDeferredOperationResultKHR
            ),
            create_micromap: next_fn!(
                gdpa,
                device,
                c"vkCreateMicromapEXT",
                vk::PFN_vkCreateMicromapEXT
            ),
            destroy_micromap: next_fn!(
                gdpa,
                device,
                c"vkDestroyMicromapEXT",
                vk::PFN_vkDestroyMicromapEXT
            ),
            cmd_build_micromaps: next_fn!(
                gdpa,
                device,
                c"vkCmdBuildMicromapsEXT",
                vk::PFN_vkCmdBuildMicromapsEXT
            ),
            build_micromaps: next_fn!(
                gdpa,
                device,
                c"vkBuildMicromapsEXT",
                vk::PFN_vkBuildMicromapsEXT
            ),
            accel: AccelFns::load(gdpa, device),
            commands: CommandFns::load(gdpa, device),
            pipe: PipeFns::load(gdpa, device),
            memory: MemoryFns::load(gdpa, device),
        }
    }
}

/// `vkCreateAccelerationStructure2KHR` (VK_KHR_opacity_micromap), newer than ash 0.38.
pub type PfnCreateAccelerationStructure2KHR = unsafe extern "system" fn(
    vk::Device,
    *const khr::AccelerationStructureCreateInfo2KHR,
    *const vk::AllocationCallbacks<'_>,
    *mut vk::AccelerationStructureKHR,
) -> vk::Result;

/// The next layer's acceleration-structure, micromap copy and query functions.
pub struct AccelFns {
    pub create_acceleration_structure: Option<vk::PFN_vkCreateAccelerationStructureKHR>,
    pub create_acceleration_structure2: Option<PfnCreateAccelerationStructure2KHR>,
    pub destroy_acceleration_structure: Option<vk::PFN_vkDestroyAccelerationStructureKHR>,
    pub cmd_build_acceleration_structures: Option<vk::PFN_vkCmdBuildAccelerationStructuresKHR>,
    pub cmd_build_acceleration_structures_indirect:
        Option<vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR>,
    pub build_acceleration_structures: Option<vk::PFN_vkBuildAccelerationStructuresKHR>,
    pub get_acceleration_structure_build_sizes:
        Option<vk::PFN_vkGetAccelerationStructureBuildSizesKHR>,
    pub cmd_copy_acceleration_structure: Option<vk::PFN_vkCmdCopyAccelerationStructureKHR>,
    pub copy_acceleration_structure: Option<vk::PFN_vkCopyAccelerationStructureKHR>,
    pub cmd_copy_acceleration_structure_to_memory:
        Option<vk::PFN_vkCmdCopyAccelerationStructureToMemoryKHR>,
    pub copy_acceleration_structure_to_memory:
        Option<vk::PFN_vkCopyAccelerationStructureToMemoryKHR>,
    pub cmd_copy_memory_to_acceleration_structure:
        Option<vk::PFN_vkCmdCopyMemoryToAccelerationStructureKHR>,
    pub copy_memory_to_acceleration_structure:
        Option<vk::PFN_vkCopyMemoryToAccelerationStructureKHR>,
    pub cmd_copy_micromap: Option<vk::PFN_vkCmdCopyMicromapEXT>,
    pub copy_micromap: Option<vk::PFN_vkCopyMicromapEXT>,
    pub cmd_copy_micromap_to_memory: Option<vk::PFN_vkCmdCopyMicromapToMemoryEXT>,
    pub copy_micromap_to_memory: Option<vk::PFN_vkCopyMicromapToMemoryEXT>,
    pub cmd_copy_memory_to_micromap: Option<vk::PFN_vkCmdCopyMemoryToMicromapEXT>,
    pub copy_memory_to_micromap: Option<vk::PFN_vkCopyMemoryToMicromapEXT>,
    pub cmd_write_micromaps_properties: Option<vk::PFN_vkCmdWriteMicromapsPropertiesEXT>,
    pub write_micromaps_properties: Option<vk::PFN_vkWriteMicromapsPropertiesEXT>,
    pub get_micromap_build_sizes: Option<vk::PFN_vkGetMicromapBuildSizesEXT>,
    pub get_device_micromap_compatibility: Option<vk::PFN_vkGetDeviceMicromapCompatibilityEXT>,
    pub create_query_pool: Option<vk::PFN_vkCreateQueryPool>,
    pub destroy_query_pool: Option<vk::PFN_vkDestroyQueryPool>,
    pub cmd_begin_query: Option<vk::PFN_vkCmdBeginQuery>,
    pub cmd_begin_query_indexed: Option<vk::PFN_vkCmdBeginQueryIndexedEXT>,
}

impl AccelFns {
    pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
        macro_rules! load {
            ($name:literal, $ty:ty) => {
                next_fn!(gdpa, device, $name, $ty)
            };
        }
        Self {
            create_acceleration_structure: load!(
                c"vkCreateAccelerationStructureKHR",
                vk::PFN_vkCreateAccelerationStructureKHR
            ),
            create_acceleration_structure2: load!(
                c"vkCreateAccelerationStructure2KHR",
                PfnCreateAccelerationStructure2KHR
            ),
            destroy_acceleration_structure: load!(
                c"vkDestroyAccelerationStructureKHR",
                vk::PFN_vkDestroyAccelerationStructureKHR
            ),
            cmd_build_acceleration_structures: load!(
                c"vkCmdBuildAccelerationStructuresKHR",
                vk::PFN_vkCmdBuildAccelerationStructuresKHR
            ),
            cmd_build_acceleration_structures_indirect: load!(
                c"vkCmdBuildAccelerationStructuresIndirectKHR",
                vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR
            ),
            build_acceleration_structures: load!(
                c"vkBuildAccelerationStructuresKHR",
                vk::PFN_vkBuildAccelerationStructuresKHR
            ),
            get_acceleration_structure_build_sizes: load!(
                c"vkGetAccelerationStructureBuildSizesKHR",
                vk::PFN_vkGetAccelerationStructureBuildSizesKHR
            ),
            cmd_copy_acceleration_structure: load!(
                c"vkCmdCopyAccelerationStructureKHR",
                vk::PFN_vkCmdCopyAccelerationStructureKHR
            ),
            copy_acceleration_structure: load!(
                c"vkCopyAccelerationStructureKHR",
                vk::PFN_vkCopyAccelerationStructureKHR
            ),
            cmd_copy_acceleration_structure_to_memory: load!(
                c"vkCmdCopyAccelerationStructureToMemoryKHR",
                vk::PFN_vkCmdCopyAccelerationStructureToMemoryKHR
            ),
            copy_acceleration_structure_to_memory: load!(
                c"vkCopyAccelerationStructureToMemoryKHR",
                vk::PFN_vkCopyAccelerationStructureToMemoryKHR
            ),
            cmd_copy_memory_to_acceleration_structure: load!(
                c"vkCmdCopyMemoryToAccelerationStructureKHR",
                vk::PFN_vkCmdCopyMemoryToAccelerationStructureKHR
            ),
            copy_memory_to_acceleration_structure: load!(
                c"vkCopyMemoryToAccelerationStructureKHR",
                vk::PFN_vkCopyMemoryToAccelerationStructureKHR
            ),
            cmd_copy_micromap: load!(c"vkCmdCopyMicromapEXT", vk::PFN_vkCmdCopyMicromapEXT),
            copy_micromap: load!(c"vkCopyMicromapEXT", vk::PFN_vkCopyMicromapEXT),
            cmd_copy_micromap_to_memory: load!(
                c"vkCmdCopyMicromapToMemoryEXT",
                vk::PFN_vkCmdCopyMicromapToMemoryEXT
            ),
            copy_micromap_to_memory: load!(
                c"vkCopyMicromapToMemoryEXT",
                vk::PFN_vkCopyMicromapToMemoryEXT
            ),
            cmd_copy_memory_to_micromap: load!(
                c"vkCmdCopyMemoryToMicromapEXT",
                vk::PFN_vkCmdCopyMemoryToMicromapEXT
            ),
            copy_memory_to_micromap: load!(
                c"vkCopyMemoryToMicromapEXT",
                vk::PFN_vkCopyMemoryToMicromapEXT
            ),
            cmd_write_micromaps_properties: load!(
                c"vkCmdWriteMicromapsPropertiesEXT",
                vk::PFN_vkCmdWriteMicromapsPropertiesEXT
            ),
            write_micromaps_properties: load!(
                c"vkWriteMicromapsPropertiesEXT",
                vk::PFN_vkWriteMicromapsPropertiesEXT
            ),
            get_micromap_build_sizes: load!(
                c"vkGetMicromapBuildSizesEXT",
                vk::PFN_vkGetMicromapBuildSizesEXT
            ),
            get_device_micromap_compatibility: load!(
                c"vkGetDeviceMicromapCompatibilityEXT",
                vk::PFN_vkGetDeviceMicromapCompatibilityEXT
            ),
            create_query_pool: load!(c"vkCreateQueryPool", vk::PFN_vkCreateQueryPool),
            destroy_query_pool: load!(c"vkDestroyQueryPool", vk::PFN_vkDestroyQueryPool),
            cmd_begin_query: load!(c"vkCmdBeginQuery", vk::PFN_vkCmdBeginQuery),
            cmd_begin_query_indexed: load!(
                c"vkCmdBeginQueryIndexedEXT",
                vk::PFN_vkCmdBeginQueryIndexedEXT
            ),
        }
    }
}

/// The next layer's command pool, command buffer and submission functions.
pub struct CommandFns {
    pub create_command_pool: Option<vk::PFN_vkCreateCommandPool>,
    pub destroy_command_pool: Option<vk::PFN_vkDestroyCommandPool>,
    pub reset_command_pool: Option<vk::PFN_vkResetCommandPool>,
    pub allocate_command_buffers: Option<vk::PFN_vkAllocateCommandBuffers>,
    pub free_command_buffers: Option<vk::PFN_vkFreeCommandBuffers>,
    pub begin_command_buffer: Option<vk::PFN_vkBeginCommandBuffer>,
    pub end_command_buffer: Option<vk::PFN_vkEndCommandBuffer>,
    pub reset_command_buffer: Option<vk::PFN_vkResetCommandBuffer>,
    pub cmd_begin_render_pass: Option<vk::PFN_vkCmdBeginRenderPass>,
    pub cmd_begin_render_pass2: Option<vk::PFN_vkCmdBeginRenderPass2>,
    pub cmd_begin_render_pass2_khr: Option<vk::PFN_vkCmdBeginRenderPass2>,
    pub cmd_end_render_pass: Option<vk::PFN_vkCmdEndRenderPass>,
    pub cmd_end_render_pass2: Option<vk::PFN_vkCmdEndRenderPass2>,
    pub cmd_end_render_pass2_khr: Option<vk::PFN_vkCmdEndRenderPass2>,
    pub cmd_begin_rendering: Option<vk::PFN_vkCmdBeginRendering>,
    pub cmd_begin_rendering_khr: Option<vk::PFN_vkCmdBeginRendering>,
    pub cmd_end_rendering: Option<vk::PFN_vkCmdEndRendering>,
    pub cmd_end_rendering_khr: Option<vk::PFN_vkCmdEndRendering>,
    pub cmd_begin_video_coding: Option<vk::PFN_vkCmdBeginVideoCodingKHR>,
    pub cmd_end_video_coding: Option<vk::PFN_vkCmdEndVideoCodingKHR>,
    pub cmd_execute_commands: Option<vk::PFN_vkCmdExecuteCommands>,
    pub queue_submit: Option<vk::PFN_vkQueueSubmit>,
    pub queue_submit2: Option<vk::PFN_vkQueueSubmit2>,
    pub queue_submit2_khr: Option<vk::PFN_vkQueueSubmit2>,
}

impl CommandFns {
    pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
        macro_rules! load {
            ($name:literal, $ty:ty) => {
                next_fn!(gdpa, device, $name, $ty)
            };
        }
        Self {
            create_command_pool: load!(c"vkCreateCommandPool", vk::PFN_vkCreateCommandPool),
            destroy_command_pool: load!(c"vkDestroyCommandPool", vk::PFN_vkDestroyCommandPool),
            reset_command_pool: load!(c"vkResetCommandPool", vk::PFN_vkResetCommandPool),
            allocate_command_buffers: load!(
                c"vkAllocateCommandBuffers",
                vk::PFN_vkAllocateCommandBuffers
            ),
            free_command_buffers: load!(c"vkFreeCommandBuffers", vk::PFN_vkFreeCommandBuffers),
            begin_command_buffer: load!(c"vkBeginCommandBuffer", vk::PFN_vkBeginCommandBuffer),
            end_command_buffer: load!(c"vkEndCommandBuffer", vk::PFN_vkEndCommandBuffer),
            reset_command_buffer: load!(c"vkResetCommandBuffer", vk::PFN_vkResetCommandBuffer),
            cmd_begin_render_pass: load!(c"vkCmdBeginRenderPass", vk::PFN_vkCmdBeginRenderPass),
            cmd_begin_render_pass2: load!(c"vkCmdBeginRenderPass2", vk::PFN_vkCmdBeginRenderPass2),
            cmd_begin_render_pass2_khr: load!(
                c"vkCmdBeginRenderPass2KHR",
                vk::PFN_vkCmdBeginRenderPass2
            ),
            cmd_end_render_pass: load!(c"vkCmdEndRenderPass", vk::PFN_vkCmdEndRenderPass),
            cmd_end_render_pass2: load!(c"vkCmdEndRenderPass2", vk::PFN_vkCmdEndRenderPass2),
            cmd_end_render_pass2_khr: load!(c"vkCmdEndRenderPass2KHR", vk::PFN_vkCmdEndRenderPass2),
            cmd_begin_rendering: load!(c"vkCmdBeginRendering", vk::PFN_vkCmdBeginRendering),
            cmd_begin_rendering_khr: load!(c"vkCmdBeginRenderingKHR", vk::PFN_vkCmdBeginRendering),
            cmd_end_rendering: load!(c"vkCmdEndRendering", vk::PFN_vkCmdEndRendering),
            cmd_end_rendering_khr: load!(c"vkCmdEndRenderingKHR", vk::PFN_vkCmdEndRendering),
            cmd_begin_video_coding: load!(
                c"vkCmdBeginVideoCodingKHR",
                vk::PFN_vkCmdBeginVideoCodingKHR
            ),
            cmd_end_video_coding: load!(c"vkCmdEndVideoCodingKHR", vk::PFN_vkCmdEndVideoCodingKHR),
            cmd_execute_commands: load!(c"vkCmdExecuteCommands", vk::PFN_vkCmdExecuteCommands),
            queue_submit: load!(c"vkQueueSubmit", vk::PFN_vkQueueSubmit),
            queue_submit2: load!(c"vkQueueSubmit2", vk::PFN_vkQueueSubmit2),
            queue_submit2_khr: load!(c"vkQueueSubmit2KHR", vk::PFN_vkQueueSubmit2),
        }
    }
}

/// `vkCmdWriteMarkerToMemoryAMD`, newer than ash 0.38.
pub type PfnCmdWriteMarkerToMemoryAMD =
    unsafe extern "system" fn(vk::CommandBuffer, *const MemoryMarkerInfoAMD);

/// The pipeline, shader, synchronization and shader-running commands: each
/// one's field in [`PipeFns`], its type and its name, handed to `$then`.
/// [`PipeFns`] is made from this list here and `crate::pipe` makes its
/// intercept table from it, so the two cannot disagree.
macro_rules! pipe_commands {
    ($then:ident) => {
        $then! {
            create_shader_module: vk::PFN_vkCreateShaderModule = c"vkCreateShaderModule";
            destroy_shader_module: vk::PFN_vkDestroyShaderModule = c"vkDestroyShaderModule";
            create_compute_pipelines: vk::PFN_vkCreateComputePipelines = c"vkCreateComputePipelines";
            create_graphics_pipelines: vk::PFN_vkCreateGraphicsPipelines = c"vkCreateGraphicsPipelines";
            create_ray_tracing_pipelines_khr: vk::PFN_vkCreateRayTracingPipelinesKHR = c"vkCreateRayTracingPipelinesKHR";
            create_ray_tracing_pipelines_nv: vk::PFN_vkCreateRayTracingPipelinesNV = c"vkCreateRayTracingPipelinesNV";
            destroy_pipeline: vk::PFN_vkDestroyPipeline = c"vkDestroyPipeline";
            create_shaders: vk::PFN_vkCreateShadersEXT = c"vkCreateShadersEXT";
            destroy_shader: vk::PFN_vkDestroyShaderEXT = c"vkDestroyShaderEXT";

            cmd_pipeline_barrier2: vk::PFN_vkCmdPipelineBarrier2 = c"vkCmdPipelineBarrier2";
            cmd_pipeline_barrier2_khr: vk::PFN_vkCmdPipelineBarrier2 = c"vkCmdPipelineBarrier2KHR";
            cmd_set_event2: vk::PFN_vkCmdSetEvent2 = c"vkCmdSetEvent2";
            cmd_set_event2_khr: vk::PFN_vkCmdSetEvent2 = c"vkCmdSetEvent2KHR";
            cmd_wait_events2: vk::PFN_vkCmdWaitEvents2 = c"vkCmdWaitEvents2";
            cmd_wait_events2_khr: vk::PFN_vkCmdWaitEvents2 = c"vkCmdWaitEvents2KHR";
            cmd_reset_event2: vk::PFN_vkCmdResetEvent2 = c"vkCmdResetEvent2";
            cmd_reset_event2_khr: vk::PFN_vkCmdResetEvent2 = c"vkCmdResetEvent2KHR";
            cmd_write_timestamp2: vk::PFN_vkCmdWriteTimestamp2 = c"vkCmdWriteTimestamp2";
            cmd_write_timestamp2_khr: vk::PFN_vkCmdWriteTimestamp2 = c"vkCmdWriteTimestamp2KHR";
            cmd_write_buffer_marker2_amd: vk::PFN_vkCmdWriteBufferMarker2AMD = c"vkCmdWriteBufferMarker2AMD";
            cmd_write_marker_to_memory_amd: $crate::dispatch::next_fns::PfnCmdWriteMarkerToMemoryAMD = c"vkCmdWriteMarkerToMemoryAMD";
            cmd_reset_query_pool: vk::PFN_vkCmdResetQueryPool = c"vkCmdResetQueryPool";
            reset_query_pool: vk::PFN_vkResetQueryPool = c"vkResetQueryPool";
            reset_query_pool_ext: vk::PFN_vkResetQueryPool = c"vkResetQueryPoolEXT";

            create_descriptor_set_layout: vk::PFN_vkCreateDescriptorSetLayout = c"vkCreateDescriptorSetLayout";
            destroy_descriptor_set_layout: vk::PFN_vkDestroyDescriptorSetLayout = c"vkDestroyDescriptorSetLayout";
            allocate_descriptor_sets: vk::PFN_vkAllocateDescriptorSets = c"vkAllocateDescriptorSets";
            free_descriptor_sets: vk::PFN_vkFreeDescriptorSets = c"vkFreeDescriptorSets";
            update_descriptor_sets: vk::PFN_vkUpdateDescriptorSets = c"vkUpdateDescriptorSets";
            cmd_bind_descriptor_sets: vk::PFN_vkCmdBindDescriptorSets = c"vkCmdBindDescriptorSets";
            cmd_bind_pipeline: vk::PFN_vkCmdBindPipeline = c"vkCmdBindPipeline";
            cmd_bind_shaders: vk::PFN_vkCmdBindShadersEXT = c"vkCmdBindShadersEXT";

            cmd_draw: vk::PFN_vkCmdDraw = c"vkCmdDraw";
            cmd_draw_indexed: vk::PFN_vkCmdDrawIndexed = c"vkCmdDrawIndexed";
            cmd_draw_indirect: vk::PFN_vkCmdDrawIndirect = c"vkCmdDrawIndirect";
            cmd_draw_indexed_indirect: vk::PFN_vkCmdDrawIndexedIndirect = c"vkCmdDrawIndexedIndirect";
            cmd_draw_indirect_count: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCount";
            cmd_draw_indirect_count_khr: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCountKHR";
            cmd_draw_indirect_count_amd: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCountAMD";
            cmd_draw_indexed_indirect_count: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCount";
            cmd_draw_indexed_indirect_count_khr: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCountKHR";
            cmd_draw_indexed_indirect_count_amd: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCountAMD";
            cmd_draw_mesh_tasks: vk::PFN_vkCmdDrawMeshTasksEXT = c"vkCmdDrawMeshTasksEXT";
            cmd_draw_mesh_tasks_indirect: vk::PFN_vkCmdDrawMeshTasksIndirectEXT = c"vkCmdDrawMeshTasksIndirectEXT";
            cmd_draw_mesh_tasks_indirect_count: vk::PFN_vkCmdDrawMeshTasksIndirectCountEXT = c"vkCmdDrawMeshTasksIndirectCountEXT";
            cmd_dispatch: vk::PFN_vkCmdDispatch = c"vkCmdDispatch";
            cmd_dispatch_base: vk::PFN_vkCmdDispatchBase = c"vkCmdDispatchBase";
            cmd_dispatch_base_khr: vk::PFN_vkCmdDispatchBase = c"vkCmdDispatchBaseKHR";
            cmd_dispatch_indirect: vk::PFN_vkCmdDispatchIndirect = c"vkCmdDispatchIndirect";
            cmd_trace_rays: vk::PFN_vkCmdTraceRaysKHR = c"vkCmdTraceRaysKHR";
            cmd_trace_rays_indirect: vk::PFN_vkCmdTraceRaysIndirectKHR = c"vkCmdTraceRaysIndirectKHR";
            cmd_trace_rays_indirect2: vk::PFN_vkCmdTraceRaysIndirect2KHR = c"vkCmdTraceRaysIndirect2KHR";
            cmd_draw_multi: vk::PFN_vkCmdDrawMultiEXT = c"vkCmdDrawMultiEXT";
            cmd_draw_multi_indexed: vk::PFN_vkCmdDrawMultiIndexedEXT = c"vkCmdDrawMultiIndexedEXT";
            cmd_draw_mesh_tasks_nv: vk::PFN_vkCmdDrawMeshTasksNV = c"vkCmdDrawMeshTasksNV";
            cmd_draw_mesh_tasks_indirect_nv: vk::PFN_vkCmdDrawMeshTasksIndirectNV = c"vkCmdDrawMeshTasksIndirectNV";
            cmd_draw_mesh_tasks_indirect_count_nv: vk::PFN_vkCmdDrawMeshTasksIndirectCountNV = c"vkCmdDrawMeshTasksIndirectCountNV";
            cmd_draw_indirect_byte_count: vk::PFN_vkCmdDrawIndirectByteCountEXT = c"vkCmdDrawIndirectByteCountEXT";
            cmd_trace_rays_nv: vk::PFN_vkCmdTraceRaysNV = c"vkCmdTraceRaysNV";
            cmd_draw_cluster_huawei: vk::PFN_vkCmdDrawClusterHUAWEI = c"vkCmdDrawClusterHUAWEI";
            cmd_draw_cluster_indirect_huawei: vk::PFN_vkCmdDrawClusterIndirectHUAWEI = c"vkCmdDrawClusterIndirectHUAWEI";
            cmd_subpass_shading_huawei: vk::PFN_vkCmdSubpassShadingHUAWEI = c"vkCmdSubpassShadingHUAWEI";
            cmd_execute_generated_commands_nv: vk::PFN_vkCmdExecuteGeneratedCommandsNV = c"vkCmdExecuteGeneratedCommandsNV";
        }
    };
}
pub(crate) use pipe_commands;

macro_rules! pipe_fns {
    ($($field:ident: $pfn:ty = $name:literal;)*) => {
        /// The next layer's pipeline, shader, synchronization and
        /// shader-running functions (see [`pipe_commands`]).
        pub struct PipeFns {
            $(pub $field: Option<$pfn>,)*
        }

        impl PipeFns {
            pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
                Self {
                    $($field: next_fn!(gdpa, device, $name, $pfn),)*
                }
            }
        }
    };
}
pipe_commands!(pipe_fns);

/// The commands that write buffer memory, those that tell a submission
/// is complete and those after which a fence stands for none
/// (`intercepted`), and the functions GPU readback records
/// with (`called`): each one's field in [`MemoryFns`], its type and its
/// name, handed to `$then`. [`MemoryFns`] is made from this list here and
/// `crate::transfer` makes its intercept table from it.
macro_rules! memory_commands {
    ($then:ident) => {
        $then! {
            intercepted {
                cmd_copy_buffer: vk::PFN_vkCmdCopyBuffer = c"vkCmdCopyBuffer";
                cmd_copy_buffer2: vk::PFN_vkCmdCopyBuffer2 = c"vkCmdCopyBuffer2";
                cmd_copy_buffer2_khr: vk::PFN_vkCmdCopyBuffer2 = c"vkCmdCopyBuffer2KHR";
                cmd_update_buffer: vk::PFN_vkCmdUpdateBuffer = c"vkCmdUpdateBuffer";
                cmd_fill_buffer: vk::PFN_vkCmdFillBuffer = c"vkCmdFillBuffer";
                cmd_copy_image_to_buffer: vk::PFN_vkCmdCopyImageToBuffer = c"vkCmdCopyImageToBuffer";
                cmd_copy_image_to_buffer2: vk::PFN_vkCmdCopyImageToBuffer2 = c"vkCmdCopyImageToBuffer2";
                cmd_copy_image_to_buffer2_khr: vk::PFN_vkCmdCopyImageToBuffer2 = c"vkCmdCopyImageToBuffer2KHR";
                cmd_copy_query_pool_results: vk::PFN_vkCmdCopyQueryPoolResults = c"vkCmdCopyQueryPoolResults";

                wait_for_fences: vk::PFN_vkWaitForFences = c"vkWaitForFences";
                get_fence_status: vk::PFN_vkGetFenceStatus = c"vkGetFenceStatus";
                reset_fences: vk::PFN_vkResetFences = c"vkResetFences";
                destroy_fence: vk::PFN_vkDestroyFence = c"vkDestroyFence";
                queue_wait_idle: vk::PFN_vkQueueWaitIdle = c"vkQueueWaitIdle";
                device_wait_idle: vk::PFN_vkDeviceWaitIdle = c"vkDeviceWaitIdle";
                wait_semaphores: vk::PFN_vkWaitSemaphores = c"vkWaitSemaphores";
                wait_semaphores_khr: vk::PFN_vkWaitSemaphores = c"vkWaitSemaphoresKHR";
                get_semaphore_counter_value: vk::PFN_vkGetSemaphoreCounterValue = c"vkGetSemaphoreCounterValue";
                get_semaphore_counter_value_khr: vk::PFN_vkGetSemaphoreCounterValue = c"vkGetSemaphoreCounterValueKHR";
                signal_semaphore: vk::PFN_vkSignalSemaphore = c"vkSignalSemaphore";
                signal_semaphore_khr: vk::PFN_vkSignalSemaphore = c"vkSignalSemaphoreKHR";
                destroy_semaphore: vk::PFN_vkDestroySemaphore = c"vkDestroySemaphore";
            }
            called {
                get_buffer_memory_requirements: vk::PFN_vkGetBufferMemoryRequirements = c"vkGetBufferMemoryRequirements";
                cmd_pipeline_barrier: vk::PFN_vkCmdPipelineBarrier = c"vkCmdPipelineBarrier";
            }
        }
    };
}
pub(crate) use memory_commands;

macro_rules! memory_fns {
    (
        intercepted { $($field:ident: $pfn:ty = $name:literal;)* }
        called { $($called:ident: $called_pfn:ty = $called_name:literal;)* }
    ) => {
        /// The next layer's functions for transfers, completion and GPU
        /// readback (see [`memory_commands`]).
        pub struct MemoryFns {
            $(pub $field: Option<$pfn>,)*
            $(pub $called: Option<$called_pfn>,)*
        }

        impl MemoryFns {
            pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
                Self {
                    $($field: next_fn!(gdpa, device, $name, $pfn),)*
                    $($called: next_fn!(gdpa, device, $called_name, $called_pfn),)*
                }
            }
        }
    };
}
memory_commands!(memory_fns);
