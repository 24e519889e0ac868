//! The acceleration-structure commands (creation, builds, size queries,
//! copies) and the micromap commands besides creation and builds (copies,
//! serialization, property queries, size queries, compatibility), with the
//! query pools the property queries write to. Each is checked through the
//! core's raw entry points and passed on unless a messenger asks to skip it;
//! device builds keep their model for the checks of their contents at
//! submission.

#![allow(unsafe_code)]

use std::ffi::{c_void, CStr};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::build_inputs::DeviceBuild;
use ommcheck::model::CommandBuffer;
use ommcheck::vuids::khr;
use ommcheck::Report;

use crate::commands;
use crate::dispatch::next_fns::{DeviceFns, PfnCreateAccelerationStructure2KHR};
use crate::dispatch::DeviceState;
use crate::intercept::{as_void, check, deferrable, device_and, device_object, guarded, track};
use crate::read;

/// This layer's function for an acceleration-structure, micromap copy or
/// query command name.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkCreateAccelerationStructureKHR" => {
            as_void(create_acceleration_structure as vk::PFN_vkCreateAccelerationStructureKHR)
        }
        b"vkCreateAccelerationStructure2KHR" => {
            as_void(create_acceleration_structure2 as PfnCreateAccelerationStructure2KHR)
        }
        b"vkDestroyAccelerationStructureKHR" => {
            as_void(destroy_acceleration_structure as vk::PFN_vkDestroyAccelerationStructureKHR)
        }
        b"vkCmdBuildAccelerationStructuresKHR" => as_void(
            cmd_build_acceleration_structures as vk::PFN_vkCmdBuildAccelerationStructuresKHR,
        ),
        b"vkCmdBuildAccelerationStructuresIndirectKHR" => as_void(
            cmd_build_acceleration_structures_indirect
                as vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR,
        ),
        b"vkBuildAccelerationStructuresKHR" => {
            as_void(build_acceleration_structures as vk::PFN_vkBuildAccelerationStructuresKHR)
        }
        b"vkGetAccelerationStructureBuildSizesKHR" => as_void(
            get_acceleration_structure_build_sizes
                as vk::PFN_vkGetAccelerationStructureBuildSizesKHR,
        ),
        b"vkCmdCopyAccelerationStructureKHR" => {
            as_void(cmd_copy_acceleration_structure as vk::PFN_vkCmdCopyAccelerationStructureKHR)
        }
        b"vkCopyAccelerationStructureKHR" => {
            as_void(copy_acceleration_structure as vk::PFN_vkCopyAccelerationStructureKHR)
        }
        b"vkCmdCopyAccelerationStructureToMemoryKHR" => as_void(
            cmd_copy_acceleration_structure_to_memory
                as vk::PFN_vkCmdCopyAccelerationStructureToMemoryKHR,
        ),
        b"vkCmdCopyMemoryToAccelerationStructureKHR" => as_void(
            cmd_copy_memory_to_acceleration_structure
                as vk::PFN_vkCmdCopyMemoryToAccelerationStructureKHR,
        ),
        b"vkCopyAccelerationStructureToMemoryKHR" => as_void(
            copy_acceleration_structure_to_memory as vk::PFN_vkCopyAccelerationStructureToMemoryKHR,
        ),
        b"vkCopyMemoryToAccelerationStructureKHR" => as_void(
            copy_memory_to_acceleration_structure as vk::PFN_vkCopyMemoryToAccelerationStructureKHR,
        ),
        b"vkCmdCopyMicromapEXT" => as_void(cmd_copy_micromap as vk::PFN_vkCmdCopyMicromapEXT),
        b"vkCopyMicromapEXT" => as_void(copy_micromap as vk::PFN_vkCopyMicromapEXT),
        b"vkCmdCopyMicromapToMemoryEXT" => {
            as_void(cmd_copy_micromap_to_memory as vk::PFN_vkCmdCopyMicromapToMemoryEXT)
        }
        b"vkCopyMicromapToMemoryEXT" => {
            as_void(copy_micromap_to_memory as vk::PFN_vkCopyMicromapToMemoryEXT)
        }
        b"vkCmdCopyMemoryToMicromapEXT" => {
            as_void(cmd_copy_memory_to_micromap as vk::PFN_vkCmdCopyMemoryToMicromapEXT)
        }
        b"vkCopyMemoryToMicromapEXT" => {
            as_void(copy_memory_to_micromap as vk::PFN_vkCopyMemoryToMicromapEXT)
        }
        b"vkCmdWriteMicromapsPropertiesEXT" => {
            as_void(cmd_write_micromaps_properties as vk::PFN_vkCmdWriteMicromapsPropertiesEXT)
        }
        b"vkWriteMicromapsPropertiesEXT" => {
            as_void(write_micromaps_properties as vk::PFN_vkWriteMicromapsPropertiesEXT)
        }
        b"vkGetMicromapBuildSizesEXT" => {
            as_void(get_micromap_build_sizes as vk::PFN_vkGetMicromapBuildSizesEXT)
        }
        b"vkGetDeviceMicromapCompatibilityEXT" => as_void(
            get_device_micromap_compatibility as vk::PFN_vkGetDeviceMicromapCompatibilityEXT,
        ),
        b"vkCreateQueryPool" => as_void(create_query_pool as vk::PFN_vkCreateQueryPool),
        b"vkDestroyQueryPool" => as_void(destroy_query_pool as vk::PFN_vkDestroyQueryPool),
        b"vkCmdBeginQuery" => as_void(cmd_begin_query as vk::PFN_vkCmdBeginQuery),
        b"vkCmdBeginQueryIndexedEXT" => {
            as_void(cmd_begin_query_indexed as vk::PFN_vkCmdBeginQueryIndexedEXT)
        }
        _ => None,
    }
}

