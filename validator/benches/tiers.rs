//! What each validation tier costs per build: (a) the time to check one
//! micromap build at the params, state and content tiers against the
//! number of micromap triangles N (1 to 10^6), for both formats, built
//! through EXT (`vkCmdBuildMicromapsEXT`) and KHR
//! (`vkCmdBuildAccelerationStructuresKHR` of type OPACITY_MICROMAP); and
//! (d) the per-call cost of the params tier on one small build; and the
//! per-call cost of the state tier on one small build against the number
//! of other buffers the application has (0 to 10^4), which resolving
//! addresses through an index keeps from growing with that number; and
//! the per-call cost of the params tier against the number of usage
//! entries (1 or 64) and micromap triangles (1, 10^3, 10^5), which a table
//! lookup per entry keeps from growing with either.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use ommcheck::Tier;

mod workload;
use workload::{
    assert_clean, time_check, track_other_buffers, Api, Format, MicromapBuild, MicromapWorkload,
    ReferencingBuild,
};

/// Subdivision level of the N sweep: 8 (2-state) or 16 (4-state) bytes a
/// triangle, so that 10^6 triangles stay at 16 or 24 MB with the array.
const SWEEP_LEVEL: u16 = 3;
const SWEEP_TRIANGLES: [u32; 7] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000];
const TIERS: [Tier; 3] = [Tier::Params, Tier::State, Tier::Content];

fn build_time(c: &mut Criterion) {
    let mut group = c.benchmark_group("build-time");
    // The largest builds take a tenth of a second and more; ten samples
    // keep the sweep within minutes.
    group.sample_size(10);
    for api in Api::ALL {
        for format in Format::ALL {
            for n in SWEEP_TRIANGLES {
                let workload = MicromapWorkload::new(n, SWEEP_LEVEL, format);
                let mut build = MicromapBuild::new(&workload, api);
                group.throughput(Throughput::Elements(u64::from(n)));
                for tier in TIERS {
                    build.validator.set_tier(tier);
                    let id = format!("{}-{}-{}", api.name(), format.name(), tier.name());
                    group.bench_with_input(BenchmarkId::new(id, n), &build, |b, build| {
                        time_check(
                            b,
                            &build.validator,
                            |v| build.check(v),
                            BatchSize::LargeInput,
                        )
                    });
                }
            }
        }
    }
    group.finish();
}

fn params_per_call(c: &mut Criterion) {
    let mut group = c.benchmark_group("params-per-call");
    let one = MicromapWorkload::new(1, SWEEP_LEVEL, Format::FourState);
    for api in Api::ALL {
        let mut build = MicromapBuild::new(&one, api);
        build.validator.set_tier(Tier::Params);
        group.bench_function(format!("{}-micromap", api.name()), |b| {
            time_check(
                b,
                &build.validator,
                |v| build.check(v),
                BatchSize::SmallInput,
            )
        });
        let mut blas = ReferencingBuild::new(&one, 1, api);
        blas.validator.set_tier(Tier::Params);
        group.bench_function(format!("{}-blas", api.name()), |b| {
            time_check(b, &blas.validator, |v| blas.check(v), BatchSize::SmallInput)
        });
    }
    group.finish();
}

/// Usage entries and micromap triangles of the params-usage-entries group.
const USAGE_ENTRIES: [u32; 2] = [1, 64];
const USAGE_TRIANGLES: [u32; 3] = [1, 1_000, 100_000];

fn params_usage_entries(c: &mut Criterion) {
    let mut group = c.benchmark_group("params-usage-entries");
    for n in USAGE_TRIANGLES {
        let workload = MicromapWorkload::new(n, SWEEP_LEVEL, Format::FourState);
        // The bottom-level build references one micromap triangle.
        let one = MicromapWorkload {
            triangles: 1,
            ..workload
        };
        for entries in USAGE_ENTRIES {
            let value = format!("N{n}-K{entries}");
            for api in Api::ALL {
                let mut build =
                    MicromapBuild::new(&workload, api).with_usage_entries(&workload, entries);
                build.validator.set_tier(Tier::Params);
                let id = BenchmarkId::new(format!("{}-micromap", api.name()), &value);
                group.bench_with_input(id, &build, |b, build| {
                    time_check(
                        b,
                        &build.validator,
                        |v| build.check(v),
                        BatchSize::SmallInput,
                    )
                });
            }
            let mut blas =
                ReferencingBuild::new(&workload, 1, Api::Ext).with_usage_entries(&one, entries);
            blas.validator.set_tier(Tier::Params);
            let id = BenchmarkId::new("ext-blas", &value);
            group.bench_with_input(id, &blas, |b, blas| {
                time_check(b, &blas.validator, |v| blas.check(v), BatchSize::SmallInput)
            });
        }
    }
    group.finish();
}

/// How many other buffers the state-per-call group tracks besides the
/// build's own.
const OTHER_BUFFERS: [u64; 3] = [0, 100, 10_000];

fn state_per_call(c: &mut Criterion) {
    let mut group = c.benchmark_group("state-per-call");
    let one = MicromapWorkload::new(1, SWEEP_LEVEL, Format::FourState);
    for api in Api::ALL {
        for others in OTHER_BUFFERS {
            let mut build = MicromapBuild::new(&one, api);
            track_other_buffers(&mut build.validator, others);
            build.validator.set_tier(Tier::State);
            // One validator checks the build again and again, rather than a
            // fresh clone each iteration: cloned anew, 10,000 buffers are out
            // of cache, and the bench would time cache misses, not lookups.
            // A valid build leaves the state as it found it but for the
            // build's record, which the next check replaces.
            let mut warm = build.validator.clone();
            for pass in ["first", "second"] {
                assert_clean(
                    &format!(
                        "{} build among {others} other buffers, {pass} check",
                        api.name()
                    ),
                    &build.check(&mut warm),
                );
            }
            let id = BenchmarkId::new(format!("{}-micromap", api.name()), others);
            group.bench_function(id, |b| b.iter(|| build.check(&mut warm)));
        }
    }
    group.finish();
}

criterion_group!(
    benches,
    build_time,
    params_per_call,
    state_per_call,
    params_usage_entries
);
criterion_main!(benches);
