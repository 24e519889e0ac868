//! The fake driver of the layer's in-process tests (`layer/tests/fake`) as
//! an installable client driver: the real Vulkan loader loads
//! `libVkICD_ommcheck_fake.so` from a manifest (`VK_DRIVER_FILES`), so an
//! application runs through the loader and the layer over a driver with
//! `VK_EXT_opacity_micromap` whose GPU holds real bytes and executes
//! transfers at submission (see `fake/gpu.rs`). The Khronos Mock ICD runs
//! no command and returns 0 for every buffer device address, so over it
//! the layer can check no device build's contents; over this driver it
//! can, including the inputs it reads back from device-local memory.
//!
//! What is added here is only what the loader asks of a driver and the
//! in-process tests never needed: interface negotiation, one physical
//! device with its properties, features and extensions, and the loader's
//! magic value in the first word of new dispatchable objects (the loader
//! then writes its dispatch table there). Every other command is the
//! fake's. The call log and fault list are off (see `fake::unlogged`):
//! nobody reads them in another process, and a soak would keep every call.
//!
//! The fake hands each thread its own range of handles, so threads of one
//! application never collide, and executes a submission inside
//! vkQueueSubmit: a fence is signaled when the call returns.

#![allow(unsafe_code, non_snake_case)]

#[path = "../tests/fake/mod.rs"]
mod fake;

use std::collections::{HashMap, HashSet};
use std::ffi::{c_char, CStr};
use std::sync::{Mutex, OnceLock, PoisonError};

use ash::vk;
use ash::vk::Handle as _;
use fake::void;

/// `ICD_LOADER_MAGIC` (vk_icd.h): what a new dispatchable object's first
/// word holds until the loader writes its dispatch table pointer there.
const ICD_LOADER_MAGIC: usize = 0x01CD_C0DE;

/// The loader–driver interface version offered: 5, under which the loader
/// passes the application's apiVersion through unchanged.
const ICD_INTERFACE_VERSION: u32 = 5;

/// The device extensions the fake implements the commands of.
const DEVICE_EXTENSIONS: [(&CStr, u32); 7] = [
    (c"VK_EXT_opacity_micromap", 2),
    (c"VK_KHR_acceleration_structure", 13),
    (c"VK_KHR_deferred_host_operations", 4),
    (c"VK_KHR_buffer_device_address", 1),
    (c"VK_KHR_synchronization2", 1),
    (c"VK_KHR_timeline_semaphore", 2),
    (c"VK_KHR_copy_commands2", 1),
];

/// The name applications find the fake's physical device by.
pub const DEVICE_NAME: &CStr = c"ommcheck fake driver";

/// `vk_icdNegotiateLoaderICDInterfaceVersion`.
///
/// # Safety
/// `version` points to the loader's version.
#[no_mangle]
pub unsafe extern "system" fn vk_icdNegotiateLoaderICDInterfaceVersion(
    version: *mut u32,
) -> vk::Result {
    // SAFETY: the loader passes a valid pointer.
    let Some(version) = (unsafe { version.as_mut() }) else {
        return vk::Result::ERROR_INCOMPATIBLE_DRIVER;
    };
    // Version 2 is the first with vk_icdGetInstanceProcAddr.
    if *version < 2 {
        return vk::Result::ERROR_INCOMPATIBLE_DRIVER;
    }
    *version = (*version).min(ICD_INTERFACE_VERSION);
    fake::unlogged();
    vk::Result::SUCCESS
}

/// `vk_icdGetInstanceProcAddr`: the commands added here, then the fake's.
///
/// # Safety
/// `name` is NUL-terminated.
#[no_mangle]
pub unsafe extern "system" fn vk_icdGetInstanceProcAddr(
    instance: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: the loader passes a NUL-terminated name.
    let wanted = unsafe { CStr::from_ptr(name) };
    // SAFETY: as above.
    instance_command(wanted).or_else(|| unsafe { fake::fake_gipa(instance, name) })
}

/// `vk_icdGetPhysicalDeviceProcAddr`: the physical-device commands the
/// loader does not know by name (none here are unknown to it).
///
/// # Safety
/// `name` is NUL-terminated.
#[no_mangle]
pub unsafe extern "system" fn vk_icdGetPhysicalDeviceProcAddr(
    _: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: the loader passes a NUL-terminated name.
    physical_device_command(unsafe { CStr::from_ptr(name) })
}