/// A `vkCmd*` command: checked against the command buffer's tracked state,
/// then recorded below unless a messenger asks to skip it.
fn recorded<F: Copy>(
    function: &'static str,
    command_buffer: vk::CommandBuffer,
    pick: fn(&DeviceFns) -> Option<F>,
    checks: impl FnOnce(&mut DeviceState, &CommandBuffer) -> Report,
    call_down: impl FnOnce(F),
) {
    guarded(function, (), || {
        // A command buffer shares its device's dispatch key.
        let Some((data, next)) = device_and(command_buffer, pick) else {
            return;
        };
        let model = commands::model(command_buffer);
        let object = (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw());
        if !check(&data, function, object, |state| checks(state, &model)) {
            call_down(next);
        }
    })
}

/// A device command that returns a `VkResult`: checked, then passed on
/// unless a messenger asks to skip it (VK_ERROR_VALIDATION_FAILED_EXT).
fn host_command<F: Copy>(
    function: &'static str,
    device: vk::Device,
    pick: fn(&DeviceFns) -> Option<F>,
    checks: impl FnOnce(&mut DeviceState) -> Report,
    call_down: impl FnOnce(F) -> vk::Result,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, pick) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        if check(&data, function, device_object(device), checks) {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        call_down(next)
    })
}

/// A device command without a result: checked, then passed on unless a
/// messenger asks to skip it.
fn query_command<F: Copy>(
    function: &'static str,
    device: vk::Device,
    pick: fn(&DeviceFns) -> Option<F>,
    checks: impl FnOnce(&mut DeviceState) -> Report,
    call_down: impl FnOnce(F),
) {
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, pick) else {
            return;
        };
        if !check(&data, function, device_object(device), checks) {
            call_down(next);
        }
    })
}

