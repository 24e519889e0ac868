//! Information about micromap data that is valid but wasteful or fragile:
//! blocks that partly overlap, unused high bits that are not zero, and
//! identical blocks stored twice that could be shared.

use std::collections::HashMap;

use crate::checks::common::Tally;
use crate::model::micromap::opacity_triangle_bytes;
use crate::model::MicromapTriangle;
use crate::report::Severity;
use crate::rules;
use crate::sim::opacity::bits_per_state;
use crate::validator::Ctx;

/// One opacity triangle whose data lies inside `data`.
pub(crate) struct Block {
    /// Its index in the triangle array.
    pub m: u64,
    pub triangle: MicromapTriangle,
}

/// Reports hygiene findings for the opacity `blocks` of one build, whose
/// data all lies inside `data`. `at` is the build's location (`pInfos[0]`).
pub(crate) fn opacity_blocks(ctx: &mut Ctx<'_>, at: &str, data: &[u8], blocks: &[Block]) {
    let mut tally = Tally::new();
    let mut ranges: Vec<(u64, u64, u64)> = Vec::with_capacity(blocks.len());
    let mut first_with_bytes: HashMap<&[u8], (u64, u64)> = HashMap::new();
    for block in blocks {
        let (format, level) = (
            u32::from(block.triangle.format),
            u32::from(block.triangle.subdivision_level),
        );
        let (Some(size), Some(bits)) = (
            opacity_triangle_bytes(format, level),
            bits_per_state(format),
        ) else {
            continue;
        };
        let start = u64::from(block.triangle.data_offset);
        let Some(bytes) = usize::try_from(start)
            .ok()
            .and_then(|s| data.get(s..s.checked_add(usize::try_from(size).ok()?)?))
        else {
            continue;
        };
        // Built only for a finding: most blocks have none.
        let loc = || format!("{at}.triangleArray[{}]", block.m);
        // Levels 0 and 1 use fewer than 8 bits of their single byte.
        let used_bits = (1u32 << (2 * level.min(2))) * bits;
        if used_bits < 8 && bytes[0] >> used_bits != 0 {
            tally.report(
                ctx,
                &rules::UNUSED_BITS,
                Severity::Info,
                loc(),
                || format!("the byte at dataOffset {start} is {:#04x}; only its low {used_bits} bits hold states", bytes[0]),
                "triangleArray",
            );
        }
        ranges.push((start, start + size, block.m));
        match first_with_bytes.get(bytes) {
            Some((other_start, other_m)) if *other_start != start => tally.report(
                ctx,
                &rules::DUPLICATE_DATA,
                Severity::Info,
                loc(),
                || format!("its {size} bytes at dataOffset {start} equal those of triangleArray[{other_m}] at {other_start}; pointing both at one copy saves the space"),
                "triangleArray",
            ),
            Some(_) => {}
            None => {
                first_with_bytes.insert(bytes, (start, block.m));
            }
        }
    }
    // Partial overlaps: sharing one block (same start and size) is fine.
    ranges.sort_unstable();
    ranges.dedup_by_key(|r| (r.0, r.1));
    let mut furthest: Option<(u64, u64)> = None; // (end, m) of the block reaching furthest so far
    for (start, end, m) in ranges {
        if let Some((other_end, other_m)) = furthest {
            if start < other_end {
                tally.report(
                    ctx,
                    &rules::OVERLAPPING_DATA,
                    Severity::Info,
                    format!("{at}.triangleArray[{m}]"),
                    || format!("its data [{start}, {end}) overlaps that of triangleArray[{other_m}] (ending at {other_end})"),
                    "triangleArray",
                );
            }
        }
        if furthest.is_none_or(|(other_end, _)| end > other_end) {
            furthest = Some((end, m));
        }
    }
    tally.finish(ctx);
}
