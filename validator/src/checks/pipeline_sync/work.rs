//! The draw, dispatch, trace-rays, generated-commands and subpass-shading
//! commands: the micromap rules they share (11636-11640) about the
//! acceleration structures their shaders reach, decided from the bound
//! pipeline or shader objects and from what the checker knows of how each
//! acceleration structure was built.

use ommcheck_vuids::vuid;
use ommcheck_vuids::Vuid;

use crate::checks::index_scan::{for_each_chunk, special_and_micromap_indices, IndexMix};
use crate::checks::{Ctx, Validator};
use crate::device::ext;
use crate::model::accel::{BuildGeometryInfo, BuildRangeInfo, GeometryData, TrianglesData};
use crate::model::accel::{INDEX_TYPE_UINT16, INDEX_TYPE_UINT32, INDEX_TYPE_UINT8};
use crate::model::pipeline::*;
use crate::model::CommandBuffer;
use crate::report::not_checked::Cause;
use crate::report::{ObjectRef, Report, RuleId};
use crate::state::{HostMemory, HostRange, State};
use crate::tier::Tier;

const DESERIALIZED: &str = "needs the serialized bytes of the micromaps an acceleration structure was deserialized from and of those it was built with, which are device memory contents the application never hands over";

/// The VUIDs one command has for the shared rules.
struct WorkVuids {
    function: &'static str,
    ray_query_mode: Vuid,
    pipeline_mixed: Vuid,
    shader_mixed: Vuid,
    /// Only the ray-tracing pipeline commands have 11640.
    pipeline_opacity: Option<Vuid>,
}

macro_rules! work_commands {
    (plain: [$($plain:ident),* $(,)?], trace: [$($trace:ident),* $(,)?] $(,)?) => {
        /// A command that runs shaders, named as in the API.
        #[allow(non_camel_case_types)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum WorkCommand {
            $($plain,)*
            $($trace,)*
        }

        impl WorkCommand {
            pub const ALL: &'static [WorkCommand] =
                &[$(WorkCommand::$plain,)* $(WorkCommand::$trace,)*];

            fn vuids(self) -> WorkVuids {
                match self {
                    $(WorkCommand::$plain => WorkVuids {
                        function: stringify!($plain),
                        ray_query_mode: vuid::$plain::micromap_11636,
                        pipeline_mixed: vuid::$plain::micromap_11638,
                        shader_mixed: vuid::$plain::micromap_11639,
                        pipeline_opacity: None,
                    },)*
                    $(WorkCommand::$trace => WorkVuids {
                        function: stringify!($trace),
                        ray_query_mode: vuid::$trace::micromap_11636,
                        pipeline_mixed: vuid::$trace::micromap_11638,
                        shader_mixed: vuid::$trace::micromap_11639,
                        pipeline_opacity: Some(vuid::$trace::micromap_11640),
                    },)*
                }
            }
        }

        pub(super) const ENFORCED: &[Vuid] = &[
            $(vuid::$plain::micromap_11636, vuid::$plain::micromap_11638, vuid::$plain::micromap_11639,)*
            $(vuid::$trace::micromap_11636, vuid::$trace::micromap_11638, vuid::$trace::micromap_11639,
              vuid::$trace::micromap_11640,)*
        ];

        pub(super) const NOT_DECIDABLE: &[(Vuid, &str)] = &[
            $((vuid::$plain::micromap_11637, DESERIALIZED),)*
            $((vuid::$trace::micromap_11637, DESERIALIZED),)*
        ];
    };
}

