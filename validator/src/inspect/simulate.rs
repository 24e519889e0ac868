//! Simulation queries against what the checker saw built: one candidate hit
//! on a triangle of a bottom-level acceleration structure, given as
//! barycentrics or as a ray against the triangle's vertices, decided the way
//! traversal decides it; and the states every referenced micromap triangle
//! of a geometry holds. Only what a query references is read: one index,
//! one micromap triangle's states, three vertices.

use std::collections::{BTreeMap, BTreeSet};

use glam::DVec3;
use serde::Serialize;

use crate::checks::Validator;
use crate::model::accel::index_size;
use crate::model::accel::{
    BuildRangeInfo, BUILD_MICROMAP_LOSSY, INDEX_TYPE_NONE, INDEX_TYPE_UINT16, INDEX_TYPE_UINT32,
};
use crate::model::Handle;
use crate::sim::decode::{LookupError, MicromapContent, WorkCounters};
use crate::sim::index::DEFAULT_DELTA;
use crate::sim::intersect::{intersect, Ray};
use crate::sim::opacity::{
    decide, instance_flags, Candidate, HitOutcome, OpacityState, Slot, SpecialIndex,
};
use crate::sim::trace::{fetch_slot, Attachment, TraceError};
use crate::state::{OpacityAttachmentRecord, State, TriangleGeometryRecord};

/// `VK_FORMAT_R32G32B32_SFLOAT`, the one vertex format the simulator reads.
pub const VERTEX_FORMAT_R32G32B32_SFLOAT: i32 = 106;

/// `VK_GEOMETRY_OPAQUE_BIT_KHR`.
const GEOMETRY_OPAQUE: u32 = 0x1;

/// Where a hit lands on the triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HitInput {
    /// The barycentrics traversal reports (u weighs vertex 1, v vertex 2),
    /// with the error they may carry (None: [`DEFAULT_DELTA`]).
    Barycentrics { u: f32, v: f32, delta: Option<f64> },
    /// A ray, intersected in f64 with the triangle's vertices as the build
    /// read them (R32G32B32_SFLOAT, after `transformData` where it is set).
    Ray(Ray),
}

/// One candidate hit to decide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitQuery {
    /// The bottom-level acceleration structure (its recorded build).
    pub acceleration_structure: Handle,
    /// Index of the geometry in the build.
    pub geometry: u32,
    /// The geometry triangle (0-based, below the build range's primitiveCount).
    pub triangle: u64,
    pub hit: HitInput,
    /// `VkGeometryInstanceFlagsKHR` of the instance.
    pub instance_flags: u32,
    /// SPIR-V `RayFlags` of the trace.
    pub ray_flags: u32,
    /// The geometry's `VK_GEOMETRY_OPAQUE_BIT_KHR` (None: as recorded).
    pub geometry_opaque: Option<bool>,
    /// The trace consumes opacity micromaps (pipeline flag, or ray query
    /// with them enabled).
    pub micromaps_enabled: bool,
}

impl HitQuery {
    /// A query at (u, v) with the default error bound and no flags.
    pub fn at(
        acceleration_structure: Handle,
        geometry: u32,
        triangle: u64,
        u: f32,
        v: f32,
    ) -> Self {
        Self {
            acceleration_structure,
            geometry,
            triangle,
            hit: HitInput::Barycentrics { u, v, delta: None },
            instance_flags: 0,
            ray_flags: 0,
            geometry_opaque: None,
            micromaps_enabled: true,
        }
    }
}

/// Which rule decided where the candidate's opacity came from (instance and
/// ray flags are applied after it, as the specification orders them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Decision {
    /// The ray misses the triangle: there is no candidate.
    Miss,
    /// The geometry has no opacity micromap: its OPAQUE bit.
    GeometryOpaqueBit,
    /// The trace does not consume micromaps: the geometry's OPAQUE bit.
    MicromapsNotEnabled,
    /// `VK_GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT`: the geometry's OPAQUE bit.
    DisabledByInstanceFlag,
    /// A special index stands for the whole triangle.
    SpecialIndex,
    /// The micromap's states at the hit.
    MicromapState,
}

impl Decision {
    pub fn describe(self) -> &'static str {
        match self {
            Self::Miss => "ray misses the triangle",
            Self::GeometryOpaqueBit => "geometry opaque bit (no opacity micromap)",
            Self::MicromapsNotEnabled => {
                "geometry opaque bit (micromaps not enabled for the trace)"
            }
            Self::DisabledByInstanceFlag => "disabled by instance flag",
            Self::SpecialIndex => "special index",
            Self::MicromapState => "micromap state",
        }
    }
}

/// What traversal makes of one candidate hit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HitAnswer {
    /// The possible outcomes (several when the hit is ambiguous or the
    /// micromap lossy; empty on a miss).
    pub outcomes: BTreeSet<HitOutcome>,
    pub decided_by: Decision,
    /// The micromap triangle or special index the triangle's index selects
    /// (None when the micromap was not consulted).
    pub slot: Option<Slot>,
    /// The micro-triangles the hit may lie in (empty unless micromap states were read).
    pub micro_triangles: BTreeSet<u32>,
    /// The states read (a special index's state, or the micro-triangles').
    pub states: BTreeSet<OpacityState>,
    /// The barycentrics used and their error bound.
    pub u: f64,
    pub v: f64,
    pub delta: f64,
    /// The ray's hit distance, for a ray query.
    pub distance: Option<f64>,
    /// The micromap was built lossy: unknown states are possible anywhere.
    pub lossy: bool,
    pub work: WorkCounters,
}

