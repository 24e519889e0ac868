//! Memory stays bounded by what the input describes, never by a count the
//! reader has not checked: the raw reader (`ommcheck::raw`) fed counts of
//! 2^32 − 1 with tiny arrays behind them peaks at a few MiB more than before
//! the call, and says what it did not read.
//!
//! The peak is measured by a counting global allocator, so this binary's
//! tests take turns ([`measure`] holds a lock). Where the API obliges the
//! application to provide `count` elements (`infoCount`, `usageCountsCount`,
//! `geometryCount`, the instances of an instances geometry), the arrays are
//! provided in full, as pages of zeros mapped but never written: they cost
//! the process no memory, so what is measured is the reader's own. Where a
//! count describes data in memory the reader only reads when it can tell
//! how far it extends (triangle counts, `primitiveCount`, index counts),
//! the memory behind it is a few bytes.

#![cfg(target_os = "linux")]
#![allow(unsafe_code)]

use std::ffi::c_void;

use ash::vk;
use ommcheck::model::{CommandBuffer, MicromapBuildInfo};
use ommcheck::raw::accel::MAX_GEOMETRIES;
use ommcheck::raw::MAX_ELEMENTS;
use ommcheck::report::Report;
use ommcheck::{Device, Profile, Validator, FINDINGS_PER_RULE_PER_CALL};

#[path = "support/peak_memory.rs"]
mod peak_memory;
use peak_memory::{measure, BOUND};

extern "C" {
    fn mmap(
        addr: *mut c_void,
        len: usize,
        prot: i32,
        flags: i32,
        fd: i32,
        offset: i64,
    ) -> *mut c_void;
    fn munmap(addr: *mut c_void, len: usize) -> i32;
}

/// `count` zeroed `T`s that cost no memory until written (never): an
/// anonymous read-only mapping of the zero page, reserved without swap.
struct Zeros<T> {
    pointer: *const T,
    len: usize,
}

impl<T> Zeros<T> {
    fn new(count: u32) -> Self {
        const PROT_READ: i32 = 1;
        const MAP_PRIVATE: i32 = 0x02;
        const MAP_ANONYMOUS: i32 = 0x20;
        const MAP_NORESERVE: i32 = 0x4000;
        let len = std::mem::size_of::<T>() * count as usize;
        // SAFETY: a fresh anonymous mapping; nothing else is touched.
        let pointer = unsafe {
            mmap(
                std::ptr::null_mut(),
                len,
                PROT_READ,
                MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE,
                -1,
                0,
            )
        };
        assert_ne!(pointer as isize, -1, "mmap of {len} bytes failed");
        Self {
            pointer: pointer.cast(),
            len,
        }
    }
}

impl<T> Drop for Zeros<T> {
    fn drop(&mut self) {
        // SAFETY: the mapping made in `new`, no longer used.
        unsafe { munmap(self.pointer.cast_mut().cast(), self.len) };
    }
}

#[path = "vuid_cases/fixtures.rs"]
mod fixtures;

const HUGE: u32 = u32::MAX;

fn validator() -> Validator {
    Validator::new(Device::with_everything(Profile::SpecMinimum))
}

fn device() -> vk::Device {
    <vk::Device as vk::Handle>::from_raw(1)
}

fn recording() -> CommandBuffer {
    CommandBuffer {
        handle: 2,
        recording: true,
        queue_flags: vk::QueueFlags::COMPUTE.as_raw(),
        ..Default::default()
    }
}

/// The most a call may allocate per element it reads of an array the API
/// says holds `count` elements: the element's model and its findings (a
/// zeroed micromap build info has two, some 1.4 KiB in all).
const PER_ELEMENT: usize = 4 << 10;

/// Asserts the call stayed within [`BOUND`] plus [`PER_ELEMENT`] for each
/// of the `read` elements the reader takes of the arrays it was given (the
/// count it was given is never what decides), and reported something (a
/// finding: never silence), `rule` among it.
fn assert_bounded(what: &str, read: usize, (report, growth): (Report, usize), rule: &str) {
    eprintln!(
        "{what}: peak growth {growth} bytes, {} findings",
        report.findings.len()
    );
    let bound = BOUND + read * PER_ELEMENT;
    assert!(
        growth < bound,
        "{what}: the peak grew by {growth} bytes, more than {bound}"
    );
    assert!(
        report.findings.iter().any(|f| f.rule.as_str() == rule),
        "{what}: no {rule} in {report}"
    );
}

const READ_BOUND: &str = ommcheck::rules::READ_BOUND.id;

/// Two 2-state level-1 triangles' entries (data at 0 and 1).
const TRIANGLES: [vk::MicromapTriangleEXT; 2] = [
    vk::MicromapTriangleEXT {
        data_offset: 0,
        subdivision_level: 1,
        format: 1,
    },
    vk::MicromapTriangleEXT {
        data_offset: 1,
        subdivision_level: 1,
        format: 1,
    },
];

