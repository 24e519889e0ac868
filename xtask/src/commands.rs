//! The commands whose entry points are generated from one description each:
//! the model of a call's parameters (`validator/src/model/calls.rs`), the
//! dispatch from that model to the command's `Validator` method
//! (`validator/src/checks/calls.rs`), the scene form of the call with the
//! `Call` enum and its names (`validator/src/scene/format/calls.rs`), the
//! scene → model resolver (`validator/src/scene/resolve/calls.rs`), the
//! model → scene writer with a round-trip test per command
//! (`validator/src/scene/write/calls.rs`) and, where the parameters allow,
//! the `*_raw` wrapper a layer calls (`validator/src/raw/calls.rs`).
//!
//! vk.xml gives each command's parameters, their types and which count
//! counts which array; a parameter's type decides its form ([`Param`]) in
//! every file, through the structures `crate::structs` describes. What
//! vk.xml does not say is in [`COMMANDS`]: the Rust name, the `Validator`
//! method, whether a scene may give `null` for an info pointer, the forms
//! of the few parameters that are not plain (a [`Custom`] names hand-written
//! helpers), and where a method takes fewer parameters than the command.

use std::fmt::Write as _;

use crate::registry::{Member, VkXml};
use crate::structs::{ash_type, fields, kind_of, read_by_members, HANDLE_KINDS, STRUCTS};
use crate::Error;

/// One command described for the generator.
pub struct CommandSpec {
    /// The vk.xml name.
    pub vk: &'static str,
    /// The name of its `Call` variant, scene struct and model struct.
    pub rust: &'static str,
    /// The `Validator` method that checks and records it.
    pub method: &'static str,
    /// Said after the signature in the scene struct's doc; may be empty.
    pub doc: &'static str,
    /// Whether a scene states an info pointer as `null` for NULL (and must
    /// state it); else the info is a plain required member.
    pub nullable: bool,
    /// Parameters whose form vk.xml's type does not decide.
    pub params: &'static [(&'static str, Param)],
    /// Docs of scene members, by vk.xml name.
    pub docs: &'static [(&'static str, &'static str)],
    /// Parameters the method does not take (resolved, then not passed).
    pub skip: &'static [&'static str],
    /// The method's arguments where they are not the parameters in order
    /// (`c` is the model call); empty: in order.
    pub args: &'static str,
    /// A hand-written step of the resolver after the parameters are
    /// resolved (`call` is the model call, mutable); empty: none.
    pub then: &'static str,
    /// The command reads host memory its structures point to (a
    /// deserialization's header): its raw wrapper is hand-written.
    pub host_read: bool,
}

/// A spec's fields that are empty in most entries.
pub const BASE: CommandSpec = CommandSpec {
    vk: "",
    rust: "",
    method: "",
    doc: "",
    nullable: false,
    params: &[],
    docs: &[],
    skip: &[],
    args: "",
    then: "",
    host_read: false,
};

/// A parameter whose scene and model forms are hand-written types, with
/// hand-written helpers between them. In the expressions `$s` is the scene
/// member, `$m` the model member and `$at` the parameter's location.
#[derive(Debug)]
pub struct Custom {
    /// The scene member's type and serde attributes.
    pub scene: &'static str,
    pub serde: &'static str,
    /// The model member's type.
    pub model: &'static str,
    /// The resolver's expression (may use `?`), the writer's, the method's
    /// argument and a test value.
    pub resolve: &'static str,
    pub write: &'static str,
    pub arg: &'static str,
    pub test: &'static str,
}

