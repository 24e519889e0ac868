//! The structures whose every form is generated from one description: the
//! model type (`validator/src/model/generated.rs`), the reader from ash
//! structures (`validator/src/raw/generated.rs`), the scene form
//! (`validator/src/scene/format/generated.rs`), the scene → model resolver
//! (`validator/src/scene/resolve/generated.rs`) and the model → scene
//! writer (`validator/src/scene/write/generated.rs`).
//!
//! vk.xml gives each structure's members and their types; [`STRUCTS`] adds
//! what it does not say: the Rust name, the defaults a scene may leave out,
//! and the members a scene must state. A member's type decides its form in
//! every file ([`Form`]); a structure with a member of another type is not
//! one of these and stays hand-written.

use std::fmt::Write as _;

use crate::names::KINDS;
use crate::registry::{Member, VkXml};
use crate::Error;

/// One structure described for the generator.
pub struct StructSpec {
    /// The vk.xml name.
    pub vk: &'static str,
    /// The model's name; the scene form is this + `Desc`, the resolver and
    /// reader functions its snake case.
    pub rust: &'static str,
    /// Said after the structure's name in the docs; may be empty.
    pub doc: &'static str,
    /// Members and the value they have when left out (by a scene or by
    /// `..Default::default()`): an enum's by its vk.xml name, a number's as
    /// a decimal; others are 0.
    pub defaults: &'static [(&'static str, &'static str)],
    /// Members a scene must state.
    pub required: &'static [&'static str],
    /// The structure the raw reader takes, where it is not ash's
    /// `vk::<name><'_>`: the KHR micromap structures ash lacks are in
    /// `ommcheck_vuids::khr` (`khr::...`).
    pub ash: &'static str,
    /// Read from another structure's pNext chain: a scene names it by its
    /// sType (a `ChainStruct` entry, with no `sType`/`pNext` members of its
    /// own), and its own pNext belongs to the chain its parent walks.
    pub chained: bool,
    /// Chained structures (vk.xml names, each a `chained` entry of
    /// [`STRUCTS`]) the model takes out of the pNext chain into a member of
    /// this Rust name: the first of each, read whole; the chain keeps the
    /// sTypes of the rest.
    pub extracts: &'static [(&'static str, &'static str)],
    /// Arrays of described structures, each a count member with an array
    /// and an array of pointers of the same length.
    pub elements: &'static [Elements],
    /// Members of the model only, which no scene states and no reader
    /// fills (their default stays): the Rust name, type and doc.
    pub model_only: &'static [(&'static str, &'static str, &'static str)],
}

/// A spec's fields that are empty in most entries.
pub const BASE: StructSpec = StructSpec {
    vk: "",
    rust: "",
    doc: "",
    defaults: &[],
    required: &[],
    ash: "",
    chained: false,
    extracts: &[],
    elements: &[],
    model_only: &[],
};

/// A count member with an array and an array of pointers that it counts
/// (`geometryCount` with `pGeometries` and `ppGeometries`): the
/// application gives one of the two. The element type is one of [`STRUCTS`].
pub struct Elements {
    /// The vk.xml name of the count member.
    pub count: &'static str,
    /// The model's names of the array and of the array of pointers.
    pub array: &'static str,
    pub pointers: &'static str,
    /// What the elements are called in a finding (`geometries`).
    pub noun: &'static str,
    /// The raw reader's bound on the elements it reads (a constant's path
    /// in `raw`).
    pub bound: &'static str,
}

/// The unions whose members are all structures of [`STRUCTS`]: vk.xml name
/// and the model's enum name. vk.xml says which selector value selects each
/// member.
pub const UNIONS: &[(&str, &str)] = &[("VkAccelerationStructureGeometryDataKHR", "GeometryData")];

/// The entry of [`STRUCTS`] for the chained structure `vk`.
fn chained(vk: &str) -> Result<&'static StructSpec, Error> {
    STRUCTS
        .iter()
        .find(|s| s.vk == vk && s.chained)
        .ok_or_else(|| Error::Registry(format!("{vk} is not a chained structure of STRUCTS")))
}

/// A copy info: `mode`'s default is the one copy its command makes.
macro_rules! copy {
    ($vk:literal, $rust:literal, $doc:literal, $mode:literal $(,)?) => {
        StructSpec {
            vk: $vk,
            rust: $rust,
            doc: $doc,
            defaults: &[("mode", $mode)],
            ..BASE
        }
    };
}

/// The generated structures.
pub const STRUCTS: &[StructSpec] = &[
    StructSpec {
        vk: "VkMicromapCreateInfoEXT",
        rust: "MicromapCreateInfo",
        doc: "",
        defaults: &[("type", "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT")],
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureCreateInfoKHR",
        rust: "AccelerationStructureCreateInfo",
        doc: "",
        defaults: &[("type", "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR")],
        required: &["type"],
        ..BASE
    },
    copy!(
        "VkCopyMicromapInfoEXT",
        "CopyMicromapInfo",
        "",
        "VK_COPY_MICROMAP_MODE_CLONE_EXT",
    ),
    copy!(
        "VkCopyMicromapToMemoryInfoEXT",
        "CopyMicromapToMemoryInfo",
        "`dst` is a device or host address, depending on the command.",
        "VK_COPY_MICROMAP_MODE_SERIALIZE_EXT",
    ),
    copy!(
        "VkCopyMemoryToMicromapInfoEXT",
        "CopyMemoryToMicromapInfo",
        "`src` is a device or host address, depending on the command.",
        "VK_COPY_MICROMAP_MODE_DESERIALIZE_EXT",
    ),
    copy!(
        "VkCopyAccelerationStructureInfoKHR",
        "CopyAccelerationStructureInfo",
        "",
        "VK_COPY_ACCELERATION_STRUCTURE_MODE_CLONE_KHR",
    ),
    copy!(
        "VkCopyAccelerationStructureToMemoryInfoKHR",
        "CopyAccelerationStructureToMemoryInfo",
        "`dst` is a device or host address, depending on the command.",
        "VK_COPY_ACCELERATION_STRUCTURE_MODE_SERIALIZE_KHR",
    ),
    copy!(
        "VkCopyMemoryToAccelerationStructureInfoKHR",
        "CopyMemoryToAccelerationStructureInfo",
        "`src` is a device or host address, depending on the command.",
        "VK_COPY_ACCELERATION_STRUCTURE_MODE_DESERIALIZE_KHR",
    ),
    StructSpec {
        vk: "VkMicromapBuildInfoEXT",
        rust: "MicromapBuildInfo",
        doc: "addresses are device or host addresses, depending on the command.",
        defaults: &[
            ("type", "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT"),
            ("mode", "VK_BUILD_MICROMAP_MODE_BUILD_EXT"),
        ],
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureTrianglesOpacityMicromapEXT",
        rust: "TrianglesOpacityMicromapExt",
        doc: "",
        defaults: &[("indexType", "VK_INDEX_TYPE_UINT32"), ("indexStride", "4")],
        chained: true,
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureTrianglesOpacityMicromapKHR",
        rust: "TrianglesOpacityMicromapKhr",
        doc: "`micromap` is an acceleration structure of type OPACITY_MICROMAP.",
        defaults: &[("indexType", "VK_INDEX_TYPE_UINT32"), ("indexStride", "4")],
        ash: "khr::AccelerationStructureTrianglesOpacityMicromapKHR",
        chained: true,
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureTrianglesDisplacementMicromapNV",
        rust: "TrianglesDisplacementMicromapNv",
        doc: "",
        defaults: &[
            ("displacementBiasAndScaleFormat", "VK_FORMAT_R16G16_SFLOAT"),
            ("displacementVectorFormat", "VK_FORMAT_R16G16B16A16_SFLOAT"),
            ("indexType", "VK_INDEX_TYPE_UINT32"),
            ("indexStride", "4"),
        ],
        chained: true,
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureGeometryMicromapDataKHR",
        rust: "GeometryMicromapData",
        doc: "In a geometry's pNext chain when `geometryType` is `VK_GEOMETRY_TYPE_MICROMAP_KHR`.",
        defaults: &[("triangleArrayStride", "8")],
        ash: "khr::AccelerationStructureGeometryMicromapDataKHR<'_>",
        chained: true,
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureGeometryAabbsDataKHR",
        rust: "AabbsData",
        doc: "",
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureBuildRangeInfoKHR",
        rust: "BuildRangeInfo",
        doc: "",
        ash: "vk::AccelerationStructureBuildRangeInfoKHR",
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureGeometryTrianglesDataKHR",
        rust: "TrianglesData",
        doc: "with the micromap attachments of its pNext chain.",
        defaults: &[
            ("vertexFormat", "VK_FORMAT_R32G32B32_SFLOAT"),
            ("vertexStride", "12"),
            ("indexType", "VK_INDEX_TYPE_NONE_KHR"),
        ],
        extracts: &[
            (
                "opacity_ext",
                "VkAccelerationStructureTrianglesOpacityMicromapEXT",
            ),
            (
                "opacity_khr",
                "VkAccelerationStructureTrianglesOpacityMicromapKHR",
            ),
            (
                "displacement_nv",
                "VkAccelerationStructureTrianglesDisplacementMicromapNV",
            ),
        ],
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureGeometryInstancesDataKHR",
        rust: "InstancesData",
        doc: "with the instances themselves where the checker can read them.",
        model_only: &[(
            "instances",
            "Option<Vec<super::accel::Instance>>",
            "The instances read from `data` (None: not readable by the checker).",
        )],
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureGeometryKHR",
        rust: "Geometry",
        doc: "with the micromap structure of its pNext chain.",
        defaults: &[("geometryType", "VK_GEOMETRY_TYPE_TRIANGLES_KHR")],
        required: &["geometryType"],
        extracts: &[("micromap", "VkAccelerationStructureGeometryMicromapDataKHR")],
        ..BASE
    },
    StructSpec {
        vk: "VkAccelerationStructureBuildGeometryInfoKHR",
        rust: "BuildGeometryInfo",
        doc: "addresses are device or host addresses, depending on the command.",
        defaults: &[
            ("type", "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR"),
            ("mode", "VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR"),
        ],
        required: &["type"],
        elements: &[Elements {
            count: "geometryCount",
            array: "geometries",
            pointers: "geometry_pointers",
            noun: "geometries",
            bound: "accel::MAX_GEOMETRIES",
        }],
        ..BASE
    },
    // What a pipeline create info chains: the flags that replace its own
    // and the libraries it links (also a ray-tracing pipeline's
    // `pLibraryInfo`).
    StructSpec {
        vk: "VkPipelineCreateFlags2CreateInfo",
        rust: "PipelineCreateFlags2CreateInfo",
        doc: "its `flags` replace the create info's.",
        ash: "vk::PipelineCreateFlags2CreateInfoKHR<'_>",
        chained: true,
        ..BASE
    },
    StructSpec {
        vk: "VkPipelineLibraryCreateInfoKHR",
        rust: "PipelineLibraryCreateInfo",
        doc: "chained to a graphics pipeline, or a ray-tracing pipeline's `pLibraryInfo`.",
        chained: true,
        ..BASE
    },
    // A shader stage's specialization constants.
    StructSpec {
        vk: "VkSpecializationMapEntry",
        rust: "SpecializationMapEntry",
        doc: "",
        defaults: &[("size", "4")],
        required: &["constantID"],
        ash: "vk::SpecializationMapEntry",
        ..BASE
    },
    StructSpec {
        vk: "VkSpecializationInfo",
        rust: "SpecializationInfo",
        doc: "",
        required: &["pData"],
        ..BASE
    },
    // A semaphore operation of vkQueueSubmit2.
    StructSpec {
        vk: "VkSemaphoreSubmitInfo",
        rust: "SemaphoreSubmitInfo",
        doc: "",
        ..BASE
    },
];

