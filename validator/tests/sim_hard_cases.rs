//! The numerically hard cases, each by name: corners, edges and vertices at
//! level 12, barycentrics just outside the triangle, needle and huge
//! triangles, grazing rays, NaN and infinity, and integer overflow.

use glam::DVec3;
use ommcheck::model::micromap::opacity_triangle_bytes;
use ommcheck::model::{MicromapTriangle, MicromapUsage, UsageCounts};
use ommcheck::sim::decode::{LookupError, MicromapContent};
use ommcheck::sim::index::{candidates, spec_index, BaryError, DEFAULT_DELTA};
use ommcheck::sim::intersect::{intersect, IntersectError, Ray};
use ommcheck::sim::opacity::{slot, Slot};

const L12_TRIANGLES: u32 = 1 << 24;

#[test]
fn corner_hits_at_level_12() {
    assert_eq!(spec_index(0.0, 0.0, 12), Ok(0));
    assert_eq!(spec_index(1.0, 0.0, 12), Ok(11_184_810));
    assert_eq!(spec_index(0.0, 1.0, 12), Ok(L12_TRIANGLES - 1));
}

#[test]
fn micro_edges_and_vertices_at_level_12_are_ambiguous() {
    let n = 4096.0f32;
    // A vertical micro-edge, a horizontal one, a diagonal one, and a micro-vertex.
    for (u, v) in [
        (1000.0 / n, 7.3 / n),
        (7.3 / n, 1000.0 / n),
        (1000.5 / n, 999.5 / n),
        (1000.0 / n, 1000.0 / n),
    ] {
        let set = candidates(u, v, 12, DEFAULT_DELTA).unwrap();
        assert!(set.len() >= 2, "({u}, {v}) gave {set:?}");
        assert!(set.contains(&spec_index(u, v, 12).unwrap()));
        assert!(set.iter().all(|i| *i < L12_TRIANGLES));
    }
}

#[test]
fn barycentrics_summing_slightly_above_one() {
    let (u, v) = (0.5f32, 0.500_001f32);
    let spec = spec_index(u, v, 12).unwrap();
    assert!(spec < L12_TRIANGLES);
    let set = candidates(u, v, 12, DEFAULT_DELTA).unwrap();
    assert!(set.contains(&spec));
    // The nearest point of the triangle is on its hypotenuse; its micro-triangles are candidates.
    assert!(set.contains(&spec_index(0.5, 0.5, 12).unwrap()), "{set:?}");
}

#[test]
fn slightly_negative_barycentrics() {
    let set = candidates(-1e-7, 0.25, 12, DEFAULT_DELTA).unwrap();
    assert!(set.contains(&spec_index(0.0, 0.25, 12).unwrap()));
    assert_eq!(spec_index(-1e-7, 0.25, 12), spec_index(0.0, 0.25, 12));
}

#[test]
fn huge_error_bounds_mean_the_whole_triangle() {
    assert_eq!(candidates(0.5, 0.25, 12, 0.5), Err(BaryError::TooUncertain));
    assert_eq!(
        candidates(0.5, 0.25, 12, f64::NAN),
        Err(BaryError::TooUncertain)
    );
    // At level 2 the same bound spans only 2 micro-triangles: listed.
    assert!(candidates(0.5, 0.25, 2, 0.5).is_ok());
}

#[test]
fn nan_and_infinity() {
    assert_eq!(spec_index(f32::NAN, 0.1, 3), Err(BaryError::NotANumber));
    assert_eq!(
        candidates(0.1, f32::NAN, 3, DEFAULT_DELTA),
        Err(BaryError::NotANumber)
    );
    // Infinity clamps like any out-of-range value: it is a number.
    assert_eq!(spec_index(f32::INFINITY, 0.0, 3), spec_index(1.0, 0.0, 3));
    let ray = Ray {
        origin: DVec3::new(0.1, 0.1, 1.0),
        direction: DVec3::NEG_Z,
        t_min: 0.0,
        t_max: f64::INFINITY,
    };
    let bad = DVec3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        intersect(&ray, bad, DVec3::X, DVec3::Y),
        Err(IntersectError::NotFinite)
    );
    assert_eq!(
        intersect(
            &Ray {
                direction: DVec3::new(0.0, 0.0, f64::NEG_INFINITY),
                ..ray
            },
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y
        ),
        Err(IntersectError::NotFinite)
    );
}

fn triangle_at(offset: DVec3, scale: f64) -> [DVec3; 3] {
    [offset, offset + DVec3::X * scale, offset + DVec3::Y * scale]
}

