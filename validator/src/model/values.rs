//! Raw values of the Vulkan enums and bits the checks compare against, named
//! as in the specification. Values ash 0.38 has come from ash; the others
//! from the generated `ommcheck_vuids::khr`.

use ash::vk;
use ommcheck_vuids::khr;

use super::names;

pub const MICROMAP_TYPE_OPACITY_MICROMAP_EXT: i32 = vk::MicromapTypeEXT::OPACITY_MICROMAP.as_raw();
pub const MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV: i32 =
    khr::MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV.as_raw();

pub const BUILD_MICROMAP_MODE_BUILD_EXT: i32 = vk::BuildMicromapModeEXT::BUILD.as_raw();

pub const OPACITY_MICROMAP_FORMAT_2_STATE: u32 = 1;
pub const OPACITY_MICROMAP_FORMAT_4_STATE: u32 = 2;

/// `VkDisplacementMicromapFormatNV` values: 64 triangles in 64 bytes, 256 in
/// 128, 1024 in 128.
pub const DISPLACEMENT_MICROMAP_FORMATS_NV: [u32; 3] = [1, 2, 3];

/// `VkBuildMicromapFlagBitsEXT`: PREFER_FAST_TRACE | PREFER_FAST_BUILD | ALLOW_COMPACTION.
pub const BUILD_MICROMAP_FLAGS_ALL: u32 = 0x7;
pub const BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT: u32 = 0x4;

pub const BUFFER_USAGE_STORAGE_BUFFER_BIT: u64 =
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw() as u64;
pub const BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT: u64 =
    khr::BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT.as_raw() as u64;
pub const BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT: u64 =
    khr::BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT.as_raw() as u64;
pub const BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR: u64 =
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw() as u64;
pub const BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR: u64 =
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR.as_raw() as u64;
pub const BUFFER_CREATE_SPARSE_RESIDENCY_BIT: u32 =
    vk::BufferCreateFlags::SPARSE_RESIDENCY.as_raw();

pub const STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT: i32 =
    vk::StructureType::MICROMAP_BUILD_INFO_EXT.as_raw();

/// Which enum a micromap format value belongs to: the micromap's type and
/// the extension whose spelling a message should use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatKind {
    /// `VkOpacityMicromapFormatEXT`
    OpacityExt,
    /// `VkOpacityMicromapFormatKHR` (the same values, KHR names)
    OpacityKhr,
    /// `VkDisplacementMicromapFormatNV`
    DisplacementNv,
}

impl FormatKind {
    /// The enumerant's name ([`format_name`]).
    pub fn name(self, format: u32) -> String {
        format_name(self, format)
    }

    /// "`<format name>` level `<level>`": one usage-count key in findings.
    pub fn key(self, format: u32, level: u32) -> String {
        format!("{} level {level}", self.name(format))
    }

    /// The format enum of a micromap of type `micromap_type` built through EXT.
    pub fn of_micromap_type(micromap_type: i32) -> Self {
        if micromap_type == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV {
            FormatKind::DisplacementNv
        } else {
            FormatKind::OpacityExt
        }
    }
}

/// `("VK_" + identifier, value)` of generated declarations, so the names
/// cannot drift from `vk.xml`.
macro_rules! named {
    ($($name:ident),* $(,)?) => {
        [$((concat!("VK_", stringify!($name)), khr::$name.as_raw() as u32)),*]
    };
}

/// A micromap format value as findings print it: its specification name
/// (`VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT`), or `format 7` for a value
/// the enum does not define.
pub fn format_name(kind: FormatKind, format: u32) -> String {
    let opacity: &[(&str, u32)] = match kind {
        FormatKind::OpacityExt => &named!(
            OPACITY_MICROMAP_FORMAT_2_STATE_EXT,
            OPACITY_MICROMAP_FORMAT_4_STATE_EXT
        ),
        FormatKind::OpacityKhr => &named!(
            OPACITY_MICROMAP_FORMAT_2_STATE_KHR,
            OPACITY_MICROMAP_FORMAT_4_STATE_KHR
        ),
        FormatKind::DisplacementNv => {
            // ash names the values TYPE_64_TRIANGLES_64_BYTES and so on; the
            // specification's names wrap that in the enum's prefix and suffix.
            let value = vk::DisplacementMicromapFormatNV::from_raw(format as i32);
            let name = format!("{value:?}");
            return match name.strip_prefix("TYPE_") {
                Some(rest) => format!("VK_DISPLACEMENT_MICROMAP_FORMAT_{rest}_NV"),
                None => format!("format {format}"),
            };
        }
    };
    opacity
        .iter()
        .find(|(_, value)| *value == format)
        .map_or_else(|| format!("format {format}"), |(name, _)| name.to_string())
}

/// A value of the enum `K` as findings print it: its specification name
/// from the scene's name table (ash's constants and the generated
/// declarations, checked against both), or the enum's name and the number
/// (`VkQueryType 123`) for a value the table lacks.
fn enum_name<K: names::Kind>(raw: i32) -> String {
    names::name_of::<K>(i64::from(raw))
        .map_or_else(|| format!("{} {raw}", K::TYPE_NAME), str::to_string)
}

/// One `pub fn name(raw: i32) -> String` per enum family, printing a value
/// by [`enum_name`].
macro_rules! enum_names {
    ($($name:ident => $kind:ident),* $(,)?) => {
        $(
            #[doc = concat!("A [`names::", stringify!($kind), "`] value by its specification name, or its type name and number.")]
            pub fn $name(raw: i32) -> String {
                enum_name::<names::$kind>(raw)
            }
        )*
    };
}

