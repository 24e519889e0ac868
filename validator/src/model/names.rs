//! Enum and flag values written by their specification names.
//!
//! Each table pairs a spec name with its value. Names of values that the
//! micromap extensions add are made from the identifiers of the generated
//! `ommcheck_vuids::khr` constants (`VK_` + identifier), so they cannot drift
//! from `vk.xml`; the other values come from ash's constants with their spec
//! name written beside them (a test checks each against ash's own name for
//! the value). Values neither provides (ash 0.38 predates them, and the
//! generator only emits the micromap extensions' own) come from the model's
//! vk.xml-derived constants; `HAND_WRITTEN` lists those names.

use std::fmt;
use std::marker::PhantomData;

use ash::vk;
use ommcheck_vuids::khr;
use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use crate::model::accel as model_accel;

/// One table entry: the spec name and the raw value.
pub type Entry = (&'static str, i64);

/// How wide the Vulkan type is, which bounds the numbers a scene may write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Repr {
    /// A 32-bit enum (`int32_t` in C).
    I32,
    /// `VkFlags`.
    U32,
    /// `VkFlags64`.
    U64,
}

impl Repr {
    fn fits(self, value: i128) -> bool {
        match self {
            Repr::I32 => i32::try_from(value).is_ok(),
            Repr::U32 => u32::try_from(value).is_ok(),
            Repr::U64 => u64::try_from(value).is_ok(),
        }
    }

    fn range(self) -> &'static str {
        match self {
            Repr::I32 => "a 32-bit signed integer",
            Repr::U32 => "a 32-bit unsigned integer",
            Repr::U64 => "a 64-bit unsigned integer",
        }
    }
}

/// A Vulkan enum or bitmask type a scene member holds.
pub trait Kind {
    /// The spec's type name, for messages and the schema.
    const TYPE_NAME: &'static str;
    const REPR: Repr;
    /// Whether values combine as bits (arrays and `A | B` are accepted).
    const BITMASK: bool;
    fn names() -> &'static [Entry];
}

/// `("VK_" + identifier, value)` of a generated KHR declaration.
macro_rules! k {
    ($name:ident) => {
        (
            concat!("VK_", stringify!($name)),
            khr::$name.as_raw() as i64,
        )
    };
}

/// `(spec name, value)` of an ash constant.
macro_rules! a {
    ($spec:literal, $ty:ident :: $value:ident) => {
        ($spec, vk::$ty::$value.as_raw() as i64)
    };
}

macro_rules! kind {
    ($(#[$doc:meta])* $kind:ident, $type_name:literal, $repr:ident, $bitmask:literal, [$($entry:expr),* $(,)?]) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $kind;
        impl Kind for $kind {
            const TYPE_NAME: &'static str = $type_name;
            const REPR: Repr = Repr::$repr;
            const BITMASK: bool = $bitmask;
            fn names() -> &'static [Entry] {
                static NAMES: &[Entry] = &[$($entry),*];
                NAMES
            }
        }
    };
}

kind!(
    StructureType,
    "VkStructureType",
    I32,
    false,
    [
        k!(STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT),
        k!(STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT),
        k!(STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT),
        k!(STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT),
        k!(STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT),
        k!(STRUCTURE_TYPE_COPY_MICROMAP_TO_MEMORY_INFO_EXT),
        k!(STRUCTURE_TYPE_COPY_MEMORY_TO_MICROMAP_INFO_EXT),
        k!(STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_2_KHR),
        k!(STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MICROMAP_DATA_KHR),
        k!(STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT),
        k!(STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_KHR),
        k!(STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_DISPLACEMENT_MICROMAP_NV),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_EXT),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_KHR),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_EXT),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_KHR),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_DISPLACEMENT_MICROMAP_FEATURES_NV),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_DISPLACEMENT_MICROMAP_PROPERTIES_NV),
        k!(STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_OPACITY_MICROMAP_FEATURES_ARM),
        a!(
            "VK_STRUCTURE_TYPE_PIPELINE_CREATE_FLAGS_2_CREATE_INFO_KHR",
            StructureType::PIPELINE_CREATE_FLAGS_2_CREATE_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_PIPELINE_LIBRARY_CREATE_INFO_KHR",
            StructureType::PIPELINE_LIBRARY_CREATE_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO",
            StructureType::SHADER_MODULE_CREATE_INFO
        ),
        (
            "VK_STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR",
            crate::model::pipeline::STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR as i64
        ),
        a!(
            "VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR",
            StructureType::PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR",
            StructureType::PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR",
            StructureType::ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR",
            StructureType::ACCELERATION_STRUCTURE_GEOMETRY_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR",
            StructureType::ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR",
            StructureType::ACCELERATION_STRUCTURE_GEOMETRY_AABBS_DATA_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR",
            StructureType::ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MOTION_TRIANGLES_DATA_NV",
            StructureType::ACCELERATION_STRUCTURE_GEOMETRY_MOTION_TRIANGLES_DATA_NV
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR",
            StructureType::ACCELERATION_STRUCTURE_CREATE_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR",
            StructureType::ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_INFO_KHR",
            StructureType::COPY_ACCELERATION_STRUCTURE_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_TO_MEMORY_INFO_KHR",
            StructureType::COPY_ACCELERATION_STRUCTURE_TO_MEMORY_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_COPY_MEMORY_TO_ACCELERATION_STRUCTURE_INFO_KHR",
            StructureType::COPY_MEMORY_TO_ACCELERATION_STRUCTURE_INFO_KHR
        ),
        a!(
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_MOTION_INFO_NV",
            StructureType::ACCELERATION_STRUCTURE_MOTION_INFO_NV
        ),
        a!(
            "VK_STRUCTURE_TYPE_OPAQUE_CAPTURE_DESCRIPTOR_DATA_CREATE_INFO_EXT",
            StructureType::OPAQUE_CAPTURE_DESCRIPTOR_DATA_CREATE_INFO_EXT
        ),
        a!(
            "VK_STRUCTURE_TYPE_MEMORY_BARRIER_2",
            StructureType::MEMORY_BARRIER_2
        ),
        (
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DENSE_GEOMETRY_FORMAT_TRIANGLES_DATA_AMDX",
            model_accel::STRUCTURE_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_DATA_AMDX as i64
        ),
        (
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_LINEAR_SWEPT_SPHERES_DATA_NV",
            model_accel::STRUCTURE_TYPE_GEOMETRY_LINEAR_SWEPT_SPHERES_DATA_NV as i64
        ),
        (
            "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_SPHERES_DATA_NV",
            model_accel::STRUCTURE_TYPE_GEOMETRY_SPHERES_DATA_NV as i64
        ),
    ]
);

