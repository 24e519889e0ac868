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
pub mod findings;
pub mod histogram;
pub mod pictures;
pub mod states;
pub mod texture;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde_json::Value;

use crate::checks::Validator;
use crate::inspect::simulate::{micromap_content, trace_attachment, vertex_numbers, SimError};
use crate::model::names;
use crate::model::values::FormatKind;
use crate::report::Finding;
use crate::scene::format::AlphaTextureDesc;
use crate::scene::{CheckOptions, NamedObject, RayReport, Scene, SceneError};
use crate::sim::decode::{MicromapContent, WorkCounters};
use crate::sim::opacity::HitOutcome;
use crate::state::{BuildRecord, TriangleGeometryRecord};

pub use canvas::RenderError;
pub use findings::{Mark, Source, Target};

/// What to draw, by scene names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Pick {
    /// A micromap (`VkMicromapEXT`, or a KHR opacity micromap's
    /// acceleration structure): one triangle, or all of them as a grid.
    Micromap { name: String, triangle: Option<u64> },
    /// Geometry `geometry` of a bottom-level acceleration structure (over
    /// its alpha texture where the scene names one).
    Geometry { name: String, geometry: u32 },
    /// A micromap build's usage counts against its triangle array, as a
    /// histogram per (format, subdivision level).
    UsageCounts { name: String },
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

/// A scene after its calls ran: the checker's state, the scene's names,
/// the findings of its calls and what the pictures draw them with.
pub struct Drawable {
    pub validator: Validator,
    pub objects: Vec<NamedObject>,
    /// The findings of the scene's calls.
    pub findings: Vec<Finding>,
    /// Whether pictures mark the findings (`ommcheck draw --no-findings`
    /// turns it off).
    pub marks: bool,
    /// The scene as JSON, which findings' locations are followed through
    /// (Null: a scene not read from text, whose findings cannot be placed).
    json: Arc<Value>,
    textures: Vec<AlphaTextureDesc>,
    base_dir: PathBuf,
}

impl Drawable {
    /// Runs `scene`'s calls at the content tier (which keeps what builds
    /// read). Its pictures mark no findings: only a [`Source`] has the
    /// text their locations are followed through.
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
            findings: report.findings,
            marks: false,
            json: Arc::new(Value::Null),
            textures: scene.file.alpha_textures.clone(),
            base_dir: scene.base_dir.clone(),
        })
    }

    /// [`Self::run_with`] on a scene read from text: its pictures mark the
    /// findings of its calls.
    pub fn run_source(source: &Source, options: &CheckOptions) -> Result<Self, SceneError> {
        let mut drawable = Self::run_with(&source.scene, options)?;
        drawable.json = Arc::clone(&source.json);
        drawable.marks = true;
        Ok(drawable)
    }

    /// The marks of this scene's findings on the picture `pick` names.
    pub fn marks_for(&self, pick: &Pick) -> Vec<Mark> {
        if !self.marks {
            return Vec::new();
        }
        findings::marks_for(pick, &self.findings, &self.objects, &self.json)
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

    /// Each of `alphaTextures` names an acceleration structure of the
    /// scene: a misspelt name would otherwise draw a geometry without its
    /// texture and say nothing.
    fn textures_name_structures(&self) -> Result<(), DrawError> {
        for (i, texture) in self.textures.iter().enumerate() {
            let name = &texture.acceleration_structure;
            self.find(name, |o| o.kind == STRUCTURE, "acceleration structure")
                .map_err(|e| {
                    DrawError::Pick(format!("alphaTextures[{i}].accelerationStructure: {e}"))
                })?;
        }
        Ok(())
    }

    /// The build of the micromap the scene names `name`.
    fn micromap_build(&self, name: &str) -> Result<(&NamedObject, &BuildRecord), DrawError> {
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
        Ok((object, built))
    }

    /// The built content of the micromap the scene names `name`.
    pub fn micromap(&self, name: &str) -> Result<&MicromapContent, DrawError> {
        let (_, built) = self.micromap_build(name)?;
        built.content.as_deref().ok_or_else(|| {
            DrawError::Pick(format!(
                "the checker could not read the triangle array or data of '{name}''s build"
            ))
        })
    }

    /// Draws what `pick` names.
    pub fn draw(&self, pick: &Pick) -> Result<Picture, DrawError> {
        let marks = self.marks_for(pick);
        let canvas = match pick {
            Pick::Micromap { name, triangle } => {
                let content = self.micromap(name)?;
                match triangle {
                    Some(m) => pictures::micromap_triangle(name, content, *m, &marks)
                        .map_err(DrawError::Pick)?,
                    None => pictures::micromap_grid(name, content, &marks),
                }
            }
            Pick::Geometry { name, geometry } => self.geometry(name, *geometry, &marks)?,
            Pick::UsageCounts { name } => self.usage_counts(name, &marks)?,
        };
        Ok(Picture {
            title: canvas_title(pick),
            svg: canvas.svg(),
        })
    }

    /// The histogram of micromap `name`'s usage counts against its array.
    fn usage_counts(&self, name: &str, marks: &[Mark]) -> Result<canvas::Canvas, DrawError> {
        let (object, built) = self.micromap_build(name)?;
        if object.kind != MICROMAP {
            return Err(DrawError::Pick(format!(
                "'{name}' is a KHR opacity micromap: the checker keeps no usage counts of its build to draw"
            )));
        }
        let content = self.micromap(name)?;
        let stated = built.usage_counts.iter().copied().collect();
        let counted = histogram::counted(content);
        let read = content.repeated.unwrap_or(content.triangles.len() as u64);
        Ok(histogram::usage_counts(
            name,
            FormatKind::of_micromap_type(built.ty),
            &stated,
            &counted,
            (read, built.triangle_count),
            marks,
        ))
    }

    fn geometry(
        &self,
        name: &str,
        index: u32,
        marks: &[Mark],
    ) -> Result<canvas::Canvas, DrawError> {
        let object = self.find(name, |o| o.kind == STRUCTURE, "acceleration structure")?;
        self.textures_name_structures()?;
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
        let primitive_count = u64::from(range.primitive_count);
        let names = pictures::GeometryNames {
            structure: name,
            geometry: index,
            micromap,
            index_type: &index_type,
        };
        let Some(desc) = self
            .textures
            .iter()
            .find(|t| t.acceleration_structure == name && t.geometry == index)
        else {
            return Ok(pictures::geometry(
                &names,
                &attachment,
                primitive_count,
                None,
                marks,
            ));
        };
        let grid = texture::load(&self.base_dir.join(&desc.png)).map_err(|e| {
            DrawError::Pick(format!(
                "the alpha texture of '{name}' geometry {index}: {e}"
            ))
        })?;
        let drawn = primitive_count.min(pictures::MAX_GEOMETRY_TRIANGLES);
        let mut missing = None;
        let uvs: Vec<Option<[(f64, f64); 3]>> = (0..drawn)
            .map(
                |t| match texture_coordinates(self, built.host, geometry, &range, desc, t) {
                    Ok(uv) => Some(uv),
                    Err(why) => {
                        missing.get_or_insert_with(|| format!("triangle {t}: {why}"));
                        None
                    }
                },
            )
            .collect();
        let over = pictures::Texture {
            png: &desc.png,
            grid: &grid,
            uvs: &uvs,
            missing,
        };
        Ok(pictures::geometry(
            &names,
            &attachment,
            primitive_count,
            Some(&over),
            marks,
        ))
    }
}