/// The objects scene names can denote, by the handle type vk.xml gives:
/// the resolver's `ObjectKind` variant.
pub(crate) const HANDLE_KINDS: &[(&str, &str)] = &[
    ("VkBuffer", "Buffer"),
    ("VkMicromapEXT", "Micromap"),
    ("VkAccelerationStructureKHR", "AccelerationStructure"),
    ("VkQueryPool", "QueryPool"),
    ("VkDeferredOperationKHR", "DeferredOperation"),
    ("VkPipeline", "Pipeline"),
    ("VkSemaphore", "Semaphore"),
];

/// The kinds of [`HANDLE_KINDS`] whose objects carry no state ommcheck
/// reads: a scene may name one it never created, and a new name denotes a
/// new object (so their resolvers take the resolver mutably).
const LOOSE_KINDS: &[&str] = &["Semaphore"];

/// Whether `spec` has a handle of a [`LOOSE_KINDS`] kind.
fn binds_names(vk: &VkXml, spec: &StructSpec) -> Result<bool, Error> {
    Ok(fields(vk, spec)?
        .iter()
        .any(|f| matches!(f.form, Form::Handle(kind) if LOOSE_KINDS.contains(&kind))))
}

/// Whether `spec`'s resolver takes the resolver mutably: it names loose
/// objects ([`binds_names`]) or reads contents (which map files), or a
/// structure it holds in a plain array does.
fn resolves_mutably(vk: &VkXml, spec: &StructSpec) -> Result<bool, Error> {
    if binds_names(vk, spec)? {
        return Ok(true);
    }
    for field in fields(vk, spec)? {
        match &field.form {
            Form::Blob(_) => return Ok(true),
            Form::Structs(structs) if resolves_mutably(vk, by_rust(structs.element))? => {
                return Ok(true)
            }
            _ => {}
        }
    }
    Ok(false)
}

/// What a member is, which decides its form in every generated file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Form {
    /// `sType`, with the structure's own value.
    SType(i128),
    /// `pNext`: the model keeps the chain's sTypes.
    Next,
    /// A handle naming an object of this `ObjectKind`.
    Handle(&'static str),
    /// A device or host address (`VkDeviceOrHostAddress[Const]KHR`: `const_`
    /// tells which) or a `VkDeviceAddress` (`union: false`).
    Address { union: bool, const_: bool },
    /// A 32-bit enum of this `names` kind; `required`: a scene must state
    /// it (the model's default still applies to code that builds one).
    Enum {
        kind: &'static str,
        default: EnumDefault,
        required: bool,
    },
    /// A bitmask of this `names` kind; `wide`: 64-bit.
    Flags { kind: &'static str, wide: bool },
    /// A plain number; `wide`: 64-bit; `default`: its value when left out
    /// (else 0).
    /// `size`: a `size_t`, 64-bit in the model.
    Number {
        wide: bool,
        default: Option<u64>,
        size: bool,
    },
    /// `usageCountsCount` with `pUsageCounts` and `ppUsageCounts`: one
    /// `UsageCounts` in the model, three members in a scene.
    UsageCounts,
    /// A `VkBool32`: `bool` in the model and in a scene.
    Bool,
    /// A union of [`UNIONS`]: the model's enum (this name) holds the member
    /// the selector member (its Rust name) selects.
    Union {
        rust: &'static str,
        selector: String,
        members: Vec<UnionMember>,
    },
    /// The count member of the structure's `elements[index]`: in the model
    /// the count, the array and the array of pointers of `element`s (a
    /// [`STRUCTS`] Rust name); `array` and `pointers` are the vk.xml names
    /// of the two members it counts.
    Elements {
        index: usize,
        element: &'static str,
        array: String,
        pointers: String,
    },
    /// A count member with the array of handles it counts (`libraryCount`
    /// with `pLibraries`): [`Handles`].
    Handles(Handles),
    /// A count member with the plain array of described structures it
    /// counts (`mapEntryCount` with `pMapEntries`): [`Structs`].
    Structs(Structs),
    /// A byte count with the bytes it counts (`dataSize` with `pData`):
    /// [`Blob`].
    Blob(Blob),
}

/// An array of handles naming objects of one `ObjectKind` (`kind`), and
/// the vk.xml names of its count and array members. The model holds the
/// handles (a NULL array reads as none), a scene the names, whose number
/// is the count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Handles {
    pub kind: &'static str,
    pub count: String,
    pub array: String,
}

/// The array of handles `count` counts in `members`, if one does: a
/// `const VkX*` member with `len="count"` whose handle type is one of
/// [`HANDLE_KINDS`].
fn handle_array(members: &[Member], count: &str) -> Option<Handles> {
    members.iter().find_map(|m| {
        let kind = HANDLE_KINDS.iter().find(|(t, _)| *t == m.type_name)?.1;
        (m.len.as_deref() == Some(count) && m.pointers == [true]).then(|| Handles {
            kind,
            count: count.to_string(),
            array: m.name.clone(),
        })
    })
}

/// A plain array of described structures (`element`, a [`STRUCTS`] Rust
/// name) and the vk.xml names of its count and array members. The model
/// holds the elements (a NULL array reads as none), a scene the list,
/// whose length is the count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Structs {
    pub element: &'static str,
    pub count: String,
    pub array: String,
}

/// The plain array of described structures `count` counts in `members`,
/// if one does: a `const VkX*` member with `len="count"` whose type is a
/// structure of [`STRUCTS`] read on its own (not from a chain), and the
/// only member `count` counts. A count that also counts an array of
/// pointers (`geometryCount` with `pGeometries` and `ppGeometries`) is an
/// `elements` entry's to describe, never a plain array.
fn struct_array(members: &[Member], count: &str) -> Option<Structs> {
    let counted = |m: &&Member| {
        m.len
            .as_deref()
            .is_some_and(|len| len.split(',').next() == Some(count))
    };
    if members.iter().filter(counted).count() != 1 {
        return None;
    }
    members.iter().find_map(|m| {
        let element = STRUCTS.iter().find(|s| s.vk == m.type_name && !s.chained)?;
        (m.len.as_deref() == Some(count) && m.pointers == [true]).then(|| Structs {
            element: element.rust,
            count: count.to_string(),
            array: m.name.clone(),
        })
    })
}

/// Bytes an application hands in, and the vk.xml names of their byte
/// count and pointer. The model holds the bytes (a NULL pointer reads as
/// none), a scene contents, whose length is the count.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Blob {
    pub count: String,
    pub array: String,
}

/// The bytes `count` counts in `members`, if it counts any: a `const void*`
/// member with `len="count"`, counted by a `size_t`.
fn blob(members: &[Member], count: &str) -> Option<Blob> {
    let counter = members.iter().find(|m| m.name == count)?;
    members.iter().find_map(|m| {
        (counter.type_name == "size_t"
            && m.type_name == "void"
            && m.len.as_deref() == Some(count)
            && m.pointers == [true])
        .then(|| Blob {
            count: count.to_string(),
            array: m.name.clone(),
        })
    })
}

/// The model's name of an array member: `pLibraries` is `libraries`.
fn array_rust(name: &str) -> String {
    let name = name.strip_prefix('p').unwrap_or(name);
    let mut chars = name.chars();
    let first = chars.next().map(|c| c.to_ascii_lowercase());
    crate::khr::snake_case(&first.into_iter().chain(chars).collect::<String>())
}

/// One member of a union: its vk.xml name, the model's variant and
/// structure (a [`STRUCTS`] Rust name), and the selector value (name and
/// number) that makes it live.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnionMember {
    pub name: String,
    pub variant: String,
    pub element: &'static str,
    pub selection: String,
    pub value: i128,
}

/// The entry of [`STRUCTS`] whose Rust name is `rust`.
fn by_rust(rust: &str) -> &'static StructSpec {
    STRUCTS
        .iter()
        .find(|s| s.rust == rust)
        .expect("forms name only STRUCTS entries")
}