work_commands! {
    plain: [
        vkCmdDispatch, vkCmdDispatchBase, vkCmdDispatchGraphAMDX, vkCmdDispatchGraphIndirectAMDX,
        vkCmdDispatchGraphIndirectCountAMDX, vkCmdDispatchIndirect, vkCmdDispatchIndirect2KHR,
        vkCmdDispatchTileQCOM, vkCmdDraw, vkCmdDrawClusterHUAWEI, vkCmdDrawClusterIndirectHUAWEI,
        vkCmdDrawIndexed, vkCmdDrawIndexedIndirect, vkCmdDrawIndexedIndirect2KHR,
        vkCmdDrawIndexedIndirectCount, vkCmdDrawIndexedIndirectCount2KHR, vkCmdDrawIndirect,
        vkCmdDrawIndirect2KHR, vkCmdDrawIndirectByteCount2EXT, vkCmdDrawIndirectByteCountEXT,
        vkCmdDrawIndirectCount, vkCmdDrawIndirectCount2KHR, vkCmdDrawMeshTasksEXT,
        vkCmdDrawMeshTasksIndirect2EXT, vkCmdDrawMeshTasksIndirectCount2EXT,
        vkCmdDrawMeshTasksIndirectCountEXT, vkCmdDrawMeshTasksIndirectCountNV,
        vkCmdDrawMeshTasksIndirectEXT, vkCmdDrawMeshTasksIndirectNV, vkCmdDrawMeshTasksNV,
        vkCmdDrawMultiEXT, vkCmdDrawMultiIndexedEXT, vkCmdExecuteGeneratedCommandsEXT,
        vkCmdExecuteGeneratedCommandsNV, vkCmdSubpassShadingHUAWEI, vkCmdTraceRaysNV,
    ],
    trace: [vkCmdTraceRaysIndirect2KHR, vkCmdTraceRaysIndirectKHR, vkCmdTraceRaysKHR],
}

impl WorkCommand {
    /// The command's name, e.g. `vkCmdDrawIndexed`.
    pub fn function(self) -> &'static str {
        self.vuids().function
    }
}

impl Validator {
    /// Any draw, dispatch or trace-rays command (`command` says which) with
    /// what is bound when it is recorded. Its own parameters (counts,
    /// buffers) are not micromap rules and are not taken.
    pub fn cmd_run_shaders(
        &mut self,
        command: WorkCommand,
        command_buffer: &CommandBuffer,
        bound: &BoundWork,
    ) -> Report {
        let _ = command_buffer;
        let vuids = command.vuids();
        let mut ctx = self.ctx(vuids.function);
        // Structures already reported as built unseen, once each.
        let mut unseen: Vec<u64> = Vec::new();
        for access in &bound.accesses {
            let Some(geometry) = ctx
                .state
                .and_then(|state| state.micromap_geometry.get(&access.acceleration_structure))
                .copied()
            else {
                // A structure the checker tracks but whose build it did not
                // see: what it holds is unknown, and the rules say so.
                let tracked = ctx.state.is_some_and(|state| {
                    state
                        .acceleration_structures
                        .contains_key(&access.acceleration_structure)
                });
                if tracked && !unseen.contains(&access.acceleration_structure) {
                    unseen.push(access.acceleration_structure);
                    let mut skipped: Vec<RuleId> = vec![
                        vuids.ray_query_mode.into(),
                        vuids.pipeline_mixed.into(),
                        vuids.shader_mixed.into(),
                    ];
                    skipped.extend(vuids.pipeline_opacity.map(RuleId::from));
                    let handle = access.acceleration_structure;
                    ctx.not_checked(
                        Cause::BuildNotSeen,
                        &skipped,
                        "",
                        Some(ObjectRef {
                            ty: "VkAccelerationStructureKHR",
                            handle,
                        }),
                        format_args!("the build of VkAccelerationStructureKHR {handle:#x}, which the bound shaders access, was not seen, so whether it holds micromap geometry is unknown"),
                    );
                }
                continue;
            };
            ray_query_mode(&mut ctx, &vuids, bound, access, geometry);
            mixed_special_indices(&mut ctx, &vuids, bound, access, geometry);
            if let Some(vuid) = vuids.pipeline_opacity {
                pipeline_opacity(&mut ctx, vuid, bound, access, geometry);
            }
        }
        ctx.finish()
    }

