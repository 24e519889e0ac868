//! The generated KHR declarations agree with ash's EXT twins and chain into
//! ash structures.

use ash::vk;
use ommcheck_vuids::khr;

#[test]
fn usage_and_triangle_layouts_match_their_ext_twins() {
    assert_eq!(
        size_of::<khr::MicromapUsageKHR>(),
        size_of::<vk::MicromapUsageEXT>()
    );
    assert_eq!(
        align_of::<khr::MicromapUsageKHR>(),
        align_of::<vk::MicromapUsageEXT>()
    );
    assert_eq!(
        std::mem::offset_of!(khr::MicromapUsageKHR, format),
        std::mem::offset_of!(vk::MicromapUsageEXT, format)
    );
    // VkMicromapTriangleKHR is 4 bytes of dataOffset, then 2 + 2.
    assert_eq!(size_of::<khr::MicromapTriangleKHR>(), 8);
    assert_eq!(
        std::mem::offset_of!(khr::MicromapTriangleKHR, subdivision_level),
        4
    );
    assert_eq!(std::mem::offset_of!(khr::MicromapTriangleKHR, format), 6);
}

#[test]
fn constants_agree_with_ash_where_ash_has_them() {
    assert_eq!(
        khr::STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT,
        vk::StructureType::MICROMAP_BUILD_INFO_EXT
    );
    assert_eq!(
        khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT,
        vk::StructureType::ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT
    );
    assert_eq!(
        khr::OPACITY_MICROMAP_FORMAT_2_STATE_KHR,
        vk::OpacityMicromapFormatEXT::TYPE_2_STATE
    );
    assert_eq!(
        khr::OPACITY_MICROMAP_FORMAT_4_STATE_KHR,
        vk::OpacityMicromapFormatEXT::TYPE_4_STATE
    );
    assert_eq!(
        khr::OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_UNKNOWN_OPAQUE_KHR,
        vk::OpacityMicromapSpecialIndexEXT::FULLY_UNKNOWN_OPAQUE
    );
    assert_eq!(
        khr::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR,
        vk::BuildAccelerationStructureFlagsKHR::ALLOW_OPACITY_MICROMAP_UPDATE_EXT
    );
    assert_eq!(
        khr::PIPELINE_STAGE_2_MICROMAP_BUILD_BIT_EXT,
        vk::PipelineStageFlags2::MICROMAP_BUILD_EXT
    );
    assert_eq!(
        khr::ACCESS_2_MICROMAP_WRITE_BIT_EXT,
        vk::AccessFlags2::MICROMAP_WRITE_EXT
    );
}

#[test]
fn khr_values_ash_lacks() {
    // Values from vk.xml: extension 624's block starts at 1000623000.
    assert_eq!(
        khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_KHR.as_raw(),
        1_000_623_000
    );
    assert_eq!(
        khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MICROMAP_DATA_KHR.as_raw(),
        1_000_623_002
    );
    assert_eq!(
        khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR.as_raw(),
        1_000_623_000
    );
    assert_eq!(khr::GEOMETRY_TYPE_MICROMAP_KHR.as_raw(), 1_000_623_000);
    assert_eq!(
        khr::BUILD_ACCELERATION_STRUCTURE_MICROMAP_LOSSY_BIT_KHR.as_raw(),
        1 << 10
    );
    assert_eq!(
        khr::PIPELINE_CREATE_2_DISALLOW_OPACITY_MICROMAP_BIT_ARM.as_raw(),
        1 << 37
    );
    assert_eq!(
        khr::OPACITY_MICROMAP_SPECIAL_INDEX_CLUSTER_GEOMETRY_DISABLE_OPACITY_MICROMAP_NV.as_raw(),
        -5
    );
}

#[test]
fn defaults_carry_their_structure_type() {
    let data = khr::AccelerationStructureGeometryMicromapDataKHR::default();
    assert_eq!(
        data.s_type,
        khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MICROMAP_DATA_KHR
    );
    assert!(data.p_usage_counts.is_null() && data.pp_usage_counts.is_null());
    let features = khr::PhysicalDeviceOpacityMicromapFeaturesKHR::default();
    assert_eq!(
        features.s_type,
        <khr::PhysicalDeviceOpacityMicromapFeaturesKHR as vk::TaggedStructure>::STRUCTURE_TYPE
    );
}

#[test]
fn opacity_attachment_chains_into_ash_triangles() {
    let mut omm = khr::AccelerationStructureTrianglesOpacityMicromapKHR {
        index_type: vk::IndexType::UINT32,
        index_stride: 4,
        ..Default::default()
    };
    let triangles =
        vk::AccelerationStructureGeometryTrianglesDataKHR::default().push_next(&mut omm);
    let next = triangles.p_next.cast::<vk::BaseInStructure<'_>>();
    // SAFETY: push_next stored a pointer to `omm`, which outlives this read.
    let s_type = unsafe { (*next).s_type };
    assert_eq!(
        s_type,
        khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_KHR
    );
}

#[test]
fn builders_set_members_and_chain_with_push_next() {
    let usage = [khr::MicromapUsageKHR::default()
        .count(3)
        .subdivision_level(2)
        .format(khr::OPACITY_MICROMAP_FORMAT_4_STATE_KHR)];
    let data = khr::AccelerationStructureGeometryMicromapDataKHR::default()
        .usage_counts(&usage)
        .data(0x1000)
        .triangle_array(0x2000)
        .triangle_array_stride(8);
    assert_eq!(data.usage_counts_count, 1);
    assert_eq!(data.p_usage_counts, usage.as_ptr());
    assert!(data.pp_usage_counts.is_null());
    let pointers = [&usage[0]];
    let by_pointer = data.usage_counts_ptrs(&pointers);
    assert_eq!(by_pointer.pp_usage_counts, pointers.as_ptr().cast());

    let mut omm = khr::AccelerationStructureTrianglesOpacityMicromapKHR::default()
        .index_type(vk::IndexType::UINT32)
        .index_buffer(0x3000)
        .index_stride(4)
        .base_triangle(1)
        .micromap(<vk::AccelerationStructureKHR as vk::Handle>::from_raw(7));
    assert_eq!(
        (omm.index_buffer, omm.index_stride, omm.base_triangle),
        (0x3000, 4, 1)
    );
    let triangles =
        vk::AccelerationStructureGeometryTrianglesDataKHR::default().push_next(&mut omm);
    assert_eq!(triangles.p_next, (&raw mut omm).cast_const().cast());

    let features = khr::PhysicalDeviceOpacityMicromapFeaturesKHR::default().micromap(true);
    assert_eq!(features.micromap, vk::TRUE);
    let mut features = features;
    let device = vk::DeviceCreateInfo::default().push_next(&mut features);
    assert!(!device.p_next.is_null());
}