/// The members of the union `union` (a [`UNIONS`] entry).
fn union_members(vk: &VkXml, union: &str) -> Result<Vec<UnionMember>, Error> {
    let aggregate = vk
        .aggregate(union)
        .ok_or_else(|| Error::Registry(format!("no union {union}")))?;
    aggregate
        .members
        .iter()
        .map(|member| {
            let missing = || {
                Error::Registry(format!(
                    "{union}.{}: a union member must be a structure of STRUCTS with a selection value",
                    member.name
                ))
            };
            let element = STRUCTS
                .iter()
                .find(|s| s.vk == member.type_name && !s.chained)
                .ok_or_else(missing)?;
            let selection = member.selection.clone().ok_or_else(missing)?;
            let value = value_of(vk, &selection).ok_or_else(missing)?;
            let mut variant = member.name.clone();
            variant[..1].make_ascii_uppercase();
            Ok(UnionMember {
                name: member.name.clone(),
                variant,
                element: element.rust,
                selection,
                value,
            })
        })
        .collect()
}

/// The value an enum member has when it is left out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EnumDefault {
    /// 0, like any member left out.
    Zero,
    /// This value (its vk.xml name and number).
    Value(String, i128),
}

/// One member of a generated structure.
pub struct Field {
    /// The vk.xml name (`deviceAddress`), which the scene uses too.
    pub name: String,
    /// The Rust name (`device_address`; `type` is `ty`).
    pub rust: String,
    pub form: Form,
}

/// The `names` kind whose type is `type_name`, following type aliases.
pub(crate) fn kind_of(vk: &VkXml, type_name: &str) -> Option<&'static str> {
    let same = |a: &str, b: &str| {
        a == b
            || vk.types.get(a).and_then(|t| t.alias.as_deref()) == Some(b)
            || vk.types.get(b).and_then(|t| t.alias.as_deref()) == Some(a)
    };
    KINDS
        .iter()
        .find(|k| same(k.type_name, type_name))
        .map(|k| k.rust)
}

/// The value of the enum value `name` in any type.
pub(crate) fn value_of(vk: &VkXml, name: &str) -> Option<i128> {
    let name = vk
        .enum_aliases
        .get(name)
        .map(String::as_str)
        .unwrap_or(name);
    vk.enum_types
        .values()
        .flat_map(|t| &t.values)
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
}

fn form(vk: &VkXml, spec: &StructSpec, member: &Member) -> Result<Form, Error> {
    let unsupported = || {
        Error::Registry(format!(
            "{}.{} ({}): no generated form for this member type; write the structure by hand",
            spec.vk, member.name, member.type_name
        ))
    };
    if member.name == "sType" {
        let value = member
            .values
            .as_deref()
            .and_then(|v| value_of(vk, v))
            .ok_or_else(unsupported)?;
        return Ok(Form::SType(value));
    }
    if member.name == "pNext" {
        return Ok(Form::Next);
    }
    if !member.pointers.is_empty() || member.len.is_some() {
        return Err(unsupported());
    }
    let ty = member.type_name.as_str();
    if ty == "VkBool32" {
        return Ok(Form::Bool);
    }
    if let Some((union, rust)) = UNIONS.iter().find(|(u, _)| *u == ty) {
        let selector = member.selector.as_deref().ok_or_else(unsupported)?;
        return Ok(Form::Union {
            rust,
            selector: crate::khr::snake_case(selector),
            members: union_members(vk, union)?,
        });
    }
    if let Some((_, kind)) = HANDLE_KINDS.iter().find(|(t, _)| *t == ty) {
        return Ok(Form::Handle(kind));
    }
    match ty {
        "VkDeviceOrHostAddressKHR" => {
            return Ok(Form::Address {
                union: true,
                const_: false,
            })
        }
        "VkDeviceOrHostAddressConstKHR" => {
            return Ok(Form::Address {
                union: true,
                const_: true,
            })
        }
        "VkDeviceAddress" => {
            return Ok(Form::Address {
                union: false,
                const_: true,
            })
        }
        "uint32_t" | "uint64_t" | "VkDeviceSize" | "size_t" => {
            let default = match spec.defaults.iter().find(|(m, _)| *m == member.name) {
                Some((_, value)) => Some(value.parse().map_err(|_| {
                    Error::Registry(format!(
                        "{}.{}: default {value} is no number",
                        spec.vk, member.name
                    ))
                })?),
                None => None,
            };
            return Ok(Form::Number {
                wide: ty != "uint32_t",
                default,
                size: ty == "size_t",
            });
        }
        _ => {}
    }
    match vk.category(ty) {
        Some("enum") => {
            let kind = kind_of(vk, ty).ok_or_else(unsupported)?;
            let default = match spec.defaults.iter().find(|(m, _)| *m == member.name) {
                Some((_, value)) => EnumDefault::Value(
                    value.to_string(),
                    value_of(vk, value).ok_or_else(|| {
                        Error::Registry(format!("{}: no enum value {value}", spec.vk))
                    })?,
                ),
                None => EnumDefault::Zero,
            };
            let required = spec.required.contains(&member.name.as_str());
            Ok(Form::Enum {
                kind,
                default,
                required,
            })
        }
        Some("bitmask") => {
            let kind = kind_of(vk, ty).ok_or_else(unsupported)?;
            let wide = KINDS
                .iter()
                .find(|k| k.rust == kind)
                .is_some_and(|k| crate::names::is_wide(vk, k));
            Ok(Form::Flags { kind, wide })
        }
        _ => Err(unsupported()),
    }
}

/// The members of `spec`'s structure with their forms.
pub fn fields(vk: &VkXml, spec: &StructSpec) -> Result<Vec<Field>, Error> {
    let aggregate = vk
        .aggregate(spec.vk)
        .ok_or_else(|| Error::Registry(format!("no structure {}", spec.vk)))?;
    aggregate
        .members
        .iter()
        // The arrays `usageCountsCount` and element counts count go with them.
        .filter(|member| {
            member.len.as_deref().is_none_or(|len| {
                let count = len.split(',').next().unwrap_or(len);
                count != "usageCountsCount"
                    && !spec.elements.iter().any(|e| e.count == count)
                    && handle_array(&aggregate.members, count).is_none()
                    && struct_array(&aggregate.members, count).is_none()
                    && blob(&aggregate.members, count).is_none()
            })
        })
        .map(|member| {
            if member.name == "usageCountsCount" {
                return Ok(Field {
                    name: "usageCounts".to_string(),
                    rust: "usage_counts".to_string(),
                    form: Form::UsageCounts,
                });
            }
            if let Some(handles) = handle_array(&aggregate.members, &member.name) {
                return Ok(Field {
                    name: handles.array.clone(),
                    rust: array_rust(&handles.array),
                    form: Form::Handles(handles),
                });
            }
            if let Some(form) = counted_form(spec, &aggregate.members, &member.name) {
                return Ok(form);
            }
            if let Some(index) = spec.elements.iter().position(|e| e.count == member.name) {
                let counted = |len: String| {
                    aggregate
                        .members
                        .iter()
                        .find(|m| m.len.as_deref() == Some(len.as_str()))
                        .filter(|m| STRUCTS.iter().any(|s| s.vk == m.type_name))
                        .ok_or_else(|| {
                            Error::Registry(format!(
                                "{}: no member {len} counts an array of a structure of STRUCTS",
                                spec.vk
                            ))
                        })
                };
                let array = counted(member.name.clone())?;
                let pointers = counted(format!("{},1", member.name))?;
                return Ok(Field {
                    name: member.name.clone(),
                    rust: crate::khr::snake_case(&member.name),
                    form: Form::Elements {
                        index,
                        element: STRUCTS
                            .iter()
                            .find(|s| s.vk == array.type_name)
                            .map_or("", |s| s.rust),
                        array: array.name.clone(),
                        pointers: pointers.name.clone(),
                    },
                });
            }
            Ok(Field {
                rust: match member.name.as_str() {
                    "sType" => "s_type".to_string(),
                    "pNext" => "next".to_string(),
                    name => crate::khr::snake_case(name),
                },
                form: form(vk, spec, member)?,
                name: member.name.clone(),
            })
        })
        .collect()
}

/// The field a count member stands for when it counts a plain array of
/// structures or bytes (not an `elements` entry of `spec`).
fn counted_form(spec: &StructSpec, members: &[Member], count: &str) -> Option<Field> {
    if spec.elements.iter().any(|e| e.count == count) {
        return None;
    }
    if let Some(structs) = struct_array(members, count) {
        return Some(Field {
            name: structs.array.clone(),
            rust: array_rust(&structs.array),
            form: Form::Structs(structs),
        });
    }
    blob(members, count).map(|blob| Field {
        name: blob.array.clone(),
        rust: array_rust(&blob.array),
        form: Form::Blob(blob),
    })
}

fn header(out: &mut String, doc: &str) {
    out.push_str(
        "// @generated by `cargo xtask generate` from vk.xml and xtask/src/structs.rs; do not edit.\n",
    );
    for line in doc.lines() {
        let _ = writeln!(out, "//! {line}");
    }
    out.push('\n');
}

fn doc(spec: &StructSpec) -> String {
    if spec.doc.is_empty() {
        format!("`{}`.", spec.vk)
    } else {
        format!("`{}`; {}", spec.vk, spec.doc)
    }
}

fn function(spec: &StructSpec) -> String {
    crate::khr::snake_case(spec.rust)
}

fn rename(field: &Field) -> String {
    // serde's camelCase of the scene's Rust name, where it is not the
    // vk.xml name (`constantID`).
    let ident = crate::khr::snake_case(&field.name);
    let mut camel = String::new();
    let mut upper = false;
    for c in ident.chars() {
        match c {
            '_' => upper = true,
            c if upper => {
                camel.push(c.to_ascii_uppercase());
                upper = false;
            }
            c => camel.push(c),
        }
    }
    if ident == "ty" {
        "    #[serde(rename = \"type\")]\n".to_string()
    } else if camel != field.name {
        format!("    #[serde(rename = \"{}\")]\n", field.name)
    } else {
        String::new()
    }
}

