//! The pictures of an HTML report: which picture a finding points at
//! ([`crate::draw::findings`], which `ommcheck draw` uses too, so the page's
//! pictures carry the same marks of the findings), and drawing them within
//! the page's bounds.

use base64::Engine as _;

use crate::draw::findings::pick_for;
pub use crate::draw::findings::Source;
use crate::draw::{Drawable, Pick, Picture};
use crate::report::Finding;
use crate::scene::{CheckOptions, SceneReport};

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
            Some(Ok(source)) => Drawable::run_source(source, options).map_err(|e| e.to_string()),
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
    use crate::scene::Scene;

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
