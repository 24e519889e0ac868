//! Cases for the `accel_attach` checks: triangle geometry that references a
//! micromap, instance flags, rules across the infos of one build, and NV
//! cluster triangle infos.

use ommcheck::checks::accel_attach::record_original_attachments;
use ommcheck::model::accel::*;
use ommcheck::model::values::*;
use ommcheck::model::{MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts};
use ommcheck::rules;
use ommcheck::state::{AccelerationStructure, BuildRecord, HostRange};
use ommcheck::vuids::khr as khr_values;
use ommcheck::vuids::vuid::{
    vkBuildAccelerationStructuresKHR as host,
    vkCmdBuildAccelerationStructuresIndirectKHR as indirect,
    vkCmdBuildAccelerationStructuresKHR as cmd,
    VkAccelerationStructureGeometryTrianglesDataKHR as triangles_vuid,
    VkAccelerationStructureInstanceKHR as instance_vuid,
    VkAccelerationStructureTrianglesDisplacementMicromapNV as nv,
    VkAccelerationStructureTrianglesOpacityMicromapEXT as ext,
    VkAccelerationStructureTrianglesOpacityMicromapKHR as khr,
    VkClusterAccelerationStructureBuildTriangleClusterInfoNV as cluster,
    VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV as cluster_template,
};
use ommcheck::{Report, RuleId, Severity, Validator};

use crate::fixtures::*;
use crate::{case, Case};

/// The bottom-level structure the builds write.
const BLAS: u64 = 0xa5;
const BLAS_OFFSET: u64 = 0x2000;
/// A second destination, for builds of two infos.
const BLAS_2: u64 = 0xa8;
const BLAS_2_OFFSET: u64 = 0x6000;
/// A structure whose memory overlaps [`KHR_MICROMAP`]'s.
const OVERLAPPING: u64 = 0xa9;
/// A bottom-level structure that is no micromap.
const NOT_A_MICROMAP: u64 = 0xaa;
/// The top-level structure instance builds write.
pub const TLAS: u64 = 0xab;
/// KHR opacity micromaps: acceleration structures of type OPACITY_MICROMAP.
const KHR_MICROMAP: u64 = 0xa6;
const KHR_MICROMAP_OFFSET: u64 = 0x4000;
const KHR_MICROMAP_2: u64 = 0xa7;
/// Triangles in each micromap's build, and in each geometry.
const TRIANGLES: u32 = 4;

/// Index regions of the input buffer: valid indices 0..3, one index past
/// the micromap, and only special indices.
const INDICES_OFFSET: u64 = 0x2000;
const BAD_INDICES_OFFSET: u64 = 0x2100;
const SPECIAL_INDICES_OFFSET: u64 = 0x2200;
const CLUSTER_SKIP_INDICES_OFFSET: u64 = 0x2300;
const BEYOND_INDICES_OFFSET: u64 = 0x2400;
const INDICES: u64 = INPUT_ADDRESS + INDICES_OFFSET;
const BAD_INDICES: u64 = INPUT_ADDRESS + BAD_INDICES_OFFSET;
const SPECIAL_INDICES: u64 = INPUT_ADDRESS + SPECIAL_INDICES_OFFSET;
const CLUSTER_SKIP_INDICES: u64 = INPUT_ADDRESS + CLUSTER_SKIP_INDICES_OFFSET;
const BEYOND_INDICES: u64 = INPUT_ADDRESS + BEYOND_INDICES_OFFSET;
const INSTANCES: u64 = INPUT_ADDRESS + 0x3000;
const INDIRECT: u64 = INPUT_ADDRESS + 0x3800;
/// Host copies of the index regions.
const HOST_INDICES: u64 = 0x7200_0000;
const HOST_SPECIAL_INDICES: u64 = 0x7200_1000;
const HOST_VERTICES: u64 = 0x7300_0000;
/// An address inside no buffer.
const NOWHERE: u64 = 0xdead_0000;

const GOOD: [u32; 4] = [0, 1, 2, 3];
/// Index 3 is one past the micromap's last triangle: "less than or equal to
/// numTriangles" as 11575 words it, but past the end.
const PAST_THE_END: [u32; 4] = [0, 1, 2, TRIANGLES];
/// Index 3 is beyond numTriangles itself: 11575 as written.
const BEYOND_THE_END: [u32; 4] = [0, 1, 2, TRIANGLES + 1];
const SPECIAL: [u32; 4] = [u32::MAX, u32::MAX - 1, u32::MAX - 2, u32::MAX - 3];
/// Index 2 is -5, the cluster-only special index.
const CLUSTER_SKIP: [u32; 4] = [0, 1, u32::MAX - 4, 3];

fn le_bytes(indices: &[u32]) -> Vec<u8> {
    indices.iter().flat_map(|i| i.to_le_bytes()).collect()
}

fn allow_update() -> u32 {
    ash::vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw()
}

fn allow_disable() -> u32 {
    khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_KHR.as_raw()
}

fn structure(ty: i32, offset: u64, built: Option<BuildRecord>) -> AccelerationStructure {
    let start = STORAGE_ADDRESS + offset;
    AccelerationStructure {
        ty,
        buffer: STORAGE,
        offset,
        size: 0x1000,
        address_range: Some((start, start + 0x1000)),
        built,
        ..Default::default()
    }
}

fn built(ty: i32, flags: u32, triangle_count: u64) -> Option<BuildRecord> {
    Some(BuildRecord {
        flags,
        ty,
        triangle_count,
        ..Default::default()
    })
}

/// The fixtures' world plus index regions, host copies, built micromaps
/// (EXT [`MICROMAP`] opacity, EXT [`MICROMAP_2`] displacement, KHR
/// [`KHR_MICROMAP`] and [`KHR_MICROMAP_2`]) and the structures above.
fn world() -> Validator {
    let mut v = validator();
    let state = v.state_mut();
    let mut input = state.buffers.get_mut(&INPUT).expect("fixture buffer");
    let mut contents = input.contents.as_deref().expect("contents").to_vec();
    for (offset, indices) in [
        (INDICES_OFFSET, GOOD),
        (BAD_INDICES_OFFSET, PAST_THE_END),
        (SPECIAL_INDICES_OFFSET, SPECIAL),
        (CLUSTER_SKIP_INDICES_OFFSET, CLUSTER_SKIP),
        (BEYOND_INDICES_OFFSET, BEYOND_THE_END),
    ] {
        let at = offset as usize;
        contents[at..at + 16].copy_from_slice(&le_bytes(&indices));
    }
    input.contents = Some(ommcheck::Bytes::from(contents));
    // The guard re-indexes the buffer when dropped; it borrows the state until then.
    drop(input);
    for (address, indices) in [(HOST_INDICES, GOOD), (HOST_SPECIAL_INDICES, SPECIAL)] {
        state.host_memory.push(HostRange {
            address,
            bytes: ommcheck::Bytes::from(le_bytes(&indices)),
        });
    }
    state.host_memory.push(HostRange {
        address: HOST_VERTICES,
        bytes: ommcheck::Bytes::from(vec![0u8; 0x100]),
    });
    let opacity = built(MICROMAP_TYPE_OPACITY_MICROMAP_EXT, 0, u64::from(TRIANGLES));
    state.micromaps.get_mut(&MICROMAP).expect("fixture").built = opacity;
    let displacement = state.micromaps.get_mut(&MICROMAP_2).expect("fixture");
    displacement.ty = MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
    displacement.built = built(
        MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV,
        0,
        u64::from(TRIANGLES),
    );
    let khr_built = built(
        ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        0,
        u64::from(TRIANGLES),
    );
    let bottom = ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL;
    for (handle, s) in [
        (BLAS, structure(bottom, BLAS_OFFSET, None)),
        (BLAS_2, structure(bottom, BLAS_2_OFFSET, None)),
        (
            OVERLAPPING,
            structure(bottom, KHR_MICROMAP_OFFSET + 0x800, None),
        ),
        (NOT_A_MICROMAP, structure(bottom, 0x9000, None)),
        (
            TLAS,
            structure(ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL, 0xa000, None),
        ),
        (
            KHR_MICROMAP,
            structure(
                ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                KHR_MICROMAP_OFFSET,
                khr_built.clone(),
            ),
        ),
        (
            KHR_MICROMAP_2,
            structure(
                ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                0x5000,
                khr_built,
            ),
        ),
    ] {
        state.acceleration_structures.insert(handle, s);
    }
    v
}