fn host(p: *const u8) -> u64 {
    p.expose_provenance() as u64
}

/// A host micromap build of `usage` over two triangles' entries and two
/// bytes of data.
fn host_micromap_build<'a>(
    usage: &'a [vk::MicromapUsageEXT],
    data: &'a [u8; 2],
    scratch: &'a mut [u8; 64],
) -> vk::MicromapBuildInfoEXT<'a> {
    vk::MicromapBuildInfoEXT {
        usage_counts_count: usage.len() as u32,
        p_usage_counts: usage.as_ptr(),
        triangle_array: vk::DeviceOrHostAddressConstKHR {
            host_address: TRIANGLES.as_ptr().cast(),
        },
        data: vk::DeviceOrHostAddressConstKHR {
            host_address: data.as_ptr().cast(),
        },
        scratch_data: vk::DeviceOrHostAddressKHR {
            host_address: scratch.as_mut_ptr().cast(),
        },
        triangle_array_stride: 8,
        ..Default::default()
    }
}

#[test]
fn micromap_builds_with_huge_counts_stay_bounded() {
    let data = [0x1u8, 0x2];
    let mut scratch = [0u8; 64];

    // 2^32 − 1 infos (all zeros).
    let infos = Zeros::<vk::MicromapBuildInfoEXT<'_>>::new(HUGE);
    let mut v = validator();
    // SAFETY: HUGE readable infos, each with NULL pointers.
    assert_bounded(
        "vkBuildMicromapsEXT infoCount",
        MAX_ELEMENTS,
        measure(|| unsafe {
            v.build_micromaps_raw(
                device(),
                vk::DeferredOperationKHR::null(),
                HUGE,
                infos.pointer,
            )
        }),
        READ_BOUND,
    );
    let mut v = validator();
    // SAFETY: as above.
    assert_bounded(
        "vkCmdBuildMicromapsEXT infoCount",
        MAX_ELEMENTS,
        measure(|| unsafe { v.cmd_build_micromaps_raw(&recording(), HUGE, infos.pointer) }),
        READ_BOUND,
    );
    drop(infos);

    // 2^32 − 1 usage counts (all zeros), by array and by pointers (NULL).
    let usages = Zeros::<vk::MicromapUsageEXT>::new(HUGE);
    let pointers = Zeros::<*const vk::MicromapUsageEXT>::new(HUGE);
    let info = vk::MicromapBuildInfoEXT {
        usage_counts_count: HUGE,
        p_usage_counts: usages.pointer,
        ..host_micromap_build(&[], &data, &mut scratch)
    };
    let mut v = validator();
    // SAFETY: HUGE readable usage counts; the other host addresses live.
    assert_bounded(
        "vkBuildMicromapsEXT usageCountsCount",
        MAX_ELEMENTS,
        measure(|| unsafe {
            v.build_micromaps_raw(device(), vk::DeferredOperationKHR::null(), 1, &info)
        }),
        READ_BOUND,
    );
    let info = vk::MicromapBuildInfoEXT {
        p_usage_counts: std::ptr::null(),
        pp_usage_counts: pointers.pointer,
        ..info
    };
    let mut v = validator();
    // SAFETY: HUGE readable (NULL) pointers.
    assert_bounded(
        "vkBuildMicromapsEXT usageCountsCount (ppUsageCounts)",
        MAX_ELEMENTS,
        measure(|| unsafe {
            v.build_micromaps_raw(device(), vk::DeferredOperationKHR::null(), 1, &info)
        }),
        READ_BOUND,
    );
    drop((usages, pointers));

    // 2^32 − 1 triangles at the highest level over a two-entry triangle
    // array: the reader must not take the count's word for the memory.
    for (level, format) in [(1, 1), (12, 2)] {
        let usage = [vk::MicromapUsageEXT {
            count: HUGE,
            subdivision_level: level,
            format,
        }];
        let mut scratch = [0u8; 64];
        let info = host_micromap_build(&usage, &data, &mut scratch);
        let mut v = validator();
        // SAFETY: the triangle array is not read past what the reader can
        // bound (the assertion is that it reports instead).
        assert_bounded(
            &format!("vkBuildMicromapsEXT triangle count, level {level}"),
            0,
            measure(|| unsafe {
                v.build_micromaps_raw(device(), vk::DeferredOperationKHR::null(), 1, &info)
            }),
            READ_BOUND,
        );
        let mut v = validator();
        let sizes = vk::MicromapBuildSizesInfoEXT::default();
        // SAFETY: valid pointers; sizes queries read no addresses.
        let (report, growth) = measure(|| unsafe {
            v.get_micromap_build_sizes_raw(
                device(),
                vk::AccelerationStructureBuildTypeKHR::HOST,
                &info,
                &sizes,
            )
        });
        eprintln!("sizes level {level}: {growth} bytes, {report}");
        assert!(growth < BOUND, "sizes: the peak grew by {growth} bytes");
    }
}

