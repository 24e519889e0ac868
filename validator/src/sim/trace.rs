//! One candidate hit on a geometry triangle with an opacity attachment:
//! fetch the triangle's index, find the micromap triangle or special index,
//! read the states the hit may land on, and decide the outcomes.

use std::collections::BTreeSet;

use crate::model::accel::{index_size, INDEX_TYPE_NONE};

use crate::sim::decode::{LookupError, MicromapContent};
use crate::sim::opacity::{decide, Candidate, HitOutcome, OpacityState, Slot};

/// A geometry's opacity attachment, with the bytes behind its index buffer.
#[derive(Clone, Copy, Debug)]
pub struct Attachment<'a> {
    /// `VkIndexType` raw value.
    pub index_type: i32,
    /// The index buffer's bytes from its address on (None: not readable).
    pub index_bytes: Option<&'a [u8]>,
    pub index_stride: u64,
    pub base_triangle: u32,
    /// The referenced micromap's content (None: VK_NULL_HANDLE or not known).
    pub micromap: Option<&'a MicromapContent>,
    /// The micromap was built lossy (KHR).
    pub lossy: bool,
    /// Cluster geometry, where -5 is meaningful.
    pub cluster: bool,
}

/// Why a hit cannot be decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceError {
    /// The index type is not one an attachment may use.
    IndexType(i32),
    /// Triangle `t`'s index lies outside the readable index buffer.
    IndexOutOfRange {
        t: u64,
    },
    /// The index buffer's contents are unknown to the checker.
    IndexUnreadable,
    /// -5 outside cluster geometry.
    ClusterSkipOutsideCluster {
        t: u64,
    },
    /// A micromap index with no micromap to read.
    NoMicromap {
        t: u64,
    },
    Lookup(LookupError),
}

/// The slot of geometry triangle `t`: read (little-endian) at `t · stride`,
/// or `t + baseTriangle` for index type NONE.
pub fn fetch_slot(attachment: &Attachment<'_>, t: u64) -> Result<Slot, TraceError> {
    if attachment.index_type == INDEX_TYPE_NONE {
        return Ok(Slot::Micromap(
            t.saturating_add(u64::from(attachment.base_triangle)),
        ));
    }
    let size =
        index_size(attachment.index_type).ok_or(TraceError::IndexType(attachment.index_type))?;
    let bytes = attachment.index_bytes.ok_or(TraceError::IndexUnreadable)?;
    let at = t
        .checked_mul(attachment.index_stride)
        .and_then(|o| usize::try_from(o).ok());
    let raw = at
        .and_then(|o| bytes.get(o..o.checked_add(size as usize)?))
        .ok_or(TraceError::IndexOutOfRange { t })?;
    let value = raw
        .iter()
        .rev()
        .fold(0u64, |acc, b| (acc << 8) | u64::from(*b));
    Ok(crate::sim::opacity::slot(
        value,
        (size * 8) as u32,
        attachment.base_triangle,
    ))
}