/// `vkCreateAccelerationStructureKHR`: checked before the call; the
/// structure the driver creates is tracked after it.
unsafe extern "system" fn create_acceleration_structure(
    device: vk::Device,
    create_info: *const vk::AccelerationStructureCreateInfoKHR<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    structure_out: *mut vk::AccelerationStructureKHR,
) -> vk::Result {
    let function = "vkCreateAccelerationStructureKHR";
    // SAFETY: the create info is valid (the API's requirement).
    let info = unsafe { create_info.as_ref() };
    let result = host_command(
        function,
        device,
        |f| f.accel.create_acceleration_structure,
        |state| match info {
            // SAFETY: as above.
            Some(info) => unsafe {
                state
                    .validator
                    .create_acceleration_structure_rules_ash(info)
            },
            None => Report::default(),
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, create_info, allocator, structure_out) },
    );
    // SAFETY: on success the next layer wrote the handle.
    let created = unsafe { read::value(structure_out) };
    if let (vk::Result::SUCCESS, Some(info), Some(structure)) = (result, info, created) {
        record_created(device, function, |state| {
            state
                .validator
                .record_acceleration_structure_created_ash(info, structure);
        });
    }
    result
}

/// Tracks what a creation made, for the device of `device`.
fn record_created(device: vk::Device, function: &'static str, body: impl FnOnce(&mut DeviceState)) {
    guarded(function, (), || {
        if let Some(data) = crate::dispatch::DEVICES.get(device) {
            track(&data, function, body);
        }
    });
}

/// `vkCreateAccelerationStructure2KHR`: as [`create_acceleration_structure`].
unsafe extern "system" fn create_acceleration_structure2(
    device: vk::Device,
    create_info: *const khr::AccelerationStructureCreateInfo2KHR,
    allocator: *const vk::AllocationCallbacks<'_>,
    structure_out: *mut vk::AccelerationStructureKHR,
) -> vk::Result {
    let function = "vkCreateAccelerationStructure2KHR";
    // SAFETY: the create info is valid (the API's requirement).
    let info = unsafe { create_info.as_ref() };
    let result = host_command(
        function,
        device,
        |f| f.accel.create_acceleration_structure2,
        |state| match info {
            // SAFETY: as above.
            Some(info) => unsafe {
                state
                    .validator
                    .create_acceleration_structure2_rules_ash(info)
            },
            None => Report::default(),
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, create_info, allocator, structure_out) },
    );
    // SAFETY: on success the next layer wrote the handle.
    let created = unsafe { read::value(structure_out) };
    if let (vk::Result::SUCCESS, Some(info), Some(structure)) = (result, info, created) {
        record_created(device, function, |state| {
            state
                .validator
                .record_acceleration_structure2_created_ash(info, structure);
        });
    }
    result
}

/// `vkDestroyAccelerationStructureKHR`: the structure is forgotten.
unsafe extern "system" fn destroy_acceleration_structure(
    device: vk::Device,
    structure: vk::AccelerationStructureKHR,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyAccelerationStructureKHR";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.accel.destroy_acceleration_structure)
        else {
            return;
        };
        track(&data, function, |state| {
            let tracked = state.validator.state_mut();
            tracked.acceleration_structures.remove(&structure.as_raw());
            tracked.original_attachments.remove(&structure.as_raw());
            // What its builds put in it: kept for the structure's life
            // only (each one destroyed stayed, found by `cargo xtask soak`).
            tracked.micromap_geometry.remove(&structure.as_raw());
            tracked.execution.forget(structure.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, structure, allocator) };
    })
}

/// A device build command: as [`recorded`], and from the content tier
/// (see `DeviceState::reads_contents`) the build as read is kept for the
/// checks of its contents at submission or completion, with what GPU
/// readback needs recorded before it ([`commands::keep_build`]).
fn recorded_build<F: Copy>(
    function: &'static str,
    command_buffer: vk::CommandBuffer,
    pick: fn(&DeviceFns) -> Option<F>,
    checks: impl FnOnce(&mut DeviceState, &CommandBuffer) -> (Report, DeviceBuild),
    call_down: impl FnOnce(F),
) {
    let kept = std::cell::Cell::new(None);
    recorded(
        function,
        command_buffer,
        pick,
        |state, model| {
            let (report, build) = checks(state, model);
            if state.reads_contents() {
                kept.set(Some((build, model.clone())));
            }
            report
        },
        |next| {
            if let Some((build, model)) = kept.take() {
                if let Some(data) = crate::dispatch::DEVICES.get(command_buffer) {
                    commands::keep_build(&data, command_buffer, &model, build);
                }
            }
            call_down(next);
        },
    );
}

