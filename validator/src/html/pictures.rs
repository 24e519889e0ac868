//! The pictures of an HTML report: which picture a finding points at, and
//! drawing them within the page's bounds.
//!
//! A finding names what it is about in its location
//! (`calls[1]: pInfos[0].triangleArray[3].dataOffset`) and sometimes in its
//! objects. The location is followed through the scene's JSON, which the
//! location's steps mirror up to the first `pNext<...>`, to the build info
//! it is inside; that info names the micromap or acceleration structure the
//! call builds (`dstMicromap`, `dstAccelerationStructure`). The rest of the
//! location says which part of it: a micromap triangle (`triangleArray[3]`)
//! or a geometry (`pGeometries[0]`). Findings about anything else (a
//! pipeline, a barrier, a query) have no picture.

use std::path::Path;

use base64::Engine as _;
use serde_json::Value;

use crate::draw::{Drawable, Pick, Picture};
use crate::report::location::{index_after, steps, Step};
use crate::report::Finding;
use crate::scene::{CheckOptions, NamedObject, Scene, SceneReport, EXAMPLE, EXAMPLE_PATH};

/// A scene again, for drawing: parsed as the checker reads it, and as plain
/// JSON, which the findings' locations are followed through.
pub struct Source {
    pub scene: Scene,
    pub json: Value,
}

impl Source {
    /// Parses scene text, as [`Scene::parse`] does.
    pub fn parse(text: &str, path: &str, base_dir: &Path) -> Result<Self, String> {
        let scene = Scene::parse(text, path, base_dir).map_err(|e| e.to_string())?;
        let json = serde_json::from_str(text).map_err(|e| format!("{path}: {e}"))?;
        Ok(Self { scene, json })
    }

    /// The scene `report` was checked from, read again from its path (the
    /// built-in example from the binary).
    pub fn reload(report: &SceneReport) -> Result<Self, String> {
        if report.path == EXAMPLE_PATH {
            return Self::parse(EXAMPLE, EXAMPLE_PATH, Path::new("."));
        }
        let path = Path::new(&report.path);
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read it again: {e}", report.path))?;
        let base_dir = path.parent().unwrap_or_else(|| Path::new("."));
        Self::parse(&text, &report.path, base_dir)
    }
}

/// The picture of what `finding` points at in the scene `json` (whose
/// named objects are `objects`), if it points at a micromap or a geometry.
pub fn pick_for(finding: &Finding, objects: &[NamedObject], json: &Value) -> Option<Pick> {
    let mut micromap = None;
    let mut structure = None;
    let mut after = Vec::new();
    if let (Some(call), steps) = steps(&finding.location) {
        // Follow the steps through the JSON for as long as it mirrors them,
        // taking the innermost object each names.
        let mut at = json.get("calls").and_then(|calls| calls.get(call));
        for (i, step) in steps.iter().enumerate() {
            let Some(value) = at else { break };
            let name = |key: &str| value.get(key).and_then(Value::as_str).map(str::to_string);
            if let Some(name) = name("dstMicromap") {
                (micromap, structure, after) = (Some(name), None, steps[i..].to_vec());
            } else if let Some(name) = name("dstAccelerationStructure") {
                (micromap, structure, after) = (None, Some(name), steps[i..].to_vec());
            }
            at = match step {
                Step::Member(m) => value.get(*m),
                Step::Index(i) => usize::try_from(*i).ok().and_then(|i| value.get(i)),
            };
        }
    }
    let triangle = index_after(&after, "triangleArray");
    if let Some(name) = micromap {
        return Some(Pick::Micromap { name, triangle });
    }
    if let Some(name) = structure {
        // A KHR opacity micromap is an acceleration structure built from a
        // micromap-data geometry: its triangles are a micromap's.
        let micromap_data = after
            .iter()
            .any(|s| matches!(s, Step::Member(m) if m.starts_with("pNext<VkAccelerationStructureGeometryMicromapData")));
        if micromap_data {
            return Some(Pick::Micromap { name, triangle });
        }
        let geometry = index_after(&after, "pGeometries").or(index_after(&after, "ppGeometries"));
        if let Some(geometry) = geometry.and_then(|g| u32::try_from(g).ok()) {
            return Some(Pick::Geometry { name, geometry });
        }
        return None;
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

/// How many pictures a page holds and how large each may be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PictureLimits {
    /// The most pictures on one page.
    pub pictures: usize,
    /// The most bytes of one picture as the page holds it (base64).
    pub bytes: usize,
}

impl PictureLimits {
    /// `16 pictures of at most 384 KiB each`, for the page's notes.
    pub fn describe(&self) -> String {
        format!(
            "at most {} of at most {} KiB each",
            crate::report::count(self.pictures, "picture", "pictures"),
            self.bytes.div_ceil(1024)
        )
    }
}

/// What a finding's picture came to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Drawn: picture `number` of the page.
    Shown { number: usize },
    /// Not drawn, and why (the scene builds no such thing, ...).
    NotDrawn(String),
    /// Drawn, but `bytes` large even as PNG, past the limit of one picture.
    TooLarge { bytes: usize },
    /// Not drawn: the page holds as many pictures as it may.
    LeftOut,
}

/// A drawn picture, as the page embeds it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Figure {
    pub number: usize,
    pub title: String,
    /// `image/svg+xml` or `image/png`.
    pub mime: &'static str,
    pub base64: String,
}

impl Figure {
    /// The `data:` URI of the picture.
    pub fn uri(&self) -> String {
        format!("data:{};base64,{}", self.mime, self.base64)
    }
}