/// The fake's own `name`, of type `F` (the wrappers below call it).
fn fake_command<F: Copy>(name: &CStr) -> F {
    // SAFETY: a NUL-terminated name; the instance is not looked at.
    let f = unsafe { fake::fake_gipa(vk::Instance::null(), name.as_ptr()) }
        .unwrap_or_else(|| panic!("the fake driver lacks {name:?}"));
    // SAFETY: the caller names the command's function type.
    unsafe { std::mem::transmute_copy(&f) }
}

fn instance_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkEnumerateInstanceExtensionProperties" => void(
            enumerate_instance_extension_properties
                as vk::PFN_vkEnumerateInstanceExtensionProperties,
        ),
        b"vkEnumerateInstanceVersion" => {
            void(enumerate_instance_version as vk::PFN_vkEnumerateInstanceVersion)
        }
        b"vkEnumeratePhysicalDevices" => {
            void(enumerate_physical_devices as vk::PFN_vkEnumeratePhysicalDevices)
        }
        b"vkCreateDevice" => void(create_device as vk::PFN_vkCreateDevice),
        b"vkGetDeviceProcAddr" => void(icd_gdpa as vk::PFN_vkGetDeviceProcAddr),
        _ => physical_device_command(name).or_else(|| device_command(name)),
    }
}

fn physical_device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetPhysicalDeviceProperties" => {
            void(get_properties as vk::PFN_vkGetPhysicalDeviceProperties)
        }
        b"vkGetPhysicalDeviceProperties2" | b"vkGetPhysicalDeviceProperties2KHR" => {
            void(get_properties2 as vk::PFN_vkGetPhysicalDeviceProperties2)
        }
        b"vkGetPhysicalDeviceFeatures" => void(get_features as vk::PFN_vkGetPhysicalDeviceFeatures),
        b"vkGetPhysicalDeviceFeatures2" | b"vkGetPhysicalDeviceFeatures2KHR" => {
            void(get_features2 as vk::PFN_vkGetPhysicalDeviceFeatures2)
        }
        b"vkEnumerateDeviceExtensionProperties" => void(
            enumerate_device_extension_properties as vk::PFN_vkEnumerateDeviceExtensionProperties,
        ),
        // The loader requires these of every driver; the fake has no images.
        b"vkGetPhysicalDeviceFormatProperties" => {
            void(get_format_properties as vk::PFN_vkGetPhysicalDeviceFormatProperties)
        }
        b"vkGetPhysicalDeviceImageFormatProperties" => {
            void(get_image_format_properties as vk::PFN_vkGetPhysicalDeviceImageFormatProperties)
        }
        b"vkGetPhysicalDeviceSparseImageFormatProperties" => void(
            get_sparse_image_format_properties
                as vk::PFN_vkGetPhysicalDeviceSparseImageFormatProperties,
        ),
        _ => None,
    }
}

/// The device commands wrapped here; the rest are the fake's.
fn device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetDeviceProcAddr" => void(icd_gdpa as vk::PFN_vkGetDeviceProcAddr),
        b"vkAllocateCommandBuffers" => {
            void(allocate_command_buffers as vk::PFN_vkAllocateCommandBuffers)
        }
        b"vkFreeCommandBuffers" => void(free_command_buffers as vk::PFN_vkFreeCommandBuffers),
        b"vkDestroyCommandPool" => void(destroy_command_pool as vk::PFN_vkDestroyCommandPool),
        b"vkGetDeviceQueue" => void(get_device_queue as vk::PFN_vkGetDeviceQueue),
        _ => None,
    }
}

unsafe extern "system" fn icd_gdpa(
    device: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: the loader passes a NUL-terminated name.
    let wanted = unsafe { CStr::from_ptr(name) };
    // SAFETY: as above.
    device_command(wanted).or_else(|| unsafe { fake::fake_gdpa(device, name) })
}