/// `vkCmdBuildAccelerationStructuresKHR`: checked at recording; at the
/// content tier and above its contents (index buffers, micromap inputs,
/// instances) when the command buffer is submitted or completes.
unsafe extern "system" fn cmd_build_acceleration_structures(
    command_buffer: vk::CommandBuffer,
    info_count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    build_range_infos: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) {
    recorded_build(
        "vkCmdBuildAccelerationStructuresKHR",
        command_buffer,
        |f| f.accel.cmd_build_acceleration_structures,
        // SAFETY: the application's arguments, valid as the API requires.
        |state, model| unsafe {
            state.validator.cmd_build_acceleration_structures_raw_kept(
                model,
                info_count,
                infos,
                build_range_infos,
            )
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, info_count, infos, build_range_infos) },
    );
}

/// `vkCmdBuildAccelerationStructuresIndirectKHR`: its build ranges are in
/// device memory, so at recording only what the parameters decide is
/// checked; from the content tier its range infos are read by the same
/// routes as its inputs (the opacity indices and instances whose extent
/// they decide towards the end of their buffers, see
/// [`crate::readback::windows`]) and decoded when the build is checked.
unsafe extern "system" fn cmd_build_acceleration_structures_indirect(
    command_buffer: vk::CommandBuffer,
    info_count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    addresses: *const vk::DeviceAddress,
    strides: *const u32,
    max_primitive_counts: *const *const u32,
) {
    recorded_build(
        "vkCmdBuildAccelerationStructuresIndirectKHR",
        command_buffer,
        |f| f.accel.cmd_build_acceleration_structures_indirect,
        // SAFETY: the application's arguments, valid as the API requires.
        |state, model| unsafe {
            state
                .validator
                .cmd_build_acceleration_structures_indirect_raw_kept(
                    model,
                    info_count,
                    infos,
                    addresses,
                    strides,
                    max_primitive_counts,
                )
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe {
            next(
                command_buffer,
                info_count,
                infos,
                addresses,
                strides,
                max_primitive_counts,
            )
        },
    );
}

/// `vkBuildAccelerationStructuresKHR`: a host build, whose host memory the
/// core reads where the API describes its extent.
unsafe extern "system" fn build_acceleration_structures(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info_count: u32,
    infos: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    build_range_infos: *const *const vk::AccelerationStructureBuildRangeInfoKHR,
) -> vk::Result {
    host_command(
        "vkBuildAccelerationStructuresKHR",
        device,
        |f| f.accel.build_acceleration_structures,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state
                .validator
                .build_acceleration_structures_raw(info_count, infos, build_range_infos)
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe {
            next(
                device,
                deferred_operation,
                info_count,
                infos,
                build_range_infos,
            )
        },
    )
}

/// `vkGetAccelerationStructureBuildSizesKHR`.
unsafe extern "system" fn get_acceleration_structure_build_sizes(
    device: vk::Device,
    build_type: vk::AccelerationStructureBuildTypeKHR,
    build_info: *const vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    max_primitive_counts: *const u32,
    size_info: *mut vk::AccelerationStructureBuildSizesInfoKHR<'_>,
) {
    query_command(
        "vkGetAccelerationStructureBuildSizesKHR",
        device,
        |f| f.accel.get_acceleration_structure_build_sizes,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| match unsafe { build_info.as_ref() } {
            // SAFETY: as above.
            Some(info) => unsafe {
                state.validator.get_acceleration_structure_build_sizes_ash(
                    build_type,
                    info,
                    max_primitive_counts,
                )
            },
            None => Report::default(),
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe {
            next(
                device,
                build_type,
                build_info,
                max_primitive_counts,
                size_info,
            )
        },
    );
}

/// `vkCmd*` commands checked by the core entry point named after `=>`,
/// given the command buffer's model and the command's arguments after
/// the command buffer; the next layer's function is the field of the
/// intercept's name.
macro_rules! recorded_commands {
    ($(
        $ours:ident($($arg:ident: $ty:ty),*) = $name:literal => $entry:ident;
    )*) => {$(
        unsafe extern "system" fn $ours(command_buffer: vk::CommandBuffer, $($arg: $ty),*) {
            recorded(
                $name,
                command_buffer,
                |f| f.accel.$ours,
                // SAFETY: the application's arguments, valid as the API requires.
                |state, model| unsafe { state.validator.$entry(model, $($arg),*) },
                // SAFETY: the next layer's function, with the application's arguments.
                |next| unsafe { next(command_buffer, $($arg),*) },
            );
        }
    )*};
}

/// Host commands given a deferred operation, checked by the core call
/// after `=>` and passed on through [`deferrable`]; the next layer's
/// function is the field of the intercept's name.
macro_rules! host_copy_commands {
    ($(
        $ours:ident($device:ident, $deferred:ident, $($arg:ident: $ty:ty),*) = $name:literal
            => $entry:ident($($entry_arg:ident),*);
    )*) => {$(
        unsafe extern "system" fn $ours(
            $device: vk::Device,
            $deferred: vk::DeferredOperationKHR,
            $($arg: $ty),*
        ) -> vk::Result {
            host_command(
                $name,
                $device,
                |f| f.accel.$ours,
                // SAFETY: the application's arguments, valid as the API
                // requires (a deserialization's src.hostAddress holds
                // serialized data, its header first).
                |state| unsafe { state.validator.$entry($($entry_arg),*) },
                // SAFETY: the next layer's function, with the application's arguments.
                |next| {
                    deferrable($device, $deferred, || unsafe {
                        next($device, $deferred, $($arg),*)
                    })
                },
            )
        }
    )*};
}

recorded_commands! {
    cmd_copy_acceleration_structure(info: *const vk::CopyAccelerationStructureInfoKHR<'_>)
        = "vkCmdCopyAccelerationStructureKHR" => cmd_copy_acceleration_structure_raw;
    cmd_copy_acceleration_structure_to_memory(
        info: *const vk::CopyAccelerationStructureToMemoryInfoKHR<'_>
    )
        = "vkCmdCopyAccelerationStructureToMemoryKHR"
        => cmd_copy_acceleration_structure_to_memory_raw;
    cmd_copy_memory_to_acceleration_structure(
        info: *const vk::CopyMemoryToAccelerationStructureInfoKHR<'_>
    )
        = "vkCmdCopyMemoryToAccelerationStructureKHR"
        => cmd_copy_memory_to_acceleration_structure_raw;
    cmd_copy_micromap(info: *const vk::CopyMicromapInfoEXT<'_>)
        = "vkCmdCopyMicromapEXT" => cmd_copy_micromap_raw;
    cmd_copy_micromap_to_memory(info: *const vk::CopyMicromapToMemoryInfoEXT<'_>)
        = "vkCmdCopyMicromapToMemoryEXT" => cmd_copy_micromap_to_memory_raw;
    cmd_copy_memory_to_micromap(info: *const vk::CopyMemoryToMicromapInfoEXT<'_>)
        = "vkCmdCopyMemoryToMicromapEXT" => cmd_copy_memory_to_micromap_raw;
    cmd_write_micromaps_properties(
        micromap_count: u32,
        micromaps: *const vk::MicromapEXT,
        query_type: vk::QueryType,
        query_pool: vk::QueryPool,
        first_query: u32
    ) = "vkCmdWriteMicromapsPropertiesEXT" => cmd_write_micromaps_properties_raw;
}

host_copy_commands! {
    copy_acceleration_structure(
        device,
        deferred_operation,
        info: *const vk::CopyAccelerationStructureInfoKHR<'_>
    )
        = "vkCopyAccelerationStructureKHR" => copy_acceleration_structure_raw(device, deferred_operation, info);
    copy_micromap(
        device,
        deferred_operation,
        info: *const vk::CopyMicromapInfoEXT<'_>
    )
        = "vkCopyMicromapEXT" => copy_micromap_raw(device, deferred_operation, info);
}

/// What a host serialization wrote at `address`, read once the driver
/// returned success without deferring it: its fingerprint is linked to the
/// serialization and kept in the provenance store. A deferred one is not
/// read (its bytes are written when the operation completes).
fn host_serialization_done(
    device: vk::Device,
    function: &'static str,
    result: vk::Result,
    address: u64,
) {
    if !matches!(
        result,
        vk::Result::SUCCESS | vk::Result::OPERATION_NOT_DEFERRED_KHR
    ) {
        return;
    }
    guarded(function, (), || {
        let Some(data) = crate::dispatch::DEVICES.get(device) else {
            return;
        };
        let mut warnings = Vec::new();
        track(&data, function, |state| {
            // SAFETY: the serialization completed: the application's
            // destination holds the serialized data, as large as the
            // serialization size the header states.
            unsafe { crate::provenance::host_serialization_done(&mut state.validator, address) };
            warnings = state.validator.provenance_store_warnings();
        });
        crate::provenance::warn(&data.instance.reporter, function, &warnings);
    });
}

/// The store's warnings a host deserialization's lookup gave.
fn store_warnings(device: vk::Device, function: &'static str) {
    guarded(function, (), || {
        let Some(data) = crate::dispatch::DEVICES.get(device) else {
            return;
        };
        let warnings = data.state().validator.provenance_store_warnings();
        crate::provenance::warn(&data.instance.reporter, function, &warnings);
    });
}

/// A host serialization: checked, passed on, and what it wrote at `dst`
/// fingerprinted ([`host_serialization_done`]).
fn host_serialization<F: Copy>(
    function: &'static str,
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    pick: fn(&DeviceFns) -> Option<F>,
    checks: impl FnOnce(&mut DeviceState) -> Report,
    call_down: impl FnOnce(F) -> vk::Result,
    dst: Option<vk::DeviceOrHostAddressKHR>,
) -> vk::Result {
    let result = host_command(function, device, pick, checks, |next| {
        deferrable(device, deferred_operation, || call_down(next))
    });
    if let Some(dst) = dst {
        // SAFETY: a host command's dst is a host address.
        let address = unsafe { dst.host_address }.expose_provenance() as u64;
        host_serialization_done(device, function, result, address);
    }
    result
}

/// A host deserialization: its source bytes at `src` are fingerprinted
/// before the check, which links what it constructs to what they were
/// serialized from; then checked and passed on.
fn host_deserialization<F: Copy>(
    function: &'static str,
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    pick: fn(&DeviceFns) -> Option<F>,
    src: Option<vk::DeviceOrHostAddressConstKHR>,
    checks: impl FnOnce(&mut DeviceState) -> Report,
    call_down: impl FnOnce(F) -> vk::Result,
) -> vk::Result {
    let checks = |state: &mut DeviceState| {
        if let Some(src) = src {
            // SAFETY: a host command's src is a host address holding
            // serialized data, its header first (the API's requirement).
            unsafe {
                let address = src.host_address.expose_provenance() as u64;
                crate::provenance::host_deserialization_source(&mut state.validator, address);
            }
        }
        checks(state)
    };
    let result = host_command(function, device, pick, checks, |next| {
        deferrable(device, deferred_operation, || call_down(next))
    });
    store_warnings(device, function);
    result
}

/// `vkCopyMicromapToMemoryEXT`.
unsafe extern "system" fn copy_micromap_to_memory(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info: *const vk::CopyMicromapToMemoryInfoEXT<'_>,
) -> vk::Result {
    host_serialization(
        "vkCopyMicromapToMemoryEXT",
        device,
        deferred_operation,
        |f| f.accel.copy_micromap_to_memory,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state
                .validator
                .copy_micromap_to_memory_raw(device, deferred_operation, info)
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, deferred_operation, info) },
        // SAFETY: the info is valid (the API's requirement).
        unsafe { info.as_ref() }.map(|i| i.dst),
    )
}

/// `vkCopyAccelerationStructureToMemoryKHR`.
unsafe extern "system" fn copy_acceleration_structure_to_memory(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info: *const vk::CopyAccelerationStructureToMemoryInfoKHR<'_>,
) -> vk::Result {
    host_serialization(
        "vkCopyAccelerationStructureToMemoryKHR",
        device,
        deferred_operation,
        |f| f.accel.copy_acceleration_structure_to_memory,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state.validator.copy_acceleration_structure_to_memory_raw(
                device,
                deferred_operation,
                info,
            )
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, deferred_operation, info) },
        // SAFETY: the info is valid (the API's requirement).
        unsafe { info.as_ref() }.map(|i| i.dst),
    )
}

/// `vkCopyMemoryToMicromapEXT`.
unsafe extern "system" fn copy_memory_to_micromap(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info: *const vk::CopyMemoryToMicromapInfoEXT<'_>,
) -> vk::Result {
    host_deserialization(
        "vkCopyMemoryToMicromapEXT",
        device,
        deferred_operation,
        |f| f.accel.copy_memory_to_micromap,
        // SAFETY: the info is valid (the API's requirement).
        unsafe { info.as_ref() }.map(|i| i.src),
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state
                .validator
                .copy_memory_to_micromap_raw(device, deferred_operation, info)
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, deferred_operation, info) },
    )
}

