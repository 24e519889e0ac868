//! The picture as SVG text, and its PNG rendering: filled polygons in the
//! state colours, the hatching of unknown states and of data past the end,
//! outlines, and text. Text is drawn as squares from font8x8's 8×8
//! bitmaps, not as SVG `<text>`: a PNG then needs no font, and looks the
//! same on every machine, which the reference pictures of the tests rely on.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::sim::opacity::OpacityState;

use super::cells::CellState;

/// A colour as `#rrggbb`.
pub type Colour = &'static str;

/// How a state is filled: its colour, and whether it is hatched (the
/// unknown states, drawn in the colour of the state they resolve to under
/// the 2-state override, with stripes).
pub struct Fill {
    pub colour: Colour,
    /// The id of the hatching pattern, if hatched.
    pub hatch: Option<&'static str>,
    /// A colour text over the fill reads in.
    pub ink: Colour,
    pub name: &'static str,
}

pub const TRANSPARENT: Colour = "#eef2f6";
pub const OPAQUE: Colour = "#2b5d9e";
pub const STRIPE: Colour = "#f08c00";
pub const PROBLEM: Colour = "#d62828";
pub const MISSING: Colour = "#c8c8c8";
pub const EDGE: Colour = "#5a5a5a";
pub const TEXT: Colour = "#202020";
/// A finding's mark: dashed, on white.
pub const MARK: Colour = "#111111";

/// An alpha texture's greys, by alpha in sixteenths: transparent white to
/// opaque dark grey, so that a texture's opaque parts look as dark as the
/// opaque state's blue.
pub const TEXTURE_GREYS: [Colour; 16] = [
    "#ffffff", "#f1f1f1", "#e3e3e3", "#d5d5d5", "#c7c7c7", "#b9b9b9", "#ababab", "#9d9d9d",
    "#8f8f8f", "#818181", "#737373", "#656565", "#575757", "#494949", "#3b3b3b", "#2d2d2d",
];

/// How each cell state is filled.
pub fn fill(state: CellState) -> Fill {
    match state {
        CellState::State(OpacityState::Transparent) => Fill {
            colour: TRANSPARENT,
            hatch: None,
            ink: TEXT,
            name: "transparent",
        },
        CellState::State(OpacityState::Opaque) => Fill {
            colour: OPAQUE,
            hatch: None,
            ink: "#ffffff",
            name: "opaque",
        },
        CellState::State(OpacityState::UnknownTransparent) => Fill {
            colour: TRANSPARENT,
            hatch: Some("hatch-ut"),
            ink: TEXT,
            name: "unknown-transparent",
        },
        CellState::State(OpacityState::UnknownOpaque) => Fill {
            colour: OPAQUE,
            hatch: Some("hatch-uo"),
            ink: "#ffffff",
            name: "unknown-opaque",
        },
        CellState::PastEnd => Fill {
            colour: MISSING,
            hatch: Some("hatch-past"),
            ink: TEXT,
            name: "past the data",
        },
    }
}

/// An SVG picture being drawn, in pixels, in three layers: the tiles (the
/// cells' fills, which never overlap, batched into one path per fill so
/// that a picture of 10^5 cells stays small and shows no seams between
/// cells of one state), their edges (one path per stroke), and everything
/// else in the order drawn.
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    /// Rectangles under the tiles (an alpha texture), one path per colour.
    backdrop: BTreeMap<Colour, String>,
    /// The tiles' fill opacity: below 1 where a backdrop shows through.
    tile_opacity: f64,
    tiles: BTreeMap<(Colour, Option<&'static str>), String>,
    edges: BTreeMap<(Colour, String), String>,
    body: String,
    /// What the picture shows, in words: the SVG's `<title>` and `<desc>`.
    title: String,
    desc: Vec<String>,
}