/// The expression reading `field` of the ash structure `info` into the
/// model (its pNext chain aside). A union of addresses goes through the
/// raw reader's `address`/`scratch_address`, which only `raw` may call.
fn ash_member(field: &Field) -> String {
    let member = format!("info.{}", field.rust);
    match &field.form {
        Form::SType(_) | Form::Enum { .. } | Form::Flags { .. } => format!("{member}.as_raw()"),
        Form::Handle(_) => format!("vk::Handle::as_raw({member})"),
        Form::Address {
            union: true,
            const_: true,
        } => format!("address(&{member})"),
        Form::Address {
            union: true,
            const_: false,
        } => format!("scratch_address(&{member})"),
        // `size_t` is 64 bits on every target ommcheck builds for.
        Form::Number { size: true, .. } => format!("{member} as u64"),
        Form::Address { union: false, .. } | Form::Number { .. } | Form::Next => member,
        Form::Bool => format!("{member} != vk::FALSE"),
        // Read by `render_reader`, which knows the structure.
        Form::Union { .. } | Form::Elements { .. } | Form::Structs(_) | Form::Blob(_) => {
            field.rust.clone()
        }
        Form::Handles(h) => format!(
            "unsafe {{ read_array(info.{}, info.{}, function, at.text(\".{}\"), findings) }}\n            \
             .unwrap_or_default().into_iter().map(vk::Handle::as_raw).collect()",
            crate::khr::snake_case(&h.array),
            crate::khr::snake_case(&h.count),
            h.array
        ),
        // Both usage structures are three 32-bit members, so the EXT
        // reader reads the KHR one as well.
        Form::UsageCounts => "unsafe { usage_counts(spare_usages, info.usage_counts_count, \
             info.p_usage_counts.cast(), info.pp_usage_counts.cast(), function, at, findings) }"
            .to_string(),
    }
}

/// The Rust type of the structure the raw reader takes.
pub(crate) fn ash_type(spec: &StructSpec) -> String {
    if spec.ash.is_empty() {
        format!("vk::{}<'_>", spec.vk.strip_prefix("Vk").unwrap_or(spec.vk))
    } else {
        spec.ash.to_string()
    }
}

/// `validator/src/model/generated.rs`.
pub fn render_model(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "Model types of the structures `xtask/src/structs.rs` describes: every\n\
         member as the application wrote it, pNext as its chain's sTypes.",
    );
    out.push_str(
        "// Every structure spells out its defaults, zero or not.\n\
         #![allow(clippy::derivable_impls)]\n\n\
         use ash::vk;\nuse ommcheck_vuids::khr;\nuse serde::{Deserialize, Serialize};\n\n\
         use super::micromap::UsageCounts;\nuse super::Handle;\n\n",
    );
    for spec in STRUCTS {
        let fields = fields(vk, spec)?;
        // Plain values (no chain, no arrays) are copied like numbers.
        let copy = fields.iter().all(|f| {
            !matches!(
                f.form,
                Form::Next
                    | Form::UsageCounts
                    | Form::Union { .. }
                    | Form::Elements { .. }
                    | Form::Handles(_)
                    | Form::Structs(_)
                    | Form::Blob(_)
            )
        }) && spec.extracts.is_empty()
            && spec.model_only.is_empty();
        let _ = writeln!(
            out,
            "/// {}\n#[derive(Clone, {}Debug, PartialEq, {}Serialize, Deserialize)]\n\
             #[serde(default, rename_all = \"camelCase\")]\npub struct {} {{",
            doc(spec),
            if copy { "Copy, " } else { "" },
            if is_eq(vk, spec)? { "Eq, " } else { "" },
            spec.rust
        );
        let mut defaults = String::new();
        for field in &fields {
            let union_type;
            let (ty, default) = match &field.form {
                Form::Bool => ("bool", "false".to_string()),
                Form::Union {
                    rust,
                    selector,
                    members,
                } => {
                    // The member the selector's default selects.
                    let selected = fields.iter().find_map(|f| match &f.form {
                        Form::Enum {
                            default: EnumDefault::Value(_, value),
                            ..
                        } if f.rust == *selector => members.iter().find(|m| m.value == *value),
                        _ => None,
                    });
                    union_type = rust.to_string();
                    let default = match selected {
                        Some(m) => format!("{rust}::{}({}::default())", m.variant, m.element),
                        None => format!("{rust}::None"),
                    };
                    let _ = writeln!(out, "    /// The union member `{}` selects.", selector);
                    (union_type.as_str(), default)
                }
                Form::Elements {
                    element,
                    array,
                    pointers,
                    index,
                } => {
                    let e = &spec.elements[*index];
                    let _ = writeln!(
                        out,
                        "    pub {}: u32,\n    /// `{array}` (None: NULL).\n    pub {}: Option<Vec<{element}>>,\n    \
                         /// `{pointers}` (None: NULL; an element None: a NULL element).\n    pub {}: Option<Vec<Option<{element}>>>,",
                        field.rust, e.array, e.pointers
                    );
                    let _ = writeln!(
                        defaults,
                        "            {}: 0,\n            {}: None,\n            {}: None,",
                        field.rust, e.array, e.pointers
                    );
                    continue;
                }
                Form::SType(value) => ("i32", value.to_string()),
                Form::Next => ("Vec<i32>", "Vec::new()".to_string()),
                Form::Handle(_) => ("Handle", "0".to_string()),
                Form::Number {
                    wide,
                    default: Some(value),
                    ..
                } => (if *wide { "u64" } else { "u32" }, value.to_string()),
                Form::Address { .. }
                | Form::Number { wide: true, .. }
                | Form::Flags { wide: true, .. } => ("u64", "0".to_string()),
                Form::Number { wide: false, .. } | Form::Flags { wide: false, .. } => {
                    ("u32", "0".to_string())
                }
                Form::UsageCounts => ("UsageCounts", "UsageCounts::default()".to_string()),
                Form::Handles(h) => {
                    let _ = writeln!(out, "    /// `{}` (a NULL array: none).", h.array);
                    ("Vec<Handle>", "Vec::new()".to_string())
                }
                Form::Structs(structs) => {
                    let _ = writeln!(out, "    /// `{}` (a NULL array: none).", structs.array);
                    union_type = format!("Vec<{}>", structs.element);
                    (union_type.as_str(), "Vec::new()".to_string())
                }
                Form::Blob(blob) => {
                    let _ = writeln!(
                        out,
                        "    /// The `{}` bytes at `{}` (NULL: none).",
                        blob.count, blob.array
                    );
                    ("Vec<u8>", "Vec::new()".to_string())
                }
                Form::Enum {
                    default: EnumDefault::Value(name, value),
                    ..
                } => ("i32", format!("{value}, // {name}")),
                Form::Enum { .. } => ("i32", "0".to_string()),
            };
            if let Form::Next = field.form {
                out.push_str(if spec.extracts.is_empty() {
                    "    /// sTypes of the structures in the pNext chain, in order.\n"
                } else {
                    "    /// sTypes of the structures in the pNext chain, in order, but for\n    \
                     /// those the members below hold.\n"
                });
            }
            let _ = writeln!(out, "{}    pub {}: {ty},", rename(field), field.rust);
            let comma = if default.contains(',') { "" } else { "," };
            let _ = writeln!(defaults, "            {}: {default}{comma}", field.rust);
        }
        for (member, vk_name) in spec.extracts {
            let _ = writeln!(
                out,
                "    /// The first `{vk_name}` in the pNext chain.\n    pub {member}: Option<{}>,",
                chained(vk_name)?.rust
            );
            let _ = writeln!(defaults, "            {member}: None,");
        }
        for (member, ty, doc) in spec.model_only {
            let _ = writeln!(out, "    /// {doc}\n    pub {member}: {ty},");
            let _ = writeln!(defaults, "            {member}: Default::default(),");
        }
        let _ = writeln!(
            out,
            "}}\n\nimpl Default for {} {{\n    fn default() -> Self {{\n        Self {{\n{defaults}        }}\n    }}\n}}\n",
            spec.rust
        );
        // Safe code can read every member but a union (which needs to know
        // which member is live), the pNext chain and arrays (pointers).
        let unsafe_members = fields.iter().any(|f| {
            matches!(
                f.form,
                Form::Address { union: true, .. }
                    | Form::UsageCounts
                    | Form::Union { .. }
                    | Form::Elements { .. }
                    | Form::Handles(_)
                    | Form::Structs(_)
                    | Form::Blob(_)
            )
        });
        if !unsafe_members && spec.extracts.is_empty() {
            let _ = writeln!(
                out,
                "impl {} {{\n    /// The members of `info`, with no pNext chain (its pointer is not read).\n    \
                 pub fn from_members(info: &{}) -> Self {{\n        Self {{",
                spec.rust,
                ash_type(spec)
            );
            for field in &fields {
                let value = match &field.form {
                    Form::Next => "Vec::new()".to_string(),
                    _ => ash_member(field),
                };
                let _ = writeln!(out, "            {}: {value},", field.rust);
            }
            for (member, _, _) in spec.model_only {
                let _ = writeln!(out, "            {member}: Default::default(),");
            }
            out.push_str("        }\n    }\n}\n\n");
        }
    }
    for (union, rust) in UNIONS {
        let members = union_members(vk, union)?;
        let eq = members
            .iter()
            .map(|m| is_eq(vk, by_rust(m.element)))
            .collect::<Result<Vec<_>, _>>()?
            .into_iter()
            .all(|eq| eq);
        let _ = writeln!(
            out,
            "/// `{union}`: the member its selector selects.\n\
             // Builds hold a handful of these; keeping the members inline keeps\n\
             // every construction plain.\n#[allow(clippy::large_enum_variant)]\n\
             #[derive(Clone, Debug, Default, PartialEq, {}Serialize, Deserialize)]\n\
             #[serde(rename_all = \"camelCase\")]\npub enum {rust} {{",
            if eq { "Eq, " } else { "" }
        );
        for m in &members {
            let _ = writeln!(
                out,
                "    /// Selected by `{}`.\n    {}({}),",
                m.selection, m.variant, m.element
            );
        }
        out.push_str(
            "    /// No member is read: the selector selects none (or the application gave none).\n    \
             #[default]\n    None,\n}\n\n",
        );
    }
    Ok(out)
}

