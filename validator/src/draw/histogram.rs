//! A micromap build's usage counts against its triangle array: per
//! (format, subdivision level) key, a bar of the count the usage counts
//! state beside a bar of the entries the array holds. Keys whose two bars
//! differ are what `OMMCHECK-usage-counts-match-triangles` reports; they
//! are drawn in red, and the findings about them marked.

use std::collections::{BTreeMap, BTreeSet};

use crate::model::values::FormatKind;
use crate::sim::decode::MicromapContent;

use super::canvas::{Canvas, Fill, EDGE, OPAQUE, PROBLEM, TEXT, TRANSPARENT};
use super::findings::{self, Mark, Target};
use super::pictures::frame;

/// The most keys drawn; the caption counts the rest. Keys that disagree
/// are drawn first.
pub const MAX_KEYS: usize = 64;
/// The bars' height at the largest count, in pixels.
const PLOT: f64 = 320.0;

/// The array's entries per (format, level): each entry it holds, or the
/// one entry read `repeated` times (`triangleArrayStride` 0).
pub fn counted(content: &MicromapContent) -> BTreeMap<(u32, u32), u64> {
    let mut counts: BTreeMap<(u32, u32), u64> = BTreeMap::new();
    match content.repeated {
        Some(n) => {
            if let Some(t) = content.triangles.get(0) {
                counts.insert((u32::from(t.format), u32::from(t.subdivision_level)), n);
            }
        }
        None => {
            for t in content.triangles.iter() {
                *counts
                    .entry((u32::from(t.format), u32::from(t.subdivision_level)))
                    .or_default() += 1;
            }
        }
    }
    counts
}

/// A key's short label under its bars: the level, then the format.
fn short_format(names: FormatKind, format: u32) -> String {
    match (names, format) {
        (FormatKind::OpacityExt | FormatKind::OpacityKhr, 1) => "2-st".into(),
        (FormatKind::OpacityExt | FormatKind::OpacityKhr, 2) => "4-st".into(),
        _ => format!("f{format}"),
    }
}

