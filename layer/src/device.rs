//! Device creation and the device commands the layer intercepts: those
//! that create what micromap builds refer to (fed to the core's tracked
//! state, as the scene runner feeds it) and the builds themselves
//! (checked through the core's raw entry points).

#![allow(unsafe_code)]

use foldhash::HashMap;
use std::ffi::{c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::raw::{objects, ReadableHost};
use ommcheck::Validator;

use crate::dispatch::next_fns::{next_fn, DeviceFns};
use crate::dispatch::{Allocation, DeviceData, DeviceState, DEVICES, INSTANCES};
use crate::intercept::{
    aliased_intercepts, as_void, check, deferrable, device_and, device_object, guarded, track,
};
use crate::own_calls::{self, OwnCall};
use crate::report::Message;
use crate::shadow::Shadows;
use crate::{abi, commands, pipelines, properties, read, readback};

/// This layer's function for a device-level command name.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkDestroyDevice" => as_void(destroy_device as vk::PFN_vkDestroyDevice),
        b"vkCreateBuffer" => as_void(create_buffer as vk::PFN_vkCreateBuffer),
        b"vkDestroyBuffer" => as_void(destroy_buffer as vk::PFN_vkDestroyBuffer),
        b"vkAllocateMemory" => as_void(allocate_memory as vk::PFN_vkAllocateMemory),
        b"vkFreeMemory" => as_void(free_memory as vk::PFN_vkFreeMemory),
        b"vkMapMemory" => as_void(map_memory as vk::PFN_vkMapMemory),
        b"vkUnmapMemory" => as_void(unmap_memory as vk::PFN_vkUnmapMemory),
        b"vkBindBufferMemory" => as_void(bind_buffer_memory as vk::PFN_vkBindBufferMemory),
        b"vkBindBufferMemory2" => as_void(bind_buffer_memory2 as vk::PFN_vkBindBufferMemory2),
        b"vkBindBufferMemory2KHR" => {
            as_void(bind_buffer_memory2_khr as vk::PFN_vkBindBufferMemory2)
        }
        b"vkGetBufferDeviceAddress" => {
            as_void(get_buffer_device_address as vk::PFN_vkGetBufferDeviceAddress)
        }
        b"vkGetBufferDeviceAddressKHR" => {
            as_void(get_buffer_device_address_khr as vk::PFN_vkGetBufferDeviceAddress)
        }
        b"vkGetBufferDeviceAddressEXT" => {
            as_void(get_buffer_device_address_ext as vk::PFN_vkGetBufferDeviceAddress)
        }
        b"vkCreateDeferredOperationKHR" => {
            as_void(create_deferred_operation as vk::PFN_vkCreateDeferredOperationKHR)
        }
        b"vkDestroyDeferredOperationKHR" => {
            as_void(destroy_deferred_operation as vk::PFN_vkDestroyDeferredOperationKHR)
        }
        b"vkDeferredOperationJoinKHR" => {
            as_void(deferred_operation_join as vk::PFN_vkDeferredOperationJoinKHR)
        }
        b"vkGetDeferredOperationResultKHR" => {
            as_void(get_deferred_operation_result as vk::PFN_vkGetDeferredOperationResultKHR)
        }
        b"vkCreateMicromapEXT" => as_void(create_micromap as vk::PFN_vkCreateMicromapEXT),
        b"vkDestroyMicromapEXT" => as_void(destroy_micromap as vk::PFN_vkDestroyMicromapEXT),
        b"vkCmdBuildMicromapsEXT" => as_void(cmd_build_micromaps as vk::PFN_vkCmdBuildMicromapsEXT),
        b"vkBuildMicromapsEXT" => as_void(build_micromaps as vk::PFN_vkBuildMicromapsEXT),
        _ => None,
    }
}

