//! `ommcheck trace`: a scene's calls are checked, then each of its `rays`
//! is simulated against what the calls built ([`Validator::simulate_hit`]),
//! and the answers are reported as text or in a stable JSON form
//! (`docs/scene-format.md`, "Tracing rays").

use std::collections::BTreeSet;
use std::fmt::Write as _;

use serde::Serialize;

use super::resolve::{self, NamedObject, ResolvedRay};
use super::{count, CheckOptions, Scene, SceneError, Summary};
use crate::checks::Validator;
use crate::inspect::simulate::{Decision, HitAnswer, HitInput, HitQuery, SimError};
use crate::model::names::{self, Kind};
use crate::model::Handle;
use crate::report::{Finding, Report};
use crate::sim::decode::{LookupError, WorkCounters};
use crate::sim::index::BaryError;
use crate::sim::opacity::{
    instance_flags, ray_flags, state_at, HitOutcome, OpacityState, Slot, SpecialIndex,
};
use crate::sim::trace::TraceError;

/// The result of `ommcheck trace` on one scene: an element of the JSON
/// output's `scenes`, laid out as `ommcheck check`'s ([`super::SceneReport`])
/// with the rays added.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TraceReport {
    pub path: String,
    /// How many calls were checked.
    pub calls: usize,
    /// The scene's named objects and their handles.
    pub objects: Vec<NamedObject>,
    /// The calls' findings, as `ommcheck check` reports them.
    pub findings: Vec<Finding>,
    pub rays: Vec<RayReport>,
    #[serde(skip)]
    pub report: Report,
}

/// Counts over the traced scenes: `ommcheck check`'s summary and the rays.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TraceSummary {
    #[serde(flatten)]
    pub checks: Summary,
    pub rays: usize,
    /// Rays the simulator answered (a miss is an answer).
    pub simulated: usize,
    /// Rays it could not answer (each says why in `error`).
    pub not_simulated: usize,
}

impl TraceSummary {
    pub fn of(reports: &[TraceReport]) -> TraceSummary {
        let mut summary = TraceSummary {
            checks: Summary::over(reports.iter().map(|r| (r.calls, &r.report))),
            ..TraceSummary::default()
        };
        for report in reports {
            summary.rays += report.rays.len();
            summary.simulated += report.rays.iter().filter(|r| r.simulated).count();
        }
        summary.not_simulated = summary.rays - summary.simulated;
        summary
    }

    /// Whether `ommcheck trace` exits 0: the calls had no errors and every
    /// ray was simulated.
    pub fn success(&self) -> bool {
        self.checks.errors == 0 && self.not_simulated == 0
    }

    /// The text form's last line.
    pub fn line(&self) -> String {
        format!(
            "{}: {} simulated, {} not simulated; {}",
            count(self.rays, "ray", "rays"),
            self.simulated,
            self.not_simulated,
            self.checks.line()
        )
    }
}

/// One ray's answer. Every member is always present (`null` or empty when
/// it does not apply), so the form is stable.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct RayReport {
    /// The ray's index in `rays`.
    pub ray: usize,
    pub name: Option<String>,
    pub acceleration_structure: String,
    pub geometry: u32,
    pub triangle: u64,
    /// Whether the simulator answered; when not, `error` says why.
    pub simulated: bool,
    pub error: Option<String>,
    /// The possible outcomes, `Ignored`, `Opaque`, `NonOpaque` (empty on a
    /// miss or when not simulated).
    pub outcomes: Vec<HitOutcome>,
    /// What decided the opacity (`micromap-state`, `special-index`,
    /// `geometry-opaque-bit`, `micromaps-not-enabled`,
    /// `disabled-by-instance-flag`, `miss`).
    pub decided_by: Option<Decision>,
    /// The same in words (`Decision::describe`).
    pub rule: Option<&'static str>,
    /// The micromap triangle or special index the triangle's index selects
    /// (null when the micromap was not consulted).
    pub slot: Option<SlotReport>,
    /// The micro-triangles the hit may lie in, each with its state.
    pub micro_triangles: Vec<MicroTriangleReport>,
    /// Every state read (a special index's, or the micro-triangles').
    pub states: Vec<OpacityState>,
    /// More than one micro-triangle lies within the hit's error bound.
    pub ambiguous: bool,
    /// The error bound spans the whole micromap triangle: every state of
    /// it is possible (`microTriangles` is then empty).
    pub whole_triangle: bool,
    /// The barycentrics used and their error bound (null on a miss).
    pub u: Option<f64>,
    pub v: Option<f64>,
    pub delta: Option<f64>,
    /// The hit distance of a ray.
    pub distance: Option<f64>,
    /// The micromap was built lossy: unknown states are possible anywhere.
    pub lossy: bool,
    /// Flags given that the simulator does not model (facing culling,
    /// skipping triangles or AABBs, unknown bits); the answer ignores them.
    pub not_modelled: Vec<String>,
    pub work: WorkReport,
}

