//! What reading device build inputs costs (issue 14), over the fake driver
//! of the in-process tests (`layer/tests/fake`), whose copies are plain
//! memcpys and whose fences are signalled at submission:
//!
//! - `record`: recording `vkCmdBuildMicromapsEXT` of N triangles whose
//!   inputs are in device-local memory, with GPU readback on (the layer
//!   takes a range of its arena and records a barrier, two copies and a
//!   barrier) and off;
//! - `complete`: the `vkWaitForFences` that sees the submission complete
//!   and checks the read-back inputs of a valid build (`wait`), against a
//!   memcpy of the bytes read back; and the `vkQueueSubmit` of the same
//!   command buffer before it (`resubmit`), which copies out what the last
//!   check kept of the readback;
//! - `route1`: `vkQueueSubmit` of an upload from a mapped staging buffer
//!   and the build, with readback off, whose inputs lie at the start of a
//!   buffer of exactly their size or of 16 MiB: the cost follows the bytes
//!   the build reads, not the buffer.
//!
//! `cargo bench -p ommcheck-layer --bench device_memory`.

#![allow(unsafe_code, dead_code)]

#[path = "../tests/fake/mod.rs"]
mod fake;

use std::ffi::CStr;
use std::hint::black_box;
use std::time::{Duration, Instant};

use ash::vk;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

use fake::app::record_micromap_build;
use fake::{device_fn, device_micromap_build, Chain};

/// Memory types of the fake driver.
const DEVICE_LOCAL: u32 = 0;
const HOST_VISIBLE: u32 = 1;

const SIZES: [u32; 3] = [64, 4096, 65536];

/// A micromap build of `triangles` 2-state level-0 triangles, its triangle
/// array and data in device-local buffers of `buffer_size` bytes (at least
/// what they hold), and a staging buffer with valid inputs.
struct Build {
    chain: Chain,
    info: vk::MicromapBuildInfoEXT<'static>,
    triangles: vk::Buffer,
    data: vk::Buffer,
    staging: vk::Buffer,
    array_bytes: u64,
    data_bytes: u64,
}

impl Build {
    fn new(readback: bool, triangles: u32, buffer_size: u64) -> Self {
        let value: &CStr = if readback { c"true" } else { c"false" };
        let chain = Chain::with_settings(&[(c"gpu_readback", value)]);
        let usage = vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
            | vk::BufferUsageFlags::TRANSFER_DST;
        let array_bytes = u64::from(triangles) * 8;
        let data_bytes = u64::from(triangles).div_ceil(8);
        let storage = chain.buffer(1 << 20, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
        let micromap = chain.micromap(storage, 1 << 20);
        let triangle_buffer = chain.buffer(buffer_size.max(array_bytes), usage, DEVICE_LOCAL);
        let data = chain.buffer(buffer_size.max(data_bytes), usage, DEVICE_LOCAL);
        let staging_usage = vk::BufferUsageFlags::TRANSFER_SRC;
        let (staging, staging_memory) =
            chain.buffer_and_memory(array_bytes + data_bytes, staging_usage, HOST_VISIBLE);
        // Valid inputs: triangle i reads bit i of the data.
        let mapped = chain.map_backing(staging_memory);
        for i in 0..triangles {
            let entry = vk::MicromapTriangleEXT {
                data_offset: i / 8,
                subdivision_level: 0,
                format: 1,
            };
            // SAFETY: inside the staging buffer's backing.
            unsafe {
                mapped
                    .add(i as usize * 8)
                    .cast::<vk::MicromapTriangleEXT>()
                    .write_unaligned(entry)
            };
        }
        let usage: &'static [vk::MicromapUsageEXT] = Box::leak(Box::new([vk::MicromapUsageEXT {
            count: triangles,
            subdivision_level: 0,
            format: 1,
        }]));
        let scratch = chain.address(chain.buffer(1 << 16, usage_address(), DEVICE_LOCAL));
        let info = device_micromap_build(
            micromap,
            usage,
            chain.address(triangle_buffer),
            chain.address(data),
            scratch,
        );
        Self {
            chain,
            info,
            triangles: triangle_buffer,
            data,
            staging,
            array_bytes,
            data_bytes,
        }
    }

    /// Records the upload from staging (route 1) where asked, then the build.
    fn record(&self, command_buffer: vk::CommandBuffer, upload: bool) {
        self.chain.begin(command_buffer);
        if upload {
            let copy: vk::PFN_vkCmdCopyBuffer = device_fn(self.chain.device, c"vkCmdCopyBuffer");
            let regions = [
                vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: self.array_bytes,
                },
                vk::BufferCopy {
                    src_offset: self.array_bytes,
                    dst_offset: 0,
                    size: self.data_bytes,
                },
            ];
            // SAFETY: one region each, inside both buffers.
            unsafe {
                copy(command_buffer, self.staging, self.triangles, 1, &regions[0]);
                copy(command_buffer, self.staging, self.data, 1, &regions[1]);
            }
        }
        record_micromap_build(&self.chain, command_buffer, &self.info);
        self.chain.end(command_buffer);
    }
}