kind!(
    MicromapType,
    "VkMicromapTypeEXT",
    I32,
    false,
    [
        a!(
            "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT",
            MicromapTypeEXT::OPACITY_MICROMAP
        ),
        k!(MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV),
    ]
);

kind!(
    BuildMicromapMode,
    "VkBuildMicromapModeEXT",
    I32,
    false,
    [a!(
        "VK_BUILD_MICROMAP_MODE_BUILD_EXT",
        BuildMicromapModeEXT::BUILD
    ),]
);

kind!(
    BuildMicromapFlags,
    "VkBuildMicromapFlagsEXT",
    U32,
    true,
    [
        a!(
            "VK_BUILD_MICROMAP_PREFER_FAST_TRACE_BIT_EXT",
            BuildMicromapFlagsEXT::PREFER_FAST_TRACE
        ),
        a!(
            "VK_BUILD_MICROMAP_PREFER_FAST_BUILD_BIT_EXT",
            BuildMicromapFlagsEXT::PREFER_FAST_BUILD
        ),
        a!(
            "VK_BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT",
            BuildMicromapFlagsEXT::ALLOW_COMPACTION
        ),
    ]
);

kind!(
    /// `VkOpacityMicromapFormatEXT` (and the KHR alias); NV displacement
    /// formats share the member and are accepted too.
    MicromapFormat, "VkOpacityMicromapFormatEXT", I32, false, [
    k!(OPACITY_MICROMAP_FORMAT_2_STATE_EXT),
    k!(OPACITY_MICROMAP_FORMAT_4_STATE_EXT),
    k!(OPACITY_MICROMAP_FORMAT_2_STATE_KHR),
    k!(OPACITY_MICROMAP_FORMAT_4_STATE_KHR),
    a!("VK_DISPLACEMENT_MICROMAP_FORMAT_64_TRIANGLES_64_BYTES_NV", DisplacementMicromapFormatNV::TYPE_64_TRIANGLES_64_BYTES),
    a!("VK_DISPLACEMENT_MICROMAP_FORMAT_256_TRIANGLES_128_BYTES_NV", DisplacementMicromapFormatNV::TYPE_256_TRIANGLES_128_BYTES),
    a!("VK_DISPLACEMENT_MICROMAP_FORMAT_1024_TRIANGLES_128_BYTES_NV", DisplacementMicromapFormatNV::TYPE_1024_TRIANGLES_128_BYTES),
]);

kind!(
    MicromapCreateFlags,
    "VkMicromapCreateFlagsEXT",
    U32,
    true,
    [a!(
        "VK_MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT",
        MicromapCreateFlagsEXT::DEVICE_ADDRESS_CAPTURE_REPLAY
    ),]
);

kind!(
    CopyMicromapMode,
    "VkCopyMicromapModeEXT",
    I32,
    false,
    [
        a!(
            "VK_COPY_MICROMAP_MODE_CLONE_EXT",
            CopyMicromapModeEXT::CLONE
        ),
        a!(
            "VK_COPY_MICROMAP_MODE_SERIALIZE_EXT",
            CopyMicromapModeEXT::SERIALIZE
        ),
        a!(
            "VK_COPY_MICROMAP_MODE_DESERIALIZE_EXT",
            CopyMicromapModeEXT::DESERIALIZE
        ),
        a!(
            "VK_COPY_MICROMAP_MODE_COMPACT_EXT",
            CopyMicromapModeEXT::COMPACT
        ),
    ]
);

kind!(
    QueryType,
    "VkQueryType",
    I32,
    false,
    [
        k!(QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT),
        k!(QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT),
        a!("VK_QUERY_TYPE_OCCLUSION", QueryType::OCCLUSION),
        a!(
            "VK_QUERY_TYPE_PIPELINE_STATISTICS",
            QueryType::PIPELINE_STATISTICS
        ),
        a!("VK_QUERY_TYPE_TIMESTAMP", QueryType::TIMESTAMP),
        a!(
            "VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR",
            QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR
        ),
        a!(
            "VK_QUERY_TYPE_ACCELERATION_STRUCTURE_SERIALIZATION_SIZE_KHR",
            QueryType::ACCELERATION_STRUCTURE_SERIALIZATION_SIZE_KHR
        ),
        a!(
            "VK_QUERY_TYPE_ACCELERATION_STRUCTURE_SERIALIZATION_BOTTOM_LEVEL_POINTERS_KHR",
            QueryType::ACCELERATION_STRUCTURE_SERIALIZATION_BOTTOM_LEVEL_POINTERS_KHR
        ),
        a!(
            "VK_QUERY_TYPE_ACCELERATION_STRUCTURE_SIZE_KHR",
            QueryType::ACCELERATION_STRUCTURE_SIZE_KHR
        ),
    ]
);

kind!(
    BuildType,
    "VkAccelerationStructureBuildTypeKHR",
    I32,
    false,
    [
        a!(
            "VK_ACCELERATION_STRUCTURE_BUILD_TYPE_HOST_KHR",
            AccelerationStructureBuildTypeKHR::HOST
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR",
            AccelerationStructureBuildTypeKHR::DEVICE
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_BUILD_TYPE_HOST_OR_DEVICE_KHR",
            AccelerationStructureBuildTypeKHR::HOST_OR_DEVICE
        ),
    ]
);

kind!(
    AccelerationStructureType,
    "VkAccelerationStructureTypeKHR",
    I32,
    false,
    [
        a!(
            "VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR",
            AccelerationStructureTypeKHR::TOP_LEVEL
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR",
            AccelerationStructureTypeKHR::BOTTOM_LEVEL
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_TYPE_GENERIC_KHR",
            AccelerationStructureTypeKHR::GENERIC
        ),
        k!(ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR),
    ]
);

