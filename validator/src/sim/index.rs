//! Micro-triangle indexing: the hierarchical curve that numbers the 4^L
//! micro-triangles of a triangle subdivided L times, both ways, and the
//! mapping from hit barycentrics (u, v) to an index with its tie rules.
//!
//! Conventions (the specification's): `u` weighs vertex 1, `v` vertex 2;
//! lattice points are `(i, j) = (u, v) · N` with `N = 2^L`. The upright
//! micro-triangle `U(i, j)` has corners `(i, j), (i+1, j), (i, j+1)`; the
//! inverted `D(i, j)` has `(i+1, j+1), (i, j+1), (i+1, j)`.

use std::collections::BTreeSet;

/// The highest subdivision level any API allows.
pub const MAX_LEVEL: u32 = 12;

/// A micro-triangle by its lattice anchor and orientation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MicroTriangle {
    pub i: u32,
    pub j: u32,
    pub upright: bool,
}

impl MicroTriangle {
    /// Whether the triangle exists at `level`.
    pub fn exists(self, level: u32) -> bool {
        let n = 1u64 << level.min(MAX_LEVEL);
        let s = u64::from(self.i) + u64::from(self.j);
        if self.upright {
            s < n
        } else {
            s + 1 < n
        }
    }

    /// Discrete barycentrics `(iu, iv, iw)`, which sum to N-1 (upright) or N-2 (inverted).
    /// Wrapping arithmetic: only the low `level` bits matter to the index,
    /// so a triangle that does not exist gives a meaningless index, never a panic.
    pub fn dbary(self, level: u32) -> (u32, u32, u32) {
        let n = 1u32 << level.min(MAX_LEVEL);
        let corner = if self.upright { 1 } else { 2 };
        (
            self.i,
            self.j,
            n.wrapping_sub(corner)
                .wrapping_sub(self.i)
                .wrapping_sub(self.j),
        )
    }

    /// The three corners in barycentrics (u, v): `(i, j), (i+1, j), (i, j+1)`
    /// upright, `(i+1, j+1), (i, j+1), (i+1, j)` inverted, divided by N
    /// (exact, since N is a power of two).
    pub fn vertices(self, level: u32) -> [(f64, f64); 3] {
        let n = f64::from(1u32 << level.min(MAX_LEVEL));
        let (i, j) = (f64::from(self.i), f64::from(self.j));
        let corners = if self.upright {
            [(i, j), (i + 1.0, j), (i, j + 1.0)]
        } else {
            [(i + 1.0, j + 1.0), (i, j + 1.0), (i + 1.0, j)]
        };
        corners.map(|(x, y)| (x / n, y / n))
    }

    /// The curve index of this micro-triangle.
    pub fn index(self, level: u32) -> u32 {
        let (iu, iv, iw) = self.dbary(level);
        index_from_dbary(iu, iv, iw, level)
    }

    /// The micro-triangle with curve index `index` at `level`; `None` when
    /// `index >= 4^level` or the level is above [`MAX_LEVEL`].
    pub fn from_index(index: u32, level: u32) -> Option<Self> {
        if level > MAX_LEVEL || u64::from(index) >= 1u64 << (2 * level) {
            return None;
        }
        let n = 1i64 << level;
        // Ordered corners (roles of vertex 0, 1, 2) in lattice units ×2, so
        // midpoints stay integral down to the finest level.
        let (mut a, mut b, mut c) = ((0i64, 0i64), (2 * n, 0i64), (0i64, 2 * n));
        let mid = |p: (i64, i64), q: (i64, i64)| ((p.0 + q.0) / 2, (p.1 + q.1) / 2);
        for k in (0..level).rev() {
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            (a, b, c) = match (index >> (2 * k)) & 3 {
                0 => (a, ab, ca),
                1 => (ca, bc, ab),
                2 => (ab, b, bc),
                _ => (bc, ca, c),
            };
        }
        let (i, j) = (a.0.min(b.0).min(c.0) / 2, a.1.min(b.1).min(c.1) / 2);
        // Upright: the corner sums exceed 3·(i, j) by (1, 1); inverted by (2, 2).
        let upright = (a.0 + b.0 + c.0) / 2 - 3 * i == 1;
        Some(Self {
            i: u32::try_from(i).ok()?,
            j: u32::try_from(j).ok()?,
            upright,
        })
    }
}