/// Whether the model of `spec` can derive `Eq`: not where a member of the
/// model only, or a structure it holds, has no `Eq` (instances hold `f32`s).
fn is_eq(vk: &VkXml, spec: &StructSpec) -> Result<bool, Error> {
    if !spec.model_only.is_empty() {
        return Ok(false);
    }
    for field in fields(vk, spec)? {
        let held: Vec<&str> = match &field.form {
            Form::Union { members, .. } => members.iter().map(|m| m.element).collect(),
            Form::Elements { element, .. } => vec![element],
            Form::Structs(structs) => vec![structs.element],
            _ => Vec::new(),
        };
        for element in held {
            if !is_eq(vk, by_rust(element))? {
                return Ok(false);
            }
        }
    }
    for (_, vk_name) in spec.extracts {
        if !is_eq(vk, chained(vk_name)?)? {
            return Ok(false);
        }
    }
    Ok(true)
}

/// `validator/src/scene/format/generated.rs`.
pub fn render_scene_form(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "Scene forms of the structures `xtask/src/structs.rs` describes: members\n\
         by their spec names, handles by object name, addresses by buffer and\n\
         offset, enums and flags by name.",
    );
    out.push_str(
        "use schemars::JsonSchema;\nuse serde::{Deserialize, Serialize};\n\n\
         use serde::Deserializer;\n\n\
         use super::{Contents, OtherStruct, UsageDesc};\nuse crate::model::names::{self, Value};\n\
         use crate::scene::args::{AddressArg, HandleArg};\n\n",
    );
    for spec in STRUCTS {
        let _ = writeln!(
            out,
            "/// {}\n#[derive(Debug, Deserialize, Serialize, JsonSchema)]\n\
             #[serde(deny_unknown_fields, rename_all = \"camelCase\")]\npub struct {}Desc {{",
            doc(spec),
            spec.rust
        );
        for field in fields(vk, spec)? {
            let name = crate::khr::snake_case(&field.name);
            let (attributes, ty) = match &field.form {
                Form::SType(_) if spec.chained => {
                    out.push_str(
                        "    /// The sType written, when it is not this structure's own: set only for\n    \
                         /// a chain entry that names the structure with `\"structure\"`.\n    \
                         #[serde(skip)]\n    #[schemars(skip)]\n    pub given_s_type: Option<i32>,\n",
                    );
                    continue;
                }
                Form::Next if spec.chained => continue,
                Form::UsageCounts => {
                    out.push_str(
                        "    /// Default: the length of pUsageCounts or ppUsageCounts.\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                         pub usage_counts_count: Option<u32>,\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                         pub p_usage_counts: Option<Vec<UsageDesc>>,\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                         pub pp_usage_counts: Option<Vec<Option<UsageDesc>>>,\n",
                    );
                    continue;
                }
                Form::Bool => ("    #[serde(default)]\n".to_string(), "bool".to_string()),
                Form::Structs(structs) => (
                    format!(
                        "    /// `{}`; `{}` is their number.\n    \
                         #[serde(default, skip_serializing_if = \"Vec::is_empty\")]\n",
                        structs.array, structs.count
                    ),
                    format!("Vec<{}Desc>", structs.element),
                ),
                Form::Blob(blob) if spec.required.contains(&blob.array.as_str()) => (
                    format!("    /// The bytes; `{}` is their length.\n", blob.count),
                    "Contents".to_string(),
                ),
                Form::Blob(blob) => (
                    format!(
                        "    /// The bytes; `{}` is their length.\n    \
                         #[serde(default, skip_serializing_if = \"Option::is_none\")]\n",
                        blob.count
                    ),
                    "Option<Contents>".to_string(),
                ),
                Form::Number { wide, .. } if spec.required.contains(&field.name.as_str()) => (
                    String::new(),
                    if *wide { "u64" } else { "u32" }.to_string(),
                ),
                Form::Handles(h) => (
                    format!(
                        "    /// `{}`, by name; `{}` is their number.\n    \
                         #[serde(default, skip_serializing_if = \"Vec::is_empty\")]\n",
                        h.array, h.count
                    ),
                    "Vec<HandleArg>".to_string(),
                ),
                Form::Union { rust, .. } => (
                    "    #[serde(default)]\n".to_string(),
                    format!("{rust}Desc"),
                ),
                Form::Elements {
                    element,
                    array,
                    pointers,
                    ..
                } => {
                    let _ = writeln!(
                        out,
                        "    /// Default: the length of {array} or {pointers}.\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    pub {name}: Option<u32>,\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                         pub {}: Option<Vec<{element}Desc>>,\n    \
                         #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                         pub {}: Option<Vec<Option<{element}Desc>>>,",
                        crate::khr::snake_case(array),
                        crate::khr::snake_case(pointers)
                    );
                    continue;
                }
                Form::Number {
                    wide,
                    default: Some(value),
                    ..
                } => (
                    format!(
                        "    /// Default {value}.\n    #[serde(skip_serializing_if = \"Option::is_none\")]\n"
                    ),
                    format!("Option<{}>", if *wide { "u64" } else { "u32" }),
                ),
                Form::SType(_) => (
                    "    #[serde(skip_serializing_if = \"Option::is_none\")]\n".to_string(),
                    "Option<Value<names::StructureType>>".to_string(),
                ),
                Form::Next => (
                    "    #[serde(default, skip_serializing_if = \"Vec::is_empty\")]\n".to_string(),
                    "Vec<ChainStruct>".to_string(),
                ),
                Form::Handle(_) => (
                    "    #[serde(default, skip_serializing_if = \"HandleArg::is_omitted\")]\n"
                        .to_string(),
                    "HandleArg".to_string(),
                ),
                Form::Address { .. } => (
                    "    #[serde(default)]\n".to_string(),
                    "AddressArg".to_string(),
                ),
                Form::Number { wide, .. } => (
                    "    #[serde(default)]\n".to_string(),
                    if *wide { "u64" } else { "u32" }.to_string(),
                ),
                Form::Flags { kind, .. } => (
                    "    #[serde(default)]\n".to_string(),
                    format!("Value<names::{kind}>"),
                ),
                Form::Enum {
                    kind,
                    required: true,
                    ..
                } => (String::new(), format!("Value<names::{kind}>")),
                Form::Enum {
                    kind,
                    default: EnumDefault::Value(default, _),
                    ..
                } => (
                    format!(
                        "    /// Default {default}.\n    #[serde(skip_serializing_if = \"Option::is_none\")]\n"
                    ),
                    format!("Option<Value<names::{kind}>>"),
                ),
                Form::Enum { kind, .. } => (
                    "    #[serde(default)]\n".to_string(),
                    format!("Value<names::{kind}>"),
                ),
            };
            let _ = writeln!(out, "{attributes}{}    pub {name}: {ty},", rename(&field));
        }
        out.push_str("}\n\n");
    }
    for (union, rust) in UNIONS {
        let _ = writeln!(
            out,
            "/// `{union}`: at most one member.\n\
             #[derive(Debug, Default, Deserialize, Serialize, JsonSchema)]\n\
             #[serde(deny_unknown_fields, rename_all = \"camelCase\")]\npub struct {rust}Desc {{"
        );
        for m in union_members(vk, union)? {
            let _ = writeln!(
                out,
                "    /// Selected by `{}`.\n    #[serde(skip_serializing_if = \"Option::is_none\")]\n    \
                 pub {}: Option<{}Desc>,",
                m.selection, m.name, m.element
            );
        }
        out.push_str("}\n\n");
    }
    render_chain_struct(vk, &mut out)?;
    Ok(out)
}

/// `ChainStruct`, the scene form of a pNext entry: one variant per chained
/// structure of [`STRUCTS`], named by its sType, and `Other`; with the
/// per-structure parts of reading an entry and of its sType.
fn render_chain_struct(vk: &VkXml, out: &mut String) -> Result<(), Error> {
    let chained: Vec<&StructSpec> = STRUCTS.iter().filter(|s| s.chained).collect();
    let mut variants = String::new();
    let mut by_tag = String::new();
    let mut by_name = String::new();
    let mut s_types = String::new();
    let mut by_variant = String::new();
    for spec in &chained {
        let entry = fields(vk, spec)?;
        let value = entry
            .iter()
            .find_map(|f| match f.form {
                Form::SType(value) => Some(value),
                _ => None,
            })
            .ok_or_else(|| Error::Registry(format!("{} has no sType", spec.vk)))?;
        let name = entry_s_type_name(vk, spec);
        let _ = writeln!(
            variants,
            "    #[serde(rename = \"{name}\")]\n    {}({}Desc),",
            spec.rust, spec.rust
        );
        let _ = writeln!(
            by_tag,
            "            // {name}\n            {value} => Deserialize::deserialize(rest).map(Self::{}),",
            spec.rust
        );
        let _ = writeln!(
            by_name,
            "            \"{}\" => serde_json::from_value(members).map(|d: {}Desc| Self::{}({}Desc {{ given_s_type: given, ..d }})),",
            spec.vk, spec.rust, spec.rust, spec.rust
        );
        let _ = writeln!(
            s_types,
            "            Self::{}(d) => d.given_s_type.unwrap_or({value}),",
            spec.rust
        );
        let _ = writeln!(
            by_variant,
            "            Self::{}(d) => (serde_json::to_value(d), \"{}\", d.given_s_type.is_some()),",
            spec.rust, spec.vk
        );
    }
    let names: Vec<String> = chained.iter().map(|s| format!("`{}`", s.vk)).collect();
    let _ = write!(
        out,
        "/// A structure of a pNext chain, named by its `sType`. The structures\n\
         /// ommcheck reads have their members; any other sType is recorded as chained\n\
         /// (its members are ignored).\n\
         #[derive(Debug, JsonSchema)]\n#[serde(tag = \"sType\")]\npub enum ChainStruct {{\n{variants}\
         \x20   /// Any other sType (by name or number); other members are ignored.\n    \
         #[serde(untagged)]\n    Other(OtherStruct),\n}}\n\n\
         impl ChainStruct {{\n    \
         /// The structures with members of their own, by their spec names: {}.\n    \
         pub const READ: &'static [&'static str] = &[{}];\n\n    \
         /// The entry whose sType is `tag`, from its other members; `other`\n    \
         /// reads it where `tag` is none of the structures with members.\n    \
         pub(super) fn tagged<'de, D: Deserializer<'de>>(\n        tag: Value<names::StructureType>,\n        rest: D,\n        \
         other: impl FnOnce(Value<names::StructureType>, D) -> Result<Self, D::Error>,\n    ) -> Result<Self, D::Error> {{\n        \
         match tag.raw() {{\n{by_tag}            _ => other(tag, rest),\n        }}\n    }}\n\n    \
         /// The structure `structure` (by its spec name) written with the sType\n    \
         /// `given`, from its members; None where it is none of the structures\n    \
         /// with members.\n    \
         pub(super) fn named(structure: &str, members: serde_json::Value, given: Option<i32>) -> Option<Result<Self, serde_json::Error>> {{\n        \
         Some(match structure {{\n{by_name}            _ => return None,\n        }})\n    }}\n\n    \
         /// The sType the entry stands for.\n    pub fn s_type(&self) -> i32 {{\n        match self {{\n{s_types}\
         \x20           Self::Other(other) => other.s_type.as_i32(),\n        }}\n    }}\n}}\n\n\
         // Written as it reads back: an entry with another structure's sType\n\
         // names its structure with `structure`.\n\
         impl Serialize for ChainStruct {{\n    \
         fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {{\n        \
         use serde::ser::Error as _;\n        \
         let (members, structure, misnamed) = match self {{\n{by_variant}\
         \x20           Self::Other(other) => return other.serialize(serializer),\n        }};\n        \
         let mut members = members.map_err(S::Error::custom)?;\n        \
         if let Some(map) = members.as_object_mut() {{\n            \
         let s_type = Value::<names::StructureType>::new(i64::from(self.s_type()));\n            \
         map.insert(\"sType\".into(), serde_json::to_value(s_type).map_err(S::Error::custom)?);\n            \
         if misnamed {{\n                map.insert(\"structure\".into(), structure.into());\n            }}\n        }}\n        \
         members.serialize(serializer)\n    }}\n}}\n",
        names.join(", "),
        chained.iter().map(|s| format!("\"{}\"", s.vk)).collect::<Vec<_>>().join(", ")
    );
    Ok(())
}