kind!(
    BuildAccelerationStructureFlags,
    "VkBuildAccelerationStructureFlagsKHR",
    U32,
    true,
    [
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_UPDATE_BIT_KHR",
            BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_COMPACTION_BIT_KHR",
            BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR",
            BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_BUILD_BIT_KHR",
            BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_LOW_MEMORY_BIT_KHR",
            BuildAccelerationStructureFlagsKHR::LOW_MEMORY
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_MOTION_BIT_NV",
            BuildAccelerationStructureFlagsKHR::MOTION_NV
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_DATA_ACCESS_KHR",
            BuildAccelerationStructureFlagsKHR::ALLOW_DATA_ACCESS
        ),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_KHR),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_BIT_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_DISPLACEMENT_MICROMAP_UPDATE_BIT_NV),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_DISPLACEMENT_MICROMAP_UPDATE_NV),
        k!(BUILD_ACCELERATION_STRUCTURE_ALLOW_CLUSTER_OPACITY_MICROMAPS_BIT_NV),
        k!(BUILD_ACCELERATION_STRUCTURE_MICROMAP_LOSSY_BIT_KHR),
    ]
);

kind!(
    BuildAccelerationStructureMode,
    "VkBuildAccelerationStructureModeKHR",
    I32,
    false,
    [
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR",
            BuildAccelerationStructureModeKHR::BUILD
        ),
        a!(
            "VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR",
            BuildAccelerationStructureModeKHR::UPDATE
        ),
    ]
);

kind!(
    GeometryType,
    "VkGeometryTypeKHR",
    I32,
    false,
    [
        a!("VK_GEOMETRY_TYPE_TRIANGLES_KHR", GeometryTypeKHR::TRIANGLES),
        a!("VK_GEOMETRY_TYPE_AABBS_KHR", GeometryTypeKHR::AABBS),
        a!("VK_GEOMETRY_TYPE_INSTANCES_KHR", GeometryTypeKHR::INSTANCES),
        k!(GEOMETRY_TYPE_MICROMAP_KHR),
        (
            "VK_GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX",
            model_accel::GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX as i64
        ),
    ]
);

kind!(
    GeometryFlags,
    "VkGeometryFlagsKHR",
    U32,
    true,
    [
        a!("VK_GEOMETRY_OPAQUE_BIT_KHR", GeometryFlagsKHR::OPAQUE),
        a!(
            "VK_GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION_BIT_KHR",
            GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION
        ),
    ]
);

kind!(
    GeometryInstanceFlags,
    "VkGeometryInstanceFlagsKHR",
    U32,
    true,
    [
        a!(
            "VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR",
            GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE
        ),
        a!(
            "VK_GEOMETRY_INSTANCE_TRIANGLE_FLIP_FACING_BIT_KHR",
            GeometryInstanceFlagsKHR::TRIANGLE_FLIP_FACING
        ),
        a!(
            "VK_GEOMETRY_INSTANCE_FORCE_OPAQUE_BIT_KHR",
            GeometryInstanceFlagsKHR::FORCE_OPAQUE
        ),
        a!(
            "VK_GEOMETRY_INSTANCE_FORCE_NO_OPAQUE_BIT_KHR",
            GeometryInstanceFlagsKHR::FORCE_NO_OPAQUE
        ),
        k!(GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_BIT_EXT),
        k!(GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_BIT_KHR),
        k!(GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_EXT),
        k!(GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_EXT),
        k!(GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_KHR),
        k!(GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_EXT),
    ]
);

kind!(
    /// SPIR-V `RayFlags` (the `Rayflags` operand of `OpTraceRayKHR` and
    /// `OpRayQueryInitializeKHR`), by their SPIR-V names; the values are
    /// the SPIR-V specification's (no Vulkan header defines them).
    RayFlags,
    "RayFlags",
    U32,
    true,
    [
        ("NoneKHR", 0),
        ("OpaqueKHR", 0x1),
        ("NoOpaqueKHR", 0x2),
        ("TerminateOnFirstHitKHR", 0x4),
        ("SkipClosestHitShaderKHR", 0x8),
        ("CullBackFacingTrianglesKHR", 0x10),
        ("CullFrontFacingTrianglesKHR", 0x20),
        ("CullOpaqueKHR", 0x40),
        ("CullNoOpaqueKHR", 0x80),
        ("SkipTrianglesKHR", 0x100),
        ("SkipBuiltinPrimitivesNV", 0x100),
        ("SkipAABBsKHR", 0x200),
        ("ForceOpacityMicromap2StateEXT", 0x400),
        ("ForceOpacityMicromap2StateKHR", 0x400),
    ]
);

kind!(
    IndexType,
    "VkIndexType",
    I32,
    false,
    [
        a!("VK_INDEX_TYPE_UINT16", IndexType::UINT16),
        a!("VK_INDEX_TYPE_UINT32", IndexType::UINT32),
        a!("VK_INDEX_TYPE_NONE_KHR", IndexType::NONE_KHR),
        a!("VK_INDEX_TYPE_UINT8_EXT", IndexType::UINT8_EXT),
        a!("VK_INDEX_TYPE_UINT8_KHR", IndexType::UINT8_KHR),
        a!("VK_INDEX_TYPE_UINT8", IndexType::UINT8_EXT),
    ]
);

