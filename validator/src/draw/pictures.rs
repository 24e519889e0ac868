//! The three picture layouts: one micromap triangle, a whole micromap as a
//! grid of its triangles, and a bottom-level geometry with the micromap
//! triangle (or special index) each of its triangles selects. Each frames
//! its drawing with a title, a legend of the states it shows and captions
//! that say what was drawn and by which downsampling rule.

use std::collections::{BTreeSet, HashMap};

use crate::sim::decode::MicromapContent;
use crate::sim::opacity::{OpacityState, Slot, SpecialIndex};
use crate::sim::trace::{fetch_slot, Attachment};

use super::canvas::{fill, Canvas, Colour, Fill, EDGE, MISSING, PROBLEM, TEXT, TEXTURE_GREYS};
use super::cells::{self, CellState, Problem, TriangleCells, READ_BUDGET};
use super::findings::{self, Mark, Target, MAX_MARKS};
use super::texture::AlphaGrid;

/// Margin around everything, in pixels.
const MARGIN: f64 = 24.0;
/// Title text scale (16 px high) and caption text scale (12 px).
const TITLE: f64 = 2.0;
const CAPTION: f64 = 1.5;
const LINE: f64 = 18.0;
/// The most polygons a picture's cells make, so that a picture's size is
/// bounded (about 70 bytes of SVG each).
pub const MAX_POLYGONS: u64 = 1 << 17;
/// The deepest level a single triangle is drawn at: 4096 cells, each
/// about 11 px across on the 720-px triangle.
pub const MAX_SINGLE_LEVEL: u32 = 6;
/// The most micromap triangles a grid shows, and geometry triangles a
/// geometry picture shows (the caption counts the rest).
pub const MAX_GRID_TRIANGLES: u64 = 4096;
pub const MAX_GEOMETRY_TRIANGLES: u64 = 1 << 18;
/// The smallest drawn cell side, in pixels.
const MIN_CELL: f64 = 4.0;

const ALL_STATES: [OpacityState; 4] = [
    OpacityState::Transparent,
    OpacityState::Opaque,
    OpacityState::UnknownTransparent,
    OpacityState::UnknownOpaque,
];

/// The deepest level whose cells are at least [`MIN_CELL`] across on a
/// triangle `side` pixels wide, capped at `cap`.
fn level_for(side: f64, cap: u32) -> u32 {
    let mut level = 0;
    while level < cap && side / f64::from(1u32 << (level + 1)) >= MIN_CELL {
        level += 1;
    }
    level
}

/// The deepest level `triangles` triangles can all be drawn at within
/// [`MAX_POLYGONS`], capped at `cap`.
fn level_within_polygons(triangles: u64, cap: u32) -> u32 {
    let mut level = 0;
    while level < cap && triangles.max(1).saturating_mul(1 << (2 * (level + 1))) <= MAX_POLYGONS {
        level += 1;
    }
    level
}

/// States a budget of reads allows each of `cells` cells.
fn reads_per_cell(cells: u64) -> u64 {
    (READ_BUDGET / cells.max(1)).max(1)
}

/// Words wrapped into lines of at most `width` characters; a word longer
/// than a line (a VUID) is cut into pieces that fit.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = Vec::new();
    let mut line = String::new();
    let pieces = text.split_whitespace().flat_map(|word| {
        let chars: Vec<char> = word.chars().collect();
        chars
            .chunks(width)
            .map(|c| c.iter().collect::<String>())
            .collect::<Vec<_>>()
    });
    for word in pieces {
        let word = word.as_str();
        if !line.is_empty() && line.len() + 1 + word.len() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The (level, level drawn, micro-triangles read per cell) of each decoded
/// triangle, which [`rule_caption`] states.
fn rules_of<'a>(
    triangles: impl IntoIterator<Item = &'a TriangleCells>,
) -> BTreeSet<(u32, u32, u64)> {
    triangles
        .into_iter()
        .filter(|t| t.problem.is_none())
        .map(|t| {
            (
                u32::from(t.triangle.subdivision_level),
                t.shown,
                t.read_per_cell,
            )
        })
        .collect()
}

/// The downsampling rule in one sentence, for captions.
pub fn rule_caption(shown: &BTreeSet<(u32, u32, u64)>) -> Option<String> {
    let inexact: Vec<String> = shown
        .iter()
        .filter(|(level, drawn, reads)| level != drawn || *reads > 1)
        .map(|(level, drawn, reads)| {
            let span = 1u64 << (2 * (level - drawn));
            let read = if *reads >= span {
                "all of them".to_string()
            } else {
                format!("{reads} of them, the first of each sub-triangle")
            };
            format!("level {level} drawn at level {drawn}: each cell holds {span} micro-triangles and reads {read}")
        })
        .collect();
    if inexact.is_empty() {
        return None;
    }
    Some(format!(
        "Downsampled: {}. A cell shows the most frequent state it reads (ties go to the higher value: unknown before known, opaque before transparent); a dot marks a mixed cell.",
        inexact.join("; ")
    ))
}