fn usage(count: u32, level: u32, format: u32) -> MicromapUsage {
    MicromapUsage {
        count,
        subdivision_level: level,
        format,
    }
}

/// A valid EXT attachment: 32-bit indices 0..3 into [`MICROMAP`].
fn ext_ok() -> TrianglesOpacityMicromapExt {
    TrianglesOpacityMicromapExt {
        index_buffer: INDICES,
        usage_counts: UsageCounts::array(vec![usage(
            TRIANGLES,
            1,
            OPACITY_MICROMAP_FORMAT_4_STATE,
        )]),
        micromap: MICROMAP,
        ..Default::default()
    }
}

/// A valid KHR attachment: 32-bit indices 0..3 into [`KHR_MICROMAP`].
fn khr_ok() -> TrianglesOpacityMicromapKhr {
    TrianglesOpacityMicromapKhr {
        index_buffer: INDICES,
        micromap: KHR_MICROMAP,
        ..Default::default()
    }
}

/// A valid NV attachment into the displacement micromap [`MICROMAP_2`].
fn nv_ok() -> TrianglesDisplacementMicromapNv {
    TrianglesDisplacementMicromapNv {
        displacement_bias_and_scale_buffer: INPUT_ADDRESS + 0x4000,
        displacement_bias_and_scale_stride: 4,
        displacement_vector_buffer: INPUT_ADDRESS + 0x5000,
        displacement_vector_stride: 8,
        index_buffer: INDICES,
        usage_counts: UsageCounts::array(vec![usage(TRIANGLES, 1, 1)]),
        micromap: MICROMAP_2,
        ..Default::default()
    }
}

/// Non-indexed triangles over 12 vertices at `vertices`, with the attachments in `data`.
fn triangles_at(vertices: u64, data: TrianglesData) -> Geometry {
    Geometry {
        geometry: GeometryData::Triangles(TrianglesData {
            vertex_data: vertices,
            max_vertex: 3 * TRIANGLES - 1,
            ..data
        }),
        ..Default::default()
    }
}

fn with_ext(attachment: TrianglesOpacityMicromapExt) -> TrianglesData {
    TrianglesData {
        opacity_ext: Some(attachment),
        ..Default::default()
    }
}

fn with_khr(attachment: TrianglesOpacityMicromapKhr) -> TrianglesData {
    TrianglesData {
        opacity_khr: Some(attachment),
        ..Default::default()
    }
}

fn with_nv(attachment: TrianglesDisplacementMicromapNv) -> TrianglesData {
    TrianglesData {
        displacement_nv: Some(attachment),
        ..Default::default()
    }
}

/// A bottom-level BUILD of `geometries` into `dst`, with scratch at `scratch`.
fn blas_build(dst: u64, scratch: u64, geometries: Vec<Geometry>) -> BuildGeometryInfo {
    BuildGeometryInfo {
        dst_acceleration_structure: dst,
        scratch_data: scratch,
        ..BuildGeometryInfo::with_geometries(ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, geometries)
    }
}

fn device_blas(data: TrianglesData) -> BuildGeometryInfo {
    blas_build(
        BLAS,
        SCRATCH_ADDRESS,
        vec![triangles_at(INPUT_ADDRESS, data)],
    )
}

fn host_blas(data: TrianglesData) -> BuildGeometryInfo {
    blas_build(BLAS, HOST_SCRATCH, vec![triangles_at(HOST_VERTICES, data)])
}

fn ranges(infos: &[BuildGeometryInfo]) -> Vec<Option<Vec<BuildRangeInfo>>> {
    infos
        .iter()
        .map(|info| {
            Some(vec![
                BuildRangeInfo {
                    primitive_count: TRIANGLES,
                    ..Default::default()
                };
                info.geometry_count as usize
            ])
        })
        .collect()
}

fn cmd_in(mut v: Validator, infos: &[BuildGeometryInfo]) -> Report {
    v.cmd_build_acceleration_structures(&command_buffer(), infos, &ranges(infos))
}

fn indirect_in(mut v: Validator, infos: &[BuildGeometryInfo]) -> Report {
    let addresses: Vec<u64> = (0..infos.len() as u64).map(|i| INDIRECT + 16 * i).collect();
    let strides = vec![16; infos.len()];
    let max_counts: Vec<_> = infos
        .iter()
        .map(|info| Some(vec![TRIANGLES; info.geometry_count as usize]))
        .collect();
    v.cmd_build_acceleration_structures_indirect(
        &command_buffer(),
        infos,
        &addresses,
        &strides,
        &max_counts,
    )
}

fn host_in(mut v: Validator, infos: &[BuildGeometryInfo]) -> Report {
    v.build_acceleration_structures(infos, &ranges(infos))
}

fn cmd_ext(attachment: TrianglesOpacityMicromapExt) -> Report {
    cmd_in(world(), &[device_blas(with_ext(attachment))])
}

fn indirect_ext(attachment: TrianglesOpacityMicromapExt) -> Report {
    indirect_in(world(), &[device_blas(with_ext(attachment))])
}

fn host_ext(attachment: TrianglesOpacityMicromapExt) -> Report {
    host_in(world(), &[host_blas(with_ext(attachment))])
}

fn cmd_khr(attachment: TrianglesOpacityMicromapKhr) -> Report {
    cmd_in(world(), &[device_blas(with_khr(attachment))])
}

fn indirect_khr(attachment: TrianglesOpacityMicromapKhr) -> Report {
    indirect_in(world(), &[device_blas(with_khr(attachment))])
}

fn host_khr(attachment: TrianglesOpacityMicromapKhr) -> Report {
    host_in(world(), &[host_blas(with_khr(attachment))])
}

fn cmd_nv(attachment: TrianglesDisplacementMicromapNv) -> Report {
    cmd_in(world(), &[device_blas(with_nv(attachment))])
}

fn ok_ext() -> Report {
    cmd_ext(ext_ok())
}

fn ok_khr() -> Report {
    cmd_khr(khr_ok())
}

fn ok_nv() -> Report {
    cmd_nv(nv_ok())
}

/// An EXT attachment with the usage counts `usages` into `micromap`.
fn ext_usages(micromap: u64, usages: Vec<MicromapUsage>) -> Report {
    cmd_ext(TrianglesOpacityMicromapExt {
        micromap,
        usage_counts: UsageCounts::array(usages),
        ..ext_ok()
    })
}

/// An EXT attachment with 4 usage-count entries as `counts` says.
fn ext_counts(counts: UsageCounts) -> Report {
    cmd_ext(TrianglesOpacityMicromapExt {
        usage_counts: counts,
        ..ext_ok()
    })
}

fn nv_counts(counts: UsageCounts) -> Report {
    cmd_nv(TrianglesDisplacementMicromapNv {
        usage_counts: counts,
        ..nv_ok()
    })
}

fn both_count_pointers() -> UsageCounts {
    let mut counts = UsageCounts::array(vec![usage(TRIANGLES, 1, 2)]);
    counts.pointers = Some(vec![Some(usage(TRIANGLES, 1, 2))]);
    counts
}

fn short_count_array() -> UsageCounts {
    let mut counts = UsageCounts::array(vec![usage(TRIANGLES, 1, 2)]);
    counts.count = 2;
    counts
}

fn null_count_pointer() -> UsageCounts {
    UsageCounts {
        count: 2,
        array: None,
        pointers: Some(vec![Some(usage(TRIANGLES, 1, 2)), None]),
    }
}

fn split_count_pointers() -> UsageCounts {
    UsageCounts::pointers(vec![usage(2, 1, 2), usage(2, 1, 2)])
}

fn nv_formats(bias_and_scale: i32, vector: i32) -> Report {
    cmd_nv(TrianglesDisplacementMicromapNv {
        displacement_bias_and_scale_format: bias_and_scale,
        displacement_vector_format: vector,
        ..nv_ok()
    })
}

