//! Per-instance and per-device data, found by the loader's dispatch key:
//! the next layer's functions this layer calls ([`next_fns`]) and the
//! device state the checks run against, with every type that state holds.
//! It sits below every intercept module and imports none: the intercept
//! modules reach a device's data here and keep their own state in it.

#![allow(unsafe_code)]

use foldhash::HashMap;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError, RwLock};

use ash::vk;
use ommcheck::raw::ReadableHost;
use ommcheck::state::MemoryBinding;
use ommcheck::{Tier, Validator};

use crate::abi::dispatch_key;
use crate::report::Reporter;
use next_fns::{DeviceFns, InstanceFns};

pub mod memory_layout;
pub mod next_fns;
pub mod next_layer_answers;
pub mod pipe_state;
pub mod readback_memory;
pub mod submissions;

/// What the layer keeps of a `VkInstance`.
pub struct InstanceData {
    pub handle: vk::Instance,
    pub next_gipa: vk::PFN_vkGetInstanceProcAddr,
    pub fns: InstanceFns,
    pub reporter: Reporter,
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
    pub memory_layout: memory_layout::MemoryLayout,
    /// Bound pipelines, shaders and descriptor sets, and what pipelines' stages use.
    pub pipe: pipe_state::PipeState,
    /// What transfers wrote into the windows builds read (route 1).
    pub shadows: crate::shadow::Shadows,
    /// Submitted builds whose read-back inputs are checked at completion.
    pub submissions: submissions::Submissions,
    /// The next layer's answers (build sizes, compatibility) the checks use, where the
    /// device can be asked (`driver_answers`).
    pub driver_answers: Option<Arc<next_layer_answers::NextLayerAnswers>>,
    /// The core's `OMMCHECK-not-checked-*` causes said on this device, with
    /// how many calls each kept from being checked in full.
    pub core_not_checked: crate::report::CauseCounts,
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
    pub readback_arena: Arc<Mutex<readback_memory::Arena>>,
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
