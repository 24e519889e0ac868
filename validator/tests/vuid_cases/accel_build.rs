//! Cases for the `accel_build` checks: KHR opacity micromaps as acceleration
//! structures, their build commands, size queries, creation and copies.

use ommcheck::model::accel::*;
use ommcheck::model::{MicromapTriangle, MicromapUsage, UsageCounts};
use ommcheck::state::HostRange;
use ommcheck::vuids::vuid::{
    vkCmdBuildAccelerationStructuresIndirectKHR as indirect,
    vkCmdBuildAccelerationStructuresKHR as cmd,
    vkCmdCopyAccelerationStructureToMemoryKHR as cmd_to_memory,
    vkCmdCopyMemoryToAccelerationStructureKHR as cmd_from_memory,
    vkGetAccelerationStructureBuildSizesKHR as sizes,
    VkAccelerationStructureBuildGeometryInfoKHR as info,
    VkAccelerationStructureCreateInfo2KHR as create_info2,
    VkAccelerationStructureCreateInfoKHR as create_info,
    VkAccelerationStructureGeometryKHR as geometry,
    VkAccelerationStructureGeometryMicromapDataKHR as micromap,
    VkCopyMemoryToAccelerationStructureInfoKHR as from_memory_info,
    VkMicromapUsageKHR as usage_vuid,
};
use ommcheck::{Device, Report, Tier, Validator};

use crate::fixtures::*;
use crate::{case, Case};

/// An acceleration structure created as an opacity micromap (with
/// `vkCreateAccelerationStructure2KHR`), and a bottom-level one.
const OMM_AS: u64 = 0xa5;
const OMM_AS_ADDRESS: u64 = STORAGE_ADDRESS + 0x2000;
const BLAS: u64 = 0xb1;

/// The fixtures' world plus [`OMM_AS`] and [`BLAS`], with `triangles` in the
/// input buffer. The creations are setup: on a device without the micromap
/// feature they report 11609, which is not what the cases ask about.
fn world_with(device: Device, triangles: &[MicromapTriangle]) -> Validator {
    let mut v = validator_with(device, triangles);
    v.create_acceleration_structure2(
        &AccelerationStructureCreateInfo2 {
            address: OMM_AS_ADDRESS,
            size: 0x1000,
            ..Default::default()
        },
        OMM_AS,
    );
    v.create_acceleration_structure(
        &AccelerationStructureCreateInfo {
            buffer: STORAGE,
            offset: 0x4000,
            size: 0x1000,
            ..Default::default()
        },
        BLAS,
    );
    v
}

/// The world with an input buffer holding only `entries`, each at its byte offset.
fn world_with_entries(entries: &[(usize, MicromapTriangle)]) -> Validator {
    let mut v = world_with(device(), &[]);
    let mut bytes = vec![0u8; INPUT_SIZE as usize];
    for (at, entry) in entries {
        bytes[*at..*at + 8].copy_from_slice(&entry.to_bytes());
    }
    if let Some(mut input) = v.state_mut().buffers.get_mut(&INPUT) {
        input.contents = Some(bytes.into());
    }
    v
}

fn world() -> Validator {
    world_with(device(), &two_triangles())
}

/// A device with every feature but those `disable` turns off.
fn device_without(disable: impl FnOnce(&mut Device)) -> Device {
    let mut d = device();
    disable(&mut d);
    d
}

fn usage(count: u32, level: u32, format: u32) -> MicromapUsage {
    MicromapUsage {
        count,
        subdivision_level: level,
        format,
    }
}

fn triangle(data_offset: u32, level: u16, format: u16) -> MicromapTriangle {
    MicromapTriangle {
        data_offset,
        subdivision_level: level,
        format,
    }
}

/// The micromap data of [`two_triangles`] in the input buffer.
fn micromap_data() -> GeometryMicromapData {
    GeometryMicromapData {
        usage_counts: two_triangle_usage(),
        data: INPUT_ADDRESS,
        triangle_array: INPUT_ADDRESS + TRIANGLES_OFFSET,
        triangle_array_stride: 8,
        ..Default::default()
    }
}

fn micromap_geometry(data: GeometryMicromapData) -> Geometry {
    Geometry {
        geometry_type: GEOMETRY_TYPE_MICROMAP,
        geometry: GeometryData::None,
        micromap: Some(data),
        ..Default::default()
    }
}