fn r16g16_sfloat() -> i32 {
    ash::vk::Format::R16G16_SFLOAT.as_raw()
}

fn r16g16b16a16_sfloat() -> i32 {
    ash::vk::Format::R16G16B16A16_SFLOAT.as_raw()
}

/// Two infos: pInfos[0] into [`BLAS`] references [`KHR_MICROMAP`]; pInfos[1]
/// (no attachment) writes `second_dst`.
fn two_infos(second_dst: u64) -> Report {
    let first = device_blas(with_khr(khr_ok()));
    let second = blas_build(
        second_dst,
        SCRATCH_ADDRESS + 0x8000,
        vec![triangles_at(INPUT_ADDRESS, TrianglesData::default())],
    );
    cmd_in(world(), &[first, second])
}

/// An update of [`BLAS`] whose original build chained `original` and which
/// now chains `now`, through `build` (Cmd or Indirect).
fn update(
    original: TrianglesData,
    now: TrianglesData,
    build: fn(Validator, &[BuildGeometryInfo]) -> Report,
) -> Report {
    let mut v = world();
    let original_build = BuildGeometryInfo {
        flags: allow_update(),
        ..device_blas(original)
    };
    let state = v.state_mut();
    record_original_attachments(state, &[original_build]);
    state
        .acceleration_structures
        .get_mut(&BLAS)
        .expect("world")
        .built = built(ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, allow_update(), 0);
    let update = BuildGeometryInfo {
        flags: allow_update(),
        mode: BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
        src_acceleration_structure: BLAS,
        ..device_blas(now)
    };
    build(v, &[update])
}

fn khr_into(micromap: u64) -> TrianglesData {
    with_khr(TrianglesOpacityMicromapKhr {
        micromap,
        ..khr_ok()
    })
}

fn khr_null() -> TrianglesData {
    with_khr(TrianglesOpacityMicromapKhr {
        micromap: 0,
        index_buffer: SPECIAL_INDICES,
        ..khr_ok()
    })
}

/// A top-level build of one instance with `flags` referencing [`BLAS`],
/// built with `blas_flags`, on a device with `micromap_features`.
fn instance_build(
    flags: u32,
    blas_flags: u32,
    micromap_features: bool,
    build: fn(Validator, &[BuildGeometryInfo]) -> Report,
    host_side: bool,
) -> Report {
    let mut v = world();
    let blas_address = STORAGE_ADDRESS + BLAS_OFFSET;
    {
        let state = v.state_mut();
        state
            .acceleration_structures
            .get_mut(&BLAS)
            .expect("world")
            .built = built(ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, blas_flags, 0);
    }
    if !micromap_features {
        let mut device = v.device().clone();
        device.features.micromap_ext = false;
        device.features.micromap_khr = false;
        let state = v.state().clone();
        v = Validator::new(device);
        *v.state_mut() = state;
    }
    let instance = Instance {
        mask: 0xff,
        flags: flags as u8,
        acceleration_structure_reference: if host_side { BLAS } else { blas_address },
        ..Default::default()
    };
    let geometry = Geometry {
        geometry_type: GEOMETRY_TYPE_INSTANCES,
        geometry: GeometryData::Instances(InstancesData {
            array_of_pointers: false,
            data: if host_side { HOST_DATA } else { INSTANCES },
            instances: Some(vec![instance]),
            ..Default::default()
        }),
        ..Default::default()
    };
    let info = BuildGeometryInfo {
        dst_acceleration_structure: TLAS,
        scratch_data: if host_side {
            HOST_SCRATCH
        } else {
            SCRATCH_ADDRESS
        },
        ..BuildGeometryInfo::with_geometries(ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL, vec![geometry])
    };
    let infos = [info];
    if host_side {
        return v.build_acceleration_structures(
            &infos,
            &[Some(vec![BuildRangeInfo {
                primitive_count: 1,
                ..Default::default()
            }])],
        );
    }
    build(v, &infos)
}

/// A device top-level build of [`TRIANGLES`] instances (or pointers to
/// them) read from `data`, whose contents the checker is not given.
fn instances_from(data: u64, array_of_pointers: bool) -> Report {
    let geometry = Geometry {
        geometry_type: GEOMETRY_TYPE_INSTANCES,
        geometry: GeometryData::Instances(InstancesData {
            array_of_pointers,
            data,
            ..Default::default()
        }),
        ..Default::default()
    };
    let info = BuildGeometryInfo {
        dst_acceleration_structure: TLAS,
        scratch_data: SCRATCH_ADDRESS,
        ..BuildGeometryInfo::with_geometries(ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL, vec![geometry])
    };
    cmd_in(world(), &[info])
}

fn disable_flag() -> u32 {
    khr_values::GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_KHR.as_raw()
}

fn force_2_state_flag() -> u32 {
    khr_values::GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_BIT_KHR.as_raw()
}

fn cluster_opacity(index_type: u32, array: u64, index_buffer: u64) -> ClusterTriangleOpacity {
    ClusterTriangleOpacity {
        opacity_micromap_index_type: index_type,
        opacity_micromap_index_buffer_stride: 4,
        opacity_micromap_array: array,
        opacity_micromap_index_buffer: index_buffer,
    }
}

fn cluster_ok() -> ClusterTriangleOpacity {
    cluster_opacity(CLUSTER_INDEX_FORMAT_32BIT_NV, INPUT_ADDRESS, INDICES)
}

fn allow_cluster_micromaps() -> u32 {
    khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_CLUSTER_OPACITY_MICROMAPS_BIT_NV.as_raw()
}

fn clusters(input_flags: u32, opacity: ClusterTriangleOpacity) -> Report {
    world().cmd_build_cluster_triangle_clusters(
        input_flags,
        &[ClusterBuildTriangleClusterInfo {
            cluster_id: 1,
            triangle_count: TRIANGLES,
            opacity,
        }],
    )
}

fn templates(input_flags: u32, opacity: ClusterTriangleOpacity) -> Report {
    world().cmd_build_cluster_triangle_cluster_templates(
        input_flags,
        &[ClusterBuildTriangleClusterTemplateInfo {
            cluster_id: 1,
            triangle_count: TRIANGLES,
            opacity,
        }],
    )
}

fn ok_clusters() -> Report {
    clusters(allow_cluster_micromaps(), cluster_ok())
}

fn ok_templates() -> Report {
    templates(allow_cluster_micromaps(), cluster_ok())
}

pub fn cases() -> Vec<Case> {
    let mut cases = ext_cases();
    cases.extend(khr_cases());
    cases.extend(nv_cases());
    cases.extend(across_info_cases());
    cases.extend(instance_cases());
    cases.extend(cluster_cases());
    cases.extend(usage_count_cases());
    cases.extend(provenance_cases());
    cases
}

