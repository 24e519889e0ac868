//! What the generators need from `vk.xml`, read with vk-parse.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

use vk_parse::{
    EnumSpec, EnumsChild, ExtensionChild, InterfaceItem, RegistryChild, TypeMember,
    TypeMemberMarkup, TypeSpec, TypesChild,
};

use crate::Error;

/// The four extensions that make up "micromap", with their short names.
pub const MICROMAP_EXTENSIONS: [(&str, &str); 4] = [
    ("VK_EXT_opacity_micromap", "EXT"),
    ("VK_KHR_opacity_micromap", "KHR"),
    ("VK_NV_displacement_micromap", "NV"),
    ("VK_ARM_pipeline_opacity_micromap", "ARM"),
];

/// The short name (`EXT`, ...) of a micromap extension.
pub fn short_name(extension: &str) -> Option<&'static str> {
    MICROMAP_EXTENSIONS
        .iter()
        .find(|(name, _)| *name == extension)
        .map(|(_, short)| *short)
}

/// One member of a structure.
#[derive(Debug, Clone)]
pub struct Member {
    pub name: String,
    /// The type name as vk.xml writes it (`uint32_t`, `VkDeviceAddress`, ...).
    pub type_name: String,
    /// Pointer depth and constness, outermost last: `const T* const*` is
    /// `[true, true]`, `void*` is `[false]`.
    pub pointers: Vec<bool>,
    /// The fixed `values=` of an sType member.
    pub values: Option<String>,
    /// The `len=` of an array member: the count member's name, then `,1`
    /// per further pointer level (`usageCountsCount,1`).
    pub len: Option<String>,
    /// A union member's `selector=`: the member of the same structure whose
    /// value says which union member is live.
    pub selector: Option<String>,
    /// A union member's `selection=`: the selector value that makes it live.
    pub selection: Option<String>,
}

/// A structure or union.
#[derive(Debug, Clone)]
pub struct Aggregate {
    pub name: String,
    pub is_union: bool,
    pub members: Vec<Member>,
    pub structextends: Vec<String>,
}

/// An enum value that an extension adds to an enumerated or bitmask type.
#[derive(Debug, Clone)]
pub struct ExtensionEnum {
    pub name: String,
    /// The `VkFoo` or `VkFooFlagBits` it extends.
    pub extends: String,
    pub value: i128,
    /// The feature or extension whose `<require>` block holds it.
    pub required_by: String,
    /// `depends=` of that block, if any.
    pub depends: Option<String>,
    /// Set when this name is an alias of another value.
    pub alias: Option<String>,
}

/// The parts of `vk.xml` the generators use.
pub struct VkXml {
    pub header_version: String,
    /// Every type by name (alias entries included).
    pub types: HashMap<String, vk_parse::Type>,
    /// Every `<enums>` block by name (`VkStructureType`, ...): name to value.
    pub enum_blocks: HashMap<String, BTreeMap<String, i128>>,
    /// Types and commands each micromap extension requires.
    pub micromap_requirements: HashMap<String, BTreeSet<&'static str>>,
    /// Symbols (types, commands, enum values) that a micromap extension
    /// introduces, i.e. that no core version and no lower-numbered extension
    /// required before it.
    pub micromap_definitions: HashMap<String, BTreeSet<&'static str>>,
    /// Alias relations among the names micromap extensions require, both ways.
    pub aliases: HashMap<String, BTreeSet<String>>,
    /// Enum values added in `<require>` blocks of extensions.
    pub extension_enums: Vec<ExtensionEnum>,
    /// For each type or command: the feature or extension that requires it first.
    pub first_required_by: HashMap<String, String>,
    /// Every enum value name that vk.xml gives as an alias (in `<enums>`
    /// blocks, core versions and extensions), with the name it aliases.
    pub enum_aliases: BTreeMap<String, String>,
    /// Every command name that vk.xml gives as an alias, with the command
    /// it aliases.
    pub command_aliases: BTreeMap<String, String>,
    /// Each command's parameters, in order (Vulkan's, not Vulkan SC's).
    pub commands: HashMap<String, Vec<Member>>,
    /// Every enumerated and bitmask-bits type with its values for Vulkan,
    /// in the order vk.xml adds them ([`EnumType`]).
    pub enum_types: HashMap<String, EnumType>,
}