/// A triangles geometry over six host vertices, not indexed, whose opacity
/// micromap attachment has `usage` and 32-bit indices at `indices`.
fn host_triangles<'a>(
    vertices: &'a [f32; 18],
    indices: &'a [u32; 2],
    usage: &'a [vk::MicromapUsageEXT],
    attachment: &'a mut vk::AccelerationStructureTrianglesOpacityMicromapEXT<'a>,
) -> vk::AccelerationStructureGeometryKHR<'a> {
    *attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
        index_type: vk::IndexType::UINT32,
        index_buffer: vk::DeviceOrHostAddressConstKHR {
            host_address: indices.as_ptr().cast(),
        },
        index_stride: 4,
        usage_counts_count: usage.len() as u32,
        p_usage_counts: usage.as_ptr(),
        micromap: <vk::MicromapEXT as vk::Handle>::from_raw(9),
        ..Default::default()
    };
    let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR {
        p_next: (attachment as *const vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>)
            .cast(),
        vertex_format: vk::Format::R32G32B32_SFLOAT,
        vertex_data: vk::DeviceOrHostAddressConstKHR {
            host_address: vertices.as_ptr().cast(),
        },
        vertex_stride: 12,
        max_vertex: 5,
        index_type: vk::IndexType::NONE_KHR,
        ..Default::default()
    };
    vk::AccelerationStructureGeometryKHR {
        geometry_type: vk::GeometryTypeKHR::TRIANGLES,
        geometry: vk::AccelerationStructureGeometryDataKHR { triangles },
        ..Default::default()
    }
}

fn blas_build<'a>(
    geometries: *const vk::AccelerationStructureGeometryKHR<'a>,
    count: u32,
    scratch: u64,
) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
    vk::AccelerationStructureBuildGeometryInfoKHR {
        ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
        mode: vk::BuildAccelerationStructureModeKHR::BUILD,
        dst_acceleration_structure: <vk::AccelerationStructureKHR as vk::Handle>::from_raw(7),
        geometry_count: count,
        p_geometries: geometries,
        scratch_data: vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        },
        ..Default::default()
    }
}