/// Coordinates to one decimal: a tenth of a pixel is finer than any
/// renderer shows, and keeps a picture of 10^5 polygons small.
fn num(x: f64) -> String {
    let r = (x * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{}", r as i64)
    } else {
        format!("{r:.1}")
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

impl Canvas {
    pub fn new(width: u32, height: u32, title: &str) -> Self {
        Self {
            width,
            height,
            backdrop: BTreeMap::new(),
            tile_opacity: 1.0,
            tiles: BTreeMap::new(),
            edges: BTreeMap::new(),
            body: String::new(),
            title: title.to_string(),
            desc: Vec::new(),
        }
    }

    /// A line of the picture's description (also drawn as a caption by the
    /// layouts that call it).
    pub fn describe(&mut self, line: &str) {
        self.desc.push(line.to_string());
    }

    /// A rectangle under every tile, in `colour`.
    pub fn backdrop(&mut self, (x, y): (f64, f64), (w, h): (f64, f64), colour: Colour) {
        let d = self.backdrop.entry(colour).or_default();
        let _ = write!(
            d,
            "M{} {}h{}v{}h-{}z",
            num(x),
            num(y),
            num(w),
            num(h),
            num(w)
        );
    }

    /// Draws the tiles' colours at `opacity` (their hatching stays whole),
    /// so that a backdrop shows through them.
    pub fn set_tile_opacity(&mut self, opacity: f64) {
        self.tile_opacity = opacity.clamp(0.0, 1.0);
    }

    /// A finding's mark around the polygon `p`: a dark dashed outline on a
    /// white one, which stands out on every fill and on the red marks of
    /// the data, grouped with the finding's words as its tooltip
    /// (`<title>`) and `data-target` naming what it marks, for a browser and
    /// for tests.
    pub fn finding_mark(&mut self, p: &[(f64, f64)], width: f64, target: &str, tooltip: &str) {
        let points = points(p);
        let _ = writeln!(
            self.body,
            "<g class=\"finding\" data-target=\"{}\"><title>{}</title><polygon points=\"{points}\" fill=\"none\" stroke=\"#ffffff\" stroke-width=\"{}\" stroke-linejoin=\"round\"/><polygon points=\"{points}\" fill=\"none\" stroke=\"{MARK}\" stroke-width=\"{}\" stroke-dasharray=\"{} {}\" stroke-linejoin=\"round\"/></g>",
            escape(target),
            escape(tooltip),
            num(width + 2.0),
            num(width),
            num(3.0 * width),
            num(2.0 * width),
        );
    }

    /// A tile: a triangle filled as `fill` says, under everything else.
    pub fn tile(&mut self, p: [(f64, f64); 3], fill: &Fill) {
        subpath(self.tiles.entry((fill.colour, fill.hatch)).or_default(), &p);
    }

    /// A tile's edges, over every tile.
    pub fn edge(&mut self, p: [(f64, f64); 3], colour: Colour, width: f64) {
        subpath(self.edges.entry((colour, num(width))).or_default(), &p);
    }

    pub fn polygon(&mut self, p: &[(f64, f64)], fill: &Fill, outline: Option<(Colour, f64)>) {
        let points = points(p);
        let stroke = match outline {
            Some((colour, width)) => {
                format!(" stroke=\"{colour}\" stroke-width=\"{}\"", num(width))
            }
            None => String::new(),
        };
        let _ = writeln!(
            self.body,
            "<polygon points=\"{points}\" fill=\"{}\"{stroke}/>",
            fill.colour
        );
        if let Some(hatch) = fill.hatch {
            let _ = writeln!(
                self.body,
                "<polygon points=\"{points}\" fill=\"url(#{hatch})\"/>"
            );
        }
    }

    /// An outline only.
    pub fn outline(&mut self, p: &[(f64, f64)], colour: Colour, width: f64) {
        let _ = writeln!(
            self.body,
            "<polygon points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"{}\" stroke-linejoin=\"round\"/>",
            points(p),
            num(width)
        );
    }

    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), colour: Colour, width: f64) {
        let _ = writeln!(
            self.body,
            "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{colour}\" stroke-width=\"{}\" stroke-linecap=\"round\"/>",
            num(a.0),
            num(a.1),
            num(b.0),
            num(b.1),
            num(width)
        );
    }

    pub fn dot(&mut self, c: (f64, f64), r: f64, colour: Colour) {
        let _ = writeln!(
            self.body,
            "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{colour}\"/>",
            num(c.0),
            num(c.1),
            num(r)
        );
    }

    /// `text` in font8x8's bitmaps, each pixel `scale` pixels, its top-left
    /// corner at `at`. Characters outside ASCII are drawn as `?`.
    pub fn text(&mut self, at: (f64, f64), scale: f64, text: &str, colour: Colour) {
        let mut path = String::new();
        for (n, c) in text.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY
                .get(c as usize)
                .unwrap_or(&font8x8::legacy::BASIC_LEGACY[b'?' as usize]);
            let left = at.0 + 8.0 * scale * n as f64;
            for (row, bits) in glyph.iter().enumerate() {
                // Runs of set bits (bit 0 is the leftmost pixel), one
                // rectangle each.
                let mut x = 0;
                while x < 8 {
                    if bits >> x & 1 == 0 {
                        x += 1;
                        continue;
                    }
                    let start = x;
                    while x < 8 && bits >> x & 1 == 1 {
                        x += 1;
                    }
                    let _ = write!(
                        path,
                        "M{} {}h{}v{}h-{}z",
                        num(left + start as f64 * scale),
                        num(at.1 + row as f64 * scale),
                        num((x - start) as f64 * scale),
                        num(scale),
                        num((x - start) as f64 * scale),
                    );
                }
            }
        }
        if !path.is_empty() {
            let _ = writeln!(self.body, "<path d=\"{path}\" fill=\"{colour}\"/>");
        }
    }

    /// `text` centred on `c`.
    pub fn text_centred(&mut self, c: (f64, f64), scale: f64, text: &str, colour: Colour) {
        let width = 8.0 * scale * text.chars().count() as f64;
        self.text((c.0 - width / 2.0, c.1 - 4.0 * scale), scale, text, colour);
    }

    /// The width `text` takes at `scale`.
    pub fn text_width(scale: f64, text: &str) -> f64 {
        8.0 * scale * text.chars().count() as f64
    }

    /// The SVG document.
    pub fn svg(&self) -> String {
        let mut out = String::with_capacity(self.body.len() + 2048);
        let _ = writeln!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">",
            w = self.width,
            h = self.height
        );
        let _ = writeln!(out, "<title>{}</title>", escape(&self.title));
        if !self.desc.is_empty() {
            let _ = writeln!(out, "<desc>{}</desc>", escape(&self.desc.join("\n")));
        }
        // Stripes 6 px apart at 45 degrees, in user space, so that hatching
        // looks alike at every cell size.
        out.push_str("<defs>\n");
        for (id, base, stripe) in [
            ("hatch-ut", "none", STRIPE),
            ("hatch-uo", "none", STRIPE),
            ("hatch-past", "none", PROBLEM),
        ] {
            let _ = writeln!(
                out,
                "<pattern id=\"{id}\" width=\"6\" height=\"6\" patternUnits=\"userSpaceOnUse\" patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"{base}\"/><rect width=\"2\" height=\"6\" fill=\"{stripe}\"/></pattern>"
            );
        }
        out.push_str("</defs>\n");
        let _ = writeln!(
            out,
            "<rect width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>",
            self.width, self.height
        );
        for (colour, d) in &self.backdrop {
            let _ = writeln!(out, "<path d=\"{d}\" fill=\"{colour}\"/>");
        }
        let opacity = if self.tile_opacity < 1.0 {
            format!(" fill-opacity=\"{}\"", self.tile_opacity)
        } else {
            String::new()
        };
        for ((colour, hatch), d) in &self.tiles {
            let _ = writeln!(out, "<path d=\"{d}\" fill=\"{colour}\"{opacity}/>");
            if let Some(hatch) = hatch {
                let _ = writeln!(out, "<path d=\"{d}\" fill=\"url(#{hatch})\"/>");
            }
        }
        for ((colour, width), d) in &self.edges {
            let _ = writeln!(
                out,
                "<path d=\"{d}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"{width}\" stroke-linejoin=\"round\"/>"
            );
        }
        out.push_str(&self.body);
        out.push_str("</svg>\n");
        out
    }
}