/// `vkCreateDevice`: takes the next layer from the loader's link info,
/// creates the device below, and sets up its checked state from the
/// create info (extensions, chained features, queues) and the settings' limits.
pub unsafe extern "system" fn create_device(
    physical_device: vk::PhysicalDevice,
    create_info: *const vk::DeviceCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    device_out: *mut vk::Device,
) -> vk::Result {
    guarded(
        "vkCreateDevice",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            // SAFETY: the loader passes a valid create info.
            let Some(info) = (unsafe { create_info.as_ref() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the loader's create info, with its writable link info.
            let Some((next_gipa, next_gdpa)) = (unsafe { abi::take_device_link(info) }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // A physical device shares its instance's dispatch key.
            let Some(instance) = INSTANCES.get(physical_device) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let Some(create) = next_fn!(
                next_gipa,
                instance.handle,
                c"vkCreateDevice",
                vk::PFN_vkCreateDevice
            ) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the create info's chain is well formed, as vkCreateDevice requires.
            if unsafe { properties::check_device_chain(&instance, physical_device, info) } {
                return vk::Result::ERROR_VALIDATION_FAILED_EXT;
            }
            // SAFETY: the next layer's vkCreateDevice, with the application's arguments.
            let result = unsafe { create(physical_device, create_info, allocator, device_out) };
            if result != vk::Result::SUCCESS {
                return result;
            }
            // SAFETY: on success the next layer wrote the device.
            let Some(handle) = (unsafe { read::value(device_out) }) else {
                return result;
            };
            let memory_properties = instance
                .fns
                .get_physical_device_memory_properties
                .map(|get| {
                    let mut properties = vk::PhysicalDeviceMemoryProperties::default();
                    own_calls::call(OwnCall::DeviceMemoryProperties, || {
                        // SAFETY: the next layer's function, with a physical
                        // device of its instance and a structure to fill.
                        unsafe { get(physical_device, &mut properties) }
                    });
                    properties
                });
            let queue_family_flags = instance
                .fns
                .get_physical_device_queue_family_properties
                .map(|get| {
                    own_calls::call(OwnCall::QueueFamilyProperties, || {
                        // SAFETY: the next layer's function, with a physical
                        // device of its instance.
                        unsafe { read::queue_family_flags(get, physical_device) }
                    })
                })
                .unwrap_or_default();
            let settings = instance.reporter.settings().clone();
            let limits = settings.limits.clone();
            let tier = settings.tier;
            // SAFETY: the create info is valid, as vkCreateDevice requires.
            let (mut device, findings) =
                unsafe { objects::device_from_create_info(info, limits, handle) };
            device.limits = properties::device_limits(&instance, physical_device, &device);
            let physical_device_count = device.physical_device_count;
            let mut validator = Validator::new(device);
            validator.set_tier(tier);
            if let Some(store) =
                crate::provenance::open(&settings, &instance.reporter, "vkCreateDevice")
            {
                validator.use_provenance_store(store);
            }
            let data = Arc::new(DeviceData {
                handle,
                next_gdpa,
                fns: DeviceFns::load(next_gdpa, handle),
                instance,
                memory_properties,
                physical_device_count,
                queue_family_flags,
                state: Mutex::new(DeviceState {
                    validator,
                    allocations: HashMap::default(),
                    mappings: HashMap::default(),
                    memory_layout: Default::default(),
                    pipe: Default::default(),
                    shadows: Shadows::new(settings.gpu_readback_max_bytes),
                    submissions: Default::default(),
                    driver_answers: None,
                    core_not_checked: Default::default(),
                }),
                readback_arena: Default::default(),
            });
            crate::driver_answers::install(&data);
            let messages: Vec<Message> = findings
                .iter()
                .map(|finding| Message::from_finding(finding, device_object(handle)))
                .collect();
            data.instance.reporter.deliver(&messages, false);
            // SAFETY: the device the loader's chain just created.
            if let Some(key) = unsafe { abi::dispatch_key(handle.as_raw()) } {
                DEVICES.insert(key, data);
            }
            result
        },
    )
}

/// `vkDestroyDevice`.
unsafe extern "system" fn destroy_device(
    device: vk::Device,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyDevice", (), || {
        if device == vk::Device::null() {
            return;
        }
        // SAFETY: a non-NULL device is one the loader created.
        let Some(key) = (unsafe { abi::dispatch_key(device.as_raw()) }) else {
            return;
        };
        let Some(data) = DEVICES.remove(key) else {
            return;
        };
        // The layer's readback memory goes before the device does.
        commands::forget_device(device);
        let totals = {
            let mut state = data.state();
            state.submissions = Default::default();
            let mut totals = readback::not_checked_totals(
                device.as_raw(),
                state.memory_layout.not_checked_counts(),
            );
            totals.extend(crate::intercept::core_not_checked_totals(
                device.as_raw(),
                state.core_not_checked.counts(),
            ));
            totals
        };
        data.instance.reporter.deliver(&totals, false);
        data.readback_arena
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .give_back_all();
        if let Some(destroy) = data.fns.destroy_device {
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { destroy(device, allocator) };
        }
    })
}

