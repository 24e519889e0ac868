//! What one micromap triangle looks like when drawn: its micro-triangles,
//! or, above the level a picture can show, the cells of a coarser level
//! each standing for the micro-triangles inside it (the downsampling rule),
//! with their states read through the simulator ([`state_at`]) and their
//! corners through the specification's curve ([`MicroTriangle`]).
//!
//! # The downsampling rule
//!
//! A triangle of level `L` drawn at level `D <= L` has `4^D` cells. The
//! curve is hierarchical: cell `k` holds exactly the micro-triangles
//! `k·4^(L-D) .. (k+1)·4^(L-D)`. A cell shows the most frequent state
//! among the micro-triangles it reads (a tie goes to the higher state
//! value: unknown before known, opaque before transparent, so a cell
//! never looks more certain than its data), and is marked *mixed* when
//! they are not all alike. It reads all of its micro-triangles when the
//! picture's budget ([`READ_BUDGET`] over all its cells) allows; otherwise
//! the first micro-triangle of each of its sub-triangles at level `D + S`,
//! `S` the largest with `cells · 4^S <= READ_BUDGET`. A picture therefore
//! reads at most `READ_BUDGET` states plus one per cell, whatever the levels.

use crate::model::micromap::opacity_triangle_bytes;
use crate::model::MicromapTriangle;
use crate::sim::decode::MicromapContent;
use crate::sim::index::{MicroTriangle, MAX_LEVEL};
use crate::sim::opacity::{bits_per_state, state_at, OpacityState};

/// The most micro-triangle states one picture reads (see the module's
/// downsampling rule): 2^24, a level-12 triangle whole.
pub const READ_BUDGET: u64 = 1 << 24;

/// What a cell shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CellState {
    State(OpacityState),
    /// At least one micro-triangle it reads lies past the data the checker has.
    PastEnd,
}

/// One drawn cell: micro-triangle `index` at the drawn level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    pub index: u32,
    pub state: CellState,
    /// The micro-triangles it read are not all one state.
    pub mixed: bool,
}

/// Why a micromap triangle's states cannot be drawn at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Problem {
    /// Its format is neither 2-state nor 4-state.
    Format(u16),
    /// Its level is above 12.
    Level(u16),
}

/// A micromap triangle as drawn.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TriangleCells {
    pub triangle: MicromapTriangle,
    /// The level drawn (`D`), at most the triangle's.
    pub shown: u32,
    /// How many micro-triangles each cell read (`4^S`).
    pub read_per_cell: u64,
    /// The cells in curve order (empty with a problem).
    pub cells: Vec<Cell>,
    pub problem: Option<Problem>,
    /// The data runs past the bytes the checker has (some cells are
    /// [`CellState::PastEnd`], or all of them).
    pub past_end: bool,
}

impl TriangleCells {
    /// Whether every cell shows the micro-triangles one to one.
    pub fn exact(&self) -> bool {
        self.shown == u32::from(self.triangle.subdivision_level) && self.read_per_cell == 1
    }

    /// One state for the whole triangle (every cell alike and none mixed):
    /// it may be drawn as one shape.
    pub fn uniform(&self) -> Option<CellState> {
        let first = self.cells.first()?;
        self.cells
            .iter()
            .all(|c| c.state == first.state && !c.mixed)
            .then_some(first.state)
    }
}

/// How many micromap triangles `content` has (a stride-0 build: all of
/// them read its one entry).
pub fn triangle_count(content: &MicromapContent) -> u64 {
    content.repeated.unwrap_or(content.triangles.len() as u64)
}

/// The entry micromap triangle `m` reads, as [`MicromapContent::triangle_data`]
/// finds it.
pub fn entry(content: &MicromapContent, m: u64) -> Option<MicromapTriangle> {
    if m >= triangle_count(content) {
        return None;
    }
    let i = if content.repeated.is_some() {
        0
    } else {
        usize::try_from(m).ok()?
    };
    content.triangles.get(i)
}

/// The bytes from the triangle's `dataOffset` to the end of the data the
/// checker has: its states, or the part of them that exists.
pub fn triangle_bytes<'a>(content: &'a MicromapContent, triangle: &MicromapTriangle) -> &'a [u8] {
    usize::try_from(triangle.data_offset)
        .ok()
        .and_then(|offset| content.data_bytes().get(offset..))
        .unwrap_or(&[])
}

