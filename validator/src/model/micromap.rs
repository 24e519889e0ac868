//! `VK_EXT_opacity_micromap` micromap builds.

use serde::{Deserialize, Serialize};

use crate::model::array_or_pointers::{ElementsCopied, ElementsRead};
pub use crate::model::generated::MicromapBuildInfo;
use crate::model::values::*;

/// `VkMicromapUsageEXT` / `VkMicromapUsageKHR`, laid out as they are, so
/// that reading an application's array of them is a copy of its bytes.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[serde(rename_all = "camelCase")]
#[repr(C)]
pub struct MicromapUsage {
    pub count: u32,
    pub subdivision_level: u32,
    pub format: u32,
}

/// A `usageCountsCount` with its `pUsageCounts` and `ppUsageCounts`, as the
/// call gave them. `None` is a NULL pointer; an element of `pointers` that is
/// `None` is a NULL element.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct UsageCounts {
    pub count: u32,
    pub array: Option<Vec<MicromapUsage>>,
    pub pointers: Option<Vec<Option<MicromapUsage>>>,
}

impl UsageCounts {
    /// `pUsageCounts` pointing at `usages`.
    pub fn array(usages: Vec<MicromapUsage>) -> Self {
        Self {
            count: usages.len() as u32,
            array: Some(usages),
            pointers: None,
        }
    }

    /// `ppUsageCounts` pointing at pointers to `usages`.
    pub fn pointers(usages: Vec<MicromapUsage>) -> Self {
        Self {
            count: usages.len() as u32,
            array: None,
            pointers: Some(usages.into_iter().map(Some).collect()),
        }
    }

    /// The member name and the usages the implementation reads: from
    /// `pUsageCounts` when it is set, else from `ppUsageCounts` (skipping NULL
    /// elements), each with its index.
    pub fn entries(&self) -> (&'static str, Vec<(usize, MicromapUsage)>) {
        (self.member(), self.usages_read().collect())
    }

    /// The member the usages are read from: `pUsageCounts` when it is set
    /// (or neither is), else `ppUsageCounts`.
    pub fn member(&self) -> &'static str {
        if self.array.is_none() && self.pointers.is_some() {
            "ppUsageCounts"
        } else {
            "pUsageCounts"
        }
    }

    /// The usages [`Self::entries`] lists, without collecting them (the
    /// checks walk them once per call, and a valid call should not allocate).
    pub fn usages_read(&self) -> UsagesRead<'_> {
        ElementsRead::new(self.array.as_deref(), self.pointers.as_deref()).copied()
    }

    /// Whether some entry read has a count other than 0 (Σ count > 0),
    /// without summing them all: most arrays answer at their first entry.
    pub fn has_triangles(&self) -> bool {
        self.usages_read().any(|(_, u)| u.count != 0)
    }

    /// Σ count over the entries, in 64 bits (it cannot overflow: at most
    /// 2^32 entries of at most 2^32 - 1 each do not fit what we hold).
    /// Checks call it several times per build, so it sums without
    /// collecting the entries.
    pub fn total(&self) -> u64 {
        // The slice the entries are read from, summed directly: a vector
        // loop rather than a step of the two-slice iterator per entry.
        match (&self.array, &self.pointers) {
            (Some(array), _) => {
                // Four entries a step: one loop test per four adds.
                let mut chunks = array.chunks_exact(4);
                let mut sum = 0u64;
                for four in &mut chunks {
                    sum += four.iter().map(|u| u64::from(u.count)).sum::<u64>();
                }
                sum + chunks
                    .remainder()
                    .iter()
                    .map(|u| u64::from(u.count))
                    .sum::<u64>()
            }
            (None, Some(pointers)) => pointers.iter().flatten().map(|u| u64::from(u.count)).sum(),
            (None, None) => 0,
        }
    }
}

/// The usages a structure's usage counts are read from, with their
/// indices: the elements of `pUsageCounts`, or the non-NULL elements of
/// `ppUsageCounts`.
pub type UsagesRead<'a> = ElementsCopied<'a, MicromapUsage>;

/// `VkMicromapTriangleEXT` / `VkMicromapTriangleKHR`: 8 bytes, little-endian.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct MicromapTriangle {
    pub data_offset: u32,
    pub subdivision_level: u16,
    pub format: u16,
}

impl MicromapTriangle {
    pub const SIZE: u64 = 8;

    pub fn from_bytes(bytes: [u8; 8]) -> Self {
        Self {
            data_offset: u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
            subdivision_level: u16::from_le_bytes([bytes[4], bytes[5]]),
            format: u16::from_le_bytes([bytes[6], bytes[7]]),
        }
    }

    pub fn to_bytes(self) -> [u8; 8] {
        let mut out = [0u8; 8];
        out[..4].copy_from_slice(&self.data_offset.to_le_bytes());
        out[4..6].copy_from_slice(&self.subdivision_level.to_le_bytes());
        out[6..].copy_from_slice(&self.format.to_le_bytes());
        out
    }
}

