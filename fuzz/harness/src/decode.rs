//! Target (b), the content decoder: arbitrary triangle arrays, data, data
//! offsets, levels and formats, and index buffers with arbitrary types,
//! strides and base triangles. Oracle: a slow decoder written here from the
//! specification's layout (each triangle's states are `4^level` values of
//! 1 or 2 bits, packed from the least significant bit of each byte at
//! `dataOffset`; an index is read little-endian at `t × stride`, and is
//! special when it is the unsigned cast of -1..-5 at its width), so every
//! answer of `ommcheck::sim` is checked, not only that it returns.

use std::collections::BTreeSet;

use ommcheck::model::accel::{
    INDEX_TYPE_NONE, INDEX_TYPE_UINT16, INDEX_TYPE_UINT32, INDEX_TYPE_UINT8,
};
use ommcheck::model::MicromapTriangle;
use ommcheck::sim::decode::{LookupError, MicromapContent, WorkCounters};
use ommcheck::sim::index::{self, BaryError};
use ommcheck::sim::opacity::{OpacityState, Slot, SpecialIndex};
use ommcheck::sim::trace::{fetch_slot, hit_outcomes, Attachment, TraceError};

use crate::input::Input;

pub fn run(data: &[u8]) {
    let first = body(data);
    let second = body(data);
    assert_eq!(first, second, "the same input decoded differently");
}

/// A level: mostly 0..=13 (12 is the largest valid one), sometimes any u16.
fn level(input: &mut Input<'_>) -> u16 {
    let l = input.u8();
    if l & 0x80 != 0 {
        input.u16()
    } else {
        u16::from(l % 14)
    }
}

fn format(input: &mut Input<'_>) -> u16 {
    match input.below(4) {
        0 | 1 => 1,
        2 => 2,
        _ => input.u16(),
    }
}