/// `vkCreateBuffer`: the buffer's size, usage and flags are tracked.
unsafe extern "system" fn create_buffer(
    device: vk::Device,
    create_info: *const vk::BufferCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    buffer_out: *mut vk::Buffer,
) -> vk::Result {
    guarded(
        "vkCreateBuffer",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.create_buffer) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the create info is valid (the API's requirement).
            let app_info = unsafe { create_info.as_ref() };
            // Build inputs gain TRANSFER_SRC, so GPU readback may copy them.
            let passed = app_info.and_then(|info| {
                // SAFETY: the chain is well formed (the API's requirement).
                let chained = unsafe {
                    read::chain_has(
                        info.p_next,
                        vk::StructureType::BUFFER_USAGE_FLAGS_2_CREATE_INFO_KHR,
                    )
                };
                let settings = data.instance.reporter.settings();
                let reads_back = settings.gpu_readback && settings.tier >= ommcheck::Tier::Content;
                readback::with_transfer_source(info, chained, reads_back)
            });
            let info_down = passed.as_ref().map_or(create_info, |p| p as *const _);
            // SAFETY: the next layer's function, with the application's
            // arguments (the create info possibly with one more usage bit).
            let result = unsafe { next(device, info_down, allocator, buffer_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: the create info passed down is valid; on success
                // the next layer wrote the handle.
                let (info, buffer) = unsafe { (info_down.as_ref(), read::value(buffer_out)) };
                if let (Some(info), Some(buffer)) = (info, buffer) {
                    track(&data, "vkCreateBuffer", |state| {
                        // SAFETY: as above; the chain is well formed.
                        let (record, _) = unsafe { objects::buffer_from_create_info(info) };
                        state
                            .validator
                            .state_mut()
                            .buffers
                            .insert(buffer.as_raw(), record);
                    });
                }
            }
            result
        },
    )
}

/// `vkDestroyBuffer`.
unsafe extern "system" fn destroy_buffer(
    device: vk::Device,
    buffer: vk::Buffer,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyBuffer", (), || {
        let Some((data, next)) = device_and(device, |f| f.destroy_buffer) else {
            return;
        };
        track(&data, "vkDestroyBuffer", |state| {
            state.validator.state_mut().buffers.remove(&buffer.as_raw());
            state.memory_layout.forget_buffer(buffer.as_raw());
            state.shadows.forget_buffer(buffer.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, buffer, allocator) };
    })
}

/// `vkAllocateMemory`: whether the memory is host-visible (from its type)
/// and multi-instance, and its size, are tracked.
unsafe extern "system" fn allocate_memory(
    device: vk::Device,
    allocate_info: *const vk::MemoryAllocateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    memory_out: *mut vk::DeviceMemory,
) -> vk::Result {
    guarded(
        "vkAllocateMemory",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.allocate_memory) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, allocate_info, allocator, memory_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: the allocate info is valid (the API's requirement); on
                // success the next layer wrote the handle.
                let (info, memory) =
                    unsafe { (read::value(allocate_info), read::value(memory_out)) };
                if let (Some(info), Some(memory)) = (info, memory) {
                    let allocation = Allocation {
                        size: info.allocation_size,
                        binding: data.binding(info.memory_type_index),
                    };
                    track(&data, "vkAllocateMemory", |state| {
                        state.allocations.insert(memory.as_raw(), allocation);
                    });
                }
            }
            result
        },
    )
}

/// `vkFreeMemory`: the allocation and its mapping are forgotten.
unsafe extern "system" fn free_memory(
    device: vk::Device,
    memory: vk::DeviceMemory,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkFreeMemory", (), || {
        let Some((data, next)) = device_and(device, |f| f.free_memory) else {
            return;
        };
        track(&data, "vkFreeMemory", |state| {
            state.allocations.remove(&memory.as_raw());
            state.mappings.remove(&memory.as_raw());
            state.memory_layout.unmap(memory.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, memory, allocator) };
    })
}

