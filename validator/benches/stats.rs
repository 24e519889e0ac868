//! What the state census (`ommcheck stats`) costs: the bytes per second
//! `ommcheck::inspect::stats::census` reads (the micromap's data and its
//! triangle array) for 8 MiB of 2-state or 4-state data at subdivision
//! levels 3, 6, 9 and 12, next to a memcpy of as many bytes in the same
//! run. Issue 18's target: at least half the memcpy's speed.
//!
//! `cargo bench -p ommcheck --bench stats -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use ommcheck::inspect::stats::census;
use ommcheck::model::micromap::opacity_triangle_bytes;
use ommcheck::model::values::{OPACITY_MICROMAP_FORMAT_2_STATE, OPACITY_MICROMAP_FORMAT_4_STATE};
use ommcheck::model::MicromapTriangle;
use ommcheck::sim::decode::MicromapContent;

const DATA_BYTES: u64 = 8 << 20;
const LEVELS: [u16; 4] = [3, 6, 9, 12];

/// 8 MiB of pseudo-random states (a 64-bit LCG: no uniform triangles, no
/// pattern a branch predictor learns) cut into triangles of `level`, one
/// after the other, each referenced once.
fn micromap(format: u32, level: u16) -> (MicromapContent, Vec<u64>) {
    let size = opacity_triangle_bytes(format, u32::from(level)).unwrap_or(1);
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let data: Vec<u8> = (0..DATA_BYTES)
        .map(|_| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (x >> 56) as u8
        })
        .collect();
    let triangles: Vec<MicromapTriangle> = (0..DATA_BYTES / size)
        .map(|m| MicromapTriangle {
            data_offset: (m * size) as u32,
            subdivision_level: level,
            format: format as u16,
        })
        .collect();
    let weights = vec![1; triangles.len()];
    (
        MicromapContent::new(triangles, ommcheck::Bytes::from(data)),
        weights,
    )
}

fn census_throughput(c: &mut Criterion) {
    let mut group = c.benchmark_group("census");
    group.sample_size(20);
    for (format, name) in [
        (OPACITY_MICROMAP_FORMAT_2_STATE, "2-state"),
        (OPACITY_MICROMAP_FORMAT_4_STATE, "4-state"),
    ] {
        for level in LEVELS {
            let (content, weights) = micromap(format, level);
            // The data and the triangle array entries it reads.
            let bytes = DATA_BYTES + 8 * content.triangles.len() as u64;
            group.throughput(Throughput::Bytes(bytes));
            let value = format!("L{level}-N{}", content.triangles.len());
            let id = BenchmarkId::new(format!("census-{name}"), &value);
            group.bench_function(id, |b| {
                b.iter(|| census(black_box(&content), black_box(&weights)))
            });
            drop(content);

            let source = vec![0x5au8; bytes as usize];
            let mut destination = vec![0u8; bytes as usize];
            let id = BenchmarkId::new(format!("memcpy-{name}"), &value);
            group.bench_function(id, |b| {
                b.iter(|| destination.copy_from_slice(black_box(&source)))
            });
            black_box(&destination);
        }
    }
    group.finish();
}

criterion_group!(benches, census_throughput);
criterion_main!(benches);