/// Why a query has no answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimError {
    /// NaN or infinite barycentrics, error bound, ray, vertices or transform.
    InvalidInput(&'static str),
    UnknownAccelerationStructure(Handle),
    /// The checker saw no build of the structure.
    NotBuilt(Handle),
    /// The build has `count` geometries.
    GeometryOutOfRange {
        geometry: u32,
        count: usize,
    },
    /// The geometry is not a triangles geometry.
    NotTriangles {
        geometry: u32,
    },
    /// The build range has `primitive_count` triangles.
    TriangleOutOfRange {
        triangle: u64,
        primitive_count: u32,
    },
    /// The build had no build range (an indirect build), which a ray query
    /// needs to find the vertices.
    NoBuildRange {
        geometry: u32,
    },
    /// A vertex format other than R32G32B32_SFLOAT.
    VertexFormat(i32),
    /// A vertex index type other than NONE, UINT16 or UINT32.
    IndexType(i32),
    /// Memory the query needs is not readable (or its address overflows).
    Unreadable {
        what: &'static str,
        address: u64,
    },
    /// A non-special index, but the micromap's content is unknown to the checker.
    MicromapUnknown(Handle),
    Trace(TraceError),
}

impl From<TraceError> for SimError {
    fn from(e: TraceError) -> Self {
        Self::Trace(e)
    }
}

/// For each slot a geometry's triangles use: how many triangles use it and
/// every state its micromap triangle holds.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SlotStates {
    pub triangles: u64,
    pub states: BTreeSet<OpacityState>,
}

/// The states a geometry's triangles can produce, by slot, with the work it took.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GeometryStates {
    pub slots: BTreeMap<Slot, SlotStates>,
    pub work: WorkCounters,
}

impl Validator {
    /// Decides one candidate hit on a triangle of a recorded bottom-level
    /// build: the triangle's opacity index, the micromap states at the hit
    /// (a set when the hit is within its error bound of a micro-edge), and
    /// the specification's decision with the instance and ray flags.
    pub fn simulate_hit(&self, query: &HitQuery) -> Result<HitAnswer, SimError> {
        let state = &self.state;
        let mut work = WorkCounters::default();
        check_finite(&query.hit)?;
        let (host, geometry) = geometry(state, query.acceleration_structure, query.geometry)?;
        let range = geometry.range;
        if let Some(r) = range {
            if query.triangle >= u64::from(r.primitive_count) {
                return Err(SimError::TriangleOutOfRange {
                    triangle: query.triangle,
                    primitive_count: r.primitive_count,
                });
            }
        }
        let (u, v, delta, distance) = match query.hit {
            HitInput::Barycentrics { u, v, delta } => (
                f64::from(u),
                f64::from(v),
                delta.unwrap_or(DEFAULT_DELTA),
                None,
            ),
            HitInput::Ray(ray) => {
                let range = range.ok_or(SimError::NoBuildRange {
                    geometry: query.geometry,
                })?;
                let [v0, v1, v2] =
                    vertices(state, host, geometry, &range, query.triangle, &mut work)?;
                match intersect(&ray, v0, v1, v2)
                    .map_err(|_| SimError::InvalidInput("ray or vertices not finite"))?
                {
                    // The hardware reports f32 barycentrics: add its slack.
                    Some(hit) => (hit.u, hit.v, hit.delta + DEFAULT_DELTA, Some(hit.t)),
                    None => {
                        return Ok(HitAnswer {
                            outcomes: BTreeSet::new(),
                            decided_by: Decision::Miss,
                            slot: None,
                            micro_triangles: BTreeSet::new(),
                            states: BTreeSet::new(),
                            u: f64::NAN,
                            v: f64::NAN,
                            delta: 0.0,
                            distance: None,
                            lossy: false,
                            work,
                        })
                    }
                }
            }
        };
        let geometry_opaque = query
            .geometry_opaque
            .unwrap_or(geometry.flags & GEOMETRY_OPAQUE != 0);
        let mut candidate = Candidate {
            has_micromap: geometry.opacity.is_some(),
            geometry_opaque,
            instance_flags: query.instance_flags,
            ray_flags: query.ray_flags,
            micromaps_enabled: query.micromaps_enabled,
            lossy: false,
        };
        let mut answer = HitAnswer {
            outcomes: BTreeSet::new(),
            decided_by: Decision::GeometryOpaqueBit,
            slot: None,
            micro_triangles: BTreeSet::new(),
            states: BTreeSet::new(),
            u,
            v,
            delta,
            distance,
            lossy: false,
            work,
        };
        let Some(opacity) = geometry.opacity else {
            answer.outcomes = decide(&candidate, &BTreeSet::new(), false);
            return Ok(answer);
        };
        // The micromap is not consulted at all where the trace or the
        // instance turns it off: nothing is read.
        if !query.micromaps_enabled {
            answer.decided_by = Decision::MicromapsNotEnabled;
        } else if query.instance_flags & instance_flags::DISABLE_OPACITY_MICROMAPS != 0 {
            answer.decided_by = Decision::DisabledByInstanceFlag;
        }
        if answer.decided_by != Decision::GeometryOpaqueBit {
            answer.outcomes = decide(&candidate, &BTreeSet::new(), false);
            return Ok(answer);
        }
        let (content, lossy) = micromap_content(state, &opacity);
        candidate.lossy = lossy;
        answer.lossy = lossy;
        let attachment = trace_attachment(state, host, &opacity, content, lossy);
        let slot = fetch_slot(&attachment, query.triangle)?;
        count_index(&mut answer.work, &opacity);
        answer.slot = Some(slot);
        match slot {
            Slot::Special(SpecialIndex::ClusterGeometryDisableOpacityMicromap) => {
                return Err(TraceError::ClusterSkipOutsideCluster { t: query.triangle }.into());
            }
            Slot::Special(special) => {
                answer.decided_by = Decision::SpecialIndex;
                answer.states.extend(special.state());
            }
            Slot::Micromap(_) => {
                let Some(content) = content else {
                    return Err(if opacity.micromap == 0 {
                        TraceError::NoMicromap { t: query.triangle }.into()
                    } else {
                        SimError::MicromapUnknown(opacity.micromap)
                    });
                };
                // Finite and within about [-1, 2] once the ray hit; any
                // finite f32 is fine for the index mapping, which clamps.
                let (u32_, v32) = (to_f32(u)?, to_f32(v)?);
                let (micro, states) = content
                    .states_counted(slot, u32_, v32, delta, &mut answer.work)
                    .map_err(|e| SimError::Trace(TraceError::Lookup(e)))?;
                answer.decided_by = Decision::MicromapState;
                answer.micro_triangles = micro;
                answer.states = states;
            }
        }
        answer.outcomes = decide(&candidate, &answer.states, false);
        Ok(answer)
    }

