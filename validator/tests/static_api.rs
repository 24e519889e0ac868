//! The safe static API (`ommcheck::fixture`, `ommcheck::acceleration_builds`):
//! each entry point with a passing and a failing case, and the same
//! findings as the raw readers give for the same build written as ash
//! structures with their pointers.

use ash::vk;
use ommcheck::acceleration_builds::{AccelerationStructureBuild, TrianglesGeometry};
use ommcheck::fixture::{packed_triangles, Fixture};
use ommcheck::model::CommandBuffer;
use ommcheck::vuids::khr;
use ommcheck::{rules, Report};

const FORMAT_4_STATE: vk::OpacityMicromapFormatEXT = vk::OpacityMicromapFormatEXT::TYPE_4_STATE;

/// Usage counts of two level-1 4-state triangles, each referenced once.
const USAGE: [vk::MicromapUsageEXT; 1] = [vk::MicromapUsageEXT {
    count: 2,
    subdivision_level: 1,
    format: 2,
}];

fn range(primitive_count: u32) -> vk::AccelerationStructureBuildRangeInfoKHR {
    vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(primitive_count)
}

/// A fixture with a built two-triangle micromap, the opacity indices in a
/// buffer, an attachment naming both (EXT or KHR), and what a BLAS build
/// over two triangles needs.
struct World<Attachment> {
    f: Fixture,
    blas: vk::AccelerationStructureKHR,
    scratch: u64,
    triangles: vk::AccelerationStructureGeometryTrianglesDataKHR<'static>,
    opacity: Attachment,
}

type ExtAttachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT<'static>;
type KhrAttachment = khr::AccelerationStructureTrianglesOpacityMicromapKHR;

/// [`World`] around the attachment `attach` makes of the index buffer.
fn world<A>(f: Fixture, attach: impl FnOnce(&mut Fixture) -> A) -> World<A> {
    let mut f = f;
    let opacity = attach(&mut f);
    let (triangles, blas, scratch) = (f.vertices(2), f.blas(), f.scratch());
    World {
        f,
        blas,
        scratch,
        triangles,
        opacity,
    }
}

fn ext_world(indices: [u32; 2]) -> World<ExtAttachment> {
    world(Fixture::new(), |f| {
        let micromap = f.micromap(&packed_triangles(2, 1, FORMAT_4_STATE));
        vk::AccelerationStructureTrianglesOpacityMicromapEXT::default()
            .index_type(vk::IndexType::UINT32)
            .index_buffer(f.input(&indices).at(0))
            .index_stride(4)
            .micromap(micromap)
    })
}

fn khr_world(indices: [u32; 2]) -> World<KhrAttachment> {
    world(Fixture::new(), |f| {
        let micromap = f.micromap_khr(&packed_triangles(2, 1, FORMAT_4_STATE));
        khr::AccelerationStructureTrianglesOpacityMicromapKHR::default()
            .index_type(vk::IndexType::UINT32)
            .index_buffer(f.input(&indices).address)
            .index_stride(4)
            .micromap(micromap)
    })
}

/// The safe device build of `geometry` into the world's BLAS.
fn safe_build<A>(world: &mut World<A>, geometry: TrianglesGeometry) -> Report {
    let build = AccelerationStructureBuild::bottom_level(world.blas, world.scratch)
        .triangles(geometry, range(2));
    world
        .f
        .cmd_build_acceleration_structures_from(&CommandBuffer::default(), &[build])
}

/// The same build through the raw reader: `triangles` with its pNext chain
/// in ash structures, `scratch` a device or host address.
fn raw_info<'a>(
    blas: vk::AccelerationStructureKHR,
    scratch: u64,
    geometries: &'a [vk::AccelerationStructureGeometryKHR<'a>],
) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
    vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
        .dst_acceleration_structure(blas)
        .geometries(geometries)
        .scratch_data(vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        })
}

fn triangles_geometry(
    triangles: vk::AccelerationStructureGeometryTrianglesDataKHR<'_>,
) -> [vk::AccelerationStructureGeometryKHR<'_>; 1] {
    [vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })]
}

fn raw_build<A>(
    world: &mut World<A>,
    triangles: vk::AccelerationStructureGeometryTrianglesDataKHR<'_>,
) -> Report {
    let geometries = triangles_geometry(triangles);
    let info = raw_info(world.blas, world.scratch, &geometries);
    let range = range(2);
    // SAFETY: every pointer in `info` points to locals that outlive the call.
    unsafe {
        world
            .f
            .cmd_build_acceleration_structures_ash(&CommandBuffer::default(), &[info], &[&range])
    }
}

fn ext_safe(world: &mut World<ExtAttachment>) -> Report {
    let geometry = TrianglesGeometry::new(&world.triangles).opacity_ext(&world.opacity, &USAGE);
    safe_build(world, geometry)
}

