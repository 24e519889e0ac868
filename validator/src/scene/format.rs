//! The scene file as written: serde types whose member names are the
//! specification's (camelCase, `sType`/`pNext` implied or explicit), with
//! enums and flags by spec name or number, handles by object name, and
//! addresses by buffer and offset. `docs/scene-format.md` describes it and
//! `docs/scene.schema.json` is generated from these types.

use schemars::JsonSchema;
use serde::de::{self, Deserializer};
use serde::{Deserialize, Serialize};

use super::args::{deserialize_tagged, AddressArg, Tagged};
use crate::checks::pipeline_sync::WorkCommand;
use crate::model::names::{self, Value};

/// Reads a member that must be present but may be `null` (a pointer
/// parameter: omitting it is a mistake, NULL is a case to check).
fn nullable<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    deserializer: D,
) -> Result<Option<T>, D::Error> {
    Option::<T>::deserialize(deserializer)
}

/// A whole scene.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
#[schemars(title = "ommcheck scene")]
pub struct SceneFile {
    /// The schema this file follows (ignored by ommcheck; editors use it).
    #[serde(rename = "$schema", default)]
    pub schema: Option<String>,
    /// Free text about the scene.
    #[serde(default)]
    pub description: Option<String>,
    /// The device the calls run on; absent: every micromap extension and
    /// feature, with the spec-minimum limits.
    #[serde(default)]
    pub device: Option<DeviceDesc>,
    #[serde(default)]
    pub buffers: Vec<BufferDesc>,
    /// Host memory that host commands (`vkBuildMicromapsEXT`, ...) read
    /// through `hostAddress` members.
    #[serde(default)]
    pub host_memory: Vec<HostMemoryDesc>,
    /// Micromaps that exist before the first call.
    #[serde(default)]
    pub micromaps: Vec<MicromapDesc>,
    /// Acceleration structures that exist before the first call.
    #[serde(default)]
    pub acceleration_structures: Vec<AccelerationStructureDesc>,
    #[serde(default)]
    pub query_pools: Vec<QueryPoolDesc>,
    /// `VkDeferredOperationKHR` objects, by name.
    #[serde(default)]
    pub deferred_operations: Vec<String>,
    /// Command buffers calls may name; a `vkCmd*` call without one records
    /// into a primary command buffer on a graphics+compute+transfer queue.
    #[serde(default)]
    pub command_buffers: Vec<CommandBufferDesc>,
    /// Names of objects declared above (buffers, micromaps, acceleration
    /// structures, query pools, deferred operations, command buffers) that
    /// belong to another `VkDevice`, not the one the calls run on.
    #[serde(default)]
    pub other_device_objects: Vec<String>,
    /// What the driver answered to size queries (`vkGetMicromapBuildSizesEXT`),
    /// for the rules that compare against its answers.
    #[serde(default)]
    pub driver_answers: DriverAnswersDesc,
    /// The API calls, checked in order.
    pub calls: Vec<Call>,
    /// Candidate hits `ommcheck trace` simulates after the calls, each on a
    /// triangle of a bottom-level acceleration structure a call built.
    #[serde(default)]
    pub rays: Vec<RayDesc>,
    /// Alpha textures that pictures of BLAS geometries are drawn over
    /// (`ommcheck draw`); the checks ignore them.
    #[serde(default)]
    pub alpha_textures: Vec<AlphaTextureDesc>,
}

/// One candidate hit to simulate (`ommcheck trace`): a triangle of a
/// geometry of a bottom-level acceleration structure built by one of the
/// calls, hit at barycentrics (`hit`) or by a ray (`ray`) intersected with
/// the triangle's vertices as the build read them.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct RayDesc {
    /// A label shown in the output.
    pub name: Option<String>,
    /// The bottom-level acceleration structure, by its name in the scene.
    pub acceleration_structure: String,
    /// The geometry's index in the build (default 0).
    #[serde(default)]
    pub geometry: u32,
    /// The geometry triangle (0-based, below the build range's primitiveCount).
    pub triangle: u64,
    /// The hit as barycentrics; exactly one of `hit` and `ray`.
    pub hit: Option<HitDesc>,
    /// The hit as a ray against the triangle's vertices; exactly one of
    /// `hit` and `ray`.
    pub ray: Option<RayGeometryDesc>,
    /// `VkGeometryInstanceFlagsKHR` of the instance the ray meets.
    #[serde(default)]
    pub instance_flags: Value<names::GeometryInstanceFlags>,
    /// SPIR-V `RayFlags` of the trace (`OpaqueKHR`, `CullOpaqueKHR`,
    /// `ForceOpacityMicromap2StateEXT`, ...).
    #[serde(default)]
    pub ray_flags: Value<names::RayFlags>,
    /// The geometry's VK_GEOMETRY_OPAQUE_BIT_KHR; absent: as the build's
    /// geometry flags say.
    pub geometry_opaque: Option<bool>,
    /// Whether the trace consumes opacity micromaps (the pipeline or ray
    /// query enables them; default true).
    #[serde(default = "yes")]
    pub micromaps_enabled: bool,
}

