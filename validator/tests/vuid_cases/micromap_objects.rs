//! Cases for the `micromap_objects` checks: micromap creation and
//! destruction, copies and (de)serialization on the device and the host,
//! property queries, build sizes, compatibility, and the micromap rule of
//! `vkCmdBeginQuery*`.

use ommcheck::model::micromap_objects::*;
use ommcheck::model::values::*;
use ommcheck::model::Handle;
use ommcheck::model::{CommandBuffer, MicromapBuildInfo};
use ommcheck::state::{Buffer, BuildRecord, MemoryBinding, Micromap, QueryPool};
use ommcheck::vuids::vuid::{
    vkCmdBeginQuery as begin_query, vkCmdBeginQueryIndexedEXT as begin_query_indexed,
    vkCmdCopyMemoryToMicromapEXT as cmd_from_memory, vkCmdCopyMicromapEXT as cmd_copy,
    vkCmdCopyMicromapToMemoryEXT as cmd_to_memory, vkCmdWriteMicromapsPropertiesEXT as cmd_write,
    vkCopyMemoryToMicromapEXT as host_from_memory, vkCopyMicromapEXT as host_copy,
    vkCopyMicromapToMemoryEXT as host_to_memory, vkCreateMicromapEXT as create,
    vkDestroyMicromapEXT as destroy, vkGetDeviceMicromapCompatibilityEXT as compatibility,
    vkGetMicromapBuildSizesEXT as build_sizes, vkWriteMicromapsPropertiesEXT as host_write,
    VkCopyMemoryToMicromapInfoEXT as from_memory_info, VkCopyMicromapInfoEXT as copy_info,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info, VkMicromapBuildSizesInfoEXT as sizes_info,
    VkMicromapCreateInfoEXT as create_info, VkMicromapVersionInfoEXT as version_info,
};
use ommcheck::{Device, Report, Validator};

use crate::fixtures::*;
use crate::{case, Case};

const DEVICE: Handle = 0xd0;
const NEW_MICROMAP: Handle = 0x4a;
const DEFERRED: Handle = 0xdef;
const UNKNOWN: Handle = 0xbad;
const POOL_COMPACTED: Handle = 0x9c;
const POOL_SERIALIZATION: Handle = 0x95;
const POOL_OCCLUSION: Handle = 0x90;
/// A micromap-storage buffer created sparse-resident.
const SPARSE: Handle = 0x9b;
/// Micromaps on buffers that are unbound, device-local, and multi-instance.
const UNBOUND_MICROMAP: Handle = 0x6a;
const DEVICE_LOCAL_MICROMAP: Handle = 0x7a;
const MULTI_INSTANCE_MICROMAP: Handle = 0x8a;
/// A device address inside no buffer (256-byte aligned).
const NOWHERE: u64 = 0x9000_0000;
/// A host address outside the described host memory (16-byte aligned).
const HOST_NOWHERE: u64 = 0x1234_0000;

/// The fixtures' world on `device`, plus: MICROMAP built with
/// ALLOW_COMPACTION, MICROMAP_2 built without, three query pools, a deferred
/// operation, and micromaps on unbound, device-local and multi-instance memory.
fn world_on(device: Device) -> Validator {
    let mut v = validator_with(device, &two_triangles());
    let state = v.state_mut();
    for (micromap, flags) in [
        (MICROMAP, BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT),
        (MICROMAP_2, 0),
    ] {
        if let Some(m) = state.micromaps.get_mut(&micromap) {
            m.built = Some(BuildRecord {
                flags,
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                triangle_count: 2,
                ..Default::default()
            });
        }
    }
    for (pool, query_type) in [
        (POOL_COMPACTED, QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT),
        (
            POOL_SERIALIZATION,
            QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT,
        ),
        (POOL_OCCLUSION, QUERY_TYPE_OCCLUSION),
    ] {
        state.query_pools.insert(
            pool,
            QueryPool {
                query_type,
                query_count: 4,
            },
        );
    }
    state.deferred_operations.insert(DEFERRED);
    let storage = |memory: Option<MemoryBinding>, create_flags: u32| Buffer {
        size: 0x1_0000,
        usage: BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT,
        create_flags,
        memory,
        ..Default::default()
    };
    let binding = |host_visible, multi_instance| {
        Some(MemoryBinding {
            host_visible,
            multi_instance,
        })
    };
    state.buffers.insert(
        SPARSE,
        storage(binding(true, false), BUFFER_CREATE_SPARSE_RESIDENCY_BIT),
    );
    for (micromap, memory) in [
        (UNBOUND_MICROMAP, None),
        (DEVICE_LOCAL_MICROMAP, binding(false, false)),
        (MULTI_INSTANCE_MICROMAP, binding(true, true)),
    ] {
        // Each micromap's buffer is its handle plus one.
        state.buffers.insert(micromap + 1, storage(memory, 0));
        state.micromaps.insert(
            micromap,
            Micromap {
                buffer: micromap + 1,
                size: 0x1000,
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                ..Default::default()
            },
        );
    }
    v
}

fn world() -> Validator {
    world_on(device())
}

fn device_where(change: fn(&mut Device)) -> Device {
    let mut d = device();
    change(&mut d);
    d
}

/// A micromap, a deferred operation and a query pool of another VkDevice.
const FOREIGN: Handle = 0xf0;

/// [`world`] where [`FOREIGN`] is a handle of another device.
fn world_with_foreign() -> Validator {
    let mut v = world();
    v.state_mut().other_device_objects.insert(FOREIGN);
    v
}

/// [`world`] where [`DEFERRED`] still runs an earlier deferred command.
fn world_with_pending() -> Validator {
    let mut v = world();
    v.state_mut().pending_deferred_operations.insert(DEFERRED);
    v
}

fn without_micromap_feature() -> Validator {
    world_on(device_where(|d| d.features.micromap_ext = false))
}

fn without_host_commands() -> Validator {
    world_on(device_where(|d| d.features.micromap_host_commands = false))
}

/// A device group of two without bufferDeviceAddressMultiDevice.
fn multi_device(multi_device_addresses: bool) -> Device {
    let mut d = device();
    d.physical_device_count = 2;
    d.features.buffer_device_address_multi_device = multi_device_addresses;
    d
}

