//! Findings on pictures: which picture a finding points at, and where on
//! it. `ommcheck draw` and the HTML report's pictures both draw the marks
//! this module finds, so a picture shows the same marks in both.
//!
//! A finding names what it is about in its location
//! (`calls[1]: pInfos[0].triangleArray[3].dataOffset`) and sometimes in its
//! objects. The location is followed through the scene's JSON, which the
//! location's steps mirror up to the first `pNext<...>`, to the build info
//! it is inside; that info names the micromap or acceleration structure the
//! call builds (`dstMicromap`, `dstAccelerationStructure`). The rest of the
//! location says which part of it: a micromap triangle (`triangleArray[3]`),
//! the usage counts (`pUsageCounts`), a geometry (`pGeometries[0]`) and in
//! it a triangle (`indexBuffer[4]`, the opacity index of triangle 4).
//! Findings about anything else (a pipeline, a barrier, a query) have no
//! picture.

use std::path::Path;
use std::sync::Arc;

use serde_json::Value;

use crate::report::location::{index_after, steps, Step};
use crate::report::Finding;
use crate::scene::{NamedObject, Scene, SceneError, SceneReport, EXAMPLE, EXAMPLE_PATH};

use super::Pick;

/// A scene for drawing: parsed as the checker reads it, and as plain JSON,
/// which the findings' locations are followed through (shared with the
/// [`super::Drawable`] run from it: a scene of many thousand triangles
/// written out is megabytes of JSON).
pub struct Source {
    pub scene: Scene,
    pub json: Arc<Value>,
}

impl Source {
    /// Parses scene text, as [`Scene::parse`] does.
    pub fn parse(text: &str, path: &str, base_dir: &Path) -> Result<Self, SceneError> {
        let scene = Scene::parse(text, path, base_dir)?;
        // The text parsed as a scene, so it is JSON.
        let json = Arc::new(serde_json::from_str(text).unwrap_or(Value::Null));
        Ok(Self { scene, json })
    }

    /// Reads and parses the scene file at `path`.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        // Scene::load says why a file cannot be read; its text is read
        // again only once it parsed.
        let scene = Scene::load(path)?;
        let json = std::fs::read_to_string(path)
            .ok()
            .and_then(|text| serde_json::from_str(&text).ok())
            .unwrap_or(Value::Null);
        Ok(Self {
            scene,
            json: Arc::new(json),
        })
    }

    /// The built-in example.
    pub fn example() -> Self {
        Self {
            scene: Scene::example(),
            json: Arc::new(serde_json::from_str(EXAMPLE).unwrap_or(Value::Null)),
        }
    }

    /// The scene `report` was checked from, read again from its path (the
    /// built-in example from the binary).
    pub fn reload(report: &SceneReport) -> Result<Self, String> {
        if report.path == EXAMPLE_PATH {
            return Ok(Self::example());
        }
        let path = Path::new(&report.path);
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read it again: {e}", report.path))?;
        let base_dir = path.parent().unwrap_or_else(|| Path::new("."));
        Self::parse(&text, &report.path, base_dir).map_err(|e| e.to_string())
    }
}

/// The build a finding's location is inside, and the steps from that build
/// info on.
fn build_of<'a>(finding: &'a Finding, json: &Value) -> Option<(Built, Vec<Step<'a>>)> {
    let (Some(call), steps) = steps(&finding.location) else {
        return None;
    };
    let mut found = None;
    // Follow the steps through the JSON for as long as it mirrors them,
    // taking the innermost object each names.
    let mut at = json.get("calls").and_then(|calls| calls.get(call));
    for (i, step) in steps.iter().enumerate() {
        let Some(value) = at else { break };
        let name = |key: &str| value.get(key).and_then(Value::as_str).map(str::to_string);
        if let Some(name) = name("dstMicromap") {
            found = Some((Built::Micromap(name), i));
        } else if let Some(name) = name("dstAccelerationStructure") {
            found = Some((Built::Structure(name), i));
        }
        at = match step {
            Step::Member(m) => value.get(*m),
            Step::Index(i) => usize::try_from(*i).ok().and_then(|i| value.get(i)),
        };
    }
    let (built, from) = found?;
    Some((built, steps[from..].to_vec()))
}