fn body(data: &[u8]) -> String {
    let mut input = Input::new(data);
    let mut out = String::new();
    let count = input.below(5) as usize;
    let triangles: Vec<MicromapTriangle> = (0..count)
        .map(|_| MicromapTriangle {
            data_offset: input.u32_mostly_below(256),
            subdivision_level: level(&mut input),
            format: format(&mut input),
        })
        .collect();
    let len = usize::from(input.u16() % 4096);
    let seed = input.bytes(64);
    // The data: the input's bytes, repeated to the length asked for.
    let bytes: Vec<u8> = (0..len)
        .map(|k| seed.get(k % seed.len().max(1)).copied().unwrap_or(0))
        .collect();
    let data_start = usize::from(input.u16());
    let mut content =
        MicromapContent::at(triangles.clone(), ommcheck::Bytes::from(bytes), data_start);
    if input.below(4) == 0 {
        let repeat = input.u64_mostly_below(256);
        content = content.repeating(repeat);
    }
    let data_bytes = content.data_bytes().to_vec();
    assert_eq!(
        data_bytes,
        content
            .data
            .get(data_start.min(content.data.len())..)
            .unwrap_or(&[]),
        "data_bytes is not the data from data_start on"
    );

    // Lookups of the micromap's triangles (and a few past its end).
    for _ in 0..3 {
        let m = input.u64_mostly_below(8);
        let got = content.triangle_data(m);
        let want = slow_triangle(&content, m);
        match (&got, &want) {
            (Ok((t, b)), Ok((wt, wb))) => {
                assert_eq!((*t, *b), (*wt, &wb[..]), "triangle {m}'s data");
            }
            (Err(e), Err(w)) => assert_eq!(error_kind(e), *w, "triangle {m}: {e:?}"),
            _ => panic!("triangle {m}: decoder {got:?}, slow decoder {want:?}"),
        }
        out += &format!("{got:?}\n");
        let (u, v) = (input.f32(), input.f32());
        let delta = match input.below(4) {
            0 => 0.0,
            1 => index::DEFAULT_DELTA,
            2 => f64::from(input.u8()) / 1024.0,
            _ => input.f64(),
        };
        let mut work = WorkCounters::default();
        let states = content.states_counted(Slot::Micromap(m), u, v, delta, &mut work);
        out += &format!("{states:?} {work:?}\n");
        match (&states, &want) {
            (Ok((micro, states)), Ok((t, bytes))) => {
                let level = u32::from(t.subdivision_level);
                let format = t.format;
                assert!(level <= index::MAX_LEVEL, "a state read at level {level}");
                let all = 1u64 << (2 * level);
                assert!(
                    micro.iter().all(|k| u64::from(*k) < all),
                    "{micro:?} at level {level}"
                );
                if micro.is_empty() {
                    // Too uncertain: every state the triangle holds.
                    if level <= 8 {
                        let want: BTreeSet<u8> = (0..all as u32)
                            .map(|k| slow_state(bytes, format, k))
                            .collect();
                        assert_eq!(codes(states), want, "all states of triangle {m}");
                    }
                } else {
                    let want: BTreeSet<u8> = micro
                        .iter()
                        .map(|k| slow_state(bytes, format, *k))
                        .collect();
                    assert_eq!(codes(states), want, "states of {micro:?} in triangle {m}");
                    let spec = index::spec_index(u, v, level).expect("finite u, v");
                    assert!(
                        micro.contains(&spec),
                        "the spec's {spec} is not in {micro:?}"
                    );
                }
            }
            (Err(LookupError::Barycentrics(BaryError::NotANumber)), Ok(_)) => {
                assert!(u.is_nan() || v.is_nan());
            }
            (Err(LookupError::Barycentrics(BaryError::Level)), Ok((t, _))) => {
                assert!(u32::from(t.subdivision_level) > index::MAX_LEVEL);
            }
            (Err(e), Err(w)) => assert_eq!(error_kind(e), *w),
            _ => panic!("states of triangle {m}: {states:?}, slow decoder {want:?}"),
        }
        if let Ok((t, _)) = &want {
            if u.is_finite() && v.is_finite() && u32::from(t.subdivision_level) <= index::MAX_LEVEL
            {
                check_spec_triangle(u, v, u32::from(t.subdivision_level));
            }
        }
    }

    // Index buffers.
    let index_type = match input.below(5) {
        0 => INDEX_TYPE_NONE,
        1 => INDEX_TYPE_UINT8,
        2 => INDEX_TYPE_UINT16,
        3 => INDEX_TYPE_UINT32,
        _ => input.i32(),
    };
    let index_len = usize::from(input.u8());
    let index_bytes: Vec<u8> = input.bytes(index_len).to_vec();
    let readable = input.below(8) != 0;
    let attachment = Attachment {
        index_type,
        index_bytes: readable.then_some(&index_bytes[..]),
        index_stride: input.u64_mostly_below(8),
        base_triangle: input.u32_mostly_below(256),
        micromap: input.bool().then_some(&content),
        lossy: input.bool(),
        cluster: input.bool(),
    };
    for _ in 0..3 {
        let t = input.u64_mostly_below(256);
        let got = fetch_slot(&attachment, t);
        let want = slow_slot(&attachment, t);
        assert_eq!(got, want, "slot of triangle {t} ({attachment:?})");
        let candidate = ommcheck::sim::opacity::Candidate {
            micromaps_enabled: input.bool(),
            geometry_opaque: input.bool(),
            ..Default::default()
        };
        let outcomes = hit_outcomes(&attachment, t, input.f32(), input.f32(), 0.0, &candidate);
        out += &format!("{got:?} {outcomes:?}\n");
    }
    out
}

/// The kind of a lookup error, as the slow decoder names it.
fn error_kind(e: &LookupError) -> &'static str {
    match e {
        LookupError::TriangleOutOfRange { .. } => "range",
        LookupError::Format { .. } => "format",
        LookupError::DataOutOfRange { .. } => "data",
        LookupError::Barycentrics(_) => "barycentrics",
    }
}

fn codes(states: &BTreeSet<OpacityState>) -> BTreeSet<u8> {
    states.iter().map(|s| *s as u8).collect()
}