/// A canvas with the title, the legend and the captions drawn, and where
/// the body of `body` pixels goes.
pub(super) fn frame(
    title: &str,
    body: (f64, f64),
    captions: &[String],
    legend: &[CellState],
) -> (Canvas, (f64, f64)) {
    let width = (body.0 + 2.0 * MARGIN)
        .max(Canvas::text_width(TITLE, title) + 2.0 * MARGIN)
        .max(720.0)
        .ceil();
    let chars = ((width - 2.0 * MARGIN) / (8.0 * CAPTION)) as usize;
    let lines: Vec<String> = captions.iter().flat_map(|c| wrap(c, chars)).collect();
    // The legend's entries, in rows that fit the width.
    let mut entries = Vec::new();
    let (mut x, mut row) = (MARGIN, 0.0);
    for state in legend {
        let f = fill(*state);
        let entry = 24.0 + Canvas::text_width(CAPTION, f.name);
        if x > MARGIN && x + entry > width - MARGIN {
            (x, row) = (MARGIN, row + 1.0);
        }
        entries.push((x, row, f));
        x += entry + 20.0;
    }
    let legend_rows = entries.last().map_or(0.0, |(_, row, _)| row + 1.0);
    let top = MARGIN + 8.0 * TITLE + 16.0;
    let legend_y = top + body.1 + 16.0;
    let captions_y = legend_y + 26.0 * legend_rows + 4.0;
    let height = (captions_y + LINE * lines.len() as f64 + MARGIN).ceil();
    let mut canvas = Canvas::new(width as u32, height as u32, title);
    canvas.text((MARGIN, MARGIN), TITLE, title, TEXT);
    for (x, row, f) in &entries {
        let y = legend_y + 26.0 * row;
        let square = [(*x, y), (x + 18.0, y), (x + 18.0, y + 18.0), (*x, y + 18.0)];
        canvas.polygon(&square, f, Some((EDGE, 1.0)));
        canvas.text((x + 24.0, y + 3.0), CAPTION, f.name, TEXT);
    }
    for (n, line) in lines.iter().enumerate() {
        canvas.text((MARGIN, captions_y + LINE * n as f64), CAPTION, line, TEXT);
    }
    // The description holds the captions unwrapped, for search and screen readers.
    for caption in captions {
        canvas.describe(caption);
    }
    (canvas, (((width - body.0) / 2.0).floor(), top))
}

/// The legend entries for what the drawn triangles show.
fn legend(drawn: &[&TriangleCells], extra: &[CellState]) -> Vec<CellState> {
    let mut shown: Vec<CellState> = ALL_STATES.iter().map(|s| CellState::State(*s)).collect();
    if drawn.iter().any(|t| t.past_end) || extra.contains(&CellState::PastEnd) {
        shown.push(CellState::PastEnd);
    }
    shown
}

/// How to draw one triangle's cells.
#[derive(Clone, Copy)]
struct Style {
    /// Number the micro-triangles (exact pictures of low levels only).
    numbers: bool,
}

fn centroid(p: &[(f64, f64); 3]) -> (f64, f64) {
    (
        (p[0].0 + p[1].0 + p[2].0) / 3.0,
        (p[0].1 + p[1].1 + p[2].1) / 3.0,
    )
}

/// The triangle `p` scaled by `factor` about its centroid.
fn grown(p: &[(f64, f64); 3], factor: f64) -> Vec<(f64, f64)> {
    let c = centroid(p);
    p.iter()
        .map(|q| (c.0 + (q.0 - c.0) * factor, c.1 + (q.1 - c.1) * factor))
        .collect()
}

/// The length of a triangle's longest side.
fn side(p: &[(f64, f64); 3]) -> f64 {
    let d = |a: (f64, f64), b: (f64, f64)| ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
    d(p[0], p[1]).max(d(p[1], p[2])).max(d(p[2], p[0]))
}

/// Draws `t` on the triangle whose vertices 0, 1, 2 are at `at`.
fn draw_triangle(canvas: &mut Canvas, t: &TriangleCells, at: [(f64, f64); 3], style: Style) {
    let outer = side(&at);
    if let Some(problem) = t.problem {
        canvas.tile(at, &missing());
        canvas.outline(&at, PROBLEM, (outer / 60.0).clamp(1.0, 3.0));
        let label = match problem {
            Problem::Format(f) => format!("format {f}"),
            Problem::Level(l) => format!("level {l}"),
        };
        label_inside(canvas, &at, &label, TEXT);
        return;
    }
    let cell_side = outer / f64::from(1u32 << t.shown);
    match t.uniform() {
        Some(state) => canvas.tile(at, &fill(state)),
        None => {
            for cell in &t.cells {
                let Some(p) = cells::corners(cell.index, t.shown, at) else {
                    continue;
                };
                let f = fill(cell.state);
                canvas.tile(p, &f);
                if cell_side >= 12.0 {
                    canvas.edge(p, EDGE, 0.5);
                }
                if cell.mixed && cell_side >= 10.0 {
                    canvas.dot(centroid(&p), (cell_side / 14.0).max(1.0), f.ink);
                }
                if style.numbers {
                    let scale = (cell_side / 48.0).clamp(1.0, 2.0);
                    canvas.text_centred(centroid(&p), scale, &cell.index.to_string(), f.ink);
                }
            }
        }
    }
    if t.past_end {
        canvas.outline(&at, PROBLEM, (outer / 60.0).clamp(1.5, 4.0));
    } else if outer >= 16.0 {
        canvas.edge(at, EDGE, (outer / 300.0).clamp(0.5, 1.5));
    }
}