    /// Records what a build the checker saw put in each destination, for the
    /// rules above: which opacity attachments its triangles chain, whether an
    /// index buffer it could read mixes special and micromap indices, and for
    /// instances, what the referenced bottom-level structures hold.
    /// `ranges[i]` are the build ranges of `infos[i]`, where known.
    pub fn record_micromap_geometry(
        &mut self,
        infos: &[BuildGeometryInfo],
        ranges: &[Option<Vec<BuildRangeInfo>>],
    ) {
        self.record_micromap_geometry_after_checks(infos, ranges, &[]);
    }

    /// As [`Self::record_micromap_geometry`], with `index_mixes`, what the
    /// call's checks found in the index buffers they read in full (which
    /// are not read again).
    pub(crate) fn record_micromap_geometry_after_checks(
        &mut self,
        infos: &[BuildGeometryInfo],
        ranges: &[Option<Vec<BuildRangeInfo>>],
        index_mixes: &[IndexMix],
    ) {
        self.record_micromap_geometry_reading(infos, ranges, index_mixes, &[]);
    }

    /// As [`Self::record_micromap_geometry_after_checks`], for a host build
    /// for which an adaptor read `read_for_call` of host memory.
    pub(crate) fn record_micromap_geometry_reading(
        &mut self,
        infos: &[BuildGeometryInfo],
        ranges: &[Option<Vec<BuildRangeInfo>>],
        index_mixes: &[IndexMix],
        read_for_call: &[HostRange],
    ) {
        for (i, info) in infos.iter().enumerate() {
            if info.dst_acceleration_structure == 0 {
                continue; // VK_NULL_HANDLE: nothing to remember it by.
            }
            let info_ranges = ranges.get(i).and_then(Option::as_ref);
            let mut geometry = MicromapGeometry::default();
            for (g, entry) in info.geometries_read() {
                let primitives = info_ranges
                    .and_then(|r| r.get(g))
                    .map_or(0, |r| r.primitive_count);
                let found = match &entry.geometry {
                    GeometryData::Triangles(triangles) => {
                        let host = self.state.host_memory(read_for_call);
                        let read = (&self.state, host, index_mixes);
                        triangles_geometry(read, self.tier, triangles, primitives)
                    }
                    GeometryData::Instances(instances) => instances
                        .instances
                        .iter()
                        .flatten()
                        .filter_map(|instance| {
                            referenced(&self.state, instance.acceleration_structure_reference)
                        })
                        .fold(MicromapGeometry::default(), union),
                    GeometryData::Aabbs(_) | GeometryData::None => MicromapGeometry::default(),
                };
                geometry = union(geometry, found);
            }
            self.state
                .micromap_geometry
                .insert(info.dst_acceleration_structure, geometry);
        }
    }
}

fn union(a: MicromapGeometry, b: MicromapGeometry) -> MicromapGeometry {
    MicromapGeometry {
        opacity_khr: a.opacity_khr || b.opacity_khr,
        opacity_ext: a.opacity_ext || b.opacity_ext,
        mixed_special_indices: a.mixed_special_indices || b.mixed_special_indices,
    }
}

/// The record of the acceleration structure an instance references, by
/// handle (host builds) or by device address.
fn referenced(state: &State, reference: u64) -> Option<MicromapGeometry> {
    if let Some(geometry) = state.micromap_geometry.get(&reference) {
        return Some(*geometry);
    }
    let (handle, _) = state
        .acceleration_structures
        .iter()
        .find(|(_, s)| s.address_range.is_some_and(|(start, _)| start == reference))?;
    state.micromap_geometry.get(handle).copied()
}