kind!(
    Format,
    "VkFormat",
    I32,
    false,
    [
        a!("VK_FORMAT_UNDEFINED", Format::UNDEFINED),
        a!("VK_FORMAT_R32G32B32_SFLOAT", Format::R32G32B32_SFLOAT),
        a!("VK_FORMAT_R32G32_SFLOAT", Format::R32G32_SFLOAT),
        a!("VK_FORMAT_R16G16B16A16_SFLOAT", Format::R16G16B16A16_SFLOAT),
        a!("VK_FORMAT_R16G16_SFLOAT", Format::R16G16_SFLOAT),
        a!("VK_FORMAT_R16G16_SNORM", Format::R16G16_SNORM),
        a!("VK_FORMAT_R16G16B16A16_SNORM", Format::R16G16B16A16_SNORM),
        a!("VK_FORMAT_R16G16B16A16_UNORM", Format::R16G16B16A16_UNORM),
        a!("VK_FORMAT_R16G16_UNORM", Format::R16G16_UNORM),
        a!("VK_FORMAT_R8G8B8A8_UNORM", Format::R8G8B8A8_UNORM),
        a!("VK_FORMAT_R8G8B8A8_SNORM", Format::R8G8B8A8_SNORM),
        a!(
            "VK_FORMAT_A2B10G10R10_UNORM_PACK32",
            Format::A2B10G10R10_UNORM_PACK32
        ),
    ]
);

kind!(
    /// `VkBufferUsageFlags2` (a superset of `VkBufferUsageFlags`; the
    /// checker tracks the 64-bit form).
    BufferUsageFlags, "VkBufferUsageFlags2", U64, true, [
    a!("VK_BUFFER_USAGE_TRANSFER_SRC_BIT", BufferUsageFlags::TRANSFER_SRC),
    a!("VK_BUFFER_USAGE_TRANSFER_DST_BIT", BufferUsageFlags::TRANSFER_DST),
    a!("VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT", BufferUsageFlags::UNIFORM_TEXEL_BUFFER),
    a!("VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT", BufferUsageFlags::STORAGE_TEXEL_BUFFER),
    a!("VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT", BufferUsageFlags::UNIFORM_BUFFER),
    a!("VK_BUFFER_USAGE_STORAGE_BUFFER_BIT", BufferUsageFlags::STORAGE_BUFFER),
    a!("VK_BUFFER_USAGE_INDEX_BUFFER_BIT", BufferUsageFlags::INDEX_BUFFER),
    a!("VK_BUFFER_USAGE_VERTEX_BUFFER_BIT", BufferUsageFlags::VERTEX_BUFFER),
    a!("VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT", BufferUsageFlags::INDIRECT_BUFFER),
    a!("VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT", BufferUsageFlags::SHADER_DEVICE_ADDRESS),
    a!("VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR", BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR),
    a!("VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR", BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR),
    a!("VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR", BufferUsageFlags::SHADER_BINDING_TABLE_KHR),
    k!(BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT),
    k!(BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT),
    k!(BUFFER_USAGE_2_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT),
    k!(BUFFER_USAGE_2_MICROMAP_STORAGE_BIT_EXT),
]);

kind!(
    BufferCreateFlags,
    "VkBufferCreateFlags",
    U32,
    true,
    [
        a!(
            "VK_BUFFER_CREATE_SPARSE_BINDING_BIT",
            BufferCreateFlags::SPARSE_BINDING
        ),
        a!(
            "VK_BUFFER_CREATE_SPARSE_RESIDENCY_BIT",
            BufferCreateFlags::SPARSE_RESIDENCY
        ),
        a!(
            "VK_BUFFER_CREATE_SPARSE_ALIASED_BIT",
            BufferCreateFlags::SPARSE_ALIASED
        ),
        a!(
            "VK_BUFFER_CREATE_PROTECTED_BIT",
            BufferCreateFlags::PROTECTED
        ),
        a!(
            "VK_BUFFER_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT",
            BufferCreateFlags::DEVICE_ADDRESS_CAPTURE_REPLAY
        ),
    ]
);

kind!(
    AccelerationStructureCreateFlags,
    "VkAccelerationStructureCreateFlagsKHR",
    U32,
    true,
    [
        a!(
            "VK_ACCELERATION_STRUCTURE_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_KHR",
            AccelerationStructureCreateFlagsKHR::DEVICE_ADDRESS_CAPTURE_REPLAY
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_CREATE_DESCRIPTOR_BUFFER_CAPTURE_REPLAY_BIT_EXT",
            AccelerationStructureCreateFlagsKHR::DESCRIPTOR_BUFFER_CAPTURE_REPLAY_EXT
        ),
        a!(
            "VK_ACCELERATION_STRUCTURE_CREATE_MOTION_BIT_NV",
            AccelerationStructureCreateFlagsKHR::MOTION_NV
        ),
    ]
);

kind!(
    AddressCommandFlags,
    "VkAddressCommandFlagsKHR",
    U32,
    true,
    [
        k!(ADDRESS_COMMAND_FULLY_BOUND_BIT_KHR),
        k!(ADDRESS_COMMAND_PROTECTED_BIT_KHR),
        k!(ADDRESS_COMMAND_STORAGE_BUFFER_USAGE_BIT_KHR),
        k!(ADDRESS_COMMAND_UNKNOWN_STORAGE_BUFFER_USAGE_BIT_KHR),
    ]
);

kind!(
    CopyAccelerationStructureMode,
    "VkCopyAccelerationStructureModeKHR",
    I32,
    false,
    [
        a!(
            "VK_COPY_ACCELERATION_STRUCTURE_MODE_CLONE_KHR",
            CopyAccelerationStructureModeKHR::CLONE
        ),
        a!(
            "VK_COPY_ACCELERATION_STRUCTURE_MODE_COMPACT_KHR",
            CopyAccelerationStructureModeKHR::COMPACT
        ),
        a!(
            "VK_COPY_ACCELERATION_STRUCTURE_MODE_SERIALIZE_KHR",
            CopyAccelerationStructureModeKHR::SERIALIZE
        ),
        a!(
            "VK_COPY_ACCELERATION_STRUCTURE_MODE_DESERIALIZE_KHR",
            CopyAccelerationStructureModeKHR::DESERIALIZE
        ),
    ]
);

kind!(
    QueueFlags,
    "VkQueueFlags",
    U32,
    true,
    [
        a!("VK_QUEUE_GRAPHICS_BIT", QueueFlags::GRAPHICS),
        a!("VK_QUEUE_COMPUTE_BIT", QueueFlags::COMPUTE),
        a!("VK_QUEUE_TRANSFER_BIT", QueueFlags::TRANSFER),
        a!("VK_QUEUE_SPARSE_BINDING_BIT", QueueFlags::SPARSE_BINDING),
        a!("VK_QUEUE_PROTECTED_BIT", QueueFlags::PROTECTED),
    ]
);