fn ext_raw(world: &mut World<ExtAttachment>) -> Report {
    let mut opacity = world.opacity.usage_counts(&USAGE);
    let triangles = world.triangles.push_next(&mut opacity);
    raw_build(world, triangles)
}

fn khr_safe(world: &mut World<KhrAttachment>) -> Report {
    let geometry = TrianglesGeometry::new(&world.triangles).opacity_khr(&world.opacity);
    safe_build(world, geometry)
}

fn khr_raw(world: &mut World<KhrAttachment>) -> Report {
    let mut opacity = world.opacity;
    let triangles = world.triangles.push_next(&mut opacity);
    raw_build(world, triangles)
}

/// `build([0, 1])` is clean and checked in full; `build([0, 2])` finds
/// index 2 past the micromap's two triangles, and nothing else.
fn assert_index_past_the_micromap_is_caught(build: impl Fn([u32; 2]) -> Report) {
    let valid = build([0, 1]);
    valid.assert_fully_checked();
    assert!(valid.is_empty(), "{valid}");

    let faulty = build([0, 2]);
    faulty.assert_fully_checked();
    assert_eq!(faulty.ids(), [rules::INDEX_IN_RANGE.id]);
}

/// The safe and the raw entry points report the same for the same build.
fn assert_same_findings(safe: impl Fn([u32; 2]) -> Report, raw: impl Fn([u32; 2]) -> Report) {
    for indices in [[0, 1], [0, 2], [7, 9]] {
        let (safe, raw) = (safe(indices), raw(indices));
        assert_eq!(safe.findings, raw.findings, "indices {indices:?}");
        assert_eq!(safe.checked, raw.checked, "indices {indices:?}");
    }
}

#[test]
fn ext_blas_build_index_past_the_micromap() {
    assert_index_past_the_micromap_is_caught(|indices| ext_safe(&mut ext_world(indices)));
}

#[test]
fn ext_safe_and_raw_builds_find_the_same() {
    assert_same_findings(
        |indices| ext_safe(&mut ext_world(indices)),
        |indices| ext_raw(&mut ext_world(indices)),
    );
}

#[test]
fn khr_blas_build_index_past_the_micromap() {
    assert_index_past_the_micromap_is_caught(|indices| khr_safe(&mut khr_world(indices)));
}

#[test]
fn khr_safe_and_raw_builds_find_the_same() {
    assert_same_findings(
        |indices| khr_safe(&mut khr_world(indices)),
        |indices| khr_raw(&mut khr_world(indices)),
    );
}

/// `vkBuildAccelerationStructuresKHR` with the opacity indices in
/// described host memory, through the safe or the raw entry point.
fn host_build(indices: [u32; 2], raw: bool) -> Report {
    let mut world = ext_world([0, 1]);
    let (vertices, scratch) = ([0u32; 18], [0u8; 4096]);
    let f = &mut world.f;
    let index_address = f.describe_host_memory(&indices);
    let vertex_address = f.describe_host_memory(&vertices);
    world.scratch = f.describe_host_memory(&scratch);
    let host = |address| vk::DeviceOrHostAddressConstKHR {
        device_address: address,
    };
    let opacity = world.opacity.index_buffer(host(index_address));
    let triangles = world.triangles.vertex_data(host(vertex_address));
    if !raw {
        let geometry = TrianglesGeometry::new(&triangles).opacity_ext(&opacity, &USAGE);
        let build = AccelerationStructureBuild::bottom_level(world.blas, world.scratch)
            .triangles(geometry, range(2));
        return world.f.build_acceleration_structures_from(&[build]);
    }
    let mut opacity = opacity.usage_counts(&USAGE);
    let geometries = triangles_geometry(triangles.push_next(&mut opacity));
    let info = raw_info(world.blas, world.scratch, &geometries);
    let range = range(2);
    // SAFETY: every pointer in `info` points to the locals above, and the
    // index buffer holds primitiveCount indices.
    unsafe {
        world
            .f
            .build_acceleration_structures_ash(&[info], &[&range])
    }
}

#[test]
fn host_blas_build_index_past_the_micromap() {
    assert_index_past_the_micromap_is_caught(|indices| host_build(indices, false));
    assert_same_findings(
        |indices| host_build(indices, false),
        |indices| host_build(indices, true),
    );
}