/// `tier`: below the content tier the index buffer is not read, so mixed
/// special indices are not known. An index buffer the checks read in full
/// (in `index_mixes`) is not read again.
fn triangles_geometry(
    (state, host, index_mixes): (&State, HostMemory<'_>, &[IndexMix]),
    tier: Tier,
    triangles: &TrianglesData,
    primitives: u32,
) -> MicromapGeometry {
    let mut indices = [
        triangles
            .opacity_ext
            .as_ref()
            .map(|a| (a.index_type, a.index_buffer, a.index_stride)),
        triangles
            .opacity_khr
            .as_ref()
            .map(|a| (a.index_type, a.index_buffer, a.index_stride)),
    ]
    .into_iter()
    .flatten();
    MicromapGeometry {
        opacity_ext: triangles.opacity_ext.is_some(),
        opacity_khr: triangles.opacity_khr.is_some(),
        mixed_special_indices: tier >= Tier::Content
            && indices.any(|(ty, address, stride)| {
                let read = index_mixes.iter().find(|m| {
                    (m.index_type, m.address, m.stride, m.count)
                        == (ty, address, stride, u64::from(primitives))
                });
                let held = match read {
                    Some(mix) => Some(mix.held),
                    None => index_mix_reading((state, host), ty, address, stride, primitives),
                };
                held == Some((true, true))
            }),
    }
}

/// [`index_mix_reading`] of device memory or the host memory the
/// application described (the tests ask of a state alone).
#[cfg(test)]
pub(crate) fn index_mix(
    state: &State,
    index_type: i32,
    address: u64,
    stride: u64,
    count: u32,
) -> Option<(bool, bool)> {
    let host = state.host_memory(&[]);
    index_mix_reading((state, host), index_type, address, stride, count)
}

/// Whether the opacity index buffer holds (special indices, micromap
/// indices), when the checker can read all `count` entries, in device
/// memory or else `host` memory.
fn index_mix_reading(
    (state, host): (&State, HostMemory<'_>),
    index_type: i32,
    address: u64,
    stride: u64,
    count: u32,
) -> Option<(bool, bool)> {
    let size: u64 = match index_type {
        INDEX_TYPE_UINT8 => 1,
        INDEX_TYPE_UINT16 => 2,
        INDEX_TYPE_UINT32 => 4,
        _ => return None, // NONE: no index buffer, no special indices.
    };
    if count == 0 {
        return Some((false, false));
    }
    // With stride 0 every triangle reads the first entry.
    let entries = if stride == 0 { 1 } else { u64::from(count) };
    let span = stride.checked_mul(entries - 1)?.checked_add(size)?;
    let bytes = state
        .read_device(address, span)
        .or_else(|| host.read(address, span))?;
    // One branch-free pass, a chunk of indices at a time (see index_scan):
    // special indices are -1..-4 cast to the index width; -5 (cluster
    // geometry's) is neither.
    let (mut special, mut real) = (false, false);
    for_each_chunk(bytes, size, stride, entries, |_, values| {
        let (s, r) = special_and_micromap_indices(values, size);
        special |= s;
        real |= r;
    });
    Some((special, real))
}

/// Whether the shader that performs `access` declares `OpacityMicromapIdKHR`
/// true, where known. Several libraries may provide a pipeline stage: it is
/// known to lack the mode only when none of them declares it.
fn declares_opacity_micromap_id(
    state: &State,
    bound: &BoundWork,
    access: &AccelerationStructureAccess,
) -> Option<bool> {
    match access.shader {
        AccessingShader::PipelineStage(stage) => {
            let record = state.pipelines.get(&bound.pipeline)?;
            let mut facts = record
                .stages
                .iter()
                .filter(|(s, _)| *s == stage)
                .map(|(_, f)| f.opacity_micromap_id)
                .peekable();
            facts.peek()?;
            facts.try_fold(false, |any, known| Some(any || known?))
        }
        AccessingShader::ShaderObject(shader) => state
            .shader_objects
            .get(&shader)
            .and_then(|s| s.facts.opacity_micromap_id),
    }
}

fn access_objects(access: &AccelerationStructureAccess) -> ObjectRef {
    ObjectRef {
        ty: "VkAccelerationStructureKHR",
        handle: access.acceleration_structure,
    }
}

fn shader_location(bound: &BoundWork, access: &AccelerationStructureAccess) -> String {
    match access.shader {
        AccessingShader::PipelineStage(stage) => {
            format!("VkPipeline {:#x} stage {stage:#x}", bound.pipeline)
        }
        AccessingShader::ShaderObject(shader) => format!("VkShaderEXT {shader:#x}"),
    }
}

/// 11636: with KHR micromaps only, a ray query reaching KHR micromap
/// geometry needs the `OpacityMicromapIdKHR` mode set true.
fn ray_query_mode(
    ctx: &mut Ctx<'_>,
    vuids: &WorkVuids,
    bound: &BoundWork,
    access: &AccelerationStructureAccess,
    geometry: MicromapGeometry,
) {
    if !access.ray_query
        || !geometry.opacity_khr
        || ctx.device.has_extension(ext::EXT_OPACITY_MICROMAP)
    {
        return;
    }
    let declares = ctx
        .state
        .and_then(|state| declares_opacity_micromap_id(state, bound, access));
    if declares == Some(false) {
        ctx.error(
            vuids.ray_query_mode,
            shader_location(bound, access),
            format!("the shader reaches VkAccelerationStructureKHR {:#x}, built with VkAccelerationStructureTrianglesOpacityMicromapKHR, through a ray query, but does not declare OpacityMicromapIdKHR with a true operand (VK_EXT_opacity_micromap is not enabled)", access.acceleration_structure),
        )
        .objects
        .push(access_objects(access));
    }
}

/// 11638 and 11639: geometry mixing special and micromap indices may not be
/// reached by a pipeline or shader object that disallows it.
fn mixed_special_indices(
    ctx: &mut Ctx<'_>,
    vuids: &WorkVuids,
    bound: &BoundWork,
    access: &AccelerationStructureAccess,
    geometry: MicromapGeometry,
) {
    if !geometry.mixed_special_indices {
        return;
    }
    let as_handle = access.acceleration_structure;
    if let Some(record) = ctx
        .state
        .and_then(|state| state.pipelines.get(&bound.pipeline))
    {
        if record.flags & CREATE_DISALLOW_MIXED_SPECIAL_INDEX != 0 {
            ctx.error(
                vuids.pipeline_mixed,
                format!("VkPipeline {:#x}", bound.pipeline),
                format!("the bound pipeline was created with VK_PIPELINE_CREATE_2_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_KHR, but VkAccelerationStructureKHR {as_handle:#x} has an opacity index buffer mixing special indices and micromap indices"),
            )
            .objects
            .push(access_objects(access));
        }
    }
    if let AccessingShader::ShaderObject(shader) = access.shader {
        let flags = ctx
            .state
            .and_then(|state| state.shader_objects.get(&shader))
            .map_or(0, |s| s.flags);
        if flags & SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX != 0 {
            ctx.error(
                vuids.shader_mixed,
                format!("VkShaderEXT {shader:#x}"),
                format!("the shader was created with VK_SHADER_CREATE_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_EXT, but VkAccelerationStructureKHR {as_handle:#x} it reaches has an opacity index buffer mixing special indices and micromap indices"),
            )
            .objects
            .push(access_objects(access));
        }
    }
}

/// 11640: tracing rays into opacity micromap geometry needs a pipeline
/// created with the ray-tracing opacity micromap flag.
fn pipeline_opacity(
    ctx: &mut Ctx<'_>,
    vuid: Vuid,
    bound: &BoundWork,
    access: &AccelerationStructureAccess,
    geometry: MicromapGeometry,
) {
    if access.ray_query || !(geometry.opacity_khr || geometry.opacity_ext) {
        return;
    }
    let Some(record) = ctx
        .state
        .and_then(|state| state.pipelines.get(&bound.pipeline))
    else {
        return;
    };
    if record.flags & CREATE_RAY_TRACING_OPACITY_MICROMAP == 0 {
        ctx.error(
            vuid,
            format!("VkPipeline {:#x}", bound.pipeline),
            format!("the bound pipeline's flags {:#x} lack VK_PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR, but rays are traced into VkAccelerationStructureKHR {:#x}, built with opacity micromap geometry", record.flags, access.acceleration_structure),
        )
        .objects
        .push(access_objects(access));
    }
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::state::Buffer;

    fn state_with(bytes: Vec<u8>) -> State {
        let mut state = State::default();
        state.buffers.insert(
            1,
            Buffer {
                size: bytes.len() as u64,
                device_address: Some(0x1000),
                contents: Some(crate::Bytes::from(bytes)),
                ..Default::default()
            },
        );
        state
    }

    /// A device build at the content tier records what its checks read of
    /// the index buffer (without reading it again), and that is what
    /// reading it again gives.
    #[test]
    fn a_device_build_records_the_mix_its_checks_read() {
        use crate::device::{Device, Profile};
        use crate::model::accel::{
            Geometry, TrianglesOpacityMicromapExt, ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
        };
        let bytes = vec![0xff, 0xff, 0x03, 0x00, 0xfb, 0xff];
        for (primitives, mixed) in [(3u32, true), (2, true), (1, false)] {
            let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
            v.set_tier(Tier::Content);
            *v.state_mut() = state_with(bytes.clone());
            let attachment = TrianglesOpacityMicromapExt {
                index_type: INDEX_TYPE_UINT16,
                index_buffer: 0x1000,
                index_stride: 2,
                ..Default::default()
            };
            let geometry = GeometryData::Triangles(TrianglesData {
                opacity_ext: Some(attachment),
                ..Default::default()
            });
            let geometries = vec![Geometry {
                geometry,
                ..Default::default()
            }];
            let info = BuildGeometryInfo {
                dst_acceleration_structure: 7,
                ..BuildGeometryInfo::with_geometries(
                    ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
                    geometries,
                )
            };
            let range = BuildRangeInfo {
                primitive_count: primitives,
                ..Default::default()
            };
            let mut ctx = v.ctx("vkCmdBuildAccelerationStructuresKHR");
            crate::checks::accel_build::builds(
                &mut ctx,
                crate::model::accel::BuildCommand::Cmd,
                std::slice::from_ref(&info),
                Some(&[Some(vec![range])]),
            );
            let index_mixes = std::mem::take(&mut ctx.index_mixes);
            drop(ctx);
            assert_eq!(index_mixes.len(), 1, "{primitives} triangles");
            let read_again = index_mix(&v.state, INDEX_TYPE_UINT16, 0x1000, 2, primitives);
            assert_eq!(Some(index_mixes[0].held), read_again);
            v.record_micromap_geometry_after_checks(&[info], &[Some(vec![range])], &index_mixes);
            let recorded = v.state.micromap_geometry[&7];
            assert_eq!(
                recorded.mixed_special_indices, mixed,
                "{primitives} triangles"
            );
        }
    }

    #[test]
    fn index_mix_finds_special_and_real_indices() {
        let state = state_with(vec![0xff, 0xff, 0x03, 0x00, 0xfb, 0xff]);
        // u16: 0xffff is special (-1), 3 is real, 0xfffb (-5) is neither.
        assert_eq!(
            index_mix(&state, INDEX_TYPE_UINT16, 0x1000, 2, 3),
            Some((true, true))
        );
        assert_eq!(
            index_mix(&state, INDEX_TYPE_UINT16, 0x1000, 2, 1),
            Some((true, false))
        );
        assert_eq!(
            index_mix(&state, INDEX_TYPE_UINT16, 0x1004, 2, 1),
            Some((false, false))
        );
        // Stride 0 reads one entry however many triangles there are.
        assert_eq!(
            index_mix(&state, INDEX_TYPE_UINT8, 0x1002, 0, u32::MAX),
            Some((false, true))
        );
        // Past the end, or with a stride that overflows: unknown.
        assert_eq!(index_mix(&state, INDEX_TYPE_UINT32, 0x1000, 4, 2), None);
        assert_eq!(
            index_mix(&state, INDEX_TYPE_UINT32, 0x1000, u64::MAX, 3),
            None
        );
    }
}
