//! A fake loader and driver for in-process chain tests: the test plays the
//! loader (it builds the `VkLayer*CreateInfo` link chain) and the next
//! layer (`fake_gipa` / `fake_gdpa` return recording stubs written here).
//!
//! Dispatchable handles are leaked boxes whose first word is a dispatch
//! key, as the loader's are: a physical device shares its instance's key,
//! a command buffer its device's. Each test thread records its own calls.

// Each test crate uses part of the fake driver.
#![allow(unsafe_code, clippy::missing_safety_doc, dead_code)]

use std::cell::RefCell;
use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

use ash::vk;
use ash::vk::Handle as _;
use VkLayer_ommcheck as layer;

use layer::abi::{
    LayerDeviceCreateInfo, LayerDeviceCreateInfoUnion, LayerDeviceLink, LayerInstanceCreateInfo,
    LayerInstanceCreateInfoUnion, LayerInstanceLink, LAYER_LINK_INFO,
};

/// A call the fake driver received: its name and the arguments a test looks at.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Call {
    pub name: &'static str,
    pub args: Vec<u64>,
}

#[derive(Default)]
struct Driver {
    calls: Vec<Call>,
    next_handle: u64,
    /// What vkMapMemory hands out: test-owned memory.
    mapped: usize,
    /// The maxOpacity2StateSubdivisionLevel vkGetPhysicalDeviceProperties2 reports.
    reported_2_state_level: u32,
}

thread_local! {
    static DRIVER: RefCell<Driver> = RefCell::new(Driver { next_handle: 1, reported_2_state_level: 3, ..Driver::default() });
}

fn record(name: &'static str, args: Vec<u64>) {
    DRIVER.with_borrow_mut(|d| d.calls.push(Call { name, args }));
}

fn next_handle() -> u64 {
    DRIVER.with_borrow_mut(|d| {
        d.next_handle += 1;
        d.next_handle
    })
}

/// The calls this thread's fake driver received with `name`.
pub fn calls(name: &str) -> Vec<Call> {
    DRIVER.with_borrow(|d| d.calls.iter().filter(|c| c.name == name).cloned().collect())
}

/// Makes vkMapMemory return `memory`.
pub fn map_to(memory: *mut u8) {
    DRIVER.with_borrow_mut(|d| d.mapped = memory.expose_provenance());
}

/// Makes vkGetPhysicalDeviceProperties2 report `level` as the EXT
/// maxOpacity2StateSubdivisionLevel (3, the specification's minimum, unless set).
pub fn report_2_state_level(level: u32) {
    DRIVER.with_borrow_mut(|d| d.reported_2_state_level = level);
}

/// A dispatchable object: the loader's dispatch pointer comes first.
#[repr(C)]
struct Dispatchable {
    key: usize,
}

/// A new dispatchable handle with dispatch key `key` (leaked: handles live
/// for the whole test process).
pub fn dispatchable(key: usize) -> u64 {
    Box::into_raw(Box::new(Dispatchable { key })).expose_provenance() as u64
}

/// A dispatch key no other object has.
fn fresh_key() -> usize {
    Box::into_raw(Box::new(0u64)).expose_provenance()
}

/// The dispatch key of a handle made by [`dispatchable`].
pub fn key_of(handle: u64) -> usize {
    // SAFETY: every dispatchable handle here is a leaked `Dispatchable`.
    unsafe { (*std::ptr::with_exposed_provenance::<Dispatchable>(handle as usize)).key }
}