/// A valid opacity-micromap build of [`micromap_data`] into [`OMM_AS`].
fn micromap_build() -> BuildGeometryInfo {
    BuildGeometryInfo {
        dst_acceleration_structure: OMM_AS,
        scratch_data: SCRATCH_ADDRESS,
        ..BuildGeometryInfo::with_geometries(
            ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            vec![micromap_geometry(micromap_data())],
        )
    }
}

/// [`micromap_build`] with its micromap data changed by `change`.
fn micromap_build_with(change: impl FnOnce(&mut GeometryMicromapData)) -> BuildGeometryInfo {
    let mut data = micromap_data();
    change(&mut data);
    BuildGeometryInfo {
        geometries: Some(vec![micromap_geometry(data)]),
        ..micromap_build()
    }
}

/// [`micromap_build`] with the LOSSY flag.
fn lossy_build() -> BuildGeometryInfo {
    BuildGeometryInfo {
        flags: BUILD_MICROMAP_LOSSY,
        ..micromap_build()
    }
}

/// A valid bottom-level build of one AABB geometry into [`BLAS`].
fn blas_build() -> BuildGeometryInfo {
    let aabbs = Geometry {
        geometry_type: GEOMETRY_TYPE_AABBS,
        geometry: GeometryData::Aabbs(AabbsData {
            data: INPUT_ADDRESS,
            stride: 24,
            ..Default::default()
        }),
        ..Default::default()
    };
    BuildGeometryInfo {
        dst_acceleration_structure: BLAS,
        scratch_data: SCRATCH_ADDRESS,
        ..BuildGeometryInfo::with_geometries(ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, vec![aabbs])
    }
}

fn one_range() -> Vec<Option<Vec<BuildRangeInfo>>> {
    vec![Some(vec![BuildRangeInfo {
        primitive_count: 1,
        ..Default::default()
    }])]
}

fn cmd_on(v: &mut Validator, build: BuildGeometryInfo) -> Report {
    let ranges = if build.ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
        vec![None]
    } else {
        one_range()
    };
    v.cmd_build_acceleration_structures(&command_buffer(), &[build], &ranges)
}

fn cmd_build(build: BuildGeometryInfo) -> Report {
    cmd_on(&mut world(), build)
}

fn ok_cmd() -> Report {
    cmd_build(micromap_build())
}

fn ok_lossy() -> Report {
    cmd_build(lossy_build())
}

fn ok_blas() -> Report {
    cmd_build(blas_build())
}

fn blas_on(device: Device, flags: u32) -> Report {
    cmd_on(
        &mut world_with(device, &two_triangles()),
        BuildGeometryInfo {
            flags,
            ..blas_build()
        },
    )
}

/// A build whose triangle array holds `triangles` and whose usage counts say `usages`.
fn cmd_with_triangles(
    triangles: &[MicromapTriangle],
    usages: Vec<MicromapUsage>,
    flags: u32,
) -> Report {
    let build = BuildGeometryInfo {
        flags,
        ..micromap_build_with(|d| d.usage_counts = UsageCounts::array(usages))
    };
    cmd_on(&mut world_with(device(), triangles), build)
}

fn sizes_of(build_type: i32, build: &BuildGeometryInfo, counts: Option<&[u32]>) -> Report {
    world().get_acceleration_structure_build_sizes(build_type, build, counts)
}

fn create2_on(device: Device, create_flags: u32) -> Report {
    world_with(device, &two_triangles()).create_acceleration_structure2(
        &AccelerationStructureCreateInfo2 {
            create_flags,
            address: STORAGE_ADDRESS + 0x3000,
            size: 0x100,
            ..Default::default()
        },
        0xa6,
    )
}

fn serialize_to(dst: u64) -> Report {
    let mut v = world();
    let built = cmd_on(&mut v, micromap_build());
    assert!(!built.has_errors(), "{built}");
    v.cmd_copy_acceleration_structure_to_memory(
        &command_buffer(),
        &CopyAccelerationStructureToMemoryInfo {
            src: OMM_AS,
            dst,
            ..Default::default()
        },
    )
}

fn deserialize_from(src: u64) -> Report {
    world().cmd_copy_memory_to_acceleration_structure(
        &command_buffer(),
        &CopyMemoryToAccelerationStructureInfo {
            src,
            dst: OMM_AS,
            ..Default::default()
        },
    )
}

