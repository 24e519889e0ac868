//! Per-instance and per-device data, found by the loader's dispatch key,
//! with the next layer's functions this layer calls. Every next function
//! is resolved when the instance or device is created (later the loader's
//! terminator may hand back this layer's own functions) and kept as an
//! `Option`, so a function the next layer lacks is never called.

#![allow(unsafe_code)]

use foldhash::HashMap;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError, RwLock};

use ash::vk;
use ommcheck::raw::ReadableHost;
use ommcheck::state::MemoryBinding;
use ommcheck::{Tier, Validator};

use crate::abi::dispatch_key;
use crate::report::Reporter;

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

/// What the layer keeps of a `VkInstance`.
pub struct InstanceData {
    pub handle: vk::Instance,
    pub next_gipa: vk::PFN_vkGetInstanceProcAddr,
    pub fns: InstanceFns,
    pub reporter: Reporter,
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
    pub accel: crate::accel::AccelFns,
    /// Command pools and buffers, their state commands, and queue submission.
    pub commands: crate::commands::CommandFns,
    /// The pipeline, shader, synchronization and shader-running commands.
    pub pipe: crate::pipe::PipeFns,
    /// Transfers, completion and what GPU readback records.
    pub memory: crate::transfer::MemoryFns,
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
            accel: crate::accel::AccelFns::load(gdpa, device),
            commands: crate::commands::CommandFns::load(gdpa, device),
            pipe: crate::pipe::PipeFns::load(gdpa, device),
            memory: crate::transfer::MemoryFns::load(gdpa, device),
        }
    }
}

/// A `VkDeviceMemory` allocation.
#[derive(Clone, Copy, Debug)]
pub struct Allocation {
    pub size: u64,
    pub binding: MemoryBinding,
}

/// What the checks run against, behind one lock.
pub struct DeviceState {
    pub validator: Validator,
    /// Allocations by handle.
    pub allocations: HashMap<u64, Allocation>,
    /// Host ranges of mapped allocations, by allocation handle: memory a
    /// host build may read its micromap data from.
    pub mappings: HashMap<u64, ReadableHost>,
    /// Where buffers lie in memory and where memory is mapped, for reading
    /// device builds' contents at submission.
    pub memory_layout: crate::memory_layout::MemoryLayout,
    /// Bound pipelines, shaders and descriptor sets, and what pipelines' stages use.
    pub pipe: crate::work::PipeState,
    /// What transfers wrote into the windows builds read (route 1).
    pub shadows: crate::shadow::Shadows,
    /// Submitted builds whose read-back inputs are checked at completion.
    pub submissions: crate::completion::Submissions,
    /// The next layer's answers (build sizes, compatibility) the checks use, where the
    /// device can be asked (`driver_answers`).
    pub driver_answers: Option<std::sync::Arc<crate::driver_answers::NextLayerAnswers>>,
}

/// What the layer keeps of a `VkDevice`.
pub struct DeviceData {
    pub handle: vk::Device,
    pub next_gdpa: vk::PFN_vkGetDeviceProcAddr,
    pub fns: DeviceFns,
    /// The instance whose messengers receive this device's messages.
    pub instance: Arc<InstanceData>,
    /// The memory types of the physical device (None: the next layer
    /// could not say, and every allocation is taken to be host-visible so
    /// host-build rules do not fire on a guess).
    pub memory_properties: Option<vk::PhysicalDeviceMemoryProperties>,
    /// Devices in the device group (multi-instance memory needs more than one).
    pub physical_device_count: u32,
    /// `VkQueueFlags` of each queue family, by index (empty: the next layer
    /// could not say).
    pub queue_family_flags: Vec<vk::QueueFlags>,
    pub state: Mutex<DeviceState>,
    /// The layer's own memory GPU readbacks copy into (route 2), behind a
    /// lock of its own: a readback gives its range back wherever it is
    /// dropped, also while `state` is held.
    pub readback_arena: Arc<Mutex<crate::readback::Arena>>,
}

impl DeviceState {
    /// The device's tier reads memory contents (`content` and above; the
    /// layer fixes the tier at device creation): device builds are kept
    /// for the content checks at submission, and host builds are offered
    /// the mapped memory their data may lie in. Below it neither is done,
    /// since no check would look at a byte; keeping every build recorded
    /// would only cost time and memory.
    pub fn reads_contents(&self) -> bool {
        self.validator.tier() >= Tier::Content
    }
}

impl DeviceData {
    /// The checked state; a check that panicked is caught inside the lock,
    /// so poisoning cannot happen, but is tolerated all the same.
    pub fn state(&self) -> MutexGuard<'_, DeviceState> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// How memory of `memory_type_index` is bound, as the checks see it.
    pub fn binding(&self, memory_type_index: u32) -> MemoryBinding {
        let Some(properties) = &self.memory_properties else {
            return MemoryBinding {
                host_visible: true,
                multi_instance: false,
            };
        };
        let memory_type = properties
            .memory_types_as_slice()
            .get(memory_type_index as usize);
        let heap = memory_type.and_then(|t| {
            properties
                .memory_heaps_as_slice()
                .get(t.heap_index as usize)
        });
        MemoryBinding {
            host_visible: memory_type.is_some_and(|t| {
                t.property_flags
                    .contains(vk::MemoryPropertyFlags::HOST_VISIBLE)
            }),
            multi_instance: self.physical_device_count > 1
                && heap.is_some_and(|h| h.flags.contains(vk::MemoryHeapFlags::MULTI_INSTANCE)),
        }
    }
}

/// Objects by dispatch key.
pub struct Registry<T> {
    map: LazyLock<RwLock<HashMap<usize, Arc<T>>>>,
}

impl<T> Registry<T> {
    pub const fn new() -> Self {
        Self {
            map: LazyLock::new(|| RwLock::new(HashMap::default())),
        }
    }

    pub fn insert(&self, key: usize, value: Arc<T>) {
        self.map
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(key, value);
    }

    pub fn remove(&self, key: usize) -> Option<Arc<T>> {
        self.map
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(&key)
    }

    /// The object whose dispatchable handle is `handle`.
    pub fn get<H: vk::Handle>(&self, handle: H) -> Option<Arc<T>> {
        // SAFETY: `handle` is a dispatchable handle the application passed
        // to a command, which the loader created.
        let key = unsafe { dispatch_key(handle.as_raw()) }?;
        self.map
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .get(&key)
            .cloned()
    }

    /// Every object, for messages that belong to no one call.
    pub fn all(&self) -> Vec<Arc<T>> {
        self.map
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .values()
            .cloned()
            .collect()
    }
}

pub static INSTANCES: Registry<InstanceData> = Registry::new();
pub static DEVICES: Registry<DeviceData> = Registry::new();