fn ext_cases() -> Vec<Case> {
    vec![
        case(
            ext::sType_sType,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    s_type: 0,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            ext::indexType_parameter,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_type: 7,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            ext::indexType_10719,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_UINT8,
                    ..ext_ok()
                })
            },
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_UINT16,
                    index_stride: 4,
                    ..ext_ok()
                })
            },
        ),
        case(
            ext::indexType_10722,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_stride: 6,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            ext::indexType_10723,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_stride: 1 << 34,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            ext::micromap_parameter,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    micromap: 0x999,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            ext::pUsageCounts_07335,
            || ext_counts(both_count_pointers()),
            ok_ext,
        ),
        case(
            ext::pUsageCounts_parameter,
            || ext_counts(short_count_array()),
            ok_ext,
        ),
        case(
            ext::ppUsageCounts_parameter,
            || ext_counts(null_count_pointer()),
            || ext_counts(split_count_pointers()),
        ),
        case(
            ext::format_11679,
            || ext_usages(MICROMAP, vec![usage(TRIANGLES, 1, 3)]),
            ok_ext,
        ),
        case(
            ext::subdivisionLevel_11680,
            || {
                ext_usages(
                    MICROMAP,
                    vec![usage(TRIANGLES, 4, OPACITY_MICROMAP_FORMAT_2_STATE)],
                )
            },
            || {
                ext_usages(
                    MICROMAP,
                    vec![usage(TRIANGLES, 3, OPACITY_MICROMAP_FORMAT_2_STATE)],
                )
            },
        ),
        case(
            ext::subdivisionLevel_11681,
            || {
                ext_usages(
                    MICROMAP,
                    vec![usage(TRIANGLES, 4, OPACITY_MICROMAP_FORMAT_4_STATE)],
                )
            },
            ok_ext,
        ),
        case(
            ext::format_11682,
            || ext_usages(MICROMAP_2, vec![usage(TRIANGLES, 1, 4)]),
            || ext_usages(MICROMAP_2, vec![usage(TRIANGLES, 1, 1)]),
        ),
        case(
            ext::subdivisionLevel_11683,
            || ext_usages(MICROMAP_2, vec![usage(TRIANGLES, 4, 1)]),
            || ext_usages(MICROMAP_2, vec![usage(TRIANGLES, 3, 1)]),
        ),
        case(
            cmd::pInfos_10904,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_NONE,
                    ..ext_ok()
                })
            },
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    ..ext_ok()
                })
            },
        ),
        case(
            cmd::pInfos_10905,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_buffer: NOWHERE,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            indirect::pInfos_10904,
            || {
                indirect_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_NONE,
                    ..ext_ok()
                })
            },
            || indirect_ext(ext_ok()),
        ),
        case(
            indirect::pInfos_10905,
            || {
                indirect_ext(TrianglesOpacityMicromapExt {
                    index_buffer: 0,
                    ..ext_ok()
                })
            },
            || indirect_ext(ext_ok()),
        ),
        case(
            host::pInfos_10892,
            || {
                host_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: HOST_INDICES,
                    ..ext_ok()
                })
            },
            || {
                host_ext(TrianglesOpacityMicromapExt {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    ..ext_ok()
                })
            },
        ),
        case(
            host::pInfos_11821,
            || {
                host_ext(TrianglesOpacityMicromapExt {
                    index_buffer: 0,
                    ..ext_ok()
                })
            },
            || {
                host_ext(TrianglesOpacityMicromapExt {
                    index_buffer: HOST_INDICES,
                    ..ext_ok()
                })
            },
        ),
        case(
            &rules::INDEX_BUFFER_RANGE,
            || {
                // Two of the four 4-byte indices fit before the buffer's end.
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_buffer: INPUT_ADDRESS + INPUT_SIZE - 8,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            &rules::NULL_MICROMAP_SPECIAL_ONLY,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    micromap: 0,
                    ..ext_ok()
                })
            },
            || {
                // Every index special, so every usage count zero.
                cmd_ext(TrianglesOpacityMicromapExt {
                    micromap: 0,
                    index_buffer: SPECIAL_INDICES,
                    usage_counts: UsageCounts::array(vec![usage(
                        0,
                        1,
                        OPACITY_MICROMAP_FORMAT_4_STATE,
                    )]),
                    ..ext_ok()
                })
            },
        ),
        case(
            &rules::CLUSTER_INDEX_OUTSIDE_CLUSTER,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_buffer: CLUSTER_SKIP_INDICES,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            &rules::INDEX_IN_RANGE,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_buffer: BAD_INDICES,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            &rules::INDEX_ALIGNMENT,
            || {
                cmd_ext(TrianglesOpacityMicromapExt {
                    index_buffer: INDICES + 2,
                    ..ext_ok()
                })
            },
            ok_ext,
        ),
        case(
            triangles_vuid::pNext_pNext,
            || {
                cmd_in(
                    world(),
                    &[device_blas(TrianglesData {
                        next: vec![1_000_150_017],
                        ..with_ext(ext_ok())
                    })],
                )
            },
            ok_ext,
        ),
    ]
}

fn khr_cases() -> Vec<Case> {
    vec![
        case(
            khr::sType_sType,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    s_type: 0,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::indexType_parameter,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: 7,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::indexType_11570,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: 9,
                    ..khr_ok()
                })
            },
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_UINT8,
                    ..khr_ok()
                })
            },
        ),
        case(
            khr::indexBuffer_11571,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_NONE,
                    ..khr_ok()
                })
            },
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    ..khr_ok()
                })
            },
        ),
        case(
            khr::indexBuffer_11572,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: NOWHERE,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::indexStride_11573,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_stride: 6,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::indexStride_11574,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_stride: 1 << 34,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::micromap_parameter,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    micromap: 0x999,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            khr::micromap_11579,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    micromap: 0,
                    ..khr_ok()
                })
            },
            || cmd_in(world(), &[device_blas(khr_null())]),
        ),
        case(
            khr::geometry_11576,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    base_triangle: 2,
                    ..khr_ok()
                })
            },
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_type: INDEX_TYPE_NONE,
                    index_buffer: 0,
                    ..khr_ok()
                })
            },
        ),
        case(
            cmd::indexBuffer_11575,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: BEYOND_INDICES,
                    ..khr_ok()
                })
            },
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: SPECIAL_INDICES,
                    ..khr_ok()
                })
            },
        ),
        case(
            cmd::indexBuffer_11577,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: INPUT_ADDRESS + INPUT_SIZE - 8,
                    ..khr_ok()
                })
            },
            ok_khr,
        ),
        case(
            cmd::indexBuffer_11578,
            || {
                cmd_khr(TrianglesOpacityMicromapKhr {
                    micromap: 0,
                    ..khr_ok()
                })
            },
            || cmd_in(world(), &[device_blas(khr_null())]),
        ),
        case(
            cmd::micromap_11624,
            || cmd_in(world(), &[device_blas(khr_into(NOT_A_MICROMAP))]),
            ok_khr,
        ),
        case(
            indirect::micromap_11624,
            || indirect_in(world(), &[device_blas(khr_into(NOT_A_MICROMAP))]),
            || indirect_khr(khr_ok()),
        ),
        case(
            host::pInfos_11705,
            || {
                host_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: HOST_SPECIAL_INDICES,
                    ..khr_ok()
                })
            },
            || {
                host_khr(TrianglesOpacityMicromapKhr {
                    index_buffer: HOST_SPECIAL_INDICES,
                    micromap: 0,
                    ..khr_ok()
                })
            },
        ),
    ]
}

fn nv_cases() -> Vec<Case> {
    vec![
        case(
            nv::sType_sType,
            || {
                cmd_nv(TrianglesDisplacementMicromapNv {
                    s_type: 0,
                    ..nv_ok()
                })
            },
            ok_nv,
        ),
        case(
            nv::indexType_parameter,
            || {
                cmd_nv(TrianglesDisplacementMicromapNv {
                    index_type: 7,
                    ..nv_ok()
                })
            },
            ok_nv,
        ),
        case(
            nv::micromap_parameter,
            || {
                cmd_nv(TrianglesDisplacementMicromapNv {
                    micromap: 0x999,
                    ..nv_ok()
                })
            },
            ok_nv,
        ),
        case(
            nv::pUsageCounts_07992,
            || nv_counts(both_count_pointers()),
            ok_nv,
        ),
        case(
            nv::pUsageCounts_parameter,
            || nv_counts(short_count_array()),
            ok_nv,
        ),
        case(
            nv::ppUsageCounts_parameter,
            || nv_counts(null_count_pointer()),
            || nv_counts(split_count_pointers()),
        ),
        case(
            nv::displacementBiasAndScaleFormat_09501,
            || nv_formats(0, r16g16b16a16_sfloat()),
            ok_nv,
        ),
        case(
            nv::displacementBiasAndScaleFormat_parameter,
            || nv_formats(999, r16g16b16a16_sfloat()),
            ok_nv,
        ),
        case(
            nv::displacementVectorFormat_09502,
            || nv_formats(r16g16_sfloat(), 0),
            ok_nv,
        ),
        case(
            nv::displacementVectorFormat_parameter,
            || nv_formats(r16g16_sfloat(), 1_000_999_000),
            ok_nv,
        ),
    ]
}