fn missing() -> Fill {
    Fill {
        colour: MISSING,
        hatch: None,
        ink: TEXT,
        name: "not drawn",
    }
}

/// A label at a triangle's centroid, if it fits.
fn label_inside(canvas: &mut Canvas, at: &[(f64, f64); 3], label: &str, ink: &'static str) {
    let room = side(at) / 2.2;
    if Canvas::text_width(1.0, label) <= room {
        let scale = (room / Canvas::text_width(1.0, label))
            .clamp(1.0, 2.0)
            .floor();
        canvas.text_centred(centroid(at), scale, label, ink);
    }
}

/// An upright equilateral-looking triangle of `side` pixels with its top-left
/// bounding corner at `(x, y)`: vertex 0 bottom left, 1 bottom right, 2 top.
fn upright(x: f64, y: f64, side: f64) -> [(f64, f64); 3] {
    let h = side * 3f64.sqrt() / 2.0;
    [(x, y + h), (x + side, y + h), (x + side / 2.0, y)]
}

fn describe_triangle(m: u64, t: &TriangleCells) -> String {
    let format = match t.triangle.format {
        1 => "2-state".to_string(),
        2 => "4-state".to_string(),
        other => format!("format {other}"),
    };
    let mut text = format!(
        "Triangle {m}: {format}, level {}, dataOffset {}.",
        t.triangle.subdivision_level, t.triangle.data_offset
    );
    if t.past_end {
        text.push_str(" Its data runs past the end of the data the checker has: red outline, the micro-triangles past the end hatched red.");
    }
    text
}

/// One micromap triangle, numbered in the specification's order when it is
/// drawn exactly at level 3 or below.
pub fn micromap_triangle(
    name: &str,
    content: &MicromapContent,
    m: u64,
    marks: &[Mark],
) -> Result<Canvas, String> {
    micromap_triangle_marked(name, content, m, None, marks)
}

/// What a mark's target is called in captions and in `data-target`.
pub(super) fn target_text(target: &Target) -> String {
    match target {
        Target::MicromapTriangle(m) => format!("micromap triangle {m}"),
        Target::GeometryTriangle(t) => format!("geometry triangle {t}"),
        Target::UsageCounts => "usage counts".into(),
        Target::Whole => "the whole picture".into(),
    }
}

/// Draws `marks` where `at` places their targets (those it cannot place,
/// such as a triangle past the drawn ones, only the caption lists): one
/// mark per target, its tooltip holding every finding there, at most
/// [`MAX_MARKS`] targets.
pub(super) fn draw_marks(
    canvas: &mut Canvas,
    marks: &[&Mark],
    width: f64,
    at: impl Fn(&Target) -> Option<Vec<(f64, f64)>>,
) {
    let mut targets: Vec<(&Target, Vec<&Mark>)> = Vec::new();
    for mark in marks {
        if let Some((_, at)) = targets.iter_mut().find(|(t, _)| *t == &mark.target) {
            at.push(mark);
        } else if targets.len() < MAX_MARKS {
            targets.push((&mark.target, vec![mark]));
        }
    }
    for (target, here) in targets {
        if let Some(p) = at(target) {
            canvas.finding_mark(&p, width, &target_text(target), &findings::tooltip(&here));
        }
    }
}

/// Where a traced ray hit a micromap triangle, as `ommcheck trace` answers
/// it: the barycentrics and the micro-triangles within their error bound.
pub struct HitMarks<'a> {
    /// Said in the title and captions (`ray 2 'grazing'`).
    pub ray: &'a str,
    pub u: f64,
    pub v: f64,
    /// The micro-triangles the hit may lie in (at the triangle's own level).
    pub micro_triangles: &'a [u32],
    /// The error bound spans the whole triangle.
    pub whole_triangle: bool,
    /// The answer in words (`opaque`, `opaque or non-opaque`).
    pub outcome: String,
}

/// Marks of a hit: the micro-triangles it may lie in, outlined.
pub const HIT: Colour = "#c2185b";