/// `vkMapMemory`: the mapped host range is remembered, so a host build
/// whose data lies in it can be read in full.
unsafe extern "system" fn map_memory(
    device: vk::Device,
    memory: vk::DeviceMemory,
    offset: vk::DeviceSize,
    size: vk::DeviceSize,
    flags: vk::MemoryMapFlags,
    data_out: *mut *mut c_void,
) -> vk::Result {
    guarded("vkMapMemory", vk::Result::ERROR_MEMORY_MAP_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.map_memory) else {
            return vk::Result::ERROR_MEMORY_MAP_FAILED;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, memory, offset, size, flags, data_out) };
        if result == vk::Result::SUCCESS {
            // SAFETY: on success the next layer wrote the pointer.
            let mapped = unsafe { read::value(data_out) }.filter(|p| !p.is_null());
            if let Some(mapped) = mapped {
                track(&data, "vkMapMemory", |state| {
                    let allocated = state.allocations.get(&memory.as_raw()).map(|a| a.size);
                    // VK_WHOLE_SIZE maps to the end of the allocation.
                    let len = if size == vk::WHOLE_SIZE {
                        allocated.and_then(|total| total.checked_sub(offset))
                    } else {
                        Some(size)
                    };
                    if let Some(len) = len {
                        let address = mapped.expose_provenance() as u64;
                        state
                            .mappings
                            .insert(memory.as_raw(), ReadableHost { address, len });
                        state.memory_layout.map(memory.as_raw(), offset);
                    }
                });
            }
        }
        result
    })
}

/// `vkUnmapMemory`.
unsafe extern "system" fn unmap_memory(device: vk::Device, memory: vk::DeviceMemory) {
    guarded("vkUnmapMemory", (), || {
        let Some((data, next)) = device_and(device, |f| f.unmap_memory) else {
            return;
        };
        track(&data, "vkUnmapMemory", |state| {
            state.mappings.remove(&memory.as_raw());
            state.memory_layout.unmap(memory.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, memory) };
    })
}

/// Records that `buffer` is bound to `memory` at `offset`.
fn bind(
    state: &mut DeviceState,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    offset: vk::DeviceSize,
) {
    state
        .memory_layout
        .bind(buffer.as_raw(), memory.as_raw(), offset);
    let binding = state
        .allocations
        .get(&memory.as_raw())
        .map(|allocation| allocation.binding)
        .unwrap_or_default();
    if let Some(mut tracked) = state
        .validator
        .state_mut()
        .buffers
        .get_mut(&buffer.as_raw())
    {
        tracked.memory = Some(binding);
    }
}

/// `vkBindBufferMemory`.
unsafe extern "system" fn bind_buffer_memory(
    device: vk::Device,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    offset: vk::DeviceSize,
) -> vk::Result {
    guarded(
        "vkBindBufferMemory",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.bind_buffer_memory) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, buffer, memory, offset) };
            if result == vk::Result::SUCCESS {
                track(&data, "vkBindBufferMemory", |state| {
                    bind(state, buffer, memory, offset)
                });
            }
            result
        },
    )
}

/// `vkBindBufferMemory2` and its KHR alias, each with its own next function.
unsafe fn bind_buffer_memory2_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkBindBufferMemory2>,
    device: vk::Device,
    bind_info_count: u32,
    bind_infos: *const vk::BindBufferMemoryInfo<'_>,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, pick) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, bind_info_count, bind_infos) };
        if result == vk::Result::SUCCESS {
            track(&data, function, |state| {
                // SAFETY: the array holds `bind_info_count` elements (the API's requirement).
                let binds =
                    unsafe { objects::bind_buffer_memory_infos(bind_info_count, bind_infos) };
                for (buffer, memory, offset) in binds {
                    bind(state, buffer, memory, offset);
                }
            });
        }
        result
    })
}

aliased_intercepts! {
    bind_buffer_memory2_with(
        device: vk::Device,
        bind_info_count: u32,
        bind_infos: *const vk::BindBufferMemoryInfo<'_>
    ) -> vk::Result {
        bind_buffer_memory2 = "vkBindBufferMemory2", bind_buffer_memory2;
        bind_buffer_memory2_khr = "vkBindBufferMemory2KHR", bind_buffer_memory2_khr;
    }
    get_buffer_device_address_with(
        device: vk::Device,
        info: *const vk::BufferDeviceAddressInfo<'_>
    ) -> vk::DeviceAddress {
        get_buffer_device_address = "vkGetBufferDeviceAddress", get_buffer_device_address;
        get_buffer_device_address_khr = "vkGetBufferDeviceAddressKHR", get_buffer_device_address_khr;
        get_buffer_device_address_ext = "vkGetBufferDeviceAddressEXT", get_buffer_device_address_ext;
    }
}