/// The curve index from discrete barycentrics, coarsest level first,
/// carrying the parity of "corner at vertex 2" choices.
pub fn index_from_dbary(iu: u32, iv: u32, iw: u32, level: u32) -> u32 {
    let bit = |x: u32, k: u32| (x >> k) & 1;
    let mut index = 0u32;
    let mut parity = 0u32;
    for k in (0..level.min(MAX_LEVEL)).rev() {
        let (a, b, c) = (bit(iu, k), bit(iv, k), bit(iw, k));
        let digit = if a == c {
            if a != b {
                parity ^= 1;
                3
            } else {
                1
            }
        } else if parity ^ a == 1 {
            2
        } else {
            0
        };
        index = index * 4 + digit;
    }
    index
}

/// The error a hardware hit's barycentrics may carry beyond the exact
/// answer when nothing better is known: a few f32 ulps of 1.
pub const DEFAULT_DELTA: f64 = 4.0 * f32::EPSILON as f64;

/// Why barycentrics could not be mapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaryError {
    /// u or v is NaN: the hit is undefined.
    NotANumber,
    /// The level is above [`MAX_LEVEL`].
    Level,
    /// The error bound spans more than [`MAX_CANDIDATE_SPAN`] micro-triangles
    /// across: every micro-triangle of the triangle is a candidate.
    TooUncertain,
}

/// The widest error bound, in micro-triangle widths, for which [`candidates`]
/// lists cells; beyond it the whole triangle is uncertain (a needle or
/// grazing hit), which callers treat as "any micro-triangle".
pub const MAX_CANDIDATE_SPAN: f64 = 64.0;

/// The specification's mapping of (u, v) to a micro-triangle at `level`,
/// with the diagonal test `ru + rv >= 1` evaluated exactly (the reference
/// code's f32 sum rounds values within 2^-25 below 1 up; see
/// [`reference_f32`]).
pub fn spec_triangle(u: f32, v: f32, level: u32) -> Result<MicroTriangle, BaryError> {
    map(u, v, level, |ru, rv| ru + rv >= 1.0)
}

/// The specification appendix's reference mapping, bit for bit, including
/// its f32 evaluation of the diagonal test.
pub fn reference_f32(u: f32, v: f32, level: u32) -> Result<MicroTriangle, BaryError> {
    map(u, v, level, |ru, rv| (ru as f32) + (rv as f32) >= 1.0)
}

fn map(
    u: f32,
    v: f32,
    level: u32,
    diagonal: impl Fn(f64, f64) -> bool,
) -> Result<MicroTriangle, BaryError> {
    if u.is_nan() || v.is_nan() {
        return Err(BaryError::NotANumber);
    }
    if level > MAX_LEVEL {
        return Err(BaryError::Level);
    }
    let n = f64::from(1u32 << level);
    // Clamp each separately (no renormalisation of u + v); scaling by a
    // power of two is exact, and so are the fractional parts.
    let (fu, fv) = (
        f64::from(u.clamp(0.0, 1.0)) * n,
        f64::from(v.clamp(0.0, 1.0)) * n,
    );
    let (mut i, mut j) = (fu.floor(), fv.floor());
    let (ru, rv) = (fu - i, fv - j);
    let last = n - 1.0;
    i = i.min(last);
    j = j.min(last);
    let upright = if i + j >= n {
        // Beyond the hypotenuse row: slide along u.
        i = last - j;
        true
    } else {
        !(diagonal(ru, rv) && i + j < last)
    };
    // i, j are integers in [0, N-1] here.
    Ok(MicroTriangle {
        i: i as u32,
        j: j as u32,
        upright,
    })
}