enum Built {
    Micromap(String),
    Structure(String),
}

fn in_usage_counts(steps: &[Step<'_>]) -> bool {
    steps
        .iter()
        .any(|s| matches!(s, Step::Member("pUsageCounts" | "ppUsageCounts")))
}

/// The picture of what `finding` points at in the scene `json` (whose
/// named objects are `objects`), if it points at a micromap, its usage
/// counts or a geometry.
pub fn pick_for(finding: &Finding, objects: &[NamedObject], json: &Value) -> Option<Pick> {
    if let Some((built, after)) = build_of(finding, json) {
        let triangle = index_after(&after, "triangleArray");
        return match built {
            Built::Micromap(name) if in_usage_counts(&after) => Some(Pick::UsageCounts { name }),
            Built::Micromap(name) => Some(Pick::Micromap { name, triangle }),
            Built::Structure(name) => {
                // A KHR opacity micromap is an acceleration structure built
                // from a micromap-data geometry: its triangles are a micromap's.
                let micromap_data = after.iter().any(|s| {
                    matches!(s, Step::Member(m) if m.starts_with("pNext<VkAccelerationStructureGeometryMicromapData"))
                });
                if micromap_data {
                    return Some(Pick::Micromap { name, triangle });
                }
                let geometry =
                    index_after(&after, "pGeometries").or(index_after(&after, "ppGeometries"));
                let geometry = u32::try_from(geometry?).ok()?;
                Some(Pick::Geometry { name, geometry })
            }
        };
    }
    // A finding outside a build may still name a micromap among its objects.
    finding.objects.iter().find_map(|object| {
        objects
            .iter()
            .find(|o| o.kind == object.ty && o.handle == object.handle)
            .filter(|o| o.kind == "VkMicromapEXT")
            .map(|o| Pick::Micromap {
                name: o.name.clone(),
                triangle: None,
            })
    })
}

/// Where on a picture a finding points.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// Micromap triangle `m` (`triangleArray[m]`).
    MicromapTriangle(u64),
    /// Geometry triangle `t` (`indexBuffer[t]`, or the vertex indices
    /// `indexData[3t..3t+3]`).
    GeometryTriangle(u64),
    /// The usage counts of a micromap build.
    UsageCounts,
    /// The whole of what the picture shows.
    Whole,
}

/// A finding as a picture marks it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mark {
    pub target: Target,
    /// `OMMCHECK-...` or the VUID.
    pub rule: String,
    pub location: String,
    pub message: String,
}

impl Mark {
    /// The mark's tooltip: rule, location and message.
    pub fn tooltip(&self) -> String {
        format!("{} at {}: {}", self.rule, self.location, self.message)
    }
}

/// The most marks one picture draws; the caption counts the rest. A scene
/// may have many findings on one picture (one per out-of-range index).
pub const MAX_MARKS: usize = 256;

