//! `ommcheck stats --states`: every micro-triangle's state of every opacity
//! micromap a scene builds, in JSON, for scripts. Each triangle's states
//! are one string of digits in the specification's curve order, `0`
//! transparent, `1` opaque, `2` unknown-transparent, `3` unknown-opaque
//! (the 4-state values), decoded by the simulator ([`state_at`]).

use serde::Serialize;

use crate::model::values::MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
use crate::model::Handle;
use crate::scene::{Scene, SceneError};
use crate::sim::decode::MicromapContent;
use crate::sim::index::MAX_LEVEL;
use crate::sim::opacity::{bits_per_state, state_at};

use super::cells;
use super::Drawable;

/// The most states one listing holds, over all its triangles: 2^28 digits,
/// the states of sixteen level-12 triangles. Triangles past it are listed
/// without states, saying why, so that a scene whose many triangles share
/// one block of data cannot make the listing take unbounded memory.
pub const MAX_LISTED_STATES: u64 = 1 << 28;

/// Said of a triangle whose states are past [`MAX_LISTED_STATES`].
const OVER_BUDGET: &str = "not listed: the listing already holds 2^28 states";

/// What the digits of `states` stand for, by value.
pub const LEGEND: [&str; 4] = [
    "transparent",
    "opaque",
    "unknown-transparent",
    "unknown-opaque",
];

/// The JSON output: the legend and each scene's micromaps.
#[derive(Clone, Debug, Serialize)]
pub struct StatesOutput {
    pub legend: [&'static str; 4],
    pub scenes: Vec<SceneStates>,
}

#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SceneStates {
    pub path: String,
    pub micromaps: Vec<MicromapStates>,
}

/// One opacity micromap's triangles.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct MicromapStates {
    /// The scene's name for it (None for one it did not name).
    pub name: Option<String>,
    /// `VkMicromapEXT`, or `VkAccelerationStructureKHR` for a KHR micromap.
    #[serde(rename = "type")]
    pub kind: &'static str,
    pub handle: Handle,
    /// Whether the checker read the build's triangle array and data; when
    /// not, `triangles` is empty.
    pub content_known: bool,
    /// With `triangleArrayStride` 0, every one of this many triangles
    /// reads the array's first entry, which is listed once.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub repeated: Option<u64>,
    pub triangles: Vec<TriangleStates>,
}

/// One micromap triangle's states.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TriangleStates {
    /// Its index in the triangle array.
    pub index: u64,
    pub data_offset: u32,
    /// `VkOpacityMicromapFormatEXT` value (1: 2-state, 2: 4-state).
    pub format: u16,
    pub subdivision_level: u16,
    /// One digit per micro-triangle, in curve order, as far as the data goes.
    pub states: String,
    /// Micro-triangles past the end of the data the checker has (not in `states`).
    pub past_end: u64,
    /// Why no state was decoded: the format is not an opacity format, or
    /// the level is above 12.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub problem: Option<&'static str>,
}

/// The states of triangle `m` (its entry `triangle`) of `content`, taken
/// from what is left of the listing's `budget` of states.
fn triangle_states(content: &MicromapContent, m: u64, budget: &mut u64) -> Option<TriangleStates> {
    let triangle = cells::entry(content, m)?;
    let format = u32::from(triangle.format);
    let level = u32::from(triangle.subdivision_level);
    let mut out = TriangleStates {
        index: m,
        data_offset: triangle.data_offset,
        format: triangle.format,
        subdivision_level: triangle.subdivision_level,
        states: String::new(),
        past_end: 0,
        problem: None,
    };
    if bits_per_state(format).is_none() {
        out.problem = Some("not an opacity format");
        return Some(out);
    }
    if level > MAX_LEVEL {
        out.problem = Some("level above 12");
        return Some(out);
    }
    let count = 1u32 << (2 * level);
    match budget.checked_sub(u64::from(count)) {
        Some(left) => *budget = left,
        None => {
            out.problem = Some(OVER_BUDGET);
            return Some(out);
        }
    }
    let bytes = cells::triangle_bytes(content, &triangle);
    out.states.reserve(count as usize);
    for k in 0..count {
        match state_at(bytes, format, k) {
            Some(state) => out.states.push(char::from(b'0' + state as u8)),
            // The data ends here, so every later state is past it too.
            None => {
                out.past_end = u64::from(count - k);
                break;
            }
        }
    }
    Some(out)
}