fn across_info_cases() -> Vec<Case> {
    vec![
        case(
            cmd::dstAccelerationStructure_11548,
            || two_infos(KHR_MICROMAP),
            || two_infos(BLAS_2),
        ),
        case(
            cmd::dstAccelerationStructure_11549,
            || two_infos(OVERLAPPING),
            || two_infos(BLAS_2),
        ),
        case(
            cmd::micromap_11625,
            || update(khr_into(KHR_MICROMAP), TrianglesData::default(), cmd_in),
            || update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP), cmd_in),
        ),
        case(
            cmd::micromap_11626,
            || update(khr_null(), khr_into(KHR_MICROMAP), cmd_in),
            || update(khr_null(), khr_null(), cmd_in),
        ),
        case(
            cmd::micromap_11627,
            || update(TrianglesData::default(), khr_into(KHR_MICROMAP), cmd_in),
            || update(TrianglesData::default(), TrianglesData::default(), cmd_in),
        ),
        case(
            cmd::micromap_11629,
            || update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP_2), cmd_in),
            || update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP), cmd_in),
        ),
        case(
            indirect::micromap_11625,
            || update(khr_into(KHR_MICROMAP), khr_null(), indirect_in),
            || update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP), indirect_in),
        ),
        case(
            indirect::micromap_11626,
            || update(khr_null(), TrianglesData::default(), indirect_in),
            || update(khr_null(), khr_null(), indirect_in),
        ),
        case(
            indirect::micromap_11627,
            || update(TrianglesData::default(), khr_null(), indirect_in),
            || {
                update(
                    TrianglesData::default(),
                    TrianglesData::default(),
                    indirect_in,
                )
            },
        ),
        case(
            indirect::micromap_11629,
            || {
                update(
                    khr_into(KHR_MICROMAP),
                    khr_into(KHR_MICROMAP_2),
                    indirect_in,
                )
            },
            || update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP), indirect_in),
        ),
    ]
}

fn instance_cases() -> Vec<Case> {
    vec![
        case(
            &rules::INSTANCES_RANGE,
            // Three of the four 64-byte instances fit before the buffer's end.
            || instances_from(INPUT_ADDRESS + INPUT_SIZE - 3 * 64, false),
            || instances_from(INPUT_ADDRESS + INPUT_SIZE - 4 * 64, false),
        ),
        case(
            instance_vuid::micromap_11580,
            || instance_build(force_2_state_flag(), 0, false, cmd_in, false),
            || instance_build(force_2_state_flag(), 0, true, cmd_in, false),
        ),
        case(
            instance_vuid::flags_11581,
            || instance_build(disable_flag(), 0, true, host_in, true),
            || instance_build(disable_flag(), allow_disable(), true, host_in, true),
        ),
        case(
            cmd::pInfos_10607,
            || instance_build(disable_flag(), 0, true, cmd_in, false),
            || instance_build(disable_flag(), allow_disable(), true, cmd_in, false),
        ),
        case(
            indirect::pInfos_10607,
            || instance_build(disable_flag(), 0, true, indirect_in, false),
            || instance_build(disable_flag(), allow_disable(), true, indirect_in, false),
        ),
    ]
}

fn cluster_cases() -> Vec<Case> {
    vec![
        case(
            cluster::opacityMicromapArray_10881,
            || clusters(0, cluster_ok()),
            ok_clusters,
        ),
        case(
            cluster::opacityMicromapArray_parameter,
            || {
                clusters(
                    allow_cluster_micromaps(),
                    cluster_opacity(CLUSTER_INDEX_FORMAT_32BIT_NV, NOWHERE, INDICES),
                )
            },
            ok_clusters,
        ),
        case(
            cluster::opacityMicromapIndexBuffer_parameter,
            || {
                clusters(
                    allow_cluster_micromaps(),
                    cluster_opacity(CLUSTER_INDEX_FORMAT_32BIT_NV, INPUT_ADDRESS, NOWHERE),
                )
            },
            ok_clusters,
        ),
        case(
            cluster::opacityMicromapIndexType_10492,
            || {
                clusters(
                    allow_cluster_micromaps(),
                    cluster_opacity(
                        CLUSTER_INDEX_FORMAT_16BIT_NV | CLUSTER_INDEX_FORMAT_32BIT_NV,
                        INPUT_ADDRESS,
                        INDICES,
                    ),
                )
            },
            || clusters(0, cluster_opacity(0, 0, 0)),
        ),
        case(
            cluster_template::opacityMicromapArray_10882,
            || templates(0, cluster_ok()),
            ok_templates,
        ),
        case(
            cluster_template::opacityMicromapArray_parameter,
            || {
                templates(
                    allow_cluster_micromaps(),
                    cluster_opacity(CLUSTER_INDEX_FORMAT_32BIT_NV, NOWHERE, INDICES),
                )
            },
            ok_templates,
        ),
        case(
            cluster_template::opacityMicromapIndexBuffer_parameter,
            || {
                templates(
                    allow_cluster_micromaps(),
                    cluster_opacity(CLUSTER_INDEX_FORMAT_32BIT_NV, INPUT_ADDRESS, NOWHERE),
                )
            },
            ok_templates,
        ),
        case(
            cluster_template::opacityMicromapIndexType_10501,
            || {
                templates(
                    allow_cluster_micromaps(),
                    cluster_opacity(0, INPUT_ADDRESS, INDICES),
                )
            },
            || {
                templates(
                    allow_cluster_micromaps(),
                    cluster_opacity(CLUSTER_INDEX_FORMAT_8BIT_NV, INPUT_ADDRESS, INDICES),
                )
            },
        ),
    ]
}

/// Where [`world_with_content`] puts the micromaps' triangle arrays in the
/// input buffer (256-byte aligned, clear of the fixtures' regions).
const CONTENT_TRIANGLES_OFFSET: u64 = 0x1800;

/// [`world`] with [`MICROMAP`] built (and its content recorded) from four
/// 4-state level-1 triangles, and the displacement micromap [`MICROMAP_2`]
/// from four format-1 level-1 triangles.
fn world_with_content() -> Validator {
    let mut v = world();
    let entries = |format: u16| -> Vec<u8> {
        (0..TRIANGLES)
            .flat_map(|m| {
                MicromapTriangle {
                    data_offset: m,
                    subdivision_level: 1,
                    format,
                }
                .to_bytes()
            })
            .collect()
    };
    let mut input = v
        .state_mut()
        .buffers
        .get_mut(&INPUT)
        .expect("fixture buffer");
    let mut contents = input.contents.as_deref().expect("contents").to_vec();
    let at = CONTENT_TRIANGLES_OFFSET as usize;
    contents[at..at + 32].copy_from_slice(&entries(2));
    contents[at + 0x100..at + 0x120].copy_from_slice(&entries(1));
    input.contents = Some(ommcheck::Bytes::from(contents));
    // The guard re-indexes the buffer when dropped; it borrows the state until then.
    drop(input);
    let opacity = MicromapBuildInfo {
        dst_micromap: MICROMAP,
        usage_counts: UsageCounts::array(vec![usage(
            TRIANGLES,
            1,
            OPACITY_MICROMAP_FORMAT_4_STATE,
        )]),
        data: INPUT_ADDRESS,
        triangle_array: INPUT_ADDRESS + CONTENT_TRIANGLES_OFFSET,
        triangle_array_stride: 8,
        scratch_data: SCRATCH_ADDRESS,
        ..Default::default()
    };
    let displacement = MicromapBuildInfo {
        ty: MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV,
        dst_micromap: MICROMAP_2,
        usage_counts: UsageCounts::array(vec![usage(TRIANGLES, 1, 1)]),
        triangle_array: INPUT_ADDRESS + CONTENT_TRIANGLES_OFFSET + 0x100,
        scratch_data: SCRATCH_ADDRESS + 0x8000,
        ..opacity.clone()
    };
    let report = v.cmd_build_micromaps(&command_buffer(), &[opacity, displacement]);
    assert!(!report.has_errors(), "{report}");
    v
}

