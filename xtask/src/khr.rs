//! Writes `vuids/src/generated/khr.rs`: the declarations of
//! `VK_KHR_opacity_micromap` and `VK_ARM_pipeline_opacity_micromap` that
//! ash 0.38 (Vulkan headers 1.3.281) predates, and typed constants for every
//! enum value and bit the micromap extensions add.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt::Write as _;

use crate::ash_names::AshNames;
use crate::registry::{Aggregate, VkXml, MICROMAP_EXTENSIONS};
use crate::Error;

/// Extensions whose structures we declare.
const DECLARING_EXTENSIONS: [&str; 2] = [
    "VK_KHR_opacity_micromap",
    "VK_ARM_pipeline_opacity_micromap",
];

/// Structures outside those extensions that a KHR micromap program needs:
/// `vkCreateAccelerationStructure2KHR` (VK_KHR_device_address_commands,
/// which VK_KHR_opacity_micromap depends on) is how a KHR opacity micromap
/// acceleration structure is created.
const EXTRA_ROOTS: [&str; 1] = ["VkAccelerationStructureCreateInfo2KHR"];

/// How a Vulkan type is spelled in the generated Rust.
#[derive(Debug, Clone)]
enum Spelling {
    /// A Rust primitive or `c_void`.
    Primitive(&'static str),
    /// `vk::Name` from ash.
    Ash(String),
    /// A type this file declares.
    Ours(String),
}

impl Spelling {
    fn rust(&self) -> String {
        match self {
            Spelling::Primitive(p) => (*p).to_string(),
            Spelling::Ash(name) => format!("vk::{name}"),
            Spelling::Ours(name) => name.clone(),
        }
    }
}

fn strip_vk(name: &str) -> &str {
    name.strip_prefix("Vk").unwrap_or(name)
}

/// `maxOpacity2StateSubdivisionLevel` -> `max_opacity2_state_subdivision_level`, as ash spells fields.
pub fn snake_case(name: &str) -> String {
    if name == "type" {
        return "ty".to_string();
    }
    let mut out = String::new();
    let mut previous: Option<char> = None;
    for c in name.chars() {
        if c.is_ascii_uppercase() {
            if previous.is_some_and(|p| p.is_ascii_lowercase() || p.is_ascii_digit()) {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
        previous = Some(c);
    }
    out
}

fn primitive(c_type: &str) -> Option<(&'static str, u64)> {
    Some(match c_type {
        "void" => ("c_void", 0),
        "char" => ("c_char", 1),
        "uint8_t" => ("u8", 1),
        "int8_t" => ("i8", 1),
        "uint16_t" => ("u16", 2),
        "int16_t" => ("i16", 2),
        "uint32_t" => ("u32", 4),
        "int32_t" => ("i32", 4),
        "uint64_t" => ("u64", 8),
        "int64_t" => ("i64", 8),
        "float" => ("f32", 4),
        "double" => ("f64", 8),
        "size_t" => ("usize", 8),
        _ => return None,
    })
}

struct Generator<'a> {
    vk: &'a VkXml,
    ash: &'a AshNames,
    /// Types to declare, in discovery order.
    queue: VecDeque<String>,
    declared: BTreeSet<String>,
    out_types: String,
    layout_tests: String,
}

impl<'a> Generator<'a> {
    /// Every name a type is known by: itself and its vk.xml aliases, both ways.
    fn type_names(&self, name: &str) -> Vec<String> {
        let mut names = vec![name.to_string()];
        if let Some(alias) = self.vk.types.get(name).and_then(|t| t.alias.clone()) {
            names.push(alias);
        }
        let mut others: Vec<String> = self
            .vk
            .types
            .iter()
            .filter(|(_, t)| t.alias.as_deref() == Some(name))
            .map(|(n, _)| n.clone())
            .collect();
        others.sort();
        names.extend(others);
        names
    }

    /// The ash name of a Vulkan type, trying its aliases.
    fn ash_name(&self, name: &str) -> Option<String> {
        self.type_names(name)
            .into_iter()
            .map(|n| strip_vk(&n).to_string())
            .find(|n| self.ash.types.contains(n))
    }

    /// The bitmask (`VkFooFlags`) type whose bits are `flag_bits`.
    fn flags_of_bits(&self, flag_bits: &str) -> Option<String> {
        let mut found: Vec<&String> = self
            .vk
            .types
            .iter()
            .filter(|(_, t)| {
                t.category.as_deref() == Some("bitmask")
                    && (t.requires.as_deref() == Some(flag_bits)
                        || t.bitvalues.as_deref() == Some(flag_bits))
            })
            .map(|(n, _)| n)
            .collect();
        found.sort();
        found.first().map(|n| (*n).clone())
    }

    fn spell(&mut self, c_type: &str) -> Result<Spelling, Error> {
        if let Some((p, _)) = primitive(c_type) {
            return Ok(Spelling::Primitive(p));
        }
        if let Some(ash) = self.ash_name(c_type) {
            return Ok(Spelling::Ash(ash));
        }
        if !self.vk.types.contains_key(c_type) {
            return Err(Error::Registry(format!("unknown type {c_type}")));
        }
        if self.declared.insert(c_type.to_string()) {
            self.queue.push_back(c_type.to_string());
        }
        Ok(Spelling::Ours(strip_vk(c_type).to_string()))
    }

    /// Size and alignment of a Vulkan type on a 64-bit target, computed from vk.xml.
    fn c_layout(&self, c_type: &str) -> Result<(u64, u64), Error> {
        if let Some((_, size)) = primitive(c_type) {
            return Ok((size, size.max(1)));
        }
        let ty = self
            .vk
            .types
            .get(c_type)
            .ok_or_else(|| Error::Registry(format!("unknown type {c_type}")))?;
        if let Some(alias) = &ty.alias {
            return self.c_layout(alias);
        }
        match ty.category.as_deref() {
            Some("enum") => Ok((4, 4)),
            Some("handle") => Ok((8, 8)),
            Some("basetype") | Some("bitmask") => {
                let vk_parse::TypeSpec::Code(code) = &ty.spec else {
                    return Err(Error::Registry(format!("{c_type}: no typedef")));
                };
                let underlying = code
                    .markup
                    .iter()
                    .find_map(|m| match m {
                        vk_parse::TypeCodeMarkup::Type(t) => Some(t.clone()),
                        _ => None,
                    })
                    .ok_or_else(|| Error::Registry(format!("{c_type}: no underlying type")))?;
                self.c_layout(&underlying)
            }
            Some("struct") | Some("union") => {
                let aggregate = self
                    .vk
                    .aggregate(c_type)
                    .ok_or_else(|| Error::Registry(format!("{c_type}: no members")))?;
                let (size, align, _) = self.aggregate_layout(&aggregate)?;
                Ok((size, align))
            }
            other => Err(Error::Registry(format!(
                "{c_type}: no layout for category {other:?}"
            ))),
        }
    }

    /// Size, alignment and member offsets of a structure or union.
    fn aggregate_layout(&self, aggregate: &Aggregate) -> Result<(u64, u64, Vec<u64>), Error> {
        let mut offset = 0u64;
        let mut size = 0u64;
        let mut align = 1u64;
        let mut offsets = Vec::new();
        for member in &aggregate.members {
            let (member_size, member_align) = if member.pointers.is_empty() {
                self.c_layout(&member.type_name)?
            } else {
                (8, 8)
            };
            align = align.max(member_align);
            if aggregate.is_union {
                offsets.push(0);
                size = size.max(member_size);
            } else {
                offset = offset.div_ceil(member_align) * member_align;
                offsets.push(offset);
                offset += member_size;
                size = offset;
            }
        }
        Ok((size.div_ceil(align) * align, align, offsets))
    }

    fn declare(&mut self, c_type: &str) -> Result<(), Error> {
        let category = self.vk.category(c_type).map(str::to_string);
        match category.as_deref() {
            Some("struct") | Some("union") => self.declare_aggregate(c_type),
            Some("enum") => self.declare_enum(c_type),
            Some("bitmask") => self.declare_bitmask(c_type),
            other => Err(Error::Registry(format!(
                "{c_type}: cannot declare category {other:?}"
            ))),
        }
    }

    fn declare_aggregate(&mut self, c_type: &str) -> Result<(), Error> {
        let aggregate = self
            .vk
            .aggregate(c_type)
            .ok_or_else(|| Error::Registry(format!("{c_type}: no members")))?;
        let rust_name = strip_vk(c_type).to_string();
        let mut fields = Vec::new();
        let mut has_union_member = false;
        for member in &aggregate.members {
            let mut spelled = self.spell(&member.type_name)?.rust();
            if member.pointers.is_empty() {
                has_union_member |= self.vk.category(&member.type_name) == Some("union");
            }
            for is_const in &member.pointers {
                spelled = format!("*{} {spelled}", if *is_const { "const" } else { "mut" });
            }
            fields.push((snake_case(&member.name), spelled, member.clone()));
        }
        let s_type = aggregate
            .members
            .iter()
            .find(|m| m.name == "sType")
            .and_then(|m| m.values.clone());
        // As ash does, a structure whose builders store borrowed pointers
        // (other than pNext) carries their lifetime, so a chain built with
        // them cannot outlive what it points to.
        let borrows = !aggregate.is_union
            && fields
                .iter()
                .any(|(_, spelled, member)| member.name != "pNext" && spelled.starts_with('*'));
        let generics = if borrows { "<'a>" } else { "" };

        let w = &mut self.out_types;
        let _ = writeln!(w, "/// `{c_type}`");
        let _ = writeln!(w, "#[repr(C)]");
        // Plain-data structures derive Default; those with an sType or
        // pointers get one that sets the sType and null pointers.
        let manual_default = aggregate.is_union
            || fields
                .iter()
                .any(|(_, spelled, member)| member.name == "sType" || spelled.starts_with('*'));
        let mut derives = vec!["Clone", "Copy"];
        if !has_union_member {
            derives.push("Debug");
        }
        if !manual_default {
            derives.push("Default");
        }
        let _ = writeln!(w, "#[derive({})]", derives.join(", "));
        let keyword = if aggregate.is_union {
            "union"
        } else {
            "struct"
        };
        let _ = writeln!(w, "pub {keyword} {rust_name}{generics} {{");
        for (field, spelled, _) in &fields {
            let _ = writeln!(w, "    pub {field}: {spelled},");
        }
        if borrows {
            let _ = writeln!(w, "    pub _marker: core::marker::PhantomData<&'a ()>,");
        }
        let _ = writeln!(w, "}}\n");

        if manual_default && !aggregate.is_union {
            let anonymous = if borrows { "<'_>" } else { "" };
            let _ = writeln!(w, "impl Default for {rust_name}{anonymous} {{");
            let _ = writeln!(w, "    fn default() -> Self {{");
            let _ = writeln!(w, "        Self {{");
            for (field, spelled, member) in &fields {
                let value = if member.name == "sType" {
                    match &s_type {
                        Some(v) => v.strip_prefix("VK_").unwrap_or(v).to_string(),
                        None => "vk::StructureType::default()".to_string(),
                    }
                } else if spelled.starts_with("*const") {
                    "core::ptr::null()".to_string()
                } else if spelled.starts_with("*mut") {
                    "core::ptr::null_mut()".to_string()
                } else {
                    "Default::default()".to_string()
                };
                let _ = writeln!(w, "            {field}: {value},");
            }
            if borrows {
                let _ = writeln!(w, "            _marker: core::marker::PhantomData,");
            }
            let _ = writeln!(w, "        }}\n    }}\n}}\n");
        }
        if !aggregate.is_union {
            write_builders(w, &rust_name, generics, &fields);
        }
        if let Some(s_type) = &s_type {
            let constant = s_type.strip_prefix("VK_").unwrap_or(s_type);
            let _ = writeln!(
                w,
                "// SAFETY: the structure starts with `s_type` and `p_next` like every Vulkan\n// structure ash chains, and `STRUCTURE_TYPE` is its sType from vk.xml."
            );
            let _ = writeln!(
                w,
                "unsafe impl vk::TaggedStructure for {rust_name}{anonymous} {{\n    const STRUCTURE_TYPE: vk::StructureType = {constant};\n}}\n",
                anonymous = if borrows { "<'_>" } else { "" }
            );
            for extended in &aggregate.structextends {
                let trait_name = format!("Extends{}", strip_vk(extended));
                if self.ash.traits.contains(&trait_name) {
                    let _ = writeln!(
                        w,
                        "// SAFETY: vk.xml lists `{extended}` in this structure's `structextends`.\nunsafe impl vk::{trait_name} for {rust_name}{anonymous} {{}}\n",
                        anonymous = if borrows { "<'_>" } else { "" }
                    );
                }
            }
        }

        // Layout test from the C rules, computed independently of rustc.
        let (size, align, offsets) = self.aggregate_layout(&aggregate)?;
        let t = &mut self.layout_tests;
        let _ = writeln!(t, "    #[test]\n    fn {}() {{", snake_case(&rust_name));
        let _ = writeln!(t, "        assert_eq!(size_of::<{rust_name}>(), {size});");
        let _ = writeln!(t, "        assert_eq!(align_of::<{rust_name}>(), {align});");
        for ((field, _, _), offset) in fields.iter().zip(offsets) {
            let _ = writeln!(
                t,
                "        assert_eq!(offset_of!({rust_name}, {field}), {offset});"
            );
        }
        let _ = writeln!(t, "    }}\n");
        Ok(())
    }

    fn enum_values(&self, enum_type: &str) -> BTreeMap<String, i128> {
        let mut values = BTreeMap::new();
        for name in self.type_names(enum_type) {
            if let Some(block) = self.vk.enum_blocks.get(&name) {
                values.extend(block.iter().map(|(n, v)| (n.clone(), *v)));
            }
        }
        values
    }

    fn declare_enum(&mut self, c_type: &str) -> Result<(), Error> {
        let rust_name = strip_vk(c_type).to_string();
        let values = self.enum_values(c_type);
        let w = &mut self.out_types;
        let _ = writeln!(
            w,
            "/// `{c_type}`; its values are the constants of this module."
        );
        let _ = writeln!(w, "#[repr(transparent)]");
        let _ = writeln!(
            w,
            "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]"
        );
        let _ = writeln!(w, "pub struct {rust_name}(pub i32);\n");
        let _ = writeln!(
            w,
            "impl {rust_name} {{\n    pub const fn from_raw(raw: i32) -> Self {{\n        Self(raw)\n    }}\n    pub const fn as_raw(self) -> i32 {{\n        self.0\n    }}\n}}\n"
        );
        for (name, value) in values {
            let value = i32::try_from(value)
                .map_err(|_| Error::Registry(format!("{name} does not fit i32")))?;
            let _ = writeln!(
                w,
                "/// `{name}`\npub const {}: {rust_name} = {rust_name}::from_raw({value});\n",
                name.strip_prefix("VK_").unwrap_or(&name)
            );
        }
        self.layout_tests.push_str(&format!(
            "    #[test]\n    fn {}() {{\n        assert_eq!(size_of::<{rust_name}>(), 4);\n    }}\n\n",
            snake_case(&rust_name)
        ));
        Ok(())
    }

    fn declare_bitmask(&mut self, c_type: &str) -> Result<(), Error> {
        let rust_name = strip_vk(c_type).to_string();
        let (size, _) = self.c_layout(c_type)?;
        let bits_type = self
            .vk
            .types
            .get(c_type)
            .and_then(|t| t.requires.clone().or_else(|| t.bitvalues.clone()));
        let bits = bits_type.map(|b| self.enum_values(&b)).unwrap_or_default();
        let raw = if size == 8 { "u64" } else { "u32" };
        let w = &mut self.out_types;
        let _ = writeln!(w, "/// `{c_type}`");
        let _ = writeln!(w, "#[repr(transparent)]");
        let _ = writeln!(
            w,
            "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]"
        );
        let _ = writeln!(w, "pub struct {rust_name}(pub {raw});\n");
        let _ = writeln!(
            w,
            "impl {rust_name} {{\n    pub const fn from_raw(raw: {raw}) -> Self {{\n        Self(raw)\n    }}\n    pub const fn as_raw(self) -> {raw} {{\n        self.0\n    }}\n    pub const fn contains(self, other: Self) -> bool {{\n        self.0 & other.0 == other.0\n    }}\n}}\n"
        );
        for (name, value) in bits {
            let value =
                u64::try_from(value).map_err(|_| Error::Registry(format!("{name} is negative")))?;
            let _ = writeln!(
                w,
                "/// `{name}`\npub const {}: {rust_name} = {rust_name}::from_raw({value:#x});\n",
                name.strip_prefix("VK_").unwrap_or(&name)
            );
        }
        self.layout_tests.push_str(&format!(
            "    #[test]\n    fn {}() {{\n        assert_eq!(size_of::<{rust_name}>(), {size});\n    }}\n\n",
            snake_case(&rust_name)
        ));
        Ok(())
    }

    /// The type a constant extending `extends` has: for `VkFooFlagBits` the
    /// `VkFooFlags` bitmask, else the enum itself.
    fn constant_type(&mut self, extends: &str) -> Result<(Spelling, u64), Error> {
        let target = if self.vk.category(extends) == Some("enum") {
            // Enumerants of a FlagBits type are values of its Flags type.
            let mut flags = None;
            for name in self.type_names(extends) {
                if let Some(f) = self.flags_of_bits(&name) {
                    flags = Some(f);
                    break;
                }
            }
            flags.unwrap_or_else(|| extends.to_string())
        } else {
            extends.to_string()
        };
        let (size, _) = self.c_layout(&target)?;
        Ok((self.spell(&target)?, size))
    }
}

/// Writes ash-style builder methods for a structure's members: one per
/// member that is a value (a `VkBool32` taken as `bool`), one taking a
/// slice for each array member (setting its count member, which gets no
/// builder of its own), and none for `sType` and `pNext` (`push_next` is
/// ash's, on the structure a chain extends).
fn write_builders(
    w: &mut String,
    rust_name: &str,
    generics: &str,
    fields: &[(String, String, crate::registry::Member)],
) {
    // Count members that an array member's `len` names.
    let counts: BTreeSet<&str> = fields
        .iter()
        .filter_map(|(_, _, m)| m.len.as_deref())
        .map(|len| len.split(',').next().unwrap_or(len))
        .collect();
    let mut methods = String::new();
    for (field, spelled, member) in fields {
        if member.name == "sType" || member.name == "pNext" || counts.contains(member.name.as_str())
        {
            continue;
        }
        let name = &member.name;
        if let Some(len) = member.len.as_deref() {
            let count = snake_case(len.split(',').next().unwrap_or(len));
            let element = spelled
                .trim_start_matches("*const ")
                .trim_start_matches("*mut ");
            if member.pointers.len() == 1 {
                let method = field.strip_prefix("p_").unwrap_or(field);
                let _ = writeln!(
                    methods,
                    "    /// Sets `{name}` to `{method}` and its count to the slice's length.\n    #[inline]\n    pub fn {method}(mut self, {method}: &'a [{element}]) -> Self {{\n        self.{count} = {method}.len() as _;\n        self.{field} = {method}.as_ptr();\n        self\n    }}\n"
                );
            } else if member.pointers.len() == 2 {
                let element = element
                    .trim_start_matches("*const ")
                    .trim_start_matches("*mut ");
                let method = format!("{}_ptrs", field.strip_prefix("pp_").unwrap_or(field));
                let _ = writeln!(
                    methods,
                    "    /// Sets `{name}` to pointers to the elements of `{method}`, and its count to the slice's length.\n    #[inline]\n    pub fn {method}(mut self, {method}: &'a [&'a {element}]) -> Self {{\n        self.{count} = {method}.len() as _;\n        self.{field} = {method}.as_ptr().cast();\n        self\n    }}\n"
                );
            }
            continue;
        }
        if spelled.starts_with('*') {
            // A pointer with no length: no member of the structures
            // generated today; left to the raw field.
            continue;
        }
        let (ty, value) = if spelled == "vk::Bool32" {
            ("bool".to_string(), format!("{field}.into()"))
        } else {
            (spelled.clone(), field.clone())
        };
        let _ = writeln!(
            methods,
            "    /// Sets `{name}`.\n    #[inline]\n    pub fn {field}(mut self, {field}: {ty}) -> Self {{\n        self.{field} = {value};\n        self\n    }}\n"
        );
    }
    if !methods.is_empty() {
        let _ = writeln!(
            w,
            "impl{generics} {rust_name}{generics} {{\n{}}}\n",
            methods.trim_end_matches('\n').to_string() + "\n"
        );
    }
}

/// Renders the file.
pub fn render(vk: &VkXml, ash: &AshNames) -> Result<String, Error> {
    let mut generator = Generator {
        vk,
        ash,
        queue: VecDeque::new(),
        declared: BTreeSet::new(),
        out_types: String::new(),
        layout_tests: String::new(),
    };

    // Roots: what the declaring extensions require, then the extra roots.
    let mut roots: Vec<String> = vk
        .micromap_requirements
        .iter()
        .filter(|(name, exts)| {
            exts.iter().any(|e| DECLARING_EXTENSIONS.contains(e))
                && matches!(
                    vk.category(name),
                    Some("struct" | "enum" | "bitmask" | "union")
                )
        })
        .map(|(name, _)| name.clone())
        .collect();
    roots.sort();
    roots.extend(EXTRA_ROOTS.iter().map(|s| s.to_string()));

    let mut aliases = String::new();
    for root in &roots {
        match generator.ash_name(root) {
            Some(ash) if ash == strip_vk(root) => {}
            Some(ash) => {
                let ours = strip_vk(root);
                let _ = writeln!(
                    aliases,
                    "/// `{root}`: ash 0.38 has it under its older name."
                );
                let _ = writeln!(aliases, "pub type {ours} = vk::{ash};\n");
                if vk.category(root) == Some("enum") {
                    for (name, value) in generator.enum_values(root) {
                        let value = i32::try_from(value)
                            .map_err(|_| Error::Registry(format!("{name} does not fit i32")))?;
                        let _ = writeln!(
                            aliases,
                            "/// `{name}`\npub const {}: {ours} = {ours}::from_raw({value});\n",
                            name.strip_prefix("VK_").unwrap_or(&name)
                        );
                    }
                }
                if matches!(vk.category(root), Some("struct" | "union")) {
                    let (size, align) = generator.c_layout(root)?;
                    let _ = writeln!(
                        generator.layout_tests,
                        "    #[test]\n    fn {}() {{\n        assert_eq!(size_of::<{ours}>(), {size});\n        assert_eq!(align_of::<{ours}>(), {align});\n    }}\n",
                        snake_case(ours)
                    );
                }
            }
            None => {
                if generator.declared.insert(root.clone()) {
                    generator.queue.push_back(root.clone());
                }
            }
        }
    }
    while let Some(next) = generator.queue.pop_front() {
        generator.declare(&next)?;
    }

    // Constants: every enum value or bit that a micromap extension adds,
    // that another extension adds for a micromap extension (`depends=`), or
    // whose name says micromap; plus the sTypes of the structures above.
    let micromap_names: Vec<&str> = MICROMAP_EXTENSIONS.iter().map(|(n, _)| *n).collect();
    let mut constants: BTreeMap<String, (String, i128, String)> = BTreeMap::new();
    let wanted_s_types: BTreeSet<String> = generator
        .declared
        .iter()
        .filter_map(|t| vk.aggregate(t))
        .flat_map(|a| a.members.into_iter().filter_map(|m| m.values))
        .collect();
    for e in &vk.extension_enums {
        let relevant = micromap_names.contains(&e.required_by.as_str())
            || e.depends
                .as_deref()
                .is_some_and(|d| micromap_names.iter().any(|m| d.contains(m)))
            || e.name.contains("MICROMAP")
            || wanted_s_types.contains(&e.name);
        if relevant {
            constants.entry(e.name.clone()).or_insert((
                e.extends.clone(),
                e.value,
                e.required_by.clone(),
            ));
        }
    }
    let mut out_constants = String::new();
    for (name, (extends, value, required_by)) in &constants {
        let (spelling, size) = generator.constant_type(extends)?;
        let raw_type = match (&spelling, size) {
            (_, 8) => "u64",
            (Spelling::Ash(_) | Spelling::Ours(_), _)
                if vk.category(extends) == Some("enum") && value_is_enum(vk, extends) =>
            {
                "i32"
            }
            _ => "u32",
        };
        let literal = match raw_type {
            "i32" => i32::try_from(*value).map(|v| v.to_string()),
            "u32" => u32::try_from(*value).map(|v| format!("{v:#x}")),
            _ => u64::try_from(*value).map(|v| format!("{v:#x}")),
        }
        .map_err(|_| Error::Registry(format!("{name} = {value} does not fit {raw_type}")))?;
        let _ = writeln!(out_constants, "/// `{name}` (from `{required_by}`)");
        let _ = writeln!(
            out_constants,
            "pub const {}: {} = {}::from_raw({literal});\n",
            name.strip_prefix("VK_").unwrap_or(name),
            spelling.rust(),
            spelling.rust()
        );
    }
    // Declarations the constants needed.
    while let Some(next) = generator.queue.pop_front() {
        generator.declare(&next)?;
    }

    let mut out = String::new();
    let _ = writeln!(
        out,
        "// @generated by `cargo xtask generate` from vk.xml (header {}). Do not edit: regenerate.\n",
        vk.header_version
    );
    out.push_str("//! Declarations ash 0.38 predates: the `VK_KHR_opacity_micromap` and\n");
    out.push_str("//! `VK_ARM_pipeline_opacity_micromap` structures and enums, and a typed\n");
    out.push_str("//! constant for every enum value and bit the micromap extensions add\n");
    out.push_str("//! (including those ash already has, so one module lists them all).\n\n");
    out.push_str("#![allow(clippy::unreadable_literal)]\n\n");
    out.push_str("#[allow(unused_imports)]\nuse core::ffi::{c_char, c_void};\n\nuse ash::vk;\n\n");
    out.push_str(&aliases);
    out.push_str(&generator.out_types);
    out.push_str(&out_constants);
    out.push_str("\n#[cfg(all(test, target_pointer_width = \"64\"))]\nmod layout {\n    use super::*;\n    use core::mem::{align_of, offset_of, size_of};\n\n");
    out.push_str(&generator.layout_tests);
    out.push_str("}\n");
    Ok(out)
}

/// Whether `extends` is a plain enumeration (signed 32-bit values) rather
/// than the bits of a bitmask.
fn value_is_enum(vk: &VkXml, extends: &str) -> bool {
    let is_bits = vk.types.values().any(|t| {
        t.category.as_deref() == Some("bitmask")
            && (t.requires.as_deref() == Some(extends) || t.bitvalues.as_deref() == Some(extends))
    });
    !is_bits
}

#[cfg(test)]
mod tests {
    use super::snake_case;

    #[test]
    fn field_names_follow_ash() {
        assert_eq!(snake_case("sType"), "s_type");
        assert_eq!(snake_case("ppUsageCounts"), "pp_usage_counts");
        assert_eq!(
            snake_case("maxOpacity2StateSubdivisionLevel"),
            "max_opacity2_state_subdivision_level"
        );
        assert_eq!(snake_case("type"), "ty");
    }
}