/// The cells of `triangle`, whose data starts at `bytes`, drawn at level
/// `min(level, max_shown)`, each reading at most `read_per_cell` states
/// (rounded down to a power of 4; at least 1).
pub fn cells(
    triangle: MicromapTriangle,
    bytes: &[u8],
    max_shown: u32,
    read_per_cell: u64,
) -> TriangleCells {
    let format = u32::from(triangle.format);
    let level = u32::from(triangle.subdivision_level);
    let mut out = TriangleCells {
        triangle,
        shown: 0,
        read_per_cell: 1,
        cells: Vec::new(),
        problem: None,
        past_end: false,
    };
    if bits_per_state(format).is_none() {
        out.problem = Some(Problem::Format(triangle.format));
        return out;
    }
    if level > MAX_LEVEL {
        out.problem = Some(Problem::Level(triangle.subdivision_level));
        return out;
    }
    let shown = level.min(max_shown);
    let below = level - shown;
    let mut sample = 0;
    while sample < below && 4u64.pow(sample + 1) <= read_per_cell {
        sample += 1;
    }
    // Cell k covers 4^below micro-triangles from k·4^below; it reads the
    // first of each of its 4^sample sub-triangles.
    let span = 1u32 << (2 * below);
    let step = 1u32 << (2 * (below - sample));
    let reads = 1u32 << (2 * sample);
    out.shown = shown;
    out.read_per_cell = u64::from(reads);
    out.past_end =
        opacity_triangle_bytes(format, level).is_some_and(|size| (bytes.len() as u64) < size);
    out.cells = (0..1u32 << (2 * shown))
        .map(|k| {
            let mut counts = [0u32; 4];
            let mut past = false;
            for r in 0..reads {
                match state_at(bytes, format, k * span + r * step) {
                    Some(state) => counts[state as usize] += 1,
                    None => past = true,
                }
            }
            let held = counts.iter().filter(|n| **n > 0).count();
            // `max_by_key` keeps the last maximum: ties go to the higher
            // state value.
            let most = (0..4).max_by_key(|s| counts[*s]).unwrap_or(0);
            Cell {
                index: k,
                state: if past {
                    CellState::PastEnd
                } else {
                    CellState::State(STATES[most])
                },
                mixed: held > 1 || (past && held > 0),
            }
        })
        .collect();
    out
}

/// The states by value.
const STATES: [OpacityState; 4] = [
    OpacityState::Transparent,
    OpacityState::Opaque,
    OpacityState::UnknownTransparent,
    OpacityState::UnknownOpaque,
];