/// The values of one `<enums>` type (`VkIndexType`, `VkBufferUsageFlagBits2`):
/// those of its block, then those core versions add, then those extensions
/// add in extension-number order. Aliases are not values; they stay in
/// [`VkXml::enum_aliases`].
#[derive(Debug, Clone, Default)]
pub struct EnumType {
    /// `type="bitmask"`.
    pub bitmask: bool,
    /// `bitwidth=` (64 for `VkFlags64` bits), 32 when absent.
    pub bitwidth: u32,
    pub values: Vec<(String, i128)>,
}

impl EnumType {
    fn add(&mut self, name: &str, value: i128) {
        // Several extensions may require one value; it is one value.
        if !self.values.iter().any(|(n, _)| n == name) {
            self.values.push((name.to_string(), value));
        }
    }
}

fn for_vulkan(api: Option<&str>) -> bool {
    api.is_none_or(|api| api.split(',').any(|a| a == "vulkan"))
}

fn enum_value(spec: &EnumSpec, owner_number: Option<i64>) -> Option<i128> {
    match spec {
        EnumSpec::Offset {
            offset,
            extnumber,
            dir,
            ..
        } => {
            let number = extnumber.or(owner_number)?;
            let magnitude =
                1_000_000_000i128 + (i128::from(number) - 1) * 1000 + i128::from(*offset);
            Some(if *dir { magnitude } else { -magnitude })
        }
        EnumSpec::Bitpos { bitpos, .. } => Some(1i128 << bitpos),
        EnumSpec::Value { value, .. } => parse_c_integer(value),
        _ => None,
    }
}

/// Parses the integer literals vk.xml uses (`-1`, `0x10`, `1000`, `(~0U)` is not one of them).
fn parse_c_integer(text: &str) -> Option<i128> {
    let text = text.trim().trim_end_matches(['U', 'L', 'u', 'l']);
    if let Some(hex) = text.strip_prefix("0x") {
        i128::from_str_radix(hex, 16).ok()
    } else {
        text.parse().ok()
    }
}

fn extends_of(spec: &EnumSpec) -> Option<&str> {
    match spec {
        EnumSpec::Offset { extends, .. } => Some(extends),
        EnumSpec::Bitpos { extends, .. }
        | EnumSpec::Value { extends, .. }
        | EnumSpec::Alias { extends, .. } => extends.as_deref(),
        _ => None,
    }
}