/// `vkGetBufferDeviceAddress` and its aliases: the address is tracked
/// with the buffer, so device addresses in builds can be traced to buffers.
unsafe fn get_buffer_device_address_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkGetBufferDeviceAddress>,
    device: vk::Device,
    info: *const vk::BufferDeviceAddressInfo<'_>,
) -> vk::DeviceAddress {
    guarded(function, 0, || {
        let Some((data, next)) = device_and(device, pick) else {
            return 0;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let address = unsafe { next(device, info) };
        // SAFETY: the info is valid (the API's requirement).
        if let Some(info) = unsafe { read::value(info) }.filter(|_| address != 0) {
            track(&data, function, |state| {
                let buffers = &mut state.validator.state_mut().buffers;
                if let Some(mut buffer) = buffers.get_mut(&info.buffer.as_raw()) {
                    buffer.device_address = Some(address);
                }
            });
        }
        address
    })
}

/// `vkCreateDeferredOperationKHR`: host builds may name the operation.
unsafe extern "system" fn create_deferred_operation(
    device: vk::Device,
    allocator: *const vk::AllocationCallbacks<'_>,
    operation_out: *mut vk::DeferredOperationKHR,
) -> vk::Result {
    guarded(
        "vkCreateDeferredOperationKHR",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.create_deferred_operation) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, allocator, operation_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: on success the next layer wrote the handle.
                if let Some(operation) = unsafe { read::value(operation_out) } {
                    track(&data, "vkCreateDeferredOperationKHR", |state| {
                        state
                            .validator
                            .create_deferred_operation(operation.as_raw());
                    });
                }
            }
            result
        },
    )
}

/// `vkDestroyDeferredOperationKHR`.
unsafe extern "system" fn destroy_deferred_operation(
    device: vk::Device,
    operation: vk::DeferredOperationKHR,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyDeferredOperationKHR", (), || {
        let Some((data, next)) = device_and(device, |f| f.destroy_deferred_operation) else {
            return;
        };
        track(&data, "vkDestroyDeferredOperationKHR", |state| {
            state
                .validator
                .destroy_deferred_operation(operation.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, operation, allocator) };
    })
}

/// `vkDeferredOperationJoinKHR`: VK_SUCCESS means the operation's command completed.
unsafe extern "system" fn deferred_operation_join(
    device: vk::Device,
    operation: vk::DeferredOperationKHR,
) -> vk::Result {
    guarded(
        "vkDeferredOperationJoinKHR",
        vk::Result::ERROR_UNKNOWN,
        || {
            let Some((data, next)) = device_and(device, |f| f.deferred_operation_join) else {
                return vk::Result::ERROR_UNKNOWN;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, operation) };
            if result == vk::Result::SUCCESS {
                track(&data, "vkDeferredOperationJoinKHR", |state| {
                    state
                        .validator
                        .deferred_operation_completed(operation.as_raw());
                    pipelines::deferred_operation_completed(state, operation.as_raw());
                });
            }
            result
        },
    )
}

/// `vkGetDeferredOperationResultKHR`: anything but VK_NOT_READY means the
/// operation's command completed.
unsafe extern "system" fn get_deferred_operation_result(
    device: vk::Device,
    operation: vk::DeferredOperationKHR,
) -> vk::Result {
    guarded(
        "vkGetDeferredOperationResultKHR",
        vk::Result::ERROR_UNKNOWN,
        || {
            let Some((data, next)) = device_and(device, |f| f.get_deferred_operation_result) else {
                return vk::Result::ERROR_UNKNOWN;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, operation) };
            if result != vk::Result::NOT_READY {
                track(&data, "vkGetDeferredOperationResultKHR", |state| {
                    state
                        .validator
                        .deferred_operation_completed(operation.as_raw());
                    pipelines::deferred_operation_completed(state, operation.as_raw());
                });
            }
            result
        },
    )
}

/// `vkCreateMicromapEXT`: checked before the call; the micromap the
/// driver creates is tracked after it.
unsafe extern "system" fn create_micromap(
    device: vk::Device,
    create_info: *const vk::MicromapCreateInfoEXT<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    micromap_out: *mut vk::MicromapEXT,
) -> vk::Result {
    guarded(
        "vkCreateMicromapEXT",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.create_micromap) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let skip = check(
                &data,
                "vkCreateMicromapEXT",
                device_object(device),
                |state| {
                    // SAFETY: the application's arguments, valid as the API requires.
                    unsafe {
                        state.validator.create_micromap_raw(
                            device,
                            create_info,
                            allocator,
                            !micromap_out.is_null(),
                        )
                    }
                },
            );
            if skip {
                return vk::Result::ERROR_VALIDATION_FAILED_EXT;
            }
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, create_info, allocator, micromap_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: the create info is valid; on success the next layer
                // wrote the handle.
                let (info, micromap) = unsafe { (create_info.as_ref(), read::value(micromap_out)) };
                if let (Some(info), Some(micromap)) = (info, micromap) {
                    track(&data, "vkCreateMicromapEXT", |state| {
                        // SAFETY: as above.
                        unsafe {
                            state.validator.record_micromap_raw(
                                info,
                                !allocator.is_null(),
                                micromap,
                            )
                        };
                    });
                }
            }
            result
        },
    )
}

