//! Target (a), the ash-struct reader (`ommcheck::raw`): arbitrary
//! `VkMicromapBuildInfoEXT` and `VkAccelerationStructureBuildGeometryInfoKHR`
//! arrays, with pNext chains (cyclic ones included), usage-count arrays and
//! pointer arrays, geometries with opacity attachments and build ranges,
//! all built from the input with counts up to 2^32 − 1.
//!
//! Every pointer points into an allocation of this target holding exactly
//! the elements the reader's contract lets it read: `count` elements, or
//! for a count past the reader's documented bound ([`MAX_ELEMENTS`], or
//! [`MAX_GEOMETRIES`] for geometries) exactly that many. Under cargo-fuzz
//! the target is built with AddressSanitizer, so a read one byte past what
//! the input described is a heap-buffer-overflow, not a silent pass.
//! Host builds (`vkBuildMicromapsEXT`) get a triangle array of exactly the
//! `(Σ usage counts − 1) × stride + 8` bytes the API describes, and data
//! inside host ranges the target declares readable; a triangle array the
//! reader must not read (its extent past [`MAX_HOST_BYTES`]) gets 8 bytes.
//! Oracle beyond no crash: the same input gives the same findings.
//!
//! Under cargo-fuzz the reader's bounds are small (`--cfg fuzzing`: 2^10
//! elements, 2^6 geometries, 2^16 host bytes; see `ommcheck::raw`), so the
//! arrays an input past a bound gets are small too; `cargo test` replays
//! the same inputs with the real bounds.
//!
//! Past the first 8 elements, usage arrays hold a valid usage and pointer
//! arrays point to one: the reader still reads all of them, but the checks
//! report nothing per element. With NULL or zero elements instead, one call
//! with 2^20 of them gives 2^20 findings (1 s in release, 600 MB as Debug
//! text), each a real error, which made every such input a libFuzzer
//! timeout without anything being wrong.

use ash::vk;
use ommcheck::model::CommandBuffer;
use ommcheck::raw::accel::MAX_GEOMETRIES;
use ommcheck::raw::{ReadableHost, MAX_ELEMENTS, MAX_HOST_BYTES};
use ommcheck::{Device, Profile, Validator};

use crate::input::Input;
use crate::structs::{count, elements, usage_total, Arena, VALID_USAGE};

pub fn run(data: &[u8]) {
    let first = body(data);
    let second = body(data);
    assert_eq!(first, second, "the same structures read differently");
}

fn validator() -> Validator {
    Validator::new(Device::with_everything(Profile::SpecMinimum))
}