/// Where the host deserializations' serialized headers lie.
const HOST_HEADER: u64 = 0x7200_0000;

/// A serialized bottom-level header with one block of `block_type` holding
/// `addresses` (the layout of vkCmdCopyAccelerationStructureToMemoryKHR).
fn serialized_header(block_type: u32, addresses: &[u64]) -> Vec<u8> {
    let mut bytes = vec![0u8; 72 + 8 * addresses.len()];
    let size = bytes.len() as u64;
    bytes[32..40].copy_from_slice(&size.to_le_bytes());
    bytes[48..56].copy_from_slice(&0xFFFF_FFFF_0000_0001u64.to_le_bytes());
    bytes[56..60].copy_from_slice(&block_type.to_le_bytes());
    bytes[64..72].copy_from_slice(&(addresses.len() as u64).to_le_bytes());
    for (k, a) in addresses.iter().enumerate() {
        bytes[72 + 8 * k..80 + 8 * k].copy_from_slice(&a.to_le_bytes());
    }
    bytes
}

/// A header naming [`OMM_AS`]'s buffer (the fixtures' storage) and a NULL.
fn valid_header() -> Vec<u8> {
    serialized_header(0, &[STORAGE_ADDRESS, 0])
}

/// `vkCopyMemoryToAccelerationStructureKHR` into [`BLAS`] from `header` in
/// host memory, on `device`.
fn host_deserialize(device: Device, header: Vec<u8>) -> Report {
    let mut v = world_with(device, &two_triangles());
    v.state_mut().host_memory.push(HostRange {
        address: HOST_HEADER,
        bytes: header.into(),
    });
    v.copy_memory_to_acceleration_structure(&CopyMemoryToAccelerationStructureInfo {
        src: HOST_HEADER,
        dst: BLAS,
        ..Default::default()
    })
}

/// `vkCmdCopyMemoryToAccelerationStructureKHR` into [`BLAS`] from `header`
/// at the start of the input buffer.
fn device_deserialize(header: Vec<u8>) -> Report {
    device_deserialize_in(world(), header)
}

/// The same in `v`.
fn device_deserialize_in(mut v: Validator, header: Vec<u8>) -> Report {
    let mut bytes = vec![0u8; INPUT_SIZE as usize];
    bytes[..header.len()].copy_from_slice(&header);
    if let Some(mut input) = v.state_mut().buffers.get_mut(&INPUT) {
        input.contents = Some(bytes.into());
    }
    v.cmd_copy_memory_to_acceleration_structure(
        &command_buffer(),
        &CopyMemoryToAccelerationStructureInfo {
            src: INPUT_ADDRESS,
            dst: BLAS,
            ..Default::default()
        },
    )
}

fn serialized_header_cases() -> Vec<Case> {
    vec![
        case(
            from_memory_info::src_11583,
            || host_deserialize(device(), serialized_header(7, &[])),
            || host_deserialize(device(), valid_header()),
        ),
        case(
            from_memory_info::dst_11584,
            || {
                host_deserialize(
                    device_without(|d| d.features.micromap_khr = false),
                    valid_header(),
                )
            },
            || host_deserialize(device(), valid_header()),
        ),
        case(
            from_memory_info::dst_11585,
            || device_deserialize(serialized_header(0, &[STORAGE_ADDRESS + 0x40])),
            || device_deserialize(valid_header()),
        ),
        // The address of the buffer of a micromap of another VkDevice: the
        // device executing the command has no micromap there.
        case(
            from_memory_info::dst_11585,
            || {
                let mut v = world();
                v.state_mut().other_device_objects.insert(OMM_AS);
                device_deserialize_in(v, valid_header())
            },
            || device_deserialize(valid_header()),
        ),
    ]
}

/// A device with neither the KHR nor the EXT micromap feature.
fn no_micromap_features() -> Device {
    device_without(|d| {
        d.features.micromap_ext = false;
        d.features.micromap_khr = false;
    })
}

/// A device with the KHR micromap feature but not the EXT one.
fn khr_only() -> Device {
    device_without(|d| d.features.micromap_ext = false)
}