/// `vkCopyMemoryToAccelerationStructureKHR`.
unsafe extern "system" fn copy_memory_to_acceleration_structure(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    info: *const vk::CopyMemoryToAccelerationStructureInfoKHR<'_>,
) -> vk::Result {
    host_deserialization(
        "vkCopyMemoryToAccelerationStructureKHR",
        device,
        deferred_operation,
        |f| f.accel.copy_memory_to_acceleration_structure,
        // SAFETY: the info is valid (the API's requirement).
        unsafe { info.as_ref() }.map(|i| i.src),
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state
                .validator
                .copy_memory_to_acceleration_structure_raw(info)
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, deferred_operation, info) },
    )
}

/// `vkCmdBeginQuery`: the micromap rule only (the pool must not be a
/// micromap size pool).
unsafe extern "system" fn cmd_begin_query(
    command_buffer: vk::CommandBuffer,
    query_pool: vk::QueryPool,
    query: u32,
    flags: vk::QueryControlFlags,
) {
    recorded(
        "vkCmdBeginQuery",
        command_buffer,
        |f| f.accel.cmd_begin_query,
        |state, model| state.validator.cmd_begin_query(model, query_pool.as_raw()),
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, query_pool, query, flags) },
    );
}

/// `vkCmdBeginQueryIndexedEXT`: the micromap rule only.
unsafe extern "system" fn cmd_begin_query_indexed(
    command_buffer: vk::CommandBuffer,
    query_pool: vk::QueryPool,
    query: u32,
    flags: vk::QueryControlFlags,
    index: u32,
) {
    recorded(
        "vkCmdBeginQueryIndexedEXT",
        command_buffer,
        |f| f.accel.cmd_begin_query_indexed,
        |state, model| {
            state
                .validator
                .cmd_begin_query_indexed(model, query_pool.as_raw())
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, query_pool, query, flags, index) },
    );
}