/// [`micromap_triangle`] with a traced ray's hit drawn on it: a dot at the
/// hit, and the micro-triangles within its error bound outlined.
pub fn micromap_triangle_marked(
    name: &str,
    content: &MicromapContent,
    m: u64,
    hit: Option<&HitMarks<'_>>,
    marks: &[Mark],
) -> Result<Canvas, String> {
    let marks: Vec<&Mark> = marks
        .iter()
        .filter(|k| matches!(k.target, Target::MicromapTriangle(t) if t == m))
        .collect();
    let count = cells::triangle_count(content);
    let entry = cells::entry(content, m).ok_or_else(|| {
        format!("micromap '{name}' has {count} triangles; there is no triangle {m}")
    })?;
    let side = 720.0;
    let shown = level_for(side, MAX_SINGLE_LEVEL);
    let t = cells::cells(
        entry,
        cells::triangle_bytes(content, &entry),
        shown,
        reads_per_cell(1 << (2 * shown)),
    );
    let level = u32::from(entry.subdivision_level);
    let numbers = t.exact() && level <= 3 && t.problem.is_none();
    let mut captions = vec![describe_triangle(m, &t)];
    if numbers {
        captions.push("Micro-triangles numbered in the specification's order; vertex 0 bottom left, vertex 1 bottom right, vertex 2 top.".into());
    } else {
        captions.push("Vertex 0 bottom left, vertex 1 bottom right, vertex 2 top.".into());
    }
    if t.problem.is_none() {
        captions.extend(rule_caption(&BTreeSet::from([(
            level,
            t.shown,
            t.read_per_cell,
        )])));
    }
    let mut title = format!("micromap '{name}', triangle {m} of {count}");
    if let Some(hit) = hit {
        title = format!("{}: {title}", hit.ray);
        let within = if hit.whole_triangle {
            "its error bound spans the whole triangle, so every micro-triangle is possible"
                .to_string()
        } else {
            match hit.micro_triangles {
                [one] => format!("micro-triangle {one} alone lies within its error bound"),
                many => format!(
                    "{} micro-triangles lie within its error bound (outlined): {}",
                    many.len(),
                    list_first(many, 8)
                ),
            }
        };
        captions.insert(
            1,
            format!(
                "{} hits at u = {}, v = {} (the dot); {within}. Outcome: {}.",
                hit.ray,
                short(hit.u),
                short(hit.v),
                hit.outcome
            ),
        );
    }
    captions.extend(findings::caption(&marks, |_| format!("triangle {m}")));
    let body = (side, side * 3f64.sqrt() / 2.0);
    let (mut canvas, (x, y)) = frame(&title, body, &captions, &legend(&[&t], &[]));
    let at = upright(x, y, side);
    draw_triangle(&mut canvas, &t, at, Style { numbers });
    if let Some(hit) = hit {
        mark_hit(&mut canvas, hit, at, level);
    }
    // Just outside the triangle, so that its red outline stays in view.
    let around = grown(&at, 1.025);
    draw_marks(&mut canvas, &marks, 4.0, |_| Some(around.clone()));
    Ok(canvas)
}