fn flag_cases() -> Vec<Case> {
    vec![
        case(
            info::flags_11558,
            || {
                blas_on(
                    device(),
                    BUILD_ALLOW_OPACITY_MICROMAP_UPDATE
                        | BUILD_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT,
                )
            },
            || blas_on(device(), BUILD_ALLOW_OPACITY_MICROMAP_UPDATE),
        ),
        case(
            info::flags_11562,
            || {
                cmd_build(BuildGeometryInfo {
                    flags: BUILD_ALLOW_DISABLE_OPACITY_MICROMAPS,
                    ..micromap_build()
                })
            },
            || {
                cmd_build(BuildGeometryInfo {
                    flags: BUILD_ALLOW_COMPACTION | BUILD_PREFER_FAST_TRACE,
                    ..micromap_build()
                })
            },
        ),
        case(
            info::flags_11709,
            || blas_on(khr_only(), BUILD_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT),
            || blas_on(khr_only(), 0),
        ),
        case(
            info::flags_11710,
            || blas_on(no_micromap_features(), BUILD_ALLOW_OPACITY_MICROMAP_UPDATE),
            || blas_on(khr_only(), BUILD_ALLOW_OPACITY_MICROMAP_UPDATE),
        ),
        case(
            info::flags_11711,
            || {
                blas_on(
                    no_micromap_features(),
                    BUILD_ALLOW_DISABLE_OPACITY_MICROMAPS,
                )
            },
            || blas_on(khr_only(), BUILD_ALLOW_DISABLE_OPACITY_MICROMAPS),
        ),
        case(
            info::type_11563,
            || blas_on(device(), BUILD_MICROMAP_LOSSY),
            ok_blas,
        ),
        case(
            info::micromap_11559,
            || {
                let d = device_without(|d| d.features.micromap_khr = false);
                cmd_on(&mut world_with(d, &two_triangles()), micromap_build())
            },
            ok_cmd,
        ),
    ]
}

