//! Pictures of what a scene builds (`ommcheck draw`) and the per-micro-
//! triangle dump (`ommcheck stats --states`). This module owns the
//! pictures' layouts, colours and downsampling rule, and finding the
//! micromaps and geometries a picture shows by their scene names; it
//! decodes nothing itself: states come from the simulator
//! ([`crate::sim::opacity::state_at`]), micro-triangle corners from its
//! curve ([`crate::sim::index::MicroTriangle`]), opacity indices from
//! [`crate::sim::trace::fetch_slot`]. It sits above `scene` and `inspect`
//! and below the CLI; nothing in the core imports it.
//!
//! docs/pictures.md describes the pictures.

pub mod canvas;
pub mod cells;
pub mod pictures;
pub mod states;

use std::path::Path;

use crate::checks::Validator;
use crate::inspect::simulate::{micromap_content, trace_attachment};
use crate::model::names;
use crate::scene::{CheckOptions, NamedObject, RayReport, Scene, SceneError};
use crate::sim::decode::MicromapContent;
use crate::sim::opacity::HitOutcome;

pub use canvas::RenderError;

/// What to draw, by scene names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Pick {
    /// A micromap (`VkMicromapEXT`, or a KHR opacity micromap's
    /// acceleration structure): one triangle, or all of them as a grid.
    Micromap { name: String, triangle: Option<u64> },
    /// Geometry `geometry` of a bottom-level acceleration structure.
    Geometry { name: String, geometry: u32 },
}

/// Why nothing was drawn.
#[derive(Debug)]
pub enum DrawError {
    Scene(SceneError),
    /// The pick names nothing drawable; the message says why.
    Pick(String),
    Render(RenderError),
    Write(String),
}

impl std::fmt::Display for DrawError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DrawError::Scene(e) => write!(f, "{e}"),
            DrawError::Pick(m) | DrawError::Write(m) => f.write_str(m),
            DrawError::Render(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for DrawError {}

/// A finished picture.
pub struct Picture {
    pub title: String,
    pub svg: String,
}

impl Picture {
    /// The picture rendered as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        canvas::png(&self.svg)
    }

    /// Writes the picture to `path`: PNG when its extension is `png`, SVG
    /// when it is `svg` (in any case).
    pub fn write(&self, path: &Path) -> Result<(), DrawError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let bytes = match extension.as_deref() {
            Some("png") => self.png().map_err(DrawError::Render)?,
            Some("svg") => self.svg.clone().into_bytes(),
            _ => {
                return Err(DrawError::Write(format!(
                    "{}: give a file ending in .svg or .png",
                    path.display()
                )))
            }
        };
        std::fs::write(path, bytes)
            .map_err(|e| DrawError::Write(format!("{}: cannot write: {e}", path.display())))
    }
}

/// A scene after its calls ran: the checker's state and the scene's names.
pub struct Drawable {
    pub validator: Validator,
    pub objects: Vec<NamedObject>,
}

impl Drawable {
    /// Runs `scene`'s calls at the content tier (which keeps what builds read).
    pub fn run(scene: &Scene) -> Result<Self, SceneError> {
        Self::run_with(scene, &CheckOptions::default())
    }

    /// Runs `scene`'s calls under `options`' limits, at its tier or the
    /// content tier where that is lower (a lower tier keeps no content to
    /// draw), so a picture shows what a check under the same options saw.
    pub fn run_with(scene: &Scene, options: &CheckOptions) -> Result<Self, SceneError> {
        let options = CheckOptions {
            limits: options.limits.clone(),
            tier: options.tier.max(crate::Tier::Content),
        };
        let (report, validator) = scene.check_into_validator(&options)?;
        Ok(Self {
            validator,
            objects: report.objects,
        })
    }