/// `x` to 6 decimal places, without trailing zeros.
fn short(x: f64) -> String {
    let text = format!("{x:.6}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// At most `n` of `items`, then how many more.
fn list_first(items: &[u32], n: usize) -> String {
    let shown: Vec<String> = items.iter().take(n).map(u32::to_string).collect();
    match items.len().saturating_sub(n) {
        0 => shown.join(", "),
        more => format!("{} and {more} more", shown.join(", ")),
    }
}

/// Draws `hit` on the triangle whose vertices are at `at`, its micro-
/// triangles at `level`: each one within the error bound outlined (at most
/// 4096, beyond which the outlines would fill the triangle), then the hit
/// point as a dot in a white ring, at `(1 - u - v)·v0 + u·v1 + v·v2`.
fn mark_hit(canvas: &mut Canvas, hit: &HitMarks<'_>, at: [(f64, f64); 3], level: u32) {
    let outer = side(&at);
    let width = (outer / f64::from(1u32 << level.min(12)) / 8.0).clamp(1.0, 3.0);
    if hit.whole_triangle {
        canvas.outline(&at, HIT, 3.0);
    } else {
        for index in hit.micro_triangles.iter().take(4096) {
            if let Some(p) = cells::corners(*index, level, at) {
                canvas.outline(&p, HIT, width);
            }
        }
    }
    let w = 1.0 - hit.u - hit.v;
    let point = (
        w * at[0].0 + hit.u * at[1].0 + hit.v * at[2].0,
        w * at[0].1 + hit.u * at[1].1 + hit.v * at[2].1,
    );
    if point.0.is_finite() && point.1.is_finite() {
        canvas.dot(point, 7.0, "#ffffff");
        canvas.dot(point, 4.5, HIT);
    }
}

/// A whole micromap: its triangles in a grid, in array order.
pub fn micromap_grid(name: &str, content: &MicromapContent, marks: &[Mark]) -> Canvas {
    let marks: Vec<&Mark> = marks.iter().collect();
    let count = cells::triangle_count(content);
    let drawn = count.min(MAX_GRID_TRIANGLES);
    let cols = (drawn as f64).sqrt().ceil().max(1.0);
    let rows = (drawn as f64 / cols).ceil().max(1.0);
    let cell = (1200.0 / cols).floor().clamp(20.0, 240.0);
    let pad = (cell / 12.0).floor().max(2.0);
    let label = cell >= 56.0;
    let side = cell - 2.0 * pad;
    let row_h = side * 3f64.sqrt() / 2.0 + 2.0 * pad + if label { 14.0 } else { 0.0 };
    let shown = level_for(side, MAX_SINGLE_LEVEL).min(level_within_polygons(drawn, 12));
    let reads = reads_per_cell(drawn.saturating_mul(1 << (2 * shown)));
    let triangles: Vec<TriangleCells> = (0..drawn)
        .filter_map(|m| {
            let entry = cells::entry(content, m)?;
            Some(cells::cells(
                entry,
                cells::triangle_bytes(content, &entry),
                shown,
                reads,
            ))
        })
        .collect();
    let mut captions = vec![format!(
        "{count} triangles in triangle-array order, left to right, top to bottom{}; each with vertex 0 bottom left, vertex 1 bottom right, vertex 2 top.",
        if drawn < count {
            format!(" (the first {drawn} drawn)")
        } else {
            String::new()
        }
    )];
    let past: Vec<String> = (0u64..)
        .zip(&triangles)
        .filter(|(_, t)| t.past_end)
        .map(|(m, _)| m.to_string())
        .collect();
    if !past.is_empty() {
        captions.push(format!(
            "Data past the end of the data the checker has (red outline, hatched red): triangle{} {}.",
            if past.len() == 1 { "" } else { "s" },
            past.join(", ")
        ));
    }
    let problems = triangles.iter().filter(|t| t.problem.is_some()).count();
    if problems > 0 {
        captions.push(format!(
            "Triangles with no opacity format or a level above 12 (grey, red outline, labelled): {problems}."
        ));
    }
    captions.extend(rule_caption(&rules_of(&triangles)));
    captions.extend(findings::caption(&marks, |k| target_text(&k.target)));
    let title = format!("micromap '{name}', {count} triangles");
    let refs: Vec<&TriangleCells> = triangles.iter().collect();
    let (mut canvas, (x0, y0)) = frame(
        &title,
        (cols * cell, rows * row_h),
        &captions,
        &legend(&refs, &[]),
    );
    for (m, t) in (0u64..).zip(&triangles) {
        let (col, row) = ((m % cols as u64) as f64, (m / cols as u64) as f64);
        let (x, y) = (x0 + col * cell + pad, y0 + row * row_h + pad);
        let at = upright(x, y, side);
        draw_triangle(&mut canvas, t, at, Style { numbers: false });
        if label {
            canvas.text_centred(
                (x + side / 2.0, y + side * 3f64.sqrt() / 2.0 + 10.0),
                1.0,
                &format!("[{m}]"),
                TEXT,
            );
        }
    }
    let width = (pad / 2.0).clamp(1.5, 4.0);
    draw_marks(&mut canvas, &marks, width, |target| match target {
        Target::MicromapTriangle(m) if *m < drawn => {
            let (col, row) = ((m % cols as u64) as f64, (m / cols as u64) as f64);
            let (x, y) = (x0 + col * cell + pad, y0 + row * row_h + pad);
            // Grown about its centroid so that its bottom edge moves down
            // by half the padding (at most 5 px): clear of the red
            // outline, above the label.
            let at = upright(x, y, side);
            let grow = 1.0 + 3.0 * (pad / 2.0).min(5.0) / (side * 3f64.sqrt() / 2.0);
            Some(grown(&at, grow))
        }
        _ => None,
    });
    canvas
}

/// What one geometry triangle selects, as drawn.
enum Selected {
    Triangle(u64),
    Special(SpecialIndex),
    /// A micromap triangle past the micromap's triangles.
    OutOfRange(u64),
    /// The index could not be read, or there is no micromap to read.
    Unread,
}

/// The names and numbers a geometry picture's captions give.
pub struct GeometryNames<'a> {
    pub structure: &'a str,
    pub geometry: u32,
    pub micromap: Option<&'a str>,
    pub index_type: &'a str,
}

/// The alpha texture a geometry is drawn over, and where each drawn
/// geometry triangle lies on it.
pub struct Texture<'a> {
    /// The PNG's path as the scene gives it.
    pub png: &'a str,
    pub grid: &'a AlphaGrid,
    /// Each drawn geometry triangle's texture coordinates at its vertices
    /// 0, 1, 2; None where they could not be found.
    pub uvs: &'a [Option<[(f64, f64); 3]>],
    /// Why the first triangle without coordinates has none.
    pub missing: Option<String>,
}