impl Drawable {
    /// Every opacity micromap the scene built, with its states, as far as
    /// `budget` (states left to list) goes.
    pub fn states(&self, budget: &mut u64) -> Vec<MicromapStates> {
        let state = self.validator.state();
        let name = |kind: &str, handle: Handle| {
            self.objects
                .iter()
                .find(|o| o.kind == kind && o.handle == handle)
                .map(|o| o.name.clone())
        };
        let micromaps = state
            .micromaps
            .iter()
            .filter_map(|(handle, m)| Some((*handle, m.built.as_ref()?)))
            .filter(|(_, built)| built.ty != MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV)
            .map(|(handle, built)| ("VkMicromapEXT", handle, built));
        let khr = state
            .acceleration_structures
            .iter()
            .filter_map(|(handle, s)| Some((*handle, s.built.as_ref()?)))
            .filter(|(_, built)| built.content.is_some())
            .map(|(handle, built)| ("VkAccelerationStructureKHR", handle, built));
        micromaps
            .chain(khr)
            .map(|(kind, handle, built)| {
                let content = built.content.as_deref();
                let listed = content.map_or(0, |c| {
                    if c.repeated.is_some() {
                        c.triangles.len().min(1) as u64
                    } else {
                        cells::triangle_count(c)
                    }
                });
                MicromapStates {
                    name: name(kind, handle),
                    kind,
                    handle,
                    content_known: content.is_some(),
                    repeated: content.and_then(|c| c.repeated),
                    triangles: content
                        .map(|c| {
                            (0..listed)
                                .filter_map(|m| triangle_states(c, m, budget))
                                .collect()
                        })
                        .unwrap_or_default(),
                }
            })
            .collect()
    }
}

/// Runs each scene and lists its micromaps' states (the first scene that
/// cannot be read or resolved is the error).
pub fn states_of(scenes: &[Scene]) -> Result<StatesOutput, SceneError> {
    let mut out = StatesOutput {
        legend: LEGEND,
        scenes: Vec::with_capacity(scenes.len()),
    };
    let mut budget = MAX_LISTED_STATES;
    for scene in scenes {
        let drawable = Drawable::run(scene)?;
        out.scenes.push(SceneStates {
            path: scene.path.clone(),
            micromaps: drawable.states(&mut budget),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MicromapTriangle;
    use crate::Bytes;

    #[test]
    fn states_are_digits_in_curve_order_up_to_the_end_of_the_data() {
        let content = MicromapContent::new(
            vec![
                MicromapTriangle {
                    data_offset: 0,
                    subdivision_level: 1,
                    format: 2,
                },
                MicromapTriangle {
                    data_offset: 1,
                    subdivision_level: 2,
                    format: 2,
                },
                MicromapTriangle {
                    data_offset: 0,
                    subdivision_level: 1,
                    format: 9,
                },
            ],
            Bytes::from(vec![0b1110_0100u8, 0b0001_1011]),
        );
        let budget = &mut MAX_LISTED_STATES.clone();
        let first = triangle_states(&content, 0, budget).unwrap();
        assert_eq!((first.states.as_str(), first.past_end), ("0123", 0));
        // Level 2, 4-state: 4 bytes needed from offset 1, 1 there.
        let second = triangle_states(&content, 1, budget).unwrap();
        assert_eq!((second.states.as_str(), second.past_end), ("3210", 12));
        let third = triangle_states(&content, 2, budget).unwrap();
        assert_eq!(third.problem, Some("not an opacity format"));
        assert!(third.states.is_empty());
        assert!(triangle_states(&content, 3, budget).is_none());
        assert_eq!(*budget, MAX_LISTED_STATES - 4 - 16);
    }

    /// Past the budget a triangle is listed without states, saying why;
    /// one that fits is listed whole.
    #[test]
    fn triangles_past_the_budget_are_listed_without_states() {
        let content = MicromapContent::new(
            vec![
                MicromapTriangle {
                    data_offset: 0,
                    subdivision_level: 1,
                    format: 2,
                };
                2
            ],
            Bytes::from(vec![0b1110_0100u8]),
        );
        let budget = &mut 6;
        let first = triangle_states(&content, 0, budget).unwrap();
        assert_eq!((first.states.as_str(), first.problem), ("0123", None));
        let second = triangle_states(&content, 1, budget).unwrap();
        assert_eq!(second.problem, Some(OVER_BUDGET));
        assert!(second.states.is_empty());
        assert_eq!(*budget, 2);
    }
}
