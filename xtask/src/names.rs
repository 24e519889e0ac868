//! `validator/src/model/names/generated.rs`: the table of spec names and
//! values behind each enum or bitmask kind a scene member holds, with every
//! value vk.xml gives the type (core and every extension), so a scene written
//! from any application's calls reads.
//!
//! [`KINDS`] is what vk.xml does not say: which kinds the scene form has,
//! their Rust names, and which vk.xml types one kind merges. Everything else
//! (the values, their order, whether a kind is a bitmask and how wide) comes
//! from vk.xml.

use std::fmt::Write as _;

use crate::registry::VkXml;
use crate::Error;

/// One kind: a Rust marker type implementing `names::Kind`.
pub struct KindSpec {
    pub rust: &'static str,
    /// Doc comment; empty: the type name says it.
    pub doc: &'static str,
    /// The spec's type name, for messages and the schema.
    pub type_name: &'static str,
    /// The vk.xml types whose values the member takes, where they are not
    /// just `type_name` (the NV displacement formats share the opacity
    /// micromap's `format` member). Where two give a value, the first one's
    /// name is the one shown.
    pub types: &'static [&'static str],
}

const fn kind(rust: &'static str, type_name: &'static str) -> KindSpec {
    KindSpec {
        rust,
        doc: "",
        type_name,
        types: &[],
    }
}

/// The kinds, in the order the generated file declares them.
pub const KINDS: &[KindSpec] = &[
    kind("StructureType", "VkStructureType"),
    kind("MicromapType", "VkMicromapTypeEXT"),
    kind("BuildMicromapMode", "VkBuildMicromapModeEXT"),
    kind("BuildMicromapFlags", "VkBuildMicromapFlagsEXT"),
    KindSpec {
        rust: "MicromapFormat",
        doc: "`VkOpacityMicromapFormatEXT` (and the KHR type it aliases); NV displacement formats share the member and are accepted too.",
        type_name: "VkOpacityMicromapFormatEXT",
        types: &["VkOpacityMicromapFormatEXT", "VkDisplacementMicromapFormatNV"],
    },
    kind("MicromapCreateFlags", "VkMicromapCreateFlagsEXT"),
    kind("CopyMicromapMode", "VkCopyMicromapModeEXT"),
    kind("QueryType", "VkQueryType"),
    kind("BuildType", "VkAccelerationStructureBuildTypeKHR"),
    kind("AccelerationStructureType", "VkAccelerationStructureTypeKHR"),
    kind(
        "BuildAccelerationStructureFlags",
        "VkBuildAccelerationStructureFlagsKHR",
    ),
    kind(
        "BuildAccelerationStructureMode",
        "VkBuildAccelerationStructureModeKHR",
    ),
    kind("GeometryType", "VkGeometryTypeKHR"),
    kind("GeometryFlags", "VkGeometryFlagsKHR"),
    kind("GeometryInstanceFlags", "VkGeometryInstanceFlagsKHR"),
    kind("IndexType", "VkIndexType"),
    kind("Format", "VkFormat"),
    KindSpec {
        rust: "BufferUsageFlags",
        doc: "`VkBufferUsageFlags2`, whose bits include every `VkBufferUsageFlags` bit; the checker tracks the 64-bit form, and the 32-bit names are accepted (and shown) for the bits they name.",
        type_name: "VkBufferUsageFlags2",
        types: &["VkBufferUsageFlags", "VkBufferUsageFlags2"],
    },
    kind("BufferCreateFlags", "VkBufferCreateFlags"),
    kind(
        "AccelerationStructureCreateFlags",
        "VkAccelerationStructureCreateFlagsKHR",
    ),
    kind("AddressCommandFlags", "VkAddressCommandFlagsKHR"),
    kind(
        "CopyAccelerationStructureMode",
        "VkCopyAccelerationStructureModeKHR",
    ),
    kind("QueueFlags", "VkQueueFlags"),
    kind("PipelineStageFlags2", "VkPipelineStageFlags2"),
    kind("AccessFlags2", "VkAccessFlags2"),
    KindSpec {
        rust: "PipelineCreateFlags",
        doc: "`VkPipelineCreateFlags` (the 32-bit `flags` of the create infos).",
        type_name: "VkPipelineCreateFlags",
        types: &[],
    },
    KindSpec {
        rust: "PipelineCreateFlags2",
        doc: "`VkPipelineCreateFlags2` (`VkPipelineCreateFlags2CreateInfo::flags`).",
        type_name: "VkPipelineCreateFlags2",
        types: &[],
    },
    kind("ShaderStageFlags", "VkShaderStageFlags"),
    kind("ShaderCreateFlags", "VkShaderCreateFlagsEXT"),
    kind("ShaderCodeType", "VkShaderCodeTypeEXT"),
    kind("PipelineBindPoint", "VkPipelineBindPoint"),
    kind(
        "ClusterIndexFormat",
        "VkClusterAccelerationStructureIndexFormatFlagsNV",
    ),
    kind("ClusterOpType", "VkClusterAccelerationStructureOpTypeNV"),
];