/// `validator/src/scene/resolve/generated.rs`.
pub fn render_resolver(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The scene → model resolvers of the structures `xtask/src/structs.rs`\n\
         describes: names become handles and addresses, absent members their\n\
         defaults.",
    );
    out.push_str(
        "// A structure of plain numbers uses neither `at` nor its defaults.\n\
         #![allow(unused_variables)]\n\n\
         use super::{chain, problem, s_type, usage_counts, ObjectKind, Resolver, Result};\n\
         use crate::model::generated as model;\nuse crate::model::names::Value;\n\
         use crate::scene::format::generated as scene;\nuse crate::scene::format::ChainStruct;\n\n\
         impl Resolver<'_> {\n",
    );
    for spec in STRUCTS {
        let fields = fields(vk, spec)?;
        let mut lets = String::new();
        let mut body = String::new();
        for field in &fields {
            let d = format!("d.{}", crate::khr::snake_case(&field.name));
            let at = format!("&format!(\"{{at}}.{}\")", field.name);
            let value = match &field.form {
                Form::Bool => d,
                Form::Handles(h) => format!(
                    "{d}.iter().enumerate().map(|(k, h)| self.handle(h, ObjectKind::{}, \
                     &format!(\"{{at}}.{}[{{k}}]\"))).collect::<Result<Vec<_>>>()?",
                    h.kind, h.array
                ),
                Form::Union { rust, .. } => {
                    format!("self.{}(&{d}, {at})?", crate::khr::snake_case(rust))
                }
                Form::Structs(structs) => format!(
                    "{d}.iter().enumerate().map(|(k, e)| self.{}(e, \
                     &format!(\"{{at}}.{}[{{k}}]\"))).collect::<Result<Vec<_>>>()?",
                    function(by_rust(structs.element)),
                    structs.array
                ),
                Form::Blob(blob) if spec.required.contains(&blob.array.as_str()) => {
                    format!("self.sized_contents(&{d}, {at})?.to_vec()")
                }
                Form::Blob(_) => format!(
                    "match &{d} {{ Some(c) => self.sized_contents(c, {at})?.to_vec(), None => Vec::new() }}"
                ),
                Form::Elements {
                    index,
                    element,
                    array,
                    pointers,
                } => {
                    let e = &spec.elements[*index];
                    let _ = writeln!(
                        lets,
                        "        let ({}, {}, {}) = self.elements({d}, &d.{}, &d.{}, at, [\"{array}\", \"{pointers}\"], Self::{})?;",
                        field.rust,
                        e.array,
                        e.pointers,
                        crate::khr::snake_case(array),
                        crate::khr::snake_case(pointers),
                        function(by_rust(element)),
                    );
                    let _ = writeln!(
                        body,
                        "            {},\n            {},\n            {},",
                        field.rust, e.array, e.pointers
                    );
                    continue;
                }
                Form::SType(_) if spec.chained => {
                    "d.given_s_type.unwrap_or(defaults.s_type)".to_string()
                }
                Form::Next if spec.chained => "Vec::new()".to_string(),
                Form::SType(_) => format!("s_type({d}, defaults.s_type)"),
                Form::Next if !spec.extracts.is_empty() => "Vec::new()".to_string(),
                Form::Next => format!("chain(&{d})"),
                Form::Handle(kind) if LOOSE_KINDS.contains(kind) => {
                    format!("self.loose_handle(&{d}, ObjectKind::{kind}, {at})?")
                }
                Form::Handle(kind) => format!("self.handle(&{d}, ObjectKind::{kind}, {at})?"),
                Form::Address { .. } => format!("self.address(&{d}, {at})?"),
                Form::Number {
                    default: Some(_), ..
                } => format!("{d}.unwrap_or(defaults.{})", field.rust),
                Form::Number { .. } => d,
                Form::UsageCounts => {
                    "usage_counts(d.usage_counts_count, &d.p_usage_counts, &d.pp_usage_counts, at)?"
                        .to_string()
                }
                Form::Flags { wide: true, .. } => format!("{d}.as_u64()"),
                Form::Flags { wide: false, .. } => format!("{d}.as_u32()"),
                Form::Enum {
                    default: EnumDefault::Value(..),
                    required: false,
                    ..
                } => format!("{d}.map_or(defaults.{}, Value::as_i32)", field.rust),
                Form::Enum { .. } => format!("{d}.as_i32()"),
            };
            let _ = writeln!(body, "            {}: {value},", field.rust);
        }
        let _ = write!(
            out,
            "    /// A {} at `at`.\n    pub(in crate::scene) fn {}({}, d: &scene::{}Desc, at: &str) -> Result<model::{}> {{\n        \
             let defaults = model::{}::default();\n{lets}        {}model::{} {{\n{body}",
            doc(spec).trim_end_matches('.'),
            function(spec),
            if resolves_mutably(vk, spec)? { "&mut self" } else { "&self" },
            spec.rust,
            spec.rust,
            spec.rust,
            if spec.extracts.is_empty() { "Ok(" } else { "let mut value = " },
            spec.rust
        );
        if spec.extracts.is_empty() {
            for (member, _, _) in spec.model_only {
                let _ = writeln!(out, "            {member}: Default::default(),");
            }
            out.push_str("        })\n    }\n\n");
            continue;
        }
        // The first of each extracted structure goes to its member; the
        // rest, and every other structure, stay sTypes in the chain for
        // the pNext rules to judge.
        out.push_str("            ..defaults\n        };\n        for (k, next) in d.p_next.iter().enumerate() {\n            \
                      let next_at = format!(\"{at}.pNext[{k}]\");\n            match next {\n");
        for (member, vk_name) in spec.extracts {
            let entry = chained(vk_name)?;
            let _ = writeln!(
                out,
                "                ChainStruct::{}(e) if value.{member}.is_none() => {{\n                    \
                 value.{member} = Some(self.{}(e, &next_at)?);\n                }}",
                entry.rust,
                function(entry)
            );
        }
        out.push_str(
            "                other => value.next.push(other.s_type()),\n            }\n        }\n        \
             Ok(value)\n    }\n\n",
        );
    }
    for (union, rust) in UNIONS {
        let members = union_members(vk, union)?;
        let names: Vec<&str> = members.iter().map(|m| m.name.as_str()).collect();
        let _ = writeln!(
            out,
            "    /// A `{union}` at `at`: the one member given (the application's\n    \
             /// selector is its own member, checked by the rules).\n    \
             pub(in crate::scene) fn {}(&self, d: &scene::{rust}Desc, at: &str) -> Result<model::{rust}> {{\n        \
             if [{}].iter().filter(|given| **given).count() > 1 {{\n            \
             return problem(at, \"a {union} union holds one member: give one of {}\");\n        }}",
            crate::khr::snake_case(rust),
            names.iter().map(|n| format!("d.{n}.is_some()")).collect::<Vec<_>>().join(", "),
            names.join(", ")
        );
        for m in &members {
            let _ = writeln!(
                out,
                "        if let Some(member) = &d.{} {{\n            \
                 return Ok(model::{rust}::{}(self.{}(member, &format!(\"{{at}}.{}\"))?));\n        }}",
                m.name,
                m.variant,
                function(by_rust(m.element)),
                m.name
            );
        }
        let _ = writeln!(out, "        Ok(model::{rust}::None)\n    }}\n");
    }
    out.push_str("}\n");
    Ok(out)
}