fn usage_address() -> vk::BufferUsageFlags {
    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
}

fn record(c: &mut Criterion) {
    let mut group = c.benchmark_group("record");
    for triangles in SIZES {
        for readback in [true, false] {
            let build = Build::new(readback, triangles, 0);
            let command_buffer = build.chain.allocate_command_buffer();
            let name = if readback {
                "readback-on"
            } else {
                "readback-off"
            };
            group.bench_with_input(BenchmarkId::new(name, triangles), &triangles, |b, _| {
                b.iter(|| {
                    build.record(command_buffer, false);
                    fake::clear_calls();
                })
            });
        }
    }
    group.finish();
}

fn complete(c: &mut Criterion) {
    let mut group = c.benchmark_group("complete");
    for triangles in SIZES {
        let build = Build::new(true, triangles, 0);
        let command_buffer = build.chain.allocate_command_buffer();
        // Uploaded first, so what is read back is a valid build's inputs.
        build.record(command_buffer, true);
        let fence = build.chain.fence();
        let bytes = build.array_bytes + build.data_bytes;
        group.throughput(Throughput::Bytes(bytes));
        group.bench_with_input(BenchmarkId::new("wait", triangles), &triangles, |b, _| {
            b.iter_custom(|iterations| {
                let mut waiting = Duration::ZERO;
                for _ in 0..iterations {
                    assert_eq!(
                        build.chain.submit_with(command_buffer, fence),
                        vk::Result::SUCCESS
                    );
                    let start = Instant::now();
                    assert_eq!(
                        black_box(build.chain.wait_for_fence(fence)),
                        vk::Result::SUCCESS
                    );
                    waiting += start.elapsed();
                    fake::clear_calls();
                }
                waiting
            })
        });
        // The submission before each of those waits: the command buffer is
        // submitted again, so what the last completion kept of the readback
        // is copied out before the copies write it again.
        group.bench_with_input(
            BenchmarkId::new("resubmit", triangles),
            &triangles,
            |b, _| {
                b.iter_custom(|iterations| {
                    let mut submitting = Duration::ZERO;
                    for _ in 0..iterations {
                        let start = Instant::now();
                        assert_eq!(
                            black_box(build.chain.submit_with(command_buffer, fence)),
                            vk::Result::SUCCESS
                        );
                        submitting += start.elapsed();
                        assert_eq!(build.chain.wait_for_fence(fence), vk::Result::SUCCESS);
                        fake::clear_calls();
                    }
                    submitting
                })
            },
        );
        let source = vec![7u8; bytes as usize];
        let mut target = vec![0u8; bytes as usize];
        group.bench_with_input(BenchmarkId::new("memcpy", triangles), &triangles, |b, _| {
            b.iter(|| {
                target.copy_from_slice(black_box(&source));
                black_box(&target);
            })
        });
    }
    group.finish();
}

fn route1(c: &mut Criterion) {
    let mut group = c.benchmark_group("route1");
    for triangles in [64, 65536] {
        for (buffer, buffer_size) in [("exact", 0), ("16MiB", 16 << 20)] {
            let build = Build::new(false, triangles, buffer_size);
            let command_buffer = build.chain.allocate_command_buffer();
            build.record(command_buffer, true);
            group.bench_with_input(BenchmarkId::new(buffer, triangles), &triangles, |b, _| {
                b.iter_custom(|iterations| {
                    let mut submitting = Duration::ZERO;
                    for _ in 0..iterations {
                        let start = Instant::now();
                        assert_eq!(
                            black_box(build.chain.submit(command_buffer)),
                            vk::Result::SUCCESS
                        );
                        submitting += start.elapsed();
                        fake::clear_calls();
                    }
                    submitting
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, record, complete, route1);
criterion_main!(benches);