/// The marks of `findings` on the picture `pick` names: every finding
/// whose own picture is `pick`, or a part of it (a finding about micromap
/// triangle 3 marks triangle 3 on the micromap's grid too).
pub fn marks_for(
    pick: &Pick,
    findings: &[Finding],
    objects: &[NamedObject],
    json: &Value,
) -> Vec<Mark> {
    let mut marks = Vec::new();
    for finding in findings {
        let Some(own) = pick_for(finding, objects, json) else {
            continue;
        };
        let target = match (pick, &own) {
            (
                Pick::Micromap {
                    name,
                    triangle: shown,
                },
                Pick::Micromap {
                    name: n,
                    triangle: at,
                },
            ) if name == n => match (shown, at) {
                (None, Some(m)) => Target::MicromapTriangle(*m),
                (None, None) => Target::Whole,
                (Some(shown), Some(m)) if shown == m => Target::MicromapTriangle(*m),
                _ => continue,
            },
            (Pick::UsageCounts { name }, Pick::UsageCounts { name: n }) if name == n => {
                Target::UsageCounts
            }
            (
                Pick::Geometry { name, geometry },
                Pick::Geometry {
                    name: n,
                    geometry: g,
                },
            ) if name == n && geometry == g => {
                let (_, steps) = steps(&finding.location);
                if let Some(t) = index_after(&steps, "indexBuffer") {
                    Target::GeometryTriangle(t)
                } else if let Some(k) = index_after(&steps, "indexData") {
                    Target::GeometryTriangle(k / 3)
                } else {
                    Target::Whole
                }
            }
            _ => continue,
        };
        marks.push(Mark {
            target,
            rule: finding.rule.to_string(),
            location: finding.location.clone(),
            message: finding.message.clone(),
        });
    }
    marks
}

/// The tooltip of one place's marks: the first few findings there, one a
/// line, then how many more (a scene may have thousands at one place).
pub fn tooltip(marks: &[&Mark]) -> String {
    const LISTED: usize = 8;
    let mut lines: Vec<String> = marks.iter().take(LISTED).map(|m| m.tooltip()).collect();
    if marks.len() > LISTED {
        lines.push(format!("and {} more findings", marks.len() - LISTED));
    }
    lines.join("\n")
}