kind!(
    PipelineStageFlags2,
    "VkPipelineStageFlags2",
    U64,
    true,
    [
        a!("VK_PIPELINE_STAGE_2_NONE", PipelineStageFlags2::NONE),
        a!(
            "VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT",
            PipelineStageFlags2::TOP_OF_PIPE
        ),
        a!(
            "VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT",
            PipelineStageFlags2::DRAW_INDIRECT
        ),
        a!(
            "VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT",
            PipelineStageFlags2::VERTEX_INPUT
        ),
        a!(
            "VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT",
            PipelineStageFlags2::VERTEX_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_TESSELLATION_CONTROL_SHADER_BIT",
            PipelineStageFlags2::TESSELLATION_CONTROL_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_TESSELLATION_EVALUATION_SHADER_BIT",
            PipelineStageFlags2::TESSELLATION_EVALUATION_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_GEOMETRY_SHADER_BIT",
            PipelineStageFlags2::GEOMETRY_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT",
            PipelineStageFlags2::FRAGMENT_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT",
            PipelineStageFlags2::COMPUTE_SHADER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT",
            PipelineStageFlags2::ALL_TRANSFER
        ),
        a!(
            "VK_PIPELINE_STAGE_2_BOTTOM_OF_PIPE_BIT",
            PipelineStageFlags2::BOTTOM_OF_PIPE
        ),
        a!("VK_PIPELINE_STAGE_2_HOST_BIT", PipelineStageFlags2::HOST),
        a!(
            "VK_PIPELINE_STAGE_2_ALL_GRAPHICS_BIT",
            PipelineStageFlags2::ALL_GRAPHICS
        ),
        a!(
            "VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT",
            PipelineStageFlags2::ALL_COMMANDS
        ),
        a!("VK_PIPELINE_STAGE_2_COPY_BIT", PipelineStageFlags2::COPY),
        a!(
            "VK_PIPELINE_STAGE_2_PRE_RASTERIZATION_SHADERS_BIT",
            PipelineStageFlags2::PRE_RASTERIZATION_SHADERS
        ),
        a!(
            "VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR",
            PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR
        ),
        a!(
            "VK_PIPELINE_STAGE_2_RAY_TRACING_SHADER_BIT_KHR",
            PipelineStageFlags2::RAY_TRACING_SHADER_KHR
        ),
        a!(
            "VK_PIPELINE_STAGE_2_TASK_SHADER_BIT_EXT",
            PipelineStageFlags2::TASK_SHADER_EXT
        ),
        a!(
            "VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT",
            PipelineStageFlags2::MESH_SHADER_EXT
        ),
        a!(
            "VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_COPY_BIT_KHR",
            PipelineStageFlags2::ACCELERATION_STRUCTURE_COPY_KHR
        ),
        k!(PIPELINE_STAGE_2_MICROMAP_BUILD_BIT_EXT),
    ]
);

kind!(
    AccessFlags2,
    "VkAccessFlags2",
    U64,
    true,
    [
        a!("VK_ACCESS_2_NONE", AccessFlags2::NONE),
        a!(
            "VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT",
            AccessFlags2::INDIRECT_COMMAND_READ
        ),
        a!("VK_ACCESS_2_SHADER_READ_BIT", AccessFlags2::SHADER_READ),
        a!("VK_ACCESS_2_SHADER_WRITE_BIT", AccessFlags2::SHADER_WRITE),
        a!("VK_ACCESS_2_TRANSFER_READ_BIT", AccessFlags2::TRANSFER_READ),
        a!(
            "VK_ACCESS_2_TRANSFER_WRITE_BIT",
            AccessFlags2::TRANSFER_WRITE
        ),
        a!("VK_ACCESS_2_HOST_READ_BIT", AccessFlags2::HOST_READ),
        a!("VK_ACCESS_2_HOST_WRITE_BIT", AccessFlags2::HOST_WRITE),
        a!("VK_ACCESS_2_MEMORY_READ_BIT", AccessFlags2::MEMORY_READ),
        a!("VK_ACCESS_2_MEMORY_WRITE_BIT", AccessFlags2::MEMORY_WRITE),
        a!(
            "VK_ACCESS_2_SHADER_SAMPLED_READ_BIT",
            AccessFlags2::SHADER_SAMPLED_READ
        ),
        a!(
            "VK_ACCESS_2_SHADER_STORAGE_READ_BIT",
            AccessFlags2::SHADER_STORAGE_READ
        ),
        a!(
            "VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT",
            AccessFlags2::SHADER_STORAGE_WRITE
        ),
        a!(
            "VK_ACCESS_2_ACCELERATION_STRUCTURE_READ_BIT_KHR",
            AccessFlags2::ACCELERATION_STRUCTURE_READ_KHR
        ),
        a!(
            "VK_ACCESS_2_ACCELERATION_STRUCTURE_WRITE_BIT_KHR",
            AccessFlags2::ACCELERATION_STRUCTURE_WRITE_KHR
        ),
        k!(ACCESS_2_MICROMAP_READ_BIT_EXT),
        k!(ACCESS_2_MICROMAP_WRITE_BIT_EXT),
    ]
);

kind!(
    /// `VkPipelineCreateFlags` (the 32-bit `flags` of the create infos).
    PipelineCreateFlags,
    "VkPipelineCreateFlags",
    U32,
    true,
    [
        a!(
            "VK_PIPELINE_CREATE_DISABLE_OPTIMIZATION_BIT",
            PipelineCreateFlags::DISABLE_OPTIMIZATION
        ),
        a!("VK_PIPELINE_CREATE_LIBRARY_BIT_KHR", PipelineCreateFlags::LIBRARY_KHR),
        k!(PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_EXT),
        k!(PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR),
        k!(PIPELINE_CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_BIT_NV),
    ]
);