    /// Every state each micromap triangle a geometry's index buffer
    /// references holds, decoding each referenced triangle once: the cost
    /// follows the triangles referenced, not the size of the micromap.
    pub fn simulate_geometry_states(
        &self,
        acceleration_structure: Handle,
        geometry_index: u32,
    ) -> Result<GeometryStates, SimError> {
        let state = &self.state;
        let (host, geometry) = geometry(state, acceleration_structure, geometry_index)?;
        let range = geometry.range.ok_or(SimError::NoBuildRange {
            geometry: geometry_index,
        })?;
        let mut out = GeometryStates::default();
        let Some(opacity) = geometry.opacity else {
            return Ok(out);
        };
        let (content, lossy) = micromap_content(state, &opacity);
        let attachment = trace_attachment(state, host, &opacity, content, lossy);
        let count = u64::from(range.primitive_count);
        // A stride of 0 gives every triangle the first one's index.
        let (distinct, weight) =
            if opacity.index_type != INDEX_TYPE_NONE && opacity.index_stride == 0 {
                (count.min(1), count)
            } else {
                (count, 1)
            };
        // Each step reads an index inside the readable index buffer or (index
        // type NONE) a triangle of the known content, failing past their
        // ends, so the loop is bounded by memory the checker holds.
        for t in 0..distinct {
            let slot = fetch_slot(&attachment, t)?;
            count_index(&mut out.work, &opacity);
            let entry = match out.slots.entry(slot) {
                std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
                std::collections::btree_map::Entry::Vacant(e) => {
                    let states = match slot {
                        Slot::Special(special) => special.state().into_iter().collect(),
                        Slot::Micromap(m) => {
                            let content = content.ok_or(if opacity.micromap == 0 {
                                SimError::Trace(TraceError::NoMicromap { t })
                            } else {
                                SimError::MicromapUnknown(opacity.micromap)
                            })?;
                            let mut states = content
                                .all_states(m, &mut out.work)
                                .map_err(|e: LookupError| SimError::Trace(TraceError::Lookup(e)))?;
                            if lossy {
                                states.insert(OpacityState::UnknownTransparent);
                                states.insert(OpacityState::UnknownOpaque);
                            }
                            states
                        }
                    };
                    e.insert(SlotStates {
                        triangles: 0,
                        states,
                    })
                }
            };
            entry.triangles = entry.triangles.saturating_add(weight);
        }
        Ok(out)
    }
}

fn check_finite(hit: &HitInput) -> Result<(), SimError> {
    match hit {
        HitInput::Barycentrics { u, v, delta } => {
            if !(u.is_finite() && v.is_finite()) {
                return Err(SimError::InvalidInput("barycentrics not finite"));
            }
            if delta.is_some_and(|d| !d.is_finite() || d < 0.0) {
                return Err(SimError::InvalidInput(
                    "error bound not finite and non-negative",
                ));
            }
        }
        HitInput::Ray(ray) => {
            let finite = ray.origin.is_finite()
                && ray.direction.is_finite()
                && !ray.t_min.is_nan()
                && !ray.t_max.is_nan();
            if !finite {
                return Err(SimError::InvalidInput("ray not finite"));
            }
        }
    }
    Ok(())
}

fn to_f32(x: f64) -> Result<f32, SimError> {
    let y = x as f32;
    if y.is_finite() {
        Ok(y)
    } else {
        Err(SimError::InvalidInput("barycentrics not finite"))
    }
}