unsafe extern "system" fn create_instance(
    info: *const vk::InstanceCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Instance,
) -> vk::Result {
    // The layer must have advanced the link before calling down.
    let mut next = unsafe { (*info).p_next };
    let mut advanced = 0;
    while !next.is_null() {
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::LOADER_INSTANCE_CREATE_INFO {
            let link = unsafe { &*next.cast::<LayerInstanceCreateInfo>() };
            advanced = u64::from(unsafe { link.u.p_layer_info.is_null() });
        }
        next = base.p_next.cast();
    }
    record("vkCreateInstance", vec![advanced]);
    unsafe { *out = vk::Instance::from_raw(dispatchable(fresh_key())) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_instance(i: vk::Instance, _: *const vk::AllocationCallbacks<'_>) {
    record("vkDestroyInstance", vec![i.as_raw()]);
}

unsafe extern "system" fn create_device(
    _: vk::PhysicalDevice,
    _: *const vk::DeviceCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Device,
) -> vk::Result {
    record("vkCreateDevice", vec![]);
    unsafe { *out = vk::Device::from_raw(dispatchable(fresh_key())) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_device(d: vk::Device, _: *const vk::AllocationCallbacks<'_>) {
    record("vkDestroyDevice", vec![d.as_raw()]);
}

/// Memory type 0 is device-local, type 1 host-visible and coherent.
unsafe extern "system" fn get_memory_properties(
    _: vk::PhysicalDevice,
    out: *mut vk::PhysicalDeviceMemoryProperties,
) {
    let mut properties = vk::PhysicalDeviceMemoryProperties {
        memory_type_count: 2,
        memory_heap_count: 1,
        ..Default::default()
    };
    properties.memory_types[0].property_flags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
    properties.memory_types[1].property_flags =
        vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
    properties.memory_heaps[0].size = 1 << 30;
    unsafe { *out = properties };
}

unsafe extern "system" fn create_messenger(
    _: vk::Instance,
    _: *const vk::DebugUtilsMessengerCreateInfoEXT<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::DebugUtilsMessengerEXT,
) -> vk::Result {
    unsafe { *out = vk::DebugUtilsMessengerEXT::from_raw(next_handle()) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_messenger(
    _: vk::Instance,
    m: vk::DebugUtilsMessengerEXT,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyDebugUtilsMessengerEXT", vec![m.as_raw()]);
}

unsafe extern "system" fn create_buffer(
    _: vk::Device,
    info: *const vk::BufferCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Buffer,
) -> vk::Result {
    let handle = next_handle();
    record("vkCreateBuffer", vec![unsafe { (*info).size }, handle]);
    unsafe { *out = vk::Buffer::from_raw(handle) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_buffer(
    _: vk::Device,
    b: vk::Buffer,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyBuffer", vec![b.as_raw()]);
}

unsafe extern "system" fn allocate_memory(
    _: vk::Device,
    _: *const vk::MemoryAllocateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::DeviceMemory,
) -> vk::Result {
    unsafe { *out = vk::DeviceMemory::from_raw(next_handle()) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn free_memory(
    _: vk::Device,
    m: vk::DeviceMemory,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkFreeMemory", vec![m.as_raw()]);
}

unsafe extern "system" fn map_memory(
    _: vk::Device,
    _: vk::DeviceMemory,
    _: vk::DeviceSize,
    _: vk::DeviceSize,
    _: vk::MemoryMapFlags,
    out: *mut *mut c_void,
) -> vk::Result {
    let mapped = DRIVER.with_borrow(|d| d.mapped);
    unsafe { *out = std::ptr::with_exposed_provenance_mut(mapped) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn unmap_memory(_: vk::Device, m: vk::DeviceMemory) {
    record("vkUnmapMemory", vec![m.as_raw()]);
}

unsafe extern "system" fn bind_buffer_memory(
    _: vk::Device,
    b: vk::Buffer,
    m: vk::DeviceMemory,
    _: vk::DeviceSize,
) -> vk::Result {
    record("vkBindBufferMemory", vec![b.as_raw(), m.as_raw()]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn bind_buffer_memory2(
    _: vk::Device,
    count: u32,
    _: *const vk::BindBufferMemoryInfo<'_>,
) -> vk::Result {
    record("vkBindBufferMemory2", vec![u64::from(count)]);
    vk::Result::SUCCESS
}

/// Buffer `n` lives at device address `n << 20`.
unsafe extern "system" fn get_buffer_device_address(
    _: vk::Device,
    info: *const vk::BufferDeviceAddressInfo<'_>,
) -> vk::DeviceAddress {
    unsafe { (*info).buffer.as_raw() << 20 }
}

unsafe extern "system" fn create_micromap(
    _: vk::Device,
    _: *const vk::MicromapCreateInfoEXT<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::MicromapEXT,
) -> vk::Result {
    let handle = next_handle();
    record("vkCreateMicromapEXT", vec![handle]);
    unsafe { *out = vk::MicromapEXT::from_raw(handle) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_micromap(
    _: vk::Device,
    m: vk::MicromapEXT,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyMicromapEXT", vec![m.as_raw()]);
}

unsafe extern "system" fn cmd_build_micromaps(
    cb: vk::CommandBuffer,
    count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) {
    let stride = if count > 0 {
        unsafe { (*infos).triangle_array_stride }
    } else {
        0
    };
    record(
        "vkCmdBuildMicromapsEXT",
        vec![
            cb.as_raw(),
            u64::from(count),
            infos.expose_provenance() as u64,
            stride,
        ],
    );
}

unsafe extern "system" fn build_micromaps(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) -> vk::Result {
    record(
        "vkBuildMicromapsEXT",
        vec![
            d.as_raw(),
            op.as_raw(),
            u64::from(count),
            infos.expose_provenance() as u64,
        ],
    );
    vk::Result::SUCCESS
}

/// One queue family with graphics, compute and transfer.
unsafe extern "system" fn get_queue_family_properties(
    _: vk::PhysicalDevice,
    count: *mut u32,
    out: *mut vk::QueueFamilyProperties,
) {
    if out.is_null() {
        unsafe { *count = 1 };
        return;
    }
    if unsafe { *count } >= 1 {
        unsafe {
            *out = vk::QueueFamilyProperties {
                queue_flags: vk::QueueFlags::GRAPHICS
                    | vk::QueueFlags::COMPUTE
                    | vk::QueueFlags::TRANSFER,
                queue_count: 1,
                ..Default::default()
            };
            *count = 1;
        }
    }
}

unsafe extern "system" fn create_command_pool(
    _: vk::Device,
    _: *const vk::CommandPoolCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::CommandPool,
) -> vk::Result {
    unsafe { *out = vk::CommandPool::from_raw(next_handle()) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn create_query_pool(
    _: vk::Device,
    _: *const vk::QueryPoolCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::QueryPool,
) -> vk::Result {
    unsafe { *out = vk::QueryPool::from_raw(next_handle()) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_begin_query(
    cb: vk::CommandBuffer,
    pool: vk::QueryPool,
    query: u32,
    _: vk::QueryControlFlags,
) {
    record(
        "vkCmdBeginQuery",
        vec![cb.as_raw(), pool.as_raw(), u64::from(query)],
    );
}

/// Command buffers share their device's dispatch key.
unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    info: *const vk::CommandBufferAllocateInfo<'_>,
    out: *mut vk::CommandBuffer,
) -> vk::Result {
    let count = unsafe { (*info).command_buffer_count } as usize;
    for i in 0..count {
        let handle = dispatchable(key_of(device.as_raw()));
        unsafe { *out.add(i) = vk::CommandBuffer::from_raw(handle) };
    }
    vk::Result::SUCCESS
}

unsafe extern "system" fn begin_command_buffer(
    cb: vk::CommandBuffer,
    _: *const vk::CommandBufferBeginInfo<'_>,
) -> vk::Result {
    record("vkBeginCommandBuffer", vec![cb.as_raw()]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn end_command_buffer(cb: vk::CommandBuffer) -> vk::Result {
    record("vkEndCommandBuffer", vec![cb.as_raw()]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_begin_render_pass(
    cb: vk::CommandBuffer,
    _: *const vk::RenderPassBeginInfo<'_>,
    _: vk::SubpassContents,
) {
    record("vkCmdBeginRenderPass", vec![cb.as_raw()]);
}

unsafe extern "system" fn cmd_end_render_pass(cb: vk::CommandBuffer) {
    record("vkCmdEndRenderPass", vec![cb.as_raw()]);
}

unsafe extern "system" fn cmd_begin_rendering(
    cb: vk::CommandBuffer,
    _: *const vk::RenderingInfo<'_>,
) {
    record("vkCmdBeginRendering", vec![cb.as_raw()]);
}

unsafe extern "system" fn cmd_end_rendering(cb: vk::CommandBuffer) {
    record("vkCmdEndRendering", vec![cb.as_raw()]);
}

unsafe extern "system" fn queue_submit(
    queue: vk::Queue,
    count: u32,
    _: *const vk::SubmitInfo<'_>,
    _: vk::Fence,
) -> vk::Result {
    record("vkQueueSubmit", vec![queue.as_raw(), u64::from(count)]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn create_acceleration_structure(
    _: vk::Device,
    _: *const vk::AccelerationStructureCreateInfoKHR<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::AccelerationStructureKHR,
) -> vk::Result {
    let handle = next_handle();
    record("vkCreateAccelerationStructureKHR", vec![handle]);
    unsafe { *out = vk::AccelerationStructureKHR::from_raw(handle) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_build_acceleration_structures(
    cb: vk::CommandBuffer,
    count: u32,
    _: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    _: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) {
    record(
        "vkCmdBuildAccelerationStructuresKHR",
        vec![cb.as_raw(), u64::from(count)],
    );
}

unsafe extern "system" fn cmd_copy_micromap(
    cb: vk::CommandBuffer,
    _: *const vk::CopyMicromapInfoEXT<'_>,
) {
    record("vkCmdCopyMicromapEXT", vec![cb.as_raw()]);
}

/// Fills the opacity micromap properties chained in `properties`.
unsafe extern "system" fn get_properties2(
    _: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties2<'_>,
) {
    let level = DRIVER.with_borrow(|d| d.reported_2_state_level);
    let mut next = unsafe { (*properties).p_next };
    while !next.is_null() {
        let base = unsafe { &mut *next.cast::<vk::BaseOutStructure<'_>>() };
        if base.s_type == vk::StructureType::PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_EXT {
            let p =
                unsafe { &mut *next.cast::<vk::PhysicalDeviceOpacityMicromapPropertiesEXT<'_>>() };
            p.max_opacity2_state_subdivision_level = level;
            p.max_opacity4_state_subdivision_level = level;
        }
        next = base.p_next.cast();
    }
    record("vkGetPhysicalDeviceProperties2", vec![]);
}

/// Writes `count` fresh handles to `out`.
unsafe fn fresh_handles<H: vk::Handle>(count: u32, out: *mut H) -> Vec<u64> {
    (0..count as usize)
        .map(|i| {
            let handle = next_handle();
            unsafe { *out.add(i) = H::from_raw(handle) };
            handle
        })
        .collect()
}

unsafe extern "system" fn create_shader_module(
    _: vk::Device,
    _: *const vk::ShaderModuleCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::ShaderModule,
) -> vk::Result {
    let handles = unsafe { fresh_handles(1, out) };
    record("vkCreateShaderModule", handles);
    vk::Result::SUCCESS
}

unsafe extern "system" fn create_compute_pipelines(
    _: vk::Device,
    _: vk::PipelineCache,
    count: u32,
    _: *const vk::ComputePipelineCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Pipeline,
) -> vk::Result {
    let handles = unsafe { fresh_handles(count, out) };
    record("vkCreateComputePipelines", handles);
    vk::Result::SUCCESS
}

/// Writes the handles at once; with a deferred operation it says the
/// creation was deferred.
unsafe extern "system" fn create_ray_tracing_pipelines(
    _: vk::Device,
    deferred: vk::DeferredOperationKHR,
    _: vk::PipelineCache,
    count: u32,
    _: *const vk::RayTracingPipelineCreateInfoKHR<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Pipeline,
) -> vk::Result {
    let handles = unsafe { fresh_handles(count, out) };
    record("vkCreateRayTracingPipelinesKHR", handles);
    if deferred == vk::DeferredOperationKHR::null() {
        vk::Result::SUCCESS
    } else {
        vk::Result::OPERATION_DEFERRED_KHR
    }
}

unsafe extern "system" fn deferred_operation_join(
    _: vk::Device,
    operation: vk::DeferredOperationKHR,
) -> vk::Result {
    record("vkDeferredOperationJoinKHR", vec![operation.as_raw()]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_pipeline_barrier2(
    cb: vk::CommandBuffer,
    _: *const vk::DependencyInfo<'_>,
) {
    record("vkCmdPipelineBarrier2", vec![cb.as_raw()]);
}

unsafe extern "system" fn create_descriptor_set_layout(
    _: vk::Device,
    _: *const vk::DescriptorSetLayoutCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::DescriptorSetLayout,
) -> vk::Result {
    unsafe { fresh_handles(1, out) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn allocate_descriptor_sets(
    _: vk::Device,
    info: *const vk::DescriptorSetAllocateInfo<'_>,
    out: *mut vk::DescriptorSet,
) -> vk::Result {
    unsafe { fresh_handles((*info).descriptor_set_count, out) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn update_descriptor_sets(
    _: vk::Device,
    writes: u32,
    _: *const vk::WriteDescriptorSet<'_>,
    copies: u32,
    _: *const vk::CopyDescriptorSet<'_>,
) {
    record(
        "vkUpdateDescriptorSets",
        vec![u64::from(writes), u64::from(copies)],
    );
}

#[allow(clippy::too_many_arguments)]
unsafe extern "system" fn cmd_bind_descriptor_sets(
    _: vk::CommandBuffer,
    _: vk::PipelineBindPoint,
    _: vk::PipelineLayout,
    first: u32,
    count: u32,
    _: *const vk::DescriptorSet,
    _: u32,
    _: *const u32,
) {
    record(
        "vkCmdBindDescriptorSets",
        vec![u64::from(first), u64::from(count)],
    );
}

unsafe extern "system" fn cmd_bind_pipeline(
    _: vk::CommandBuffer,
    point: vk::PipelineBindPoint,
    pipeline: vk::Pipeline,
) {
    record(
        "vkCmdBindPipeline",
        vec![point.as_raw() as u64, pipeline.as_raw()],
    );
}

type Region = *const vk::StridedDeviceAddressRegionKHR;

#[allow(clippy::too_many_arguments)]
unsafe extern "system" fn cmd_trace_rays(
    cb: vk::CommandBuffer,
    _: Region,
    _: Region,
    _: Region,
    _: Region,
    width: u32,
    height: u32,
    depth: u32,
) {
    record(
        "vkCmdTraceRaysKHR",
        vec![
            cb.as_raw(),
            u64::from(width),
            u64::from(height),
            u64::from(depth),
        ],
    );
}

/// A command no layer knows, which the fake driver has.
pub unsafe extern "system" fn unknown_command() {
    record("vkOmmcheckTestUnknownCommand", vec![]);
}

fn void<F: Copy>(f: F) -> vk::PFN_vkVoidFunction {
    // SAFETY: `F` is always a function pointer type here.
    Some(unsafe { std::mem::transmute_copy::<F, unsafe extern "system" fn()>(&f) })
}

/// The fake driver's device commands. It lacks vkCreateDeferredOperationKHR,
/// which the layer intercepts, so tests can see the layer hide it too.
fn device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkDestroyDevice" => void(destroy_device as vk::PFN_vkDestroyDevice),
        b"vkCreateBuffer" => void(create_buffer as vk::PFN_vkCreateBuffer),
        b"vkDestroyBuffer" => void(destroy_buffer as vk::PFN_vkDestroyBuffer),
        b"vkAllocateMemory" => void(allocate_memory as vk::PFN_vkAllocateMemory),
        b"vkFreeMemory" => void(free_memory as vk::PFN_vkFreeMemory),
        b"vkMapMemory" => void(map_memory as vk::PFN_vkMapMemory),
        b"vkUnmapMemory" => void(unmap_memory as vk::PFN_vkUnmapMemory),
        b"vkBindBufferMemory" => void(bind_buffer_memory as vk::PFN_vkBindBufferMemory),
        b"vkBindBufferMemory2" => void(bind_buffer_memory2 as vk::PFN_vkBindBufferMemory2),
        b"vkGetBufferDeviceAddress" => {
            void(get_buffer_device_address as vk::PFN_vkGetBufferDeviceAddress)
        }
        b"vkCreateMicromapEXT" => void(create_micromap as vk::PFN_vkCreateMicromapEXT),
        b"vkDestroyMicromapEXT" => void(destroy_micromap as vk::PFN_vkDestroyMicromapEXT),
        b"vkCmdBuildMicromapsEXT" => void(cmd_build_micromaps as vk::PFN_vkCmdBuildMicromapsEXT),
        b"vkBuildMicromapsEXT" => void(build_micromaps as vk::PFN_vkBuildMicromapsEXT),
        b"vkOmmcheckTestUnknownCommand" => void(unknown_command as unsafe extern "system" fn()),
        b"vkCreateCommandPool" => void(create_command_pool as vk::PFN_vkCreateCommandPool),
        b"vkCreateQueryPool" => void(create_query_pool as vk::PFN_vkCreateQueryPool),
        b"vkCmdBeginQuery" => void(cmd_begin_query as vk::PFN_vkCmdBeginQuery),
        b"vkAllocateCommandBuffers" => {
            void(allocate_command_buffers as vk::PFN_vkAllocateCommandBuffers)
        }
        b"vkBeginCommandBuffer" => void(begin_command_buffer as vk::PFN_vkBeginCommandBuffer),
        b"vkEndCommandBuffer" => void(end_command_buffer as vk::PFN_vkEndCommandBuffer),
        b"vkCmdCopyMicromapEXT" => void(cmd_copy_micromap as vk::PFN_vkCmdCopyMicromapEXT),
        b"vkCmdBeginRenderPass" => void(cmd_begin_render_pass as vk::PFN_vkCmdBeginRenderPass),
        b"vkCmdEndRenderPass" => void(cmd_end_render_pass as vk::PFN_vkCmdEndRenderPass),
        b"vkCmdBeginRendering" => void(cmd_begin_rendering as vk::PFN_vkCmdBeginRendering),
        b"vkCmdEndRendering" => void(cmd_end_rendering as vk::PFN_vkCmdEndRendering),
        b"vkQueueSubmit" => void(queue_submit as vk::PFN_vkQueueSubmit),
        b"vkCreateAccelerationStructureKHR" => {
            void(create_acceleration_structure as vk::PFN_vkCreateAccelerationStructureKHR)
        }
        b"vkCmdBuildAccelerationStructuresKHR" => {
            void(cmd_build_acceleration_structures as vk::PFN_vkCmdBuildAccelerationStructuresKHR)
        }
        b"vkCreateShaderModule" => void(create_shader_module as vk::PFN_vkCreateShaderModule),
        b"vkCreateComputePipelines" => {
            void(create_compute_pipelines as vk::PFN_vkCreateComputePipelines)
        }
        b"vkCreateRayTracingPipelinesKHR" => {
            void(create_ray_tracing_pipelines as vk::PFN_vkCreateRayTracingPipelinesKHR)
        }
        b"vkDeferredOperationJoinKHR" => {
            void(deferred_operation_join as vk::PFN_vkDeferredOperationJoinKHR)
        }
        b"vkCmdPipelineBarrier2" => void(cmd_pipeline_barrier2 as vk::PFN_vkCmdPipelineBarrier2),
        b"vkCreateDescriptorSetLayout" => {
            void(create_descriptor_set_layout as vk::PFN_vkCreateDescriptorSetLayout)
        }
        b"vkAllocateDescriptorSets" => {
            void(allocate_descriptor_sets as vk::PFN_vkAllocateDescriptorSets)
        }
        b"vkUpdateDescriptorSets" => void(update_descriptor_sets as vk::PFN_vkUpdateDescriptorSets),
        b"vkCmdBindDescriptorSets" => {
            void(cmd_bind_descriptor_sets as vk::PFN_vkCmdBindDescriptorSets)
        }
        b"vkCmdBindPipeline" => void(cmd_bind_pipeline as vk::PFN_vkCmdBindPipeline),
        b"vkCmdTraceRaysKHR" => void(cmd_trace_rays as vk::PFN_vkCmdTraceRaysKHR),
        _ => None,
    }
}

pub unsafe extern "system" fn fake_gdpa(
    _: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    device_command(unsafe { CStr::from_ptr(name) })
}

pub unsafe extern "system" fn fake_gipa(
    _: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    let name = unsafe { CStr::from_ptr(name) };
    match name.to_bytes() {
        b"vkCreateInstance" => void(create_instance as vk::PFN_vkCreateInstance),
        b"vkDestroyInstance" => void(destroy_instance as vk::PFN_vkDestroyInstance),
        b"vkCreateDevice" => void(create_device as vk::PFN_vkCreateDevice),
        b"vkGetPhysicalDeviceQueueFamilyProperties" => {
            void(get_queue_family_properties as vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties)
        }
        b"vkGetPhysicalDeviceMemoryProperties" => {
            void(get_memory_properties as vk::PFN_vkGetPhysicalDeviceMemoryProperties)
        }
        b"vkCreateDebugUtilsMessengerEXT" => {
            void(create_messenger as vk::PFN_vkCreateDebugUtilsMessengerEXT)
        }
        b"vkDestroyDebugUtilsMessengerEXT" => {
            void(destroy_messenger as vk::PFN_vkDestroyDebugUtilsMessengerEXT)
        }
        b"vkGetDeviceProcAddr" => void(fake_gdpa as vk::PFN_vkGetDeviceProcAddr),
        b"vkGetPhysicalDeviceProperties2" => {
            void(get_properties2 as vk::PFN_vkGetPhysicalDeviceProperties2)
        }
        _ => device_command(name),
    }
}

/// One message a messenger received.
#[derive(Clone, Debug)]
pub struct Received {
    pub severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    pub id: String,
    pub number: i32,
    pub text: String,
    pub objects: Vec<(vk::ObjectType, u64)>,
}

/// What a test's messenger collects, and what its callback returns.
#[derive(Default)]
pub struct Collector {
    pub received: Mutex<Vec<Received>>,
    pub answer: std::sync::atomic::AtomicU32,
}

impl Collector {
    pub fn take(&self) -> Vec<Received> {
        std::mem::take(&mut *self.received.lock().unwrap())
    }

    pub fn answer_with(&self, value: vk::Bool32) {
        self.answer
            .store(value, std::sync::atomic::Ordering::SeqCst);
    }
}

pub unsafe extern "system" fn collect(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let collector = unsafe { &*user_data.cast::<Collector>() };
    let data = unsafe { &*data };
    let text = |p: *const c_char| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned();
    let objects = unsafe { std::slice::from_raw_parts(data.p_objects, data.object_count as usize) }
        .iter()
        .map(|o| (o.object_type, o.object_handle))
        .collect();
    collector.received.lock().unwrap().push(Received {
        severity,
        id: text(data.p_message_id_name),
        number: data.message_id_number,
        text: text(data.p_message),
        objects,
    });
    collector.answer.load(std::sync::atomic::Ordering::SeqCst)
}

/// The layer's function `name`, through its own vkGetInstanceProcAddr.
pub fn instance_fn<F: Copy>(instance: vk::Instance, name: &CStr) -> F {
    // SAFETY: a NUL-terminated name.
    let f = unsafe { layer::vkGetInstanceProcAddr(instance, name.as_ptr()) }
        .unwrap_or_else(|| panic!("the layer returned NULL for {name:?}"));
    // SAFETY: the caller names the command's function type.
    unsafe { std::mem::transmute_copy(&f) }
}

/// The layer's function `name`, through its own vkGetDeviceProcAddr.
pub fn device_fn<F: Copy>(device: vk::Device, name: &CStr) -> F {
    // SAFETY: a NUL-terminated name.
    let f = unsafe { layer::vkGetDeviceProcAddr(device, name.as_ptr()) }
        .unwrap_or_else(|| panic!("the layer returned NULL for {name:?}"));
    // SAFETY: the caller names the command's function type.
    unsafe { std::mem::transmute_copy(&f) }
}

/// An instance and device created through the layer over the fake driver,
/// with a messenger for errors and warnings.
pub struct Chain {
    pub instance: vk::Instance,
    pub device: vk::Device,
    pub physical_device: vk::PhysicalDevice,
    pub command_buffer: vk::CommandBuffer,
    pub messenger: vk::DebugUtilsMessengerEXT,
    pub collector: Box<Collector>,
}

/// Creates the instance as the loader would: a `VkLayerInstanceCreateInfo`
/// link to the fake driver in the chain. Returns the result, the instance,
/// and whether the layer advanced the link.
pub fn create_instance_through_layer(with_link: bool) -> (vk::Result, vk::Instance, bool) {
    create_instance_with(with_link, std::ptr::null())
}

/// As [`create_instance_through_layer`], with the application's own pNext
/// chain `next` after the loader's link info.
pub fn create_instance_with(
    with_link: bool,
    next: *const std::ffi::c_void,
) -> (vk::Result, vk::Instance, bool) {
    let mut link = LayerInstanceLink {
        p_next: std::ptr::null_mut(),
        pfn_next_get_instance_proc_addr: Some(fake_gipa),
        pfn_next_get_physical_device_proc_addr: None,
    };
    let link_info = LayerInstanceCreateInfo {
        s_type: vk::StructureType::LOADER_INSTANCE_CREATE_INFO,
        p_next: next,
        function: LAYER_LINK_INFO,
        u: LayerInstanceCreateInfoUnion {
            p_layer_info: &mut link,
        },
    };
    let info = vk::InstanceCreateInfo {
        p_next: if with_link {
            (&link_info as *const LayerInstanceCreateInfo).cast()
        } else {
            next
        },
        ..Default::default()
    };
    let create: vk::PFN_vkCreateInstance = instance_fn(vk::Instance::null(), c"vkCreateInstance");
    let mut instance = vk::Instance::null();
    // SAFETY: a valid create info as the loader builds it.
    let result = unsafe { create(&info, std::ptr::null(), &mut instance) };
    // SAFETY: the union holds pLayerInfo.
    let advanced = unsafe { link_info.u.p_layer_info.is_null() };
    (result, instance, advanced)
}

/// Registers a messenger for `severities` that collects into `collector`.
pub fn add_messenger(
    instance: vk::Instance,
    severities: vk::DebugUtilsMessageSeverityFlagsEXT,
    collector: &Collector,
) -> vk::DebugUtilsMessengerEXT {
    let create: vk::PFN_vkCreateDebugUtilsMessengerEXT =
        instance_fn(instance, c"vkCreateDebugUtilsMessengerEXT");
    let info = vk::DebugUtilsMessengerCreateInfoEXT {
        message_severity: severities,
        message_type: vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
        pfn_user_callback: Some(collect),
        p_user_data: (collector as *const Collector).cast_mut().cast(),
        ..Default::default()
    };
    let mut messenger = vk::DebugUtilsMessengerEXT::null();
    // SAFETY: a valid create info; the collector outlives the messenger.
    let result = unsafe { create(instance, &info, std::ptr::null(), &mut messenger) };
    assert_eq!(result, vk::Result::SUCCESS);
    messenger
}

impl Chain {
    /// The chain, with `VK_EXT_opacity_micromap` and its `micromap` and
    /// `micromapHostCommands` features and `bufferDeviceAddress` enabled.
    pub fn new() -> Self {
        Self::with_instance_next(std::ptr::null())
    }

    /// As [`Chain::new`], with `next` (the application's structures, such
    /// as a `VkLayerSettingsCreateInfoEXT`) chained to `VkInstanceCreateInfo`.
    pub fn with_instance_next(next: *const std::ffi::c_void) -> Self {
        let chain = Self::with_chains(next, std::ptr::null_mut());
        assert_eq!(chain.1, vk::Result::SUCCESS);
        chain.0
    }

    /// As [`Chain::new`], with `extra` (NULL, or a structure with a NULL
    /// pNext) chained to the device create info too; returns what
    /// vkCreateDevice returned.
    pub fn with_device_chain(extra: *mut vk::BaseOutStructure<'_>) -> (Self, vk::Result) {
        Self::with_chains(std::ptr::null(), extra)
    }

    /// The chain with `next` after the instance's link info and `extra` in
    /// the device create info.
    fn with_chains(
        next: *const std::ffi::c_void,
        extra: *mut vk::BaseOutStructure<'_>,
    ) -> (Self, vk::Result) {
        let (result, instance, advanced) = create_instance_with(true, next);
        assert_eq!(result, vk::Result::SUCCESS);
        assert!(advanced, "the layer did not advance the instance link");
        let collector = Box::<Collector>::default();
        let messenger = add_messenger(
            instance,
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
            &collector,
        );
        let physical_device = vk::PhysicalDevice::from_raw(dispatchable(key_of(instance.as_raw())));
        let mut link = LayerDeviceLink {
            p_next: std::ptr::null_mut(),
            pfn_next_get_instance_proc_addr: Some(fake_gipa),
            pfn_next_get_device_proc_addr: Some(fake_gdpa),
        };
        let mut micromap = vk::PhysicalDeviceOpacityMicromapFeaturesEXT {
            micromap: vk::TRUE,
            micromap_host_commands: vk::TRUE,
            ..Default::default()
        };
        let mut address = vk::PhysicalDeviceBufferDeviceAddressFeatures {
            buffer_device_address: vk::TRUE,
            p_next: extra.cast(),
            ..Default::default()
        };
        let names = [
            c"VK_EXT_opacity_micromap".as_ptr(),
            c"VK_KHR_acceleration_structure".as_ptr(),
            c"VK_KHR_deferred_host_operations".as_ptr(),
        ];
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default().queue_priorities(&priorities)];
        let mut info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&names)
            .push_next(&mut micromap)
            .push_next(&mut address);
        let link_info = LayerDeviceCreateInfo {
            s_type: vk::StructureType::LOADER_DEVICE_CREATE_INFO,
            p_next: info.p_next,
            function: LAYER_LINK_INFO,
            u: LayerDeviceCreateInfoUnion {
                p_layer_info: &mut link,
            },
        };
        info.p_next = (&link_info as *const LayerDeviceCreateInfo).cast();
        let create: vk::PFN_vkCreateDevice = instance_fn(instance, c"vkCreateDevice");
        let mut device = vk::Device::null();
        // SAFETY: a valid create info as the loader builds it.
        let result = unsafe { create(physical_device, &info, std::ptr::null(), &mut device) };
        // SAFETY: the union holds pLayerInfo.
        let advanced = unsafe { link_info.u.p_layer_info.is_null() };
        assert!(
            advanced || result != vk::Result::SUCCESS,
            "device link not advanced"
        );
        let command_buffer = vk::CommandBuffer::from_raw(dispatchable(key_of(device.as_raw())));
        let chain = Self {
            instance,
            device,
            physical_device,
            command_buffer,
            messenger,
            collector,
        };
        (chain, result)
    }

    pub fn buffer(&self, size: u64, usage: vk::BufferUsageFlags, memory_type: u32) -> vk::Buffer {
        self.buffer_and_memory(size, usage, memory_type).0
    }

    /// A buffer bound at offset 0 to memory of its own, and the memory.
    pub fn buffer_and_memory(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
        memory_type: u32,
    ) -> (vk::Buffer, vk::DeviceMemory) {
        let create: vk::PFN_vkCreateBuffer = device_fn(self.device, c"vkCreateBuffer");
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        let mut buffer = vk::Buffer::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut buffer) };
        assert_eq!(result, vk::Result::SUCCESS);
        let memory = self.memory(size, memory_type);
        let bind: vk::PFN_vkBindBufferMemory = device_fn(self.device, c"vkBindBufferMemory");
        // SAFETY: valid arguments.
        assert_eq!(
            unsafe { bind(self.device, buffer, memory, 0) },
            vk::Result::SUCCESS
        );
        (buffer, memory)
    }

    pub fn memory(&self, size: u64, memory_type: u32) -> vk::DeviceMemory {
        let allocate: vk::PFN_vkAllocateMemory = device_fn(self.device, c"vkAllocateMemory");
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(size)
            .memory_type_index(memory_type);
        let mut memory = vk::DeviceMemory::null();
        // SAFETY: valid arguments.
        let result = unsafe { allocate(self.device, &info, std::ptr::null(), &mut memory) };
        assert_eq!(result, vk::Result::SUCCESS);
        memory
    }

    /// Maps `memory`, which the fake driver places at `host`.
    pub fn map(&self, memory: vk::DeviceMemory, host: *mut u8) {
        map_to(host);
        let map: vk::PFN_vkMapMemory = device_fn(self.device, c"vkMapMemory");
        let mut mapped = std::ptr::null_mut();
        // SAFETY: valid arguments.
        let result = unsafe {
            map(
                self.device,
                memory,
                0,
                vk::WHOLE_SIZE,
                vk::MemoryMapFlags::empty(),
                &mut mapped,
            )
        };
        assert_eq!(result, vk::Result::SUCCESS);
        assert_eq!(mapped.cast::<u8>(), host);
    }

    pub fn address(&self, buffer: vk::Buffer) -> u64 {
        let get: vk::PFN_vkGetBufferDeviceAddress =
            device_fn(self.device, c"vkGetBufferDeviceAddress");
        let info = vk::BufferDeviceAddressInfo::default().buffer(buffer);
        // SAFETY: valid arguments.
        unsafe { get(self.device, &info) }
    }

    pub fn micromap(&self, buffer: vk::Buffer, size: u64) -> vk::MicromapEXT {
        let create: vk::PFN_vkCreateMicromapEXT = device_fn(self.device, c"vkCreateMicromapEXT");
        let info = vk::MicromapCreateInfoEXT {
            buffer,
            size,
            ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
            ..Default::default()
        };
        let mut micromap = vk::MicromapEXT::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut micromap) };
        assert_eq!(result, vk::Result::SUCCESS);
        micromap
    }
}

/// Two 2-state level-1 triangles (one byte of data each).
pub const USAGE: [vk::MicromapUsageEXT; 1] = [vk::MicromapUsageEXT {
    count: 2,
    subdivision_level: 1,
    format: 1,
}];

/// Everything a device build reads, created through the layer.
pub struct DeviceBuild {
    pub micromap: vk::MicromapEXT,
    pub input: u64,
    pub scratch: u64,
}

impl DeviceBuild {
    pub fn new(chain: &Chain) -> Self {
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
        let micromap = chain.micromap(storage, 4096);
        let input = chain.buffer(
            4096,
            vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            0,
        );
        let scratch = chain.buffer(
            4096,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            0,
        );
        Self {
            micromap,
            input: chain.address(input),
            scratch: chain.address(scratch),
        }
    }

    /// A valid build info: the triangle array at the start of the input
    /// buffer, the data 256 bytes in.
    pub fn info(&self) -> vk::MicromapBuildInfoEXT<'static> {
        vk::MicromapBuildInfoEXT {
            ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
            mode: vk::BuildMicromapModeEXT::BUILD,
            dst_micromap: self.micromap,
            usage_counts_count: 1,
            p_usage_counts: USAGE.as_ptr(),
            data: vk::DeviceOrHostAddressConstKHR {
                device_address: self.input + 256,
            },
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                device_address: self.input,
            },
            triangle_array_stride: 8,
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: self.scratch,
            },
            ..Default::default()
        }
    }
}