/// Where each geometry triangle is drawn.
enum Layout {
    /// Two triangles to a square of `side` pixels, `cols` squares a row.
    Squares { side: f64, cols: u64 },
    /// At its texture coordinates: `(u, v)` is drawn at
    /// `origin + scale·(u, v)`.
    Texture { origin: (f64, f64), scale: f64 },
}

/// The corners of the squares layout's triangle `t`, its square's corner at `(x, y)`.
fn square_triangle(t: u64, (x, y): (f64, f64), s: f64) -> [(f64, f64); 3] {
    if t.is_multiple_of(2) {
        [(x, y + s), (x + s, y + s), (x, y)]
    } else {
        [(x + s, y), (x, y), (x + s, y + s)]
    }
}

/// A bottom-level geometry, each of its triangles drawn with the micromap
/// triangle its opacity index selects mapped onto it: over its alpha
/// texture at its texture coordinates where `texture` is given, otherwise
/// in a canonical layout (geometry triangles `2q` and `2q + 1` share
/// square `q`, in rows, their vertex 0 at the square's bottom-left or
/// top-right corner).
pub fn geometry(
    names: &GeometryNames<'_>,
    attachment: &Attachment<'_>,
    primitive_count: u64,
    texture: Option<&Texture<'_>>,
    marks: &[Mark],
) -> Canvas {
    let marks: Vec<&Mark> = marks.iter().collect();
    let content = attachment.micromap;
    let micromap_count = content.map_or(0, cells::triangle_count);
    let drawn = primitive_count.min(MAX_GEOMETRY_TRIANGLES);
    let selected: Vec<Selected> = (0..drawn)
        .map(|t| match fetch_slot(attachment, t) {
            Ok(Slot::Special(s)) => Selected::Special(s),
            Ok(Slot::Micromap(_)) if content.is_none() => Selected::Unread,
            Ok(Slot::Micromap(m)) if m >= micromap_count => Selected::OutOfRange(m),
            Ok(Slot::Micromap(m)) => Selected::Triangle(m),
            // Past the index buffer's known contents, or an index type no
            // attachment may use: the checks report it; here it is unread.
            Err(_) => Selected::Unread,
        })
        .collect();
    // The layout, the body's size and the side a triangle typically has.
    let (layout, body, typical) = match texture {
        None => {
            let squares = drawn.div_ceil(2).max(1);
            let cols = (squares as f64).sqrt().ceil();
            let rows = (squares as f64 / cols).ceil();
            let s = (1600.0 / cols).floor().clamp(3.0, 240.0);
            let layout = Layout::Squares {
                side: s,
                cols: cols as u64,
            };
            (layout, (cols * s, rows * s), s)
        }
        Some(texture) => {
            // The texture's square and every triangle's coordinates, 720
            // pixels on the longer side.
            let (mut lo, mut hi) = ((0.0f64, 0.0f64), (1.0f64, 1.0f64));
            for p in texture.uvs.iter().flatten().flatten() {
                lo = (lo.0.min(p.0), lo.1.min(p.1));
                hi = (hi.0.max(p.0), hi.1.max(p.1));
            }
            let scale = 720.0 / (hi.0 - lo.0).max(hi.1 - lo.1);
            let body = ((hi.0 - lo.0) * scale, (hi.1 - lo.1) * scale);
            let sides: Vec<f64> = texture
                .uvs
                .iter()
                .flatten()
                .map(|p| side(p) * scale)
                .collect();
            let typical = sides.iter().sum::<f64>() / sides.len().max(1) as f64;
            let layout = Layout::Texture {
                origin: (-lo.0 * scale, -lo.1 * scale),
                scale,
            };
            (layout, body, typical)
        }
    };
    let distinct: BTreeSet<u64> = selected
        .iter()
        .filter_map(|s| match s {
            Selected::Triangle(m) => Some(*m),
            _ => None,
        })
        .collect();
    let shown = level_for(typical, 12).min(level_within_polygons(drawn, 12));
    let reads = reads_per_cell((distinct.len() as u64).saturating_mul(1 << (2 * shown)));
    let mut decoded: HashMap<u64, TriangleCells> = HashMap::new();
    if let Some(content) = content {
        for m in &distinct {
            if let Some(entry) = cells::entry(content, *m) {
                let bytes = cells::triangle_bytes(content, &entry);
                decoded.insert(*m, cells::cells(entry, bytes, shown, reads));
            }
        }
    }
    let placement = match texture {
        None => "two to a square (triangle 2q with vertex 0 bottom left, 2q+1 with vertex 0 top right)".to_string(),
        Some(t) => format!(
            "at their texture coordinates over the alpha texture {} ({} x {} texels, its {} drawn as {} x {} cells of the mean alpha in 16 greys, white transparent to dark grey opaque; the states over it at 55% opacity)",
            t.png, t.grid.width, t.grid.height, t.grid.channel, t.grid.cols, t.grid.rows
        ),
    };
    let mut captions = vec![format!(
        "Geometry {} of '{}': {primitive_count} triangles{}, {placement}, each showing the micromap triangle its opacity index selects. Opacity micromap {}, {micromap_count} triangles; index type {}.",
        names.geometry,
        names.structure,
        if drawn < primitive_count {
            format!(" (the first {drawn} drawn)")
        } else {
            String::new()
        },
        names.micromap.map_or("VK_NULL_HANDLE".to_string(), |n| format!("'{n}'")),
        names.index_type,
    )];
    if let Some(texture) = texture {
        let without = texture.uvs.iter().filter(|uv| uv.is_none()).count();
        if without > 0 {
            captions.push(format!(
                "Not drawn, without texture coordinates: {without} triangles{}.",
                texture
                    .missing
                    .as_ref()
                    .map_or(String::new(), |why| format!(" ({why})"))
            ));
        }
    }
    let mut counts = [0u64; 4];
    let mut specials = [0u64; 5];
    for s in &selected {
        match s {
            Selected::Triangle(_) => counts[0] += 1,
            Selected::Special(sp) => {
                counts[1] += 1;
                specials[(-sp.value() - 1) as usize] += 1;
            }
            Selected::OutOfRange(_) => counts[2] += 1,
            Selected::Unread => counts[3] += 1,
        }
    }
    let mut what = vec![format!(
        "Geometry triangles selecting a micromap triangle: {}",
        counts[0]
    )];
    if counts[1] > 0 {
        let by: Vec<String> = (1..=5)
            .zip(specials)
            .filter(|(_, n)| *n > 0)
            .map(|(v, n)| format!("{n} of -{v}"))
            .collect();
        what.push(format!(
            "using a special index, drawn filled with its state and labelled: {} ({})",
            counts[1],
            by.join(", ")
        ));
    }
    if counts[2] > 0 {
        let first: Vec<String> = selected
            .iter()
            .enumerate()
            .filter_map(|(t, s)| match s {
                Selected::OutOfRange(m) => Some(format!("triangle {t} selects {m}")),
                _ => None,
            })
            .take(4)
            .collect();
        what.push(format!(
            "selecting a triangle past the micromap's {micromap_count}, red X: {} ({})",
            counts[2],
            first.join(", ")
        ));
    }
    if counts[3] > 0 {
        what.push(format!(
            "with an index the checker could not read or no micromap, grey '?': {}",
            counts[3]
        ));
    }
    captions.push(format!("{}.", what.join("; ")));
    let past: Vec<String> = decoded
        .iter()
        .filter(|(_, t)| t.past_end)
        .map(|(m, _)| *m)
        .collect::<BTreeSet<u64>>()
        .iter()
        .map(u64::to_string)
        .collect();
    if !past.is_empty() {
        captions.push(format!(
            "Micromap triangles whose data runs past the end of the data the checker has (red outline, hatched red): {}.",
            past.join(", ")
        ));
    }
    captions.extend(rule_caption(&rules_of(decoded.values())));
    captions.extend(findings::caption(&marks, |k| target_text(&k.target)));
    let title = format!("'{}' geometry {}", names.structure, names.geometry);
    let refs: Vec<&TriangleCells> = decoded.values().collect();
    let (mut canvas, (x0, y0)) = frame(&title, body, &captions, &legend(&refs, &[]));
    // Where triangle t lies on the canvas.
    let at = |t: u64| -> Option<[(f64, f64); 3]> {
        match layout {
            Layout::Squares { side, cols } => {
                let q = t / 2;
                let corner = (x0 + (q % cols) as f64 * side, y0 + (q / cols) as f64 * side);
                Some(square_triangle(t, corner, side))
            }
            Layout::Texture { origin, scale } => {
                let uv = (*texture?.uvs.get(usize::try_from(t).ok()?)?)?;
                Some(uv.map(|(u, v)| (x0 + origin.0 + u * scale, y0 + origin.1 + v * scale)))
            }
        }
    };
    if let (Some(texture), Layout::Texture { origin, scale }) = (texture, &layout) {
        draw_texture(
            &mut canvas,
            texture.grid,
            (x0 + origin.0, y0 + origin.1),
            *scale,
        );
        canvas.set_tile_opacity(0.55);
    }
    let (labels, s) = match layout {
        Layout::Squares { side, .. } => (side >= 96.0, side),
        Layout::Texture { .. } => (false, typical),
    };
    // Red outlines are drawn last, so that no neighbour covers them.
    let mut marked: Vec<([(f64, f64); 3], f64)> = Vec::new();
    for (t, sel) in (0u64..).zip(&selected) {
        let Some(at) = at(t) else { continue };
        let label = match sel {
            Selected::Triangle(m) => {
                if let Some(cells) = decoded.get(m) {
                    draw_triangle(&mut canvas, cells, at, Style { numbers: false });
                    if cells.past_end || cells.problem.is_some() {
                        marked.push((at, (s / 60.0).clamp(1.0, 4.0)));
                    }
                }
                format!("{t}: [{m}]")
            }
            Selected::Special(sp) => {
                let f = sp
                    .state()
                    .map_or_else(missing, |st| fill(CellState::State(st)));
                canvas.tile(at, &f);
                if s >= 16.0 {
                    canvas.edge(at, EDGE, (s / 200.0).clamp(0.3, 1.0));
                }
                format!("{t}: {}", sp.value())
            }
            Selected::OutOfRange(m) => {
                canvas.tile(at, &missing());
                let c = centroid(&at);
                // s/6 on a square's half: its longest side is s·√2.
                let r = side(&at) / (6.0 * std::f64::consts::SQRT_2);
                let width = (s / 40.0).clamp(0.8, 3.0);
                canvas.line((c.0 - r, c.1 - r), (c.0 + r, c.1 + r), PROBLEM, width);
                canvas.line((c.0 - r, c.1 + r), (c.0 + r, c.1 - r), PROBLEM, width);
                marked.push((at, width));
                format!("{t}: [{m}]")
            }
            Selected::Unread => {
                canvas.tile(at, &missing());
                if s >= 16.0 {
                    canvas.edge(at, EDGE, (s / 200.0).clamp(0.3, 1.0));
                }
                format!("{t}: ?")
            }
        };
        if labels {
            // Beside the square's corner the triangle does not cover
            // much of: toward vertex 0.
            let c = centroid(&at);
            let toward = ((c.0 + at[0].0) / 2.0, (c.1 + at[0].1) / 2.0);
            let width = Canvas::text_width(1.0, &label);
            let (bx, by) = (toward.0 - width / 2.0 - 2.0, toward.1 - 6.0);
            canvas.polygon(
                &[
                    (bx, by),
                    (bx + width + 4.0, by),
                    (bx + width + 4.0, by + 12.0),
                    (bx, by + 12.0),
                ],
                &Fill {
                    colour: "#ffffff",
                    hatch: None,
                    ink: TEXT,
                    name: "label",
                },
                None,
            );
            canvas.text_centred(toward, 1.0, &label, TEXT);
        }
    }
    for (at, width) in &marked {
        canvas.outline(at, PROBLEM, *width);
    }
    let width = (s / 40.0).clamp(1.5, 4.0);
    draw_marks(&mut canvas, &marks, width, |target| match target {
        Target::GeometryTriangle(t) if *t < drawn => at(*t).map(|p| p.to_vec()),
        _ => None,
    });
    canvas
}

