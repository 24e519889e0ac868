//! The small value forms a scene writes in many places: object handles by
//! name, addresses by buffer and offset, buffer memory, and objects tagged by
//! a first member (`"call"`, `"sType"`).

use std::fmt;
use std::marker::PhantomData;

use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde::de::value::MapAccessDeserializer;
use serde::de::{self, DeserializeOwned, Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};

/// A handle member: an object's name, a raw handle value, or `null`
/// (VK_NULL_HANDLE); `Omitted` when the member is absent.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum HandleArg {
    #[default]
    Omitted,
    Null,
    Name(String),
    Raw(u64),
}

struct HandleVisitor;

impl<'de> Visitor<'de> for HandleVisitor {
    type Value = HandleArg;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an object name, a handle number, or null")
    }

    fn visit_unit<E: de::Error>(self) -> Result<HandleArg, E> {
        Ok(HandleArg::Null)
    }

    fn visit_none<E: de::Error>(self) -> Result<HandleArg, E> {
        Ok(HandleArg::Null)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<HandleArg, E> {
        Ok(if v == 0 {
            HandleArg::Null
        } else {
            HandleArg::Raw(v)
        })
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<HandleArg, E> {
        if v.is_empty() {
            return Err(E::custom("an object name must not be empty"));
        }
        Ok(HandleArg::Name(v.to_string()))
    }
}

impl<'de> Deserialize<'de> for HandleArg {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(HandleVisitor)
    }
}

impl HandleArg {
    /// Absent from the scene (a writer leaves the member out).
    pub fn is_omitted(&self) -> bool {
        matches!(self, HandleArg::Omitted)
    }
}

/// As read: a name, a number, or null (an omitted member writes as null
/// where it is written at all).
impl Serialize for HandleArg {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            HandleArg::Omitted | HandleArg::Null => serializer.serialize_none(),
            HandleArg::Name(name) => serializer.serialize_str(name),
            HandleArg::Raw(raw) => serializer.serialize_u64(*raw),
        }
    }
}

impl JsonSchema for HandleArg {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Handle".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "An object by its name in the scene, a raw handle value, or null (VK_NULL_HANDLE)",
            "type": ["string", "integer", "null"]
        })
    }
}

/// A device or host address: a number, `null` (0), `{"buffer": NAME,
/// "offset": N}`, `{"host": NAME, "offset": N}`, or the spec's union
/// members `{"deviceAddress": ADDRESS}` / `{"hostAddress": ADDRESS}`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AddressArg {
    #[default]
    Null,
    Raw(u64),
    Buffer {
        name: String,
        offset: u64,
    },
    Host {
        name: String,
        offset: u64,
    },
}

/// The object form of an address, as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
struct AddressObject {
    buffer: Option<String>,
    host: Option<String>,
    #[serde(default)]
    offset: u64,
    device_address: Option<Box<AddressArg>>,
    host_address: Option<Box<AddressArg>>,
}

struct AddressVisitor;

impl<'de> Visitor<'de> for AddressVisitor {
    type Value = AddressArg;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an address: a number, null, {\"buffer\": NAME, \"offset\": N} or {\"host\": NAME, \"offset\": N}")
    }

    fn visit_unit<E: de::Error>(self) -> Result<AddressArg, E> {
        Ok(AddressArg::Null)
    }

    fn visit_none<E: de::Error>(self) -> Result<AddressArg, E> {
        Ok(AddressArg::Null)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<AddressArg, E> {
        Ok(AddressArg::Raw(v))
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<AddressArg, A::Error> {
        let object = AddressObject::deserialize(MapAccessDeserializer::new(map))?;
        let forms = usize::from(object.buffer.is_some())
            + usize::from(object.host.is_some())
            + usize::from(object.device_address.is_some())
            + usize::from(object.host_address.is_some());
        if forms != 1 {
            return Err(de::Error::custom(
                "an address object needs exactly one of `buffer`, `host`, `deviceAddress` or `hostAddress`",
            ));
        }
        let nested = object.device_address.or(object.host_address);
        if let Some(nested) = nested {
            if object.offset != 0 {
                return Err(de::Error::custom(
                    "`offset` goes inside `deviceAddress` / `hostAddress`, next to `buffer` or `host`",
                ));
            }
            return Ok(*nested);
        }
        Ok(match (object.buffer, object.host) {
            (Some(name), _) => AddressArg::Buffer {
                name,
                offset: object.offset,
            },
            (_, Some(name)) => AddressArg::Host {
                name,
                offset: object.offset,
            },
            _ => AddressArg::Null,
        })
    }
}

impl<'de> Deserialize<'de> for AddressArg {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(AddressVisitor)
    }
}