impl VkXml {
    pub fn load(path: &Path) -> Result<Self, Error> {
        let (registry, _warnings) = vk_parse::parse_file(path)
            .map_err(|e| Error::Registry(format!("{}: {e:?}", path.display())))?;

        let mut types = HashMap::new();
        let mut enum_blocks: HashMap<String, BTreeMap<String, i128>> = HashMap::new();
        let mut features = Vec::new();
        let mut extensions = Vec::new();
        let mut header_version = String::new();
        let mut enum_aliases = BTreeMap::new();
        let mut command_aliases = BTreeMap::new();
        let mut commands = HashMap::new();
        let mut enum_types: HashMap<String, EnumType> = HashMap::new();
        for child in registry.0 {
            match child {
                RegistryChild::Types(block) => {
                    for child in block.children {
                        if let TypesChild::Type(ty) = child {
                            if let Some(name) = type_name(&ty) {
                                let for_vulkan = ty
                                    .api
                                    .as_deref()
                                    .is_none_or(|api| api.split(',').any(|a| a == "vulkan"));
                                if name == "VK_HEADER_VERSION" && for_vulkan {
                                    header_version = header_version_of(&ty).unwrap_or_default();
                                }
                                if for_vulkan {
                                    types.insert(name, ty);
                                }
                            }
                        }
                    }
                }
                RegistryChild::Enums(block) => {
                    let Some(name) = block.name.clone() else {
                        continue;
                    };
                    let values = enum_blocks.entry(name.clone()).or_default();
                    let kind = block.kind.as_deref();
                    let ordered = enum_types.entry(name).or_default();
                    ordered.bitmask = kind == Some("bitmask");
                    ordered.bitwidth = block.bitwidth.unwrap_or(32);
                    let is_type = matches!(kind, Some("enum" | "bitmask"));
                    for child in block.children {
                        if let EnumsChild::Enum(e) = child {
                            if let EnumSpec::Alias { alias, .. } = &e.spec {
                                enum_aliases.insert(e.name.clone(), alias.clone());
                            }
                            if let (true, true, Some(value)) = (
                                is_type,
                                for_vulkan(e.api.as_deref()),
                                enum_value(&e.spec, None),
                            ) {
                                ordered.add(&e.name, value);
                            }
                            if let Some(value) = enum_value(&e.spec, None) {
                                values.insert(e.name, value);
                            }
                        }
                    }
                }
                RegistryChild::Commands(block) => {
                    for command in block.children {
                        match command {
                            vk_parse::Command::Alias { name, alias } => {
                                command_aliases.insert(name, alias);
                            }
                            vk_parse::Command::Definition(def) => {
                                let params = def
                                    .params
                                    .iter()
                                    .filter(|p| for_vulkan(p.api.as_deref()))
                                    .map(|p| {
                                        let type_name =
                                            p.definition.type_name.clone().unwrap_or_default();
                                        Member {
                                            pointers: pointer_shape(&p.definition.code, &type_name),
                                            name: p.definition.name.clone(),
                                            type_name,
                                            values: None,
                                            len: p.len.clone(),
                                            selector: None,
                                            selection: None,
                                        }
                                    })
                                    .collect();
                                commands.insert(def.proto.name.clone(), params);
                            }
                            _ => {}
                        }
                    }
                }
                RegistryChild::Feature(feature) => features.push(feature),
                RegistryChild::Extensions(block) => extensions.extend(block.children),
                _ => {}
            }
        }
        if header_version.is_empty() {
            return Err(Error::Registry(format!(
                "{}: no VK_HEADER_VERSION",
                path.display()
            )));
        }
        // "Introduced by" follows the order in which the API grew: core
        // versions first, then extensions by number.
        extensions.sort_by_key(|e| e.number.unwrap_or(i64::MAX));

        // Values core versions and extensions add to enumerated types.
        let features_for_vulkan = features
            .iter()
            .filter(|f| for_vulkan(Some(&f.api)))
            .map(|f| (&f.children, None));
        let extensions_for_vulkan = extensions
            .iter()
            .filter(|e| for_vulkan(e.supported.as_deref()))
            .map(|e| (&e.children, e.number));
        for (children, number) in features_for_vulkan.chain(extensions_for_vulkan) {
            for child in children {
                let ExtensionChild::Require { items, api, .. } = child else {
                    continue;
                };
                if !for_vulkan(api.as_deref()) {
                    continue;
                }
                for item in items {
                    let InterfaceItem::Enum(e) = item else {
                        continue;
                    };
                    if !for_vulkan(e.api.as_deref()) {
                        continue;
                    }
                    if let (Some(extends), Some(value)) =
                        (extends_of(&e.spec), enum_value(&e.spec, number))
                    {
                        if let Some(ordered) = enum_types.get_mut(extends) {
                            ordered.add(&e.name, value);
                        }
                    }
                }
            }
        }

        for require in features
            .iter()
            .flat_map(|f| &f.children)
            .chain(extensions.iter().flat_map(|e| &e.children))
        {
            if let ExtensionChild::Require { items, .. } = require {
                for item in items {
                    if let InterfaceItem::Enum(e) = item {
                        if let EnumSpec::Alias { alias, .. } = &e.spec {
                            enum_aliases.insert(e.name.clone(), alias.clone());
                        }
                    }
                }
            }
        }

        let mut first_required_by: HashMap<String, String> = HashMap::new();
        for feature in &features {
            for child in &feature.children {
                if let ExtensionChild::Require { items, .. } = child {
                    for item in items {
                        let name = match item {
                            InterfaceItem::Type { name, .. }
                            | InterfaceItem::Command { name, .. } => name,
                            InterfaceItem::Enum(e) => &e.name,
                            _ => continue,
                        };
                        first_required_by
                            .entry(name.clone())
                            .or_insert_with(|| feature.name.clone());
                    }
                }
            }
        }

        let mut micromap_requirements: HashMap<String, BTreeSet<&'static str>> = HashMap::new();
        let mut micromap_definitions: HashMap<String, BTreeSet<&'static str>> = HashMap::new();
        let mut aliases: HashMap<String, BTreeSet<String>> = HashMap::new();
        let mut extension_enums = Vec::new();
        for extension in &extensions {
            let micromap = MICROMAP_EXTENSIONS
                .iter()
                .find(|(name, _)| *name == extension.name)
                .map(|(name, _)| *name);
            for child in &extension.children {
                let ExtensionChild::Require { items, depends, .. } = child else {
                    continue;
                };
                for item in items {
                    match item {
                        InterfaceItem::Type { name, .. } | InterfaceItem::Command { name, .. } => {
                            let first = !first_required_by.contains_key(name);
                            if first {
                                first_required_by.insert(name.clone(), extension.name.clone());
                            }
                            if let Some(micromap) = micromap {
                                micromap_requirements
                                    .entry(name.clone())
                                    .or_default()
                                    .insert(micromap);
                                if first {
                                    micromap_definitions
                                        .entry(name.clone())
                                        .or_default()
                                        .insert(micromap);
                                }
                            }
                        }
                        InterfaceItem::Enum(e) => {
                            let introduces = !matches!(e.spec, EnumSpec::None);
                            if let (Some(micromap), true) = (micromap, introduces) {
                                if !first_required_by.contains_key(&e.name) {
                                    micromap_definitions
                                        .entry(e.name.clone())
                                        .or_default()
                                        .insert(micromap);
                                }
                                if let EnumSpec::Alias { alias, .. } = &e.spec {
                                    aliases
                                        .entry(e.name.clone())
                                        .or_default()
                                        .insert(alias.clone());
                                    aliases
                                        .entry(alias.clone())
                                        .or_default()
                                        .insert(e.name.clone());
                                }
                            }
                            if let Some(extends) = extends_of(&e.spec) {
                                extension_enums.push(ExtensionEnum {
                                    name: e.name.clone(),
                                    extends: extends.to_string(),
                                    value: enum_value(&e.spec, extension.number).unwrap_or(0),
                                    required_by: extension.name.clone(),
                                    depends: depends.clone(),
                                    alias: match &e.spec {
                                        EnumSpec::Alias { alias, .. } => Some(alias.clone()),
                                        _ => None,
                                    },
                                });
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
        // Resolve the values of aliased enum names.
        let by_name: HashMap<String, i128> = extension_enums
            .iter()
            .filter(|e| e.alias.is_none())
            .map(|e| (e.name.clone(), e.value))
            .chain(
                enum_blocks
                    .values()
                    .flat_map(|block| block.iter().map(|(name, value)| (name.clone(), *value))),
            )
            .collect();
        let alias_of: HashMap<String, String> = extension_enums
            .iter()
            .filter_map(|e| e.alias.clone().map(|alias| (e.name.clone(), alias)))
            .collect();
        for e in &mut extension_enums {
            // vk.xml chains aliases at most a few links deep
            // (`..._EXT` -> `..._BIT_EXT` -> `..._BIT_KHR`).
            let mut target = e.alias.clone();
            for _ in 0..8 {
                let Some(name) = target.take() else { break };
                if let Some(value) = by_name.get(&name) {
                    e.value = *value;
                    break;
                }
                target = alias_of.get(&name).cloned();
            }
        }
        Ok(Self {
            header_version,
            types,
            enum_blocks,
            micromap_requirements,
            micromap_definitions,
            aliases,
            extension_enums,
            first_required_by,
            enum_aliases,
            command_aliases,
            commands,
            enum_types,
        })
    }

    /// The alias closure of a name, itself included.
    pub fn alias_closure(&self, name: &str) -> BTreeSet<String> {
        let mut out = BTreeSet::from([name.to_string()]);
        let mut stack = vec![name.to_string()];
        while let Some(next) = stack.pop() {
            for other in self.aliases.get(&next).into_iter().flatten() {
                if out.insert(other.clone()) {
                    stack.push(other.clone());
                }
            }
        }
        out
    }

    /// A structure or union definition by name, following a type alias.
    pub fn aggregate(&self, name: &str) -> Option<Aggregate> {
        let mut ty = self.types.get(name)?;
        if let Some(alias) = &ty.alias {
            ty = self.types.get(alias)?;
        }
        let is_union = match ty.category.as_deref() {
            Some("struct") => false,
            Some("union") => true,
            _ => return None,
        };
        let TypeSpec::Members(members) = &ty.spec else {
            return None;
        };
        let members = members
            .iter()
            .filter_map(|m| match m {
                TypeMember::Definition(def) => Some(def),
                _ => None,
            })
            // vk.xml also carries Vulkan SC variants of some members.
            .filter(|def| {
                def.api
                    .as_deref()
                    .is_none_or(|api| api.split(',').any(|a| a == "vulkan"))
            })
            .map(|def| {
                let mut name = String::new();
                let mut type_name = String::new();
                for markup in &def.markup {
                    match markup {
                        TypeMemberMarkup::Name(n) => name = n.clone(),
                        TypeMemberMarkup::Type(t) => type_name = t.clone(),
                        _ => {}
                    }
                }
                Member {
                    pointers: pointer_shape(&def.code, &type_name),
                    name,
                    type_name,
                    values: def.values.clone(),
                    len: def.len.clone(),
                    selector: def.selector.clone(),
                    selection: def.selection.clone(),
                }
            })
            .collect();
        Some(Aggregate {
            name: name.to_string(),
            is_union,
            members,
            structextends: ty
                .structextends
                .as_deref()
                .map(|s| s.split(',').map(str::to_string).collect())
                .unwrap_or_default(),
        })
    }

    /// Category of a type (`enum`, `bitmask`, `struct`, `handle`, `basetype`, ...).
    pub fn category(&self, name: &str) -> Option<&str> {
        self.types.get(name)?.category.as_deref()
    }
}

fn type_name(ty: &vk_parse::Type) -> Option<String> {
    if let Some(name) = &ty.name {
        return Some(name.clone());
    }
    if let TypeSpec::Code(code) = &ty.spec {
        for markup in &code.markup {
            if let vk_parse::TypeCodeMarkup::Name(name) = markup {
                return Some(name.clone());
            }
        }
    }
    None
}

fn header_version_of(ty: &vk_parse::Type) -> Option<String> {
    let TypeSpec::Code(code) = &ty.spec else {
        return None;
    };
    code.code.split_whitespace().last().map(str::to_string)
}

/// Reads pointer depth and constness from a member's C declaration, e.g.
/// `const VkMicromapUsageKHR* const* ppUsageCounts`.
fn pointer_shape(code: &str, type_name: &str) -> Vec<bool> {
    let Some(at) = code.find(type_name) else {
        return Vec::new();
    };
    let before = &code[..at];
    let after = &code[at + type_name.len()..];
    let mut shape = Vec::new();
    // The pointee's own constness is written before the type name.
    let mut next_const = before.contains("const");
    let mut rest = after;
    while let Some(star) = rest.find('*') {
        shape.push(next_const);
        rest = &rest[star + 1..];
        next_const = rest.trim_start().starts_with("const");
    }
    // `shape[i]` says whether what the i-th pointer points to is const.
    shape
}