/// Writes the loader's magic value into a new dispatchable object.
///
/// # Safety
/// `handle` is a dispatchable object of the fake's (a leaked box whose first
/// word is the dispatch key) that no other thread uses yet.
unsafe fn set_loader_magic(handle: u64) {
    let first = std::ptr::with_exposed_provenance_mut::<usize>(handle as usize);
    // SAFETY: the caller's guarantee: the first word of a live, unshared box.
    unsafe { first.write(ICD_LOADER_MAGIC) };
}

/// Copies `items` out in the two-call idiom: the count alone when `out` is
/// NULL, else at most `*count` of them and VK_INCOMPLETE when that is fewer.
///
/// # Safety
/// `count` is valid; `out` NULL or valid for `*count` elements.
unsafe fn enumerate<T: Copy>(items: &[T], count: *mut u32, out: *mut T) -> vk::Result {
    if out.is_null() {
        // SAFETY: the caller's guarantee.
        unsafe { *count = items.len() as u32 };
        return vk::Result::SUCCESS;
    }
    // SAFETY: as above.
    let room = unsafe { *count } as usize;
    let written = room.min(items.len());
    // SAFETY: `out` holds `room` elements, at least `written`.
    unsafe { std::ptr::copy_nonoverlapping(items.as_ptr(), out, written) };
    // SAFETY: as above.
    unsafe { *count = written as u32 };
    if written < items.len() {
        vk::Result::INCOMPLETE
    } else {
        vk::Result::SUCCESS
    }
}

unsafe extern "system" fn enumerate_instance_extension_properties(
    _: *const c_char,
    count: *mut u32,
    out: *mut vk::ExtensionProperties,
) -> vk::Result {
    // The loader implements debug utils and debug report itself.
    // SAFETY: the loader's pointers.
    unsafe { enumerate::<vk::ExtensionProperties>(&[], count, out) }
}

unsafe extern "system" fn enumerate_instance_version(version: *mut u32) -> vk::Result {
    // SAFETY: the loader's pointer.
    unsafe { *version = vk::API_VERSION_1_3 };
    vk::Result::SUCCESS
}

/// The one physical device, shared by every instance (the fake's physical
/// device functions look at no handle).
fn physical_device() -> vk::PhysicalDevice {
    static DEVICE: OnceLock<u64> = OnceLock::new();
    vk::PhysicalDevice::from_raw(*DEVICE.get_or_init(|| fake::dispatchable(ICD_LOADER_MAGIC)))
}

unsafe extern "system" fn enumerate_physical_devices(
    _: vk::Instance,
    count: *mut u32,
    out: *mut vk::PhysicalDevice,
) -> vk::Result {
    // SAFETY: the loader's pointers.
    unsafe { enumerate(&[physical_device()], count, out) }
}

fn properties() -> vk::PhysicalDeviceProperties {
    let mut properties = vk::PhysicalDeviceProperties {
        api_version: vk::API_VERSION_1_3,
        driver_version: 1,
        device_type: vk::PhysicalDeviceType::CPU,
        ..Default::default()
    };
    for (to, from) in properties
        .device_name
        .iter_mut()
        .zip(DEVICE_NAME.to_bytes_with_nul())
    {
        *to = *from as c_char;
    }
    properties
}

unsafe extern "system" fn get_properties(
    _: vk::PhysicalDevice,
    out: *mut vk::PhysicalDeviceProperties,
) {
    // SAFETY: the loader's pointer.
    unsafe { *out = properties() };
}

/// The core properties, then the fake's micromap properties in the chain.
unsafe extern "system" fn get_properties2(
    physical: vk::PhysicalDevice,
    out: *mut vk::PhysicalDeviceProperties2<'_>,
) {
    // SAFETY: the application's structure, through the loader.
    unsafe { (*out).properties = properties() };
    let fake: vk::PFN_vkGetPhysicalDeviceProperties2 =
        fake_command(c"vkGetPhysicalDeviceProperties2");
    // SAFETY: as above.
    unsafe { fake(physical, out) };
}

unsafe extern "system" fn get_features(
    _: vk::PhysicalDevice,
    out: *mut vk::PhysicalDeviceFeatures,
) {
    // SAFETY: the loader's pointer.
    unsafe { *out = vk::PhysicalDeviceFeatures::default() };
}