/// The corners of micro-triangle `index` at `level` on a triangle whose
/// vertices 0, 1, 2 are drawn at `corners`: the specification's
/// barycentrics (u weighs vertex 1, v vertex 2) mapped affinely.
pub fn corners(index: u32, level: u32, corners: [(f64, f64); 3]) -> Option<[(f64, f64); 3]> {
    let micro = MicroTriangle::from_index(index, level)?;
    let [a, b, c] = corners;
    Some(micro.vertices(level).map(|(u, v)| {
        (
            a.0 + u * (b.0 - a.0) + v * (c.0 - a.0),
            a.1 + u * (b.1 - a.1) + v * (c.1 - a.1),
        )
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertex 0 at the origin, vertex 1 at (1, 0), vertex 2 at (0, 1):
    /// picture coordinates are the barycentrics (u, v).
    const UNIT: [(f64, f64); 3] = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];

    fn triangle(format: u16, level: u16) -> MicromapTriangle {
        MicromapTriangle {
            data_offset: 0,
            subdivision_level: level,
            format,
        }
    }

    #[test]
    fn level_1_corners_follow_the_spec_order() {
        // The specification's level-1 order: the triangle at vertex 0, the
        // middle (inverted) one, the one at vertex 1, the one at vertex 2.
        let expected = [
            [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5)],
            [(0.5, 0.5), (0.0, 0.5), (0.5, 0.0)],
            [(0.5, 0.0), (1.0, 0.0), (0.5, 0.5)],
            [(0.0, 0.5), (0.5, 0.5), (0.0, 1.0)],
        ];
        for (k, want) in expected.iter().enumerate() {
            assert_eq!(corners(k as u32, 1, UNIT), Some(*want), "index {k}");
        }
        assert_eq!(corners(4, 1, UNIT), None);
    }

    #[test]
    fn level_2_corners_follow_the_spec_order() {
        // The level-2 table of the specification's figure, as the anchor
        // (lower-left lattice corner, in quarters) and orientation of each index.
        let table: [(u32, u32, bool); 16] = [
            (0, 0, true),
            (0, 0, false),
            (1, 0, true),
            (0, 1, true),
            (0, 1, false),
            (1, 1, true),
            (1, 1, false),
            (1, 0, false),
            (2, 0, true),
            (2, 0, false),
            (3, 0, true),
            (2, 1, true),
            (1, 2, true),
            (0, 2, false),
            (0, 2, true),
            (0, 3, true),
        ];
        for (k, (i, j, upright)) in table.iter().enumerate() {
            let (i, j) = (f64::from(*i) / 4.0, f64::from(*j) / 4.0);
            let q = 0.25;
            let want = if *upright {
                [(i, j), (i + q, j), (i, j + q)]
            } else {
                [(i + q, j + q), (i, j + q), (i + q, j)]
            };
            assert_eq!(corners(k as u32, 2, UNIT), Some(want), "index {k}");
        }
    }

    #[test]
    fn corners_map_affinely_onto_the_drawn_triangle() {
        let drawn = [(10.0, 100.0), (90.0, 100.0), (50.0, 20.0)];
        // Index 2 at level 1 is the triangle at vertex 1.
        assert_eq!(
            corners(2, 1, drawn),
            Some([(50.0, 100.0), (90.0, 100.0), (70.0, 60.0)])
        );
    }

    #[test]
    fn exact_cells_are_the_decoded_states() {
        // 4-state level 1: T, O, UT, UO packed from the least significant bit.
        let drawn = cells(triangle(2, 1), &[0b1110_0100], 6, READ_BUDGET);
        assert!(drawn.exact());
        let states: Vec<CellState> = drawn.cells.iter().map(|c| c.state).collect();
        assert_eq!(
            states,
            STATES.map(CellState::State).to_vec(),
            "{:?}",
            drawn.cells
        );
        assert!(drawn.cells.iter().all(|c| !c.mixed));
        assert!(!drawn.past_end);
    }

    #[test]
    fn a_cell_shows_the_most_frequent_state_of_the_micro_triangles_inside_it() {
        // 2-state level 2 drawn at level 1: cell k holds indices 4k..4k+4.
        // Cell 0: 3 opaque, 1 transparent; cell 1: all transparent; cell 2:
        // 2 and 2 (a tie: opaque, the higher value); cell 3: all opaque.
        let bits: u16 = 0b1111_0011_0000_0111;
        let drawn = cells(triangle(1, 2), &bits.to_le_bytes(), 1, READ_BUDGET);
        assert_eq!(drawn.shown, 1);
        assert_eq!(drawn.read_per_cell, 4);
        assert!(!drawn.exact());
        let shown: Vec<(CellState, bool)> =
            drawn.cells.iter().map(|c| (c.state, c.mixed)).collect();
        let opaque = CellState::State(OpacityState::Opaque);
        let transparent = CellState::State(OpacityState::Transparent);
        assert_eq!(
            shown,
            [
                (opaque, true),
                (transparent, false),
                (opaque, true),
                (opaque, false)
            ]
        );
    }

    #[test]
    fn a_small_budget_reads_the_first_micro_triangle_of_each_sub_triangle() {
        // 2-state level 3 drawn at level 0 with 4 reads: indices 0, 16, 32, 48.
        let mut data = [0u8; 8];
        for k in [16u32, 32, 48] {
            data[(k / 8) as usize] |= 1 << (k % 8);
        }
        let drawn = cells(triangle(1, 3), &data, 0, 4);
        assert_eq!(drawn.read_per_cell, 4);
        assert_eq!(
            drawn.cells,
            [Cell {
                index: 0,
                state: CellState::State(OpacityState::Opaque),
                mixed: true
            }]
        );
        // The budget is rounded down to a power of 4 and never below one read.
        assert_eq!(cells(triangle(1, 3), &data, 0, 15).read_per_cell, 4);
        assert_eq!(cells(triangle(1, 3), &data, 0, 0).read_per_cell, 1);
        // A level-12 triangle drawn at level 6 within the budget reads all.
        let level12 = vec![0u8; 1 << 22];
        let drawn = cells(triangle(2, 12), &level12, 6, READ_BUDGET / 4096);
        assert_eq!((drawn.shown, drawn.read_per_cell), (6, 4096));
        assert_eq!(drawn.cells.len(), 4096);
    }

    #[test]
    fn states_past_the_data_are_marked() {
        // 4-state level 2 needs 4 bytes; 2 are there: indices 0..8 decode.
        let drawn = cells(triangle(2, 2), &[0x55, 0x55], 2, READ_BUDGET);
        assert!(drawn.past_end);
        let past: Vec<u32> = drawn
            .cells
            .iter()
            .filter(|c| c.state == CellState::PastEnd)
            .map(|c| c.index)
            .collect();
        assert_eq!(past, (8..16).collect::<Vec<_>>());
        assert_eq!(
            cells(triangle(7, 2), &[], 2, READ_BUDGET).problem,
            Some(Problem::Format(7))
        );
        assert_eq!(
            cells(triangle(1, 13), &[], 2, READ_BUDGET).problem,
            Some(Problem::Level(13))
        );
    }
}