/// The curve index the specification gives for (u, v).
pub fn spec_index(u: f32, v: f32, level: u32) -> Result<u32, BaryError> {
    spec_triangle(u, v, level).map(|t| t.index(level))
}

/// Every micro-triangle whose closed region lies within `delta` (in
/// barycentric units) of (u, v), plus the specification's and the f32
/// reference's answers: the indices a conforming implementation may use
/// for a hit whose barycentrics carry an error up to `delta`.
pub fn candidates(u: f32, v: f32, level: u32, delta: f64) -> Result<BTreeSet<u32>, BaryError> {
    let mut out = BTreeSet::new();
    out.insert(spec_triangle(u, v, level)?.index(level));
    out.insert(reference_f32(u, v, level)?.index(level));
    let n = f64::from(1u32 << level);
    // A NaN bound says nothing about where the hit is (and `max` would drop it).
    let eps = if delta.is_nan() {
        f64::INFINITY
    } else {
        delta.max(0.0) * n
    };
    if eps > MAX_CANDIDATE_SPAN {
        return Err(BaryError::TooUncertain);
    }
    // The nearest point of the triangle {x >= 0, y >= 0, x + y <= N}.
    let (mut x, mut y) = (f64::from(u) * n, f64::from(v) * n);
    x = x.max(0.0);
    y = y.max(0.0);
    if x + y > n {
        let excess = (x + y - n) / 2.0;
        (x, y) = ((x - excess).max(0.0), (y - excess).max(0.0));
        if x + y > n {
            (x, y) = (x.min(n), n - x.min(n));
        }
    }
    let range = |c: f64| -> (i64, i64) {
        (
            ((c - eps).floor() as i64).max(0),
            ((c + eps).floor() as i64).min(n as i64 - 1),
        )
    };
    let (i_range, j_range) = (range(x), range(y));
    for i in i_range.0..=i_range.1 {
        for j in j_range.0..=j_range.1 {
            let (fi, fj) = (i as f64, j as f64);
            let up = MicroTriangle {
                i: i as u32,
                j: j as u32,
                upright: true,
            };
            if up.exists(level)
                && x >= fi - eps
                && y >= fj - eps
                && x + y <= fi + fj + 1.0 + 2.0 * eps
            {
                out.insert(up.index(level));
            }
            let down = MicroTriangle {
                upright: false,
                ..up
            };
            if down.exists(level)
                && x <= fi + 1.0 + eps
                && y <= fj + 1.0 + eps
                && x + y >= fi + fj + 1.0 - 2.0 * eps
            {
                out.insert(down.index(level));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn up(i: u32, j: u32) -> MicroTriangle {
        MicroTriangle {
            i,
            j,
            upright: true,
        }
    }

    fn down(i: u32, j: u32) -> MicroTriangle {
        MicroTriangle {
            i,
            j,
            upright: false,
        }
    }

    #[test]
    fn reference_vectors() {
        for (level, t, index) in [
            (1, up(0, 0), 0),
            (1, down(0, 0), 1),
            (1, up(1, 0), 2),
            (1, up(0, 1), 3),
            (2, up(2, 1), 11),
            (2, up(1, 2), 12),
            (2, down(0, 2), 13),
            (2, up(0, 2), 14),
            (3, down(3, 0), 31),
            (3, up(4, 0), 32),
            (12, up(4095, 0), 11_184_810),
            (12, up(0, 4095), 16_777_215),
            (12, down(2047, 2047), 6_990_506),
            (12, up(1234, 567), 3_012_967),
            (12, down(1234, 567), 3_012_962),
        ] {
            assert_eq!(t.index(level), index, "{t:?} at level {level}");
            assert_eq!(
                MicroTriangle::from_index(index, level),
                Some(t),
                "index {index} at level {level}"
            );
        }
    }

    #[test]
    fn level_2_and_3_tables() {
        // Rows from edge V0-V1 (j = 0) upwards, columns left to right
        // alternating upright and inverted.
        let level2: [&[u32]; 4] = [
            &[0, 1, 2, 7, 8, 9, 10],
            &[3, 4, 5, 6, 11],
            &[14, 13, 12],
            &[15],
        ];
        for (j, row) in level2.iter().enumerate() {
            for (c, index) in row.iter().enumerate() {
                let t = MicroTriangle {
                    i: (c / 2) as u32,
                    j: j as u32,
                    upright: c % 2 == 0,
                };
                assert_eq!(t.index(2), *index, "{t:?}");
            }
        }
        assert_eq!(up(0, 7).index(3), 63);
        assert_eq!(down(1, 3).index(3), 18);
        assert_eq!(down(2, 3).index(3), 24);
        assert_eq!(up(7, 0).index(3), 42);
    }

    #[test]
    fn indexing_is_a_bijection_with_a_matching_inverse() {
        for level in 0..=8 {
            let count = 1u32 << (2 * level);
            let mut seen = vec![false; count as usize];
            for index in 0..count {
                let t = MicroTriangle::from_index(index, level).expect("in range");
                assert!(t.exists(level));
                assert_eq!(t.index(level), index);
                assert!(!std::mem::replace(&mut seen[index as usize], true));
            }
            assert_eq!(MicroTriangle::from_index(count, level), None);
        }
    }

    #[test]
    fn continuous_reference_vectors_and_tie_rules() {
        assert_eq!(spec_index(0.3, 0.2, 2), Ok(7));
        assert_eq!(spec_index(0.25, 0.25, 1), Ok(1)); // diagonal edge: inverted
        assert_eq!(spec_index(1.0, 0.0, 3), Ok(42));
        assert_eq!(spec_index(0.0, 0.0, 12), Ok(0));
        assert_eq!(spec_index(0.0, 1.0, 12), Ok(16_777_215));
        assert_eq!(spec_index(1.0 / 3.0, 1.0 / 3.0, 12), Ok(5_592_405));
        assert_eq!(spec_index(0.123_456, 0.654_321, 12), Ok(14_401_640));
        assert_eq!(spec_index(f32::NAN, 0.0, 3), Err(BaryError::NotANumber));
        assert_eq!(spec_index(0.5, 0.5, 13), Err(BaryError::Level));
        // Out-of-range input clamps and slides along u.
        assert_eq!(spec_index(2.0, -1.0, 3), spec_index(1.0, 0.0, 3));
    }

    #[test]
    fn centroids_map_to_their_triangle() {
        for level in 0..=6 {
            let n = f64::from(1u32 << level);
            for index in 0..(1u32 << (2 * level)) {
                let t = MicroTriangle::from_index(index, level).unwrap();
                let (ci, cj) = if t.upright {
                    (f64::from(t.i) + 1.0 / 3.0, f64::from(t.j) + 1.0 / 3.0)
                } else {
                    (f64::from(t.i) + 2.0 / 3.0, f64::from(t.j) + 2.0 / 3.0)
                };
                let (u, v) = ((ci / n) as f32, (cj / n) as f32);
                assert_eq!(spec_index(u, v, level), Ok(index), "level {level} {t:?}");
                assert_eq!(
                    reference_f32(u, v, level).map(|t| t.index(level)),
                    Ok(index)
                );
            }
        }
    }

    #[test]
    fn candidates_contain_the_spec_answer_and_the_edge_neighbours() {
        let set = candidates(0.25, 0.25, 1, 1e-6).unwrap();
        assert!(set.contains(&1));
        assert!(set.contains(&0), "{set:?}");
        let inside = candidates(0.1, 0.1, 1, 1e-6).unwrap();
        assert_eq!(inside, BTreeSet::from([0]));
        // Slightly outside the triangle still finds the nearest micro-triangles.
        let outside = candidates(-1e-7, 0.5, 2, 1e-6).unwrap();
        assert!(outside.contains(&spec_index(0.0, 0.5, 2).unwrap()));
    }
}