    /// The object named `name` among those `accept` takes; the error
    /// suggests the closest of them.
    fn find(
        &self,
        name: &str,
        accept: impl Fn(&NamedObject) -> bool,
        what: &str,
    ) -> Result<&NamedObject, DrawError> {
        self.objects
            .iter()
            .find(|o| o.name == name && accept(o))
            .ok_or_else(|| {
                let names: Vec<&str> = self
                    .objects
                    .iter()
                    .filter(|o| accept(o))
                    .map(|o| o.name.as_str())
                    .collect();
                let hint = crate::suggest::did_you_mean(name, names.iter().copied(), 3)
                    .map(|s| format!("; {s}"))
                    .unwrap_or_else(|| {
                        if names.is_empty() {
                            format!("; the scene names no {what}")
                        } else {
                            format!("; the scene's: {}", names.join(", "))
                        }
                    });
                DrawError::Pick(format!("no {what} is named `{name}`{hint}"))
            })
    }

    /// The built content of the micromap the scene names `name`.
    pub fn micromap(&self, name: &str) -> Result<&MicromapContent, DrawError> {
        // A KHR opacity micromap is an acceleration structure built from
        // micromap content; a BLAS is not a micromap.
        let state = self.validator.state();
        let khr_micromap = |o: &NamedObject| {
            o.kind == STRUCTURE
                && state
                    .acceleration_structures
                    .get(&o.handle)
                    .and_then(|s| s.built.as_ref())
                    .is_some_and(|b| b.content.is_some())
        };
        let object = self.find(name, |o| o.kind == MICROMAP || khr_micromap(o), "micromap")?;
        let state = self.validator.state();
        let built = if object.kind == MICROMAP {
            state
                .micromaps
                .get(&object.handle)
                .and_then(|m| m.built.as_ref())
        } else {
            state
                .acceleration_structures
                .get(&object.handle)
                .and_then(|s| s.built.as_ref())
        };
        let built = built.ok_or_else(|| {
            DrawError::Pick(format!("'{name}' was not built by the scene's calls"))
        })?;
        built.content.as_deref().ok_or_else(|| {
            DrawError::Pick(format!(
                "the checker could not read the triangle array or data of '{name}''s build"
            ))
        })
    }

    /// Draws what `pick` names.
    pub fn draw(&self, pick: &Pick) -> Result<Picture, DrawError> {
        let canvas = match pick {
            Pick::Micromap { name, triangle } => {
                let content = self.micromap(name)?;
                match triangle {
                    Some(m) => {
                        pictures::micromap_triangle(name, content, *m).map_err(DrawError::Pick)?
                    }
                    None => pictures::micromap_grid(name, content),
                }
            }
            Pick::Geometry { name, geometry } => self.geometry(name, *geometry)?,
        };
        Ok(Picture {
            title: canvas_title(pick),
            svg: canvas.svg(),
        })
    }

    fn geometry(&self, name: &str, index: u32) -> Result<canvas::Canvas, DrawError> {
        let object = self.find(name, |o| o.kind == STRUCTURE, "acceleration structure")?;
        let state = self.validator.state();
        let built = state
            .acceleration_structures
            .get(&object.handle)
            .and_then(|s| s.built.as_ref())
            .ok_or_else(|| {
                DrawError::Pick(format!("'{name}' was not built by the scene's calls"))
            })?;
        let count = built.geometries.len();
        let geometry = built
            .geometries
            .get(index as usize)
            .ok_or_else(|| {
                DrawError::Pick(format!(
                    "'{name}' has {count} geometries; there is no geometry {index}"
                ))
            })?
            .as_ref()
            .ok_or_else(|| {
                DrawError::Pick(format!(
                    "geometry {index} of '{name}' is not a triangles geometry"
                ))
            })?;
        let opacity = geometry.opacity.ok_or_else(|| {
            DrawError::Pick(format!(
                "geometry {index} of '{name}' has no opacity micromap attached"
            ))
        })?;
        let range = geometry.range.ok_or_else(|| {
            DrawError::Pick(format!(
                "geometry {index} of '{name}' was built without a build range (an indirect build): its triangle count is unknown"
            ))
        })?;
        let (content, lossy) = micromap_content(state, &opacity);
        let attachment = trace_attachment(state, built.host, &opacity, content, lossy);
        let kind = if opacity.khr { STRUCTURE } else { MICROMAP };
        let micromap = self
            .objects
            .iter()
            .find(|o| o.kind == kind && o.handle == opacity.micromap)
            .map(|o| o.name.as_str());
        let index_type = names::name_of::<names::IndexType>(i64::from(opacity.index_type))
            .map_or_else(|| opacity.index_type.to_string(), str::to_string);
        Ok(pictures::geometry(
            &pictures::GeometryNames {
                structure: name,
                geometry: index,
                micromap,
                index_type: &index_type,
            },
            &attachment,
            u64::from(range.primitive_count),
        ))
    }
}