fn structure_cases() -> Vec<Case> {
    vec![
        case(
            info::geometryCount_11560,
            || {
                let g = micromap_geometry(micromap_data());
                cmd_build(BuildGeometryInfo {
                    geometry_count: 2,
                    geometries: Some(vec![g.clone(), g]),
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::geometryType_11561,
            || {
                cmd_build(BuildGeometryInfo {
                    geometries: blas_build().geometries,
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::geometryType_11707,
            || {
                let mut v = world();
                let build = BuildGeometryInfo {
                    geometries: micromap_build().geometries,
                    ..blas_build()
                };
                v.cmd_build_acceleration_structures(&command_buffer(), &[build], &[None])
            },
            ok_blas,
        ),
        case(
            geometry::flags_11569,
            || {
                let mut g = micromap_geometry(micromap_data());
                g.flags = 1; // VK_GEOMETRY_OPAQUE_BIT_KHR
                cmd_build(BuildGeometryInfo {
                    geometries: Some(vec![g]),
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            geometry::micromap_11568,
            || {
                let mut g = micromap_geometry(micromap_data());
                g.next.push(STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA);
                cmd_build(BuildGeometryInfo {
                    geometries: Some(vec![g]),
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            geometry::pNext_pNext,
            || {
                let mut g = micromap_geometry(micromap_data());
                g.next.push(STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR);
                cmd_build(BuildGeometryInfo {
                    geometries: Some(vec![g]),
                    ..micromap_build()
                })
            },
            || {
                let mut build = blas_build();
                if let Some(g) = build.geometries.as_mut().and_then(|g| g.first_mut()) {
                    g.next.push(STRUCTURE_TYPE_GEOMETRY_SPHERES_DATA_NV);
                }
                cmd_build(build)
            },
        ),
        case(
            micromap::sType_sType,
            || cmd_build(micromap_build_with(|d| d.s_type = 0)),
            ok_cmd,
        ),
        case(
            micromap::triangleArrayStride_11646,
            || cmd_build(micromap_build_with(|d| d.triangle_array_stride = 4)),
            ok_cmd,
        ),
        case(
            micromap::triangleArrayStride_11647,
            || cmd_build(micromap_build_with(|d| d.triangle_array_stride = 10)),
            || {
                // Stride 12: the second entry moves to byte 12 of the array.
                let at = TRIANGLES_OFFSET as usize;
                let mut v =
                    world_with_entries(&[(at, triangle(0, 1, 2)), (at + 12, triangle(1, 1, 2))]);
                cmd_on(
                    &mut v,
                    micromap_build_with(|d| d.triangle_array_stride = 12),
                )
            },
        ),
    ]
}

fn usage_count_cases() -> Vec<Case> {
    vec![
        case(
            micromap::pUsageCounts_11642,
            || {
                cmd_build(micromap_build_with(|d| {
                    d.usage_counts.pointers = Some(vec![Some(usage(2, 1, 2))]);
                }))
            },
            || {
                cmd_build(micromap_build_with(|d| {
                    d.usage_counts = UsageCounts::pointers(vec![usage(2, 1, 2)]);
                }))
            },
        ),
        case(
            micromap::pUsageCounts_parameter,
            || cmd_build(micromap_build_with(|d| d.usage_counts.count = 3)),
            ok_cmd,
        ),
        case(
            micromap::ppUsageCounts_parameter,
            || {
                cmd_build(micromap_build_with(|d| {
                    d.usage_counts = UsageCounts {
                        count: 2,
                        array: None,
                        pointers: Some(vec![Some(usage(2, 1, 2)), None]),
                    };
                }))
            },
            || {
                cmd_build(micromap_build_with(|d| {
                    d.usage_counts = UsageCounts::pointers(vec![usage(1, 1, 2), usage(1, 1, 2)]);
                }))
            },
        ),
        case(
            micromap::count_11643,
            || {
                cmd_build(micromap_build_with(|d| {
                    d.usage_counts = UsageCounts::array(vec![usage((1 << 27) + 1, 1, 2)]);
                }))
            },
            ok_cmd,
        ),
        case(
            usage_vuid::format_parameter,
            || cmd_with_triangles(&two_triangles(), vec![usage(2, 1, 3)], 0),
            ok_cmd,
        ),
        case(
            micromap::subdivisionLevel_11645,
            || {
                let triangles = [triangle(0, 4, 1), triangle(32, 4, 1)];
                cmd_with_triangles(&triangles, vec![usage(2, 4, 1)], 0)
            },
            || {
                let triangles = [triangle(0, 3, 1), triangle(8, 3, 1)];
                cmd_with_triangles(&triangles, vec![usage(2, 3, 1)], 0)
            },
        ),
        case(
            info::subdivisionLevel_11564,
            || cmd_with_triangles(&two_triangles(), vec![usage(2, 4, 2)], 0),
            ok_cmd,
        ),
        case(
            info::subdivisionLevel_11565,
            || cmd_with_triangles(&two_triangles(), vec![usage(2, 4, 2)], BUILD_MICROMAP_LOSSY),
            ok_lossy,
        ),
        case(
            info::format_11712,
            || cmd_with_triangles(&two_triangles(), vec![usage(2, 1, 1)], BUILD_MICROMAP_LOSSY),
            ok_lossy,
        ),
    ]
}

fn triangle_array_cases() -> Vec<Case> {
    vec![
        case(
            info::format_11713,
            || {
                let triangles = [triangle(0, 1, 2), triangle(1, 1, 1)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], BUILD_MICROMAP_LOSSY)
            },
            ok_lossy,
        ),
        case(
            info::subdivisionLevel_11566,
            || {
                let triangles = [triangle(0, 1, 2), triangle(1, 4, 2)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], 0)
            },
            ok_cmd,
        ),
        case(
            info::subdivisionLevel_11567,
            || {
                let triangles = [triangle(0, 1, 2), triangle(1, 4, 2)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], BUILD_MICROMAP_LOSSY)
            },
            ok_lossy,
        ),
        case(
            cmd::micromap_11553,
            || {
                let triangles = [triangle(0, 1, 2), triangle(INPUT_SIZE as u32, 1, 2)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], 0)
            },
            || {
                let triangles = [triangle(0, 1, 2), triangle(INPUT_SIZE as u32 - 1, 1, 2)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], 0)
            },
        ),
        case(
            cmd::micromap_11554,
            || cmd_build(micromap_build_with(|d| d.triangle_array_stride = 0x8000)),
            || {
                // The same stride fits when the array starts at the buffer's start.
                let mut v =
                    world_with_entries(&[(0, triangle(0, 1, 2)), (0x8000, triangle(1, 1, 2))]);
                cmd_on(
                    &mut v,
                    micromap_build_with(|d| {
                        d.triangle_array = INPUT_ADDRESS;
                        d.triangle_array_stride = 0x8000;
                    }),
                )
            },
        ),
        case(
            cmd::micromap_11555,
            || {
                let triangles = [triangle(0, 1, 2), triangle(1, 1, 3)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], 0)
            },
            ok_cmd,
        ),
        case(
            cmd::micromap_11556,
            || {
                let triangles = [triangle(0, 1, 2), triangle(1, 4, 1)];
                cmd_with_triangles(&triangles, vec![usage(2, 1, 2)], 0)
            },
            ok_cmd,
        ),
    ]
}

fn command_cases() -> Vec<Case> {
    vec![
        case(
            cmd::dstAccelerationStructure_11547,
            || {
                cmd_build(BuildGeometryInfo {
                    dst_acceleration_structure: BLAS,
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::mode_11545,
            || {
                cmd_build(BuildGeometryInfo {
                    mode: BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::srcAccelerationStructure_11546,
            || {
                cmd_build(BuildGeometryInfo {
                    src_acceleration_structure: OMM_AS,
                    ..micromap_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::ppBuildRangeInfos_11543,
            || {
                world().cmd_build_acceleration_structures(
                    &command_buffer(),
                    &[blas_build()],
                    &[None],
                )
            },
            ok_blas,
        ),
        case(
            cmd::ppBuildRangeInfos_11544,
            || {
                world().cmd_build_acceleration_structures(
                    &command_buffer(),
                    &[micromap_build()],
                    &[Some(Vec::new())],
                )
            },
            ok_cmd,
        ),
        case(
            cmd::micromap_11550,
            || cmd_build(micromap_build_with(|d| d.data = 0)),
            ok_cmd,
        ),
        case(
            cmd::micromap_11551,
            // The scratch buffer lacks the build-input usage.
            || cmd_build(micromap_build_with(|d| d.data = SCRATCH_ADDRESS)),
            ok_cmd,
        ),
        case(
            cmd::micromap_11552,
            || cmd_build(micromap_build_with(|d| d.data = INPUT_ADDRESS + 64)),
            || cmd_build(micromap_build_with(|d| d.data = INPUT_ADDRESS + 128)),
        ),
        case(
            indirect::type_11557,
            || {
                world().cmd_build_acceleration_structures_indirect(
                    &command_buffer(),
                    &[micromap_build()],
                    &[INPUT_ADDRESS],
                    &[16],
                    &[None],
                )
            },
            || {
                world().cmd_build_acceleration_structures_indirect(
                    &command_buffer(),
                    &[blas_build()],
                    &[INPUT_ADDRESS],
                    &[16],
                    &[Some(vec![1])],
                )
            },
        ),
    ]
}

fn object_cases() -> Vec<Case> {
    vec![
        case(
            sizes::buildType_11614,
            || sizes_of(BUILD_TYPE_HOST, &micromap_build(), None),
            || sizes_of(BUILD_TYPE_DEVICE, &micromap_build(), None),
        ),
        case(
            sizes::pMaxPrimitiveCounts_11612,
            || sizes_of(BUILD_TYPE_DEVICE, &blas_build(), None),
            || sizes_of(BUILD_TYPE_DEVICE, &blas_build(), Some(&[1])),
        ),
        case(
            sizes::pMaxPrimitiveCounts_11613,
            || sizes_of(BUILD_TYPE_DEVICE, &micromap_build(), Some(&[2])),
            || sizes_of(BUILD_TYPE_DEVICE, &micromap_build(), None),
        ),
        case(
            create_info::type_11600,
            || {
                world().create_acceleration_structure(
                    &AccelerationStructureCreateInfo {
                        ty: ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                        buffer: STORAGE,
                        size: 0x100,
                        ..Default::default()
                    },
                    0xa7,
                )
            },
            || {
                world().create_acceleration_structure(
                    &AccelerationStructureCreateInfo {
                        buffer: STORAGE,
                        size: 0x100,
                        ..Default::default()
                    },
                    0xa7,
                )
            },
        ),
        case(
            create_info2::createFlags_11610,
            || create2_on(device(), CREATE_DESCRIPTOR_BUFFER_CAPTURE_REPLAY_BIT_EXT),
            || create2_on(device(), 0),
        ),
        case(
            create_info2::createFlags_11611,
            || create2_on(device(), CREATE_MOTION_BIT_NV),
            || create2_on(device(), 0),
        ),
        case(
            create_info2::micromap_11609,
            || create2_on(device_without(|d| d.features.micromap_khr = false), 0),
            || create2_on(device(), 0),
        ),
        case(
            cmd_to_memory::pInfo_11699,
            || serialize_to(STORAGE_ADDRESS + 0x3040),
            || serialize_to(STORAGE_ADDRESS + 0x3080),
        ),
        case(
            cmd_from_memory::VUID_vkCmdCopyAccelerationStructureToMemoryKHR_pInfo_11700,
            || deserialize_from(INPUT_ADDRESS + 0x40),
            || deserialize_from(INPUT_ADDRESS + 0x80),
        ),
    ]
}

pub fn cases() -> Vec<Case> {
    [
        flag_cases(),
        structure_cases(),
        usage_count_cases(),
        triangle_array_cases(),
        command_cases(),
        object_cases(),
        serialized_header_cases(),
    ]
    .into_iter()
    .flatten()
    .collect()
}

#[test]
fn builds_record_the_micromap_on_its_destination() {
    let mut v = world();
    let report = cmd_on(&mut v, lossy_build());
    assert!(!report.has_errors(), "{report}");
    let built = v.state().acceleration_structures[&OMM_AS].built.clone();
    let built = built.expect("the build is recorded");
    assert_eq!(
        (built.ty, built.flags, built.triangle_count),
        (
            ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            BUILD_MICROMAP_LOSSY,
            2
        )
    );
    assert_eq!(
        v.state().acceleration_structures[&OMM_AS].address_range,
        Some((OMM_AS_ADDRESS, OMM_AS_ADDRESS + 0x1000))
    );
}

#[test]
fn host_builds_read_host_memory_and_report_our_rules() {
    let mut v = world();
    let build = micromap_build_with(|d| {
        d.data = HOST_DATA;
        d.triangle_array = HOST_TRIANGLES;
        d.usage_counts = UsageCounts::array(vec![usage(3, 1, 2)]);
    });
    let report = v.build_acceleration_structures(&[build], &[None]);
    // Three triangles declared, two described in host memory.
    assert!(
        report.contains(&ommcheck::rules::TRIANGLE_ARRAY_RANGE),
        "{report}"
    );
    assert!(!report.contains(cmd::micromap_11554), "{report}");
}

#[test]
fn a_huge_usage_count_reads_only_what_memory_holds() {
    let report = cmd_build(micromap_build_with(|d| {
        d.usage_counts = UsageCounts::array(vec![usage(u32::MAX, 1, 2), usage(u32::MAX, 1, 2)]);
    }));
    assert!(report.contains(micromap::count_11643));
    assert!(report.contains(cmd::micromap_11554));
}

#[test]
fn khr_micromap_data_gets_the_hygiene_information_too() {
    // The hygiene information is computed from the simulate tier up.
    let at = |tier: Tier, triangles: &[MicromapTriangle]| {
        let mut v = world_with(device(), triangles);
        v.set_tier(tier);
        let build =
            micromap_build_with(|d| d.usage_counts = UsageCounts::array(vec![usage(2, 2, 2)]));
        cmd_on(&mut v, build)
    };
    // Two level-2 4-state blocks of zeros at offsets 0 and 4: one copy would do.
    let two_copies = [triangle(0, 2, 2), triangle(4, 2, 2)];
    let twice = at(Tier::Simulate, &two_copies);
    assert!(twice.contains(&ommcheck::rules::DUPLICATE_DATA), "{twice}");
    assert!(!twice.has_errors(), "{twice}");
    let shared = at(Tier::Simulate, &[triangle(0, 2, 2), triangle(0, 2, 2)]);
    assert!(
        !shared.contains(&ommcheck::rules::DUPLICATE_DATA),
        "{shared}"
    );
    // The default tier reads no data block for it.
    let content = at(Tier::Content, &two_copies);
    assert!(content.is_empty(), "{content}");
}

#[test]
fn the_triangle_array_range_is_not_checked_without_buffer_addresses() {
    let report = cmd_on(&mut forget_addresses(world()), micromap_build());
    let finding = unknown_address_skipping(&report, cmd::micromap_11554);
    assert_eq!(finding.location, "pInfos[0].pGeometries[0].pNext<VkAccelerationStructureGeometryMicromapDataKHR>.triangleArray");
    // With the addresses known the rule is checked and nothing is skipped.
    let known = ok_cmd();
    assert!(known.checked.contains(cmd::micromap_11554), "{known}");
    assert_eq!(known.not_checked().count(), 0, "{known}");
}