/// A hit at barycentrics: u weighs vertex 1, v vertex 2 (rounded to f32, as
/// traversal reports them).
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct HitDesc {
    pub u: f64,
    pub v: f64,
    /// The error the barycentrics may carry; absent: 4 f32 ulps of 1.
    pub delta: Option<f64>,
}

/// A ray as `traceRayEXT` takes it.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct RayGeometryDesc {
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    /// Default 0.
    #[serde(default)]
    pub t_min: f64,
    /// Absent: unbounded.
    pub t_max: Option<f64>,
}

/// The device: enabled extensions and features, and its limits.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct DeviceDesc {
    /// Enabled device extensions; absent: every micromap and ray-tracing
    /// extension ommcheck knows.
    pub extensions: Option<Vec<String>>,
    /// Enabled features by structure; absent: every feature. When present,
    /// features not listed are disabled.
    pub features: Option<FeaturesDesc>,
    /// `spec-minimum` (default), `permissive`, or the path (relative to the
    /// scene) of a JSON file of limits with the spec's member names.
    pub profile: Option<String>,
    /// Limits over the profile's, by the spec's member names.
    pub limits: Option<LimitsDesc>,
    /// Physical devices in the device group (default 1).
    pub physical_device_count: Option<u32>,
    /// Queues the device was created with (default 1).
    pub queue_count: Option<u32>,
}

/// Device limits by the spec's member names (each optional; absent ones
/// keep the profile's value).
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct LimitsDesc {
    /// `VkPhysicalDeviceOpacityMicromapPropertiesEXT/KHR::maxOpacity2StateSubdivisionLevel`
    pub max_opacity2_state_subdivision_level: Option<u32>,
    /// `...::maxOpacity4StateSubdivisionLevel`
    pub max_opacity4_state_subdivision_level: Option<u32>,
    /// `VkPhysicalDeviceOpacityMicromapPropertiesKHR::maxOpacityLossy4StateSubdivisionLevel`
    pub max_opacity_lossy4_state_subdivision_level: Option<u32>,
    /// `VkPhysicalDeviceOpacityMicromapPropertiesKHR::maxMicromapTriangles`
    pub max_micromap_triangles: Option<u64>,
    /// `VkPhysicalDeviceDisplacementMicromapPropertiesNV::maxDisplacementMicromapSubdivisionLevel`
    pub max_displacement_micromap_subdivision_level: Option<u32>,
    /// `VkPhysicalDeviceAccelerationStructurePropertiesKHR::minAccelerationStructureScratchOffsetAlignment`
    pub min_acceleration_structure_scratch_offset_alignment: Option<u32>,
}

/// The memory a buffer is bound to.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum MemoryDesc {
    /// Bound to device-local memory (the default).
    #[default]
    DeviceLocal,
    /// Bound to memory with VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT.
    HostVisible,
    /// Bound to memory allocated with multiple instances (device groups).
    MultiInstance,
    /// Host-visible and multi-instance.
    HostVisibleMultiInstance,
    /// Not bound to any memory.
    Unbound,
}

/// A `VkBuffer`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct BufferDesc {
    pub name: String,
    pub size: u64,
    /// `VkBufferUsageFlags2` bits.
    #[serde(default)]
    pub usage: Value<names::BufferUsageFlags>,
    /// `VkBufferCreateFlags` bits.
    #[serde(default)]
    pub flags: Value<names::BufferCreateFlags>,
    #[serde(default)]
    pub memory: MemoryDesc,
    /// What `vkGetBufferDeviceAddress` returns; absent: assigned (256-byte
    /// aligned, in declaration order, clear of every fixed address).
    pub device_address: Option<u64>,
    /// The buffer's bytes the checker may read; bytes not given are zero.
    /// Absent: the checker does not know the contents.
    pub contents: Option<Contents>,
}