fn usage_count_cases() -> Vec<Case> {
    vec![
        // Special indices select no micromap triangle, so the four triangles
        // the counts declare are referenced by none.
        case(
            &rules::ATTACH_USAGE_COUNTS,
            || {
                cmd_in(
                    world_with_content(),
                    &[device_blas(with_ext(TrianglesOpacityMicromapExt {
                        index_buffer: SPECIAL_INDICES,
                        ..ext_ok()
                    }))],
                )
            },
            || cmd_in(world_with_content(), &[device_blas(with_ext(ext_ok()))]),
        ),
        // The displacement attachment's counts name level 2; the triangles
        // its indices select are level 1.
        case(
            &rules::ATTACH_USAGE_COUNTS,
            || {
                cmd_in(
                    world_with_content(),
                    &[device_blas(with_nv(TrianglesDisplacementMicromapNv {
                        usage_counts: UsageCounts::array(vec![usage(TRIANGLES, 2, 1)]),
                        ..nv_ok()
                    }))],
                )
            },
            || cmd_in(world_with_content(), &[device_blas(with_nv(nv_ok()))]),
        ),
    ]
}

/// The usage-count rule on one EXT attachment in [`world_with_content`].
fn usage_findings(attachment: TrianglesOpacityMicromapExt) -> Report {
    cmd_in(world_with_content(), &[device_blas(with_ext(attachment))])
}

#[test]
fn usage_counts_count_each_reference_and_skip_what_is_unknown() {
    let rule = &rules::ATTACH_USAGE_COUNTS;
    // Stride 0: every triangle reads index 0, four references to one triangle.
    assert!(!usage_findings(TrianglesOpacityMicromapExt {
        index_stride: 0,
        ..ext_ok()
    })
    .contains(rule));
    // ... which three counts do not describe.
    assert!(usage_findings(TrianglesOpacityMicromapExt {
        index_stride: 0,
        usage_counts: UsageCounts::array(vec![usage(3, 1, OPACITY_MICROMAP_FORMAT_4_STATE)]),
        ..ext_ok()
    })
    .contains(rule));
    // Counts split over duplicate keys are summed; zero counts are allowed.
    assert!(!usage_findings(TrianglesOpacityMicromapExt {
        usage_counts: UsageCounts::pointers(vec![
            usage(1, 1, OPACITY_MICROMAP_FORMAT_4_STATE),
            usage(3, 1, OPACITY_MICROMAP_FORMAT_4_STATE),
            usage(0, 2, OPACITY_MICROMAP_FORMAT_2_STATE),
        ]),
        ..ext_ok()
    })
    .contains(rule));
    // Index type NONE: triangle t uses t + baseTriangle.
    assert!(!usage_findings(TrianglesOpacityMicromapExt {
        index_type: INDEX_TYPE_NONE,
        index_buffer: 0,
        ..ext_ok()
    })
    .contains(rule));
    // An index past the micromap is the index rule's finding, not a count mismatch.
    let past = usage_findings(TrianglesOpacityMicromapExt {
        index_buffer: BAD_INDICES,
        ..ext_ok()
    });
    assert!(past.contains(&rules::INDEX_IN_RANGE) && !past.contains(rule));
    let based = usage_findings(TrianglesOpacityMicromapExt {
        index_type: INDEX_TYPE_NONE,
        index_buffer: 0,
        base_triangle: 1,
        ..ext_ok()
    });
    assert!(based.contains(&rules::INDEX_IN_RANGE) && !based.contains(rule));
    // A NULL micromap has no triangles: with every index special, every
    // count must be zero.
    let null_micromap = |usage_counts| {
        usage_findings(TrianglesOpacityMicromapExt {
            micromap: 0,
            index_buffer: SPECIAL_INDICES,
            usage_counts,
            ..ext_ok()
        })
    };
    let counted = null_micromap(ext_ok().usage_counts);
    assert!(counted.contains(rule), "{counted:#?}");
    let zero = UsageCounts::array(vec![usage(0, 1, OPACITY_MICROMAP_FORMAT_4_STATE)]);
    assert!(!null_micromap(zero).contains(rule));
    // A non-special index into a NULL micromap is 11578's or our rule's
    // finding, not a count mismatch.
    assert!(!usage_findings(TrianglesOpacityMicromapExt {
        micromap: 0,
        ..ext_ok()
    })
    .contains(rule));
    // A micromap whose content the checker never saw: not decided.
    assert!(!cmd_ext(TrianglesOpacityMicromapExt {
        index_buffer: SPECIAL_INDICES,
        ..ext_ok()
    })
    .contains(rule));
}

/// The report's first finding of `rule`, which it must have.
fn first_finding<'r>(report: &'r Report, rule: &'static rules::OwnRule) -> &'r ommcheck::Finding {
    report
        .findings
        .iter()
        .find(|f| f.rule == RuleId::from(rule))
        .unwrap_or_else(|| panic!("no {} finding in {report:#?}", rule.id))
}

#[test]
fn usage_count_findings_name_the_key_and_the_counts() {
    let report = usage_findings(TrianglesOpacityMicromapExt {
        index_buffer: SPECIAL_INDICES,
        ..ext_ok()
    });
    let finding = first_finding(&report, &rules::ATTACH_USAGE_COUNTS);
    assert!(
        finding.location.ends_with(
            ".geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.pUsageCounts[0]"
        ),
        "{}",
        finding.location
    );
    assert!(
        finding
            .message
            .starts_with("VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 1: the usage counts say 4,")
            && finding.message.contains("0 times"),
        "{}",
        finding.message
    );
}

/// 11575 and 11576 as written ("less than or equal to numTriangles", 11575
/// for indices greater than zero); what lies past the micromap's last
/// triangle otherwise is our rule's.
#[test]
fn khr_index_rules_follow_the_vuid_wording() {
    let own = &rules::INDEX_IN_RANGE;
    let ids = |report: &Report| -> Vec<&str> {
        report.findings.iter().map(|f| f.rule.as_str()).collect()
    };
    // Index 4 + 0 == numTriangles 4: one past the end, not 11575's "greater than".
    let one_past = cmd_khr(TrianglesOpacityMicromapKhr {
        index_buffer: BAD_INDICES,
        ..khr_ok()
    });
    assert_eq!(ids(&one_past), [own.id], "{one_past:#?}");
    // Index 0 + baseTriangle 4 == 4 and index 3 + 4 > 4: index 0 is never 11575's.
    let based = cmd_khr(TrianglesOpacityMicromapKhr {
        base_triangle: TRIANGLES,
        ..khr_ok()
    });
    let based_ids = ids(&based);
    assert!(based_ids.contains(&own.id), "{based:#?}");
    assert!(
        based_ids.contains(&cmd::indexBuffer_11575.id()),
        "{based:#?}"
    );
    let index_zero = based
        .findings
        .iter()
        .find(|f| f.location.ends_with("indexBuffer[0]"))
        .expect("index 0 reported");
    assert_eq!(index_zero.rule.as_str(), own.id);
    // No index buffer: triangle 3 + baseTriangle 1 == 4 is ours, + 2 is 11576's.
    let none = |base_triangle| {
        cmd_khr(TrianglesOpacityMicromapKhr {
            index_type: INDEX_TYPE_NONE,
            index_buffer: 0,
            base_triangle,
            ..khr_ok()
        })
    };
    assert_eq!(ids(&none(1)), [own.id]);
    assert_eq!(ids(&none(2)), [khr::geometry_11576.id()]);
    // Every finding quotes its rule's statement.
    for finding in one_past.findings.iter().chain(&none(1).findings) {
        assert!(finding.rule.statement().contains("fetched at index"));
    }
}

#[test]
fn an_index_buffer_past_its_end_names_the_last_index_inside() {
    let report = cmd_ext(TrianglesOpacityMicromapExt {
        index_buffer: INPUT_ADDRESS + INPUT_SIZE - 8,
        ..ext_ok()
    });
    let finding = first_finding(&report, &rules::INDEX_BUFFER_RANGE);
    assert_eq!(
        finding.message,
        "the 8 bytes from indexBuffer hold 2 4-byte indices at stride 4, but primitiveCount is 4: index 2 lies past the end (the last inside is index 1)"
    );
    // A stride of 0 reads one index for every triangle.
    assert!(!cmd_ext(TrianglesOpacityMicromapExt {
        index_buffer: INPUT_ADDRESS + INPUT_SIZE - 4,
        index_stride: 0,
        ..ext_ok()
    })
    .contains(&rules::INDEX_BUFFER_RANGE));
}