unsafe extern "system" fn write_micromaps_properties(
    device: vk::Device,
    micromap_count: u32,
    micromaps: *const vk::MicromapEXT,
    query_type: vk::QueryType,
    data_size: usize,
    data: *mut c_void,
    stride: usize,
) -> vk::Result {
    host_command(
        "vkWriteMicromapsPropertiesEXT",
        device,
        |f| f.accel.write_micromaps_properties,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state.validator.write_micromaps_properties_raw(
                device,
                micromap_count,
                micromaps,
                query_type,
                data_size,
                data.cast_const(),
                stride,
            )
        },
        // SAFETY: the next layer's function, with the application's
        // arguments; then what it wrote, kept for the serialization checks.
        |next| unsafe {
            let result = next(
                device,
                micromap_count,
                micromaps,
                query_type,
                data_size,
                data,
                stride,
            );
            if result == vk::Result::SUCCESS {
                let written = (data.cast_const(), data_size, stride);
                crate::driver_answers::remember_serialization_sizes(
                    device,
                    read::array(micromaps, micromap_count),
                    query_type,
                    written,
                );
            }
            result
        },
    )
}

unsafe extern "system" fn get_micromap_build_sizes(
    device: vk::Device,
    build_type: vk::AccelerationStructureBuildTypeKHR,
    build_info: *const vk::MicromapBuildInfoEXT<'_>,
    size_info: *mut vk::MicromapBuildSizesInfoEXT<'_>,
) {
    query_command(
        "vkGetMicromapBuildSizesEXT",
        device,
        |f| f.accel.get_micromap_build_sizes,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state.validator.get_micromap_build_sizes_raw(
                device,
                build_type,
                build_info,
                size_info.cast_const(),
            )
        },
        // SAFETY: the next layer's function, with the application's
        // arguments; then what it wrote, kept for the build checks.
        |next| unsafe {
            next(device, build_type, build_info, size_info);
            crate::driver_answers::remember(device, build_type, build_info, size_info);
        },
    );
}

