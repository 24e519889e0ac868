//! A fake loader and driver for in-process chain tests: the test plays the
//! loader (it builds the `VkLayer*CreateInfo` link chain) and the next
//! layer (`fake_gipa` / `fake_gdpa` return recording stubs written here).
//!
//! Dispatchable handles are leaked boxes whose first word is a dispatch
//! key, as the loader's are: a physical device shares its instance's key,
//! a command buffer its device's. Each test thread records its own calls.
//!
//! `layer/fake-icd` builds this module into an ICD the real loader loads
//! (with the call log off, see [`unlogged`]).

// Each test crate uses part of the fake driver.
#![allow(unsafe_code, clippy::missing_safety_doc, dead_code)]

use std::cell::RefCell;
use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

use ash::vk;
use ash::vk::Handle as _;
use layer::own_calls::OwnCall;
use VkLayer_ommcheck as layer;

pub mod app;
pub mod gpu;

use layer::abi::{
    LayerDeviceCreateInfo, LayerDeviceCreateInfoUnion, LayerDeviceLink, LayerInstanceCreateInfo,
    LayerInstanceCreateInfoUnion, LayerInstanceLink, LAYER_LINK_INFO,
};

/// A call the fake driver received: its name, the arguments a test looks
/// at, (while [`describe_calls`] is on) what its pointers pointed to and
/// what it returned, as text, and which of the layer's own calls it was
/// (None: one the layer passed on from the application).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Call {
    pub name: &'static str,
    pub args: Vec<u64>,
    pub detail: String,
    pub own: Option<OwnCall>,
}

#[derive(Default)]
struct Driver {
    calls: Vec<Call>,
    /// This thread's handles are `base + 1`, `base + 2`, ...: threads share
    /// the layer, which tracks objects by handle, so no two threads may hand
    /// out the same one.
    base: u64,
    next_handle: u64,
    /// What the next vkMapMemory hands out instead of the allocation's own
    /// bytes: test-owned memory (0: none).
    mapped: usize,
    /// The maxOpacity2StateSubdivisionLevel vkGetPhysicalDeviceProperties2 reports.
    reported_2_state_level: u32,
    /// Whether calls are logged with their pointed-to contents. Off unless
    /// a test asks: other tests pass counts their arrays do not hold (the
    /// layer must bound what it reads; the fake driver would read them).
    describe: bool,
    /// Command buffers handed out since the last [`reset`], reused in order
    /// after it, so a rerun of the same calls sees the same handles.
    command_buffers: Vec<u64>,
    next_command_buffer: usize,
    /// The layer's own objects' handles are `base + OWN_HANDLES + 1`, ...:
    /// apart from the application's, so the application gets the same
    /// handles with and without the layer.
    next_own_handle: u64,
    /// The layer's own call to fail, and with what (see [`fail_own`]).
    fail: Option<(OwnCall, vk::Result)>,
    /// The own calls failed, in order, with the command that failed.
    failed: Vec<(OwnCall, &'static str, vk::Result)>,
}

/// Where the layer's own handles start in a thread's range of 2^24.
const OWN_HANDLES: u64 = 1 << 23;

/// Gives each thread's driver its own range of handles.
static THREADS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

thread_local! {
    static DRIVER: RefCell<Driver> = RefCell::new({
        // Handles stay below 2^44 (buffer addresses are `handle << 20`) for
        // the first 2^20 threads; no test process starts that many.
        let base = THREADS.fetch_add(1, std::sync::atomic::Ordering::Relaxed) << 24;
        Driver {
            base,
            next_handle: base + 1,
            next_own_handle: base + OWN_HANDLES + 1,
            reported_2_state_level: 3,
            ..Driver::default()
        }
    });
}

/// Whether this process keeps call logs and fault lists at all; the ICD
/// build (`layer/fake-icd`) turns them off with [`unlogged`].
static LOGGED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);

/// Turns the call log off for the whole process, and makes the fake GPU's
/// faults go to stderr instead of a list: the ICD build serves
/// applications that never read either, and a long run would keep every
/// call it made.
pub fn unlogged() {
    LOGGED.store(false, std::sync::atomic::Ordering::Relaxed);
}

/// Whether calls and faults are kept (see [`unlogged`]).
fn logged() -> bool {
    LOGGED.load(std::sync::atomic::Ordering::Relaxed)
}

fn record(name: &'static str, args: Vec<u64>) {
    record_with(name, args, String::new);
}

/// Records the call, with `detail()` when calls are described.
fn record_with(name: &'static str, args: Vec<u64>, detail: impl FnOnce() -> String) {
    if !logged() {
        return;
    }
    let describe = DRIVER.with_borrow(|d| d.describe);
    let detail = if describe { detail() } else { String::new() };
    let own = layer::testing::own_call_in_progress();
    DRIVER.with_borrow_mut(|d| {
        d.calls.push(Call {
            name,
            args,
            detail,
            own,
        })
    });
}

fn next_handle() -> u64 {
    let own = layer::testing::own_call_in_progress().is_some();
    DRIVER.with_borrow_mut(|d| {
        let next = if own {
            &mut d.next_own_handle
        } else {
            &mut d.next_handle
        };
        *next += 1;
        *next
    })
}

/// Makes this thread's fake driver fail the layer's own `call` with
/// `result`, every time until [`heal`]; the application's calls of the
/// same command go on succeeding.
pub fn fail_own(call: OwnCall, result: vk::Result) {
    DRIVER.with_borrow_mut(|d| d.fail = Some((call, result)));
}

/// Ends [`fail_own`]: the driver has recovered.
pub fn heal() {
    DRIVER.with_borrow_mut(|d| d.fail = None);
}

/// The layer's own calls this thread's driver failed, in order, with the
/// command each was made to.
pub fn failed_own() -> Vec<(OwnCall, &'static str, vk::Result)> {
    DRIVER.with_borrow(|d| d.failed.clone())
}

/// The error `name` returns now: the one [`fail_own`] asked for, where
/// the call is the layer's own call it named (recorded with no arguments,
/// the error in [`failed_own`]); None to go on.
fn injected_failure(name: &'static str) -> Option<vk::Result> {
    let own = layer::testing::own_call_in_progress()?;
    let result = DRIVER.with_borrow_mut(|d| {
        let (call, result) = d.fail.filter(|(call, _)| *call == own)?;
        d.failed.push((call, name, result));
        Some(result)
    })?;
    record(name, Vec::new());
    Some(result)
}

