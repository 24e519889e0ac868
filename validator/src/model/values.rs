//! Raw values of the Vulkan enums and bits the checks compare against, named
//! as in the specification. Values ash 0.38 has come from ash; the others
//! from the generated `ommcheck_vuids::khr`.

use ash::vk;
use ommcheck_vuids::khr;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::names::{name_of, Kind, MicromapFormat};

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