/// The recorded triangles geometry `index` of a built structure, and
/// whether the build read host addresses.
fn geometry(
    state: &State,
    handle: Handle,
    index: u32,
) -> Result<(bool, &TriangleGeometryRecord), SimError> {
    let structure = state
        .acceleration_structures
        .get(&handle)
        .ok_or(SimError::UnknownAccelerationStructure(handle))?;
    let built = structure.built.as_ref().ok_or(SimError::NotBuilt(handle))?;
    let count = built.geometries.len();
    let entry = usize::try_from(index)
        .ok()
        .and_then(|i| built.geometries.get(i))
        .ok_or(SimError::GeometryOutOfRange {
            geometry: index,
            count,
        })?;
    let geometry = entry
        .as_ref()
        .ok_or(SimError::NotTriangles { geometry: index })?;
    Ok((built.host, geometry))
}

/// The attachment's micromap content (EXT: a `VkMicromapEXT`'s build; KHR:
/// an OPACITY_MICROMAP acceleration structure's) and whether it was built lossy.
pub(crate) fn micromap_content<'a>(
    state: &'a State,
    opacity: &OpacityAttachmentRecord,
) -> (Option<&'a MicromapContent>, bool) {
    let record = if opacity.khr {
        state
            .acceleration_structures
            .get(&opacity.micromap)
            .and_then(|s| s.built.as_ref())
    } else {
        state
            .micromaps
            .get(&opacity.micromap)
            .and_then(|m| m.built.as_ref())
    };
    let lossy = opacity.khr && record.is_some_and(|r| r.flags & BUILD_MICROMAP_LOSSY != 0);
    (record.and_then(|r| r.content.as_deref()), lossy)
}

pub(crate) fn trace_attachment<'a>(
    state: &'a State,
    host: bool,
    opacity: &OpacityAttachmentRecord,
    content: Option<&'a MicromapContent>,
    lossy: bool,
) -> Attachment<'a> {
    let index_bytes = if opacity.index_type == INDEX_TYPE_NONE {
        None
    } else if host {
        // After the build: only the host memory the application described
        // is still known.
        state.host_memory(&[]).bytes_from(opacity.index_buffer)
    } else {
        state.device_bytes_from(opacity.index_buffer)
    };
    Attachment {
        index_type: opacity.index_type,
        index_bytes,
        index_stride: opacity.index_stride,
        base_triangle: opacity.base_triangle,
        micromap: content,
        lossy,
        cluster: false,
    }
}

/// One opacity index read (none for index type NONE).
fn count_index(work: &mut WorkCounters, opacity: &OpacityAttachmentRecord) {
    if let Some(size) = index_size(opacity.index_type) {
        work.indices_read = work.indices_read.saturating_add(1);
        work.bytes_read = work.bytes_read.saturating_add(size);
    }
}

/// `len` bytes at `address`, host or device.
fn read<'a>(
    state: &'a State,
    host: bool,
    address: u64,
    len: u64,
    what: &'static str,
    work: &mut WorkCounters,
) -> Result<&'a [u8], SimError> {
    let bytes = if host {
        state.host_memory(&[]).read(address, len)
    } else {
        state.read_device(address, len)
    };
    let bytes = bytes.ok_or(SimError::Unreadable { what, address })?;
    work.bytes_read = work.bytes_read.saturating_add(len);
    Ok(bytes)
}