/// As read: a number, null, or `{"buffer"|"host": NAME, "offset": N}`
/// (the offset left out when 0).
impl Serialize for AddressArg {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let (key, name, offset) = match self {
            AddressArg::Null => return serializer.serialize_none(),
            AddressArg::Raw(raw) => return serializer.serialize_u64(*raw),
            AddressArg::Buffer { name, offset } => ("buffer", name, *offset),
            AddressArg::Host { name, offset } => ("host", name, *offset),
        };
        let mut map = serializer.serialize_map(Some(if offset == 0 { 1 } else { 2 }))?;
        map.serialize_entry(key, name)?;
        if offset != 0 {
            map.serialize_entry("offset", &offset)?;
        }
        map.end()
    }
}

impl JsonSchema for AddressArg {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Address".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "A device or host address: a number, null (0), a buffer's device address plus an offset, a host memory block's address plus an offset, or the spec's union member wrapping one of those",
            "anyOf": [
                { "type": "integer", "minimum": 0 },
                { "type": "null" },
                {
                    "type": "object",
                    "properties": { "buffer": { "type": "string" }, "offset": { "type": "integer", "minimum": 0 } },
                    "required": ["buffer"],
                    "additionalProperties": false
                },
                {
                    "type": "object",
                    "properties": { "host": { "type": "string" }, "offset": { "type": "integer", "minimum": 0 } },
                    "required": ["host"],
                    "additionalProperties": false
                },
                {
                    "type": "object",
                    "properties": { "deviceAddress": { "$ref": "#/$defs/Address" } },
                    "required": ["deviceAddress"],
                    "additionalProperties": false
                },
                {
                    "type": "object",
                    "properties": { "hostAddress": { "$ref": "#/$defs/Address" } },
                    "required": ["hostAddress"],
                    "additionalProperties": false
                }
            ]
        })
    }
}

/// An object whose kind is named by one member (`"call"` for calls,
/// `"sType"` for pNext structures). Written first, the tag lets the rest be
/// read in place, so errors inside point at their own line and column;
/// written later, the object is buffered first and errors point at its end.
pub trait Tagged: Sized {
    const TAG: &'static str;
    /// What the object is, for messages ("a call", "a pNext structure").
    const WHAT: &'static str;
    type Tag: DeserializeOwned;
    fn from_rest<'de, D: Deserializer<'de>>(tag: Self::Tag, rest: D) -> Result<Self, D::Error>;
}

/// Reads a [`Tagged`] object.
pub fn deserialize_tagged<'de, T: Tagged, D: Deserializer<'de>>(
    deserializer: D,
) -> Result<T, D::Error> {
    deserializer.deserialize_map(TaggedVisitor(PhantomData))
}

struct TaggedVisitor<T>(PhantomData<T>);

impl<'de, T: Tagged> Visitor<'de> for TaggedVisitor<T> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (an object with a `{}` member)", T::WHAT, T::TAG)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<T, A::Error> {
        let Some(first) = map.next_key::<String>()? else {
            return Err(de::Error::missing_field(T::TAG));
        };
        if first == T::TAG {
            let tag: T::Tag = map.next_value()?;
            return T::from_rest(tag, MapAccessDeserializer::new(map));
        }
        let mut object = serde_json::Map::new();
        let value: serde_json::Value = map.next_value()?;
        object.insert(first, value);
        while let Some((key, value)) = map.next_entry::<String, serde_json::Value>()? {
            object.insert(key, value);
        }
        let Some(tag) = object.remove(T::TAG) else {
            return Err(de::Error::missing_field(T::TAG));
        };
        let tag = T::Tag::deserialize(tag).map_err(de::Error::custom)?;
        T::from_rest(tag, serde_json::Value::Object(object)).map_err(de::Error::custom)
    }
}