/// Where the triangle's opacity comes from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SlotReport {
    /// `micromap` or `special`.
    pub kind: &'static str,
    /// The micromap triangle (index read plus baseTriangle).
    pub micromap_triangle: Option<u64>,
    /// Its format's spec name, where the checker knows the micromap's contents.
    pub format: Option<String>,
    pub subdivision_level: Option<u16>,
    /// The special index (-1 to -5) and its spec name.
    pub special_index: Option<i64>,
    pub special_name: Option<&'static str>,
}

/// A micro-triangle the hit may lie in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct MicroTriangleReport {
    pub index: u32,
    /// Null where the state could not be read back.
    pub state: Option<OpacityState>,
}

/// The simulator's work for one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct WorkReport {
    pub blocks_decoded: u64,
    pub bytes_read: u64,
    pub indices_read: u64,
}

impl From<WorkCounters> for WorkReport {
    fn from(w: WorkCounters) -> Self {
        Self {
            blocks_decoded: w.blocks_decoded,
            bytes_read: w.bytes_read,
            indices_read: w.indices_read,
        }
    }
}

impl Scene {
    /// Checks the scene's calls, then simulates each of its rays against
    /// what the calls built. A semantic error returns before anything runs.
    pub fn trace(&self, options: &CheckOptions) -> Result<TraceReport, SceneError> {
        let run = self.run(options)?;
        let objects = &run.checked.objects;
        let rays: Vec<RayReport> = run
            .rays
            .iter()
            .enumerate()
            .map(|(i, ray)| ray_report(&run.validator, objects, i, ray))
            .collect();
        let report = run.checked.report;
        Ok(TraceReport {
            path: self.path.clone(),
            calls: run.checked.calls,
            objects: run.checked.objects,
            findings: report.findings.clone(),
            rays,
            report,
        })
    }
}

impl TraceReport {
    /// The counts over this one scene.
    pub fn summary(&self) -> TraceSummary {
        TraceSummary::of(std::slice::from_ref(self))
    }

    /// The text form: the calls' findings as `ommcheck check` prints them,
    /// then one block per ray (the summary line is the caller's, after the
    /// last scene).
    pub fn text(&self) -> String {
        let rays = count(self.rays.len(), "ray", "rays");
        let mut out = super::header(&self.path, self.calls, rays);
        if self.findings.is_empty() {
            out.push_str("no findings\n\n");
        } else {
            let named = self
                .report
                .text_naming(&|object| resolve::scene_name(&self.objects, object));
            let _ = write!(out, "\n{named}");
        }
        for ray in &self.rays {
            ray.write_text(&mut out);
        }
        out
    }
}