fn f32_at(bytes: &[u8], i: usize) -> f64 {
    let b = bytes.get(4 * i..4 * i + 4).unwrap_or(&[0; 4]);
    f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The vertex numbers of geometry triangle `t` as the build reads them:
/// with indices, `firstVertex` plus the `3t + k`th index from `indexData +
/// primitiveOffset`; without, `firstVertex + 3t + k`. Vertex `n` is at
/// `vertexData + n·stride`, plus `primitiveOffset` without indices.
pub(crate) fn vertex_numbers(
    state: &State,
    host: bool,
    g: &TriangleGeometryRecord,
    range: &BuildRangeInfo,
    t: u64,
    work: &mut WorkCounters,
) -> Result<[u64; 3], SimError> {
    let overflow = |what| SimError::Unreadable {
        what,
        address: u64::MAX,
    };
    let offset = u64::from(range.primitive_offset);
    let first = u64::from(range.first_vertex);
    let mut out = [0u64; 3];
    for (k, number) in (0u64..).zip(out.iter_mut()) {
        let corner = t
            .checked_mul(3)
            .and_then(|c| c.checked_add(k))
            .ok_or(overflow("vertex index"))?;
        let index = match g.index_type {
            INDEX_TYPE_NONE => corner,
            INDEX_TYPE_UINT16 | INDEX_TYPE_UINT32 => {
                let size = if g.index_type == INDEX_TYPE_UINT16 {
                    2
                } else {
                    4
                };
                let at = corner
                    .checked_mul(size)
                    .and_then(|o| o.checked_add(offset))
                    .and_then(|o| o.checked_add(g.index_data))
                    .ok_or(overflow("vertex index"))?;
                let bytes = read(state, host, at, size, "vertex index", work)?;
                work.indices_read = work.indices_read.saturating_add(1);
                bytes
                    .iter()
                    .rev()
                    .fold(0u64, |acc, b| (acc << 8) | u64::from(*b))
            }
            other => return Err(SimError::IndexType(other)),
        };
        *number = first.checked_add(index).ok_or(overflow("vertex"))?;
    }
    Ok(out)
}

/// The three vertices of geometry triangle `t` as the build reads them
/// (at [`vertex_numbers`]), then moved by `transformData + transformOffset`
/// (a row-major 3×4 matrix) where it is set.
fn vertices(
    state: &State,
    host: bool,
    g: &TriangleGeometryRecord,
    range: &BuildRangeInfo,
    t: u64,
    work: &mut WorkCounters,
) -> Result<[DVec3; 3], SimError> {
    if g.vertex_format != VERTEX_FORMAT_R32G32B32_SFLOAT {
        return Err(SimError::VertexFormat(g.vertex_format));
    }
    let overflow = |what| SimError::Unreadable {
        what,
        address: u64::MAX,
    };
    // Without indices the vertices start at primitiveOffset.
    let base = if g.index_type == INDEX_TYPE_NONE {
        g.vertex_data
            .checked_add(u64::from(range.primitive_offset))
            .ok_or(overflow("vertex"))?
    } else {
        g.vertex_data
    };
    let numbers = vertex_numbers(state, host, g, range, t, work)?;
    let mut out = [DVec3::ZERO; 3];
    for (number, vertex) in numbers.iter().zip(out.iter_mut()) {
        let at = number
            .checked_mul(g.vertex_stride)
            .and_then(|o| o.checked_add(base))
            .ok_or(overflow("vertex"))?;
        let bytes = read(state, host, at, 12, "vertex", work)?;
        *vertex = DVec3::new(f32_at(bytes, 0), f32_at(bytes, 1), f32_at(bytes, 2));
    }
    if g.transform_data != 0 {
        let at = g
            .transform_data
            .checked_add(u64::from(range.transform_offset))
            .ok_or(overflow("transform"))?;
        let m = read(state, host, at, 48, "transform", work)?;
        let row =
            |r: usize| DVec3::new(f32_at(m, 4 * r), f32_at(m, 4 * r + 1), f32_at(m, 4 * r + 2));
        let (r0, r1, r2) = (row(0), row(1), row(2));
        let (t0, t1, t2) = (f32_at(m, 3), f32_at(m, 7), f32_at(m, 11));
        for p in &mut out {
            *p = DVec3::new(r0.dot(*p) + t0, r1.dot(*p) + t1, r2.dot(*p) + t2);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::device::{Device, Profile};
    use crate::model::accel::*;
    use crate::model::values::MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
    use crate::model::{
        CommandBuffer, MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts,
    };
    use crate::sim::opacity::ray_flags;
    use crate::state::{AccelerationStructure, Buffer, Micromap};

    const BUFFER: Handle = 1;
    const ADDRESS: u64 = 0x100_0000;
    const SIZE: usize = 0x8_0000;
    const DATA: usize = 0;
    const ARRAY: usize = 0x4_0000;
    const INDICES: usize = 0x6_0000;
    const VERTICES: usize = 0x7_0000;
    const MICROMAP: Handle = 7;
    const BLAS: Handle = 9;
    const KHR_MICROMAP: Handle = 10;

    /// A validator whose one buffer holds `data`, `triangles` (the triangle
    /// array), 32-bit opacity `indices` and non-indexed `vertices`; an EXT
    /// micromap built from the first two and a BLAS of one geometry with
    /// `vertices.len() / 3` triangles attached to it.
    fn world(
        triangles: &[MicromapTriangle],
        data: &[u8],
        indices: &[u32],
        vertices: &[[f32; 3]],
    ) -> Validator {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        let mut bytes = vec![0u8; SIZE];
        bytes[DATA..DATA + data.len()].copy_from_slice(data);
        for (m, t) in triangles.iter().enumerate() {
            bytes[ARRAY + 8 * m..ARRAY + 8 * m + 8].copy_from_slice(&t.to_bytes());
        }
        for (t, i) in indices.iter().enumerate() {
            bytes[INDICES + 4 * t..INDICES + 4 * t + 4].copy_from_slice(&i.to_le_bytes());
        }
        for (k, p) in vertices.iter().enumerate() {
            for (c, x) in p.iter().enumerate() {
                let at = VERTICES + 12 * k + 4 * c;
                bytes[at..at + 4].copy_from_slice(&x.to_le_bytes());
            }
        }
        let state = v.state_mut();
        state.buffers.insert(
            BUFFER,
            Buffer {
                size: SIZE as u64,
                device_address: Some(ADDRESS),
                contents: Some(crate::Bytes::from(bytes)),
                ..Default::default()
            },
        );
        state.micromaps.insert(
            MICROMAP,
            Micromap {
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                ..Default::default()
            },
        );
        for (handle, ty) in [
            (BLAS, ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL),
            (KHR_MICROMAP, ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP),
        ] {
            state.acceleration_structures.insert(
                handle,
                AccelerationStructure {
                    ty,
                    ..Default::default()
                },
            );
        }
        let mut histogram: BTreeMap<(u16, u16), u32> = BTreeMap::new();
        for t in triangles {
            *histogram
                .entry((t.format, t.subdivision_level))
                .or_default() += 1;
        }
        let usages: Vec<MicromapUsage> = histogram
            .iter()
            .map(|((format, level), count)| MicromapUsage {
                count: *count,
                subdivision_level: u32::from(*level),
                format: u32::from(*format),
            })
            .collect();
        let build = MicromapBuildInfo {
            dst_micromap: MICROMAP,
            usage_counts: UsageCounts::array(usages),
            data: ADDRESS + DATA as u64,
            triangle_array: ADDRESS + ARRAY as u64,
            triangle_array_stride: 8,
            ..Default::default()
        };
        let _ = v.cmd_build_micromaps(&CommandBuffer::default(), &[build]);
        let attachment = TrianglesOpacityMicromapExt {
            index_buffer: ADDRESS + INDICES as u64,
            micromap: MICROMAP,
            ..Default::default()
        };
        blas(&mut v, Some(attachment), None, (vertices.len() / 3) as u32);
        v
    }

    /// Builds [`BLAS`] from one non-indexed geometry over the world's vertices.
    fn blas(
        v: &mut Validator,
        ext: Option<TrianglesOpacityMicromapExt>,
        khr: Option<TrianglesOpacityMicromapKhr>,
        primitive_count: u32,
    ) {
        let geometry = Geometry {
            geometry: GeometryData::Triangles(TrianglesData {
                vertex_data: ADDRESS + VERTICES as u64,
                max_vertex: 3 * primitive_count,
                opacity_ext: ext,
                opacity_khr: khr,
                ..Default::default()
            }),
            ..Default::default()
        };
        let info = BuildGeometryInfo {
            dst_acceleration_structure: BLAS,
            ..BuildGeometryInfo::with_geometries(
                ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
                vec![geometry],
            )
        };
        let ranges = [Some(vec![BuildRangeInfo {
            primitive_count,
            ..Default::default()
        }])];
        let _ = v.cmd_build_acceleration_structures(&CommandBuffer::default(), &[info], &ranges);
    }

    fn four_state(data_offset: u32, level: u16) -> MicromapTriangle {
        MicromapTriangle {
            data_offset,
            subdivision_level: level,
            format: 2,
        }
    }

    /// Triangle t: (0,0,0), (1,0,0), (0,1,0) shifted by 2t along x.
    fn unit_triangles(count: usize) -> Vec<[f32; 3]> {
        (0..count)
            .flat_map(|t| {
                let x = 2.0 * t as f32;
                [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
            })
            .collect()
    }

    /// Micromap triangle 0: level 1, states T, O, UT, UO; geometry triangle
    /// 0 uses it, triangle 1 is fully opaque (-2), triangle 2 uses a
    /// triangle the micromap does not have.
    fn small_world() -> Validator {
        world(
            &[four_state(0, 1)],
            &[0b1110_0100],
            &[0, u32::MAX - 1, 5],
            &unit_triangles(3),
        )
    }

    fn down_z(x: f64, y: f64) -> Ray {
        Ray {
            origin: DVec3::new(x, y, 1.0),
            direction: DVec3::new(0.0, 0.0, -1.0),
            t_min: 0.0,
            t_max: 10.0,
        }
    }

    #[test]
    fn builds_keep_the_micromap_content_without_copying_the_data() {
        let v = small_world();
        let record = v.state().micromaps[&MICROMAP].built.clone().unwrap();
        let content = record.content.unwrap();
        assert_eq!(content.triangles, vec![four_state(0, 1)]);
        let buffer = v.state().buffers[&BUFFER].contents.clone().unwrap();
        assert_eq!(content.data.as_ptr(), buffer.as_ptr(), "shared, not copied");
        assert_eq!(content.data_bytes()[0], 0b1110_0100);
        let blas = v.state().acceleration_structures[&BLAS]
            .built
            .clone()
            .unwrap();
        let geometry = blas.geometries[0].clone().unwrap();
        assert_eq!(geometry.range.map(|r| r.primitive_count), Some(3));
        assert_eq!(
            geometry.opacity.map(|o| (o.khr, o.micromap)),
            Some((false, MICROMAP))
        );
    }

    #[test]
    fn barycentric_hits_read_one_index_and_one_block() {
        let v = small_world();
        let a = v.simulate_hit(&HitQuery::at(BLAS, 0, 0, 0.1, 0.1)).unwrap();
        assert_eq!(a.outcomes, BTreeSet::from([HitOutcome::Ignored]));
        assert_eq!(a.decided_by, Decision::MicromapState);
        assert_eq!(a.slot, Some(Slot::Micromap(0)));
        assert_eq!(a.micro_triangles, BTreeSet::from([0]));
        assert_eq!(a.states, BTreeSet::from([OpacityState::Transparent]));
        assert_eq!(
            a.work,
            WorkCounters {
                blocks_decoded: 1,
                bytes_read: 5,
                indices_read: 1
            }
        );
        let uo = v.simulate_hit(&HitQuery::at(BLAS, 0, 0, 0.1, 0.8)).unwrap();
        assert_eq!(uo.outcomes, BTreeSet::from([HitOutcome::NonOpaque]));
        // On the diagonal micro-edge between T and O: both.
        let edge = v
            .simulate_hit(&HitQuery::at(BLAS, 0, 0, 0.25, 0.25))
            .unwrap();
        assert_eq!(
            edge.outcomes,
            BTreeSet::from([HitOutcome::Ignored, HitOutcome::Opaque])
        );
        // The 2-state ray flag turns UO into opaque.
        let forced = HitQuery {
            ray_flags: ray_flags::FORCE_OPACITY_MICROMAP_2_STATE,
            ..HitQuery::at(BLAS, 0, 0, 0.1, 0.8)
        };
        let forced = v.simulate_hit(&forced).unwrap();
        assert_eq!(forced.outcomes, BTreeSet::from([HitOutcome::Opaque]));
    }

    #[test]
    fn special_indices_and_disabled_micromaps_decide_without_reading_states() {
        let v = small_world();
        let special = v.simulate_hit(&HitQuery::at(BLAS, 0, 1, 0.1, 0.1)).unwrap();
        assert_eq!(special.decided_by, Decision::SpecialIndex);
        assert_eq!(special.slot, Some(Slot::Special(SpecialIndex::FullyOpaque)));
        assert_eq!(special.outcomes, BTreeSet::from([HitOutcome::Opaque]));
        assert_eq!(special.work.blocks_decoded, 0);
        let disabled = HitQuery {
            micromaps_enabled: false,
            ..HitQuery::at(BLAS, 0, 0, 0.1, 0.1)
        };
        let disabled = v.simulate_hit(&disabled).unwrap();
        assert_eq!(disabled.decided_by, Decision::MicromapsNotEnabled);
        assert_eq!(disabled.outcomes, BTreeSet::from([HitOutcome::NonOpaque]));
        assert_eq!(disabled.work, WorkCounters::default());
        let by_instance = HitQuery {
            instance_flags: instance_flags::DISABLE_OPACITY_MICROMAPS,
            geometry_opaque: Some(true),
            ..HitQuery::at(BLAS, 0, 0, 0.1, 0.1)
        };
        let by_instance = v.simulate_hit(&by_instance).unwrap();
        assert_eq!(by_instance.decided_by, Decision::DisabledByInstanceFlag);
        assert_eq!(by_instance.outcomes, BTreeSet::from([HitOutcome::Opaque]));
    }

    #[test]
    fn rays_hit_the_vertices_the_build_read() {
        let v = small_world();
        let query = |ray| HitQuery {
            hit: HitInput::Ray(ray),
            ..HitQuery::at(BLAS, 0, 0, 0.0, 0.0)
        };
        let hit = v.simulate_hit(&query(down_z(0.1, 0.1))).unwrap();
        assert_eq!(hit.decided_by, Decision::MicromapState);
        assert_eq!(hit.outcomes, BTreeSet::from([HitOutcome::Ignored]));
        assert_eq!(hit.distance, Some(1.0));
        assert!((hit.u - 0.1).abs() < 1e-7 && (hit.v - 0.1).abs() < 1e-7);
        // Three vertices (36 bytes), one index (4), one byte of states.
        assert_eq!(hit.work.bytes_read, 41);
        let miss = v.simulate_hit(&query(down_z(0.9, 0.9))).unwrap();
        assert_eq!(miss.decided_by, Decision::Miss);
        assert!(miss.outcomes.is_empty());
        // Triangle 1 lies at x in [2, 3]: the ray at x = 2.1 hits it.
        let second = HitQuery {
            triangle: 1,
            ..query(down_z(2.1, 0.1))
        };
        let second = v.simulate_hit(&second).unwrap();
        assert_eq!(second.decided_by, Decision::SpecialIndex);
    }

    #[test]
    fn invalid_input_is_an_error_not_a_guess() {
        let v = small_world();
        for (u, v_) in [(f32::NAN, 0.1), (0.1, f32::INFINITY)] {
            assert_eq!(
                v.simulate_hit(&HitQuery::at(BLAS, 0, 0, u, v_)),
                Err(SimError::InvalidInput("barycentrics not finite"))
            );
        }
        let bad_delta = HitQuery {
            hit: HitInput::Barycentrics {
                u: 0.1,
                v: 0.1,
                delta: Some(f64::NAN),
            },
            ..HitQuery::at(BLAS, 0, 0, 0.0, 0.0)
        };
        assert!(matches!(
            v.simulate_hit(&bad_delta),
            Err(SimError::InvalidInput(_))
        ));
        let bad_ray = HitQuery {
            hit: HitInput::Ray(down_z(f64::NAN, 0.1)),
            ..HitQuery::at(BLAS, 0, 0, 0.0, 0.0)
        };
        assert!(matches!(
            v.simulate_hit(&bad_ray),
            Err(SimError::InvalidInput(_))
        ));
        // A NaN vertex: the intersection refuses it.
        let mut vertices = unit_triangles(1);
        vertices[1][0] = f32::NAN;
        let nan_world = world(&[four_state(0, 1)], &[0], &[0], &vertices);
        let ray = HitQuery {
            hit: HitInput::Ray(down_z(0.1, 0.1)),
            ..HitQuery::at(BLAS, 0, 0, 0.0, 0.0)
        };
        assert!(matches!(
            nan_world.simulate_hit(&ray),
            Err(SimError::InvalidInput(_))
        ));
    }

    #[test]
    fn queries_outside_the_build_are_errors() {
        let v = small_world();
        assert_eq!(
            v.simulate_hit(&HitQuery::at(99, 0, 0, 0.1, 0.1)),
            Err(SimError::UnknownAccelerationStructure(99))
        );
        assert_eq!(
            v.simulate_hit(&HitQuery::at(BLAS, 1, 0, 0.1, 0.1)),
            Err(SimError::GeometryOutOfRange {
                geometry: 1,
                count: 1
            })
        );
        assert_eq!(
            v.simulate_hit(&HitQuery::at(BLAS, 0, 3, 0.1, 0.1)),
            Err(SimError::TriangleOutOfRange {
                triangle: 3,
                primitive_count: 3
            })
        );
        assert_eq!(
            v.simulate_hit(&HitQuery::at(BLAS, 0, 2, 0.1, 0.1)),
            Err(SimError::Trace(TraceError::Lookup(
                LookupError::TriangleOutOfRange { m: 5, count: 1 }
            )))
        );
        assert_eq!(
            v.simulate_hit(&HitQuery::at(BLAS, 0, u64::MAX, 0.1, 0.1)),
            Err(SimError::TriangleOutOfRange {
                triangle: u64::MAX,
                primitive_count: 3
            })
        );
    }

    #[test]
    fn cost_follows_the_referenced_triangles_not_the_micromap_size() {
        // 10,000 level-3 4-state triangles (16 bytes each); the geometry's
        // 100 triangles reference every 100th: 1% of the micromap.
        let micromap: Vec<MicromapTriangle> =
            (0..10_000u32).map(|m| four_state(16 * m, 3)).collect();
        let data: Vec<u8> = (0..160_000u32).map(|i| (i % 251) as u8).collect();
        let indices: Vec<u32> = (0..100u32).map(|t| 100 * t).collect();
        let v = world(&micromap, &data, &indices, &unit_triangles(100));
        let states = v.simulate_geometry_states(BLAS, 0).unwrap();
        assert_eq!(states.slots.len(), 100);
        assert_eq!(states.work.blocks_decoded, 100);
        assert_eq!(states.work.indices_read, 100);
        // At most the 16 bytes of each block, and 4 bytes per index.
        assert!(states.work.bytes_read <= 100 * (16 + 4));
        assert!(states.work.bytes_read >= 100 * (1 + 4));
        let mut per_hit = WorkCounters::default();
        for t in 0..100 {
            per_hit += v
                .simulate_hit(&HitQuery::at(BLAS, 0, t, 0.3, 0.3))
                .unwrap()
                .work;
        }
        assert_eq!(per_hit.blocks_decoded, 100);
        assert_eq!(per_hit.indices_read, 100);
    }

    #[test]
    fn geometry_states_count_repeated_references_once_per_block() {
        // All three triangles use micromap triangle 0 or a special index.
        let v = world(
            &[four_state(0, 1)],
            &[0b1110_0100],
            &[0, 0, u32::MAX],
            &unit_triangles(3),
        );
        let states = v.simulate_geometry_states(BLAS, 0).unwrap();
        assert_eq!(states.work.blocks_decoded, 1);
        assert_eq!(states.slots[&Slot::Micromap(0)].triangles, 2);
        assert_eq!(
            states.slots[&Slot::Micromap(0)].states,
            BTreeSet::from([
                OpacityState::Transparent,
                OpacityState::Opaque,
                OpacityState::UnknownTransparent,
                OpacityState::UnknownOpaque
            ])
        );
        assert_eq!(
            states.slots[&Slot::Special(SpecialIndex::FullyTransparent)].states,
            BTreeSet::from([OpacityState::Transparent])
        );
    }

    #[test]
    fn khr_micromap_builds_keep_content_and_lossy_adds_unknown_states() {
        let mut v = small_world();
        let micromap = Geometry {
            geometry_type: khr_geometry_micromap(),
            geometry: GeometryData::None,
            micromap: Some(GeometryMicromapData {
                usage_counts: UsageCounts::array(vec![MicromapUsage {
                    count: 1,
                    subdivision_level: 1,
                    format: 2,
                }]),
                data: ADDRESS + DATA as u64,
                triangle_array: ADDRESS + ARRAY as u64,
                triangle_array_stride: 8,
                ..Default::default()
            }),
            ..Default::default()
        };
        let info = BuildGeometryInfo {
            dst_acceleration_structure: KHR_MICROMAP,
            flags: BUILD_MICROMAP_LOSSY,
            ..BuildGeometryInfo::with_geometries(
                ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                vec![micromap],
            )
        };
        let ranges = [Some(vec![BuildRangeInfo::default()])];
        let _ = v.cmd_build_acceleration_structures(&CommandBuffer::default(), &[info], &ranges);
        let record = v.state().acceleration_structures[&KHR_MICROMAP]
            .built
            .clone()
            .unwrap();
        let content = record.content.unwrap();
        assert_eq!(content.triangles, vec![four_state(0, 1)]);
        let attachment = TrianglesOpacityMicromapKhr {
            index_buffer: ADDRESS + INDICES as u64,
            micromap: KHR_MICROMAP,
            ..Default::default()
        };
        blas(&mut v, None, Some(attachment), 3);
        let a = v.simulate_hit(&HitQuery::at(BLAS, 0, 0, 0.4, 0.4)).unwrap();
        assert!(a.lossy);
        assert_eq!(a.states, BTreeSet::from([OpacityState::Opaque]));
        assert_eq!(
            a.outcomes,
            BTreeSet::from([HitOutcome::Opaque, HitOutcome::NonOpaque])
        );
    }

    fn khr_geometry_micromap() -> i32 {
        crate::vuids::khr::GEOMETRY_TYPE_MICROMAP_KHR.as_raw()
    }
}