/// The `<enums>` block holding the values of `type_name`: the type itself
/// for an enum, its `FlagBits` for a bitmask, through type aliases.
fn values_block<'a>(vk: &'a VkXml, type_name: &'a str) -> Result<&'a str, Error> {
    let mut name = type_name;
    for _ in 0..4 {
        let ty = vk
            .types
            .get(name)
            .ok_or_else(|| Error::Registry(format!("no type {name}")))?;
        if let Some(alias) = &ty.alias {
            name = alias;
            continue;
        }
        return match ty.category.as_deref() {
            Some("enum") => Ok(name),
            Some("bitmask") => ty
                .bitvalues
                .as_deref()
                .or(ty.requires.as_deref())
                .ok_or_else(|| Error::Registry(format!("bitmask {name} has no bits type"))),
            other => Err(Error::Registry(format!(
                "{name} is a {other:?}, not an enum or bitmask"
            ))),
        };
    }
    Err(Error::Registry(format!(
        "{type_name}: alias chain too long"
    )))
}

/// The `(name, value)` entries of one kind. Where vk.xml makes a micromap
/// value's `_EXT` spelling an alias of a `_KHR` one, the `_EXT` spelling
/// comes first: the first name for a value is the one findings show, and
/// the EXT extension's users read the names they wrote.
/// One kind's generated table.
struct Table {
    entries: Vec<(String, i128)>,
    bitmask: bool,
    /// `Repr`'s variant: how wide the Vulkan type is.
    repr: &'static str,
}

fn table(vk: &VkXml, spec: &KindSpec) -> Result<Table, Error> {
    let mut out: Vec<(String, i128)> = Vec::new();
    let (mut bitmask, mut bitwidth) = (None, 32);
    let types = if spec.types.is_empty() {
        std::slice::from_ref(&spec.type_name)
    } else {
        spec.types
    };
    for type_name in types {
        let block = values_block(vk, type_name)?;
        let ty = vk
            .enum_types
            .get(block)
            .ok_or_else(|| Error::Registry(format!("no <enums> block {block}")))?;
        if *bitmask.get_or_insert(ty.bitmask) != ty.bitmask {
            return Err(Error::Registry(format!(
                "{} merges enums and bitmasks",
                spec.rust
            )));
        }
        bitwidth = bitwidth.max(ty.bitwidth);
        for (name, value) in &ty.values {
            if let Some(ext) = ext_spelling(vk, name) {
                if !out.iter().any(|(n, _)| *n == ext) {
                    out.push((ext, *value));
                }
            }
            if !out.iter().any(|(n, _)| n == name) {
                out.push((name.clone(), *value));
            }
        }
    }
    let bitmask = bitmask.unwrap_or(false);
    let repr = match (bitmask, bitwidth) {
        (false, _) => "I32",
        (true, 64) => "U64",
        (true, _) => "U32",
    };
    Ok(Table {
        entries: out,
        bitmask,
        repr,
    })
}

/// Whether `spec`'s values are 64-bit (`VkFlags64`).
pub fn is_wide(vk: &VkXml, spec: &KindSpec) -> bool {
    table(vk, spec).is_ok_and(|t| t.repr == "U64")
}

/// The `_EXT` alias of a micromap value named `..._KHR`, where vk.xml has one.
fn ext_spelling(vk: &VkXml, name: &str) -> Option<String> {
    let stem = name.strip_suffix("_KHR")?;
    if !stem.contains("MICROMAP") {
        return None;
    }
    let ext = format!("{stem}_EXT");
    (vk.enum_aliases.get(&ext).map(String::as_str) == Some(name)).then_some(ext)
}

pub fn render(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    out.push_str(
        "// @generated by `cargo xtask generate` from vk.xml and xtask/src/names.rs; do not edit.\n\
         //! Every value vk.xml gives each kind of enum or bitmask a scene member\n\
         //! holds, by its spec name.\n\n\
         use super::{Entry, Kind, Repr};\n\n",
    );
    for spec in KINDS {
        let Table {
            entries,
            bitmask,
            repr,
        } = table(vk, spec)?;
        let doc = if spec.doc.is_empty() {
            format!("`{}`.", spec.type_name)
        } else {
            spec.doc.to_string()
        };
        let statics = crate::khr::snake_case(spec.rust).to_uppercase();
        let _ = writeln!(
            out,
            "/// {doc}\n#[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub struct {rust};\n\n\
             impl Kind for {rust} {{\n    const TYPE_NAME: &'static str = \"{type_name}\";\n    \
             const REPR: Repr = Repr::{repr};\n    const BITMASK: bool = {bitmask};\n    \
             fn names() -> &'static [Entry] {{\n        {statics}\n    }}\n}}\n",
            rust = spec.rust,
            type_name = spec.type_name,
        );
        let _ = writeln!(out, "static {statics}: &[Entry] = &[");
        for (name, value) in entries {
            let value = i64::try_from(value)
                .map_err(|_| Error::Registry(format!("{name} = {value} does not fit i64")))?;
            let _ = writeln!(out, "    (\"{name}\", {value}),");
        }
        out.push_str("];\n\n");
    }
    Ok(out)
}