/// Bytes of one opacity micromap triangle's data: `ceil(4^level * bits / 8)`
/// with `bits` = 1 (2-state) or 2 (4-state); `None` for an unknown format or
/// a level whose size does not fit 64 bits.
pub fn opacity_triangle_bytes(format: u32, level: u32) -> Option<u64> {
    let bits: u32 = match format {
        OPACITY_MICROMAP_FORMAT_2_STATE => 1,
        OPACITY_MICROMAP_FORMAT_4_STATE => 2,
        _ => return None,
    };
    // 4^level * bits = 2^(2 level + bits - 1); in bytes, at least 1.
    let exponent = level.checked_mul(2)?.checked_add(bits - 1)?;
    if exponent >= 64 + 3 {
        return None;
    }
    Some(if exponent <= 3 {
        1
    } else {
        1u64.checked_shl(exponent - 3)?
    })
}

/// Micromap build infos a call read and no one kept, whose vectors (the
/// list and each info's usage entries) the next call reads into, so that a
/// build call below the content tier allocates nothing. Small ones only:
/// one huge call must not keep its memory for the device's lifetime.
#[derive(Clone, Debug, Default)]
pub(crate) struct SpareInfos(pub(crate) Vec<MicromapBuildInfo>);

impl SpareInfos {
    /// The most infos, and usage entries of one info, kept for reuse.
    pub(crate) const INFOS: usize = 64;
    pub(crate) const USAGES: usize = 4096;

    /// Keeps `infos` for the next call if they are small.
    pub fn keep(&mut self, infos: Vec<MicromapBuildInfo>) {
        let small = infos.capacity() <= Self::INFOS
            && infos.iter().all(|info| {
                info.usage_counts
                    .array
                    .as_ref()
                    .is_none_or(|array| array.capacity() <= Self::USAGES)
            });
        if small {
            self.0 = infos;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_sizes_match_the_table() {
        // (level, 2-state bytes, 4-state bytes) from the spec's packing rule.
        for (level, two, four) in [
            (0, 1, 1),
            (1, 1, 1),
            (2, 2, 4),
            (3, 8, 16),
            (4, 32, 64),
            (12, 2_097_152, 4_194_304),
        ] {
            assert_eq!(
                opacity_triangle_bytes(OPACITY_MICROMAP_FORMAT_2_STATE, level),
                Some(two),
                "level {level}"
            );
            assert_eq!(
                opacity_triangle_bytes(OPACITY_MICROMAP_FORMAT_4_STATE, level),
                Some(four),
                "level {level}"
            );
        }
        assert_eq!(opacity_triangle_bytes(3, 1), None);
        assert_eq!(
            opacity_triangle_bytes(OPACITY_MICROMAP_FORMAT_4_STATE, 40),
            None
        );
        assert_eq!(
            opacity_triangle_bytes(OPACITY_MICROMAP_FORMAT_4_STATE, u32::MAX),
            None
        );
    }

    #[test]
    fn triangle_round_trips() {
        let t = MicromapTriangle {
            data_offset: 0x0102_0304,
            subdivision_level: 5,
            format: 2,
        };
        assert_eq!(t.to_bytes(), [4, 3, 2, 1, 5, 0, 2, 0]);
        assert_eq!(MicromapTriangle::from_bytes(t.to_bytes()), t);
    }

    #[test]
    fn usage_entries_prefer_the_array_and_skip_null_pointers() {
        let u = |count| MicromapUsage {
            count,
            subdivision_level: 1,
            format: 2,
        };
        let counts = UsageCounts {
            count: 3,
            array: None,
            pointers: Some(vec![Some(u(1)), None, Some(u(u32::MAX))]),
        };
        let (name, entries) = counts.entries();
        assert_eq!(name, "ppUsageCounts");
        assert_eq!(entries.iter().map(|(i, _)| *i).collect::<Vec<_>>(), [0, 2]);
        assert_eq!(counts.total(), 1 + u64::from(u32::MAX));

        let both_arrays = UsageCounts {
            array: Some(vec![u(4), u(5)]),
            ..counts.clone()
        };
        let (name, entries) = both_arrays.entries();
        assert_eq!(name, "pUsageCounts");
        assert_eq!(entries, [(0, u(4)), (1, u(5))]);
        assert_eq!(both_arrays.total(), 9);
        let neither = UsageCounts::default();
        assert_eq!(neither.entries(), ("pUsageCounts", Vec::new()));
        assert_eq!(neither.total(), 0);
        assert_eq!(counts.member(), "ppUsageCounts");
        let both = UsageCounts {
            array: Some(vec![u(7)]),
            ..counts
        };
        assert_eq!(both.member(), "pUsageCounts");
        assert_eq!(both.usages_read().collect::<Vec<_>>(), [(0, u(7))]);
        assert_eq!(both.total(), 7);
        assert_eq!(UsageCounts::default().member(), "pUsageCounts");
        assert_eq!(UsageCounts::default().usages_read().count(), 0);
        // Triangles: some entry read with a count, as Σ count > 0 says.
        assert!(both.has_triangles());
        assert!(!UsageCounts::default().has_triangles());
        let zeros = UsageCounts::array(vec![u(0), u(0)]);
        assert!(!zeros.has_triangles());
        assert_eq!(zeros.total(), 0);
        let null_first = UsageCounts {
            count: 2,
            array: None,
            pointers: Some(vec![None, Some(u(3))]),
        };
        assert!(null_first.has_triangles());
    }
}