/// The alpha grid as rectangles of 16 greys, the texture's square
/// `scale` pixels wide with its top-left corner at `corner`; each row's
/// runs of one grey make one rectangle.
fn draw_texture(canvas: &mut Canvas, grid: &AlphaGrid, corner: (f64, f64), scale: f64) {
    let (cw, ch) = (
        scale / f64::from(grid.cols.max(1)),
        scale / f64::from(grid.rows.max(1)),
    );
    let grey = |a: u8| TEXTURE_GREYS[usize::from(a >> 4)];
    for (r, row) in grid.alpha.chunks(grid.cols.max(1) as usize).enumerate() {
        let mut c = 0;
        while c < row.len() {
            let colour = grey(row[c]);
            let start = c;
            while c < row.len() && grey(row[c]) == colour {
                c += 1;
            }
            canvas.backdrop(
                (corner.0 + start as f64 * cw, corner.1 + r as f64 * ch),
                ((c - start) as f64 * cw, ch),
                colour,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_keep_cells_visible_and_pictures_bounded() {
        // 720 px: level 6 cells are 11 px, level 7 cells 5.6, level 8 2.8.
        assert_eq!(level_for(720.0, 12), 7);
        assert_eq!(level_for(720.0, MAX_SINGLE_LEVEL), 6);
        assert_eq!(level_for(3.0, 12), 0);
        // 65,536 triangles within 2^17 polygons: level 0 only.
        assert_eq!(level_within_polygons(65_536, 12), 0);
        assert_eq!(level_within_polygons(1, 12), 8);
        assert_eq!(level_within_polygons(2, 3), 3);
    }

    #[test]
    fn the_rule_is_stated_only_when_a_picture_is_downsampled() {
        assert_eq!(rule_caption(&BTreeSet::from([(3, 3, 1)])), None);
        let stated = rule_caption(&BTreeSet::from([(12, 6, 4096)])).unwrap();
        assert!(
            stated.contains("level 12 drawn at level 6: each cell holds 4096 micro-triangles and reads all of them"),
            "{stated}"
        );
        let sampled = rule_caption(&BTreeSet::from([(12, 0, 256)])).unwrap();
        assert!(sampled.contains("reads 256 of them"), "{sampled}");
    }

    #[test]
    fn captions_wrap_at_words() {
        assert_eq!(wrap("aa bb cc", 5), ["aa bb", "cc"]);
        assert_eq!(wrap("a VUID-long", 4), ["a", "VUID", "-lon", "g"]);
        assert_eq!(wrap("", 5), Vec::<String>::new());
    }
}