/// The histogram of micromap `name`'s usage counts (`stated`, summed per
/// key) against its triangle array (`counted`, of the `read` entries the
/// checker read out of the `total` the usage counts sum to).
pub fn usage_counts(
    name: &str,
    names: FormatKind,
    stated: &BTreeMap<(u32, u32), u64>,
    counted: &BTreeMap<(u32, u32), u64>,
    (read, total): (u64, u64),
    marks: &[Mark],
) -> Canvas {
    let count_of =
        |map: &BTreeMap<(u32, u32), u64>, key: &(u32, u32)| map.get(key).copied().unwrap_or(0);
    let keys: BTreeSet<(u32, u32)> = stated.keys().chain(counted.keys()).copied().collect();
    let differs = |key: &(u32, u32)| count_of(stated, key) != count_of(counted, key);
    let wrong: Vec<(u32, u32)> = keys.iter().filter(|k| differs(k)).copied().collect();
    // Those that disagree first, then the others, each in key order.
    let mut shown: Vec<(u32, u32)> = wrong
        .iter()
        .chain(keys.iter().filter(|k| !differs(k)))
        .take(MAX_KEYS)
        .copied()
        .collect();
    shown.sort_unstable();
    let key_text = |(format, level): (u32, u32)| names.key(format, level);
    let marks: Vec<&Mark> = marks
        .iter()
        .filter(|m| m.target == Target::UsageCounts)
        .collect();
    // The keys a finding is about: its message names them ("`<key>`: the
    // usage counts say ..."), in the words the check writes them with.
    let about =
        |mark: &Mark, key: (u32, u32)| mark.message.contains(&format!("{}:", key_text(key)));

    let mut captions = vec![format!(
        "Usage counts of micromap '{name}' against its triangle array, per (format, subdivision level): {} keys{}; the pale bar is the count the usage counts state, the blue bar the entries the array holds. Keys whose bars differ are labelled in red.",
        keys.len(),
        if shown.len() < keys.len() {
            format!(" ({} drawn, those that disagree first)", shown.len())
        } else {
            String::new()
        }
    )];
    if read < total {
        captions.push(format!(
            "The checker read {read} of the {total} array entries the usage counts sum to; the blue bars count those."
        ));
    }
    if !wrong.is_empty() {
        let listed: Vec<String> = wrong
            .iter()
            .take(4)
            .map(|k| {
                format!(
                    "{}: stated {}, counted {}",
                    key_text(*k),
                    count_of(stated, k),
                    count_of(counted, k)
                )
            })
            .collect();
        let more = wrong.len().saturating_sub(4);
        captions.push(format!(
            "Disagreeing: {}{}.",
            listed.join("; "),
            if more > 0 {
                format!("; and {more} more")
            } else {
                String::new()
            }
        ));
    }
    captions.extend(findings::caption(&marks, |m| {
        let named: Vec<String> = wrong
            .iter()
            .filter(|k| about(m, **k))
            .map(|k| key_text(*k))
            .collect();
        if named.is_empty() {
            "the usage counts".into()
        } else {
            named.join(" and ")
        }
    }));

    let most = shown
        .iter()
        .map(|k| count_of(stated, k).max(count_of(counted, k)))
        .max()
        .unwrap_or(0)
        .max(1);
    let axis = Canvas::text_width(1.0, &most.to_string()) + 8.0;
    let group = (960.0 / shown.len().max(1) as f64)
        .floor()
        .clamp(40.0, 96.0);
    let bar = ((group - 12.0) / 2.0).floor();
    // Room above the plot for the legend, the counts over the bars and
    // the findings' marks around them.
    let legend_h = 44.0;
    let stated_fill = Fill {
        colour: TRANSPARENT,
        hatch: None,
        ink: TEXT,
        name: "stated by the usage counts",
    };
    let counted_fill = Fill {
        colour: OPAQUE,
        hatch: None,
        ink: "#ffffff",
        name: "counted in the triangle array",
    };
    let legend_w: f64 = [&stated_fill, &counted_fill]
        .iter()
        .map(|f| 48.0 + Canvas::text_width(1.0, f.name))
        .sum();
    let plot_w = axis + group * shown.len().max(1) as f64;
    let body = (plot_w.max(legend_w), legend_h + PLOT + 36.0);
    let title = format!("micromap '{name}': usage counts against the triangle array");
    let (mut canvas, (x0, y0)) = frame(&title, body, &captions, &[]);
    // The legend of the two bars, above the plot.
    let mut x = x0;
    for f in [&stated_fill, &counted_fill] {
        let square = [
            (x, y0),
            (x + 18.0, y0),
            (x + 18.0, y0 + 18.0),
            (x, y0 + 18.0),
        ];
        canvas.polygon(&square, f, Some((EDGE, 1.0)));
        canvas.text((x + 24.0, y0 + 5.0), 1.0, f.name, TEXT);
        x += 24.0 + Canvas::text_width(1.0, f.name) + 24.0;
    }
    let base = y0 + legend_h + PLOT;
    let left = x0 + axis;
    canvas.line((left, y0 + legend_h), (left, base), EDGE, 1.0);
    canvas.line(
        (left, base),
        (left + group * shown.len() as f64, base),
        EDGE,
        1.0,
    );
    canvas.text((x0, base - 4.0), 1.0, "0", TEXT);
    canvas.text((x0, y0 + legend_h - 4.0), 1.0, &most.to_string(), TEXT);
    for (i, key) in shown.iter().enumerate() {
        let gx = left + group * i as f64 + 6.0;
        let wrong_here = differs(key);
        for (j, (value, f)) in [
            (count_of(stated, key), &stated_fill),
            (count_of(counted, key), &counted_fill),
        ]
        .into_iter()
        .enumerate()
        {
            let h = PLOT * value as f64 / most as f64;
            let x = gx + bar * j as f64;
            let rect = [
                (x, base - h),
                (x + bar, base - h),
                (x + bar, base),
                (x, base),
            ];
            let outline = if wrong_here { PROBLEM } else { EDGE };
            canvas.polygon(&rect, f, Some((outline, 1.0)));
            let text = value.to_string();
            if Canvas::text_width(1.0, &text) <= bar + 4.0 {
                canvas.text_centred((x + bar / 2.0, base - h - 8.0), 1.0, &text, TEXT);
            }
        }
        let ink = if wrong_here { PROBLEM } else { TEXT };
        let centre = gx + bar;
        canvas.text_centred((centre, base + 10.0), 1.0, &format!("L{}", key.1), ink);
        canvas.text_centred((centre, base + 22.0), 1.0, &short_format(names, key.0), ink);
        let here: Vec<&Mark> = marks.iter().copied().filter(|m| about(m, *key)).collect();
        if !here.is_empty() {
            let top = base
                - PLOT * count_of(stated, key).max(count_of(counted, key)) as f64 / most as f64
                - 18.0;
            let (l, r) = (gx - 3.0, gx + 2.0 * bar + 3.0);
            canvas.finding_mark(
                &[(l, top), (r, top), (r, base + 30.0), (l, base + 30.0)],
                2.0,
                &format!("usage counts {}", key_text(*key)),
                &findings::tooltip(&here),
            );
        }
    }
    canvas
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MicromapTriangle;
    use crate::Bytes;

    fn entry(format: u16, level: u16) -> MicromapTriangle {
        MicromapTriangle {
            data_offset: 0,
            subdivision_level: level,
            format,
        }
    }

    #[test]
    fn the_array_is_counted_per_key_and_a_repeated_entry_once_per_triangle() {
        let content = MicromapContent::new(
            vec![entry(1, 3), entry(2, 3), entry(1, 3)],
            Bytes::from(vec![0u8; 4]),
        );
        assert_eq!(
            counted(&content),
            BTreeMap::from([((1, 3), 2), ((2, 3), 1)])
        );
        let repeated =
            MicromapContent::new(vec![entry(2, 5)], Bytes::from(vec![0u8; 4])).repeating(1 << 20);
        assert_eq!(counted(&repeated), BTreeMap::from([((2, 5), 1 << 20)]));
    }

    #[test]
    fn keys_that_disagree_are_drawn_first_and_past_the_bound_counted() {
        // 100 keys agree, one (level 99) disagrees: it is among the 64 drawn.
        let counted: BTreeMap<(u32, u32), u64> = (0..100).map(|l| ((1, l), 1)).collect();
        let mut stated = counted.clone();
        stated.insert((1, 99), 2);
        let svg = usage_counts(
            "m",
            FormatKind::OpacityExt,
            &stated,
            &counted,
            (100, 101),
            &[],
        )
        .svg();
        assert!(
            svg.contains("100 keys (64 drawn, those that disagree first)"),
            "{svg}"
        );
        assert!(
            svg.contains("VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT level 99: stated 2, counted 1")
        );
        assert!(svg.contains("The checker read 100 of the 101 array entries"));
    }
}