/// The captions of a picture's marks: the first few findings placed (with
/// `what` they point at), then those about the whole picture, which no
/// outline marks.
pub fn caption(marks: &[&Mark], what: impl Fn(&Mark) -> String) -> Vec<String> {
    const LISTED: usize = 4;
    let list = |marks: Vec<&&Mark>, words: &dyn Fn(&Mark) -> String| {
        let mut listed: Vec<String> = marks.iter().take(LISTED).map(|m| words(m)).collect();
        if marks.len() > LISTED {
            listed.push(format!("and {} more", marks.len() - LISTED));
        }
        listed.join(", ")
    };
    let (whole, placed): (Vec<&&Mark>, Vec<&&Mark>) =
        marks.iter().partition(|m| m.target == Target::Whole);
    let mut captions = Vec::new();
    if !placed.is_empty() {
        captions.push(format!(
            "Findings, marked with a black dashed outline on white where drawn (the SVG's tooltip gives each message): {}.",
            list(placed, &|m| format!("{} ({})", what(m), m.rule))
        ));
    }
    if !whole.is_empty() {
        captions.push(format!(
            "Findings about all of it: {}.",
            list(whole, &|m| format!("{} at {}", m.rule, m.location))
        ));
    }
    captions
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::Severity;
    use crate::rules;

    fn finding(location: &str) -> Finding {
        Finding::new(
            &rules::TRIANGLE_DATA_RANGE,
            Severity::Error,
            "vkCmdBuildMicromapsEXT",
            location,
            "m",
        )
    }

    #[test]
    fn findings_pick_the_triangle_the_usage_counts_the_geometry_or_the_micromap() {
        let json: Value = serde_json::from_str(EXAMPLE).unwrap();
        let pick = |location: &str| pick_for(&finding(location), &[], &json);
        assert_eq!(
            pick("calls[1]: pInfos[0].triangleArray[3].dataOffset"),
            Some(Pick::Micromap {
                name: "foliage-omm".into(),
                triangle: Some(3)
            })
        );
        assert_eq!(
            pick("calls[1]: pInfos[0].pUsageCounts"),
            Some(Pick::UsageCounts {
                name: "foliage-omm".into(),
            })
        );
        assert_eq!(
            pick("calls[1]: pInfos[0].data"),
            Some(Pick::Micromap {
                name: "foliage-omm".into(),
                triangle: None
            })
        );
        assert_eq!(
            pick("calls[3]: pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer[4]"),
            Some(Pick::Geometry {
                name: "foliage-blas".into(),
                geometry: 0
            })
        );
        // The build info itself, a call with no build, nothing at all.
        assert_eq!(pick("calls[3]: pInfos[0].scratchData"), None);
        assert_eq!(pick("calls[0]: pCreateInfo->buffer"), None);
        assert_eq!(pick("device"), None);
    }

    #[test]
    fn a_khr_micromap_build_picks_the_micromap() {
        let json = serde_json::json!({ "calls": [{ "pInfos": [{ "dstAccelerationStructure": "khr-omm" }] }] });
        let location = "calls[0]: pInfos[0].pGeometries[0].pNext<VkAccelerationStructureGeometryMicromapDataKHR>.triangleArray[5].format";
        assert_eq!(
            pick_for(&finding(location), &[], &json),
            Some(Pick::Micromap {
                name: "khr-omm".into(),
                triangle: Some(5)
            })
        );
    }

    #[test]
    fn a_finding_naming_a_micromap_object_picks_its_grid() {
        let objects = [NamedObject {
            name: "omm".into(),
            kind: "VkMicromapEXT",
            handle: 0x33,
        }];
        let named = finding("calls[0]: pMicromaps[0]").with_object("VkMicromapEXT", 0x33);
        assert_eq!(
            pick_for(&named, &objects, &Value::Null),
            Some(Pick::Micromap {
                name: "omm".into(),
                triangle: None
            })
        );
        let unnamed = finding("calls[0]").with_object("VkMicromapEXT", 0x34);
        assert_eq!(pick_for(&unnamed, &objects, &Value::Null), None);
    }

    #[test]
    fn a_tooltip_lists_eight_findings_and_counts_the_rest() {
        let mark = Mark {
            target: Target::GeometryTriangle(4),
            rule: "OMMCHECK-x".into(),
            location: "calls[3]: pInfos[0]".into(),
            message: "m".into(),
        };
        let many = vec![&mark; 20];
        let tip = tooltip(&many);
        assert_eq!(tip.lines().count(), 9);
        assert!(tip.starts_with("OMMCHECK-x at calls[3]: pInfos[0]: m\n"));
        assert!(tip.ends_with("and 12 more findings"), "{tip}");
    }

    #[test]
    fn marks_land_on_the_part_a_finding_points_at() {
        let json: Value = serde_json::from_str(EXAMPLE).unwrap();
        let findings = [
            finding("calls[1]: pInfos[0].triangleArray[3].dataOffset"),
            finding("calls[1]: pInfos[0].triangleArray[1].format"),
            finding("calls[1]: pInfos[0].pUsageCounts"),
            finding("calls[3]: pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer[4]"),
            finding("calls[3]: pInfos[0].pGeometries[0].geometry.triangles.indexData[7]"),
        ];
        let targets = |pick: Pick| -> Vec<Target> {
            marks_for(&pick, &findings, &[], &json)
                .into_iter()
                .map(|m| m.target)
                .collect()
        };
        let micromap = |triangle| Pick::Micromap {
            name: "foliage-omm".into(),
            triangle,
        };
        assert_eq!(
            targets(micromap(None)),
            [Target::MicromapTriangle(3), Target::MicromapTriangle(1)]
        );
        assert_eq!(targets(micromap(Some(3))), [Target::MicromapTriangle(3)]);
        assert_eq!(targets(micromap(Some(0))), []);
        assert_eq!(
            targets(Pick::UsageCounts {
                name: "foliage-omm".into()
            }),
            [Target::UsageCounts]
        );
        assert_eq!(
            targets(Pick::Geometry {
                name: "foliage-blas".into(),
                geometry: 0
            }),
            [Target::GeometryTriangle(4), Target::GeometryTriangle(2)]
        );
        assert_eq!(
            targets(Pick::Geometry {
                name: "foliage-blas".into(),
                geometry: 1
            }),
            []
        );
    }
}
