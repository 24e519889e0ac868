//! What reading contents costs: (b) the bytes the content tier reads per
//! second for one EXT micromap build (its triangle array: the data blocks
//! are measured against the data's memory, not read), next to a plain
//! memcpy of as many bytes in the same run, over subdivision levels 0 to
//! 12; and (c) the
//! content-tier check of a bottom-level build whose opacity attachment
//! references 1%, 10% and 100% of a 10^6-triangle micromap, whose time must
//! follow the referenced count, not the micromap's size; and the same
//! check per referenced index with 16- and 32-bit indices, every triangle
//! of a micromap 16-bit indices can address referenced once.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use ommcheck::Tier;

mod workload;
use workload::{time_check, Api, Format, MicromapBuild, MicromapWorkload, ReferencingBuild};

/// Levels of the throughput sweep; N at each is as many triangles as
/// [`THROUGHPUT_BUDGET`] bytes of triangle array hold, at most 10^6: 10^6
/// at every level (triangles share data blocks where distinct ones would
/// not fit the workload's data, see `MicromapWorkload::distinct_blocks`).
const THROUGHPUT_LEVELS: [u16; 7] = [0, 2, 4, 6, 8, 10, 12];
const THROUGHPUT_BUDGET: u64 = 16 << 20;
const MAX_TRIANGLES: u32 = 1_000_000;

/// The referenced micromap: 10^6 4-state triangles at level 3 (24 MB with its array).
const REFERENCED_MICROMAP: MicromapWorkload = MicromapWorkload {
    triangles: MAX_TRIANGLES,
    level: 3,
    format: Format::FourState,
};
const REFERENCED_PERCENT: [u32; 3] = [1, 10, 100];

fn content_throughput(c: &mut Criterion) {
    let mut group = c.benchmark_group("content-throughput");
    group.sample_size(10);
    for format in Format::ALL {
        for level in THROUGHPUT_LEVELS {
            let workload =
                MicromapWorkload::within_budget(level, format, THROUGHPUT_BUDGET, MAX_TRIANGLES);
            let bytes = workload.bytes_read();
            group.throughput(Throughput::Bytes(bytes));
            let value = format!("L{level}-N{}", workload.triangles);

            let build = MicromapBuild::new(&workload, Api::Ext);
            let id = BenchmarkId::new(format!("content-{}", format.name()), &value);
            group.bench_with_input(id, &build, |b, build| {
                time_check(
                    b,
                    &build.validator,
                    |v| build.check(v),
                    BatchSize::LargeInput,
                )
            });
            drop(build);

            let source = vec![0x5au8; bytes as usize];
            let mut destination = vec![0u8; bytes as usize];
            let id = BenchmarkId::new(format!("memcpy-{}", format.name()), &value);
            group.bench_function(id, |b| {
                b.iter(|| destination.copy_from_slice(black_box(&source)))
            });
            black_box(&destination);
        }
    }
    group.finish();
}

fn referenced_fraction(c: &mut Criterion) {
    let mut group = c.benchmark_group("referenced-fraction");
    group.sample_size(10);
    let m = REFERENCED_MICROMAP.triangles;
    for api in Api::ALL {
        for percent in REFERENCED_PERCENT {
            let referenced = m / 100 * percent;
            let mut blas = ReferencingBuild::new(&REFERENCED_MICROMAP, referenced, api);
            blas.validator.set_tier(Tier::Content);
            group.throughput(Throughput::Elements(u64::from(referenced)));
            let id = BenchmarkId::new(api.name(), format!("{referenced}-of-{m}"));
            group.bench_with_input(id, &blas, |b, blas| {
                time_check(b, &blas.validator, |v| blas.check(v), BatchSize::LargeInput)
            });
        }
    }
    group.finish();
}

/// The micromap of the index-width group: as many level-3 4-state
/// triangles as 16-bit indices select (0xFFFB: -5..-1 are special), all
/// referenced.
const INDEX_WIDTH_MICROMAP: MicromapWorkload = MicromapWorkload {
    triangles: 0xFFFB,
    level: 3,
    format: Format::FourState,
};

fn index_width(c: &mut Criterion) {
    let mut group = c.benchmark_group("index-width");
    group.sample_size(20);
    let n = INDEX_WIDTH_MICROMAP.triangles;
    for api in Api::ALL {
        for index_bytes in [2, 4] {
            let mut blas =
                ReferencingBuild::with_index_bytes(&INDEX_WIDTH_MICROMAP, n, api, index_bytes);
            blas.validator.set_tier(Tier::Content);
            group.throughput(Throughput::Elements(u64::from(n)));
            let id = BenchmarkId::new(api.name(), format!("{}-bit", 8 * index_bytes));
            group.bench_with_input(id, &blas, |b, blas| {
                time_check(b, &blas.validator, |v| blas.check(v), BatchSize::LargeInput)
            });
        }
    }
    group.finish();
}

criterion_group!(
    benches,
    content_throughput,
    referenced_fraction,
    index_width
);
criterion_main!(benches);