/// The picture in at most `limit` bytes of base64: its SVG, or where that
/// is larger, its PNG (a picture of many cells is smaller as pixels).
fn encode(picture: &Picture, limit: usize) -> Result<(&'static str, String), Outcome> {
    let base64 = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);
    let encoded_len = |bytes: usize| bytes.div_ceil(3) * 4;
    if encoded_len(picture.svg.len()) <= limit {
        return Ok(("image/svg+xml", base64(picture.svg.as_bytes())));
    }
    let png = picture
        .png()
        .map_err(|e| Outcome::NotDrawn(e.to_string()))?;
    if encoded_len(png.len()) <= limit {
        Ok(("image/png", base64(&png)))
    } else {
        Err(Outcome::TooLarge {
            bytes: encoded_len(png.len()),
        })
    }
}

/// The pictures of one page: each distinct pick of a scene drawn once, at
/// most [`PictureLimits::pictures`] in all, in the order findings ask.
pub struct Gallery<'a> {
    limits: PictureLimits,
    options: &'a CheckOptions,
    load: &'a dyn Fn(&SceneReport) -> Result<Source, String>,
    /// Pictures drawn and embedded so far.
    pub shown: usize,
    /// Findings whose picture was not drawn because the page was full.
    pub left_out: usize,
    /// Pictures drawn but too large to embed.
    pub too_large: usize,
    scene: Option<SceneState<'a>>,
}

/// What the gallery keeps of the scene whose findings it draws now.
struct SceneState<'a> {
    report: &'a SceneReport,
    source: Option<Result<Source, String>>,
    drawable: Option<Result<Drawable, String>>,
    /// Each pick asked for, and what it came to.
    drawn: Vec<(Pick, Outcome)>,
}

impl<'a> Gallery<'a> {
    /// A gallery that reads each scene with `load` and draws under
    /// `options` (the limits the findings were checked under).
    pub fn new(
        limits: PictureLimits,
        options: &'a CheckOptions,
        load: &'a dyn Fn(&SceneReport) -> Result<Source, String>,
    ) -> Self {
        Self {
            limits,
            options,
            load,
            shown: 0,
            left_out: 0,
            too_large: 0,
            scene: None,
        }
    }

    /// Starts on the findings of `report`; the scene is read again only when
    /// one of them is asked about.
    pub fn begin(&mut self, report: &'a SceneReport) {
        self.scene = Some(SceneState {
            report,
            source: None,
            drawable: None,
            drawn: Vec::new(),
        });
    }

    /// Why the scene [`Self::begin`] named could not be read again for its
    /// pictures, if it was asked about and could not.
    pub fn scene_error(&self) -> Option<&str> {
        match self.scene.as_ref()?.source.as_ref()? {
            Err(e) => Some(e),
            Ok(_) => None,
        }
    }

    /// The picture of what `finding` (of the scene [`Self::begin`] named)
    /// points at: None when it points at nothing drawable; the figure the
    /// first time a picture is shown (to embed), its outcome alone after.
    pub fn picture(&mut self, finding: &Finding) -> Option<(Outcome, Option<Figure>)> {
        let limits = self.limits;
        let scene = self.scene.as_mut()?;
        let report = scene.report;
        let source = scene.source.get_or_insert_with(|| (self.load)(report));
        let pick = match source {
            Ok(source) => pick_for(finding, &report.objects, &source.json)?,
            // Whether the finding had a picture is unknown: say nothing.
            Err(_) => return None,
        };
        if let Some((_, outcome)) = scene.drawn.iter().find(|(p, _)| *p == pick) {
            return Some((outcome.clone(), None));
        }
        if self.shown >= limits.pictures {
            self.left_out += 1;
            return Some((Outcome::LeftOut, None));
        }
        let options = self.options;
        let drawable = scene.drawable.get_or_insert_with(|| match &scene.source {
            Some(Ok(source)) => {
                Drawable::run_with(&source.scene, options).map_err(|e| e.to_string())
            }
            Some(Err(e)) => Err(e.clone()),
            None => Err("the scene was not read".into()),
        });
        let drawn = match drawable {
            Ok(drawable) => drawable
                .draw(&pick)
                .map_err(|e| Outcome::NotDrawn(e.to_string()))
                .and_then(|picture| {
                    encode(&picture, limits.bytes).map(|encoded| (picture.title, encoded))
                }),
            Err(e) => Err(Outcome::NotDrawn(e.clone())),
        };
        let (outcome, figure) = match drawn {
            Ok((title, (mime, base64))) => {
                self.shown += 1;
                let number = self.shown;
                let figure = Figure {
                    number,
                    title,
                    mime,
                    base64,
                };
                (Outcome::Shown { number }, Some(figure))
            }
            Err(outcome) => {
                if matches!(outcome, Outcome::TooLarge { .. }) {
                    self.too_large += 1;
                }
                (outcome, None)
            }
        };
        scene.drawn.push((pick, outcome.clone()));
        Some((outcome, figure))
    }
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
    fn findings_pick_the_triangle_the_geometry_or_the_micromap() {
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
    fn a_picture_too_large_for_svg_is_embedded_as_png_or_left_out() {
        let picture = crate::draw::draw(
            &Scene::example(),
            &Pick::Micromap {
                name: "foliage-omm".into(),
                triangle: None,
            },
        )
        .unwrap();
        let svg_len = picture.svg.len().div_ceil(3) * 4;
        let (mime, data) = encode(&picture, svg_len).unwrap();
        assert_eq!((mime, data.len()), ("image/svg+xml", svg_len));
        let (mime, data) = encode(&picture, svg_len - 1).unwrap();
        assert_eq!(mime, "image/png");
        assert!(data.len() < svg_len, "{} bytes of PNG", data.len());
        match encode(&picture, 100) {
            Err(Outcome::TooLarge { bytes }) => assert_eq!(bytes, data.len()),
            other => panic!("{other:?}"),
        }
    }
}