fn bad_allocator() -> AllocationCallbacks {
    AllocationCallbacks {
        pfn_free: 0,
        ..Default::default()
    }
}

// vkCreateMicromapEXT

fn micromap_create_info() -> MicromapCreateInfo {
    MicromapCreateInfo {
        buffer: STORAGE,
        offset: 0x1000,
        size: 0x100,
        ..Default::default()
    }
}

fn create_on(v: &mut Validator, info: &MicromapCreateInfo) -> Report {
    v.create_micromap(DEVICE, Some(info), None, Some(NEW_MICROMAP))
}

fn create_with(change: fn(&mut MicromapCreateInfo)) -> Report {
    let mut info = micromap_create_info();
    change(&mut info);
    create_on(&mut world(), &info)
}

fn ok_create() -> Report {
    create_with(|_| {})
}

fn capture_replay(info: &mut MicromapCreateInfo) {
    info.create_flags = MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT;
    info.device_address = STORAGE_ADDRESS + 0x1000;
}

fn create_replay_on(device: Device) -> Report {
    let mut info = micromap_create_info();
    capture_replay(&mut info);
    create_on(&mut world_on(device), &info)
}

// vkDestroyMicromapEXT

fn destroy_created_with_allocator(allocator: Option<&AllocationCallbacks>) -> Report {
    let mut v = world();
    if let Some(m) = v.state_mut().micromaps.get_mut(&MICROMAP) {
        m.allocator = true;
    }
    v.destroy_micromap(DEVICE, MICROMAP, allocator)
}

fn ok_destroy() -> Report {
    world().destroy_micromap(DEVICE, MICROMAP, None)
}

// Copies between micromaps

fn copy_micromap_info() -> CopyMicromapInfo {
    CopyMicromapInfo {
        src: MICROMAP,
        dst: MICROMAP_2,
        ..Default::default()
    }
}

fn cmd_copy_with(change: fn(&mut CopyMicromapInfo)) -> Report {
    let mut info = copy_micromap_info();
    change(&mut info);
    world().cmd_copy_micromap(&command_buffer(), Some(&info))
}

fn ok_cmd_copy() -> Report {
    cmd_copy_with(|_| {})
}

fn cmd_copy_on(cb: &CommandBuffer) -> Report {
    world().cmd_copy_micromap(cb, Some(&copy_micromap_info()))
}

fn host_copy_with(change: fn(&mut CopyMicromapInfo)) -> Report {
    let mut info = copy_micromap_info();
    change(&mut info);
    world().copy_micromap(DEVICE, 0, Some(&info))
}

fn host_copy_call(mut v: Validator, device: Handle, deferred: Handle, with_info: bool) -> Report {
    let info = copy_micromap_info();
    v.copy_micromap(device, deferred, with_info.then_some(&info))
}

// Serialization

fn to_memory_info(dst: u64) -> CopyMicromapToMemoryInfo {
    CopyMicromapToMemoryInfo {
        src: MICROMAP,
        dst,
        ..Default::default()
    }
}

fn cmd_to_memory_with(change: fn(&mut CopyMicromapToMemoryInfo)) -> Report {
    let mut info = to_memory_info(INPUT_ADDRESS);
    change(&mut info);
    world().cmd_copy_micromap_to_memory(&command_buffer(), Some(&info))
}

fn ok_cmd_to_memory() -> Report {
    cmd_to_memory_with(|_| {})
}

fn cmd_to_memory_on(cb: &CommandBuffer) -> Report {
    world().cmd_copy_micromap_to_memory(cb, Some(&to_memory_info(INPUT_ADDRESS)))
}

fn host_to_memory_with(change: fn(&mut CopyMicromapToMemoryInfo)) -> Report {
    let mut info = to_memory_info(HOST_DATA);
    change(&mut info);
    world().copy_micromap_to_memory(DEVICE, 0, Some(&info))
}

fn host_to_memory_call(
    mut v: Validator,
    device: Handle,
    deferred: Handle,
    with_info: bool,
) -> Report {
    let info = to_memory_info(HOST_DATA);
    v.copy_micromap_to_memory(device, deferred, with_info.then_some(&info))
}

// Deserialization

fn from_memory_info(src: u64) -> CopyMemoryToMicromapInfo {
    CopyMemoryToMicromapInfo {
        src,
        dst: MICROMAP,
        ..Default::default()
    }
}

fn cmd_from_memory_with(change: fn(&mut CopyMemoryToMicromapInfo)) -> Report {
    let mut info = from_memory_info(INPUT_ADDRESS);
    change(&mut info);
    world().cmd_copy_memory_to_micromap(&command_buffer(), Some(&info))
}

fn ok_cmd_from_memory() -> Report {
    cmd_from_memory_with(|_| {})
}

fn cmd_from_memory_on(cb: &CommandBuffer) -> Report {
    world().cmd_copy_memory_to_micromap(cb, Some(&from_memory_info(INPUT_ADDRESS)))
}

fn host_from_memory_with(change: fn(&mut CopyMemoryToMicromapInfo)) -> Report {
    let mut info = from_memory_info(HOST_DATA);
    change(&mut info);
    world().copy_memory_to_micromap(DEVICE, 0, Some(&info))
}

fn host_from_memory_call(
    mut v: Validator,
    device: Handle,
    deferred: Handle,
    with_info: bool,
) -> Report {
    let info = from_memory_info(HOST_DATA);
    v.copy_memory_to_micromap(device, deferred, with_info.then_some(&info))
}

// Property queries

fn cmd_write(micromaps: Vec<Handle>, query_type: i32, pool: Handle, first_query: u32) -> Report {
    world().cmd_write_micromaps_properties(
        &command_buffer(),
        &MicromapList::of(micromaps),
        query_type,
        pool,
        first_query,
    )
}

fn ok_cmd_write() -> Report {
    cmd_write(
        vec![MICROMAP],
        QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
        POOL_COMPACTED,
        0,
    )
}

fn cmd_write_on(cb: &CommandBuffer) -> Report {
    world().cmd_write_micromaps_properties(
        cb,
        &MicromapList::of(vec![MICROMAP]),
        QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
        POOL_COMPACTED,
        0,
    )
}

/// `vkWriteMicromapsPropertiesEXT` of a compacted-size query into `HOST_DATA`.
struct HostWrite {
    micromaps: MicromapList,
    query_type: i32,
    data_size: u64,
    data: u64,
    stride: u64,
}