/// The features the fake implements the commands of, where the chain asks.
unsafe extern "system" fn get_features2(
    _: vk::PhysicalDevice,
    out: *mut vk::PhysicalDeviceFeatures2<'_>,
) {
    // SAFETY: the application's structure, through the loader.
    unsafe { (*out).features = vk::PhysicalDeviceFeatures::default() };
    // SAFETY: as above.
    let mut next = unsafe { (*out).p_next };
    // A chain longer than this is not the application's.
    for _ in 0..64 {
        if next.is_null() {
            break;
        }
        // SAFETY: every structure in a pNext chain starts with sType, pNext.
        let base = unsafe { &mut *next.cast::<vk::BaseOutStructure<'_>>() };
        match base.s_type {
            vk::StructureType::PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_EXT => {
                // SAFETY: the sType names the structure.
                let f = unsafe {
                    &mut *next.cast::<vk::PhysicalDeviceOpacityMicromapFeaturesEXT<'_>>()
                };
                f.micromap = vk::TRUE;
                f.micromap_host_commands = vk::TRUE;
            }
            vk::StructureType::PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR => {
                // SAFETY: as above.
                let f = unsafe {
                    &mut *next.cast::<vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_>>()
                };
                f.acceleration_structure = vk::TRUE;
                f.acceleration_structure_host_commands = vk::TRUE;
            }
            vk::StructureType::PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES => {
                // SAFETY: as above.
                let f = unsafe {
                    &mut *next.cast::<vk::PhysicalDeviceBufferDeviceAddressFeatures<'_>>()
                };
                f.buffer_device_address = vk::TRUE;
            }
            _ => {}
        }
        next = base.p_next.cast();
    }
}

/// No format supports anything: the fake has no images.
unsafe extern "system" fn get_format_properties(
    _: vk::PhysicalDevice,
    _: vk::Format,
    out: *mut vk::FormatProperties,
) {
    // SAFETY: the loader's pointer.
    unsafe { *out = vk::FormatProperties::default() };
}

unsafe extern "system" fn get_image_format_properties(
    _: vk::PhysicalDevice,
    _: vk::Format,
    _: vk::ImageType,
    _: vk::ImageTiling,
    _: vk::ImageUsageFlags,
    _: vk::ImageCreateFlags,
    _: *mut vk::ImageFormatProperties,
) -> vk::Result {
    vk::Result::ERROR_FORMAT_NOT_SUPPORTED
}

unsafe extern "system" fn get_sparse_image_format_properties(
    _: vk::PhysicalDevice,
    _: vk::Format,
    _: vk::ImageType,
    _: vk::SampleCountFlags,
    _: vk::ImageUsageFlags,
    _: vk::ImageTiling,
    count: *mut u32,
    _: *mut vk::SparseImageFormatProperties,
) {
    // SAFETY: the loader's pointer.
    unsafe { *count = 0 };
}

unsafe extern "system" fn enumerate_device_extension_properties(
    _: vk::PhysicalDevice,
    layer: *const c_char,
    count: *mut u32,
    out: *mut vk::ExtensionProperties,
) -> vk::Result {
    // A driver has no layers' extensions to list.
    let extensions: Vec<vk::ExtensionProperties> = if layer.is_null() {
        DEVICE_EXTENSIONS
            .iter()
            .map(|&(name, spec_version)| {
                let mut e = vk::ExtensionProperties {
                    spec_version,
                    ..Default::default()
                };
                for (to, from) in e.extension_name.iter_mut().zip(name.to_bytes_with_nul()) {
                    *to = *from as c_char;
                }
                e
            })
            .collect()
    } else {
        Vec::new()
    };
    // SAFETY: the loader's pointers.
    unsafe { enumerate(&extensions, count, out) }
}

unsafe extern "system" fn create_device(
    physical: vk::PhysicalDevice,
    info: *const vk::DeviceCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Device,
) -> vk::Result {
    let fake: vk::PFN_vkCreateDevice = fake_command(c"vkCreateDevice");
    // SAFETY: the application's arguments, through the loader.
    let result = unsafe { fake(physical, info, allocator, out) };
    if result == vk::Result::SUCCESS {
        // SAFETY: a device the fake just made; the loader has not seen it.
        unsafe { set_loader_magic((*out).as_raw()) };
    }
    result
}

/// The command buffers of each command pool, which the fake hands out as
/// boxes it never frees (its in-process tests keep every handle): freed
/// here with their pool, or by vkFreeCommandBuffers, so that an
/// application making and freeing command buffers for as long as it runs
/// (`cargo xtask soak`) holds no more memory for them than it uses.
static POOLS: Mutex<Option<HashMap<u64, HashSet<u64>>>> = Mutex::new(None);

fn pools<R>(f: impl FnOnce(&mut HashMap<u64, HashSet<u64>>) -> R) -> R {
    f(POOLS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .get_or_insert_with(HashMap::new))
}

unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    info: *const vk::CommandBufferAllocateInfo<'_>,
    out: *mut vk::CommandBuffer,
) -> vk::Result {
    let fake: vk::PFN_vkAllocateCommandBuffers = fake_command(c"vkAllocateCommandBuffers");
    // SAFETY: the application's arguments, through the loader.
    let result = unsafe { fake(device, info, out) };
    if result == vk::Result::SUCCESS {
        // SAFETY: as above.
        let (count, pool) = unsafe { ((*info).command_buffer_count, (*info).command_pool) };
        for k in 0..count as usize {
            // SAFETY: command buffers the fake just made, not handed out yet.
            let handle = unsafe { *out.add(k) }.as_raw();
            // SAFETY: as above.
            unsafe { set_loader_magic(handle) };
            pools(|pools| pools.entry(pool.as_raw()).or_default().insert(handle));
        }
    }
    result
}