enum_names!(
    micromap_type_name => MicromapType,
    acceleration_structure_type_name => AccelerationStructureType,
    build_type_name => BuildType,
    build_acceleration_structure_mode_name => BuildAccelerationStructureMode,
    query_type_name => QueryType,
    index_type_name => IndexType,
    geometry_type_name => GeometryType,
    copy_micromap_mode_name => CopyMicromapMode,
);

/// A `VkStructureType` value by name: the scene's table (which has the
/// micromap values ash 0.38 lacks), else ash's name of the core enum with
/// the specification's `VK_STRUCTURE_TYPE_` prefix, else `VkStructureType 7`.
pub fn structure_type_name(raw: i32) -> String {
    if let Some(name) = names::name_of::<names::StructureType>(i64::from(raw)) {
        return name.to_string();
    }
    // ash's Debug prints a value it does not know as its number.
    let ash = format!("{:?}", vk::StructureType::from_raw(raw));
    if ash.parse::<i64>().is_ok() {
        enum_name::<names::StructureType>(raw)
    } else {
        format!("VK_STRUCTURE_TYPE_{ash}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::names::{name_of, Kind, MicromapFormat};

    #[test]
    fn formats_print_by_their_specification_names() {
        assert_eq!(
            format_name(FormatKind::OpacityExt, OPACITY_MICROMAP_FORMAT_4_STATE),
            "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT"
        );
        assert_eq!(
            format_name(FormatKind::OpacityKhr, OPACITY_MICROMAP_FORMAT_2_STATE),
            "VK_OPACITY_MICROMAP_FORMAT_2_STATE_KHR"
        );
        assert_eq!(format_name(FormatKind::OpacityExt, 7), "format 7");
        assert_eq!(format_name(FormatKind::DisplacementNv, 0), "format 0");
        assert_eq!(
            FormatKind::of_micromap_type(MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV),
            FormatKind::DisplacementNv
        );
    }

    #[test]
    fn enum_values_print_by_name_or_as_the_enum_and_number() {
        assert_eq!(
            micromap_type_name(MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV),
            "VK_MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV"
        );
        assert_eq!(micromap_type_name(5), "VkMicromapTypeEXT 5");
        assert_eq!(
            acceleration_structure_type_name(
                crate::model::accel::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP
            ),
            "VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR"
        );
        assert_eq!(
            acceleration_structure_type_name(vk::AccelerationStructureTypeKHR::TOP_LEVEL.as_raw()),
            "VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR"
        );
        assert_eq!(
            build_type_name(vk::AccelerationStructureBuildTypeKHR::HOST.as_raw()),
            "VK_ACCELERATION_STRUCTURE_BUILD_TYPE_HOST_KHR"
        );
        assert_eq!(
            build_acceleration_structure_mode_name(1),
            "VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR"
        );
        assert_eq!(
            query_type_name(khr::QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT.as_raw()),
            "VK_QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT"
        );
        assert_eq!(query_type_name(2), "VK_QUERY_TYPE_TIMESTAMP");
        assert_eq!(query_type_name(123), "VkQueryType 123");
        assert_eq!(index_type_name(1), "VK_INDEX_TYPE_UINT32");
        assert_eq!(index_type_name(-1), "VkIndexType -1");
        assert_eq!(
            geometry_type_name(khr::GEOMETRY_TYPE_MICROMAP_KHR.as_raw()),
            "VK_GEOMETRY_TYPE_MICROMAP_KHR"
        );
        assert_eq!(geometry_type_name(0), "VK_GEOMETRY_TYPE_TRIANGLES_KHR");
        assert_eq!(
            copy_micromap_mode_name(3),
            "VK_COPY_MICROMAP_MODE_COMPACT_EXT"
        );
        assert_eq!(copy_micromap_mode_name(9), "VkCopyMicromapModeEXT 9");
    }

    #[test]
    fn structure_types_come_from_the_table_then_from_ash() {
        assert_eq!(
            structure_type_name(STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT),
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT"
        );
        // Not in the scene's table: ash's name with the spec's prefix.
        assert_eq!(
            structure_type_name(vk::StructureType::BUFFER_CREATE_INFO.as_raw()),
            "VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO"
        );
        assert_eq!(structure_type_name(-7), "VkStructureType -7");
    }

    /// Every name is one the scene format accepts for that value.
    #[test]
    fn names_agree_with_the_scene_tables() {
        for kind in [
            FormatKind::OpacityExt,
            FormatKind::OpacityKhr,
            FormatKind::DisplacementNv,
        ] {
            for format in 1..=3u32 {
                let name = format_name(kind, format);
                if name.starts_with("format ") {
                    continue;
                }
                let table = MicromapFormat::names();
                assert!(
                    table.contains(&(name.as_str(), i64::from(format))),
                    "{name} = {format} is not in the scene table"
                );
            }
        }
        assert_eq!(
            format_name(FormatKind::DisplacementNv, 3),
            "VK_DISPLACEMENT_MICROMAP_FORMAT_1024_TRIANGLES_128_BYTES_NV"
        );
        assert_eq!(
            name_of::<MicromapFormat>(2),
            Some(format_name(FormatKind::OpacityExt, 2).as_str())
        );
    }
}