fn body(data: &[u8]) -> String {
    let mut input = Input::new(data);
    let mut arena = Arena::default();
    let mut out = String::new();

    // Micromap builds.
    let info_count = input.below(4);
    let mut infos = Vec::new();
    for _ in 0..info_count {
        let next = arena.chain(&mut input, std::ptr::null());
        let (count, array, pointers) = arena.usage_counts(&mut input, VALID_USAGE);
        infos.push(vk::MicromapBuildInfoEXT {
            s_type: if input.below(8) == 0 {
                vk::StructureType::from_raw(input.i32())
            } else {
                vk::StructureType::MICROMAP_BUILD_INFO_EXT
            },
            p_next: next,
            ty: vk::MicromapTypeEXT::from_raw(i32::from(input.u8() % 2)),
            flags: vk::BuildMicromapFlagsEXT::from_raw(input.u32()),
            mode: vk::BuildMicromapModeEXT::from_raw(i32::from(input.u8() % 2)),
            dst_micromap: vk::Handle::from_raw(u64::from(input.u8())),
            usage_counts_count: count,
            p_usage_counts: array,
            pp_usage_counts: pointers,
            data: vk::DeviceOrHostAddressConstKHR {
                device_address: input.u64(),
            },
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: input.u64(),
            },
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                device_address: input.u64(),
            },
            triangle_array_stride: input.u64_mostly_below(16),
            ..Default::default()
        });
    }
    let cb = CommandBuffer::default();
    let mut v = validator();
    // SAFETY: every pointer in `infos` points into `arena`, holding the
    // elements its count describes (up to the reader's bound; see the module).
    let report = unsafe { v.cmd_build_micromaps_raw(&cb, info_count, infos.as_ptr()) };
    out += &format!("{report:?}\n");
    if input.below(8) == 0 {
        // pInfos NULL with any count: reported, never read.
        let count = input.u32();
        // SAFETY: a NULL pInfos is not read.
        let report = unsafe { v.cmd_build_micromaps_raw(&cb, count, std::ptr::null()) };
        out += &format!("{report:?}\n");
    }

    // The same infos as a host build, with host addresses.
    let mut readable = Vec::new();
    for info in infos.iter_mut() {
        let total = usage_total(
            info.usage_counts_count,
            info.p_usage_counts,
            info.pp_usage_counts,
        );
        let extent = total
            .checked_sub(1)
            .and_then(|n| n.checked_mul(info.triangle_array_stride))
            .and_then(|n| n.checked_add(8));
        let seed = input.bytes(32);
        let triangles = match extent {
            Some(e) if e <= 1 << 16 => arena.bytes(e as usize, seed),
            // Too long to read (the reader must not) or nothing to read.
            Some(e) if e > MAX_HOST_BYTES => arena.bytes(8, seed),
            None => arena.bytes(8, seed),
            // Between: more than this target allocates; NULL is not read.
            Some(_) => std::ptr::null(),
        };
        info.triangle_array = vk::DeviceOrHostAddressConstKHR {
            host_address: triangles.cast(),
        };
        let len = usize::from(input.u16() % 1024);
        let seed = input.bytes(32);
        let data = arena.bytes(len, seed);
        let offset = usize::from(input.u16()) % (len + 1);
        // SAFETY: `offset <= len`: inside the allocation or one past its end.
        let data_at = unsafe { data.add(offset) };
        info.data = vk::DeviceOrHostAddressConstKHR {
            host_address: data_at.cast(),
        };
        match input.below(3) {
            0 => {}
            1 => readable.push(ReadableHost {
                address: data.expose_provenance() as u64,
                len: len as u64,
            }),
            _ => {
                let cut = usize::from(input.u16()) % (len + 1);
                readable.push(ReadableHost {
                    // SAFETY: `cut <= len`.
                    address: unsafe { data.add(cut) }.expose_provenance() as u64,
                    len: (len - cut) as u64,
                });
            }
        }
    }
    let mut v = validator();
    // SAFETY: as above, and each triangle array holds the bytes the API
    // describes (or is NULL, or is one the reader must not read), and each
    // of `readable` lies inside an allocation of `arena`.
    let report = unsafe {
        v.build_micromaps_raw_reading(
            vk::Handle::from_raw(1),
            vk::DeferredOperationKHR::null(),
            info_count,
            infos.as_ptr(),
            &readable,
        )
    };
    out += &format!("{report:?}\n");

    // Acceleration-structure builds.
    let as_count = input.below(3);
    let mut as_infos = Vec::new();
    let mut range_pointers = Vec::new();
    let mut max_counts = Vec::new();
    for _ in 0..as_count {
        let geometry_count = count(&mut input);
        let n = geometry_count.min(MAX_GEOMETRIES) as usize;
        let geometries = arena.geometry_arrays(&mut input, n, |_| None);
        let next = arena.chain(&mut input, std::ptr::null());
        let ty = vk::AccelerationStructureTypeKHR::from_raw(i32::from(input.u8() % 4));
        let flags = input.u32();
        let info = arena.build_info(&mut input, next, ty, flags, geometry_count, geometries);
        as_infos.push(info);
        // Build ranges and max primitive counts: `geometryCount` elements,
        // up to the reader's bound for each: ranges are read as far as the
        // geometries ([`MAX_GEOMETRIES`]), counts as any array
        // ([`MAX_ELEMENTS`]).
        let m = (geometry_count as usize).min(MAX_ELEMENTS);
        if input.below(4) == 0 {
            range_pointers.push(std::ptr::null());
        } else {
            let list = elements(n, Default::default(), || {
                vk::AccelerationStructureBuildRangeInfoKHR {
                    primitive_count: input.u32_mostly_below(256),
                    primitive_offset: u32::from(input.u16()),
                    first_vertex: u32::from(input.u8()),
                    transform_offset: u32::from(input.u8()),
                }
            });
            range_pointers.push(list.as_ptr());
            arena.ranges.push(list);
        }
        let list = elements(m, 0, || input.u32());
        max_counts.push(list.as_ptr());
        arena.counts.push(list);
    }
    let ranges: Box<[_]> = range_pointers.into_boxed_slice();
    let ranges_pointer = if input.below(8) == 0 {
        std::ptr::null()
    } else {
        ranges.as_ptr()
    };
    arena.range_pointers.push(ranges);
    let mut v = validator();
    // SAFETY: every pointer points into `arena`, holding the elements its
    // count describes (up to the reader's bounds); unions hold the member
    // their geometryType selects.
    let report = unsafe {
        v.cmd_build_acceleration_structures_raw(&cb, as_count, as_infos.as_ptr(), ranges_pointer)
    };
    out += &format!("{report:?}\n");
    for (info, counts) in as_infos.iter().zip(&max_counts) {
        // SAFETY: as above; `counts` holds geometryCount counts (bounded).
        let report = unsafe {
            v.get_acceleration_structure_build_sizes_ash(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                info,
                *counts,
            )
        };
        out += &format!("{report:?}\n");
    }
    out
}