/// The calls this thread's fake driver received with `name`.
pub fn calls(name: &str) -> Vec<Call> {
    DRIVER.with_borrow(|d| d.calls.iter().filter(|c| c.name == name).cloned().collect())
}

/// Every call this thread's fake driver received, in order.
pub fn all_calls() -> Vec<Call> {
    DRIVER.with_borrow(|d| d.calls.clone())
}

/// Turns the logging of pointed-to contents on or off for this thread.
pub fn describe_calls(on: bool) {
    DRIVER.with_borrow_mut(|d| d.describe = on);
}

/// Forgets this thread's calls, keeping its handles counting on.
pub fn reset_calls() {
    DRIVER.with_borrow_mut(|d| d.calls.clear());
}

/// Forgets this thread's calls and starts its handles (and command
/// buffers) over, so the same calls made again get the same handles back.
/// Forgets the calls recorded so far (benchmarks run many thousands).
pub fn clear_calls() {
    DRIVER.with_borrow_mut(|d| d.calls.clear());
}

pub fn reset() {
    DRIVER.with_borrow_mut(|d| {
        d.calls.clear();
        d.next_handle = d.base + 1;
        d.next_command_buffer = 0;
        d.failed.clear();
    });
}

/// Makes this thread's next vkMapMemory return `memory`, test-owned bytes,
/// instead of a pointer into the allocation (whose bytes the fake GPU's
/// commands read and write; test-owned bytes they do not see).
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