/// A block of host memory that host commands read.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct HostMemoryDesc {
    pub name: String,
    /// Bytes; absent: the end of the last piece of `contents`.
    pub size: Option<u64>,
    /// The host address; absent: assigned.
    pub address: Option<u64>,
    pub contents: Option<Contents>,
}

/// One piece or a list of pieces of contents.
#[derive(Debug, JsonSchema, Serialize)]
#[serde(untagged)]
pub enum Contents {
    One(Piece),
    Many(Vec<Piece>),
}

impl<'de> Deserialize<'de> for Contents {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct ContentsVisitor;
        impl<'de> de::Visitor<'de> for ContentsVisitor {
            type Value = Contents;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a contents piece ({\"at\": N, \"hex\": ...}) or an array of them")
            }
            fn visit_map<A: de::MapAccess<'de>>(self, map: A) -> Result<Contents, A::Error> {
                Piece::deserialize(de::value::MapAccessDeserializer::new(map)).map(Contents::One)
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<Contents, A::Error> {
                Vec::<Piece>::deserialize(de::value::SeqAccessDeserializer::new(seq))
                    .map(Contents::Many)
            }
        }
        deserializer.deserialize_any(ContentsVisitor)
    }
}

impl Contents {
    pub fn pieces(&self) -> &[Piece] {
        match self {
            Contents::One(piece) => std::slice::from_ref(piece),
            Contents::Many(pieces) => pieces,
        }
    }
}

/// Bytes placed at `at` (default 0): exactly one of the forms.
#[derive(Debug, Default, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct Piece {
    #[serde(default)]
    pub at: u64,
    /// Hex digits; spaces, newlines and `_` are ignored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hex: Option<String>,
    /// Standard base64.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base64: Option<String>,
    /// A binary file, relative to the scene's directory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u8: Option<Vec<u8>>,
    /// Little-endian 16-bit values (an index buffer of VK_INDEX_TYPE_UINT16).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u16: Option<Vec<u16>>,
    /// Little-endian 32-bit values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u32: Option<Vec<u32>>,
    /// Little-endian 64-bit values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u64: Option<Vec<u64>>,
    /// `VkMicromapTriangleEXT` entries, 8 bytes each.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangles: Option<Vec<TriangleDesc>>,
}

/// `VkMicromapTriangleEXT`.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct TriangleDesc {
    pub data_offset: u32,
    pub subdivision_level: u16,
    pub format: Value<names::MicromapFormat>,
}

/// What a build the checker did not see left in an object.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct BuiltDesc {
    /// The build's `flags` (raw bits of the build's flag type).
    #[serde(default)]
    pub flags: u32,
    /// The number of micromap triangles (Σ usage counts).
    #[serde(default)]
    pub triangle_count: u64,
}

/// A `VkMicromapEXT` created before the scene's calls.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct MicromapDesc {
    pub name: String,
    pub buffer: String,
    #[serde(default)]
    pub offset: u64,
    pub size: u64,
    #[serde(rename = "type")]
    pub ty: Option<Value<names::MicromapType>>,
    #[serde(default)]
    pub create_flags: Value<names::MicromapCreateFlags>,
    /// Set when the micromap was built by a build the scene does not show.
    pub built: Option<BuiltDesc>,
}

/// A `VkAccelerationStructureKHR` created before the scene's calls: in a
/// buffer (`vkCreateAccelerationStructureKHR`) or at an address range
/// (`vkCreateAccelerationStructure2KHR`).
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AccelerationStructureDesc {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: Value<names::AccelerationStructureType>,
    pub buffer: Option<String>,
    #[serde(default)]
    pub offset: u64,
    /// The start of its address range (created with
    /// vkCreateAccelerationStructure2KHR).
    #[serde(default)]
    pub address: Option<AddressArg>,
    pub size: u64,
    pub built: Option<BuiltDesc>,
}