/// [`count`] of a 64-bit counter.
fn count64(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// `x` as the shortest decimal that reads back to it: an f32 value (the
/// barycentrics traversal reports) as f32, anything else as f64.
fn short(x: f64) -> String {
    let single = x as f32;
    if f64::from(single) == x {
        single.to_string()
    } else {
        x.to_string()
    }
}

fn join<T>(items: impl IntoIterator<Item = T>, f: impl Fn(T) -> String) -> String {
    items.into_iter().map(f).collect::<Vec<_>>().join(", ")
}

impl RayReport {
    fn write_text(&self, out: &mut String) {
        let label = self
            .name
            .as_ref()
            .map(|n| format!(" \"{n}\""))
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "rays[{}]{label}: {} geometry {} triangle {}",
            self.ray, self.acceleration_structure, self.geometry, self.triangle
        );
        if let Some(error) = &self.error {
            let _ = writeln!(out, "  not simulated:   {error}\n");
            return;
        }
        if let (Some(u), Some(v), Some(delta)) = (self.u, self.v, self.delta) {
            let at = match self.distance {
                Some(t) => format!("ray hit at t = {t}, "),
                None => String::new(),
            };
            let _ = writeln!(
                out,
                "  hit:             {at}(u, v) = ({}, {}) ± {delta:e}",
                short(u),
                short(v)
            );
        }
        let outcomes = if self.outcomes.is_empty() {
            "none".to_string()
        } else {
            join(&self.outcomes, |o| format!("{o:?}"))
        };
        let _ = writeln!(out, "  outcomes:        {outcomes}");
        if let Some(rule) = self.rule {
            let _ = writeln!(out, "  decided by:      {rule}");
        }
        if let Some(slot) = &self.slot {
            let text = match (slot.micromap_triangle, slot.special_index) {
                (Some(m), _) => {
                    let detail = match (&slot.format, slot.subdivision_level) {
                        (Some(f), Some(l)) => format!(" ({f}, level {l})"),
                        _ => String::new(),
                    };
                    format!("micromap triangle {m}{detail}")
                }
                (None, Some(i)) => {
                    format!("special index {i} ({})", slot.special_name.unwrap_or("?"))
                }
                (None, None) => "?".to_string(),
            };
            let _ = writeln!(out, "  slot:            {text}");
        }
        if self.whole_triangle {
            let _ = writeln!(
                out,
                "  micro-triangles: any (the error bound spans the whole triangle)"
            );
        } else if !self.micro_triangles.is_empty() {
            let micro = join(&self.micro_triangles, |m| match m.state {
                Some(s) => format!("{} {s:?}", m.index),
                None => m.index.to_string(),
            });
            let _ = writeln!(out, "  micro-triangles: {micro}");
        }
        if !self.states.is_empty() {
            let _ = writeln!(
                out,
                "  states:          {}",
                join(&self.states, |s| format!("{s:?}"))
            );
        }
        if self.decided_by == Some(Decision::MicromapState) {
            let ambiguous = if self.ambiguous || self.whole_triangle {
                "yes"
            } else {
                "no"
            };
            let _ = writeln!(out, "  ambiguous:       {ambiguous}");
        }
        if self.lossy {
            let _ = writeln!(out, "  lossy micromap:  unknown states possible anywhere");
        }
        if !self.not_modelled.is_empty() {
            let _ = writeln!(
                out,
                "  not modelled:    {} (ignored)",
                self.not_modelled.join(", ")
            );
        }
        let w = &self.work;
        let _ = writeln!(
            out,
            "  work:            {} decoded, {} read, {} read\n",
            count64(w.blocks_decoded, "block", "blocks"),
            count64(w.bytes_read, "byte", "bytes"),
            count64(w.indices_read, "index", "indices")
        );
    }
}

/// Simulates one resolved ray.
fn ray_report(
    validator: &Validator,
    objects: &[NamedObject],
    i: usize,
    ray: &ResolvedRay,
) -> RayReport {
    let query = &ray.query;
    let mut report = RayReport {
        ray: i,
        name: ray.name.clone(),
        acceleration_structure: ray.acceleration_structure.clone(),
        geometry: query.geometry,
        triangle: query.triangle,
        simulated: false,
        error: None,
        outcomes: Vec::new(),
        decided_by: None,
        rule: None,
        slot: None,
        micro_triangles: Vec::new(),
        states: Vec::new(),
        ambiguous: false,
        whole_triangle: false,
        u: None,
        v: None,
        delta: None,
        distance: None,
        lossy: false,
        not_modelled: not_modelled(query),
        work: WorkReport::default(),
    };
    let answer = match validator.simulate_hit(query) {
        Ok(answer) => answer,
        Err(error) => {
            report.error = Some(describe_sim_error(&error, query, objects));
            return report;
        }
    };
    fill(&mut report, validator, query, &answer);
    report
}

fn fill(report: &mut RayReport, validator: &Validator, query: &HitQuery, answer: &HitAnswer) {
    report.simulated = true;
    report.outcomes = answer.outcomes.iter().copied().collect();
    report.decided_by = Some(answer.decided_by);
    report.rule = Some(answer.decided_by.describe());
    report.states = answer.states.iter().copied().collect();
    report.lossy = answer.lossy;
    report.work = answer.work.into();
    if answer.decided_by != Decision::Miss {
        report.u = Some(answer.u);
        report.v = Some(answer.v);
        report.delta = Some(answer.delta);
        report.distance = answer.distance;
    }
    report.slot = answer.slot.map(|slot| match slot {
        Slot::Micromap(m) => {
            let header = micromap_triangle(validator, query, m);
            SlotReport {
                kind: "micromap",
                micromap_triangle: Some(m),
                format: header.map(|(format, _)| {
                    names::name_of::<names::MicromapFormat>(i64::from(format))
                        .map_or_else(|| format.to_string(), str::to_string)
                }),
                subdivision_level: header.map(|(_, level)| level),
                special_index: None,
                special_name: None,
            }
        }
        Slot::Special(special) => SlotReport {
            kind: "special",
            micromap_triangle: None,
            format: None,
            subdivision_level: None,
            special_index: Some(special.value()),
            special_name: Some(special_name(special)),
        },
    });
    if answer.decided_by == Decision::MicromapState {
        report.ambiguous = answer.micro_triangles.len() > 1;
        report.whole_triangle = answer.micro_triangles.is_empty();
        if let Some(Slot::Micromap(m)) = answer.slot {
            report.micro_triangles = micro_states(validator, query, m, &answer.micro_triangles);
        }
    }
}