unsafe extern "system" fn get_device_micromap_compatibility(
    device: vk::Device,
    version_info: *const vk::MicromapVersionInfoEXT<'_>,
    compatibility: *mut vk::AccelerationStructureCompatibilityKHR,
) {
    query_command(
        "vkGetDeviceMicromapCompatibilityEXT",
        device,
        |f| f.accel.get_device_micromap_compatibility,
        // SAFETY: the application's arguments, valid as the API requires.
        |state| unsafe {
            state.validator.get_device_micromap_compatibility_raw(
                device,
                version_info,
                compatibility.cast_const(),
            )
        },
        // SAFETY: the next layer's function, with the application's
        // arguments; then what it wrote, kept for the deserialization checks.
        |next| unsafe {
            next(device, version_info, compatibility);
            crate::driver_answers::remember_compatibility(
                device,
                version_info,
                compatibility.cast_const(),
            );
        },
    );
}

/// `vkCreateQueryPool`: the pool's type and size decide the micromap query rules.
unsafe extern "system" fn create_query_pool(
    device: vk::Device,
    create_info: *const vk::QueryPoolCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    pool_out: *mut vk::QueryPool,
) -> vk::Result {
    let function = "vkCreateQueryPool";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.accel.create_query_pool) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, create_info, allocator, pool_out) };
        // SAFETY: on success the next layer wrote the handle.
        if let (vk::Result::SUCCESS, Some(pool)) = (result, unsafe { read::value(pool_out) }) {
            track(&data, function, |state| {
                // SAFETY: the create info is valid (the API's requirement).
                unsafe { state.validator.record_query_pool_raw(create_info, pool) };
            });
        }
        result
    })
}

unsafe extern "system" fn destroy_query_pool(
    device: vk::Device,
    pool: vk::QueryPool,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyQueryPool";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.accel.destroy_query_pool) else {
            return;
        };
        track(&data, function, |state| {
            state.validator.forget_query_pool(pool.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pool, allocator) };
    })
}