/// Triangle `m`'s entry and the bytes of its states, the slow way: the
/// entry is `m` (or 0 for a stride-0 build of `count` triangles), its size
/// `ceil(4^level × bits / 8)` bytes, computed in 128 bits.
fn slow_triangle(
    content: &MicromapContent,
    m: u64,
) -> Result<(MicromapTriangle, Vec<u8>), &'static str> {
    let count = content.repeated.unwrap_or(content.triangles.len() as u64);
    if m >= count {
        return Err("range");
    }
    let entry = if content.repeated.is_some() {
        0
    } else {
        m as usize
    };
    let t = content.triangles.get(entry).ok_or("range")?;
    let bits: u128 = match t.format {
        1 => 1,
        2 => 2,
        _ => return Err("format"),
    };
    let level = u128::from(t.subdivision_level);
    if 2 * level + bits > 120 {
        // Far more than any memory: sized as no data can hold it (or not at all).
        return Err(if 2 * level + bits > 67 {
            "format"
        } else {
            "data"
        });
    }
    let size = ((1u128 << (2 * level)) * bits).div_ceil(8);
    let start = u128::from(t.data_offset);
    let data = content.data_bytes();
    if size > u128::from(u64::MAX) {
        return Err("format");
    }
    if start + size > data.len() as u128 {
        return Err("data");
    }
    Ok((t, data[start as usize..(start + size) as usize].to_vec()))
}

/// State `k` of one triangle's bytes: bit `k` (2-state) or bits `2k, 2k+1`
/// (4-state), counting from the least significant bit of byte 0.
fn slow_state(bytes: &[u8], format: u16, k: u32) -> u8 {
    let k = k as usize;
    if format == 1 {
        (bytes[k / 8] >> (k % 8)) & 1
    } else {
        (bytes[k / 4] >> (2 * (k % 4))) & 3
    }
}

/// The slot of triangle `t`, the slow way (the value read sign-extended
/// from its width; -1..-5 are the special indices).
fn slow_slot(a: &Attachment<'_>, t: u64) -> Result<Slot, TraceError> {
    if a.index_type == INDEX_TYPE_NONE {
        return Ok(Slot::Micromap(t.saturating_add(u64::from(a.base_triangle))));
    }
    let size: u128 = match a.index_type {
        INDEX_TYPE_UINT8 => 1,
        INDEX_TYPE_UINT16 => 2,
        INDEX_TYPE_UINT32 => 4,
        other => return Err(TraceError::IndexType(other)),
    };
    let bytes = a.index_bytes.ok_or(TraceError::IndexUnreadable)?;
    let at = u128::from(t) * u128::from(a.index_stride);
    if at + size > bytes.len() as u128 {
        return Err(TraceError::IndexOutOfRange { t });
    }
    let mut value: u64 = 0;
    for k in 0..size as usize {
        value |= u64::from(bytes[at as usize + k]) << (8 * k);
    }
    let width = 8 * size as u32;
    let signed = ((value << (64 - width)) as i64) >> (64 - width);
    Ok(match signed {
        -1 => Slot::Special(SpecialIndex::FullyTransparent),
        -2 => Slot::Special(SpecialIndex::FullyOpaque),
        -3 => Slot::Special(SpecialIndex::FullyUnknownTransparent),
        -4 => Slot::Special(SpecialIndex::FullyUnknownOpaque),
        -5 => Slot::Special(SpecialIndex::ClusterGeometryDisableOpacityMicromap),
        _ => Slot::Micromap(value + u64::from(a.base_triangle)),
    })
}

/// The micro-triangle the specification maps (u, v) to contains the point
/// (each coordinate clamped to [0, 1]) when the point is on the triangle,
/// and its index maps back to it. Scaling by 2^level is exact in f64.
pub fn check_spec_triangle(u: f32, v: f32, level: u32) {
    let t = index::spec_triangle(u, v, level).expect("finite u, v and a valid level");
    assert_eq!(
        index::MicroTriangle::from_index(t.index(level), level),
        Some(t),
        "index of {t:?} at level {level} does not map back"
    );
    let n = f64::from(1u32 << level);
    let (x, y) = (
        f64::from(u.clamp(0.0, 1.0)) * n,
        f64::from(v.clamp(0.0, 1.0)) * n,
    );
    if x + y > n {
        return; // Off the triangle: the spec slides it onto the last row.
    }
    let (i, j) = (f64::from(t.i), f64::from(t.j));
    let inside = if t.upright {
        x >= i && y >= j && x + y <= i + j + 1.0
    } else {
        x <= i + 1.0 && y <= j + 1.0 && x + y >= i + j + 1.0
    };
    assert!(inside, "({u}, {v}) is not in {t:?} at level {level}");
}