/// Appends the closed polygon `p` to the path data `d`.
fn subpath(d: &mut String, p: &[(f64, f64)]) {
    for (n, (x, y)) in p.iter().enumerate() {
        let _ = write!(
            d,
            "{}{} {}",
            if n == 0 { "M" } else { "L" },
            num(*x),
            num(*y)
        );
    }
    d.push('Z');
}

fn points(p: &[(f64, f64)]) -> String {
    let mut out = String::new();
    for (n, (x, y)) in p.iter().enumerate() {
        if n > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{},{}", num(*x), num(*y));
    }
    out
}

/// Why a picture could not be rendered as PNG.
#[derive(Debug)]
pub struct RenderError(pub String);

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// `svg` rendered by resvg at its own size, as PNG bytes.
pub fn png(svg: &str) -> Result<Vec<u8>, RenderError> {
    let tree = resvg::usvg::Tree::from_str(svg, &resvg::usvg::Options::default())
        .map_err(|e| RenderError(format!("the SVG does not parse: {e}")))?;
    let size = tree.size().to_int_size();
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| RenderError("the picture has no pixels".into()))?;
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    pixmap
        .encode_png()
        .map_err(|e| RenderError(format!("cannot encode the PNG: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_from_the_bitmaps() {
        let mut canvas = Canvas::new(40, 10, "t");
        canvas.text((0.0, 0.0), 1.0, "1", TEXT);
        let svg = canvas.svg();
        // font8x8's "1" has a set pixel in each of its first seven rows.
        let rows = (0..7).filter(|r| svg.contains(&format!(" {r}h"))).count();
        assert_eq!(rows, 7, "{svg}");
        let png = png(&svg).unwrap();
        let pixmap = resvg::tiny_skia::Pixmap::decode_png(&png).unwrap();
        let dark = pixmap
            .pixels()
            .iter()
            .filter(|p| p.red() < 128 && p.alpha() == 255)
            .count();
        assert!(dark > 5, "{dark} dark pixels");
    }

    #[test]
    fn numbers_are_rounded_to_a_tenth() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(1.04), "1");
        assert_eq!(num(2.25), "2.3");
        assert_eq!(num(-0.5), "-0.5");
    }
}