/// A `VkQueryPool`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct QueryPoolDesc {
    pub name: String,
    pub query_type: Value<names::QueryType>,
    pub query_count: u32,
}

/// A `VkCommandBuffer` and its state at the calls that name it.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct CommandBufferDesc {
    pub name: String,
    /// Between vkBeginCommandBuffer and vkEndCommandBuffer (default true).
    #[serde(default = "yes")]
    pub recording: bool,
    /// Flags of the queue family its pool belongs to (default graphics,
    /// compute and transfer).
    pub queue_flags: Option<Value<names::QueueFlags>>,
    #[serde(default)]
    pub in_render_pass: bool,
    #[serde(default)]
    pub in_video_coding: bool,
    #[serde(default)]
    pub suspended: bool,
}

fn yes() -> bool {
    true
}

/// `pSizeInfo` left out: a VkMicromapBuildSizesInfoEXT with its sType.
fn some_sizes_info() -> Option<SizesInfoDesc> {
    Some(SizesInfoDesc::default())
}

/// A chained structure ommcheck does not read, or (with `structure`) one
/// of the structures it reads, written with another structure's sType.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct OtherStruct {
    pub s_type: Value<names::StructureType>,
    /// The structure the entry is, by its spec name, when `sType` is not
    /// that structure's own (to express a wrong sType): one of
    /// `VkAccelerationStructureTrianglesOpacityMicromapEXT`,
    /// `VkAccelerationStructureTrianglesOpacityMicromapKHR`,
    /// `VkAccelerationStructureTrianglesDisplacementMicromapNV`,
    /// `VkAccelerationStructureGeometryMicromapDataKHR` (with their members),
    /// or a micromap feature or property structure
    /// (`VkPhysicalDeviceOpacityMicromapFeaturesEXT`, ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure: Option<String>,
}

impl Tagged for ChainStruct {
    const TAG: &'static str = "sType";
    const WHAT: &'static str = "a pNext structure";
    type Tag = Value<names::StructureType>;

    fn from_rest<'de, D: Deserializer<'de>>(tag: Self::Tag, rest: D) -> Result<Self, D::Error> {
        ChainStruct::tagged(tag, rest, misnamed)
    }
}

/// A chain entry whose sType is none of the structures ommcheck reads: any
/// other structure (its members are ignored), or, with `"structure"`, one
/// of those structures written with a wrong sType.
fn misnamed<'de, D: Deserializer<'de>>(
    tag: Value<names::StructureType>,
    rest: D,
) -> Result<ChainStruct, D::Error> {
    use serde_json::Value as Json;
    let mut members = serde_json::Map::<String, Json>::deserialize(rest)?;
    let structure = match members.remove("structure") {
        None => None,
        Some(Json::String(name)) => Some(name),
        Some(other) => {
            return Err(de::Error::custom(format!(
                "`structure` is a structure name, not {other}"
            )))
        }
    };
    let given = Some(tag.as_i32());
    let members = Json::Object(members);
    if let Some(name) = structure.as_deref() {
        // The members are already parsed, so errors in them carry no
        // position; the message names the structure.
        if let Some(entry) = ChainStruct::named(name, members.clone(), given) {
            return entry.map_err(|e| de::Error::custom(format!("{name}: {e}")));
        }
    }
    Ok(match structure.as_deref() {
        Some(name) => {
            if crate::model::pipeline::MicromapStruct::ALL
                .iter()
                .all(|s| s.name() != name)
            {
                return Err(de::Error::custom(format!(
                    "unknown structure `{name}`: `structure` names a structure ommcheck reads (the opacity or displacement micromap structures of a triangles geometry, VkAccelerationStructureGeometryMicromapDataKHR, or a micromap feature or property structure)"
                )));
            }
            ChainStruct::Other(OtherStruct {
                s_type: tag,
                structure,
            })
        }
        None => ChainStruct::Other(OtherStruct {
            s_type: tag,
            structure: None,
        }),
    })
}

impl<'de> Deserialize<'de> for ChainStruct {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserialize_tagged(deserializer)
    }
}

/// `VkMicromapUsageEXT` / `VkMicromapUsageKHR`.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct UsageDesc {
    pub count: u32,
    pub subdivision_level: u32,
    pub format: Value<names::MicromapFormat>,
}