/// `vkDestroyMicromapEXT`: checked, then passed on unless a messenger asks to skip it.
unsafe extern "system" fn destroy_micromap(
    device: vk::Device,
    micromap: vk::MicromapEXT,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyMicromapEXT", (), || {
        let Some((data, next)) = device_and(device, |f| f.destroy_micromap) else {
            return;
        };
        let skip = check(
            &data,
            "vkDestroyMicromapEXT",
            device_object(device),
            |state| {
                // SAFETY: the application's allocator, valid as the API requires.
                unsafe {
                    state
                        .validator
                        .destroy_micromap_raw(device, micromap, allocator)
                }
            },
        );
        if !skip {
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { next(device, micromap, allocator) };
        }
    })
}

/// `vkCmdBuildMicromapsEXT`: checked against the command buffer's tracked
/// state, then recorded below unless a messenger asks to skip it. At the
/// content tier and above the build's contents are checked when the
/// command buffer is submitted.
unsafe extern "system" fn cmd_build_micromaps(
    command_buffer: vk::CommandBuffer,
    info_count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) {
    guarded("vkCmdBuildMicromapsEXT", (), || {
        // A command buffer shares its device's dispatch key.
        let Some((data, next)) = device_and(command_buffer, |f| f.cmd_build_micromaps) else {
            return;
        };
        let recording = commands::model(command_buffer);
        let object = (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw());
        let mut kept = None;
        let skip = check(&data, "vkCmdBuildMicromapsEXT", object, |state| {
            // SAFETY: the application's arguments, valid as the API requires.
            let (report, build) = unsafe {
                state
                    .validator
                    .cmd_build_micromaps_raw_kept(&recording, info_count, infos)
            };
            kept = build.filter(|_| state.reads_contents());
            report
        });
        if !skip {
            if let Some(build) = kept {
                commands::keep_build(&data, command_buffer, &recording, build);
            }
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { next(command_buffer, info_count, infos) };
        }
    })
}

/// `vkBuildMicromapsEXT`: checked at the call, reading (at the content tier
/// and above) the triangle array and, where it lies in mapped memory, the
/// data in full, then passed on unless a messenger asks to skip it; what
/// it builds is recorded, from what was read before the call, once the
/// driver accepted it.
unsafe extern "system" fn build_micromaps(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info_count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) -> vk::Result {
    guarded(
        "vkBuildMicromapsEXT",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.build_micromaps) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let mut read = None;
            let skip = check(
                &data,
                "vkBuildMicromapsEXT",
                device_object(device),
                |state| {
                    let mapped: Vec<ReadableHost> = if state.reads_contents() {
                        state.mappings.values().copied().collect()
                    } else {
                        Vec::new()
                    };
                    // Only the state tier and above compare scratch with the
                    // destinations' mappings (11668).
                    if state.validator.tier() >= ommcheck::Tier::State {
                        // SAFETY: the application's arguments, valid as the API
                        // requires.
                        unsafe {
                            crate::driver_answers::map_destinations(state, info_count, infos)
                        };
                    }
                    // SAFETY: the application's arguments, valid as the API
                    // requires; mapped ranges stay readable until unmapped.
                    let build = unsafe {
                        state.validator.read_build_micromaps_raw(
                            device,
                            deferred_operation,
                            info_count,
                            infos,
                            &mapped,
                        )
                    };
                    let report = state.validator.build_micromaps_read_rules(&build);
                    read = Some(build);
                    report
                },
            );
            if skip {
                return vk::Result::ERROR_VALIDATION_FAILED_EXT;
            }
            deferrable(device, deferred_operation, || {
                // SAFETY: the next layer's function, with the application's arguments.
                let result = unsafe { next(device, deferred_operation, info_count, infos) };
                // Any success code: built, deferred or not. Recorded before
                // a build the driver ran at once completes its operation.
                if let (true, Some(build)) = (result.as_raw() >= 0, read) {
                    track(&data, "vkBuildMicromapsEXT", |state| {
                        state.validator.record_build_micromaps_read(build);
                    });
                }
                result
            })
        },
    )
}
