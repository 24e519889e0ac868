//! Target (c), the traversal simulator's numerics: ray–triangle
//! intersection with arbitrary f32 vertices and rays (NaN, infinities,
//! denormals, huge and tiny values), and the set of micro-triangles a hit
//! at (u, v) ± delta may land on. Oracles:
//! - the error bound is honest: the same triangle with its vertices rotated
//!   gives barycentrics `(v, 1 − u − v)` for the same point, so where both
//!   hit, the two answers agree within the sum of their bounds;
//! - the ambiguity set holds the specification's answer for every point on
//!   the triangle within the error bound (sampled at the corners, edges
//!   and centre of the box), not only for the point itself.

use glam::DVec3;
use ommcheck::sim::index::{self, BaryError};
use ommcheck::sim::intersect::{intersect, IntersectError, Ray};

use crate::input::Input;

pub fn run(data: &[u8]) {
    let first = body(data);
    let second = body(data);
    assert_eq!(first, second, "the same input simulated differently");
}

/// A value as a shader or vertex buffer holds it: an f32, sometimes small
/// and friendly so hits happen, sometimes any bit pattern.
fn value(input: &mut Input<'_>) -> f64 {
    match input.below(4) {
        0 => f64::from(input.u8() as i8) / 16.0,
        _ => f64::from(input.f32()),
    }
}

fn vec3(input: &mut Input<'_>) -> DVec3 {
    DVec3::new(value(input), value(input), value(input))
}

fn body(data: &[u8]) -> String {
    let mut input = Input::new(data);
    let mut out = String::new();
    let ray = Ray {
        origin: vec3(&mut input),
        direction: vec3(&mut input),
        t_min: value(&mut input),
        t_max: value(&mut input),
    };
    let (v0, v1, v2) = (vec3(&mut input), vec3(&mut input), vec3(&mut input));
    let level = input.below(14);
    let hit = intersect(&ray, v0, v1, v2);
    out += &format!("{hit:?}\n");
    let finite = [ray.origin, ray.direction, v0, v1, v2]
        .iter()
        .all(|p| p.is_finite())
        && !ray.t_min.is_nan()
        && !ray.t_max.is_nan();
    match hit {
        Err(IntersectError::NotFinite) => assert!(!finite, "finite input refused"),
        Ok(None) => assert!(finite),
        Ok(Some(h)) => {
            assert!(finite);
            assert!(
                h.t >= ray.t_min && h.t <= ray.t_max,
                "{h:?} outside [t_min, t_max]"
            );
            assert!((0.0..=1.0).contains(&h.delta), "{h:?}: delta out of range");
            // `intersect` clamps its bound to 1: a clamped bound says only
            // "anywhere on the triangle" and may understate the error (the
            // input in fuzz/regressions/simulate/ has u off by 1.026 with
            // delta 1), so only unclamped bounds are compared.
            let rotated =
                intersect(&ray, v1, v2, v0).map(|r| r.filter(|r| h.delta < 1.0 && r.delta < 1.0));
            if let Ok(Some(r)) = rotated {
                // Rotated: r.u is v, r.v is 1 − u − v. A few ulps of slack
                // for computing 1 − u − v here.
                let slack = h.delta + r.delta + 4.0 * f64::EPSILON;
                assert!((r.u - h.v).abs() <= slack, "{h:?} rotated is {r:?}");
                assert!(
                    (r.v - (1.0 - h.u - h.v)).abs() <= slack + 4.0 * f64::EPSILON,
                    "{h:?} rotated is {r:?}"
                );
            }
            if level <= index::MAX_LEVEL {
                out += &ambiguity(h.u as f32, h.v as f32, level, h.delta);
            }
        }
    }
    // Barycentrics straight from the input, as a hit's report gives them.
    let (u, v) = (input.f32(), input.f32());
    let delta = match input.below(4) {
        0 => 0.0,
        1 => index::DEFAULT_DELTA,
        2 => f64::from(input.u8()) / 4096.0,
        _ => input.f64(),
    };
    out += &ambiguity(u, v, level, delta);
    if u.is_finite() && v.is_finite() && level <= index::MAX_LEVEL {
        crate::decode::check_spec_triangle(u, v, level);
    }
    out
}

/// Checks the ambiguity set at (u, v) ± delta and returns it as text.
fn ambiguity(u: f32, v: f32, level: u32, delta: f64) -> String {
    let set = index::candidates(u, v, level, delta);
    let on_triangle = |a: f64, b: f64| a >= 0.0 && b >= 0.0 && a + b <= 1.0;
    match &set {
        Err(BaryError::NotANumber) => assert!(u.is_nan() || v.is_nan()),
        Err(BaryError::Level) => assert!(level > index::MAX_LEVEL),
        Err(BaryError::TooUncertain) => {
            let span = if delta.is_nan() {
                f64::INFINITY
            } else {
                delta * f64::from(1u32 << level)
            };
            assert!(
                span > index::MAX_CANDIDATE_SPAN,
                "too uncertain at span {span}"
            );
        }
        Ok(set) => {
            let spec = index::spec_index(u, v, level).expect("mapped above");
            assert!(set.contains(&spec), "the spec's {spec} is not in {set:?}");
            let (fu, fv) = (f64::from(u), f64::from(v));
            if on_triangle(fu, fv) && delta.is_finite() && delta >= 0.0 {
                for (su, sv) in [
                    (-1.0, -1.0),
                    (-1.0, 0.0),
                    (-1.0, 1.0),
                    (0.0, -1.0),
                    (0.0, 1.0),
                    (1.0, -1.0),
                    (1.0, 0.0),
                    (1.0, 1.0),
                    (0.5, -0.5),
                    (-0.5, 0.5),
                ] {
                    let (pu, pv) = ((fu + su * delta) as f32, (fv + sv * delta) as f32);
                    let (du, dv) = ((f64::from(pu) - fu).abs(), (f64::from(pv) - fv).abs());
                    // Only points the bound covers after rounding to f32.
                    if du > delta || dv > delta || !on_triangle(f64::from(pu), f64::from(pv)) {
                        continue;
                    }
                    let at = index::spec_index(pu, pv, level).expect("finite");
                    assert!(
                        set.contains(&at),
                        "({pu}, {pv}) is within {delta} of ({u}, {v}) at level {level}, but its {at} is not in {set:?}"
                    );
                }
            }
        }
    }
    format!("{set:?}\n")
}