/// `VkAllocationCallbacks`: each function pointer as a number (0: NULL).
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AllocationCallbacksDesc {
    #[serde(default = "some_function")]
    pub pfn_allocation: u64,
    #[serde(default = "some_function")]
    pub pfn_reallocation: u64,
    #[serde(default = "some_function")]
    pub pfn_free: u64,
    #[serde(default)]
    pub pfn_internal_allocation: u64,
    #[serde(default)]
    pub pfn_internal_free: u64,
}

fn some_function() -> u64 {
    0x1000
}

/// `VkMicromapBuildSizesInfoEXT` as handed in (its sizes are outputs).
#[derive(Debug, Default, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct SizesInfoDesc {
    pub s_type: Option<Value<names::StructureType>>,
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
}

/// `VkMicromapVersionInfoEXT`.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct MicromapVersionInfoDesc {
    pub s_type: Option<Value<names::StructureType>>,
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
    /// The 2 × VK_UUID_SIZE bytes, as hex; null: NULL.
    #[serde(deserialize_with = "nullable")]
    #[schemars(required)]
    pub p_version_data: Option<String>,
}

/// `VkDeviceAddressRangeKHR`.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AddressRangeDesc {
    #[serde(default)]
    pub address: AddressArg,
    #[serde(default)]
    pub size: u64,
}

/// `VkAccelerationStructureCreateInfo2KHR`.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AccelerationStructureCreateInfo2Desc {
    pub s_type: Option<Value<names::StructureType>>,
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
    #[serde(default)]
    pub create_flags: Value<names::AccelerationStructureCreateFlags>,
    pub address_range: AddressRangeDesc,
    #[serde(default)]
    pub address_flags: Value<names::AddressCommandFlags>,
    #[serde(rename = "type")]
    pub ty: Value<names::AccelerationStructureType>,
}

/// A command buffer parameter: the name of one in `commandBuffers`, an
/// inline description (without `name`), or `null` (VK_NULL_HANDLE).
#[derive(Debug, Default, JsonSchema)]
#[serde(untagged)]
pub enum CommandBufferArg {
    #[default]
    #[serde(skip)]
    Omitted,
    /// VK_NULL_HANDLE.
    Null,
    Name(String),
    Inline(InlineCommandBuffer),
}

impl CommandBufferArg {
    /// Left out of the call (the default command buffer).
    pub fn is_omitted(&self) -> bool {
        matches!(self, CommandBufferArg::Omitted)
    }
}

impl Serialize for CommandBufferArg {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            CommandBufferArg::Omitted | CommandBufferArg::Null => serializer.serialize_none(),
            CommandBufferArg::Name(name) => serializer.serialize_str(name),
            CommandBufferArg::Inline(inline) => inline.serialize(serializer),
        }
    }
}

impl<'de> Deserialize<'de> for CommandBufferArg {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct CommandBufferVisitor;
        impl<'de> de::Visitor<'de> for CommandBufferVisitor {
            type Value = CommandBufferArg;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(
                    "the name of a command buffer in `commandBuffers`, a command buffer object, or null",
                )
            }
            fn visit_unit<E: de::Error>(self) -> Result<CommandBufferArg, E> {
                Ok(CommandBufferArg::Null)
            }
            fn visit_none<E: de::Error>(self) -> Result<CommandBufferArg, E> {
                Ok(CommandBufferArg::Null)
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<CommandBufferArg, E> {
                Ok(CommandBufferArg::Name(v.to_string()))
            }
            fn visit_map<A: de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<CommandBufferArg, A::Error> {
                InlineCommandBuffer::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(CommandBufferArg::Inline)
            }
        }
        deserializer.deserialize_any(CommandBufferVisitor)
    }
}

/// A command buffer described where it is used.
#[derive(Debug, Deserialize, JsonSchema, Serialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct InlineCommandBuffer {
    /// The raw handle the command receives; absent: a valid command buffer
    /// handle. 0 is VK_NULL_HANDLE.
    #[serde(default)]
    pub handle: Option<u64>,
    #[serde(default = "yes")]
    pub recording: bool,
    pub queue_flags: Option<Value<names::QueueFlags>>,
    #[serde(default)]
    pub in_render_pass: bool,
    #[serde(default)]
    pub in_video_coding: bool,
    #[serde(default)]
    pub suspended: bool,
}