#[test]
fn vertices_far_from_the_origin() {
    let offset = DVec3::new(1e7, -1e7, 3e7);
    let [v0, v1, v2] = triangle_at(offset, 1.0);
    let ray = Ray {
        origin: offset + DVec3::new(0.3, 0.2, 1.0),
        direction: DVec3::NEG_Z,
        t_min: 0.0,
        t_max: 2.0,
    };
    let hit = intersect(&ray, v0, v1, v2).unwrap().expect("hit");
    assert!((hit.u - 0.3).abs() <= hit.delta.max(1e-9), "{hit:?}");
    assert!((hit.v - 0.2).abs() <= hit.delta.max(1e-9), "{hit:?}");
}

#[test]
fn needle_and_near_zero_area_triangles() {
    // Exactly degenerate: never hit (a == 0 is culled).
    let [v0, v1, _] = triangle_at(DVec3::ZERO, 1.0);
    let ray = Ray {
        origin: DVec3::new(0.5, 0.0, 1.0),
        direction: DVec3::NEG_Z,
        t_min: 0.0,
        t_max: 2.0,
    };
    assert_eq!(intersect(&ray, v0, v1, v1 * 2.0), Ok(None));
    // A needle: its barycentrics are uncertain, so many micro-triangles are candidates.
    let needle = DVec3::new(0.0, 1e-9, 0.0);
    let ray = Ray {
        origin: DVec3::new(0.25, 0.5e-9, 1.0),
        ..ray
    };
    if let Some(hit) = intersect(&ray, v0, v1, needle).unwrap() {
        match candidates(hit.u as f32, hit.v as f32, 12, hit.delta) {
            Ok(set) => assert!(set.len() > 1, "{hit:?} {set:?}"),
            // So uncertain that any micro-triangle of the triangle may be hit.
            Err(e) => assert_eq!(e, BaryError::TooUncertain, "{hit:?}"),
        }
    }
}

#[test]
fn grazing_rays() {
    let [v0, v1, v2] = triangle_at(DVec3::ZERO, 1.0);
    // Almost parallel to the triangle's plane.
    let direction = DVec3::new(1.0, 0.0, -1e-9).normalize();
    let ray = Ray {
        origin: DVec3::new(-0.5, 0.25, 0.5e-9),
        direction,
        t_min: 0.0,
        t_max: 10.0,
    };
    if let Some(hit) = intersect(&ray, v0, v1, v2).unwrap() {
        assert!(hit.u.is_finite() && hit.v.is_finite() && hit.delta >= 0.0);
        match candidates(hit.u as f32, hit.v as f32, 12, hit.delta) {
            Ok(set) => assert!(set.contains(&spec_index(hit.u as f32, hit.v as f32, 12).unwrap())),
            Err(e) => assert_eq!(e, BaryError::TooUncertain, "{hit:?}"),
        }
    }
}

#[test]
fn level_12_blocks_and_offsets_near_2_pow_32() {
    assert_eq!(opacity_triangle_bytes(2, 12), Some(4 << 20));
    assert_eq!(opacity_triangle_bytes(1, 12), Some(2 << 20));
    // A level-12 block at dataOffset u32::MAX - 1 ends past 2^32 without wrapping.
    let content = MicromapContent::new(
        vec![MicromapTriangle {
            data_offset: u32::MAX - 1,
            subdivision_level: 12,
            format: 2,
        }],
        ommcheck::Bytes::from(vec![0u8; 16]),
    );
    assert_eq!(
        content.states(Slot::Micromap(0), 0.1, 0.1, 0.0),
        Err(LookupError::DataOutOfRange { m: 0 })
    );
}

#[test]
fn base_triangle_near_2_pow_32() {
    assert_eq!(
        slot(0xFFFF_FFF0, 32, u32::MAX),
        Slot::Micromap(0xFFFF_FFF0 + u64::from(u32::MAX))
    );
    assert_eq!(
        slot(0xFFFA, 16, u32::MAX),
        Slot::Micromap(0xFFFA + u64::from(u32::MAX))
    );
}

#[test]
fn usage_counts_summing_past_2_pow_32() {
    let usage = |count| MicromapUsage {
        count,
        subdivision_level: 0,
        format: 2,
    };
    let counts = UsageCounts::array(vec![usage(u32::MAX), usage(u32::MAX), usage(2)]);
    assert_eq!(counts.total(), 2 * u64::from(u32::MAX) + 2);
}