#[test]
fn instances_past_their_end_name_the_last_inside() {
    let report = instances_from(INPUT_ADDRESS + INPUT_SIZE - 3 * 64, false);
    assert_eq!(
        first_finding(&report, &rules::INSTANCES_RANGE).message,
        "the 192 bytes from data + primitiveOffset 0 hold 3 64-byte instances, but primitiveCount is 4: instance 3 lies past the end (the last inside is instance 2)"
    );
    // Four 8-byte pointers fit where four instances do not.
    let pointers = |data| instances_from(data, true).contains(&rules::INSTANCES_RANGE);
    assert!(!pointers(INPUT_ADDRESS + INPUT_SIZE - 32));
    assert!(pointers(INPUT_ADDRESS + INPUT_SIZE - 24));
}

#[test]
fn an_attachment_to_a_micromap_whose_build_was_not_seen_says_what_it_skips() {
    let mut v = world();
    v.state_mut()
        .micromaps
        .get_mut(&MICROMAP)
        .expect("fixture")
        .built = None;
    let report = cmd_in(v, &[device_blas(with_ext(ext_ok()))]);
    let skipped: Vec<_> = report.not_checked().collect();
    assert_eq!(skipped.len(), 1, "{report}");
    let finding = skipped[0];
    assert_eq!(finding.rule.as_str(), "OMMCHECK-not-checked-build-not-seen");
    assert_eq!(finding.severity, Severity::Info);
    assert!(finding.location.ends_with(".micromap"), "{finding}");
    assert_eq!(finding.objects[0].handle, MICROMAP);
    assert_eq!(
        finding.not_checked,
        [
            RuleId::from(&rules::INDEX_IN_RANGE),
            RuleId::from(&rules::ATTACH_USAGE_COUNTS)
        ]
    );
    assert!(finding.message.contains("Validator::cmd_build_micromaps"));
    assert!(!report.has_errors(), "{report}");
    // The built twin decides both.
    let built = ok_ext();
    assert!(built.not_checked().all(|f| !f
        .not_checked
        .contains(&RuleId::from(&rules::INDEX_IN_RANGE))));
    assert!(built.checked.contains(&rules::INDEX_IN_RANGE));
}

#[test]
fn unreadable_index_buffers_and_instances_are_reported_not_checked() {
    let mut v = world();
    v.state_mut()
        .buffers
        .get_mut(&INPUT)
        .expect("fixture")
        .contents = None;
    let report = cmd_in(v, &[device_blas(with_ext(ext_ok()))]);
    let finding = report
        .not_checked()
        .find(|f| f.location.ends_with(".indexBuffer"))
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(finding.rule.as_str(), "OMMCHECK-not-checked-contents");
    assert_eq!(finding.objects[0].handle, INPUT);
    assert!(finding
        .not_checked
        .contains(&RuleId::from(&rules::INDEX_IN_RANGE)));
    assert!(report.require_fully_checked().is_err());
    let summary = report.summary();
    assert!(summary.rules_not_checked >= 1);
    // With the contents given, the indices are read.
    let readable = ok_ext();
    assert!(
        readable
            .not_checked()
            .all(|f| !f.location.ends_with(".indexBuffer")),
        "{readable}"
    );
}

#[test]
fn an_update_of_a_structure_whose_original_build_was_not_seen_says_so() {
    let update_info = BuildGeometryInfo {
        flags: allow_update(),
        mode: BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
        src_acceleration_structure: BLAS,
        ..device_blas(khr_into(KHR_MICROMAP))
    };
    let report = cmd_in(world(), &[update_info]);
    let finding = report
        .not_checked()
        .find(|f| f.location == "pInfos[0].srcAccelerationStructure")
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(finding.rule.as_str(), "OMMCHECK-not-checked-build-not-seen");
    assert_eq!(finding.objects[0].handle, BLAS);
    assert!(finding.not_checked.contains(&cmd::micromap_11625.into()));
    // With the original build recorded, the update rules are decided.
    let seen = update(khr_into(KHR_MICROMAP), khr_into(KHR_MICROMAP), cmd_in);
    assert!(seen
        .not_checked()
        .all(|f| f.location != "pInfos[0].srcAccelerationStructure"));
    assert!(seen.checked.contains(cmd::micromap_11625));
}

#[test]
fn the_index_buffer_range_is_not_checked_without_buffer_addresses() {
    let blas = device_blas(with_khr(khr_ok()));
    let report = cmd_in(forget_addresses(world()), &[blas]);
    unknown_address_skipping(&report, cmd::indexBuffer_11577);
    // With the addresses known the rule is checked and nothing is skipped.
    let known = ok_khr();
    assert!(known.checked.contains(cmd::indexBuffer_11577), "{known}");
    assert_eq!(known.not_checked().count(), 0, "{known}");
}

// Deserialized structures (11582, 11587, 11628, 11634; 11637 in pipeline_sync)

/// KHR micromaps on buffers of their own, so that a serialized header names
/// each by its buffer's address: one deserialized from KHR_MICROMAP's
/// serialization, one that a build in this run wrote.
const OWN_STORAGE: u64 = 0xd5;
const OWN_STORAGE_ADDRESS: u64 = 0x50_0000;
pub const DESERIALIZED_MICROMAP: u64 = 0xd6;
const OTHER_STORAGE: u64 = 0xd7;
const OTHER_STORAGE_ADDRESS: u64 = 0x51_0000;
pub const OTHER_MICROMAP: u64 = 0xd8;
/// Where the serializations write, in the input buffer (whose contents the
/// checker has).
const SERIALIZED_MICROMAP: u64 = INPUT_ADDRESS + 0x6000;
const SERIALIZED_BLAS: u64 = INPUT_ADDRESS + 0x7000;
/// The structure deserialized from BLAS's serialization.
pub const DESERIALIZED_BLAS: u64 = BLAS_2;

fn no_errors(report: Report) {
    assert!(!report.has_errors(), "{report}");
}

/// A bottom-level serialized header with one opacity-micromap block holding `address`.
fn header_naming(address: u64) -> Vec<u8> {
    let mut bytes = vec![0u8; 48];
    bytes.extend_from_slice(&((0xFFFF_FFFFu64 << 32) | 1).to_le_bytes());
    bytes.extend_from_slice(&[0u8; 8]);
    bytes.extend_from_slice(&1u64.to_le_bytes());
    bytes.extend_from_slice(&address.to_le_bytes());
    bytes
}

/// [`world`] where: BLAS was built (flags `flags`) with geometry 0 on
/// KHR_MICROMAP; KHR_MICROMAP and BLAS were serialized on the device; the
/// micromap was deserialized into DESERIALIZED_MICROMAP and the structure
/// into DESERIALIZED_BLAS from a header naming micromap `named`
/// (DESERIALIZED_MICROMAP or OTHER_MICROMAP); OTHER_MICROMAP holds what a
/// build in this run put there.
pub fn deserialized_world(named: u64, flags: u32) -> Validator {
    use ommcheck::state::{Buffer, MemoryBinding};
    let mut v = world();
    let state = v.state_mut();
    for (buffer, address, micromap) in [
        (OWN_STORAGE, OWN_STORAGE_ADDRESS, DESERIALIZED_MICROMAP),
        (OTHER_STORAGE, OTHER_STORAGE_ADDRESS, OTHER_MICROMAP),
    ] {
        state.buffers.insert(
            buffer,
            Buffer {
                size: 0x1_0000,
                usage: BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR,
                device_address: Some(address),
                memory: Some(MemoryBinding::default()),
                ..Default::default()
            },
        );
        state.acceleration_structures.insert(
            micromap,
            AccelerationStructure {
                ty: ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                buffer,
                size: 0x1000,
                address_range: Some((address, address + 0x1000)),
                ..Default::default()
            },
        );
    }
    let named_address = if named == OTHER_MICROMAP {
        OTHER_STORAGE_ADDRESS
    } else {
        OWN_STORAGE_ADDRESS
    };
    let mut input = state.buffers.get_mut(&INPUT).expect("fixture buffer");
    let mut contents = input.contents.as_deref().expect("contents").to_vec();
    let header = header_naming(named_address);
    let at = (SERIALIZED_BLAS - INPUT_ADDRESS) as usize;
    contents[at..at + header.len()].copy_from_slice(&header);
    input.contents = Some(ommcheck::Bytes::from(contents));
    drop(input);
    state.provenance.constructed(OTHER_MICROMAP);
    let original = BuildGeometryInfo {
        flags,
        ..device_blas(khr_into(KHR_MICROMAP))
    };
    no_errors(cmd_in_ref(&mut v, &[original]));
    let cb = command_buffer();
    for (src, dst) in [(KHR_MICROMAP, SERIALIZED_MICROMAP), (BLAS, SERIALIZED_BLAS)] {
        let info = CopyAccelerationStructureToMemoryInfo {
            src,
            dst,
            mode: COPY_MODE_SERIALIZE,
            ..Default::default()
        };
        no_errors(v.cmd_copy_acceleration_structure_to_memory(&cb, &info));
    }
    for (src, dst) in [
        (SERIALIZED_MICROMAP, DESERIALIZED_MICROMAP),
        (SERIALIZED_BLAS, DESERIALIZED_BLAS),
    ] {
        let info = CopyMemoryToAccelerationStructureInfo {
            src,
            dst,
            mode: COPY_MODE_DESERIALIZE,
            ..Default::default()
        };
        no_errors(v.cmd_copy_memory_to_acceleration_structure(&cb, &info));
    }
    v
}

