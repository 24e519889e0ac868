//! Target `host_build`: `vkBuildAccelerationStructuresKHR` as a layer
//! receives it (`Validator::build_acceleration_structures_raw`), the one
//! acceleration-structure command whose reader follows host addresses.
//! Arbitrary `VkAccelerationStructureBuildGeometryInfoKHR` arrays (any type,
//! flags with MOTION_NV or without, any mode, `geometryCount` up to
//! 2^32 − 1, `pGeometries` and `ppGeometries`, geometries of every type
//! including micromap and unknown ones, pNext chains with cycles) and build
//! ranges (`primitiveCount` up to 2^32 − 1, any `primitiveOffset`).
//!
//! Every host address the reader documents it reads points into an
//! allocation of this target holding exactly the bytes it may read for the
//! counts given (see [`crate::structs`]): the instances of an instances
//! geometry (`primitiveCount` instances, or pointers each NULL or to one
//! instance, from `data + primitiveOffset`; not for MOTION_NV builds), each
//! micromap-data structure's triangle array (`(Σ usage counts − 1) ×
//! stride + 8` bytes) and each EXT or KHR opacity attachment's index
//! buffer (`(primitiveCount − 1) × indexStride + index size` bytes).
//! Addresses the reader documents it does not read (vertex, index,
//! transform and AABB data, micromap data, index buffers of type NONE,
//! arrays past [`ommcheck::raw::MAX_HOST_BYTES`], instances without a build
//! range) are the input's numbers, no pointer of this process. Under
//! cargo-fuzz the target is built with AddressSanitizer, so a read one
//! byte past what the input described, or before it, is a finding.
//! Oracle beyond no crash: the same input gives the same findings.

use ash::vk;
use ommcheck::raw::accel::MAX_GEOMETRIES;
use ommcheck::{Device, Profile, Validator};

use crate::input::Input;
use crate::structs::{count, elements, Arena, HostGeometry};

pub fn run(data: &[u8]) {
    let first = body(data);
    let second = body(data);
    assert_eq!(first, second, "the same host build read differently");
}

/// `VK_BUILD_ACCELERATION_STRUCTURE_MOTION_BIT_NV`.
const MOTION_NV: u32 = vk::BuildAccelerationStructureFlagsKHR::MOTION_NV.as_raw();

/// A primitive count: mostly a few, sometimes thousands, sometimes any u32
/// (past the reader's bounds and the target's allocations).
fn primitive_count(input: &mut Input<'_>) -> u32 {
    match input.below(8) {
        7 => input.u32(),
        6 => u32::from(input.u16()),
        _ => u32::from(input.u8() % 8),
    }
}

/// A build range: any offset (aligned or not, up to 2^32 − 1); first
/// vertex and transform offset are not read for host memory, but checked.
fn range(input: &mut Input<'_>) -> vk::AccelerationStructureBuildRangeInfoKHR {
    vk::AccelerationStructureBuildRangeInfoKHR {
        primitive_count: primitive_count(input),
        primitive_offset: match input.below(4) {
            0 => 0,
            1 => u32::from(input.u8()) * 16,
            2 => u32::from(input.u8()),
            _ => input.u32(),
        },
        first_vertex: u32::from(input.u8()),
        transform_offset: u32::from(input.u8()),
    }
}

fn body(data: &[u8]) -> String {
    let mut input = Input::new(data);
    let mut arena = Arena::default();
    let mut out = String::new();

    let info_count = input.below(4);
    // ppBuildRangeInfos itself NULL: no geometry has a range, and the
    // reader reads nothing whose extent a range describes.
    let no_ranges = input.below(8) == 0;
    let mut infos = Vec::new();
    let mut range_pointers = Vec::new();
    for _ in 0..info_count {
        // Type and flags first: whether instances are read depends on them.
        let ty = match input.below(5) {
            4 => ommcheck_vuids::khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR,
            t => vk::AccelerationStructureTypeKHR::from_raw(t as i32),
        };
        let mut flags = input.u32();
        if input.bool() {
            flags &= !MOTION_NV;
        }
        let geometry_count = count(&mut input);
        // The ranges, before the geometries whose reads they size: up to
        // the reader's bound, `min(geometryCount, MAX_GEOMETRIES)`.
        let m = geometry_count.min(MAX_GEOMETRIES) as usize;
        let ranges = if no_ranges || input.below(4) == 0 {
            None
        } else {
            Some(elements(m, Default::default(), || range(&mut input)))
        };
        let host = |g: usize| HostGeometry {
            range: ranges
                .as_ref()
                .and_then(|r| r.get(g))
                .map(|r| (r.primitive_count, r.primitive_offset)),
            instances: flags & MOTION_NV == 0,
        };
        let geometries = arena.geometry_arrays(&mut input, m, |g| Some(host(g)));
        let next = arena.chain(&mut input, std::ptr::null());
        let info = arena.build_info(&mut input, next, ty, flags, geometry_count, geometries);
        infos.push(info);
        range_pointers.push(match ranges {
            Some(list) => {
                let p = list.as_ptr();
                arena.ranges.push(list);
                p
            }
            None => std::ptr::null(),
        });
    }
    let ranges: Box<[_]> = range_pointers.into_boxed_slice();
    let ranges_pointer = if no_ranges {
        std::ptr::null()
    } else {
        ranges.as_ptr()
    };
    arena.range_pointers.push(ranges);

    let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
    // SAFETY: every pointer points into `arena`, holding the elements its
    // count describes (up to the reader's bounds); unions hold the member
    // their geometryType selects; every host address the reader reads is
    // readable for the extent it documents (see the module).
    let report =
        unsafe { v.build_acceleration_structures_raw(info_count, infos.as_ptr(), ranges_pointer) };
    out += &format!("{report:?}\n");
    if input.below(8) == 0 {
        // pInfos and ppBuildRangeInfos NULL with any count: reported, never read.
        let count = input.u32();
        // SAFETY: NULL arrays are not read.
        let report = unsafe {
            v.build_acceleration_structures_raw(count, std::ptr::null(), std::ptr::null())
        };
        out += &format!("{report:?}\n");
    }
    out
}
