//! Micro-triangle indexing: the hierarchical curve that numbers the 4^L
//! micro-triangles of a triangle subdivided L times, both ways, and the
//! mapping from hit barycentrics (u, v) to an index with its tie rules.
//!
//! Conventions (the specification's): `u` weighs vertex 1, `v` vertex 2;
//! lattice points are `(i, j) = (u, v) · N` with `N = 2^L`. The upright
//! micro-triangle `U(i, j)` has corners `(i, j), (i+1, j), (i, j+1)`; the
//! inverted `D(i, j)` has `(i+1, j+1), (i, j+1), (i+1, j)`.

use std::cmp::Ordering;
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
    // Cell k touches c when k <= c + eps and k + 1 >= c - eps: the lower
    // end is ceil(c - eps) - 1, so a point on a grid line also visits the
    // cells below or to the left of it.
    let range = |c: f64| -> (i64, i64) {
        (
            ((c - eps).ceil() as i64 - 1).max(0),
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
            let diagonal = fi + fj + 1.0;
            if up.exists(level)
                && x >= fi - eps
                && y >= fj - eps
                && sum_cmp(x, y, diagonal + 2.0 * eps).is_some_and(Ordering::is_le)
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
                && sum_cmp(x, y, diagonal - 2.0 * eps).is_some_and(Ordering::is_ge)
            {
                out.insert(down.index(level));
            }
        }
    }
    Ok(out)
}

/// `x + y` compared with `bound` exactly, without the rounding of the f64
/// sum: a point a hair off a diagonal micro-edge must not be read as on it.
/// Rounding is monotone, so a rounded sum on either side of a representable
/// bound says the exact sum is on that side; a rounded sum equal to it
/// leaves the decision to the rounding error, which the two-sum recovers
/// exactly (Knuth's TwoSum; no overflow at these magnitudes).
/// `None` when anything is NaN (an infinite hit), which no test accepts.
fn sum_cmp(x: f64, y: f64, bound: f64) -> Option<Ordering> {
    let sum = x + y;
    let y_part = sum - x;
    let error = (x - (sum - y_part)) + (y - y_part);
    Some(sum.partial_cmp(&bound)?.then(error.partial_cmp(&0.0)?))
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

    #[test]
    fn exact_ties_list_every_touching_micro_triangle() {
        // (1, 1.5) in lattice units lies on the edge shared by D(0, 1) = 4
        // and U(1, 1) = 5.
        assert_eq!(candidates(0.25, 0.375, 2, 0.0), Ok(BTreeSet::from([4, 5])));
        // The level-1 centre vertex (1, 1)/2 = (0.5, 0.5) is on the triangle's
        // own edge: D(0, 0), U(1, 0) and U(0, 1) touch it.
        assert_eq!(candidates(0.5, 0.5, 1, 0.0), Ok(BTreeSet::from([1, 2, 3])));
        // A hair above the diagonal x + y = 1, closer than an f64 sum
        // resolves: U(0, 0) (index 0) does not contain it.
        let hair = f32::from_bits(1);
        assert_eq!(candidates(0.5, hair, 1, 0.0), Ok(BTreeSet::from([1, 2])));
    }

    /// Where on the triangle a generated point lies.
    #[derive(Clone, Copy, Debug)]
    enum Place {
        Vertex,
        Horizontal,
        Vertical,
        Diagonal,
        EdgeU0,
        EdgeV0,
        Hypotenuse,
        Anywhere,
    }

    /// The micro-triangles whose closed regions contain the point
    /// (x, y) / 2^sub in lattice units, at `level`: integers only.
    fn containing(x: u64, y: u64, sub: u32, level: u32) -> BTreeSet<u32> {
        let (n, scale) = (1u64 << level, 1u64 << sub);
        let mut out = BTreeSet::new();
        let (ci, cj) = (x / scale, y / scale);
        for i in ci.saturating_sub(1)..=ci + 1 {
            for j in cj.saturating_sub(1)..=cj + 1 {
                let (lo_x, lo_y, diagonal) = (i * scale, j * scale, (i + j + 1) * scale);
                let anchor = (u32::try_from(i).unwrap(), u32::try_from(j).unwrap());
                if i + j < n && x >= lo_x && y >= lo_y && x + y <= diagonal {
                    out.insert(up(anchor.0, anchor.1).index(level));
                }
                if i + j + 2 <= n && x <= lo_x + scale && y <= lo_y + scale && x + y >= diagonal {
                    out.insert(down(anchor.0, anchor.1).index(level));
                }
            }
        }
        out
    }

    /// A point at `place`, in units of 2^-sub lattice widths, from two free
    /// numbers.
    fn point(place: Place, level: u32, sub: u32, a: u64, b: u64) -> (u64, u64) {
        let (n, scale) = (1u64 << level, 1u64 << sub);
        let total = n * scale;
        let on_grid = |r: u64, max: u64| (r % (max / scale + 1)) * scale;
        match place {
            Place::Vertex => {
                let x = on_grid(a, total);
                (x, on_grid(b, total - x))
            }
            Place::Horizontal => {
                let y = on_grid(a, total);
                (b % (total - y + 1), y)
            }
            Place::Vertical => {
                let x = on_grid(a, total);
                (x, b % (total - x + 1))
            }
            Place::Diagonal => {
                let sum = on_grid(a, total);
                let x = b % (sum + 1);
                (x, sum - x)
            }
            Place::EdgeU0 => (0, a % (total + 1)),
            Place::EdgeV0 => (a % (total + 1), 0),
            Place::Hypotenuse => {
                let x = a % (total + 1);
                (x, total - x)
            }
            Place::Anywhere => {
                let x = a % (total + 1);
                (x, b % (total - x + 1))
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]

        #[test]
        fn zero_bound_answers_are_the_closed_regions_containing_the_point(
            level in 0u32..=MAX_LEVEL,
            sub in 0u32..=8,
            place in proptest::sample::select(vec![
                Place::Vertex, Place::Horizontal, Place::Vertical, Place::Diagonal,
                Place::EdgeU0, Place::EdgeV0, Place::Hypotenuse, Place::Anywhere,
            ]),
            a in proptest::prelude::any::<u64>(),
            b in proptest::prelude::any::<u64>(),
        ) {
            let (x, y) = point(place, level, sub, a, b);
            let expected = containing(x, y, sub, level);
            proptest::prop_assert!(!expected.is_empty(), "({x}, {y}) is on the triangle");
            // x and y are below 2^21, so u = x / 2^(level + sub) is exact in f32.
            let denominator = f64::from(1u32 << (level + sub));
            let (u, v) = ((x as f64 / denominator) as f32, (y as f64 / denominator) as f32);
            proptest::prop_assert_eq!(candidates(u, v, level, 0.0), Ok(expected));
        }
    }
}