#[test]
fn structure_builds_with_huge_counts_stay_bounded() {
    let vertices = [0.5f32; 18];
    let indices = [0u32, 1];
    let scratch = vec![0u8; 4096];
    let scratch = host(scratch.as_ptr());

    // 2^32 − 1 infos, and as many (NULL) range pointers.
    let infos = Zeros::<vk::AccelerationStructureBuildGeometryInfoKHR<'_>>::new(HUGE);
    let range_pointers = Zeros::<*const vk::AccelerationStructureBuildRangeInfoKHR>::new(HUGE);
    let mut v = validator();
    // SAFETY: HUGE readable infos with NULL pointers, HUGE NULL range pointers.
    assert_bounded(
        "vkBuildAccelerationStructuresKHR infoCount",
        MAX_ELEMENTS,
        measure(|| unsafe {
            v.build_acceleration_structures_raw(HUGE, infos.pointer, range_pointers.pointer)
        }),
        READ_BOUND,
    );
    let mut v = validator();
    // SAFETY: as above.
    assert_bounded(
        "vkCmdBuildAccelerationStructuresKHR infoCount",
        MAX_ELEMENTS,
        measure(|| unsafe {
            v.cmd_build_acceleration_structures_raw(
                &recording(),
                HUGE,
                infos.pointer,
                range_pointers.pointer,
            )
        }),
        READ_BOUND,
    );
    drop((infos, range_pointers));

    // 2^32 − 1 geometries (zeros: triangles with no addresses) and ranges.
    let geometries = Zeros::<vk::AccelerationStructureGeometryKHR<'_>>::new(HUGE);
    let ranges = Zeros::<vk::AccelerationStructureBuildRangeInfoKHR>::new(HUGE);
    let info = blas_build(geometries.pointer, HUGE, scratch);
    let mut v = validator();
    // SAFETY: HUGE readable geometries and ranges.
    assert_bounded(
        "vkBuildAccelerationStructuresKHR geometryCount",
        MAX_GEOMETRIES as usize,
        measure(|| unsafe { v.build_acceleration_structures_raw(1, &info, &ranges.pointer) }),
        READ_BOUND,
    );
    let mut v = validator();
    // SAFETY: as above.
    assert_bounded(
        "vkCmdBuildAccelerationStructuresKHR geometryCount",
        MAX_GEOMETRIES as usize,
        measure(|| unsafe {
            v.cmd_build_acceleration_structures_raw(&recording(), 1, &info, &ranges.pointer)
        }),
        READ_BOUND,
    );
    drop((geometries, ranges));

    // 2^32 − 1 primitives over six vertices, and an attachment of 2^32 − 1
    // triangles over two indices: extents the reader must not take on trust.
    let usage = [vk::MicromapUsageEXT {
        count: HUGE,
        subdivision_level: 12,
        format: 2,
    }];
    let mut attachment = Default::default();
    let geometry = host_triangles(&vertices, &indices, &usage, &mut attachment);
    let info = blas_build(&geometry, 1, scratch);
    let range = vk::AccelerationStructureBuildRangeInfoKHR {
        primitive_count: HUGE,
        ..Default::default()
    };
    let range_pointer: *const _ = &range;
    let mut v = validator();
    // SAFETY: the host arrays are not read past what the reader can bound.
    assert_bounded(
        "vkBuildAccelerationStructuresKHR primitiveCount",
        0,
        measure(|| unsafe { v.build_acceleration_structures_raw(1, &info, &range_pointer) }),
        READ_BOUND,
    );
    let mut v = validator();
    // SAFETY: device addresses are not read.
    let (report, growth) = measure(|| unsafe {
        v.cmd_build_acceleration_structures_raw(&recording(), 1, &info, &range_pointer)
    });
    eprintln!("cmd primitiveCount: {growth} bytes, {report}");
    assert!(growth < BOUND, "the peak grew by {growth} bytes");
    assert!(!report.is_empty(), "nothing reported");

    // An instances geometry of 2^32 − 1 instances (zeros), read on the host.
    let instances = Zeros::<vk::AccelerationStructureInstanceKHR>::new(HUGE);
    let geometry = vk::AccelerationStructureGeometryKHR {
        geometry_type: vk::GeometryTypeKHR::INSTANCES,
        geometry: vk::AccelerationStructureGeometryDataKHR {
            instances: vk::AccelerationStructureGeometryInstancesDataKHR {
                data: vk::DeviceOrHostAddressConstKHR {
                    host_address: instances.pointer.cast(),
                },
                ..Default::default()
            },
        },
        ..Default::default()
    };
    let info = vk::AccelerationStructureBuildGeometryInfoKHR {
        ty: vk::AccelerationStructureTypeKHR::TOP_LEVEL,
        ..blas_build(&geometry, 1, scratch)
    };
    let mut v = validator();
    // SAFETY: HUGE readable instances.
    assert_bounded(
        "vkBuildAccelerationStructuresKHR instances",
        MAX_ELEMENTS,
        measure(|| unsafe { v.build_acceleration_structures_raw(1, &info, &range_pointer) }),
        READ_BOUND,
    );
}

/// 2^16 device builds into one micromap with one scratch: every pair
/// collides. Reported once per info and rule (the rules hold pairwise; the
/// check used to compare, and report, every pair: 2^31 findings here, and
/// some 2^39 pairs at the reader's bound of 2^20 infos).
#[test]
fn builds_colliding_in_every_pair_are_reported_once_per_info() {
    const INFOS: usize = 1 << 16;
    let infos: Vec<MicromapBuildInfo> = vec![fixtures::device_build(); INFOS];
    let mut v = fixtures::validator();
    let (report, growth) = measure(|| v.cmd_build_micromaps(&recording(), &infos));
    eprintln!("{INFOS} colliding builds: peak growth {growth} bytes");
    // Linear in the infos read, not in their findings: those stop at the
    // per-rule limit.
    let bound = BOUND + INFOS * PER_ELEMENT;
    assert!(growth < bound, "the peak grew by {growth} bytes");
    let listed = FINDINGS_PER_RULE_PER_CALL as usize;
    for rule in [
        ommcheck::vuids::vuid::vkCmdBuildMicromapsEXT::dstMicromap_11649.id(),
        ommcheck::vuids::vuid::vkCmdBuildMicromapsEXT::scratchData_11651.id(),
    ] {
        let reported: Vec<_> = report
            .findings
            .iter()
            .filter(|f| f.rule.as_str() == rule)
            .collect();
        assert_eq!(reported.len(), listed, "{rule}");
        // Each info after the first, once: the listed ones at distinct
        // infos, the last one counting the rest.
        let mut at: Vec<&str> = reported.iter().map(|f| f.location.as_str()).collect();
        at.sort_unstable();
        at.dedup();
        assert_eq!(at.len(), listed, "{rule}");
        let more = INFOS - 1 - listed;
        assert!(
            reported[listed - 1]
                .message
                .contains(&format!("({more} more findings of this rule")),
            "{rule}: {}",
            reported[listed - 1].message
        );
    }
}