#[test]
fn a_micromap_geometry_with_a_build_range_is_caught() {
    // Micromap geometry takes no build range (11544); `geometry` adds any
    // geometry of the owned model, here with a range it must not have.
    let mut f = Fixture::new();
    let micromap = f.micromap_khr(&packed_triangles(1, 0, FORMAT_4_STATE));
    let usage = [khr::MicromapUsageKHR::default()
        .count(1)
        .format(khr::OPACITY_MICROMAP_FORMAT_4_STATE_KHR)];
    let data =
        khr::AccelerationStructureGeometryMicromapDataKHR::default().triangle_array_stride(8);
    let scratch = f.scratch();
    let valid = AccelerationStructureBuild::opacity_micromap(micromap, scratch)
        .micromap_data(&data, &usage);
    let (info, ranges) = valid.model();
    assert!(
        ranges.is_none(),
        "micromap geometry leaves ppBuildRangeInfos[i] NULL"
    );
    let geometry = info.geometries.as_ref().expect("pGeometries")[0].clone();
    let faulty = AccelerationStructureBuild::opacity_micromap(micromap, scratch)
        .geometry(geometry, Some(Default::default()));
    let report = f.cmd_build_acceleration_structures_from(&CommandBuffer::default(), &[faulty]);
    let rule = ommcheck::vuids::vuid::vkCmdBuildAccelerationStructuresKHR::ppBuildRangeInfos_11544;
    assert!(report.contains(rule), "{report}");
}

#[test]
#[should_panic(expected = "fixture set-up: vkCmdBuildMicromapsEXT reported findings")]
fn a_fixture_micromap_of_an_unknown_format_panics_with_the_report() {
    let mut f = Fixture::new();
    let triangle = vk::MicromapTriangleEXT {
        data_offset: 0,
        subdivision_level: 1,
        format: 9,
    };
    f.micromap(&[triangle]);
}

#[test]
fn a_khr_micromap_created_from_the_generated_create_info() {
    let mut f = Fixture::new();
    let storage = f.buffer(
        4096,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
    );
    let range = khr::DeviceAddressRangeKHR {
        address: storage.address,
        size: 4096,
    };
    let info = khr::AccelerationStructureCreateInfo2KHR::default()
        .address_range(range)
        .ty(khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR);
    let micromap = f.handle();
    let valid = f.create_acceleration_structure2_from(&info, micromap);
    valid.assert_fully_checked();
    assert!(valid.is_empty(), "{valid}");

    let motion = info.create_flags(vk::AccelerationStructureCreateFlagsKHR::MOTION_NV);
    let faulty = f.create_acceleration_structure2_from(&motion, vk::Handle::from_raw(0x77));
    let rule = ommcheck::vuids::vuid::VkAccelerationStructureCreateInfo2KHR::createFlags_11611;
    assert_eq!(faulty.ids(), [rule.id()]);
}

#[test]
fn a_query_pool_created_from_its_create_info_decides_the_query_rules() {
    use ommcheck::model::micromap_objects::MicromapList;
    let mut f = Fixture::new();
    let micromap = f.micromap(&packed_triangles(1, 0, FORMAT_4_STATE));
    let query_type = vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT;
    let pool = f.handle::<vk::QueryPool>();
    let info = vk::QueryPoolCreateInfo::default()
        .query_type(query_type)
        .query_count(1);
    f.create_query_pool_from(&info, pool);
    let mut write = |query_type: vk::QueryType| {
        f.cmd_write_micromaps_properties(
            &CommandBuffer::default(),
            &MicromapList::of(vec![vk::Handle::as_raw(micromap)]),
            query_type.as_raw(),
            vk::Handle::as_raw(pool),
            0,
        )
    };
    let valid = write(query_type);
    assert!(valid.is_empty(), "{valid}");
    let faulty = write(vk::QueryType::MICROMAP_COMPACTED_SIZE_EXT);
    let rule = ommcheck::vuids::vuid::vkCmdWriteMicromapsPropertiesEXT::queryPool_07525;
    assert!(faulty.contains(rule), "{faulty}");
}

/// What was not checked shows in a report's defaults: its text prints the
/// not-checked information (a report filters no severity), its summary
/// counts the rules, and the report is not empty, so a test asserting
/// `report.is_empty()` fails instead of passing in silence.
#[test]
fn rules_not_checked_show_in_a_reports_text_and_summary() {
    use ommcheck::model::{MicromapBuildInfo, MicromapUsage, UsageCounts};
    use ommcheck::{Device, Validator};

    let mut v = Validator::new(Device::default());
    let build = MicromapBuildInfo {
        usage_counts: UsageCounts::array(vec![MicromapUsage {
            count: 1,
            subdivision_level: 0,
            format: 2,
        }]),
        data: 0x1000,
        triangle_array: 0x2000,
        ..Default::default()
    };
    // No buffer was described: the triangle array cannot be read.
    let report = v.cmd_build_micromaps(&CommandBuffer::default(), &[build]);
    assert!(!report.is_empty());
    let text = report.to_string();
    assert!(
        text.contains("Validation Information: [ OMMCHECK-not-checked-"),
        "{text}"
    );
    assert!(
        text.contains(rules::TRIANGLE_DATA_RANGE.id),
        "the rule not checked is named: {text}"
    );
    let summary = report.summary();
    assert!(summary.rules_not_checked > 0, "{summary:?}");
    assert!(
        summary
            .to_string()
            .ends_with(&format!(", {} not checked", summary.rules_not_checked)),
        "{summary}"
    );
    assert!(report.require_fully_checked().is_err());
}