kind!(
    /// `VkPipelineCreateFlags2` (`VkPipelineCreateFlags2CreateInfo::flags`).
    PipelineCreateFlags2,
    "VkPipelineCreateFlags2",
    U64,
    true,
    [
        a!(
            "VK_PIPELINE_CREATE_2_DISABLE_OPTIMIZATION_BIT",
            PipelineCreateFlags2KHR::DISABLE_OPTIMIZATION
        ),
        a!("VK_PIPELINE_CREATE_2_LIBRARY_BIT_KHR", PipelineCreateFlags2KHR::LIBRARY),
        k!(PIPELINE_CREATE_2_RAY_TRACING_OPACITY_MICROMAP_BIT_EXT),
        k!(PIPELINE_CREATE_2_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR),
        k!(PIPELINE_CREATE_2_RAY_TRACING_DISPLACEMENT_MICROMAP_BIT_NV),
        k!(PIPELINE_CREATE_2_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_KHR),
        k!(PIPELINE_CREATE_2_DISALLOW_OPACITY_MICROMAP_BIT_ARM),
    ]
);

kind!(
    ShaderStageFlags,
    "VkShaderStageFlags",
    U32,
    true,
    [
        a!("VK_SHADER_STAGE_VERTEX_BIT", ShaderStageFlags::VERTEX),
        a!(
            "VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT",
            ShaderStageFlags::TESSELLATION_CONTROL
        ),
        a!(
            "VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT",
            ShaderStageFlags::TESSELLATION_EVALUATION
        ),
        a!("VK_SHADER_STAGE_GEOMETRY_BIT", ShaderStageFlags::GEOMETRY),
        a!("VK_SHADER_STAGE_FRAGMENT_BIT", ShaderStageFlags::FRAGMENT),
        a!("VK_SHADER_STAGE_COMPUTE_BIT", ShaderStageFlags::COMPUTE),
        a!(
            "VK_SHADER_STAGE_RAYGEN_BIT_KHR",
            ShaderStageFlags::RAYGEN_KHR
        ),
        a!(
            "VK_SHADER_STAGE_ANY_HIT_BIT_KHR",
            ShaderStageFlags::ANY_HIT_KHR
        ),
        a!(
            "VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR",
            ShaderStageFlags::CLOSEST_HIT_KHR
        ),
        a!("VK_SHADER_STAGE_MISS_BIT_KHR", ShaderStageFlags::MISS_KHR),
        a!(
            "VK_SHADER_STAGE_INTERSECTION_BIT_KHR",
            ShaderStageFlags::INTERSECTION_KHR
        ),
        a!(
            "VK_SHADER_STAGE_CALLABLE_BIT_KHR",
            ShaderStageFlags::CALLABLE_KHR
        ),
        a!("VK_SHADER_STAGE_TASK_BIT_EXT", ShaderStageFlags::TASK_EXT),
        a!("VK_SHADER_STAGE_MESH_BIT_EXT", ShaderStageFlags::MESH_EXT),
    ]
);

kind!(
    ShaderCreateFlags,
    "VkShaderCreateFlagsEXT",
    U32,
    true,
    [
        a!(
            "VK_SHADER_CREATE_LINK_STAGE_BIT_EXT",
            ShaderCreateFlagsEXT::LINK_STAGE
        ),
        k!(SHADER_CREATE_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_EXT),
    ]
);

kind!(
    ShaderCodeType,
    "VkShaderCodeTypeEXT",
    I32,
    false,
    [
        a!("VK_SHADER_CODE_TYPE_BINARY_EXT", ShaderCodeTypeEXT::BINARY),
        a!("VK_SHADER_CODE_TYPE_SPIRV_EXT", ShaderCodeTypeEXT::SPIRV),
    ]
);

kind!(
    PipelineBindPoint,
    "VkPipelineBindPoint",
    I32,
    false,
    [
        a!(
            "VK_PIPELINE_BIND_POINT_GRAPHICS",
            PipelineBindPoint::GRAPHICS
        ),
        a!("VK_PIPELINE_BIND_POINT_COMPUTE", PipelineBindPoint::COMPUTE),
        a!(
            "VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR",
            PipelineBindPoint::RAY_TRACING_KHR
        ),
        a!(
            "VK_PIPELINE_BIND_POINT_SUBPASS_SHADING_HUAWEI",
            PipelineBindPoint::SUBPASS_SHADING_HUAWEI
        ),
        a!(
            "VK_PIPELINE_BIND_POINT_EXECUTION_GRAPH_AMDX",
            PipelineBindPoint::EXECUTION_GRAPH_AMDX
        ),
    ]
);

kind!(
    /// `VkClusterAccelerationStructureIndexFormatFlagBitsNV`; values from vk.xml.
    ClusterIndexFormat,
    "VkClusterAccelerationStructureIndexFormatFlagsNV",
    U32,
    true,
    [
        (
            "VK_CLUSTER_ACCELERATION_STRUCTURE_INDEX_FORMAT_8BIT_NV",
            model_accel::CLUSTER_INDEX_FORMAT_8BIT_NV as i64
        ),
        (
            "VK_CLUSTER_ACCELERATION_STRUCTURE_INDEX_FORMAT_16BIT_NV",
            model_accel::CLUSTER_INDEX_FORMAT_16BIT_NV as i64
        ),
        (
            "VK_CLUSTER_ACCELERATION_STRUCTURE_INDEX_FORMAT_32BIT_NV",
            model_accel::CLUSTER_INDEX_FORMAT_32BIT_NV as i64
        ),
    ]
);

kind!(
    /// `VkClusterAccelerationStructureOpTypeNV`: the two operations whose
    /// inputs carry opacity micromaps; values from vk.xml.
    ClusterOpType,
    "VkClusterAccelerationStructureOpTypeNV",
    I32,
    false,
    [
        ("VK_CLUSTER_ACCELERATION_STRUCTURE_OP_TYPE_BUILD_TRIANGLE_CLUSTER_NV", 2),
        ("VK_CLUSTER_ACCELERATION_STRUCTURE_OP_TYPE_BUILD_TRIANGLE_CLUSTER_TEMPLATE_NV", 3),
    ]
);