/// The texture coordinates a picture draws: the texture's square and 64
/// repeats of it on every side.
pub const UV_RANGE: std::ops::RangeInclusive<f64> = -64.0..=65.0;

/// The texture coordinates of geometry triangle `t`'s vertices 0, 1, 2:
/// `desc.uvs` at the vertex numbers the build reads.
fn texture_coordinates(
    drawable: &Drawable,
    host: bool,
    geometry: &TriangleGeometryRecord,
    range: &crate::model::accel::BuildRangeInfo,
    desc: &AlphaTextureDesc,
    t: u64,
) -> Result<[(f64, f64); 3], String> {
    let state = drawable.validator.state();
    let numbers = vertex_numbers(
        state,
        host,
        geometry,
        range,
        t,
        &mut WorkCounters::default(),
    )
    .map_err(|e| match e {
        SimError::Unreadable { what, address } => {
            format!("its {what} at {address:#x} is not in memory whose contents the scene gives")
        }
        SimError::IndexType(t) => format!("vertex index type {t} is not NONE, UINT16 or UINT32"),
        other => format!("{other:?}"),
    })?;
    let mut out = [(0.0, 0.0); 3];
    for (n, corner) in numbers.iter().zip(out.iter_mut()) {
        let [u, v] = usize::try_from(*n)
            .ok()
            .and_then(|n| desc.uvs.get(n))
            .copied()
            .ok_or_else(|| {
                format!(
                    "vertex {n} has no texture coordinate (uvs holds {})",
                    desc.uvs.len()
                )
            })?;
        // Far outside the texture a triangle would shrink the texture to
        // nothing (and an infinite extent would make the picture's size
        // not a number).
        if !(UV_RANGE.contains(&u) && UV_RANGE.contains(&v)) {
            return Err(format!(
                "vertex {n}'s texture coordinate [{u:?}, {v:?}] is outside [{}, {}]",
                UV_RANGE.start(),
                UV_RANGE.end()
            ));
        }
        *corner = (u, v);
    }
    Ok(out)
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
        let canvas = pictures::micromap_triangle_marked(&micromap, content, m, Some(&hit), &[])
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
        Pick::UsageCounts { name } => format!("micromap '{name}' usage counts"),
    }
}

/// Runs `scene` and draws what `pick` names, without findings' marks.
pub fn draw(scene: &Scene, pick: &Pick) -> Result<Picture, DrawError> {
    Drawable::run(scene).map_err(DrawError::Scene)?.draw(pick)
}

/// Runs the scene `source` and draws what `pick` names with the marks of
/// its findings, as `ommcheck draw` does.
pub fn draw_source(source: &Source, pick: &Pick) -> Result<Picture, DrawError> {
    Drawable::run_source(source, &CheckOptions::default())
        .map_err(DrawError::Scene)?
        .draw(pick)
}