/// What a parameter is, which decides its form in every generated file.
#[derive(Debug)]
pub enum Param {
    /// `VkDevice`: omitted is the scene's device.
    Device,
    /// `VkCommandBuffer`: a name, an inline description or null.
    CommandBuffer,
    /// A handle naming an object of this `ObjectKind`.
    Handle(&'static str),
    /// A pointer through which the command returns a new object of this
    /// `ObjectKind`: the scene names it (null: NULL).
    Created(&'static str),
    /// An array of handles of this `ObjectKind`, its count its length.
    Handles(&'static str),
    /// `micromapCount` with `pMicromaps`: a count the scene may leave to
    /// the array's length, and an array that may be NULL.
    MicromapList,
    /// A 32-bit enum of this `names` kind; a scene must state it.
    Enum(&'static str),
    /// A plain number; `wide`: 64-bit.
    Number {
        wide: bool,
    },
    /// A pointer only looked at as an address (`void* pData`).
    Address,
    /// An array of `VkDeviceAddress`es.
    Addresses,
    /// An array of `uint32_t`.
    Numbers,
    /// An array of `uint32_t` whose length another structure gives: absent
    /// or null is NULL.
    OptionalNumbers,
    /// An array of pointers to arrays of `uint32_t` (null: a NULL element).
    NumberLists,
    /// A pointer to a structure of `STRUCTS` (this Rust name).
    Info {
        rust: &'static str,
        nullable: bool,
    },
    /// An array of structures of `STRUCTS`, its count its length.
    Infos(&'static str),
    /// An array of pointers to arrays of structures of `STRUCTS` (null: a
    /// NULL element).
    Lists(&'static str),
    /// `const VkAllocationCallbacks* pAllocator`.
    Allocator,
    Custom(&'static Custom),
}

/// `pSizeInfo` of `vkGetMicromapBuildSizesEXT`: absent is a structure with
/// its sType, null is NULL.
const MICROMAP_SIZES: Custom = Custom {
    scene: "Option<SizesInfoDesc>",
    serde: "#[serde(default = \"some_sizes_info\", deserialize_with = \"nullable\")]",
    model: "Option<crate::model::micromap_objects::MicromapBuildSizesInfo>",
    resolve: "sizes_info(&$s)",
    write: "sizes_info_desc(&$m)",
    arg: "$m.as_ref()",
    test: "Some(Default::default())",
};

/// `pSizeInfo` of `vkGetAccelerationStructureBuildSizesKHR`: its sType
/// and chain, which no rule reads; absent is NULL.
const ACCELERATION_SIZES: Custom = Custom {
    scene: "Option<SizesInfoDesc>",
    serde: "#[serde(default)]",
    model: "Option<crate::model::micromap_objects::MicromapBuildSizesInfo>",
    resolve: "sizes_info(&$s)",
    write: "sizes_info_desc(&$m)",
    arg: "$m.as_ref()",
    test: "None",
};

/// `pVersionInfo`: its `pVersionData` is hex in a scene.
const VERSION_INFO: Custom = Custom {
    scene: "Option<MicromapVersionInfoDesc>",
    serde: "#[serde(deserialize_with = \"nullable\")]\n#[schemars(required)]",
    model: "Option<crate::model::micromap_objects::MicromapVersionInfo>",
    resolve: "version_info(&$s, &$at)?",
    write: "version_info_desc(&$m)",
    arg: "$m.as_ref()",
    test: "Some(crate::model::micromap_objects::MicromapVersionInfo { version_data: Some(vec![1, 2]), ..Default::default() })",
};

/// `pCompatibility`: only whether it is NULL matters.
const COMPATIBILITY: Custom = Custom {
    scene: "bool",
    serde: "#[serde(default = \"yes\")]",
    model: "bool",
    resolve: "$s",
    write: "$m",
    arg: "$m",
    test: "false",
};

/// `VkAccelerationStructureCreateInfo2KHR`, hand-written: its address range
/// is a nested structure.
const CREATE_INFO_2: Custom = Custom {
    scene: "AccelerationStructureCreateInfo2Desc",
    serde: "",
    model: "crate::model::accel::AccelerationStructureCreateInfo2",
    resolve: "self.create_info2(&$s, &$at)?",
    write: "create_info2_desc(&$m, names)",
    arg: "&$m",
    test: "Default::default()",
};

/// A micromap command: info pointers may be null.
macro_rules! micromap {
    ($vk:literal, $rust:literal, $method:literal $(, $field:ident: $value:expr)* $(,)?) => {
        CommandSpec {
            vk: $vk,
            rust: $rust,
            method: $method,
            nullable: true,
            $($field: $value,)*
            ..BASE
        }
    };
}

/// An acceleration-structure command: info pointers are required; the
/// host commands' methods take neither the device nor the deferred
/// operation (no micromap rule concerns them).
macro_rules! khr {
    ($vk:literal, $rust:literal, $method:literal $(, $field:ident: $value:expr)* $(,)?) => {
        CommandSpec {
            vk: $vk,
            rust: $rust,
            method: $method,
            $($field: $value,)*
            ..BASE
        }
    };
}

/// The parameters of a host command that its method does not take.
const HOST: &[&str] = &["device", "deferredOperation"];

/// The generated commands.
pub const COMMANDS: &[CommandSpec] = &[
    micromap!(
        "vkCreateMicromapEXT",
        "CreateMicromap",
        "create_micromap",
        docs: &[("pMicromap", "The name the new micromap gets; null: pMicromap is NULL.")],
    ),
    micromap!(
        "vkDestroyMicromapEXT",
        "DestroyMicromap",
        "destroy_micromap"
    ),
    micromap!(
        "vkCmdBuildMicromapsEXT",
        "CmdBuildMicromaps",
        "cmd_build_micromaps"
    ),
    micromap!(
        "vkBuildMicromapsEXT",
        "BuildMicromaps",
        "build_micromaps",
        doc: "addresses are host addresses.",
    ),
    micromap!(
        "vkGetMicromapBuildSizesEXT",
        "GetMicromapBuildSizes",
        "get_micromap_build_sizes",
        params: &[("pSizeInfo", Param::Custom(&MICROMAP_SIZES))],
        docs: &[("pSizeInfo", "Absent: a VkMicromapBuildSizesInfoEXT with its sType.")],
    ),
    micromap!(
        "vkCmdCopyMicromapEXT",
        "CmdCopyMicromap",
        "cmd_copy_micromap"
    ),
    micromap!(
        "vkCmdCopyMicromapToMemoryEXT",
        "CmdCopyMicromapToMemory",
        "cmd_copy_micromap_to_memory"
    ),
    micromap!(
        "vkCmdCopyMemoryToMicromapEXT",
        "CmdCopyMemoryToMicromap",
        "cmd_copy_memory_to_micromap"
    ),
    micromap!("vkCopyMicromapEXT", "CopyMicromap", "copy_micromap"),
    micromap!(
        "vkCopyMicromapToMemoryEXT",
        "CopyMicromapToMemory",
        "copy_micromap_to_memory"
    ),
    micromap!(
        "vkCopyMemoryToMicromapEXT",
        "CopyMemoryToMicromap",
        "copy_memory_to_micromap",
        host_read: true,
    ),
    micromap!(
        "vkCmdWriteMicromapsPropertiesEXT",
        "CmdWriteMicromapsProperties",
        "cmd_write_micromaps_properties",
        params: &[("pMicromaps", Param::MicromapList)],
        docs: &[("micromapCount", "Default: the length of pMicromaps.")],
    ),
    micromap!(
        "vkWriteMicromapsPropertiesEXT",
        "WriteMicromapsProperties",
        "write_micromaps_properties",
        params: &[("pMicromaps", Param::MicromapList)],
    ),
    micromap!(
        "vkGetDeviceMicromapCompatibilityEXT",
        "GetDeviceMicromapCompatibility",
        "get_device_micromap_compatibility",
        params: &[
            ("pVersionInfo", Param::Custom(&VERSION_INFO)),
            ("pCompatibility", Param::Custom(&COMPATIBILITY)),
        ],
        docs: &[("pCompatibility", "false: pCompatibility is NULL.")],
    ),
    khr!(
        "vkCreateAccelerationStructureKHR",
        "CreateAccelerationStructure",
        "create_acceleration_structure",
        docs: &[("pAccelerationStructure", "The name the new acceleration structure gets.")],
        args: "&c.create_info, c.acceleration_structure.unwrap_or(0)",
    ),
    khr!(
        "vkCreateAccelerationStructure2KHR",
        "CreateAccelerationStructure2",
        "create_acceleration_structure2",
        params: &[("pCreateInfo", Param::Custom(&CREATE_INFO_2))],
        args: "&c.create_info, c.acceleration_structure.unwrap_or(0)",
    ),
    khr!(
        "vkCmdBuildAccelerationStructuresKHR",
        "CmdBuildAccelerationStructures",
        "cmd_build_acceleration_structures",
        docs: &[("ppBuildRangeInfos", "One array per info (null: a NULL element); absent: none.")],
        then: "self.instances_read(&mut call.infos, &call.build_range_infos, false);",
    ),
    khr!(
        "vkCmdBuildAccelerationStructuresIndirectKHR",
        "CmdBuildAccelerationStructuresIndirect",
        "cmd_build_acceleration_structures_indirect",
        then: "let ranges = self.indirect_ranges(&call.infos, &call.indirect_device_addresses, &call.indirect_strides);\n\
               self.instances_read(&mut call.infos, &ranges, false);",
    ),
    khr!(
        "vkBuildAccelerationStructuresKHR",
        "BuildAccelerationStructures",
        "build_acceleration_structures",
        doc: "addresses are host addresses.",
        skip: HOST,
        then: "self.instances_read(&mut call.infos, &call.build_range_infos, true);",
    ),
    khr!(
        "vkGetAccelerationStructureBuildSizesKHR",
        "GetAccelerationStructureBuildSizes",
        "get_acceleration_structure_build_sizes",
        params: &[("pSizeInfo", Param::Custom(&ACCELERATION_SIZES))],
        docs: &[("pMaxPrimitiveCounts", "null or absent: NULL.")],
        skip: &["device", "pSizeInfo"],
    ),
    khr!(
        "vkCmdCopyAccelerationStructureKHR",
        "CmdCopyAccelerationStructure",
        "cmd_copy_acceleration_structure"
    ),
    khr!(
        "vkCopyAccelerationStructureKHR",
        "CopyAccelerationStructure",
        "copy_acceleration_structure",
        skip: HOST,
    ),
    khr!(
        "vkCmdCopyAccelerationStructureToMemoryKHR",
        "CmdCopyAccelerationStructureToMemory",
        "cmd_copy_acceleration_structure_to_memory"
    ),
    khr!(
        "vkCmdCopyMemoryToAccelerationStructureKHR",
        "CmdCopyMemoryToAccelerationStructure",
        "cmd_copy_memory_to_acceleration_structure"
    ),
    khr!(
        "vkCopyAccelerationStructureToMemoryKHR",
        "CopyAccelerationStructureToMemory",
        "copy_acceleration_structure_to_memory",
        skip: HOST,
    ),
    khr!(
        "vkCopyMemoryToAccelerationStructureKHR",
        "CopyMemoryToAccelerationStructure",
        "copy_memory_to_acceleration_structure",
        skip: HOST,
        host_read: true,
    ),
    khr!(
        "vkWriteAccelerationStructuresPropertiesKHR",
        "WriteAccelerationStructuresProperties",
        "write_acceleration_structures_properties",
        skip: &["device", "pData"],
    ),
];

/// The calls whose scene form and resolver are still hand-written (the
/// device, pipeline, synchronization, query and cluster calls): vk.xml
/// name and the name of the `Call` variant and of its scene struct.
pub const HAND_WRITTEN: &[(&str, &str)] = &[
    ("vkCreateDevice", "CreateDevice"),
    (
        "vkGetPhysicalDeviceProperties2",
        "GetPhysicalDeviceProperties2",
    ),
    ("vkCreateShaderModule", "CreateShaderModule"),
    ("vkCreateComputePipelines", "CreateComputePipelines"),
    ("vkCreateGraphicsPipelines", "CreateGraphicsPipelines"),
    (
        "vkCreateRayTracingPipelinesKHR",
        "CreateRayTracingPipelinesKhr",
    ),
    (
        "vkCreateRayTracingPipelinesNV",
        "CreateRayTracingPipelinesNv",
    ),
    ("vkCreateShadersEXT", "CreateShaders"),
    ("vkCmdBindPipeline", "CmdBindPipeline"),
    ("vkCmdBindShadersEXT", "CmdBindShaders"),
    ("vkCmdPipelineBarrier2", "CmdPipelineBarrier2"),
    ("vkCmdSetEvent2", "CmdSetEvent2"),
    ("vkCmdWaitEvents2", "CmdWaitEvents2"),
    ("vkCmdResetEvent2", "CmdResetEvent2"),
    ("vkCmdWriteTimestamp2", "CmdWriteTimestamp2"),
    ("vkCmdWriteBufferMarker2AMD", "CmdWriteBufferMarker2Amd"),
    ("vkCmdWriteMarkerToMemoryAMD", "CmdWriteMarkerToMemoryAmd"),
    ("vkQueueSubmit2", "QueueSubmit2"),
    ("vkCmdBeginQuery", "CmdBeginQuery"),
    ("vkCmdBeginQueryIndexedEXT", "CmdBeginQueryIndexed"),
    (
        "vkCmdBuildClusterAccelerationStructureIndirectNV",
        "CmdBuildClusterAccelerationStructureIndirect",
    ),
];

/// One parameter of a generated command.
pub struct Arg {
    /// The vk.xml name, which the scene uses too.
    pub name: String,
    /// The scene struct's member (snake case of `name`).
    pub scene: String,
    /// The model's member: `name` without its pointer prefix.
    pub model: String,
    /// The count member that goes with it in a scene (`MicromapList`).
    pub count: Option<String>,
    pub param: Param,
}

/// The model's name of a parameter: `pInfos` is `infos`.
fn model_name(name: &str) -> String {
    let bare = name.trim_start_matches('p');
    if bare.len() < name.len() && bare.starts_with(|c: char| c.is_ascii_uppercase()) {
        crate::khr::snake_case(&format!("{}{}", bare[..1].to_lowercase(), &bare[1..]))
    } else {
        crate::khr::snake_case(name)
    }
}

/// The form vk.xml's type gives `p`, a parameter of `spec`.
fn derive(vk: &VkXml, spec: &CommandSpec, p: &Member) -> Result<Param, Error> {
    let unsupported = || {
        Error::Registry(format!(
            "{}({}: {}): no generated form for this parameter; give it one in COMMANDS",
            spec.vk, p.name, p.type_name
        ))
    };
    let ty = p.type_name.as_str();
    let pointers: &[bool] = &p.pointers;
    let handle = HANDLE_KINDS.iter().find(|(t, _)| *t == ty).map(|(_, k)| *k);
    let described = STRUCTS.iter().find(|s| s.vk == ty && !s.chained);
    Ok(match (ty, pointers, p.len.is_some()) {
        ("VkDevice", [], _) => Param::Device,
        ("VkCommandBuffer", [], _) => Param::CommandBuffer,
        (_, [], _) if handle.is_some() => Param::Handle(handle.unwrap_or_default()),
        (_, [false], false) if handle.is_some() => Param::Created(handle.unwrap_or_default()),
        (_, [true], true) if handle.is_some() => Param::Handles(handle.unwrap_or_default()),
        ("uint32_t", [], _) => Param::Number { wide: false },
        ("VkDeviceSize" | "size_t" | "uint64_t", [], _) => Param::Number { wide: true },
        ("void", [false], _) => Param::Address,
        ("VkDeviceAddress", [true], true) => Param::Addresses,
        ("uint32_t", [true], true) if p.len.as_deref().is_some_and(|l| l.contains("->")) => {
            Param::OptionalNumbers
        }
        ("uint32_t", [true], true) => Param::Numbers,
        ("uint32_t", [true, true], true) => Param::NumberLists,
        ("VkAllocationCallbacks", [true], false) => Param::Allocator,
        (_, [true], false) if described.is_some() => Param::Info {
            rust: described.map_or("", |s| s.rust),
            nullable: spec.nullable,
        },
        (_, [true], true) if described.is_some() => Param::Infos(described.map_or("", |s| s.rust)),
        (_, [true, true], true) if described.is_some() => {
            Param::Lists(described.map_or("", |s| s.rust))
        }
        (_, [], _) if vk.category(ty) == Some("enum") => {
            Param::Enum(kind_of(vk, ty).ok_or_else(unsupported)?)
        }
        _ => return Err(unsupported()),
    })
}

/// The parameters of `spec` with their forms; counts that only give an
/// array's length are left out (the scene's array has one).
pub fn args(vk: &VkXml, spec: &CommandSpec) -> Result<Vec<Arg>, Error> {
    let params = vk
        .commands
        .get(spec.vk)
        .ok_or_else(|| Error::Registry(format!("no command {}", spec.vk)))?;
    // `dataSize` with `void* pData` stays: the data is only an address.
    let counted = |name: &str| {
        params.iter().any(|p| {
            p.type_name != "void"
                && p.len
                    .as_deref()
                    .is_some_and(|len| len.split(',').next() == Some(name))
        })
    };
    let mut out = Vec::new();
    for p in params {
        if counted(&p.name) {
            continue;
        }
        let param = match spec.params.iter().find(|(name, _)| *name == p.name) {
            Some((_, Param::MicromapList)) => Param::MicromapList,
            Some((_, Param::Custom(custom))) => Param::Custom(custom),
            Some((_, other)) => {
                return Err(Error::Registry(format!(
                    "{}({}): COMMANDS gives only MicromapList or Custom forms, not {other:?}",
                    spec.vk, p.name
                )))
            }
            None => derive(vk, spec, p)?,
        };
        let count = match param {
            Param::MicromapList => p.len.clone(),
            _ => None,
        };
        out.push(Arg {
            scene: crate::khr::snake_case(&p.name),
            model: model_name(&p.name),
            name: p.name.clone(),
            count,
            param,
        });
    }
    let named = spec
        .params
        .iter()
        .map(|(n, _)| n)
        .chain(spec.docs.iter().map(|(n, _)| n));
    for name in named {
        if !params.iter().any(|p| p.name == *name) {
            return Err(Error::Registry(format!(
                "{} has no parameter {name}",
                spec.vk
            )));
        }
    }
    Ok(out)
}

fn header(out: &mut String, doc: &str) {
    out.push_str(
        "// @generated by `cargo xtask generate` from vk.xml and xtask/src/commands.rs; do not edit.\n",
    );
    for line in doc.lines() {
        let _ = writeln!(out, "//! {line}");
    }
    out.push('\n');
}

/// `text` as doc comment lines, wrapped at 80 columns as if indented four
/// spaces, as most of the hand-written ones were: the schema's descriptions
/// keep their line breaks.
fn doc_lines(out: &mut String, text: &str) {
    let mut line = String::new();
    for word in text.split(' ') {
        if !line.is_empty() && 8 + line.len() + 1 + word.len() > 80 {
            let _ = writeln!(out, "/// {line}");
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    let _ = writeln!(out, "/// {line}");
}

/// `vkName(param, ...)` with every vk.xml parameter.
fn signature(vk: &VkXml, spec: &CommandSpec) -> String {
    let names: Vec<&str> = vk
        .commands
        .get(spec.vk)
        .map(|params| params.iter().map(|p| p.name.as_str()).collect())
        .unwrap_or_default();
    format!("`{}({})`", spec.vk, names.join(", "))
}

fn snake(rust: &str) -> String {
    crate::khr::snake_case(rust)
}

/// `validator/src/model/calls.rs`.
pub fn render_model(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The parameters of each call `xtask/src/commands.rs` describes, in\n\
         vk.xml's order and in model form: what the resolver makes of a\n\
         scene's call, what `Validator::check_call` checks, and what the\n\
         writer turns back into a scene.",
    );
    out.push_str(
        "use crate::model::generated as structs;\nuse crate::model::{CommandBuffer, Handle};\n\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "/// The parameters of {}.\n#[derive(Clone, Debug, Default, PartialEq)]\npub struct {} {{",
            signature(vk, spec),
            spec.rust
        );
        for arg in args(vk, spec)? {
            let ty = match &arg.param {
                Param::Device | Param::Handle(_) => "Handle".to_string(),
                Param::CommandBuffer => "CommandBuffer".to_string(),
                Param::Created(_) => "Option<Handle>".to_string(),
                Param::Handles(_) => "Vec<Handle>".to_string(),
                Param::MicromapList => "crate::model::micromap_objects::MicromapList".to_string(),
                Param::Enum(_) => "i32".to_string(),
                Param::Number { wide: false } => "u32".to_string(),
                Param::Number { wide: true } | Param::Address => "u64".to_string(),
                Param::Addresses => "Vec<u64>".to_string(),
                Param::Numbers => "Vec<u32>".to_string(),
                Param::OptionalNumbers => "Option<Vec<u32>>".to_string(),
                Param::NumberLists => "Vec<Option<Vec<u32>>>".to_string(),
                Param::Info {
                    rust,
                    nullable: true,
                } => format!("Option<structs::{rust}>"),
                Param::Info { rust, .. } => format!("structs::{rust}"),
                Param::Infos(rust) => format!("Vec<structs::{rust}>"),
                Param::Lists(rust) => format!("Vec<Option<Vec<structs::{rust}>>>"),
                Param::Allocator => {
                    "Option<crate::model::micromap_objects::AllocationCallbacks>".to_string()
                }
                Param::Custom(custom) => custom.model.to_string(),
            };
            let _ = writeln!(out, "    /// `{}`.\n    pub {}: {ty},", arg.name, arg.model);
        }
        out.push_str("}\n\n");
    }
    out.push_str("/// A call of one of the generated commands.\n#[derive(Clone, Debug, PartialEq)]\npub enum Call {\n");
    for spec in COMMANDS {
        let _ = writeln!(out, "    {}({}),", spec.rust, spec.rust);
    }
    out.push_str("}\n\nimpl Call {\n    /// The command's vk.xml name.\n    pub fn name(&self) -> &'static str {\n        match self {\n");
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "            Call::{}(_) => \"{}\",",
            spec.rust, spec.vk
        );
    }
    out.push_str("        }\n    }\n}\n");
    Ok(out)
}

/// `validator/src/checks/calls.rs`.
pub fn render_checks(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "`Validator::check_call`: each generated command's call, in model\n\
         form, checked and recorded by the command's method.",
    );
    out.push_str(
        "use super::Validator;\nuse crate::model::calls::Call;\nuse crate::report::Report;\n\n\
         impl Validator {\n    \
         /// Checks `call` and records its effect: the command's method with\n    \
         /// the call's parameters (those it takes, in vk.xml's order).\n    \
         pub fn check_call(&mut self, call: &Call) -> Report {\n        match call {\n",
    );
    for spec in COMMANDS {
        let args = if spec.args.is_empty() {
            let mut list = Vec::new();
            for arg in args(vk, spec)? {
                if spec.skip.contains(&arg.name.as_str()) {
                    continue;
                }
                let m = format!("c.{}", arg.model);
                list.push(match &arg.param {
                    Param::Device
                    | Param::Handle(_)
                    | Param::Created(_)
                    | Param::Enum(_)
                    | Param::Number { .. }
                    | Param::Address => m,
                    Param::Info { nullable: true, .. } | Param::Allocator => {
                        format!("{m}.as_ref()")
                    }
                    Param::OptionalNumbers => format!("{m}.as_deref()"),
                    Param::Custom(custom) => custom.arg.replace("$m", &m),
                    _ => format!("&{m}"),
                });
            }
            list.join(", ")
        } else {
            spec.args.to_string()
        };
        let _ = writeln!(
            out,
            "            Call::{}(c) => self.{}({args}),",
            spec.rust, spec.method
        );
    }
    out.push_str("        }\n    }\n}\n");
    Ok(out)
}

/// `validator/src/scene/format/calls.rs`.
pub fn render_scene_form(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The scene form of each call `xtask/src/commands.rs` describes, members\n\
         by their vk.xml names, and the `Call` enum of every call a scene reads\n\
         with the names it reads them by.",
    );
    out.push_str(
        "use schemars::JsonSchema;\nuse serde::{Deserialize, Deserializer, Serialize};\n\n\
         use super::*;\nuse crate::model::names::{self, Value};\n\
         use crate::scene::args::{AddressArg, HandleArg};\n\n",
    );
    for spec in COMMANDS {
        let mut text = signature(vk, spec);
        if spec.doc.is_empty() {
            text.push('.');
        } else {
            let _ = write!(text, "; {}", spec.doc);
        }
        doc_lines(&mut out, &text);
        let _ = writeln!(
            out,
            "#[derive(Debug, Deserialize, Serialize, JsonSchema)]\n\
             #[serde(deny_unknown_fields, rename_all = \"camelCase\")]\npub struct {} {{",
            spec.rust
        );
        let nullable = "#[serde(deserialize_with = \"nullable\")]\n#[schemars(required)]";
        for arg in args(vk, spec)? {
            let doc = spec
                .docs
                .iter()
                .find(|(n, _)| *n == arg.name)
                .map(|(_, d)| *d);
            if let Some(count) = &arg.count {
                if let Some(doc) = spec.docs.iter().find(|(n, _)| n == count).map(|(_, d)| *d) {
                    let _ = writeln!(out, "    /// {doc}");
                }
                let _ = writeln!(
                    out,
                    "    pub {}: Option<u32>,",
                    crate::khr::snake_case(count)
                );
            }
            if let Some(doc) = doc {
                let _ = writeln!(out, "    /// {doc}");
            }
            let (serde, ty) = match &arg.param {
                Param::Device | Param::Handle(_) => (
                    "#[serde(default, skip_serializing_if = \"HandleArg::is_omitted\")]",
                    "HandleArg".to_string(),
                ),
                Param::CommandBuffer => (
                    "#[serde(default, skip_serializing_if = \"CommandBufferArg::is_omitted\")]",
                    "CommandBufferArg".to_string(),
                ),
                Param::Created(_) => (nullable, "Option<String>".to_string()),
                Param::Handles(_) => ("", "Vec<HandleArg>".to_string()),
                Param::MicromapList => (nullable, "Option<Vec<HandleArg>>".to_string()),
                Param::Enum(kind) => ("", format!("Value<names::{kind}>")),
                Param::Number { wide: false } => ("#[serde(default)]", "u32".to_string()),
                Param::Number { wide: true } => ("#[serde(default)]", "u64".to_string()),
                Param::Address => ("#[serde(default)]", "AddressArg".to_string()),
                Param::Addresses => ("#[serde(default)]", "Vec<AddressArg>".to_string()),
                Param::Numbers => ("#[serde(default)]", "Vec<u32>".to_string()),
                Param::OptionalNumbers => ("#[serde(default)]", "Option<Vec<u32>>".to_string()),
                Param::NumberLists => ("#[serde(default)]", "Vec<Option<Vec<u32>>>".to_string()),
                Param::Info {
                    rust,
                    nullable: true,
                } => (nullable, format!("Option<{rust}Desc>")),
                Param::Info { rust, .. } => ("", format!("{rust}Desc")),
                Param::Infos(rust) => ("", format!("Vec<{rust}Desc>")),
                Param::Lists(rust) => {
                    ("#[serde(default)]", format!("Vec<Option<Vec<{rust}Desc>>>"))
                }
                Param::Allocator => (
                    "#[serde(default)]",
                    "Option<AllocationCallbacksDesc>".to_string(),
                ),
                Param::Custom(custom) => (custom.serde, custom.scene.to_string()),
            };
            if !serde.is_empty() {
                let _ = writeln!(out, "    {serde}");
            }
            let _ = writeln!(out, "    pub {}: {ty},", arg.scene);
        }
        out.push_str("}\n\n");
    }
    out.push_str(
        "/// One API call: `{\"call\": \"vkCmdBuildMicromapsEXT\", ...parameters}`.\n\
         #[derive(Debug, JsonSchema)]\n#[serde(tag = \"call\")]\npub enum Call {\n",
    );
    let all = || {
        COMMANDS
            .iter()
            .map(|s| (s.vk, s.rust))
            .chain(HAND_WRITTEN.iter().copied())
    };
    for (vk_name, rust) in all() {
        let _ = writeln!(
            out,
            "    #[serde(rename = \"{vk_name}\")]\n    {rust}({rust}),"
        );
    }
    out.push_str(
        "    /// A command that runs shaders (`WORK_CALL_NAMES`).\n    #[serde(untagged)]\n    \
         RunShaders(RunShadersCall),\n    /// A call of execution order (`EXECUTION_CALL_NAMES`).\n    \
         #[serde(untagged)]\n    Execution(ExecutionCall),\n}\n\n",
    );
    let _ = writeln!(
        out,
        "/// Every call name a scene may use, for messages and docs.\npub const CALL_NAMES: [&str; {}] = [",
        all().count()
    );
    for (vk_name, _) in all() {
        let _ = writeln!(out, "    \"{vk_name}\",");
    }
    out.push_str(
        "];\n\n/// The call named `name`, one of [`CALL_NAMES`], with its parameters read\n\
         /// from `rest`; `rest` back for any other name.\n\
         pub(super) fn named_call<'de, D: Deserializer<'de>>(name: &str, rest: D) -> Result<Result<Call, D::Error>, D> {\n    \
         Ok(match name {\n",
    );
    for (vk_name, rust) in all() {
        let _ = writeln!(
            out,
            "        \"{vk_name}\" => Deserialize::deserialize(rest).map(Call::{rust}),"
        );
    }
    out.push_str("        _ => return Err(rest),\n    })\n}\n");
    Ok(out)
}

/// `validator/src/scene/resolve/calls.rs`.
pub fn render_resolver(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The scene → model resolvers of the calls `xtask/src/commands.rs`\n\
         describes.",
    );
    out.push_str(
        "use super::{allocator, sizes_info, version_info, ObjectKind, Resolver, Result};\n\
         use crate::model::calls as model;\nuse crate::scene::format as scene;\n\n\
         impl Resolver<'_> {\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "    /// The model of a scene's `{}` call at `at`.\n    \
             pub(in crate::scene) fn {}_call(&mut self, c: &scene::{}, at: &str) -> Result<model::{}> {{\n        \
             #[allow(unused_mut)]\n        let mut call = model::{} {{",
            spec.vk,
            snake(spec.rust),
            spec.rust,
            spec.rust,
            spec.rust
        );
        for arg in args(vk, spec)? {
            let s = format!("c.{}", arg.scene);
            let at = format!("format!(\"{{at}}.{}\")", arg.name);
            let value = match &arg.param {
                Param::Device => format!("self.device_handle(&{s}, &{at})?"),
                Param::CommandBuffer => format!("self.command_buffer(&{s}, at)?"),
                Param::Handle(kind) => format!("self.handle(&{s}, ObjectKind::{kind}, &{at})?"),
                Param::Created(kind) => format!("self.created(&{s}, ObjectKind::{kind}, &{at})?"),
                Param::Handles(kind) => format!("self.handles(&{s}, ObjectKind::{kind}, &{at})?"),
                Param::MicromapList => format!(
                    "self.micromap_list(c.{}, &{s}, at)?",
                    crate::khr::snake_case(arg.count.as_deref().unwrap_or_default())
                ),
                Param::Enum(_) => format!("{s}.as_i32()"),
                Param::Number { .. } => s,
                Param::Address => format!("self.address(&{s}, &{at})?"),
                Param::Addresses => format!("self.addresses(&{s}, &{at})?"),
                Param::Numbers | Param::OptionalNumbers | Param::NumberLists => {
                    format!("{s}.clone()")
                }
                Param::Info {
                    rust,
                    nullable: true,
                } => format!("self.option(&{s}, &{at}, Self::{})?", snake(rust)),
                Param::Info { rust, .. } => format!("self.{}(&{s}, &{at})?", snake(rust)),
                Param::Infos(rust) => format!("self.list(&{s}, &{at}, Self::{})?", snake(rust)),
                Param::Lists(rust) => format!("self.lists(&{s}, &{at}, Self::{})?", snake(rust)),
                Param::Allocator => format!("allocator(&{s})"),
                Param::Custom(custom) => custom.resolve.replace("$s", &s).replace("$at", &at),
            };
            let _ = writeln!(out, "            {}: {value},", arg.model);
        }
        out.push_str("        };\n");
        if !spec.then.is_empty() {
            for line in spec.then.lines() {
                let _ = writeln!(out, "        {}", line.trim());
            }
        }
        out.push_str("        Ok(call)\n    }\n\n");
    }
    out.push_str(
        "    /// The model of `call` where it is a generated command's, else None.\n    \
         pub(in crate::scene) fn model_call(&mut self, call: &scene::Call, at: &str) -> Option<Result<model::Call>> {\n        \
         Some(match call {\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "            scene::Call::{}(c) => self.{}_call(c, at).map(model::Call::{}),",
            spec.rust,
            snake(spec.rust),
            spec.rust
        );
    }
    out.push_str("            _ => return None,\n        })\n    }\n}\n");
    Ok(out)
}

/// `validator/src/scene/write/calls.rs`.
pub fn render_writer(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The model → scene writers of the calls `xtask/src/commands.rs`\n\
         describes: what the resolver reads back to the same model call.",
    );
    out.push_str(
        "use super::{allocator_desc, command_buffer_arg, create_info2_desc, device_arg, micromap_list_desc, sizes_info_desc, version_info_desc, Names};\n\
         use crate::model::calls as model;\nuse crate::model::names::Value;\n\
         use crate::scene::format as scene;\nuse crate::scene::ObjectKind;\n\n\
         impl scene::Call {\n    \
         /// The scene form of `call`, naming objects and addresses by `names`.\n    \
         pub fn written(call: &model::Call, names: &dyn Names) -> Self {\n        match call {\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "            model::Call::{}(m) => Self::{}(scene::{} {{",
            spec.rust, spec.rust, spec.rust
        );
        for arg in args(vk, spec)? {
            let m = format!("m.{}", arg.model);
            let value = match &arg.param {
                Param::Device => format!("device_arg({m})"),
                Param::CommandBuffer => format!("command_buffer_arg(&{m}, names)"),
                Param::Handle(kind) => format!("names.handle(ObjectKind::{kind}, {m})"),
                Param::Created(kind) => {
                    format!("{m}.map(|h| names.created(ObjectKind::{kind}, h))")
                }
                Param::Handles(kind) => {
                    format!("{m}.iter().map(|&h| names.handle(ObjectKind::{kind}, h)).collect()")
                }
                Param::MicromapList => {
                    let _ = writeln!(
                        out,
                        "                {}: micromap_list_desc(&{m}, names).0,",
                        crate::khr::snake_case(arg.count.as_deref().unwrap_or_default())
                    );
                    format!("micromap_list_desc(&{m}, names).1")
                }
                Param::Enum(_) => format!("Value::new(i64::from({m}))"),
                Param::Number { .. } => m,
                Param::Address => format!("names.address({m})"),
                Param::Addresses => format!("{m}.iter().map(|&a| names.address(a)).collect()"),
                Param::Numbers | Param::OptionalNumbers | Param::NumberLists => {
                    format!("{m}.clone()")
                }
                Param::Info {
                    rust,
                    nullable: true,
                } => format!("{m}.as_ref().map(|i| scene::{rust}Desc::written(i, names))"),
                Param::Info { rust, .. } => format!("scene::{rust}Desc::written(&{m}, names)"),
                Param::Infos(rust) => {
                    format!("{m}.iter().map(|i| scene::{rust}Desc::written(i, names)).collect()")
                }
                Param::Lists(rust) => format!(
                    "{m}.iter().map(|l| l.as_ref().map(|l| l.iter().map(|i| scene::{rust}Desc::written(i, names)).collect())).collect()"
                ),
                Param::Allocator => format!("{m}.as_ref().map(allocator_desc)"),
                Param::Custom(custom) => custom.write.replace("$m", &m),
            };
            let _ = writeln!(out, "                {}: {value},", arg.scene);
        }
        out.push_str("            }),\n");
    }
    out.push_str(
        "        }\n    }\n\n    \
         /// The JSON of a generated command's call, with its `call` name;\n    \
         /// None for the calls whose form is hand-written.\n    \
         pub fn json(&self) -> Option<serde_json::Result<serde_json::Value>> {\n        \
         let (name, params) = match self {\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "            Self::{}(c) => (\"{}\", serde_json::to_value(c)),",
            spec.rust, spec.vk
        );
    }
    out.push_str(
        "            _ => return None,\n        };\n        \
         Some(params.map(|mut params| {\n            \
         if let Some(members) = params.as_object_mut() {\n                \
         members.insert(\"call\".into(), name.into());\n            }\n            params\n        }))\n    }\n}\n\n",
    );
    // Every generated call reads back to the model it was written from.
    out.push_str(
        "#[cfg(test)]\nmod tests {\n    use super::super::{Names, Numbers};\n    \
         use crate::model::calls as model;\n    use crate::scene::format as scene;\n    \
         use crate::scene::ObjectKind;\n\n    \
         /// `call` written, as JSON, read back and resolved.\n    \
         fn round_trip(call: model::Call) {\n        \
         let names: &dyn Names = &Numbers;\n        \
         let json = scene::Call::written(&call, names).json().unwrap().unwrap();\n        \
         let read: scene::Call = serde_json::from_value(json.clone()).unwrap();\n        \
         let resolved = crate::scene::resolve_alone_mut(|r| r.model_call(&read, \"x\").unwrap());\n        \
         assert_eq!(resolved, Ok(call), \"{json}\");\n    }\n\n",
    );
    for spec in COMMANDS {
        let _ = writeln!(
            out,
            "    #[test]\n    fn {}_reads_back_as_written() {{\n        round_trip(model::Call::{}(model::{} {{",
            snake(spec.rust),
            spec.rust,
            spec.rust
        );
        for (i, arg) in args(vk, spec)?.iter().enumerate() {
            let i = i as u64 + 1;
            let value = match &arg.param {
                Param::Device | Param::Handle(_) => format!("0x1000 + {i}"),
                Param::CommandBuffer => format!(
                    "crate::model::CommandBuffer {{ handle: 0x1000 + {i}, recording: false, ..Default::default() }}"
                ),
                // The handle the resolver gives the first object it binds.
                Param::Created(kind) => format!("Some(ObjectKind::{kind}.handle_base())"),
                Param::Handles(_) => format!("vec![0x1000 + {i}, 0]"),
                // A count beyond the array.
                Param::MicromapList => format!(
                    "crate::model::micromap_objects::MicromapList {{ count: {i} + 1, handles: Some(vec![0x1000]) }}"
                ),
                Param::Enum(_) | Param::Number { .. } => i.to_string(),
                Param::Address => format!("0x2000_0000 + {i}"),
                Param::Addresses => format!("vec![0x2000_0000 + {i}, 0]"),
                Param::Numbers => format!("vec![{i}]"),
                Param::OptionalNumbers => format!("Some(vec![{i}])"),
                Param::NumberLists => format!("vec![Some(vec![{i}]), None]"),
                Param::Info { nullable: true, .. } | Param::Allocator => {
                    "Some(Default::default())".to_string()
                }
                Param::Info { .. } => "Default::default()".to_string(),
                Param::Infos(_) => "vec![Default::default()]".to_string(),
                Param::Lists(_) => "vec![Some(vec![Default::default()]), None]".to_string(),
                Param::Custom(custom) => custom.test.to_string(),
            };
            let _ = writeln!(out, "            {}: {value},", arg.model);
        }
        out.push_str("        }));\n    }\n\n");
    }
    out.push_str("}\n");
    Ok(out)
}

/// Whether the raw wrapper of `spec` is generated: every parameter is a
/// value, a handle, the command buffer's model, a micromap list or an info
/// structure with a raw reader; and the command reads no host memory
/// beyond its structures (a deserialization reads its header: `host`).
fn raw_generated(vk: &VkXml, spec: &CommandSpec) -> Result<bool, Error> {
    if spec.host_read {
        return Ok(false);
    }
    for arg in args(vk, spec)? {
        let ok = match &arg.param {
            Param::Device
            | Param::CommandBuffer
            | Param::Handle(_)
            | Param::Enum(_)
            | Param::Number { .. }
            | Param::Address
            | Param::MicromapList => true,
            Param::Info { rust, .. } => {
                let info = STRUCTS.iter().find(|s| s.rust == *rust);
                match info {
                    Some(info) => !read_by_members(info, &fields(vk, info)?),
                    None => false,
                }
            }
            _ => false,
        };
        if !ok {
            return Ok(false);
        }
    }
    Ok(true)
}

/// The vk.xml type of parameter `name` of `spec`.
fn param_type<'a>(vk: &'a VkXml, spec: &CommandSpec, name: &str) -> &'a str {
    vk.commands
        .get(spec.vk)
        .and_then(|params| params.iter().find(|p| p.name == name))
        .map_or("", |p| p.type_name.as_str())
}

/// ash's name of the vk.xml type `ty` (`VkQueryPool` is `vk::QueryPool`).
fn ash_name(ty: &str) -> String {
    format!("vk::{}", ty.strip_prefix("Vk").unwrap_or(ty))
}

/// `validator/src/raw/calls.rs`.
pub fn render_raw(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    header(
        &mut out,
        "The `*_raw` entry points a layer calls for the calls\n\
         `xtask/src/commands.rs` describes whose parameters are all values,\n\
         handles, micromap lists and info structures with a raw reader: each\n\
         reads the ash parameters into the model call (bounded as `raw`\n\
         bounds every read) and checks it with `Validator::check_call`; the\n\
         reading's findings come first.",
    );
    out.push_str(
        "use ash::vk;\n\nuse super::commands::{micromap_list, with_findings};\n\
         use super::generated as read;\nuse crate::model::calls::{self as model, Call};\n\
         use crate::model::CommandBuffer;\nuse crate::report::Report;\nuse crate::Validator;\n\n\
         impl Validator {\n",
    );
    for spec in COMMANDS {
        if !raw_generated(vk, spec)? {
            continue;
        }
        let args = args(vk, spec)?;
        let mut params = Vec::new();
        let mut safety = Vec::new();
        let mut reads = String::new();
        let mut fields_out = String::new();
        for arg in &args {
            let name = &arg.model;
            let ty = param_type(vk, spec, &arg.name);
            let value = match &arg.param {
                Param::Device | Param::Handle(_) => {
                    params.push(format!("{name}: {}", ash_name(ty)));
                    format!("vk::Handle::as_raw({name})")
                }
                Param::CommandBuffer => {
                    params.push(format!("{name}: &CommandBuffer"));
                    format!("{name}.clone()")
                }
                Param::Enum(_) => {
                    params.push(format!("{name}: {}", ash_name(ty)));
                    format!("{name}.as_raw()")
                }
                Param::Number { .. } => {
                    let (raw, value) = match ty {
                        "uint32_t" => ("u32", name.to_string()),
                        "size_t" => ("usize", format!("{name} as u64")),
                        _ => ("u64", name.to_string()),
                    };
                    params.push(format!("{name}: {raw}"));
                    value
                }
                Param::Address => {
                    params.push(format!("{name}: *const std::ffi::c_void"));
                    format!("{name}.addr() as u64")
                }
                Param::MicromapList => {
                    let count = crate::khr::snake_case(arg.count.as_deref().unwrap_or_default());
                    params.push(format!("{count}: u32"));
                    params.push(format!("{name}: *const vk::MicromapEXT"));
                    safety.push(format!(
                        "a non-NULL `{name}` must point to `{count}` handles"
                    ));
                    let _ = writeln!(
                        reads,
                        "        // SAFETY: forwarded from the caller.\n        \
                         let {name} = unsafe {{ micromap_list({count}, {name}, function, &mut findings) }};"
                    );
                    name.to_string()
                }
                Param::Info { rust, nullable } => {
                    let info = STRUCTS
                        .iter()
                        .find(|s| s.rust == *rust)
                        .ok_or_else(|| Error::Registry(format!("no structure {rust}")))?;
                    params.push(format!("{name}: *const {}", ash_type(info)));
                    safety.push(format!(
                        "a non-NULL `{name}` must point to a `{}` with a well-formed pNext chain",
                        info.vk
                    ));
                    let read = format!(
                        "// SAFETY: forwarded from the caller.\n        \
                         unsafe {{ read::{}(info, function, \"{}\", &mut findings) }}",
                        snake(rust),
                        arg.name
                    );
                    if *nullable {
                        let _ = writeln!(
                            reads,
                            "        // SAFETY: forwarded from the caller.\n        \
                             let {name} = unsafe {{ {name}.as_ref() }}.map(|info| {{\n        {read}\n        }});"
                        );
                    } else {
                        let _ = writeln!(
                            reads,
                            "        // SAFETY: forwarded from the caller.\n        \
                             let Some(info) = (unsafe {{ {name}.as_ref() }}) else {{\n            \
                             // No micromap rule concerns a NULL `{}` of this command.\n            \
                             return with_findings(findings, Report::default());\n        }};\n        \
                             let {name} = {{\n        {read}\n        }};",
                            arg.name
                        );
                    }
                    name.to_string()
                }
                other => {
                    return Err(Error::Registry(format!(
                        "{}: no raw form for {other:?}",
                        spec.vk
                    )))
                }
            };
            if value == arg.model {
                let _ = writeln!(fields_out, "            {value},");
            } else {
                let _ = writeln!(fields_out, "            {}: {value},", arg.model);
            }
        }
        let safety = if safety.is_empty() {
            "Nothing beyond the handles' being what they say.".to_string()
        } else {
            let mut text = safety.join("; ");
            text[..1].make_ascii_uppercase();
            text + "."
        };
        let _ = writeln!(
            out,
            "    /// Checks {} as a layer receives it.\n    ///\n    /// # Safety",
            signature(vk, spec)
        );
        let mut safety_doc = String::new();
        doc_lines(&mut safety_doc, &safety);
        for line in safety_doc.lines() {
            let _ = writeln!(out, "    {line}");
        }
        if params.len() >= 7 {
            out.push_str("    #[allow(clippy::too_many_arguments)]\n");
        }
        let _ = writeln!(
            out,
            "    pub unsafe fn {}_raw(&mut self, {}) -> Report {{\n        \
             let function = \"{}\";\n        #[allow(unused_mut)]\n        let mut findings = Vec::new();\n{reads}        \
             let call = model::{} {{\n{fields_out}        }};\n        \
             with_findings(findings, self.check_call(&Call::{}(call)))\n    }}\n",
            snake(spec.rust),
            params.join(", "),
            spec.vk,
            spec.rust,
            spec.rust
        );
    }
    out.push_str("}\n");
    Ok(out)
}