/// Names whose values neither ash 0.38 nor the generated KHR declarations
/// provide; their values are the model's constants, taken from vk.xml of
/// Vulkan 1.4.360.
pub const HAND_WRITTEN: [&str; 5] = [
    "VK_STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR",
    "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DENSE_GEOMETRY_FORMAT_TRIANGLES_DATA_AMDX",
    "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_LINEAR_SWEPT_SPHERES_DATA_NV",
    "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_SPHERES_DATA_NV",
    "VK_GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX",
];

/// The value of `name` in `K`'s table. Every spelling vk.xml gives a value
/// is accepted: where `name`, or the table's own name for the value, is an
/// alias (`VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT_KHR`), the two match when
/// they stand for the same name.
pub fn lookup<K: Kind>(name: &str) -> Option<i64> {
    let names = K::names();
    if let Some((_, value)) = names.iter().find(|(entry, _)| *entry == name) {
        return Some(*value);
    }
    let unaliased = |name: &'static str| ommcheck_vuids::enum_alias_target(name).unwrap_or(name);
    let target = ommcheck_vuids::enum_alias_target(name);
    names
        .iter()
        .find(|(entry, _)| match target {
            Some(target) => unaliased(entry) == target,
            None => ommcheck_vuids::enum_alias_target(entry) == Some(name),
        })
        .map(|(_, value)| *value)
}

/// The first name `K`'s table gives `value`, if any.
pub fn name_of<K: Kind>(value: i64) -> Option<&'static str> {
    K::names()
        .iter()
        .find(|(_, v)| *v == value)
        .map(|(name, _)| *name)
}

/// A member holding a `K` value, written as its spec name or a number (and,
/// for a bitmask, as an array of those or `"A | B"`). The value is checked to
/// fit the Vulkan type when the scene is read.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Value<K> {
    raw: i64,
    kind: PhantomData<K>,
}

impl<K> fmt::Debug for Value<K> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.raw)
    }
}

impl<K: Kind> Value<K> {
    pub fn new(raw: i64) -> Self {
        Self {
            raw,
            kind: PhantomData,
        }
    }

    pub fn raw(self) -> i64 {
        self.raw
    }

    /// As a 32-bit enum (a value read from a scene fits its type).
    pub fn as_i32(self) -> i32 {
        i32::try_from(self.raw).unwrap_or_default()
    }

    pub fn as_u32(self) -> u32 {
        u32::try_from(self.raw).unwrap_or_default()
    }

    pub fn as_u64(self) -> u64 {
        u64::try_from(self.raw).unwrap_or_default()
    }

    /// For the 16-bit `format` member of a triangle entry in a buffer.
    pub fn as_u16(self) -> Option<u16> {
        u16::try_from(self.raw).ok()
    }
}

impl<K: Kind> Default for Value<K> {
    fn default() -> Self {
        Self::new(0)
    }
}

/// Parses one name or number of `K`; a bitmask also takes `A | B`.
fn parse_text<K: Kind>(text: &str) -> Result<i64, String> {
    if K::BITMASK && text.contains('|') {
        let mut bits: i64 = 0;
        for part in text.split('|') {
            bits |= parse_text::<K>(part.trim())?;
        }
        return Ok(bits);
    }
    if let Some(value) = lookup::<K>(text) {
        return Ok(value);
    }
    let number = if let Some(hex) = text.strip_prefix("0x") {
        i128::from_str_radix(hex, 16).ok()
    } else {
        text.parse::<i128>().ok()
    };
    if let Some(number) = number {
        return checked::<K>(number);
    }
    let names = K::names().iter().map(|(name, _)| *name);
    match crate::suggest::did_you_mean(text, names.clone(), 3) {
        Some(hint) => Err(format!("unknown {} name `{text}`; {hint}", K::TYPE_NAME)),
        None => Err(format!(
            "unknown {} name `{text}`; expected one of {}, or a number",
            K::TYPE_NAME,
            names.collect::<Vec<_>>().join(", ")
        )),
    }
}

fn checked<K: Kind>(number: i128) -> Result<i64, String> {
    if K::REPR.fits(number) {
        i64::try_from(number).map_err(|_| {
            format!(
                "{number} does not fit {}, {}",
                K::TYPE_NAME,
                K::REPR.range()
            )
        })
    } else {
        Err(format!(
            "{number} does not fit {}, {}",
            K::TYPE_NAME,
            K::REPR.range()
        ))
    }
}

struct ValueVisitor<K>(PhantomData<K>);

impl<'de, K: Kind> Visitor<'de> for ValueVisitor<K> {
    type Value = Value<K>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if K::BITMASK {
            write!(
                f,
                "a {} bit name, a number, or an array of them",
                K::TYPE_NAME
            )
        } else {
            write!(f, "a {} name or a number", K::TYPE_NAME)
        }
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        checked::<K>(i128::from(v))
            .map(Value::new)
            .map_err(E::custom)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        checked::<K>(i128::from(v))
            .map(Value::new)
            .map_err(E::custom)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        parse_text::<K>(v).map(Value::new).map_err(E::custom)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        if !K::BITMASK {
            return Err(de::Error::invalid_type(de::Unexpected::Seq, &self));
        }
        let mut bits: i64 = 0;
        while let Some(bit) = seq.next_element::<Value<K>>()? {
            bits |= bit.raw;
        }
        Ok(Value::new(bits))
    }
}

impl<'de, K: Kind> Deserialize<'de> for Value<K> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(ValueVisitor(PhantomData))
    }
}

