//! A built opacity micromap's content, decoded on demand: only the
//! micro-triangles a lookup touches are read, so the cost of a simulation
//! follows the hits asked about, not the size of the micromap.

use std::collections::BTreeSet;
use std::sync::Arc;

use crate::model::micromap::opacity_triangle_bytes;
use crate::model::MicromapTriangle;
use crate::sim::index::{self, BaryError};
use crate::sim::opacity::{state_at, OpacityState, Slot};

/// The triangle array and data of one micromap build.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MicromapContent {
    /// `triangleArray`, one entry per micromap triangle.
    pub triangles: Vec<MicromapTriangle>,
    /// The bytes `data` points to (as far as the checker could read them).
    pub data: Arc<[u8]>,
}

/// Why a lookup has no answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LookupError {
    /// The slot names micromap triangle `m`, but the micromap has `count`.
    TriangleOutOfRange { m: u64, count: u64 },
    /// Triangle `m` has a format that is not an opacity format.
    Format { m: u64, format: u16 },
    /// Triangle `m`'s data lies outside the data the checker has.
    DataOutOfRange { m: u64 },
    /// The barycentrics cannot be mapped (NaN, or a level above 12).
    Barycentrics(BaryError),
}

impl MicromapContent {
    /// The bytes of triangle `m`'s states.
    pub fn triangle_data(&self, m: u64) -> Result<(&MicromapTriangle, &[u8]), LookupError> {
        let count = self.triangles.len() as u64;
        let triangle = usize::try_from(m)
            .ok()
            .and_then(|i| self.triangles.get(i))
            .ok_or(LookupError::TriangleOutOfRange { m, count })?;
        let size = opacity_triangle_bytes(
            u32::from(triangle.format),
            u32::from(triangle.subdivision_level),
        )
        .ok_or(LookupError::Format {
            m,
            format: triangle.format,
        })?;
        let start = u64::from(triangle.data_offset);
        let bytes = start
            .checked_add(size)
            .and_then(|end| Some((usize::try_from(start).ok()?, usize::try_from(end).ok()?)))
            .and_then(|(s, e)| self.data.get(s..e))
            .ok_or(LookupError::DataOutOfRange { m })?;
        Ok((triangle, bytes))
    }

    /// The states a hit at (u, v) with barycentric error up to `delta` may
    /// read from the triangle in `slot`.
    pub fn states(
        &self,
        slot: Slot,
        u: f32,
        v: f32,
        delta: f64,
    ) -> Result<BTreeSet<OpacityState>, LookupError> {
        match slot {
            Slot::Special(special) => Ok(special.state().into_iter().collect()),
            Slot::Micromap(m) => {
                let (triangle, bytes) = self.triangle_data(m)?;
                let level = u32::from(triangle.subdivision_level);
                let micro =
                    index::candidates(u, v, level, delta).map_err(LookupError::Barycentrics)?;
                micro
                    .into_iter()
                    .map(|k| {
                        state_at(bytes, u32::from(triangle.format), k)
                            .ok_or(LookupError::DataOutOfRange { m })
                    })
                    .collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::opacity::SpecialIndex;

    fn content() -> MicromapContent {
        // Triangle 0: 4-state level 1 with states T, O, UT, UO; triangle 1:
        // 2-state level 0, opaque; triangle 2: data past the end.
        MicromapContent {
            triangles: vec![
                MicromapTriangle {
                    data_offset: 0,
                    subdivision_level: 1,
                    format: 2,
                },
                MicromapTriangle {
                    data_offset: 1,
                    subdivision_level: 0,
                    format: 1,
                },
                MicromapTriangle {
                    data_offset: 2,
                    subdivision_level: 3,
                    format: 2,
                },
            ],
            data: Arc::from(vec![0b1110_0100u8, 0x01]),
        }
    }

    #[test]
    fn lookups_read_the_micro_triangle_the_hit_is_in() {
        let c = content();
        assert_eq!(
            c.states(Slot::Micromap(0), 0.1, 0.1, 0.0),
            Ok(BTreeSet::from([OpacityState::Transparent]))
        );
        assert_eq!(
            c.states(Slot::Micromap(0), 0.4, 0.4, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
        assert_eq!(
            c.states(Slot::Micromap(0), 0.1, 0.8, 0.0),
            Ok(BTreeSet::from([OpacityState::UnknownOpaque]))
        );
        // On the diagonal edge between micro-triangles 0 and 1, both are possible.
        assert_eq!(
            c.states(Slot::Micromap(0), 0.25, 0.25, 1e-6),
            Ok(BTreeSet::from([
                OpacityState::Transparent,
                OpacityState::Opaque
            ]))
        );
        assert_eq!(
            c.states(Slot::Micromap(1), 0.3, 0.3, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
        assert_eq!(
            c.states(Slot::Special(SpecialIndex::FullyOpaque), 0.3, 0.3, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
    }

    #[test]
    fn bad_slots_and_data_are_errors_not_panics() {
        let c = content();
        assert_eq!(
            c.states(Slot::Micromap(3), 0.1, 0.1, 0.0),
            Err(LookupError::TriangleOutOfRange { m: 3, count: 3 })
        );
        assert_eq!(
            c.states(Slot::Micromap(u64::MAX), 0.1, 0.1, 0.0),
            Err(LookupError::TriangleOutOfRange {
                m: u64::MAX,
                count: 3
            })
        );
        assert_eq!(
            c.states(Slot::Micromap(2), 0.1, 0.1, 0.0),
            Err(LookupError::DataOutOfRange { m: 2 })
        );
        assert_eq!(
            c.states(Slot::Micromap(0), f32::NAN, 0.1, 0.0),
            Err(LookupError::Barycentrics(BaryError::NotANumber))
        );
    }
}