/// The bytes of micromap triangle `m` of the micromap the query's geometry
/// references, with its format and level (None where the checker does not
/// know them). Reads what `simulate_hit` read, for the report only.
fn micromap_block<'a>(
    validator: &'a Validator,
    query: &HitQuery,
    m: u64,
) -> Option<(u16, u16, &'a [u8])> {
    let state = &validator.state;
    let built = state
        .acceleration_structures
        .get(&query.acceleration_structure)?
        .built
        .as_ref()?;
    let geometry = built
        .geometries
        .get(usize::try_from(query.geometry).ok()?)?
        .as_ref()?;
    let opacity = geometry.opacity?;
    let record = if opacity.khr {
        state
            .acceleration_structures
            .get(&opacity.micromap)?
            .built
            .as_ref()?
    } else {
        state.micromaps.get(&opacity.micromap)?.built.as_ref()?
    };
    let content = record.content.as_deref()?;
    let (triangle, bytes) = content.triangle_data(m).ok()?;
    Some((triangle.format, triangle.subdivision_level, bytes))
}

fn micromap_triangle(validator: &Validator, query: &HitQuery, m: u64) -> Option<(u16, u16)> {
    micromap_block(validator, query, m).map(|(format, level, _)| (format, level))
}

/// Each micro-triangle of the answer with the state it holds.
fn micro_states(
    validator: &Validator,
    query: &HitQuery,
    m: u64,
    micro: &BTreeSet<u32>,
) -> Vec<MicroTriangleReport> {
    let block = micromap_block(validator, query, m);
    micro
        .iter()
        .map(|&index| MicroTriangleReport {
            index,
            state: block.and_then(|(format, _, bytes)| state_at(bytes, u32::from(format), index)),
        })
        .collect()
}

fn special_name(special: SpecialIndex) -> &'static str {
    match special {
        SpecialIndex::FullyTransparent => "VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_TRANSPARENT_EXT",
        SpecialIndex::FullyOpaque => "VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_OPAQUE_EXT",
        SpecialIndex::FullyUnknownTransparent => {
            "VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_UNKNOWN_TRANSPARENT_EXT"
        }
        SpecialIndex::FullyUnknownOpaque => {
            "VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_UNKNOWN_OPAQUE_EXT"
        }
        SpecialIndex::ClusterGeometryDisableOpacityMicromap => {
            "VK_OPACITY_MICROMAP_SPECIAL_INDEX_CLUSTER_GEOMETRY_DISABLE_OPACITY_MICROMAP_NV"
        }
    }
}

/// The flags of a query that the simulator does not apply.
fn not_modelled(query: &HitQuery) -> Vec<String> {
    // Ray flags that decide nothing about a candidate's opacity
    // (TerminateOnFirstHit, SkipClosestHitShader) are not listed.
    let ray_read = ray_flags::OPAQUE
        | ray_flags::NO_OPAQUE
        | ray_flags::CULL_OPAQUE
        | ray_flags::CULL_NO_OPAQUE
        | ray_flags::FORCE_OPACITY_MICROMAP_2_STATE
        | 0x4
        | 0x8;
    let instance_read = instance_flags::FORCE_OPAQUE
        | instance_flags::FORCE_NO_OPAQUE
        | instance_flags::FORCE_OPACITY_MICROMAP_2_STATE
        | instance_flags::DISABLE_OPACITY_MICROMAPS;
    let mut out = bit_names::<names::RayFlags>(query.ray_flags & !ray_read, "rayFlags");
    out.extend(bit_names::<names::GeometryInstanceFlags>(
        query.instance_flags & !instance_read,
        "instanceFlags",
    ));
    out
}

