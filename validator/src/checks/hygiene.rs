//! Information about micromap data that is valid but wasteful or fragile:
//! blocks that partly overlap, unused high bits that are not zero, and
//! identical blocks stored twice that could be shared.
//!
//! None of it is a validity rule, and it reads every byte of every block,
//! so the checks run it from the simulate tier up ([`Ctx::hygiene`]): the
//! content tier reads the triangle array but no data byte.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

use crate::checks::common::Tally;
use crate::checks::Ctx;
use crate::model::micromap::opacity_triangle_bytes;
use crate::report::location::Locate;
use crate::report::Severity;
use crate::rules;
use crate::sim::decode::TriangleEntries;
use crate::sim::opacity::bits_per_state;

/// One block's bytes as a map key, hashed once with XXH3 (a fast hash made
/// for bulk bytes; the map compares the bytes themselves on a match, so a
/// collision costs a comparison, never a wrong answer).
#[derive(PartialEq, Eq)]
struct BlockBytes<'a>(&'a [u8]);

impl Hash for BlockBytes<'_> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(xxhash_rust::xxh3::xxh3_64(self.0));
    }
}

/// Hands on the XXH3 digest [`BlockBytes`] writes as the map's hash.
#[derive(Default)]
struct DigestHasher(u64);

impl Hasher for DigestHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        // Only `write_u64` is used; any other input still hashes.
        for &byte in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(byte);
        }
    }

    fn write_u64(&mut self, digest: u64) {
        self.0 = digest;
    }
}

/// Reports hygiene findings for the opacity `triangles` of one build (entry
/// `m` of the triangle array is `triangles[m]`), whose data starts at
/// `data`. Entries with an invalid format or level, or whose block does not
/// lie inside `data`, are skipped: the validity rules report them. `at` is
/// the build's location (`pInfos[0]`).
pub(crate) fn opacity_blocks(
    ctx: &mut Ctx<'_>,
    at: &str,
    data: &[u8],
    triangles: &TriangleEntries,
) {
    let mut tally = Tally::new();
    let mut ranges: Vec<(u64, u64, u64)> = Vec::with_capacity(triangles.len());
    let mut first_with_bytes: HashMap<
        BlockBytes<'_>,
        (u64, u64),
        BuildHasherDefault<DigestHasher>,
    > = HashMap::default();
    for (m, triangle) in (0u64..).zip(triangles.iter()) {
        let (format, level) = (
            u32::from(triangle.format),
            u32::from(triangle.subdivision_level),
        );
        let (Some(size), Some(bits)) = (
            opacity_triangle_bytes(format, level),
            bits_per_state(format),
        ) else {
            continue;
        };
        let start = u64::from(triangle.data_offset);
        let Some(bytes) = usize::try_from(start)
            .ok()
            .and_then(|s| data.get(s..s.checked_add(usize::try_from(size).ok()?)?))
        else {
            continue;
        };
        // Written out only for a finding: most blocks have none.
        let loc = at.member("triangleArray").index(m);
        // Levels 0 and 1 use fewer than 8 bits of their single byte.
        let used_bits = (1u32 << (2 * level.min(2))) * bits;
        if used_bits < 8 && bytes[0] >> used_bits != 0 {
            tally.report(
                ctx,
                &rules::UNUSED_BITS,
                Severity::Info,
                loc,
                || format!("the byte at dataOffset {start} is {:#04x}; only its low {used_bits} bits hold states", bytes[0]),
                "triangleArray",
            );
        }
        ranges.push((start, start + size, m));
        match first_with_bytes.get(&BlockBytes(bytes)) {
            Some((other_start, other_m)) if *other_start != start => tally.report(
                ctx,
                &rules::DUPLICATE_DATA,
                Severity::Info,
                loc,
                || format!("its {size} bytes at dataOffset {start} equal those of triangleArray[{other_m}] at {other_start}; pointing both at one copy saves the space"),
                "triangleArray",
            ),
            Some(_) => {}
            None => {
                first_with_bytes.insert(BlockBytes(bytes), (start, m));
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
                    at.member("triangleArray").index(m),
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
