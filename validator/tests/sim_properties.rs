//! Properties of the simulator's numerics that must hold for every input,
//! including the hard ones: level 12, points on edges and vertices,
//! barycentrics outside the triangle, huge index values.

use ommcheck::sim::index::{self, MicroTriangle, MAX_LEVEL};
use ommcheck::sim::opacity::{slot, Slot};
use proptest::prelude::*;

fn level_and_index() -> impl Strategy<Value = (u32, u32)> {
    (0..=MAX_LEVEL).prop_flat_map(|level| (Just(level), 0..(1u32 << (2 * level))))
}

proptest! {
    #[test]
    fn index_round_trips((level, i) in level_and_index()) {
        let t = MicroTriangle::from_index(i, level).unwrap();
        prop_assert!(t.exists(level));
        prop_assert_eq!(t.index(level), i);
    }

    /// A point strictly inside a micro-triangle, farther than `margin` from
    /// its edges, maps to it; and the ambiguity set at a smaller tolerance is
    /// that triangle alone.
    #[test]
    fn interior_points_map_to_their_triangle((level, i) in level_and_index(), a in 0.05f64..0.9, b in 0.05f64..0.9) {
        prop_assume!(a + b < 0.95);
        let t = MicroTriangle::from_index(i, level).unwrap();
        let n = f64::from(1u32 << level);
        // Barycentric position inside the unit micro-triangle, then placed.
        let (x, y) = if t.upright {
            (f64::from(t.i) + a, f64::from(t.j) + b)
        } else {
            (f64::from(t.i) + 1.0 - a, f64::from(t.j) + 1.0 - b)
        };
        let (u, v) = ((x / n) as f32, (y / n) as f32);
        // f32 rounding moves the point by at most 2^-24 relative; stay well inside.
        let margin = a.min(b).min(1.0 - a - b);
        prop_assume!(margin > 1e-3);
        prop_assert_eq!(index::spec_index(u, v, level), Ok(i));
        let set = index::candidates(u, v, level, margin / n / 4.0).unwrap();
        prop_assert_eq!(set.into_iter().collect::<Vec<_>>(), vec![i]);
    }

    /// Any finite input, in or out of the triangle, gives an index in range,
    /// and the ambiguity set contains both reference answers.
    #[test]
    fn every_input_gives_an_index_in_range(level in 0..=MAX_LEVEL, u in -0.5f32..1.5, v in -0.5f32..1.5, delta in 0.0f64..1e-3) {
        let spec = index::spec_index(u, v, level).unwrap();
        prop_assert!(u64::from(spec) < 1u64 << (2 * level));
        let reference = index::reference_f32(u, v, level).unwrap().index(level);
        let set = index::candidates(u, v, level, delta).unwrap();
        prop_assert!(set.contains(&spec) && set.contains(&reference));
        prop_assert!(set.iter().all(|k| u64::from(*k) < 1u64 << (2 * level)));
    }

    /// Points exactly on micro-edges and vertices have several candidates
    /// under any positive tolerance, one of which is the spec's answer.
    #[test]
    fn lattice_points_are_ambiguous(level in 1..=MAX_LEVEL, i in 0u32..4096, j in 0u32..4096) {
        let n = 1u32 << level;
        let (i, j) = (i % n, j % n);
        prop_assume!(i + j <= n);
        let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
        let set = index::candidates(u, v, level, 1e-9).unwrap();
        prop_assert!(set.contains(&index::spec_index(u, v, level).unwrap()));
        // Every lattice point but the corner (0, 0) touches two or more micro-triangles.
        prop_assert!((i, j) == (0, 0) || set.len() >= 2, "{:?}", set);
    }

    /// Index values are special only at the top five values of their width;
    /// everything else adds baseTriangle without wrapping.
    #[test]
    fn slots_never_wrap(raw in any::<u32>(), base in any::<u32>()) {
        match slot(u64::from(raw), 32, base) {
            Slot::Micromap(m) => {
                prop_assert!(raw < u32::MAX - 4);
                prop_assert_eq!(m, u64::from(raw) + u64::from(base));
            }
            Slot::Special(s) => prop_assert_eq!(i64::from(raw as i32), s.value()),
        }
    }
}

fn vertex() -> impl Strategy<Value = glam::DVec3> {
    (-100.0f64..100.0, -100.0f64..100.0, -100.0f64..100.0)
        .prop_map(|(x, y, z)| glam::DVec3::new(x, y, z))
}

proptest! {
    /// Rotating a triangle's vertex order must not change whether or where
    /// a ray hits it; the barycentrics rotate with the vertices (u, v of the
    /// rotated triangle are v and w = 1 - u - v of the original), which is
    /// why opacity lookups do depend on the order the index buffer gives.
    #[test]
    fn vertex_rotation_moves_barycentrics_not_hits(v0 in vertex(), v1 in vertex(), v2 in vertex(), a in 0.05f64..0.9, b in 0.05f64..0.9) {
        use ommcheck::sim::intersect::{intersect, Ray};
        prop_assume!(a + b < 0.95);
        let normal = (v1 - v0).cross(v2 - v0);
        prop_assume!(normal.length() > 1e-3);
        let target = v0 + (v1 - v0) * a + (v2 - v0) * b;
        let ray = Ray { origin: target + normal.normalize(), direction: -normal.normalize(), t_min: 0.0, t_max: 10.0 };
        let hit = intersect(&ray, v0, v1, v2).unwrap();
        let rotated = intersect(&ray, v1, v2, v0).unwrap();
        let (Some(hit), Some(rotated)) = (hit, rotated) else {
            return Err(TestCaseError::fail("an interior point was missed"));
        };
        let tolerance = hit.delta + rotated.delta + 1e-9;
        prop_assert!((hit.t - rotated.t).abs() <= 1e-9 * (1.0 + hit.t.abs()));
        prop_assert!((rotated.u - hit.v).abs() <= tolerance);
        prop_assert!((rotated.v - (1.0 - hit.u - hit.v)).abs() <= tolerance);
    }
}