impl<K: Kind> JsonSchema for Value<K> {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        K::TYPE_NAME.into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        let names: Vec<&str> = K::names().iter().map(|(name, _)| *name).collect();
        let name = json_schema!({ "type": "string", "enum": names });
        let description = if K::BITMASK {
            format!(
                "{}: bit names, `A | B`, a number, or an array of those",
                K::TYPE_NAME
            )
        } else {
            format!("{}: its spec name or a number", K::TYPE_NAME)
        };
        if K::BITMASK {
            json_schema!({
                "description": description,
                "anyOf": [
                    name,
                    { "type": "string", "pattern": "\\|" },
                    { "type": "integer" },
                    { "type": "array", "items": { "anyOf": [name, { "type": "integer" }] } }
                ]
            })
        } else {
            json_schema!({
                "description": description,
                "anyOf": [name, { "type": "integer" }]
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn from_json<K: Kind>(text: &str) -> Result<i64, String> {
        serde_json::from_str::<Value<K>>(text)
            .map(Value::raw)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn names_numbers_and_bit_combinations() {
        assert_eq!(
            from_json::<MicromapFormat>("\"VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT\""),
            Ok(2)
        );
        assert_eq!(from_json::<MicromapFormat>("2"), Ok(2));
        let usage = from_json::<BufferUsageFlags>(
            "[\"VK_BUFFER_USAGE_STORAGE_BUFFER_BIT\", \"VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT\"]",
        );
        assert_eq!(usage, Ok(0x20 | 0x20000));
        assert_eq!(
            from_json::<BufferUsageFlags>(
                "\"VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT\""
            ),
            usage
        );
        assert_eq!(from_json::<IndexType>("\"0x3b9d4e88\""), Ok(1_000_165_000));
    }

    #[test]
    fn unknown_names_and_overflows_say_what_was_expected() {
        let error =
            from_json::<MicromapFormat>("\"VK_OPACITY_MICROMAP_FORMAT_8_STATE_EXT\"").unwrap_err();
        assert!(
            error.contains("unknown VkOpacityMicromapFormatEXT name"),
            "{error}"
        );
        assert!(
            error.contains("VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT"),
            "{error}"
        );
        assert!(from_json::<BuildMicromapFlags>("4294967296").is_err());
        assert!(from_json::<MicromapType>("-1").is_ok());
        assert!(from_json::<BufferUsageFlags>("-1").is_err());
        assert!(from_json::<MicromapType>("[1]").is_err());
    }

    /// The hand-written spec names of ash values agree with ash's own name
    /// for the value (its Debug output drops the `VK_<TYPE>_` prefix and the
    /// `_BIT` part).
    #[test]
    fn ash_names_agree_with_ash() {
        fn check<K: Kind, T: fmt::Debug>(from_raw: impl Fn(i64) -> T) {
            for (name, value) in K::names() {
                if HAND_WRITTEN.contains(name) {
                    continue;
                }
                let ash_name = format!("{:?}", from_raw(*value));
                // Unknown values print as a number (bits of a 64-bit
                // flag type in binary).
                if ash_name.chars().all(|c| c.is_ascii_digit()) || ash_name.starts_with("0x") {
                    // ash 0.38 does not know the value: it comes from the
                    // generated declarations, named by their identifiers.
                    continue;
                }
                let strip_vendor = |text: &str| {
                    ["_EXT", "_KHR", "_NV"]
                        .iter()
                        .fold(text.to_string(), |t, v| t.trim_end_matches(v).to_string())
                };
                let spec_core = strip_vendor(&name.replace("_BIT", ""));
                let ash_core = strip_vendor(&ash_name.replace("TYPE_", ""));
                assert!(
                    spec_core.ends_with(&strip_vendor(&ash_name))
                        || spec_core.contains(&ash_core)
                        || ash_name.contains(" | "),
                    "{name} is {value}, which ash calls {ash_name}"
                );
            }
        }
        check::<StructureType, _>(|v| vk::StructureType::from_raw(v as i32));
        check::<MicromapType, _>(|v| vk::MicromapTypeEXT::from_raw(v as i32));
        check::<CopyMicromapMode, _>(|v| vk::CopyMicromapModeEXT::from_raw(v as i32));
        check::<QueryType, _>(|v| vk::QueryType::from_raw(v as i32));
        check::<AccelerationStructureType, _>(|v| {
            vk::AccelerationStructureTypeKHR::from_raw(v as i32)
        });
        check::<GeometryType, _>(|v| vk::GeometryTypeKHR::from_raw(v as i32));
        check::<Format, _>(|v| vk::Format::from_raw(v as i32));
        check::<BufferUsageFlags, _>(|v| vk::BufferUsageFlags::from_raw(v as u32));
        check::<BuildAccelerationStructureFlags, _>(|v| {
            vk::BuildAccelerationStructureFlagsKHR::from_raw(v as u32)
        });
        check::<CopyAccelerationStructureMode, _>(|v| {
            vk::CopyAccelerationStructureModeKHR::from_raw(v as i32)
        });
        check::<PipelineStageFlags2, _>(|v| vk::PipelineStageFlags2::from_raw(v as u64));
        check::<AccessFlags2, _>(|v| vk::AccessFlags2::from_raw(v as u64));
        check::<PipelineCreateFlags, _>(|v| vk::PipelineCreateFlags::from_raw(v as u32));
        check::<PipelineCreateFlags2, _>(|v| vk::PipelineCreateFlags2KHR::from_raw(v as u64));
        check::<ShaderStageFlags, _>(|v| vk::ShaderStageFlags::from_raw(v as u32));
        check::<ShaderCreateFlags, _>(|v| vk::ShaderCreateFlagsEXT::from_raw(v as u32));
        check::<ShaderCodeType, _>(|v| vk::ShaderCodeTypeEXT::from_raw(v as i32));
        check::<PipelineBindPoint, _>(|v| vk::PipelineBindPoint::from_raw(v as i32));
    }

    #[test]
    fn every_name_is_unique_within_its_kind() {
        fn unique<K: Kind>() {
            let mut names: Vec<&str> = K::names().iter().map(|(n, _)| *n).collect();
            names.sort_unstable();
            let len = names.len();
            names.dedup();
            assert_eq!(names.len(), len, "{}", K::TYPE_NAME);
        }
        unique::<StructureType>();
        unique::<BufferUsageFlags>();
        unique::<BuildAccelerationStructureFlags>();
        unique::<GeometryInstanceFlags>();
        unique::<RayFlags>();
        unique::<IndexType>();
        unique::<PipelineStageFlags2>();
        unique::<AccessFlags2>();
        unique::<PipelineCreateFlags>();
        unique::<PipelineCreateFlags2>();
        unique::<ShaderStageFlags>();
        unique::<ShaderCreateFlags>();
        unique::<ShaderCodeType>();
        unique::<PipelineBindPoint>();
        unique::<ClusterIndexFormat>();
        unique::<ClusterOpType>();
    }
}