/// The name of each set bit (the first name of its value), or the member
/// and the bit as hex (`rayFlags 0x800`).
fn bit_names<K: Kind>(bits: u32, member: &str) -> Vec<String> {
    (0..32)
        .map(|b| 1u32 << b)
        .filter(|bit| bits & bit != 0)
        .map(|bit| {
            names::name_of::<K>(i64::from(bit))
                .map_or_else(|| format!("{member} {bit:#x}"), str::to_string)
        })
        .collect()
}

fn object_name(objects: &[NamedObject], handle: Handle) -> String {
    objects
        .iter()
        .find(|o| o.handle == handle)
        .map_or_else(|| format!("{handle:#x}"), |o| format!("`{}`", o.name))
}

/// Why a ray could not be simulated, in words.
pub fn describe_sim_error(error: &SimError, query: &HitQuery, objects: &[NamedObject]) -> String {
    match *error {
        SimError::InvalidInput(what) => format!("invalid input: {what}"),
        SimError::UnknownAccelerationStructure(h) => format!(
            "acceleration structure {} does not exist at the end of the calls (destroyed, or never created)",
            object_name(objects, h)
        ),
        SimError::NotBuilt(h) => format!(
            "acceleration structure {} has no build the checker saw: build it with a call before tracing",
            object_name(objects, h)
        ),
        SimError::GeometryOutOfRange { geometry, count } => {
            format!("geometry {geometry} is past the build's {count} geometries")
        }
        SimError::NotTriangles { geometry } => {
            format!("geometry {geometry} is not a triangles geometry")
        }
        SimError::TriangleOutOfRange {
            triangle,
            primitive_count,
        } => format!(
            "triangle {triangle} is not below the build range's primitiveCount {primitive_count}"
        ),
        SimError::NoBuildRange { geometry } => format!(
            "geometry {geometry} was built without build ranges (an indirect build): a ray cannot find its vertices"
        ),
        SimError::VertexFormat(format) => format!(
            "vertex format {}: the simulator reads VK_FORMAT_R32G32B32_SFLOAT vertices only",
            names::name_of::<names::Format>(i64::from(format))
                .map_or_else(|| format.to_string(), str::to_string)
        ),
        SimError::IndexType(t) => {
            format!("vertex index type {t} is not NONE, UINT16 or UINT32")
        }
        SimError::Unreadable { what, address } => format!(
            "the {what} at {address:#x} is not in memory whose contents the scene gives"
        ),
        SimError::MicromapUnknown(h) => format!(
            "the contents of micromap {} are unknown to the checker (its build's data or triangle array had no contents)",
            object_name(objects, h)
        ),
        SimError::Trace(e) => describe_trace_error(e, query),
    }
}

fn describe_trace_error(error: TraceError, query: &HitQuery) -> String {
    match error {
        TraceError::IndexType(t) => format!(
            "the opacity attachment's index type {t} is not UINT8, UINT16, UINT32 or NONE"
        ),
        TraceError::IndexOutOfRange { t } => format!(
            "triangle {t}'s opacity index lies past the index buffer's known contents"
        ),
        TraceError::IndexUnreadable => {
            "the opacity index buffer's contents are unknown (give the buffer contents)".into()
        }
        TraceError::ClusterSkipOutsideCluster { t } => format!(
            "triangle {t}'s opacity index is -5 (cluster geometry only) outside cluster geometry"
        ),
        TraceError::NoMicromap { t } => format!(
            "triangle {t}'s opacity index names a micromap triangle, but the attachment's micromap is VK_NULL_HANDLE"
        ),
        TraceError::Lookup(e) => match e {
            LookupError::TriangleOutOfRange { m, count } => {
                format!("micromap triangle {m} is past the micromap's {count} triangles")
            }
            LookupError::Format { m, format } => {
                format!("micromap triangle {m} has format {format}, not an opacity format")
            }
            LookupError::DataOutOfRange { m } => {
                format!("micromap triangle {m}'s states lie outside the data the build read")
            }
            LookupError::Barycentrics(BaryError::NotANumber) => {
                let what = match query.hit {
                    HitInput::Barycentrics { .. } => "the barycentrics",
                    HitInput::Ray(_) => "the ray's barycentrics",
                };
                format!("{what} are not numbers")
            }
            LookupError::Barycentrics(BaryError::Level) => {
                "the micromap triangle's subdivision level is above 12".into()
            }
            LookupError::Barycentrics(BaryError::TooUncertain) => {
                "the hit's error bound spans the whole triangle".into()
            }
        },
    }
}