/// The possible outcomes of a hit at (u, v) ± `delta` on geometry triangle `t`.
pub fn hit_outcomes(
    attachment: &Attachment<'_>,
    t: u64,
    u: f32,
    v: f32,
    delta: f64,
    candidate: &Candidate,
) -> Result<BTreeSet<HitOutcome>, TraceError> {
    let candidate = Candidate {
        has_micromap: true,
        lossy: attachment.lossy,
        ..*candidate
    };
    let slot = fetch_slot(attachment, t)?;
    let (states, cluster_skip): (BTreeSet<OpacityState>, bool) = match slot {
        Slot::Special(special) => match special.state() {
            Some(state) => (BTreeSet::from([state]), false),
            None if attachment.cluster => (BTreeSet::new(), true),
            None => return Err(TraceError::ClusterSkipOutsideCluster { t }),
        },
        Slot::Micromap(_) => {
            let micromap = attachment.micromap.ok_or(TraceError::NoMicromap { t })?;
            (
                micromap
                    .states(slot, u, v, delta)
                    .map_err(TraceError::Lookup)?,
                false,
            )
        }
    };
    Ok(decide(&candidate, &states, cluster_skip))
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::model::accel::INDEX_TYPE_UINT16;
    use crate::model::MicromapTriangle;

    fn micromap() -> MicromapContent {
        MicromapContent::new(
            vec![MicromapTriangle {
                data_offset: 0,
                subdivision_level: 1,
                format: 2,
            }],
            crate::Bytes::from(vec![0b1110_0100u8]),
        )
    }

    fn attachment<'a>(bytes: &'a [u8], micromap: &'a MicromapContent) -> Attachment<'a> {
        Attachment {
            index_type: INDEX_TYPE_UINT16,
            index_bytes: Some(bytes),
            index_stride: 2,
            base_triangle: 0,
            micromap: Some(micromap),
            lossy: false,
            cluster: false,
        }
    }

    fn enabled() -> Candidate {
        Candidate {
            micromaps_enabled: true,
            ..Default::default()
        }
    }

    #[test]
    fn indices_select_micromap_triangles_and_special_states() {
        let m = micromap();
        // Triangle 0 uses micromap triangle 0, triangle 1 is fully opaque (0xFFFE).
        let indices = [0u8, 0, 0xFE, 0xFF];
        let a = attachment(&indices, &m);
        assert_eq!(
            hit_outcomes(&a, 0, 0.1, 0.1, 0.0, &enabled()),
            Ok(BTreeSet::from([HitOutcome::Ignored]))
        );
        assert_eq!(
            hit_outcomes(&a, 0, 0.4, 0.4, 0.0, &enabled()),
            Ok(BTreeSet::from([HitOutcome::Opaque]))
        );
        assert_eq!(
            hit_outcomes(&a, 0, 0.1, 0.8, 0.0, &enabled()),
            Ok(BTreeSet::from([HitOutcome::NonOpaque]))
        );
        assert_eq!(
            hit_outcomes(&a, 1, 0.1, 0.1, 0.0, &enabled()),
            Ok(BTreeSet::from([HitOutcome::Opaque]))
        );
        assert_eq!(
            hit_outcomes(&a, 2, 0.1, 0.1, 0.0, &enabled()),
            Err(TraceError::IndexOutOfRange { t: 2 })
        );
        assert_eq!(
            hit_outcomes(&a, u64::MAX, 0.1, 0.1, 0.0, &enabled()),
            Err(TraceError::IndexOutOfRange { t: u64::MAX })
        );
    }

    #[test]
    fn out_of_range_micromap_indices_and_cluster_skips_are_errors() {
        let m = micromap();
        let indices = [1u8, 0, 0xFB, 0xFF];
        let a = attachment(&indices, &m);
        assert!(matches!(
            hit_outcomes(&a, 0, 0.1, 0.1, 0.0, &enabled()),
            Err(TraceError::Lookup(LookupError::TriangleOutOfRange {
                m: 1,
                count: 1
            }))
        ));
        assert_eq!(
            hit_outcomes(&a, 1, 0.1, 0.1, 0.0, &enabled()),
            Err(TraceError::ClusterSkipOutsideCluster { t: 1 })
        );
        let cluster = Attachment { cluster: true, ..a };
        // -5 in cluster geometry: the geometry's opaque bit decides (here non-opaque).
        assert_eq!(
            hit_outcomes(&cluster, 1, 0.1, 0.1, 0.0, &enabled()),
            Ok(BTreeSet::from([HitOutcome::NonOpaque]))
        );
    }

    #[test]
    fn index_type_none_uses_the_triangle_number() {
        let m = micromap();
        let a = Attachment {
            index_type: INDEX_TYPE_NONE,
            index_bytes: None,
            ..attachment(&[], &m)
        };
        assert_eq!(fetch_slot(&a, 0), Ok(Slot::Micromap(0)));
        let based = Attachment {
            base_triangle: 5,
            ..a
        };
        assert_eq!(fetch_slot(&based, u64::MAX), Ok(Slot::Micromap(u64::MAX)));
        assert_eq!(
            fetch_slot(&Attachment { index_type: 9, ..a }, 0),
            Err(TraceError::IndexType(9))
        );
    }
}