unsafe extern "system" fn free_command_buffers(
    device: vk::Device,
    pool: vk::CommandPool,
    count: u32,
    command_buffers: *const vk::CommandBuffer,
) {
    let fake: vk::PFN_vkFreeCommandBuffers = fake_command(c"vkFreeCommandBuffers");
    // SAFETY: the application's arguments, through the loader.
    unsafe { fake(device, pool, count, command_buffers) };
    let freed: Vec<u64> = if command_buffers.is_null() {
        Vec::new()
    } else {
        // SAFETY: `pCommandBuffers` holds `commandBufferCount` handles.
        unsafe { std::slice::from_raw_parts(command_buffers, count as usize) }
            .iter()
            .map(|c| c.as_raw())
            .collect()
    };
    for handle in freed {
        // Only command buffers of this pool the fake made (NULL is allowed).
        if pools(|pools| {
            pools
                .get_mut(&pool.as_raw())
                .is_some_and(|p| p.remove(&handle))
        }) {
            // SAFETY: the application no longer uses a freed command buffer.
            unsafe { fake::release_dispatchable(handle) };
        }
    }
}

unsafe extern "system" fn destroy_command_pool(
    device: vk::Device,
    pool: vk::CommandPool,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let fake: vk::PFN_vkDestroyCommandPool = fake_command(c"vkDestroyCommandPool");
    // SAFETY: the application's arguments, through the loader.
    unsafe { fake(device, pool, allocator) };
    for handle in pools(|pools| pools.remove(&pool.as_raw())).unwrap_or_default() {
        // SAFETY: its pool's command buffers go with it.
        unsafe { fake::release_dispatchable(handle) };
    }
}

/// The fake hands out one handle per queue again and again; only a queue
/// never handed out before gets the magic value (the loader may already be
/// dispatching another thread's calls through one handed out earlier).
unsafe extern "system" fn get_device_queue(
    device: vk::Device,
    family: u32,
    index: u32,
    out: *mut vk::Queue,
) {
    static SEEN: Mutex<Option<HashSet<u64>>> = Mutex::new(None);
    let fake: vk::PFN_vkGetDeviceQueue = fake_command(c"vkGetDeviceQueue");
    // SAFETY: the application's arguments, through the loader.
    unsafe { fake(device, family, index, out) };
    // SAFETY: the fake wrote the queue.
    let queue = unsafe { *out }.as_raw();
    let mut seen = SEEN.lock().unwrap_or_else(PoisonError::into_inner);
    if seen.get_or_insert_with(HashSet::new).insert(queue) {
        // SAFETY: a queue handed out for the first time.
        unsafe { set_loader_magic(queue) };
    }
}