/// `validator/src/raw/generated.rs`.
pub fn render_reader(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "Readers of the structures `xtask/src/structs.rs` describes, from the\n\
         ash structures an application hands in: members as written, the\n\
         pNext chain walked as `chain_s_types` walks it, addresses as numbers.",
    );
    out.push_str(
        "// A structure with no pNext chain or arrays of its own reads no memory:\n// its `function`, `at` and `findings` go unused.\n#![allow(unused_imports, unused_variables, clippy::ptr_arg)]\n\nuse std::fmt::Display;\n\nuse ash::vk;\nuse ommcheck_vuids::khr;\n\n\
         use super::accel::{self, address, scratch_address};\n\
         use super::{array_slice, chain, chain_s_types, read_array, read_bytes, read_elements, usage_counts, ElementArrays};\n\
         use crate::model::generated as model;\nuse crate::model::micromap::MicromapUsage;\n\
         use crate::report::location::Locate;\nuse crate::report::Finding;\n\n",
    );
    for spec in STRUCTS {
        let fields = fields(vk, spec)?;
        if read_by_members(spec, &fields) {
            continue;
        }
        let safety = if spec.chained {
            "/// Its own pNext chain is part of the chain the caller walks."
        } else if !fields.iter().any(|f| f.form == Form::Next) {
            "/// `info` must be valid as the API requires."
        } else {
            "/// `info`'s pNext chain must be well formed."
        };
        let usages = fields.iter().any(|f| f.form == Form::UsageCounts);
        let arrays = if usages {
            "\n/// Its usage-count pointers must be NULL or valid for `usageCountsCount`\n\
             /// elements, as the API requires."
        } else if !spec.extracts.is_empty() {
            "\n/// The structures it takes from the chain must be valid as their own\n\
             /// readers require."
        } else if fields
            .iter()
            .any(|f| matches!(f.form, Form::Elements { .. }))
        {
            "\n/// Its arrays must be NULL or valid for their counts, and each element\n\
             /// valid as its own reader requires, as the API requires."
        } else if fields.iter().any(|f| matches!(f.form, Form::Handles(_))) {
            "\n/// Its arrays of handles must be NULL or valid for their counts, as the\n\
             /// API requires."
        } else if fields
            .iter()
            .any(|f| matches!(f.form, Form::Structs(_) | Form::Blob(_)))
        {
            "\n/// Its arrays and bytes must be NULL or valid for their counts, each\n\
             /// element valid as its own reader requires, as the API requires."
        } else if fields.iter().any(|f| matches!(f.form, Form::Union { .. })) {
            "\n/// Its unions must hold the member their selector selects, valid as\n\
             /// that member's reader requires."
        } else {
            ""
        };
        // A build reads its usage counts into an allocation it keeps from
        // call to call.
        let spare = if usages {
            "spare_usages: Vec<MicromapUsage>, "
        } else {
            ""
        };
        let mut lets = String::new();
        for field in &fields {
            let Form::Elements {
                index,
                element,
                array,
                pointers,
            } = &field.form
            else {
                continue;
            };
            let e = &spec.elements[*index];
            let _ = writeln!(
                lets,
                "    let read = |element: &{}, at: &dyn Display, findings: &mut Vec<Finding>| {{\n        \
                 // SAFETY: each element is one the caller guarantees valid.\n        \
                 unsafe {{ {}(element, function, at, findings) }}\n    }};\n    \
                 let members = ElementArrays {{ count: info.{}, array: info.{}, pointers: info.{}, \
                 bound: {}, names: [\"{}\", \"{array}\", \"{pointers}\"], noun: \"{}\" }};\n    \
                 // SAFETY: forwarded from the caller.\n    \
                 let ({}, {}, {}) = unsafe {{ read_elements(members, function, at, findings, read) }};",
                ash_type(by_rust(element)),
                function(by_rust(element)),
                field.rust,
                crate::khr::snake_case(array),
                crate::khr::snake_case(pointers),
                e.bound,
                field.name,
                e.noun,
                field.rust,
                e.array,
                e.pointers,
            );
        }
        let _ = writeln!(
            out,
            "/// Reads a {} (at `at`, as findings name it).\n///\n/// # Safety\n\
             {safety}{arrays}\n\
             pub(crate) unsafe fn {}({spare}info: &{}, function: &'static str, at: impl Display + Copy, findings: &mut Vec<Finding>) -> model::{} {{\n\
             {lets}    {}model::{} {{",
            doc(spec).trim_end_matches('.'),
            function(spec),
            ash_type(spec),
            spec.rust,
            if spec.extracts.is_empty() { "" } else { "let mut value = " },
            spec.rust,
        );
        for field in &fields {
            let value = match &field.form {
                Form::Elements { index, .. } => {
                    let e = &spec.elements[*index];
                    let _ = writeln!(
                        out,
                        "        {},\n        {},\n        {},",
                        field.rust, e.array, e.pointers
                    );
                    continue;
                }
                Form::Union {
                    rust,
                    selector,
                    members,
                } => {
                    let mut arms = String::new();
                    for m in members {
                        let entry = by_rust(m.element);
                        let read = if read_by_members(entry, &self::fields(vk, entry)?) {
                            format!("model::{}::from_members(member)", entry.rust)
                        } else {
                            format!(
                                "{{\n                    // SAFETY: forwarded from the caller.\n                    \
                                 unsafe {{ {}(member, function, at.text(\".{}.{}\"), findings) }}\n                }}",
                                function(entry),
                                field.name,
                                m.name
                            )
                        };
                        let _ = writeln!(
                            arms,
                            "            // {}\n            {} => {{\n                \
                             // SAFETY: the caller guarantees the union holds the member\n                \
                             // `{selector}` selects: {}.\n                \
                             let member = unsafe {{ &info.{}.{} }};\n                \
                             model::{rust}::{}({read})\n            }}",
                            m.selection, m.value, m.name, field.rust, m.name, m.variant
                        );
                    }
                    format!(
                        "match info.{selector}.as_raw() {{\n{arms}            \
                         // Any other value selects no member known to be valid.\n            \
                         _ => model::{rust}::None,\n        }}"
                    )
                }
                Form::Structs(structs) => struct_array_reader(vk, structs)?,
                Form::Blob(blob) => format!(
                    "unsafe {{ read_bytes(info.{}.cast(), info.{}, function, at.text(\".{}\"), findings) }}\n            \
                     .unwrap_or_default()",
                    crate::khr::snake_case(&blob.array),
                    crate::khr::snake_case(&blob.count),
                    blob.array
                ),
                Form::Next if spec.chained || !spec.extracts.is_empty() => "Vec::new()".to_string(),
                Form::Next => {
                    "unsafe { chain_s_types(info.p_next, function, at, findings) }".to_string()
                }
                _ => ash_member(field),
            };
            if matches!(field.form, Form::Next if !spec.chained && spec.extracts.is_empty())
                || matches!(
                    field.form,
                    Form::UsageCounts | Form::Handles(_) | Form::Structs(_) | Form::Blob(_)
                )
            {
                out.push_str("        // SAFETY: forwarded from the caller.\n");
            }
            let _ = writeln!(out, "        {}: {value},", field.rust);
        }
        if spec.extracts.is_empty() {
            for (member, _, _) in spec.model_only {
                let _ = writeln!(out, "        {member}: Default::default(),");
            }
            out.push_str("    }\n}\n\n");
            continue;
        }
        for (member, _) in spec.extracts {
            let _ = writeln!(out, "        {member}: None,");
        }
        out.push_str(
            "    };\n    // SAFETY: forwarded from the caller.\n    \
             let links = unsafe { chain(info.p_next, function, at, findings) };\n    \
             for link in links {\n        match link.s_type {\n",
        );
        for (member, vk_name) in spec.extracts {
            let entry = chained(vk_name)?;
            let entry_fields = self::fields(vk, entry)?;
            let s_type = entry_fields
                .iter()
                .find_map(|f| match f.form {
                    Form::SType(value) => Some(value),
                    _ => None,
                })
                .ok_or_else(|| Error::Registry(format!("{vk_name} has no sType")))?;
            let spare = if entry_fields.iter().any(|f| f.form == Form::UsageCounts) {
                "Vec::new(), "
            } else {
                ""
            };
            let read = if read_by_members(entry, &entry_fields) {
                format!("model::{}::from_members(entry)", entry.rust)
            } else {
                format!(
                    "{{\n                    let entry_at = at.text(\".pNext<{vk_name}>\");\n                    \
                     // SAFETY: forwarded from the caller.\n                    \
                     unsafe {{ {}({spare}entry, function, entry_at, findings) }}\n                }}",
                    function(entry)
                )
            };
            let _ = writeln!(
                out,
                "            // {}\n            {s_type} if value.{member}.is_none() => {{\n                \
                 // SAFETY: a structure in a valid chain with this sType is a\n                \
                 // {vk_name}.\n                \
                 let entry = unsafe {{ &*link.address.cast::<{}>() }};\n                \
                 value.{member} = Some({read});\n            }}",
                entry_s_type_name(vk, entry),
                ash_type(entry),
            );
        }
        out.push_str(
            "            other => value.next.push(other),\n        }\n    }\n    value\n}\n\n",
        );
    }
    Ok(out)
}

/// The raw reader's expression for a plain array of structures: bounded
/// by `read_array`'s bound before anything is read, each element read as
/// its own reader reads it.
fn struct_array_reader(vk: &VkXml, structs: &Structs) -> Result<String, Error> {
    let element = by_rust(structs.element);
    let array = crate::khr::snake_case(&structs.array);
    let count = crate::khr::snake_case(&structs.count);
    Ok(if read_by_members(element, &fields(vk, element)?) {
        format!(
            "unsafe {{ read_array(info.{array}, info.{count}, function, at.text(\".{}\"), findings) }}\n            \
             .unwrap_or_default().iter().map(model::{}::from_members).collect()",
            structs.array, element.rust
        )
    } else {
        format!(
            "unsafe {{ array_slice(info.{array}, info.{count}, function, at.text(\".{}\"), findings) }}\n            \
             .unwrap_or_default().iter().enumerate().map(|(i, e)| {{\n                \
             // SAFETY: each element is one the caller guarantees valid.\n                \
             unsafe {{ {}(e, function, at.text(\".{}\").index(i), findings) }}\n            }}).collect()",
            structs.array,
            function(element),
            structs.array
        )
    })
}