macro_rules! params {
    ($(#[$doc:meta])* $name:ident { $($(#[$fdoc:meta])* $field:ident : $ty:ty),* $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Deserialize, JsonSchema)]
        #[serde(deny_unknown_fields, rename_all = "camelCase")]
        pub struct $name {
            $($(#[$fdoc])* pub $field: $ty),*
        }
    };
}

/// A command that runs shaders, by name, with its parameters.
#[derive(Debug, JsonSchema)]
pub struct RunShadersCall {
    #[serde(rename = "call")]
    pub command: WorkCommandName,
    #[serde(flatten)]
    pub params: RunShaders,
}

/// The name of a command that runs shaders.
#[derive(Clone, Copy, Debug)]
pub struct WorkCommandName(pub WorkCommand);

impl JsonSchema for WorkCommandName {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "WorkCommandName".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let names: Vec<&str> = WorkCommand::ALL.iter().map(|c| c.function()).collect();
        schemars::json_schema!({
            "description": "A draw, dispatch, trace-rays, generated-commands or subpass-shading command",
            "enum": names
        })
    }
}

/// The names of the commands that run shaders, which share one form.
pub fn work_call_names() -> impl Iterator<Item = &'static str> {
    WorkCommand::ALL.iter().map(|c| c.function())
}

/// The spelling of `name` that scenes read: `name` itself where it is a
/// call scenes know, else the known call it and that call name the same
/// command through vk.xml's aliases (`vkCmdPipelineBarrier2KHR` is
/// `vkCmdPipelineBarrier2`); `name` where there is none.
fn known_call_name(name: &str) -> &str {
    let known = || {
        CALL_NAMES
            .iter()
            .copied()
            .chain(work_call_names())
            .chain(EXECUTION_CALL_NAMES)
    };
    if known().any(|call| call == name) {
        return name;
    }
    let unaliased = |call: &'static str| ommcheck_vuids::command_alias_target(call).unwrap_or(call);
    let target = ommcheck_vuids::command_alias_target(name);
    known()
        .find(|&call| match target {
            Some(target) => unaliased(call) == target,
            None => ommcheck_vuids::command_alias_target(call) == Some(name),
        })
        .unwrap_or(name)
}

/// How many of the closest calls an unknown call name suggests.
const CALL_SUGGESTIONS: usize = 3;

impl Tagged for Call {
    const TAG: &'static str = "call";
    const WHAT: &'static str = "a call";
    type Tag = String;

    fn from_rest<'de, D: Deserializer<'de>>(name: String, rest: D) -> Result<Self, D::Error> {
        use Deserialize as De;
        let name = known_call_name(&name);
        let rest = match calls::named_call(name, rest) {
            Ok(call) => return call,
            Err(rest) => rest,
        };
        Ok(match name {
            name if EXECUTION_CALL_NAMES.contains(&name) => {
                Call::Execution(execution::execution_call(name, rest)?)
            }
            other => match WorkCommand::ALL.iter().find(|c| c.function() == other) {
                Some(command) => Call::RunShaders(RunShadersCall {
                    command: WorkCommandName(*command),
                    params: De::deserialize(rest)?,
                }),
                None => {
                    let calls = CALL_NAMES
                        .iter()
                        .copied()
                        .chain(work_call_names())
                        .chain(EXECUTION_CALL_NAMES);
                    let hint = crate::suggest::did_you_mean(other, calls, CALL_SUGGESTIONS)
                        .map(|s| format!("; {s}"))
                        .unwrap_or_default();
                    return Err(de::Error::custom(format!(
                        "unknown call `{other}`{hint} (docs/scene-format.md lists the calls ommcheck reads)"
                    )));
                }
            },
        })
    }
}

impl<'de> Deserialize<'de> for Call {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserialize_tagged(deserializer)
    }
}

// The calls xtask/src/commands.rs describes, and the `Call` enum.
mod calls;
pub use calls::*;
// Device, pipeline, shader, synchronization, query and cluster calls.
mod driver;
pub mod generated;
mod pipeline;
pub use driver::*;
pub use generated::*;
pub use pipeline::*;
// Command buffer, submission, wait and query-reset calls.
mod execution;
pub use execution::*;
mod texture;
pub use texture::AlphaTextureDesc;