fn cmd_in_ref(v: &mut Validator, infos: &[BuildGeometryInfo]) -> Report {
    v.cmd_build_acceleration_structures(&command_buffer(), infos, &ranges(infos))
}

/// A copy of DESERIALIZED_BLAS (`host`: on the host), whose header named `named`.
fn copy_deserialized(named: u64, host: bool) -> Report {
    let mut v = deserialized_world(named, allow_update());
    let info = CopyAccelerationStructureInfo {
        src: DESERIALIZED_BLAS,
        dst: NOT_A_MICROMAP,
        mode: COPY_MODE_CLONE,
        ..Default::default()
    };
    if host {
        v.copy_acceleration_structure(&info)
    } else {
        v.cmd_copy_acceleration_structure(&command_buffer(), &info)
    }
}

/// A serialization of DESERIALIZED_BLAS (`host`: on the host), whose header named `named`.
fn serialize_deserialized(named: u64, host: bool) -> Report {
    let mut v = deserialized_world(named, allow_update());
    let info = CopyAccelerationStructureToMemoryInfo {
        src: DESERIALIZED_BLAS,
        dst: if host {
            HOST_INDICES
        } else {
            INPUT_ADDRESS + 0x8000
        },
        mode: COPY_MODE_SERIALIZE,
        ..Default::default()
    };
    if host {
        v.copy_acceleration_structure_to_memory(&info)
    } else {
        v.cmd_copy_acceleration_structure_to_memory(&command_buffer(), &info)
    }
}

/// An update of DESERIALIZED_BLAS (originally built allowing updates but
/// not micromap updates) chaining `micromap` to geometry 0.
fn update_deserialized(
    micromap: u64,
    build: fn(Validator, &[BuildGeometryInfo]) -> Report,
) -> Report {
    let v = deserialized_world(DESERIALIZED_MICROMAP, allow_update());
    let update = BuildGeometryInfo {
        flags: allow_update(),
        mode: BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
        src_acceleration_structure: DESERIALIZED_BLAS,
        dst_acceleration_structure: DESERIALIZED_BLAS,
        ..device_blas(khr_into(micromap))
    };
    build(v, &[update])
}

fn provenance_cases() -> Vec<Case> {
    use ommcheck::vuids::vuid::{
        vkCmdCopyAccelerationStructureKHR as cmd_copy, vkCopyAccelerationStructureKHR as host_copy,
        VkCopyAccelerationStructureToMemoryInfoKHR as to_memory,
    };
    vec![
        case(
            cmd_copy::src_11634,
            || copy_deserialized(OTHER_MICROMAP, false),
            || copy_deserialized(DESERIALIZED_MICROMAP, false),
        ),
        case(
            host_copy::src_11587,
            || copy_deserialized(OTHER_MICROMAP, true),
            || copy_deserialized(DESERIALIZED_MICROMAP, true),
        ),
        case(
            to_memory::src_11582,
            || serialize_deserialized(OTHER_MICROMAP, false),
            || serialize_deserialized(DESERIALIZED_MICROMAP, true),
        ),
        case(
            cmd::micromap_11628,
            || update_deserialized(OTHER_MICROMAP, cmd_in),
            || update_deserialized(DESERIALIZED_MICROMAP, cmd_in),
        ),
        case(
            indirect::micromap_11628,
            || update_deserialized(OTHER_MICROMAP, indirect_in),
            || update_deserialized(DESERIALIZED_MICROMAP, indirect_in),
        ),
    ]
}

#[test]
fn what_a_deserialized_structure_references_is_decided_only_where_known() {
    use ommcheck::vuids::vuid::vkCmdCopyAccelerationStructureKHR as cmd_copy;
    // Both paths decide the rule.
    for named in [DESERIALIZED_MICROMAP, OTHER_MICROMAP] {
        let report = copy_deserialized(named, false);
        assert!(report.checked.contains(cmd_copy::src_11634), "{report}");
    }
    // The serialized micromap's bytes were never seen: its deserialization
    // holds unknown contents, so the copy says it could not tell.
    let mut v = deserialized_world(DESERIALIZED_MICROMAP, allow_update());
    let unknown = CopyMemoryToAccelerationStructureInfo {
        src: INPUT_ADDRESS + 0x9000,
        dst: DESERIALIZED_MICROMAP,
        mode: COPY_MODE_DESERIALIZE,
        ..Default::default()
    };
    no_errors(v.cmd_copy_memory_to_acceleration_structure(&command_buffer(), &unknown));
    let info = CopyAccelerationStructureInfo {
        src: DESERIALIZED_BLAS,
        dst: NOT_A_MICROMAP,
        mode: COPY_MODE_CLONE,
        ..Default::default()
    };
    let report = v.cmd_copy_acceleration_structure(&command_buffer(), &info);
    assert!(!report.has_errors(), "{report}");
    let finding = report.not_checked().next().expect("not checked");
    assert_eq!(
        finding.rule.as_str(),
        "OMMCHECK-not-checked-serialization-not-seen"
    );
    // A structure deserialized from bytes no serialization wrote: not checked either.
    let mut v = world();
    let from_file = CopyMemoryToAccelerationStructureInfo {
        src: INPUT_ADDRESS + 0x9000,
        dst: BLAS,
        mode: COPY_MODE_DESERIALIZE,
        ..Default::default()
    };
    v.cmd_copy_memory_to_acceleration_structure(&command_buffer(), &from_file);
    let report = v.cmd_copy_acceleration_structure(
        &command_buffer(),
        &CopyAccelerationStructureInfo { src: BLAS, ..info },
    );
    assert!(!report.has_errors(), "{report}");
    assert_eq!(report.not_checked().count(), 1, "{report}");
}

#[test]
fn an_update_replaces_what_a_deserialized_structure_must_reference() {
    use ommcheck::vuids::vuid::vkCmdCopyAccelerationStructureKHR as cmd_copy;
    // Originally built allowing micromap updates: the update may chain any
    // micromap, and replaces the one the copy would ask about.
    let flags = allow_update()
        | khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR.as_raw();
    let mut v = deserialized_world(OTHER_MICROMAP, flags);
    let update = BuildGeometryInfo {
        flags,
        mode: BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
        src_acceleration_structure: DESERIALIZED_BLAS,
        dst_acceleration_structure: DESERIALIZED_BLAS,
        ..device_blas(khr_into(OTHER_MICROMAP))
    };
    no_errors(cmd_in_ref(&mut v, &[update]));
    let info = CopyAccelerationStructureInfo {
        src: DESERIALIZED_BLAS,
        dst: NOT_A_MICROMAP,
        mode: COPY_MODE_CLONE,
        ..Default::default()
    };
    let report = v.cmd_copy_acceleration_structure(&command_buffer(), &info);
    assert!(report.findings.is_empty(), "{report}");
    assert!(report.checked.contains(cmd_copy::src_11634), "{report}");
}
