//! Enum and flag values written by their specification names.
//!
//! Each kind's table pairs a spec name with its value. The tables of the
//! Vulkan types are generated from vk.xml ([`generated`], written by `cargo
//! xtask generate`): every value the type has in core and in every
//! extension. Aliases vk.xml gives are accepted through
//! `ommcheck_vuids::enum_alias_target`. Only SPIR-V's ray flags, which no
//! Vulkan header defines, are written here.

use std::fmt;
use std::marker::PhantomData;

use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};

mod generated;
pub use generated::*;

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

/// SPIR-V `RayFlags` (the `Rayflags` operand of `OpTraceRayKHR` and
/// `OpRayQueryInitializeKHR`), by their SPIR-V names; the values are the
/// SPIR-V specification's (no Vulkan header defines them, so vk.xml cannot
/// generate them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayFlags;

impl Kind for RayFlags {
    const TYPE_NAME: &'static str = "RayFlags";
    const REPR: Repr = Repr::U32;
    const BITMASK: bool = true;
    fn names() -> &'static [Entry] {
        &[
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
    }
}

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

/// At most this many names are listed in an unknown-name error.
const LISTED_NAMES: usize = 24;

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
        // A short list helps; a type with hundreds of values is better
        // looked up in the schema than read in an error.
        None if K::names().len() <= LISTED_NAMES => Err(format!(
            "unknown {} name `{text}`; expected one of {}, or a number",
            K::TYPE_NAME,
            names.collect::<Vec<_>>().join(", ")
        )),
        None => Err(format!(
            "unknown {} name `{text}`; expected one of its {} names (docs/scene.schema.json lists them), or a number",
            K::TYPE_NAME,
            K::names().len()
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

/// The form a scene writer gives a value, which reads back to it: an
/// enum's name; a bitmask's bit names joined by ` | ` when every bit has
/// one; else the number.
impl<K: Kind> Value<K> {
    pub fn written(&self) -> Written {
        if let Some(name) = name_of::<K>(self.raw) {
            return Written::Name(name.to_string());
        }
        if K::BITMASK && self.raw > 0 {
            let bits = (0..64)
                .map(|bit| 1i64 << bit)
                .filter(|bit| self.raw & bit != 0);
            let names: Option<Vec<&str>> = bits.map(name_of::<K>).collect();
            if let Some(names) = names {
                return Written::Name(names.join(" | "));
            }
        }
        Written::Number(self.raw)
    }
}

/// A value as a scene writes it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum Written {
    Name(String),
    Number(i64),
}

impl<K: Kind> Serialize for Value<K> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.written().serialize(serializer)
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

    /// Every spelling vk.xml gives a value reads: the core name, the
    /// vendor names it was promoted from, and values of extensions the
    /// checks never look at (a capture of any application writes them).
    #[test]
    fn every_vk_xml_spelling_of_a_value_reads() {
        for name in [
            "\"VK_INDEX_TYPE_UINT8\"",
            "\"VK_INDEX_TYPE_UINT8_EXT\"",
            "\"VK_INDEX_TYPE_UINT8_KHR\"",
        ] {
            assert_eq!(from_json::<IndexType>(name), Ok(1_000_265_000), "{name}");
        }
        assert_eq!(
            from_json::<StructureType>("\"VK_STRUCTURE_TYPE_VIDEO_DECODE_INFO_KHR\""),
            Ok(1_000_024_000)
        );
        assert_eq!(
            from_json::<PipelineStageFlags2>(
                "\"VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT_KHR | VK_PIPELINE_STAGE_2_HOST_BIT\""
            ),
            Ok(0x10000 | 0x4000)
        );
        assert_eq!(
            from_json::<MicromapFormat>("\"VK_OPACITY_MICROMAP_FORMAT_2_STATE_KHR\""),
            Ok(1)
        );
        // A name vk.xml gives no value of the type is refused.
        assert!(from_json::<IndexType>("\"VK_FORMAT_R8_UNORM\"").is_err());
    }

    /// Findings show a value by its vk.xml name; where vk.xml made a
    /// micromap value's EXT name an alias of the KHR one, the EXT name,
    /// which VK_EXT_opacity_micromap's users wrote.
    #[test]
    fn values_show_by_their_vk_xml_name_and_micromap_values_by_the_ext_name() {
        assert_eq!(
            name_of::<IndexType>(1_000_265_000),
            Some("VK_INDEX_TYPE_UINT8")
        );
        assert_eq!(
            name_of::<MicromapFormat>(1),
            Some("VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT")
        );
        assert_eq!(
            name_of::<BufferUsageFlags>(0x20),
            Some("VK_BUFFER_USAGE_STORAGE_BUFFER_BIT")
        );
        assert_eq!(
            name_of::<BufferUsageFlags>(0x800000),
            Some("VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT")
        );
    }

    #[test]
    fn a_long_table_is_not_listed_in_an_error() {
        let error = from_json::<StructureType>("\"QQQ\"").unwrap_err();
        assert!(
            error.contains("docs/scene.schema.json lists them"),
            "{error}"
        );
        assert!(error.len() < 200, "{error}");
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