/// Whether the model's `from_members` reads all of `spec` (no union, no
/// arrays, no chain of its own to walk), so it has no raw reader.
pub(crate) fn read_by_members(spec: &StructSpec, fields: &[Field]) -> bool {
    spec.extracts.is_empty()
        && fields.iter().all(|f| match f.form {
            Form::UsageCounts
            | Form::Address { union: true, .. }
            | Form::Union { .. }
            | Form::Elements { .. }
            | Form::Handles(_)
            | Form::Structs(_)
            | Form::Blob(_) => false,
            Form::Next => spec.chained,
            _ => true,
        })
}

/// The vk.xml name of `spec`'s sType value.
fn entry_s_type_name(vk: &VkXml, spec: &StructSpec) -> String {
    vk.aggregate(spec.vk)
        .and_then(|a| {
            a.members
                .iter()
                .find(|m| m.name == "sType")
                .and_then(|m| m.values.clone())
        })
        .unwrap_or_default()
}

/// `validator/src/scene/write/generated.rs`.
pub fn render_writer(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The model → scene writers of the structures `xtask/src/structs.rs`\n\
         describes: what the resolver reads back to the same model. Members\n\
         at their defaults are left out where the scene form allows it.",
    );
    out.push_str(
        "// A structure of plain numbers names no objects or addresses.\n\
         #![allow(unused_variables)]\n\n\
         use super::{chain_entry, contents, elements_count, usage_counts_count, usage_desc, Names};\n\
         use crate::model::generated as model;\n\
         use crate::model::names::Value;\nuse crate::scene::format::generated as scene;\n\
         use crate::scene::format::ChainStruct;\nuse crate::scene::ObjectKind;\n\n",
    );
    for spec in STRUCTS {
        let fields = fields(vk, spec)?;
        let _ = writeln!(
            out,
            "impl scene::{}Desc {{\n    /// The scene form of a {}, naming objects and addresses by `names`.\n    \
             pub fn written(model: &model::{}, names: &dyn Names) -> Self {{\n        \
             let defaults = model::{}::default();\n        Self {{",
            spec.rust,
            doc(spec).trim_end_matches('.'),
            spec.rust,
            spec.rust
        );
        for field in &fields {
            let m = format!("model.{}", field.rust);
            let value = match &field.form {
                Form::SType(_) if spec.chained => {
                    let _ = writeln!(
                        out,
                        "            given_s_type: ({m} != defaults.s_type).then_some({m}),"
                    );
                    continue;
                }
                Form::Bool => m,
                Form::Handles(h) => format!(
                    "{m}.iter().map(|h| names.handle(ObjectKind::{}, *h)).collect()",
                    h.kind
                ),
                Form::Union { rust, .. } => format!("scene::{rust}Desc::written(&{m}, names)"),
                Form::Structs(structs) => format!(
                    "{m}.iter().map(|e| scene::{}Desc::written(e, names)).collect()",
                    structs.element
                ),
                Form::Blob(blob) if spec.required.contains(&blob.array.as_str()) => {
                    format!("contents(&{m})")
                }
                Form::Blob(_) => format!("(!{m}.is_empty()).then(|| contents(&{m}))"),
                Form::Elements {
                    index,
                    element,
                    array,
                    pointers,
                } => {
                    let e = &spec.elements[*index];
                    let _ = writeln!(
                        out,
                        "            {}: elements_count({m}, &model.{}, &model.{}),\n            \
                         {}: model.{}.as_ref().map(|a| a.iter().map(|e| scene::{element}Desc::written(e, names)).collect()),\n            \
                         {}: model.{}.as_ref().map(|p| p.iter().map(|e| e.as_ref().map(|e| scene::{element}Desc::written(e, names))).collect()),",
                        field.rust,
                        e.array,
                        e.pointers,
                        crate::khr::snake_case(array),
                        e.array,
                        crate::khr::snake_case(pointers),
                        e.pointers
                    );
                    continue;
                }
                // A chained structure's own pNext is its parent's chain.
                Form::Next if spec.chained => continue,
                Form::UsageCounts => {
                    let _ = writeln!(
                        out,
                        "            usage_counts_count: usage_counts_count(&{m}),\n            \
                         p_usage_counts: {m}.array.as_ref().map(|a| a.iter().map(usage_desc).collect()),\n            \
                         pp_usage_counts: {m}.pointers.as_ref().map(|p| p.iter().map(|u| u.as_ref().map(usage_desc)).collect()),"
                    );
                    continue;
                }
                Form::Number {
                    default: Some(_), ..
                } => format!("({m} != defaults.{}).then_some({m})", field.rust),
                Form::SType(_) => {
                    format!("({m} != defaults.s_type).then(|| Value::new(i64::from({m})))")
                }
                // The extracted structures first: the resolver extracts the
                // first entry of each sType, and the chain's other entries
                // of that sType are sTypes alone.
                Form::Next if !spec.extracts.is_empty() => {
                    let mut entries = "std::iter::empty()".to_string();
                    for (member, vk_name) in spec.extracts {
                        let entry = chained(vk_name)?;
                        let _ = write!(
                            entries,
                            ".chain(model.{member}.iter().map(|e| ChainStruct::{}(scene::{}Desc::written(e, names))))",
                            entry.rust, entry.rust
                        );
                    }
                    format!("{entries}.chain({m}.iter().copied().map(chain_entry)).collect()")
                }
                Form::Next => format!("{m}.iter().copied().map(chain_entry).collect()"),
                Form::Handle(kind) => format!("names.handle(ObjectKind::{kind}, {m})"),
                Form::Address { .. } => format!("names.address({m})"),
                Form::Number { .. } => m,
                // The bits as they are: bit 63, which no Vulkan flag uses,
                // then reads back as an error rather than as other bits.
                Form::Flags { wide: true, .. } => {
                    format!("Value::new(i64::from_ne_bytes({m}.to_ne_bytes()))")
                }
                Form::Flags { wide: false, .. } => format!("Value::new(i64::from({m}))"),
                Form::Enum {
                    default: EnumDefault::Value(..),
                    required: false,
                    ..
                } => format!(
                    "({m} != defaults.{}).then(|| Value::new(i64::from({m})))",
                    field.rust
                ),
                Form::Enum { .. } => format!("Value::new(i64::from({m}))"),
            };
            let _ = writeln!(
                out,
                "            {}: {value},",
                crate::khr::snake_case(&field.name)
            );
        }
        out.push_str("        }\n    }\n}\n\n");
    }
    for (union, rust) in UNIONS {
        let _ = writeln!(
            out,
            "impl scene::{rust}Desc {{\n    /// The scene form of a `{union}`, naming objects and addresses by `names`.\n    \
             pub fn written(model: &model::{rust}, names: &dyn Names) -> Self {{\n        match model {{"
        );
        for m in union_members(vk, union)? {
            let _ = writeln!(
                out,
                "            model::{rust}::{}(member) => Self {{\n                \
                 {}: Some(scene::{}Desc::written(member, names)),\n                ..Self::default()\n            }},",
                m.variant, m.name, m.element
            );
        }
        let _ = writeln!(
            out,
            "            model::{rust}::None => Self::default(),\n        }}\n    }}\n}}\n"
        );
    }
    // Every generated structure reads back to the model it was written from.
    out.push_str(
        "#[cfg(test)]\nmod tests {\n    use super::super::{Names, Numbers};\n    \
         use crate::model::generated as model;\n    use crate::scene::format::generated as scene;\n\n",
    );
    for spec in STRUCTS {
        let fields = fields(vk, spec)?;
        let _ = writeln!(
            out,
            "    #[test]\n    fn {}_reads_back_as_written() {{\n        let model = model::{} {{",
            function(spec),
            spec.rust
        );
        for (i, field) in fields.iter().enumerate() {
            let i = i as u64 + 1;
            let value = match &field.form {
                Form::SType(_) => continue,
                Form::Next if spec.chained => continue,
                // An sType of no structure the scene form reads.
                Form::Next => "vec![1_000_001_000]".to_string(),
                Form::Handle(_) => format!("0x1000 + {i}"),
                Form::Handles(_) => format!("vec![0x1000 + {i}, 0]"),
                Form::Structs(_) => "vec![Default::default()]".to_string(),
                Form::Blob(_) => format!("vec![{i}, 0, 0xff]"),
                Form::Address { .. } => format!("0x2000_0000 + {i}"),
                Form::Number { .. } | Form::Flags { .. } | Form::Enum { .. } => i.to_string(),
                // A count beyond the arrays, a one-element array and a NULL
                // pointer element: each member must come back.
                Form::UsageCounts => format!(
                    "crate::model::micromap::UsageCounts {{ count: {i}, \
                     array: Some(vec![crate::model::micromap::MicromapUsage {{ count: 1, subdivision_level: 2, format: 1 }}]), \
                     pointers: Some(vec![None]) }}"
                ),
                Form::Bool => "true".to_string(),
                // A member other than the default's.
                Form::Union { rust, members, .. } => match members.last() {
                    Some(m) => format!("model::{rust}::{}(Default::default())", m.variant),
                    None => format!("model::{rust}::None"),
                },
                Form::Elements { index, .. } => {
                    let e = &spec.elements[*index];
                    let _ = writeln!(
                        out,
                        "            {}: {i},\n            {}: Some(vec![Default::default()]),\n            \
                         {}: Some(vec![None]),",
                        field.rust, e.array, e.pointers
                    );
                    continue;
                }
            };
            let _ = writeln!(out, "            {}: {value},", field.rust);
        }
        // The sType, a chained structure's pNext and extracted structures
        // keep their defaults.
        let rest = if fields
            .iter()
            .any(|f| matches!(f.form, Form::SType(_) | Form::Next))
            || !spec.extracts.is_empty()
            || !spec.model_only.is_empty()
        {
            "            ..Default::default()\n"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "{rest}        }};\n        \
             let names: &dyn Names = &Numbers;\n        \
             let json = serde_json::to_string(&scene::{}Desc::written(&model, names)).unwrap();\n        \
             let read: scene::{}Desc = serde_json::from_str(&json).unwrap();\n        \
             assert_eq!(crate::scene::resolve_alone(|r| r.{}(&read, \"x\")), Ok(model), \"{{json}}\");\n    }}\n",
            spec.rust,
            spec.rust,
            function(spec)
        );
    }
    out.push_str("}\n");
    Ok(out)
}