/// Frees a handle [`dispatchable`] made, for the ICD build, whose
/// application's command buffers come and go for as long as it runs.
///
/// # Safety
/// `handle` came from [`dispatchable`], is not freed yet, and nothing uses
/// it any more.
pub unsafe fn release_dispatchable(handle: u64) {
    let object = std::ptr::with_exposed_provenance_mut::<Dispatchable>(handle as usize);
    // SAFETY: the caller's guarantee: a box `dispatchable` leaked.
    drop(unsafe { Box::from_raw(object) });
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
    record("vkGetPhysicalDeviceMemoryProperties", vec![]);
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

unsafe extern "system" fn create_report_callback(
    _: vk::Instance,
    _: *const vk::DebugReportCallbackCreateInfoEXT<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::DebugReportCallbackEXT,
) -> vk::Result {
    unsafe { *out = vk::DebugReportCallbackEXT::from_raw(next_handle()) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_report_callback(
    _: vk::Instance,
    c: vk::DebugReportCallbackEXT,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyDebugReportCallbackEXT", vec![c.as_raw()]);
}

unsafe extern "system" fn create_buffer(
    _: vk::Device,
    info: *const vk::BufferCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Buffer,
) -> vk::Result {
    if let Some(failed) = injected_failure("vkCreateBuffer") {
        return failed;
    }
    let handle = next_handle();
    record_with(
        "vkCreateBuffer",
        vec![unsafe { (*info).size }, handle],
        || {
            let i = unsafe { &*info };
            format!(
                "{:?} {:?} {:?} next={}",
                i.flags,
                i.usage,
                i.sharing_mode,
                unsafe { chain(i.p_next) }
            )
        },
    );
    gpu::create_buffer(handle, unsafe { (*info).size }, unsafe { (*info).usage });
    unsafe { *out = vk::Buffer::from_raw(handle) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn destroy_buffer(
    _: vk::Device,
    b: vk::Buffer,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyBuffer", vec![b.as_raw()]);
    gpu::destroy_buffer(b.as_raw());
}

unsafe extern "system" fn allocate_memory(
    _: vk::Device,
    info: *const vk::MemoryAllocateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::DeviceMemory,
) -> vk::Result {
    if let Some(failed) = injected_failure("vkAllocateMemory") {
        return failed;
    }
    let handle = next_handle();
    record_with("vkAllocateMemory", vec![handle], || {
        let i = unsafe { &*info };
        format!(
            "size={} type={} next={}",
            i.allocation_size,
            i.memory_type_index,
            unsafe { chain(i.p_next) }
        )
    });
    let result = gpu::allocate(handle, unsafe { (*info).allocation_size }, unsafe {
        (*info).memory_type_index
    });
    if result == vk::Result::SUCCESS {
        unsafe { *out = vk::DeviceMemory::from_raw(handle) };
    }
    result
}

unsafe extern "system" fn free_memory(
    _: vk::Device,
    m: vk::DeviceMemory,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkFreeMemory", vec![m.as_raw()]);
    gpu::free(m.as_raw());
}

unsafe extern "system" fn map_memory(
    _: vk::Device,
    m: vk::DeviceMemory,
    offset: vk::DeviceSize,
    size: vk::DeviceSize,
    flags: vk::MemoryMapFlags,
    out: *mut *mut c_void,
) -> vk::Result {
    if let Some(failed) = injected_failure("vkMapMemory") {
        return failed;
    }
    let test_owned = DRIVER.with_borrow_mut(|d| std::mem::take(&mut d.mapped));
    let mapped = if test_owned != 0 {
        test_owned
    } else {
        match gpu::mapping(m.as_raw(), offset) {
            Some(address) => address,
            None => return vk::Result::ERROR_MEMORY_MAP_FAILED,
        }
    };
    record(
        "vkMapMemory",
        vec![
            m.as_raw(),
            offset,
            size,
            u64::from(flags.as_raw()),
            mapped as u64,
        ],
    );
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
    offset: vk::DeviceSize,
) -> vk::Result {
    if let Some(failed) = injected_failure("vkBindBufferMemory") {
        return failed;
    }
    record("vkBindBufferMemory", vec![b.as_raw(), m.as_raw()]);
    gpu::bind(b.as_raw(), m.as_raw(), offset);
    vk::Result::SUCCESS
}

/// Buffer `n` lives at device address `n << 20`.
unsafe extern "system" fn get_buffer_device_address(
    _: vk::Device,
    info: *const vk::BufferDeviceAddressInfo<'_>,
) -> vk::DeviceAddress {
    let buffer = unsafe { (*info).buffer.as_raw() };
    record("vkGetBufferDeviceAddress", vec![buffer, buffer << 20]);
    buffer << 20
}

unsafe extern "system" fn create_micromap(
    _: vk::Device,
    info: *const vk::MicromapCreateInfoEXT<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::MicromapEXT,
) -> vk::Result {
    let handle = next_handle();
    record_with("vkCreateMicromapEXT", vec![handle], || {
        let i = unsafe { &*info };
        format!(
            "{:?} buffer={} offset={} size={} {:?} address={} next={}",
            i.create_flags,
            i.buffer.as_raw(),
            i.offset,
            i.size,
            i.ty,
            i.device_address,
            unsafe { chain(i.p_next) }
        )
    });
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
    record_with(
        "vkCmdBuildMicromapsEXT",
        vec![
            cb.as_raw(),
            u64::from(count),
            infos.expose_provenance() as u64,
            stride,
        ],
        || unsafe { each(infos, count, |i| micromap_build_info(i)) },
    );
}

unsafe extern "system" fn build_micromaps(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) -> vk::Result {
    record_with(
        "vkBuildMicromapsEXT",
        vec![
            d.as_raw(),
            op.as_raw(),
            u64::from(count),
            infos.expose_provenance() as u64,
        ],
        || unsafe { each(infos, count, |i| micromap_build_info(i)) },
    );
    vk::Result::SUCCESS
}

/// The queue families: 0 with graphics, compute and transfer, 1 with
/// transfer only (for the rules that depend on a pool's family).
const QUEUE_FAMILIES: [vk::QueueFlags; 2] = [
    vk::QueueFlags::from_raw(
        vk::QueueFlags::GRAPHICS.as_raw()
            | vk::QueueFlags::COMPUTE.as_raw()
            | vk::QueueFlags::TRANSFER.as_raw(),
    ),
    vk::QueueFlags::TRANSFER,
];

unsafe extern "system" fn get_queue_family_properties(
    _: vk::PhysicalDevice,
    count: *mut u32,
    out: *mut vk::QueueFamilyProperties,
) {
    record(
        "vkGetPhysicalDeviceQueueFamilyProperties",
        vec![u64::from(out.is_null())],
    );
    if out.is_null() {
        unsafe { *count = QUEUE_FAMILIES.len() as u32 };
        return;
    }
    let written = (unsafe { *count } as usize).min(QUEUE_FAMILIES.len());
    for (i, flags) in QUEUE_FAMILIES.iter().take(written).enumerate() {
        unsafe {
            *out.add(i) = vk::QueueFamilyProperties {
                queue_flags: *flags,
                queue_count: 1,
                ..Default::default()
            };
        }
    }
    unsafe { *count = written as u32 };
}

unsafe extern "system" fn create_command_pool(
    _: vk::Device,
    info: *const vk::CommandPoolCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::CommandPool,
) -> vk::Result {
    let handle = next_handle();
    record_with("vkCreateCommandPool", vec![handle], || {
        let i = unsafe { &*info };
        format!("{:?} family={}", i.flags, i.queue_family_index)
    });
    unsafe { *out = vk::CommandPool::from_raw(handle) };
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

unsafe extern "system" fn cmd_reset_query_pool(
    cb: vk::CommandBuffer,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
) {
    let args = vec![
        cb.as_raw(),
        pool.as_raw(),
        u64::from(first),
        u64::from(count),
    ];
    record("vkCmdResetQueryPool", args);
}

unsafe extern "system" fn cmd_write_micromaps_properties(
    cb: vk::CommandBuffer,
    count: u32,
    _: *const vk::MicromapEXT,
    _: vk::QueryType,
    pool: vk::QueryPool,
    first: u32,
) {
    let args = vec![
        cb.as_raw(),
        u64::from(count),
        pool.as_raw(),
        u64::from(first),
    ];
    record("vkCmdWriteMicromapsPropertiesEXT", args);
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
    let i = unsafe { &*info };
    let key = key_of(device.as_raw());
    let handles: Vec<u64> = (0..i.command_buffer_count)
        .map(|_| {
            // The ICD build never resets (its application's handles are
            // not rerun), and would keep every handle it ever made.
            if !logged() {
                return dispatchable(key);
            }
            DRIVER.with_borrow_mut(|d| {
                // Reuse the handle this position had before a reset, if it
                // was this device's.
                let reused = d
                    .command_buffers
                    .get(d.next_command_buffer)
                    .copied()
                    .filter(|&h| key_of(h) == key);
                let handle = reused.unwrap_or_else(|| dispatchable(key));
                if reused.is_none() {
                    d.command_buffers.truncate(d.next_command_buffer);
                    d.command_buffers.push(handle);
                }
                d.next_command_buffer += 1;
                handle
            })
        })
        .collect();
    for (k, &handle) in handles.iter().enumerate() {
        unsafe { *out.add(k) = vk::CommandBuffer::from_raw(handle) };
    }
    for &handle in &handles {
        gpu::allocated(handle, i.command_pool.as_raw());
    }
    record_with("vkAllocateCommandBuffers", handles, || {
        format!(
            "pool={} {:?} count={}",
            i.command_pool.as_raw(),
            i.level,
            i.command_buffer_count
        )
    });
    vk::Result::SUCCESS
}

unsafe extern "system" fn begin_command_buffer(
    cb: vk::CommandBuffer,
    info: *const vk::CommandBufferBeginInfo<'_>,
) -> vk::Result {
    // Beginning resets what was recorded.
    gpu::forget(cb.as_raw());
    record_with("vkBeginCommandBuffer", vec![cb.as_raw()], || {
        let i = unsafe { &*info };
        format!(
            "{:?} inheritance={}",
            i.flags,
            !i.p_inheritance_info.is_null()
        )
    });
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
    submits: *const vk::SubmitInfo<'_>,
    fence: vk::Fence,
) -> vk::Result {
    record_with(
        "vkQueueSubmit",
        vec![queue.as_raw(), u64::from(count)],
        || {
            let submits = unsafe {
                each(submits, count, |s| {
                    format!(
                        "waits={:?} stages={:?} command_buffers={:?} signals={:?} next={}",
                        slice(s.p_wait_semaphores, s.wait_semaphore_count),
                        slice(s.p_wait_dst_stage_mask, s.wait_semaphore_count),
                        slice(s.p_command_buffers, s.command_buffer_count),
                        slice(s.p_signal_semaphores, s.signal_semaphore_count),
                        chain(s.p_next),
                    )
                })
            };
            format!("{submits} fence={}", fence.as_raw())
        },
    );
    unsafe { gpu::execute_submits(count, submits, fence) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn create_acceleration_structure(
    _: vk::Device,
    info: *const vk::AccelerationStructureCreateInfoKHR<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::AccelerationStructureKHR,
) -> vk::Result {
    let handle = next_handle();
    record_with("vkCreateAccelerationStructureKHR", vec![handle], || {
        let i = unsafe { &*info };
        format!(
            "{:?} buffer={} offset={} size={} {:?} address={} next={}",
            i.create_flags,
            i.buffer.as_raw(),
            i.offset,
            i.size,
            i.ty,
            i.device_address,
            unsafe { chain(i.p_next) }
        )
    });
    unsafe { *out = vk::AccelerationStructureKHR::from_raw(handle) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_build_acceleration_structures(
    cb: vk::CommandBuffer,
    count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    ranges: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) {
    record_with(
        "vkCmdBuildAccelerationStructuresKHR",
        vec![cb.as_raw(), u64::from(count)],
        || unsafe { structure_builds(count, infos, ranges) },
    );
}

unsafe extern "system" fn cmd_build_acceleration_structures_indirect(
    cb: vk::CommandBuffer,
    count: u32,
    _: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    _: *const vk::DeviceAddress,
    _: *const u32,
    _: *const *const u32,
) {
    record(
        "vkCmdBuildAccelerationStructuresIndirectKHR",
        vec![cb.as_raw(), u64::from(count)],
    );
}

unsafe extern "system" fn cmd_copy_micromap(
    cb: vk::CommandBuffer,
    info: *const vk::CopyMicromapInfoEXT<'_>,
) {
    record_with("vkCmdCopyMicromapEXT", vec![cb.as_raw()], || unsafe {
        copy_micromap_info(&*info)
    });
}

unsafe extern "system" fn cmd_copy_micromap_to_memory(
    cb: vk::CommandBuffer,
    info: *const vk::CopyMicromapToMemoryInfoEXT<'_>,
) {
    let i = unsafe { &*info };
    let dst = unsafe { i.dst.device_address };
    record(
        "vkCmdCopyMicromapToMemoryEXT",
        vec![cb.as_raw(), i.src.as_raw(), dst],
    );
}

/// The serialization size the fake driver reports for every micromap.
pub const SERIALIZATION_SIZE: u64 = 512;

/// Writes [`SERIALIZATION_SIZE`] (or, for compacted sizes, 256) for each
/// micromap at `stride` intervals.
unsafe extern "system" fn write_micromaps_properties(
    _: vk::Device,
    count: u32,
    _: *const vk::MicromapEXT,
    query_type: vk::QueryType,
    data_size: usize,
    data: *mut c_void,
    stride: usize,
) -> vk::Result {
    let size = if query_type == vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT {
        SERIALIZATION_SIZE
    } else {
        256
    };
    for k in 0..count as usize {
        if k * stride + 8 <= data_size {
            unsafe {
                data.cast::<u8>()
                    .add(k * stride)
                    .cast::<u64>()
                    .write_unaligned(size)
            };
        }
    }
    record(
        "vkWriteMicromapsPropertiesEXT",
        vec![u64::from(count), query_type.as_raw() as u64],
    );
    vk::Result::SUCCESS
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

// What the call log shows of pointed-to structures (only while
// `describe_calls` is on): every member the application set, arrays
// element by element (at most `MAX_DESCRIBED` elements), pNext chains as
// their sTypes.

/// The most elements of one array a description shows.
const MAX_DESCRIBED: u32 = 64;

/// The first `count` elements at `pointer` (at most [`MAX_DESCRIBED`]);
/// None for NULL.
unsafe fn slice<T: Copy + std::fmt::Debug>(pointer: *const T, count: u32) -> Option<Vec<T>> {
    (!pointer.is_null()).then(|| {
        unsafe { std::slice::from_raw_parts(pointer, count.min(MAX_DESCRIBED) as usize) }.to_vec()
    })
}

/// `describe` of each of the `count` structures at `pointer`.
unsafe fn each<T>(pointer: *const T, count: u32, describe: impl Fn(&T) -> String) -> String {
    if pointer.is_null() {
        return "NULL".into();
    }
    let items: Vec<String> = (0..count.min(MAX_DESCRIBED) as usize)
        .map(|k| describe(unsafe { &*pointer.add(k) }))
        .collect();
    format!("[{}]", items.join("; "))
}

/// The sTypes of a pNext chain (at most 16).
unsafe fn chain(mut next: *const c_void) -> String {
    let mut types = Vec::new();
    while !next.is_null() && types.len() < 16 {
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        types.push(base.s_type.as_raw());
        next = base.p_next.cast();
    }
    format!("{types:?}")
}

fn address(a: vk::DeviceOrHostAddressConstKHR) -> u64 {
    // SAFETY: both members are 64 bits; any bits are a valid u64.
    unsafe { a.device_address }
}

fn address_mut(a: vk::DeviceOrHostAddressKHR) -> u64 {
    // SAFETY: as above.
    unsafe { a.device_address }
}

/// The usage counts, by array and by pointers.
unsafe fn usage_counts(
    count: u32,
    array: *const vk::MicromapUsageEXT,
    pointers: *const *const vk::MicromapUsageEXT,
) -> String {
    let by_pointer = unsafe { each(pointers, count, |p| format!("{:?}", p.as_ref())) };
    format!("count={count} array={:?} pointers={by_pointer}", unsafe {
        slice(array, count)
    })
}

unsafe fn micromap_build_info(i: &vk::MicromapBuildInfoEXT<'_>) -> String {
    format!(
        "{:?} {:?} {:?} dst={} usage=({}) data={:#x} scratch={:#x} triangles={:#x} stride={} next={}",
        i.ty,
        i.flags,
        i.mode,
        i.dst_micromap.as_raw(),
        unsafe { usage_counts(i.usage_counts_count, i.p_usage_counts, i.pp_usage_counts) },
        address(i.data),
        address_mut(i.scratch_data),
        address(i.triangle_array),
        i.triangle_array_stride,
        unsafe { chain(i.p_next) },
    )
}

unsafe fn geometry(g: &vk::AccelerationStructureGeometryKHR<'_>) -> String {
    let data = match g.geometry_type {
        vk::GeometryTypeKHR::TRIANGLES => {
            let t = unsafe { g.geometry.triangles };
            let mut attachments = Vec::new();
            let mut next = t.p_next;
            while !next.is_null() && attachments.len() < 16 {
                let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
                if base.s_type
                    == vk::StructureType::ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT
                {
                    let a = unsafe {
                        &*next.cast::<vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>>()
                    };
                    attachments.push(format!(
                        "omm {:?} indices={:#x} stride={} base={} usage=({}) micromap={}",
                        a.index_type,
                        address(a.index_buffer),
                        a.index_stride,
                        a.base_triangle,
                        unsafe {
                            usage_counts(a.usage_counts_count, a.p_usage_counts, a.pp_usage_counts)
                        },
                        a.micromap.as_raw(),
                    ));
                } else {
                    attachments.push(format!("{}", base.s_type.as_raw()));
                }
                next = base.p_next.cast();
            }
            format!(
                "triangles {:?} vertices={:#x} stride={} max={} {:?} indices={:#x} transform={:#x} next={attachments:?}",
                t.vertex_format,
                address(t.vertex_data),
                t.vertex_stride,
                t.max_vertex,
                t.index_type,
                address(t.index_data),
                address(t.transform_data),
            )
        }
        vk::GeometryTypeKHR::AABBS => {
            let a = unsafe { g.geometry.aabbs };
            format!(
                "aabbs data={:#x} stride={} next={}",
                address(a.data),
                a.stride,
                unsafe { chain(a.p_next) }
            )
        }
        vk::GeometryTypeKHR::INSTANCES => {
            let n = unsafe { g.geometry.instances };
            format!(
                "instances pointers={} data={:#x} next={}",
                n.array_of_pointers,
                address(n.data),
                unsafe { chain(n.p_next) }
            )
        }
        other => format!("{other:?}"),
    };
    format!("{:?} {data} next={}", g.flags, unsafe { chain(g.p_next) })
}

unsafe fn build_geometry_info(i: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>) -> String {
    let geometries = unsafe { each(i.p_geometries, i.geometry_count, |g| geometry(g)) };
    let by_pointer = unsafe {
        each(i.pp_geometries, i.geometry_count, |g| match g.as_ref() {
            Some(g) => geometry(g),
            None => "NULL".into(),
        })
    };
    format!(
        "{:?} {:?} {:?} src={} dst={} count={} geometries={geometries} pointers={by_pointer} scratch={:#x} next={}",
        i.ty,
        i.flags,
        i.mode,
        i.src_acceleration_structure.as_raw(),
        i.dst_acceleration_structure.as_raw(),
        i.geometry_count,
        address_mut(i.scratch_data),
        unsafe { chain(i.p_next) },
    )
}

/// The infos of a build and, for each, its `geometryCount` range infos.
unsafe fn structure_builds(
    count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    ranges: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) -> String {
    let described = unsafe { each(infos, count, |i| build_geometry_info(i)) };
    let ranges: Vec<String> = (0..count.min(MAX_DESCRIBED) as usize)
        .map(|k| {
            if ranges.is_null() || infos.is_null() {
                return "NULL".into();
            }
            let list = unsafe { *ranges.add(k) };
            format!("{:?}", unsafe {
                slice(list, (*infos.add(k)).geometry_count)
            })
        })
        .collect();
    format!("{described} ranges={ranges:?}")
}

fn copy_micromap_info(i: &vk::CopyMicromapInfoEXT<'_>) -> String {
    format!(
        "src={} dst={} {:?} next={}",
        i.src.as_raw(),
        i.dst.as_raw(),
        i.mode,
        unsafe { chain(i.p_next) }
    )
}

fn copy_structure_info(i: &vk::CopyAccelerationStructureInfoKHR<'_>) -> String {
    format!(
        "src={} dst={} {:?} next={}",
        i.src.as_raw(),
        i.dst.as_raw(),
        i.mode,
        unsafe { chain(i.p_next) }
    )
}

unsafe extern "system" fn destroy_acceleration_structure(
    _: vk::Device,
    s: vk::AccelerationStructureKHR,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyAccelerationStructureKHR", vec![s.as_raw()]);
}

/// A host build; returns OPERATION_NOT_DEFERRED_KHR with a deferred
/// operation (a success code the application must see as such).
unsafe extern "system" fn build_acceleration_structures(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    ranges: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) -> vk::Result {
    record_with(
        "vkBuildAccelerationStructuresKHR",
        vec![d.as_raw(), op.as_raw(), u64::from(count)],
        || unsafe { structure_builds(count, infos, ranges) },
    );
    if op == vk::DeferredOperationKHR::null() {
        vk::Result::SUCCESS
    } else {
        vk::Result::OPERATION_NOT_DEFERRED_KHR
    }
}

/// Writes sizes that depend on every primitive count, so an altered
/// argument shows in what the application gets.
unsafe extern "system" fn get_acceleration_structure_build_sizes(
    _: vk::Device,
    build_type: vk::AccelerationStructureBuildTypeKHR,
    info: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    max_primitive_counts: *const u32,
    out: *mut vk::AccelerationStructureBuildSizesInfoKHR<'_>,
) {
    let i = unsafe { &*info };
    let counts = unsafe { slice(max_primitive_counts, i.geometry_count) }.unwrap_or_default();
    let primitives: u64 = counts.iter().map(|&c| u64::from(c)).sum();
    let out = unsafe { &mut *out };
    out.acceleration_structure_size = 256 + 64 * primitives;
    out.update_scratch_size = 128 + 16 * primitives;
    out.build_scratch_size = 512 + 32 * primitives;
    record_with(
        "vkGetAccelerationStructureBuildSizesKHR",
        vec![build_type.as_raw() as u64, out.acceleration_structure_size],
        || format!("{} counts={counts:?}", unsafe { build_geometry_info(i) }),
    );
}

/// Writes sizes that depend on the usage counts (see
/// [`get_acceleration_structure_build_sizes`]).
unsafe extern "system" fn get_micromap_build_sizes(
    _: vk::Device,
    build_type: vk::AccelerationStructureBuildTypeKHR,
    info: *const vk::MicromapBuildInfoEXT<'_>,
    out: *mut vk::MicromapBuildSizesInfoEXT<'_>,
) {
    let i = unsafe { &*info };
    let usage = unsafe { slice(i.p_usage_counts, i.usage_counts_count) }.unwrap_or_default();
    let triangles: u64 = usage.iter().map(|u| u64::from(u.count)).sum();
    let out = unsafe { &mut *out };
    out.micromap_size = 1024 + 8 * triangles;
    out.build_scratch_size = 2048 + triangles;
    out.discardable = vk::TRUE;
    record_with(
        "vkGetMicromapBuildSizesEXT",
        vec![build_type.as_raw() as u64, out.micromap_size],
        || unsafe { micromap_build_info(i) },
    );
}

/// The driver UUID of the fake driver: serialized micromap data whose
/// first 16 bytes are these is compatible with it, other data is not.
pub const DRIVER_UUID: [u8; 16] = *b"ommcheck-fake-dr";

/// Serialized micromap data at a host address aligned as
/// `vkCopyMemoryToMicromapEXT` requires (16 bytes): its version (a driver
/// UUID, then 16 bytes of compatibility data), then zeros.
#[repr(C, align(16))]
pub struct Serialized(pub [u8; 64]);

impl Serialized {
    pub fn new(driver_uuid: [u8; 16], compatibility: u8) -> Self {
        let mut data = Self([0; 64]);
        data.0[..16].copy_from_slice(&driver_uuid);
        data.0[16..32].fill(compatibility);
        data
    }

    /// The info that deserializes this data into `micromap` on the host.
    pub fn deserialize_into(
        &self,
        micromap: vk::MicromapEXT,
    ) -> vk::CopyMemoryToMicromapInfoEXT<'_> {
        vk::CopyMemoryToMicromapInfoEXT {
            src: vk::DeviceOrHostAddressConstKHR {
                host_address: self.0.as_ptr().cast(),
            },
            dst: micromap,
            mode: vk::CopyMicromapModeEXT::DESERIALIZE,
            ..Default::default()
        }
    }
}

/// Answers compatible iff the version data starts with [`DRIVER_UUID`];
/// records the answer (1 compatible, 0 not).
unsafe extern "system" fn get_device_micromap_compatibility(
    _: vk::Device,
    info: *const vk::MicromapVersionInfoEXT<'_>,
    out: *mut vk::AccelerationStructureCompatibilityKHR,
) {
    let version = unsafe { &*(*info).p_version_data };
    let compatible = version[..16] == DRIVER_UUID;
    unsafe {
        *out = if compatible {
            vk::AccelerationStructureCompatibilityKHR::COMPATIBLE
        } else {
            vk::AccelerationStructureCompatibilityKHR::INCOMPATIBLE
        }
    };
    record(
        "vkGetDeviceMicromapCompatibilityEXT",
        vec![u64::from(compatible)],
    );
}

/// The serialized data the fake driver writes on the host, 64 bytes: the
/// header ([`DRIVER_UUID`], 16 zero bytes of compatibility data, the
/// serialized size 64, the deserialized size, a count of 0), then the
/// serialized object's handle, so that each object's bytes differ.
pub const HOST_SERIALIZED_SIZE: usize = 64;

/// Writes [`HOST_SERIALIZED_SIZE`] bytes of serialized `object` at `dst`.
///
/// # Safety
/// `dst` must be writable for [`HOST_SERIALIZED_SIZE`] bytes.
unsafe fn write_serialization(dst: *mut u8, object: u64) {
    let mut data = [0u8; HOST_SERIALIZED_SIZE];
    data[..16].copy_from_slice(&DRIVER_UUID);
    data[32..40].copy_from_slice(&(HOST_SERIALIZED_SIZE as u64).to_le_bytes());
    data[40..48].copy_from_slice(&1024u64.to_le_bytes());
    data[56..64].copy_from_slice(&object.to_le_bytes());
    unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), dst, data.len()) };
}

unsafe extern "system" fn copy_micromap_to_memory(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    info: *const vk::CopyMicromapToMemoryInfoEXT<'_>,
) -> vk::Result {
    record("vkCopyMicromapToMemoryEXT", vec![d.as_raw(), op.as_raw()]);
    let i = unsafe { &*info };
    let dst = unsafe { i.dst.host_address }.cast::<u8>();
    if !dst.is_null() {
        unsafe { write_serialization(dst, i.src.as_raw()) };
    }
    vk::Result::SUCCESS
}

unsafe extern "system" fn copy_acceleration_structure_to_memory(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    info: *const vk::CopyAccelerationStructureToMemoryInfoKHR<'_>,
) -> vk::Result {
    record(
        "vkCopyAccelerationStructureToMemoryKHR",
        vec![d.as_raw(), op.as_raw()],
    );
    let i = unsafe { &*info };
    let dst = unsafe { i.dst.host_address }.cast::<u8>();
    if !dst.is_null() {
        unsafe { write_serialization(dst, i.src.as_raw()) };
    }
    vk::Result::SUCCESS
}

unsafe extern "system" fn copy_memory_to_micromap(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    _: *const vk::CopyMemoryToMicromapInfoEXT<'_>,
) -> vk::Result {
    record("vkCopyMemoryToMicromapEXT", vec![d.as_raw(), op.as_raw()]);
    vk::Result::SUCCESS
}

unsafe extern "system" fn copy_micromap(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    info: *const vk::CopyMicromapInfoEXT<'_>,
) -> vk::Result {
    record_with("vkCopyMicromapEXT", vec![d.as_raw(), op.as_raw()], || {
        copy_micromap_info(unsafe { &*info })
    });
    vk::Result::SUCCESS
}

unsafe extern "system" fn cmd_copy_acceleration_structure(
    cb: vk::CommandBuffer,
    info: *const vk::CopyAccelerationStructureInfoKHR<'_>,
) {
    record_with(
        "vkCmdCopyAccelerationStructureKHR",
        vec![cb.as_raw()],
        || copy_structure_info(unsafe { &*info }),
    );
}

unsafe extern "system" fn copy_acceleration_structure(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    info: *const vk::CopyAccelerationStructureInfoKHR<'_>,
) -> vk::Result {
    record_with(
        "vkCopyAccelerationStructureKHR",
        vec![d.as_raw(), op.as_raw()],
        || copy_structure_info(unsafe { &*info }),
    );
    vk::Result::SUCCESS
}

unsafe extern "system" fn copy_memory_to_acceleration_structure(
    d: vk::Device,
    op: vk::DeferredOperationKHR,
    info: *const vk::CopyMemoryToAccelerationStructureInfoKHR<'_>,
) -> vk::Result {
    record_with(
        "vkCopyMemoryToAccelerationStructureKHR",
        vec![d.as_raw(), op.as_raw()],
        || format!("dst={:#x}", unsafe { &*info }.dst.as_raw()),
    );
    vk::Result::SUCCESS
}

unsafe extern "system" fn free_command_buffers(
    _: vk::Device,
    pool: vk::CommandPool,
    count: u32,
    command_buffers: *const vk::CommandBuffer,
) {
    let mut args = vec![pool.as_raw()];
    args.extend(
        unsafe { slice(command_buffers, count) }
            .unwrap_or_default()
            .iter()
            .map(|c| c.as_raw()),
    );
    for &command_buffer in &args[1..] {
        gpu::freed(command_buffer);
    }
    record("vkFreeCommandBuffers", args);
}

unsafe extern "system" fn destroy_command_pool(
    _: vk::Device,
    pool: vk::CommandPool,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyCommandPool", vec![pool.as_raw()]);
    gpu::pool_destroyed(pool.as_raw());
}

/// A command no layer knows, which the fake driver has.
pub unsafe extern "system" fn unknown_command() {
    record("vkOmmcheckTestUnknownCommand", vec![]);
}

/// A command as the loader's `PFN_vkVoidFunction` (the ICD build's tables,
/// `layer/fake-icd`, use it too).
pub fn void<F: Copy>(f: F) -> vk::PFN_vkVoidFunction {
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
        b"vkBindBufferMemory2" | b"vkBindBufferMemory2KHR" => {
            void(gpu::bind_buffer_memory2 as vk::PFN_vkBindBufferMemory2)
        }
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
        b"vkCmdResetQueryPool" => void(cmd_reset_query_pool as vk::PFN_vkCmdResetQueryPool),
        b"vkCmdWriteMicromapsPropertiesEXT" => {
            void(cmd_write_micromaps_properties as vk::PFN_vkCmdWriteMicromapsPropertiesEXT)
        }
        b"vkAllocateCommandBuffers" => {
            void(allocate_command_buffers as vk::PFN_vkAllocateCommandBuffers)
        }
        b"vkBeginCommandBuffer" => void(begin_command_buffer as vk::PFN_vkBeginCommandBuffer),
        b"vkEndCommandBuffer" => void(end_command_buffer as vk::PFN_vkEndCommandBuffer),
        b"vkCmdCopyMicromapEXT" => void(cmd_copy_micromap as vk::PFN_vkCmdCopyMicromapEXT),
        b"vkCmdCopyMicromapToMemoryEXT" => {
            void(cmd_copy_micromap_to_memory as vk::PFN_vkCmdCopyMicromapToMemoryEXT)
        }
        b"vkWriteMicromapsPropertiesEXT" => {
            void(write_micromaps_properties as vk::PFN_vkWriteMicromapsPropertiesEXT)
        }
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
        b"vkCmdBuildAccelerationStructuresIndirectKHR" => void(
            cmd_build_acceleration_structures_indirect
                as vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR,
        ),
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
        b"vkCmdPipelineBarrier2" | b"vkCmdPipelineBarrier2KHR" => {
            void(gpu::cmd_pipeline_barrier2 as vk::PFN_vkCmdPipelineBarrier2)
        }
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
        b"vkDestroyAccelerationStructureKHR" => {
            void(destroy_acceleration_structure as vk::PFN_vkDestroyAccelerationStructureKHR)
        }
        b"vkBuildAccelerationStructuresKHR" => {
            void(build_acceleration_structures as vk::PFN_vkBuildAccelerationStructuresKHR)
        }
        b"vkGetAccelerationStructureBuildSizesKHR" => void(
            get_acceleration_structure_build_sizes
                as vk::PFN_vkGetAccelerationStructureBuildSizesKHR,
        ),
        b"vkGetMicromapBuildSizesEXT" => {
            void(get_micromap_build_sizes as vk::PFN_vkGetMicromapBuildSizesEXT)
        }
        b"vkCopyMicromapEXT" => void(copy_micromap as vk::PFN_vkCopyMicromapEXT),
        b"vkGetDeviceMicromapCompatibilityEXT" => {
            void(get_device_micromap_compatibility as vk::PFN_vkGetDeviceMicromapCompatibilityEXT)
        }
        b"vkCopyMemoryToMicromapEXT" => {
            void(copy_memory_to_micromap as vk::PFN_vkCopyMemoryToMicromapEXT)
        }
        b"vkCopyMicromapToMemoryEXT" => {
            void(copy_micromap_to_memory as vk::PFN_vkCopyMicromapToMemoryEXT)
        }
        b"vkCmdCopyAccelerationStructureKHR" => {
            void(cmd_copy_acceleration_structure as vk::PFN_vkCmdCopyAccelerationStructureKHR)
        }
        b"vkCopyAccelerationStructureKHR" => {
            void(copy_acceleration_structure as vk::PFN_vkCopyAccelerationStructureKHR)
        }
        b"vkCopyMemoryToAccelerationStructureKHR" => void(
            copy_memory_to_acceleration_structure as vk::PFN_vkCopyMemoryToAccelerationStructureKHR,
        ),
        b"vkCopyAccelerationStructureToMemoryKHR" => void(
            copy_acceleration_structure_to_memory as vk::PFN_vkCopyAccelerationStructureToMemoryKHR,
        ),
        b"vkFreeCommandBuffers" => void(free_command_buffers as vk::PFN_vkFreeCommandBuffers),
        b"vkDestroyCommandPool" => void(destroy_command_pool as vk::PFN_vkDestroyCommandPool),
        _ => gpu_command(name),
    }
}

/// The commands of the fake GPU (see `gpu`).
fn gpu_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkResetCommandBuffer" => void(gpu::reset_command_buffer as vk::PFN_vkResetCommandBuffer),
        b"vkGetBufferMemoryRequirements" => {
            void(gpu::get_buffer_memory_requirements as vk::PFN_vkGetBufferMemoryRequirements)
        }
        b"vkGetBufferMemoryRequirements2" | b"vkGetBufferMemoryRequirements2KHR" => {
            void(gpu::get_buffer_memory_requirements2 as vk::PFN_vkGetBufferMemoryRequirements2)
        }
        b"vkFlushMappedMemoryRanges" | b"vkInvalidateMappedMemoryRanges" => {
            void(gpu::flush_or_invalidate as vk::PFN_vkFlushMappedMemoryRanges)
        }
        b"vkResetCommandPool" => void(gpu::reset_command_pool as vk::PFN_vkResetCommandPool),
        b"vkCmdCopyBuffer" => void(gpu::cmd_copy_buffer as vk::PFN_vkCmdCopyBuffer),
        b"vkCmdCopyBuffer2" | b"vkCmdCopyBuffer2KHR" => {
            void(gpu::cmd_copy_buffer2 as vk::PFN_vkCmdCopyBuffer2)
        }
        b"vkCmdUpdateBuffer" => void(gpu::cmd_update_buffer as vk::PFN_vkCmdUpdateBuffer),
        b"vkCmdFillBuffer" => void(gpu::cmd_fill_buffer as vk::PFN_vkCmdFillBuffer),
        b"vkCmdPipelineBarrier" => void(gpu::cmd_pipeline_barrier as vk::PFN_vkCmdPipelineBarrier),
        b"vkCmdExecuteCommands" => void(gpu::cmd_execute_commands as vk::PFN_vkCmdExecuteCommands),
        b"vkCmdDispatch" => void(gpu::cmd_dispatch as vk::PFN_vkCmdDispatch),
        b"vkQueueSubmit2" | b"vkQueueSubmit2KHR" => {
            void(gpu::queue_submit2 as vk::PFN_vkQueueSubmit2)
        }
        b"vkQueueWaitIdle" => void(gpu::queue_wait_idle as vk::PFN_vkQueueWaitIdle),
        b"vkDeviceWaitIdle" => void(gpu::device_wait_idle as vk::PFN_vkDeviceWaitIdle),
        b"vkGetDeviceQueue" => void(gpu::get_device_queue as vk::PFN_vkGetDeviceQueue),
        b"vkCreateFence" => void(gpu::create_fence as vk::PFN_vkCreateFence),
        b"vkDestroyFence" => void(gpu::destroy_fence as vk::PFN_vkDestroyFence),
        b"vkResetFences" => void(gpu::reset_fences as vk::PFN_vkResetFences),
        b"vkWaitForFences" => void(gpu::wait_for_fences as vk::PFN_vkWaitForFences),
        b"vkGetFenceStatus" => void(gpu::get_fence_status as vk::PFN_vkGetFenceStatus),
        b"vkCreateSemaphore" => void(gpu::create_semaphore as vk::PFN_vkCreateSemaphore),
        b"vkDestroySemaphore" => void(gpu::destroy_semaphore as vk::PFN_vkDestroySemaphore),
        b"vkGetSemaphoreCounterValue" | b"vkGetSemaphoreCounterValueKHR" => {
            void(gpu::get_semaphore_counter_value as vk::PFN_vkGetSemaphoreCounterValue)
        }
        b"vkWaitSemaphores" | b"vkWaitSemaphoresKHR" => {
            void(gpu::wait_semaphores as vk::PFN_vkWaitSemaphores)
        }
        b"vkSignalSemaphore" | b"vkSignalSemaphoreKHR" => {
            void(gpu::signal_semaphore as vk::PFN_vkSignalSemaphore)
        }
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
        b"vkCreateDebugReportCallbackEXT" => {
            void(create_report_callback as vk::PFN_vkCreateDebugReportCallbackEXT)
        }
        b"vkDestroyDebugReportCallbackEXT" => {
            void(destroy_report_callback as vk::PFN_vkDestroyDebugReportCallbackEXT)
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
        Self::with_settings(&[])
    }

    /// As [`Chain::new`], with `next` (the application's structures, such
    /// as a `VkLayerSettingsCreateInfoEXT`) chained to `VkInstanceCreateInfo`.
    pub fn with_instance_next(next: *const std::ffi::c_void) -> Self {
        let chain = Self::with_chains(next, std::ptr::null_mut(), true);
        assert_eq!(chain.1, vk::Result::SUCCESS);
        chain.0
    }

    /// As [`Chain::new`], with `extra` (NULL, or a structure with a NULL
    /// pNext) chained to the device create info too; returns what
    /// vkCreateDevice returned.
    pub fn with_device_chain(extra: *mut vk::BaseOutStructure<'_>) -> (Self, vk::Result) {
        app::with_settings(&[], |next| Self::with_chains(next, extra, true))
    }

    /// The chain with `next` after the instance's link info and `extra` in
    /// the device create info; `micromap` false leaves the micromap
    /// features off.
    fn with_chains(
        next: *const std::ffi::c_void,
        extra: *mut vk::BaseOutStructure<'_>,
        micromap: bool,
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
            micromap: micromap.into(),
            micromap_host_commands: micromap.into(),
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

    /// Maps `memory`, which the fake driver places at `host` (test-owned
    /// bytes, which the fake GPU's commands do not see).
    pub fn map(&self, memory: vk::DeviceMemory, host: *mut u8) {
        map_to(host);
        assert_eq!(self.map_backing(memory), host);
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

/// The two 2-state level-1 triangles of [`USAGE`], their data at bytes 0
/// and 1 (one byte each).
pub const TRIANGLES: [vk::MicromapTriangleEXT; 2] = [
    vk::MicromapTriangleEXT {
        data_offset: 0,
        subdivision_level: 1,
        format: 1,
    },
    vk::MicromapTriangleEXT {
        data_offset: 1,
        subdivision_level: 1,
        format: 1,
    },
];

/// A device build of `usage` into `micromap`: the triangle array (stride
/// 8) at `triangles`, the data at `data`, scratch at `scratch`.
pub fn device_micromap_build(
    micromap: vk::MicromapEXT,
    usage: &'static [vk::MicromapUsageEXT],
    triangles: u64,
    data: u64,
    scratch: u64,
) -> vk::MicromapBuildInfoEXT<'static> {
    vk::MicromapBuildInfoEXT {
        ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
        mode: vk::BuildMicromapModeEXT::BUILD,
        dst_micromap: micromap,
        usage_counts_count: usage.len() as u32,
        p_usage_counts: usage.as_ptr(),
        data: vk::DeviceOrHostAddressConstKHR {
            device_address: data,
        },
        triangle_array: vk::DeviceOrHostAddressConstKHR {
            device_address: triangles,
        },
        triangle_array_stride: 8,
        scratch_data: vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        },
        ..Default::default()
    }
}

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

    /// Records this build through the layer with both `pUsageCounts` and
    /// `ppUsageCounts` set (VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516).
    pub fn record_with_both_usage_pointers(&self, chain: &Chain) {
        let pointers = [USAGE.as_ptr()];
        let faulty = vk::MicromapBuildInfoEXT {
            pp_usage_counts: pointers.as_ptr(),
            ..self.info()
        };
        let cmd: vk::PFN_vkCmdBuildMicromapsEXT =
            device_fn(chain.device, c"vkCmdBuildMicromapsEXT");
        // SAFETY: valid pointers for one info.
        unsafe { cmd(chain.command_buffer, 1, &faulty) };
    }

    /// A valid build info: the triangle array at the start of the input
    /// buffer, the data 256 bytes in.
    pub fn info(&self) -> vk::MicromapBuildInfoEXT<'static> {
        device_micromap_build(
            self.micromap,
            &USAGE,
            self.input,
            self.input + 256,
            self.scratch,
        )
    }
}