fn host_write_call() -> HostWrite {
    HostWrite {
        micromaps: MicromapList::of(vec![MICROMAP]),
        query_type: QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
        data_size: 8,
        data: HOST_DATA,
        stride: 8,
    }
}

fn host_write_on(mut v: Validator, device: Handle, change: fn(&mut HostWrite)) -> Report {
    let mut call = host_write_call();
    change(&mut call);
    v.write_micromaps_properties(
        device,
        &call.micromaps,
        call.query_type,
        call.data_size,
        call.data,
        call.stride,
    )
}

fn host_write_with(change: fn(&mut HostWrite)) -> Report {
    host_write_on(world(), DEVICE, change)
}

fn ok_host_write() -> Report {
    host_write_with(|_| {})
}

// Build sizes and compatibility

fn build_sizes_on(
    mut v: Validator,
    device: Handle,
    build_type: i32,
    info: Option<&MicromapBuildInfo>,
    sizes: Option<&MicromapBuildSizesInfo>,
) -> Report {
    v.get_micromap_build_sizes(device, build_type, info, sizes)
}

fn build_sizes_with(change: fn(&mut MicromapBuildSizesInfo)) -> Report {
    let mut sizes = MicromapBuildSizesInfo::default();
    change(&mut sizes);
    build_sizes_on(world(), DEVICE, 1, Some(&device_build()), Some(&sizes))
}

fn ok_build_sizes() -> Report {
    build_sizes_with(|_| {})
}

fn compatibility_with(change: fn(&mut MicromapVersionInfo)) -> Report {
    let mut version = MicromapVersionInfo::default();
    change(&mut version);
    world().get_device_micromap_compatibility(DEVICE, Some(&version), true)
}

fn ok_compatibility() -> Report {
    compatibility_with(|_| {})
}