impl Drawable {
    /// The micromap triangle a traced ray's hit read, with the hit drawn on
    /// it (`ommcheck trace --draw`); an error says why a ray has none (a
    /// miss, a special index, a geometry without a micromap).
    pub fn ray(&self, ray: &RayReport) -> Result<Picture, DrawError> {
        let label = match &ray.name {
            Some(name) => format!("ray {} '{name}'", ray.ray),
            None => format!("ray {}", ray.ray),
        };
        let why = ray.rule.unwrap_or("it was not simulated");
        let (Some(m), Some(u), Some(v)) = (
            ray.slot.as_ref().and_then(|s| s.micromap_triangle),
            ray.u,
            ray.v,
        ) else {
            return Err(DrawError::Pick(format!(
                "{label} read no micromap triangle ({why})"
            )));
        };
        let name = &ray.acceleration_structure;
        let object = self.find(name, |o| o.kind == STRUCTURE, "acceleration structure")?;
        let state = self.validator.state();
        let opacity = state
            .acceleration_structures
            .get(&object.handle)
            .and_then(|s| s.built.as_ref())
            .and_then(|b| b.geometries.get(ray.geometry as usize))
            .and_then(|g| g.as_ref())
            .and_then(|g| g.opacity)
            .ok_or_else(|| {
                DrawError::Pick(format!(
                    "geometry {} of '{name}' has no opacity micromap the checker built",
                    ray.geometry
                ))
            })?;
        let content = micromap_content(state, &opacity).0.ok_or_else(|| {
            DrawError::Pick(format!(
                "the checker could not read the micromap {label} hit"
            ))
        })?;
        let kind = if opacity.khr { STRUCTURE } else { MICROMAP };
        let micromap = self
            .objects
            .iter()
            .find(|o| o.kind == kind && o.handle == opacity.micromap)
            .map_or_else(|| format!("{:#x}", opacity.micromap), |o| o.name.clone());
        let micro: Vec<u32> = ray.micro_triangles.iter().map(|t| t.index).collect();
        let outcomes: Vec<&str> = ray
            .outcomes
            .iter()
            .map(|o| match o {
                HitOutcome::Ignored => "ignored",
                HitOutcome::Opaque => "opaque",
                HitOutcome::NonOpaque => "non-opaque",
            })
            .collect();
        let hit = pictures::HitMarks {
            ray: &label,
            u,
            v,
            micro_triangles: &micro,
            whole_triangle: ray.whole_triangle,
            outcome: outcomes.join(" or "),
        };
        let canvas = pictures::micromap_triangle_marked(&micromap, content, m, Some(&hit))
            .map_err(DrawError::Pick)?;
        Ok(Picture {
            title: format!("{label} on micromap '{micromap}' triangle {m}"),
            svg: canvas.svg(),
        })
    }
}

const MICROMAP: &str = "VkMicromapEXT";
const STRUCTURE: &str = "VkAccelerationStructureKHR";

fn canvas_title(pick: &Pick) -> String {
    match pick {
        Pick::Micromap {
            name,
            triangle: Some(m),
        } => format!("micromap '{name}' triangle {m}"),
        Pick::Micromap { name, .. } => format!("micromap '{name}'"),
        Pick::Geometry { name, geometry } => format!("'{name}' geometry {geometry}"),
    }
}

/// Runs `scene` and draws what `pick` names.
pub fn draw(scene: &Scene, pick: &Pick) -> Result<Picture, DrawError> {
    Drawable::run(scene).map_err(DrawError::Scene)?.draw(pick)
}