/// The six command-buffer rules of a `vkCmd*` entry point, each failing on
/// a command buffer with one defect and passing on the fixtures' one.
macro_rules! command_buffer_cases {
    ($vuids:ident, $on:ident) => {
        vec![
            case(
                $vuids::commandBuffer_parameter,
                || {
                    $on(&CommandBuffer {
                        handle: 0,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
            case(
                $vuids::commandBuffer_recording,
                || {
                    $on(&CommandBuffer {
                        recording: false,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
            case(
                $vuids::commandBuffer_cmdpool,
                || {
                    $on(&CommandBuffer {
                        queue_flags: ommcheck::model::command::queue::TRANSFER,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
            case(
                $vuids::renderpass,
                || {
                    $on(&CommandBuffer {
                        in_render_pass: true,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
            case(
                $vuids::videocoding,
                || {
                    $on(&CommandBuffer {
                        in_video_coding: true,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
            case(
                $vuids::suspended,
                || {
                    $on(&CommandBuffer {
                        suspended: true,
                        ..command_buffer()
                    })
                },
                || $on(&command_buffer()),
            ),
        ]
    };
}

/// The four rules every host copy states about its call: the device, the
/// deferred operation, the micromapHostCommands feature, and a NULL pInfo.
macro_rules! host_call_cases {
    ($vuids:ident, $host_commands:ident, $call:ident) => {
        vec![
            case(
                $vuids::device_parameter,
                || $call(world(), 0, 0, true),
                || $call(world(), DEVICE, 0, true),
            ),
            case(
                $vuids::deferredOperation_parameter,
                || $call(world(), DEVICE, UNKNOWN, true),
                || $call(world(), DEVICE, DEFERRED, true),
            ),
            case(
                $vuids::deferredOperation_parent,
                || $call(world_with_foreign(), DEVICE, FOREIGN, true),
                || $call(world_with_foreign(), DEVICE, DEFERRED, true),
            ),
            case(
                $vuids::deferredOperation_03678,
                || $call(world_with_pending(), DEVICE, DEFERRED, true),
                || $call(world(), DEVICE, DEFERRED, true),
            ),
            case(
                $vuids::$host_commands,
                || $call(without_host_commands(), DEVICE, 0, true),
                || $call(world(), DEVICE, 0, true),
            ),
            case(
                $vuids::pInfo_parameter,
                || $call(world(), DEVICE, 0, false),
                || $call(world(), DEVICE, 0, true),
            ),
        ]
    };
}

/// The rules that objects of one call come from one device.
fn parent_cases() -> Vec<Case> {
    vec![
        case(
            destroy::micromap_parent,
            || world_with_foreign().destroy_micromap(DEVICE, FOREIGN, None),
            || world_with_foreign().destroy_micromap(DEVICE, MICROMAP, None),
        ),
        case(
            copy_info::commonparent,
            || {
                let info = CopyMicromapInfo {
                    dst: FOREIGN,
                    ..copy_micromap_info()
                };
                world_with_foreign().cmd_copy_micromap(&command_buffer(), Some(&info))
            },
            ok_cmd_copy,
        ),
        case(
            host_write::pMicromaps_parent,
            || {
                host_write_on(world_with_foreign(), DEVICE, |w| {
                    w.micromaps = MicromapList::of(vec![FOREIGN])
                })
            },
            ok_host_write,
        ),
        case(
            cmd_write::commonparent,
            || {
                world_with_foreign().cmd_write_micromaps_properties(
                    &command_buffer(),
                    &MicromapList::of(vec![MICROMAP]),
                    QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT,
                    FOREIGN,
                    0,
                )
            },
            ok_cmd_write,
        ),
    ]
}

pub fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    cases.extend(parent_cases());
    cases.extend(create_cases());
    cases.extend(destroy_cases());
    cases.extend(copy_cases());
    cases.extend(serialization_cases());
    cases.extend(deserialization_cases());
    cases.extend(provenance_cases());
    cases.extend(property_cases());
    cases.extend(query_cases());
    cases.extend(command_buffer_cases!(cmd_copy, cmd_copy_on));
    cases.extend(command_buffer_cases!(cmd_to_memory, cmd_to_memory_on));
    cases.extend(command_buffer_cases!(cmd_from_memory, cmd_from_memory_on));
    cases.extend(command_buffer_cases!(cmd_write, cmd_write_on));
    cases.extend(host_call_cases!(
        host_copy,
        micromapHostCommands_07560,
        host_copy_call
    ));
    cases.extend(host_call_cases!(
        host_to_memory,
        micromapHostCommands_07571,
        host_to_memory_call
    ));
    cases.extend(host_call_cases!(
        host_from_memory,
        micromapHostCommands_07566,
        host_from_memory_call
    ));
    cases
}

fn create_cases() -> Vec<Case> {
    vec![
        case(
            create_info::buffer_07435,
            || create_with(|c| c.buffer = INPUT),
            ok_create,
        ),
        case(
            create_info::buffer_07436,
            || create_with(|c| c.buffer = SPARSE),
            ok_create,
        ),
        case(
            create_info::buffer_parameter,
            || create_with(|c| c.buffer = UNKNOWN),
            ok_create,
        ),
        case(
            create_info::bufferDeviceAddressMultiDevice_11617,
            || create_replay_on(multi_device(false)),
            || create_replay_on(multi_device(true)),
        ),
        case(
            create_info::createFlags_parameter,
            || create_with(|c| c.create_flags = 0x2),
            || create_with(capture_replay),
        ),
        case(
            create_info::deviceAddress_07433,
            || create_with(|c| c.device_address = STORAGE_ADDRESS + 0x1000),
            || create_with(capture_replay),
        ),
        case(
            create_info::deviceAddress_parameter,
            || {
                create_with(|c| {
                    capture_replay(c);
                    c.device_address = NOWHERE;
                })
            },
            || create_with(capture_replay),
        ),
        case(
            create_info::micromapCaptureReplay_11616,
            || create_replay_on(device_where(|d| d.features.micromap_capture_replay = false)),
            || create_replay_on(device()),
        ),
        case(
            create_info::offset_07437,
            || {
                create_with(|c| {
                    c.offset = 0xff00;
                    c.size = 0x200;
                })
            },
            || {
                create_with(|c| {
                    c.offset = 0xff00;
                    c.size = 0x100;
                })
            },
        ),
        case(
            create_info::offset_07438,
            || create_with(|c| c.offset = 0x1080),
            ok_create,
        ),
        case(
            create_info::pNext_pNext,
            || create_with(|c| c.next = vec![STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT]),
            ok_create,
        ),
        case(
            create_info::sType_sType,
            || create_with(|c| c.s_type = STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT),
            ok_create,
        ),
        case(
            create_info::type_parameter,
            || create_with(|c| c.ty = 5),
            || create_with(|c| c.ty = MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV),
        ),
        case(
            create::device_parameter,
            || world().create_micromap(0, Some(&micromap_create_info()), None, Some(NEW_MICROMAP)),
            ok_create,
        ),
        case(
            create::device_queuecount,
            || {
                let mut v = world_on(device_where(|d| d.queue_count = 0));
                create_on(&mut v, &micromap_create_info())
            },
            ok_create,
        ),
        case(
            create::micromap_11615,
            || create_on(&mut without_micromap_feature(), &micromap_create_info()),
            ok_create,
        ),
        case(
            create::pAllocator_parameter,
            || {
                world().create_micromap(
                    DEVICE,
                    Some(&micromap_create_info()),
                    Some(&bad_allocator()),
                    Some(NEW_MICROMAP),
                )
            },
            || {
                world().create_micromap(
                    DEVICE,
                    Some(&micromap_create_info()),
                    Some(&AllocationCallbacks::default()),
                    Some(NEW_MICROMAP),
                )
            },
        ),
        case(
            create::pCreateInfo_parameter,
            || world().create_micromap(DEVICE, None, None, Some(NEW_MICROMAP)),
            ok_create,
        ),
        case(
            create::pMicromap_parameter,
            || world().create_micromap(DEVICE, Some(&micromap_create_info()), None, None),
            || {
                // Created, then destroyed with matching (absent) callbacks.
                let mut v = world();
                let mut report = create_on(&mut v, &micromap_create_info());
                report.extend(v.destroy_micromap(DEVICE, NEW_MICROMAP, None));
                report
            },
        ),
    ]
}

fn destroy_cases() -> Vec<Case> {
    vec![
        case(
            destroy::device_parameter,
            || world().destroy_micromap(0, MICROMAP, None),
            ok_destroy,
        ),
        case(
            destroy::micromap_07442,
            || destroy_created_with_allocator(None),
            || destroy_created_with_allocator(Some(&AllocationCallbacks::default())),
        ),
        case(
            destroy::micromap_07443,
            || world().destroy_micromap(DEVICE, MICROMAP, Some(&AllocationCallbacks::default())),
            ok_destroy,
        ),
        case(
            destroy::micromap_11619,
            || without_micromap_feature().destroy_micromap(DEVICE, MICROMAP, None),
            ok_destroy,
        ),
        case(
            destroy::micromap_parameter,
            || world().destroy_micromap(DEVICE, UNKNOWN, None),
            || world().destroy_micromap(DEVICE, 0, None),
        ),
        case(
            destroy::pAllocator_parameter,
            || destroy_created_with_allocator(Some(&bad_allocator())),
            || destroy_created_with_allocator(Some(&AllocationCallbacks::default())),
        ),
    ]
}

fn copy_cases() -> Vec<Case> {
    vec![
        case(
            copy_info::dst_parameter,
            || cmd_copy_with(|c| c.dst = UNKNOWN),
            ok_cmd_copy,
        ),
        case(
            copy_info::src_parameter,
            || cmd_copy_with(|c| c.src = UNKNOWN),
            ok_cmd_copy,
        ),
        case(
            copy_info::mode_07531,
            || cmd_copy_with(|c| c.mode = COPY_MICROMAP_MODE_SERIALIZE_EXT),
            || cmd_copy_with(|c| c.mode = COPY_MICROMAP_MODE_COMPACT_EXT),
        ),
        case(
            copy_info::mode_07533,
            || {
                cmd_copy_with(|c| {
                    c.mode = COPY_MICROMAP_MODE_COMPACT_EXT;
                    c.src = MICROMAP_2;
                    c.dst = MICROMAP;
                })
            },
            || {
                cmd_copy_with(|c| {
                    c.src = MICROMAP_2;
                    c.dst = MICROMAP;
                })
            },
        ),
        case(
            copy_info::pNext_pNext,
            || cmd_copy_with(|c| c.next = vec![STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT]),
            ok_cmd_copy,
        ),
        case(
            copy_info::sType_sType,
            || cmd_copy_with(|c| c.s_type = STRUCTURE_TYPE_COPY_MICROMAP_TO_MEMORY_INFO_EXT),
            ok_cmd_copy,
        ),
        case(
            cmd_copy::buffer_07529,
            || cmd_copy_with(|c| c.src = UNBOUND_MICROMAP),
            ok_cmd_copy,
        ),
        case(
            cmd_copy::buffer_07530,
            || cmd_copy_with(|c| c.dst = UNBOUND_MICROMAP),
            ok_cmd_copy,
        ),
        case(
            cmd_copy::pInfo_parameter,
            || world().cmd_copy_micromap(&command_buffer(), None),
            ok_cmd_copy,
        ),
        case(
            host_copy::buffer_07558,
            || host_copy_with(|c| c.src = DEVICE_LOCAL_MICROMAP),
            || host_copy_with(|_| {}),
        ),
        case(
            host_copy::buffer_07559,
            || host_copy_with(|c| c.dst = DEVICE_LOCAL_MICROMAP),
            || host_copy_with(|_| {}),
        ),
        case(
            host_copy::buffer_07561,
            || host_copy_with(|c| c.src = MULTI_INSTANCE_MICROMAP),
            || host_copy_with(|_| {}),
        ),
        case(
            host_copy::buffer_07562,
            || host_copy_with(|c| c.dst = MULTI_INSTANCE_MICROMAP),
            || host_copy_with(|_| {}),
        ),
    ]
}

fn serialization_cases() -> Vec<Case> {
    vec![
        case(
            to_memory_info::mode_07542,
            || cmd_to_memory_with(|c| c.mode = COPY_MICROMAP_MODE_CLONE_EXT),
            ok_cmd_to_memory,
        ),
        case(
            to_memory_info::mode_parameter,
            || cmd_to_memory_with(|c| c.mode = 9),
            ok_cmd_to_memory,
        ),
        case(
            to_memory_info::pNext_pNext,
            || cmd_to_memory_with(|c| c.next = vec![STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT]),
            ok_cmd_to_memory,
        ),
        case(
            to_memory_info::sType_sType,
            || cmd_to_memory_with(|c| c.s_type = STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT),
            ok_cmd_to_memory,
        ),
        case(
            to_memory_info::src_parameter,
            || cmd_to_memory_with(|c| c.src = UNKNOWN),
            ok_cmd_to_memory,
        ),
        case(
            cmd_to_memory::buffer_07539,
            || cmd_to_memory_with(|c| c.src = UNBOUND_MICROMAP),
            ok_cmd_to_memory,
        ),
        case(
            cmd_to_memory::pInfo_07536,
            || cmd_to_memory_with(|c| c.dst = NOWHERE),
            ok_cmd_to_memory,
        ),
        case(
            cmd_to_memory::pInfo_07537,
            || cmd_to_memory_with(|c| c.dst = INPUT_ADDRESS + 16),
            || cmd_to_memory_with(|c| c.dst = INPUT_ADDRESS + 256),
        ),
        case(
            cmd_to_memory::pInfo_parameter,
            || world().cmd_copy_micromap_to_memory(&command_buffer(), None),
            ok_cmd_to_memory,
        ),
        case(
            host_to_memory::buffer_07568,
            || host_to_memory_with(|c| c.src = DEVICE_LOCAL_MICROMAP),
            || host_to_memory_with(|_| {}),
        ),
        case(
            host_to_memory::buffer_07572,
            || host_to_memory_with(|c| c.src = MULTI_INSTANCE_MICROMAP),
            || host_to_memory_with(|_| {}),
        ),
        case(
            host_to_memory::pInfo_07569,
            || host_to_memory_with(|c| c.dst = 0),
            || host_to_memory_with(|_| {}),
        ),
        case(
            host_to_memory::pInfo_07570,
            || host_to_memory_with(|c| c.dst = HOST_DATA + 4),
            || host_to_memory_with(|c| c.dst = HOST_DATA + 16),
        ),
    ]
}

fn deserialization_cases() -> Vec<Case> {
    vec![
        case(
            from_memory_info::dst_parameter,
            || cmd_from_memory_with(|c| c.dst = UNKNOWN),
            ok_cmd_from_memory,
        ),
        case(
            from_memory_info::mode_07548,
            || cmd_from_memory_with(|c| c.mode = COPY_MICROMAP_MODE_SERIALIZE_EXT),
            ok_cmd_from_memory,
        ),
        case(
            from_memory_info::mode_parameter,
            || cmd_from_memory_with(|c| c.mode = -1),
            ok_cmd_from_memory,
        ),
        case(
            from_memory_info::pNext_pNext,
            || cmd_from_memory_with(|c| c.next = vec![STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT]),
            ok_cmd_from_memory,
        ),
        case(
            from_memory_info::sType_sType,
            || cmd_from_memory_with(|c| c.s_type = 0),
            ok_cmd_from_memory,
        ),
        case(
            cmd_from_memory::buffer_07546,
            || cmd_from_memory_with(|c| c.dst = UNBOUND_MICROMAP),
            ok_cmd_from_memory,
        ),
        case(
            cmd_from_memory::pInfo_07543,
            || cmd_from_memory_with(|c| c.src = NOWHERE),
            ok_cmd_from_memory,
        ),
        case(
            cmd_from_memory::pInfo_07544,
            || cmd_from_memory_with(|c| c.src = INPUT_ADDRESS + 0x80),
            || cmd_from_memory_with(|c| c.src = INPUT_ADDRESS + 0x100),
        ),
        case(
            cmd_from_memory::pInfo_parameter,
            || world().cmd_copy_memory_to_micromap(&command_buffer(), None),
            ok_cmd_from_memory,
        ),
        case(
            host_from_memory::buffer_07565,
            || host_from_memory_with(|c| c.dst = DEVICE_LOCAL_MICROMAP),
            || host_from_memory_with(|_| {}),
        ),
        case(
            host_from_memory::buffer_07567,
            || host_from_memory_with(|c| c.dst = MULTI_INSTANCE_MICROMAP),
            || host_from_memory_with(|_| {}),
        ),
        case(
            host_from_memory::pInfo_07563,
            || host_from_memory_with(|c| c.src = HOST_NOWHERE),
            || host_from_memory_with(|_| {}),
        ),
        case(
            host_from_memory::pInfo_07564,
            || host_from_memory_with(|c| c.src = HOST_DATA + 8),
            || host_from_memory_with(|c| c.src = HOST_DATA + 32),
        ),
    ]
}

fn property_cases() -> Vec<Case> {
    const COMPACTED: i32 = QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT;
    vec![
        case(
            cmd_write::buffer_07527,
            || cmd_write(vec![UNBOUND_MICROMAP], COMPACTED, POOL_COMPACTED, 0),
            ok_cmd_write,
        ),
        case(
            cmd_write::micromapCount_arraylength,
            || cmd_write(vec![], COMPACTED, POOL_COMPACTED, 0),
            ok_cmd_write,
        ),
        case(
            cmd_write::pMicromaps_07502,
            || cmd_write(vec![MICROMAP_2], COMPACTED, POOL_COMPACTED, 0),
            || {
                cmd_write(
                    vec![MICROMAP_2],
                    QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT,
                    POOL_SERIALIZATION,
                    0,
                )
            },
        ),
        case(
            cmd_write::pMicromaps_parameter,
            || cmd_write(vec![MICROMAP, UNKNOWN], COMPACTED, POOL_COMPACTED, 0),
            ok_cmd_write,
        ),
        case(
            cmd_write::query_07528,
            || cmd_write(vec![MICROMAP, MICROMAP], COMPACTED, POOL_COMPACTED, 3),
            || cmd_write(vec![MICROMAP, MICROMAP], COMPACTED, POOL_COMPACTED, 2),
        ),
        case(
            cmd_write::queryPool_07525,
            || cmd_write(vec![MICROMAP], COMPACTED, POOL_SERIALIZATION, 0),
            ok_cmd_write,
        ),
        case(
            cmd_write::queryPool_parameter,
            || cmd_write(vec![MICROMAP], COMPACTED, UNKNOWN, 0),
            ok_cmd_write,
        ),
        case(
            cmd_write::queryType_07503,
            || cmd_write(vec![MICROMAP], QUERY_TYPE_OCCLUSION, POOL_OCCLUSION, 0),
            ok_cmd_write,
        ),
        case(
            host_write::buffer_07577,
            || host_write_with(|w| w.micromaps = MicromapList::of(vec![DEVICE_LOCAL_MICROMAP])),
            ok_host_write,
        ),
        case(
            host_write::buffer_07579,
            || host_write_with(|w| w.micromaps = MicromapList::of(vec![MULTI_INSTANCE_MICROMAP])),
            ok_host_write,
        ),
        case(
            host_write::dataSize_07576,
            || host_write_with(|w| w.micromaps = MicromapList::of(vec![MICROMAP, MICROMAP])),
            || {
                host_write_with(|w| {
                    w.micromaps = MicromapList::of(vec![MICROMAP, MICROMAP]);
                    w.data_size = 16;
                })
            },
        ),
        case(
            host_write::dataSize_arraylength,
            || host_write_with(|w| w.data_size = 0),
            ok_host_write,
        ),
        case(
            host_write::device_parameter,
            || host_write_on(world(), 0, |_| {}),
            ok_host_write,
        ),
        case(
            host_write::micromapCount_arraylength,
            || host_write_with(|w| w.micromaps = MicromapList::of(vec![])),
            ok_host_write,
        ),
        case(
            host_write::micromapHostCommands_07578,
            || host_write_on(without_host_commands(), DEVICE, |_| {}),
            ok_host_write,
        ),
        case(
            host_write::pData_parameter,
            || host_write_with(|w| w.data = 0),
            ok_host_write,
        ),
        case(
            host_write::pMicromaps_07502,
            || host_write_with(|w| w.micromaps = MicromapList::of(vec![MICROMAP_2])),
            || {
                host_write_with(|w| {
                    w.micromaps = MicromapList::of(vec![MICROMAP_2]);
                    w.query_type = QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT;
                })
            },
        ),
        case(
            host_write::pMicromaps_parameter,
            || {
                host_write_with(|w| {
                    w.micromaps = MicromapList {
                        count: 1,
                        handles: None,
                    }
                })
            },
            ok_host_write,
        ),
        case(
            host_write::queryType_07503,
            || host_write_with(|w| w.query_type = QUERY_TYPE_OCCLUSION),
            ok_host_write,
        ),
        case(
            host_write::queryType_10071,
            || {
                host_write_with(|w| {
                    w.stride = 12;
                    w.data_size = 12;
                })
            },
            || {
                host_write_with(|w| {
                    w.stride = 16;
                    w.data_size = 16;
                })
            },
        ),
        case(
            host_write::queryType_10072,
            || host_write_with(|w| w.data = HOST_DATA + 4),
            ok_host_write,
        ),
        case(
            host_write::queryType_parameter,
            || host_write_with(|w| w.query_type = 3),
            ok_host_write,
        ),
    ]
}

fn query_cases() -> Vec<Case> {
    vec![
        case(
            build_sizes::buildType_parameter,
            || {
                build_sizes_on(
                    world(),
                    DEVICE,
                    3,
                    Some(&device_build()),
                    Some(&Default::default()),
                )
            },
            ok_build_sizes,
        ),
        case(
            build_sizes::device_07440,
            || {
                build_sizes_on(
                    world_on(multi_device(false)),
                    DEVICE,
                    1,
                    Some(&device_build()),
                    Some(&Default::default()),
                )
            },
            || {
                build_sizes_on(
                    world_on(multi_device(true)),
                    DEVICE,
                    1,
                    Some(&device_build()),
                    Some(&Default::default()),
                )
            },
        ),
        case(
            build_sizes::device_parameter,
            || {
                build_sizes_on(
                    world(),
                    0,
                    1,
                    Some(&device_build()),
                    Some(&Default::default()),
                )
            },
            ok_build_sizes,
        ),
        case(
            build_sizes::micromap_11618,
            || {
                build_sizes_on(
                    without_micromap_feature(),
                    DEVICE,
                    1,
                    Some(&device_build()),
                    Some(&Default::default()),
                )
            },
            ok_build_sizes,
        ),
        case(
            build_sizes::pBuildInfo_parameter,
            || build_sizes_on(world(), DEVICE, 1, None, Some(&Default::default())),
            ok_build_sizes,
        ),
        case(
            build_sizes::pSizeInfo_parameter,
            || build_sizes_on(world(), DEVICE, 1, Some(&device_build()), None),
            ok_build_sizes,
        ),
        case(
            sizes_info::pNext_pNext,
            || build_sizes_with(|s| s.next = vec![STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT]),
            ok_build_sizes,
        ),
        case(
            sizes_info::sType_sType,
            || build_sizes_with(|s| s.s_type = STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT),
            ok_build_sizes,
        ),
        case(
            compatibility::device_parameter,
            || {
                world().get_device_micromap_compatibility(
                    0,
                    Some(&MicromapVersionInfo::default()),
                    true,
                )
            },
            ok_compatibility,
        ),
        case(
            compatibility::micromap_11666,
            || {
                without_micromap_feature().get_device_micromap_compatibility(
                    DEVICE,
                    Some(&MicromapVersionInfo::default()),
                    true,
                )
            },
            ok_compatibility,
        ),
        case(
            compatibility::pCompatibility_parameter,
            || {
                world().get_device_micromap_compatibility(
                    DEVICE,
                    Some(&MicromapVersionInfo::default()),
                    false,
                )
            },
            ok_compatibility,
        ),
        case(
            compatibility::pVersionInfo_parameter,
            || world().get_device_micromap_compatibility(DEVICE, None, true),
            ok_compatibility,
        ),
        case(
            version_info::pNext_pNext,
            || compatibility_with(|v| v.next = vec![STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT]),
            ok_compatibility,
        ),
        case(
            version_info::pVersionData_parameter,
            || compatibility_with(|v| v.version_data = Some(vec![0; UUID_SIZE])),
            || compatibility_with(|v| v.version_data = Some(vec![7; 2 * UUID_SIZE])),
        ),
        case(
            version_info::sType_sType,
            || compatibility_with(|v| v.s_type = STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT),
            ok_compatibility,
        ),
        case(
            begin_query::queryType_08972,
            || world().cmd_begin_query(&command_buffer(), POOL_COMPACTED),
            || world().cmd_begin_query(&command_buffer(), POOL_OCCLUSION),
        ),
        case(
            begin_query_indexed::queryType_08972,
            || world().cmd_begin_query_indexed(&command_buffer(), POOL_SERIALIZATION),
            || world().cmd_begin_query_indexed(&command_buffer(), POOL_OCCLUSION),
        ),
    ]
}

#[test]
fn created_micromaps_are_tracked_until_destroyed() {
    let mut v = world();
    let info = MicromapCreateInfo {
        buffer: STORAGE,
        offset: 0x2000,
        size: 0x300,
        ..Default::default()
    };
    let allocator = AllocationCallbacks::default();
    assert!(v
        .create_micromap(DEVICE, Some(&info), Some(&allocator), Some(NEW_MICROMAP))
        .is_empty());
    let created = v.state().micromaps.get(&NEW_MICROMAP).cloned();
    assert_eq!(
        created,
        Some(Micromap {
            buffer: STORAGE,
            offset: 0x2000,
            size: 0x300,
            ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
            create_flags: 0,
            device_address: STORAGE_ADDRESS + 0x2000,
            allocator: true,
            built: None,
        })
    );
    // A build sees the new micromap; destroying it with the callbacks it was
    // created with is clean and forgets it.
    let build = MicromapBuildInfo {
        dst_micromap: NEW_MICROMAP,
        ..device_build()
    };
    assert!(!v
        .cmd_build_micromaps(&command_buffer(), &[build])
        .has_errors());
    assert!(v
        .destroy_micromap(DEVICE, NEW_MICROMAP, Some(&allocator))
        .is_empty());
    assert!(!v.state().micromaps.contains_key(&NEW_MICROMAP));
    assert!(v
        .cmd_copy_micromap(
            &command_buffer(),
            Some(&CopyMicromapInfo {
                src: NEW_MICROMAP,
                dst: MICROMAP,
                ..Default::default()
            })
        )
        .contains(copy_info::src_parameter));
}

#[test]
fn a_known_device_handle_must_match() {
    let mut d = device();
    d.handle = DEVICE;
    let mut v = world_on(d);
    assert!(v
        .destroy_micromap(DEVICE + 1, 0, None)
        .contains(destroy::device_parameter));
    assert!(v.destroy_micromap(DEVICE, 0, None).is_empty());
}

// Provenance of serialized micromaps (07547, 07550)

/// `world` after serializing `serialized` on the device to INPUT_ADDRESS
/// (`host`: on the host to HOST_DATA), then deserializing from there
/// into `into`.
fn serialize_then_deserialize(
    mut v: Validator,
    host: bool,
    serialized: Handle,
    into: Handle,
) -> Report {
    let at = if host { HOST_DATA } else { INPUT_ADDRESS };
    let to = CopyMicromapToMemoryInfo {
        src: serialized,
        ..to_memory_info(at)
    };
    let from = CopyMemoryToMicromapInfo {
        dst: into,
        ..from_memory_info(at)
    };
    if host {
        let report = v.copy_micromap_to_memory(DEVICE, 0, Some(&to));
        assert!(!report.has_errors(), "{report}");
        v.copy_memory_to_micromap(DEVICE, 0, Some(&from))
    } else {
        let report = v.cmd_copy_micromap_to_memory(&command_buffer(), Some(&to));
        assert!(!report.has_errors(), "{report}");
        v.cmd_copy_memory_to_micromap(&command_buffer(), Some(&from))
    }
}

/// [`world`] where MICROMAP was created twice as large as MICROMAP_2.
fn world_with_larger_micromap() -> Validator {
    let mut v = world();
    if let Some(m) = v.state_mut().micromaps.get_mut(&MICROMAP) {
        m.size = 0x2000;
    }
    v
}

/// Deserializes into MICROMAP from the memory of MICROMAP_2, which a copy
/// recorded just before wrote (`overwritten`), or from bytes serialized
/// from MICROMAP_2 there after that copy.
fn deserialize_from_micromap_memory(overwritten: bool) -> Report {
    let mut v = world();
    let clone = CopyMicromapInfo {
        src: MICROMAP,
        dst: MICROMAP_2,
        mode: COPY_MICROMAP_MODE_CLONE_EXT,
        ..Default::default()
    };
    let report = v.cmd_copy_micromap(&command_buffer(), Some(&clone));
    assert!(!report.has_errors(), "{report}");
    let at = STORAGE_ADDRESS + 0x8000;
    if !overwritten {
        let to = CopyMicromapToMemoryInfo {
            src: MICROMAP_2,
            ..to_memory_info(at)
        };
        v.cmd_copy_micromap_to_memory(&command_buffer(), Some(&to));
    }
    v.cmd_copy_memory_to_micromap(&command_buffer(), Some(&from_memory_info(at)))
}

fn provenance_cases() -> Vec<Case> {
    vec![
        case(
            from_memory_info::src_07547,
            || deserialize_from_micromap_memory(true),
            || deserialize_from_micromap_memory(false),
        ),
        case(
            from_memory_info::dst_07550,
            || {
                serialize_then_deserialize(
                    world_with_larger_micromap(),
                    false,
                    MICROMAP,
                    MICROMAP_2,
                )
            },
            || serialize_then_deserialize(world_with_larger_micromap(), true, MICROMAP_2, MICROMAP),
        ),
    ]
}

#[test]
fn serialized_micromaps_are_followed_on_the_device_and_the_host() {
    for host in [false, true] {
        let report = serialize_then_deserialize(world(), host, MICROMAP, MICROMAP_2);
        assert!(
            report.checked.contains(from_memory_info::src_07547),
            "{report}"
        );
        assert!(
            report.checked.contains(from_memory_info::dst_07550),
            "{report}"
        );
        assert!(report.findings.is_empty(), "{report}");
        let larger =
            serialize_then_deserialize(world_with_larger_micromap(), host, MICROMAP, MICROMAP_2);
        assert_eq!(
            larger.ids(),
            ["VUID-VkCopyMemoryToMicromapInfoEXT-dst-07550"],
            "{larger}"
        );
    }
}

#[test]
fn bytes_no_serialization_wrote_are_not_checked_and_say_why() {
    let report = world()
        .cmd_copy_memory_to_micromap(&command_buffer(), Some(&from_memory_info(INPUT_ADDRESS)));
    assert!(!report.has_errors(), "{report}");
    let finding = report
        .not_checked()
        .next()
        .expect("a not-checked information");
    assert_eq!(
        finding.rule.as_str(),
        "OMMCHECK-not-checked-serialization-not-seen"
    );
    assert!(
        finding.message.contains("no serialization the checker saw"),
        "{}",
        finding.message
    );
}

/// Serialized micromap bytes: a header whose serialized size is `len`, then `fill`.
fn serialized_bytes(len: usize, fill: u8) -> Vec<u8> {
    let mut bytes = vec![fill; len];
    bytes[32..40].copy_from_slice(&(len as u64).to_le_bytes());
    bytes[48..56].fill(0);
    bytes
}

#[test]
fn bytes_linked_by_their_fingerprint_are_followed_wherever_they_are_read() {
    use ommcheck::state::HostRange;
    const ELSEWHERE: u64 = 0x7300_0000;
    let mut v = world_with_larger_micromap();
    let to = to_memory_info(HOST_DATA);
    v.copy_micromap_to_memory(DEVICE, 0, Some(&to));
    let bytes = serialized_bytes(256, 7);
    assert!(v.serialized_bytes(true, HOST_DATA, &bytes));
    assert!(
        !v.serialized_bytes(true, ELSEWHERE, &bytes),
        "nothing serialized there"
    );
    assert!(
        !v.serialized_bytes(true, HOST_DATA, &bytes[..100]),
        "shorter than its size"
    );
    // The same bytes elsewhere (written back from a file): linked to MICROMAP.
    v.state_mut().host_memory.push(HostRange {
        address: ELSEWHERE,
        bytes: ommcheck::Bytes::from(bytes.clone()),
    });
    let from = CopyMemoryToMicromapInfo {
        dst: MICROMAP_2,
        ..from_memory_info(ELSEWHERE)
    };
    let report = v.copy_memory_to_micromap(DEVICE, 0, Some(&from));
    assert_eq!(
        report.ids(),
        ["VUID-VkCopyMemoryToMicromapInfoEXT-dst-07550"],
        "{report}"
    );
    assert!(
        report.findings[0].message.contains("fingerprint"),
        "{report}"
    );
    // Other bytes there: not known.
    let other = serialized_bytes(256, 8);
    v.state_mut().host_memory.push(HostRange {
        address: ELSEWHERE + 0x1000,
        bytes: ommcheck::Bytes::from(other),
    });
    let from = CopyMemoryToMicromapInfo {
        dst: MICROMAP_2,
        ..from_memory_info(ELSEWHERE + 0x1000)
    };
    let report = v.copy_memory_to_micromap(DEVICE, 0, Some(&from));
    assert!(!report.has_errors(), "{report}");
    assert_eq!(report.not_checked().count(), 1, "{report}");
}

#[test]
fn an_acceleration_structure_serialization_is_no_micromap_data() {
    use ommcheck::model::accel::{
        CopyAccelerationStructureToMemoryInfo, ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
        COPY_MODE_SERIALIZE,
    };
    use ommcheck::state::AccelerationStructure;
    const BLAS: Handle = 0xa5;
    let mut v = world();
    v.state_mut().acceleration_structures.insert(
        BLAS,
        AccelerationStructure {
            ty: ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
            buffer: STORAGE,
            offset: 0xc000,
            size: 0x1000,
            ..Default::default()
        },
    );
    let to = CopyAccelerationStructureToMemoryInfo {
        src: BLAS,
        dst: HOST_DATA,
        mode: COPY_MODE_SERIALIZE,
        ..Default::default()
    };
    assert!(!v.copy_acceleration_structure_to_memory(&to).has_errors());
    let report = v.copy_memory_to_micromap(DEVICE, 0, Some(&from_memory_info(HOST_DATA)));
    assert_eq!(
        report.ids(),
        ["VUID-VkCopyMemoryToMicromapInfoEXT-src-07547"],
        "{report}"
    );
    assert!(
        report.findings[0]
            .message
            .contains("vkCopyAccelerationStructureToMemoryKHR"),
        "{report}"
    );
}
