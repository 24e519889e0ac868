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

use std::ffi::c_void;

use ash::vk;
use ommcheck::model::CommandBuffer;
use ommcheck::raw::accel::MAX_GEOMETRIES;
use ommcheck::raw::{ReadableHost, MAX_ELEMENTS, MAX_HOST_BYTES};
use ommcheck::{Device, Profile, Validator};

use crate::input::Input;

pub fn run(data: &[u8]) {
    let first = body(data);
    let second = body(data);
    assert_eq!(first, second, "the same structures read differently");
}

/// A pNext chain element of a type the target does not model: sType and
/// pNext, then zeros to 256 bytes. Whatever structure its sType names (the
/// fuzzer may name one the reader knows), every member lies inside the node
/// and reads as zero (NULL pointers, zero counts), which makes it a valid
/// structure of that type.
#[repr(C)]
struct Node {
    s_type: vk::StructureType,
    p_next: *const c_void,
    rest: [u64; 30],
}

type OmmExt = vk::AccelerationStructureTrianglesOpacityMicromapEXT<'static>;
type Geometry = vk::AccelerationStructureGeometryKHR<'static>;

/// Every allocation the structures point into; kept alive for the calls.
/// Boxes do not move when the vectors holding them grow (the elements of a
/// `Vec<T>` would), so pointers taken into them stay valid.
#[allow(clippy::vec_box)]
#[derive(Default)]
struct Arena {
    nodes: Vec<Box<Node>>,
    omms: Vec<Box<OmmExt>>,
    usages: Vec<Box<[vk::MicromapUsageEXT]>>,
    usage_pointers: Vec<Box<[*const vk::MicromapUsageEXT]>>,
    single_usages: Vec<Box<vk::MicromapUsageEXT>>,
    bytes: Vec<Box<[u8]>>,
    geometries: Vec<Box<[Geometry]>>,
    geometry_pointers: Vec<Box<[*const Geometry]>>,
    single_geometries: Vec<Box<Geometry>>,
    ranges: Vec<Box<[vk::AccelerationStructureBuildRangeInfoKHR]>>,
    range_pointers: Vec<Box<[*const vk::AccelerationStructureBuildRangeInfoKHR]>>,
    counts: Vec<Box<[u32]>>,
}

/// A count: mostly small, one time in eight any u32 (up to 2^32 − 1).
fn count(input: &mut Input<'_>) -> u32 {
    let c = input.u8();
    if c & 7 == 7 {
        input.u32()
    } else {
        u32::from(c >> 3) % 5
    }
}

/// `n` elements, the first few from `make`, the rest `fill`.
fn elements<T: Copy>(n: usize, fill: T, mut make: impl FnMut() -> T) -> Box<[T]> {
    let mut list = vec![fill; n];
    for slot in list.iter_mut().take(8) {
        *slot = make();
    }
    list.into_boxed_slice()
}

fn usage(input: &mut Input<'_>) -> vk::MicromapUsageEXT {
    vk::MicromapUsageEXT {
        count: if input.bool() {
            input.u32()
        } else {
            u32::from(input.u8() % 8)
        },
        subdivision_level: if input.bool() {
            input.u32()
        } else {
            u32::from(input.u8() % 14)
        },
        format: match input.below(4) {
            0 | 1 => 1,
            2 => 2,
            _ => input.u32(),
        },
    }
}

impl Arena {
    /// A pNext chain of up to 3 nodes, each linking to a node (itself and
    /// earlier ones included: cycles), to `tail`, or to nothing.
    fn chain(&mut self, input: &mut Input<'_>, tail: *const c_void) -> *const c_void {
        let n = input.below(4) as usize;
        let first = self.nodes.len();
        for _ in 0..n {
            let s_type = match input.below(4) {
                0 => vk::StructureType::from_raw(input.i32()),
                1 => vk::StructureType::ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT,
                2 => vk::StructureType::from_raw(
                    ommcheck::model::accel::STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA,
                ),
                _ => vk::StructureType::from_raw(
                    ommcheck::model::accel::STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR,
                ),
            };
            self.nodes.push(Box::new(Node {
                s_type,
                p_next: std::ptr::null(),
                rest: [0; 30],
            }));
        }
        let addresses: Vec<*const c_void> = self.nodes[first..]
            .iter()
            .map(|node| (&**node as *const Node).cast())
            .collect();
        for k in 0..n {
            let to = input.below(n as u32 + 2) as usize;
            self.nodes[first + k].p_next = match to {
                t if t < n => addresses[t],
                t if t == n => tail,
                _ => std::ptr::null(),
            };
        }
        addresses.first().copied().unwrap_or(tail)
    }

    /// A usage-count triple: (count, pUsageCounts, ppUsageCounts).
    fn usage_counts(
        &mut self,
        input: &mut Input<'_>,
    ) -> (
        u32,
        *const vk::MicromapUsageEXT,
        *const *const vk::MicromapUsageEXT,
    ) {
        let count = count(input);
        let n = (count as usize).min(MAX_ELEMENTS);
        let which = input.below(4);
        let mut array = std::ptr::null();
        let mut pointers = std::ptr::null();
        let valid = vk::MicromapUsageEXT {
            count: 0,
            subdivision_level: 0,
            format: 1,
        };
        if which & 1 == 1 {
            let list = elements(n, valid, || usage(input));
            array = list.as_ptr();
            self.usages.push(list);
        }
        if which & 2 == 2 {
            let shared = Box::new(valid);
            let fill: *const vk::MicromapUsageEXT = &*shared;
            self.single_usages.push(shared);
            let list = elements(n, fill, || {
                if input.below(4) == 0 {
                    std::ptr::null()
                } else {
                    let one = Box::new(usage(input));
                    let p: *const vk::MicromapUsageEXT = &*one;
                    self.single_usages.push(one);
                    p
                }
            });
            pointers = list.as_ptr();
            self.usage_pointers.push(list);
        }
        (count, array, pointers)
    }

    fn bytes(&mut self, len: usize, seed: &[u8]) -> *const u8 {
        let list: Box<[u8]> = (0..len)
            .map(|k| seed.get(k % seed.len().max(1)).copied().unwrap_or(0))
            .collect();
        let p = list.as_ptr();
        self.bytes.push(list);
        p
    }

    fn omm(&mut self, input: &mut Input<'_>) -> *const c_void {
        let (count, array, pointers) = self.usage_counts(input);
        let next = if input.below(4) == 0 {
            self.chain(input, std::ptr::null())
        } else {
            std::ptr::null()
        };
        let omm = Box::new(OmmExt {
            p_next: next.cast_mut(),
            index_type: vk::IndexType::from_raw(match input.below(4) {
                0 => vk::IndexType::UINT16.as_raw(),
                1 => vk::IndexType::UINT32.as_raw(),
                2 => vk::IndexType::NONE_KHR.as_raw(),
                _ => input.i32(),
            }),
            index_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: input.u64(),
            },
            index_stride: u64::from(input.u8()),
            base_triangle: input.u32(),
            usage_counts_count: count,
            p_usage_counts: array,
            pp_usage_counts: pointers,
            micromap: vk::Handle::from_raw(u64::from(input.u8())),
            ..Default::default()
        });
        let p = (&*omm as *const OmmExt).cast();
        self.omms.push(omm);
        p
    }

    fn geometry(&mut self, input: &mut Input<'_>) -> Geometry {
        let ty = match input.below(5) {
            0 | 1 => vk::GeometryTypeKHR::TRIANGLES,
            2 => vk::GeometryTypeKHR::AABBS,
            3 => vk::GeometryTypeKHR::INSTANCES,
            _ => vk::GeometryTypeKHR::from_raw(input.i32()),
        };
        let next = self.chain(input, std::ptr::null());
        let mut geometry = Geometry {
            p_next: next,
            geometry_type: ty,
            flags: vk::GeometryFlagsKHR::from_raw(input.u32()),
            ..Default::default()
        };
        match ty {
            vk::GeometryTypeKHR::TRIANGLES => {
                let omm = if input.below(4) != 0 {
                    self.omm(input)
                } else {
                    std::ptr::null()
                };
                let next = self.chain(input, omm);
                geometry.geometry.triangles = vk::AccelerationStructureGeometryTrianglesDataKHR {
                    p_next: next,
                    vertex_format: vk::Format::from_raw(input.i32()),
                    vertex_data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    vertex_stride: u64::from(input.u16()),
                    max_vertex: input.u32(),
                    index_type: vk::IndexType::from_raw(i32::from(input.u8() % 4)),
                    index_data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    transform_data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    ..Default::default()
                };
            }
            vk::GeometryTypeKHR::AABBS => {
                geometry.geometry.aabbs = vk::AccelerationStructureGeometryAabbsDataKHR {
                    p_next: self.chain(input, std::ptr::null()),
                    data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    stride: u64::from(input.u16()),
                    ..Default::default()
                };
            }
            vk::GeometryTypeKHR::INSTANCES => {
                geometry.geometry.instances = vk::AccelerationStructureGeometryInstancesDataKHR {
                    p_next: self.chain(input, std::ptr::null()),
                    array_of_pointers: u32::from(input.bool()),
                    data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    ..Default::default()
                };
            }
            // Another type: the union stays zero (no member is selected).
            _ => {}
        }
        geometry
    }
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
        let (count, array, pointers) = arena.usage_counts(&mut input);
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
            triangle_array_stride: if input.bool() {
                input.u64()
            } else {
                u64::from(input.u8() % 16)
            },
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
        let entries: Vec<vk::MicromapUsageEXT> = if !info.p_usage_counts.is_null() {
            let n = (info.usage_counts_count as usize).min(MAX_ELEMENTS);
            // SAFETY: the arena holds `n` usages there.
            unsafe { std::slice::from_raw_parts(info.p_usage_counts, n) }.to_vec()
        } else if !info.pp_usage_counts.is_null() {
            let n = (info.usage_counts_count as usize).min(MAX_ELEMENTS);
            // SAFETY: the arena holds `n` pointers there, each NULL or to one usage.
            unsafe { std::slice::from_raw_parts(info.pp_usage_counts, n) }
                .iter()
                .filter_map(|p| unsafe { p.as_ref() }.copied())
                .collect()
        } else {
            Vec::new()
        };
        let total: u64 = entries.iter().map(|u| u64::from(u.count)).sum();
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
        let which = input.below(4);
        let mut array = std::ptr::null();
        let mut pointers = std::ptr::null();
        if which & 1 == 1 {
            let list = elements(n, Geometry::default(), || arena.geometry(&mut input));
            array = list.as_ptr();
            arena.geometries.push(list);
        }
        if which & 2 == 2 {
            let list = elements(n, std::ptr::null(), || {
                if input.below(4) == 0 {
                    std::ptr::null()
                } else {
                    let one = Box::new(arena.geometry(&mut input));
                    let p: *const Geometry = &*one;
                    arena.single_geometries.push(one);
                    p
                }
            });
            pointers = list.as_ptr();
            arena.geometry_pointers.push(list);
        }
        let next = arena.chain(&mut input, std::ptr::null());
        as_infos.push(vk::AccelerationStructureBuildGeometryInfoKHR {
            p_next: next,
            ty: vk::AccelerationStructureTypeKHR::from_raw(i32::from(input.u8() % 4)),
            flags: vk::BuildAccelerationStructureFlagsKHR::from_raw(input.u32()),
            mode: vk::BuildAccelerationStructureModeKHR::from_raw(i32::from(input.u8() % 3)),
            src_acceleration_structure: vk::Handle::from_raw(u64::from(input.u8())),
            dst_acceleration_structure: vk::Handle::from_raw(u64::from(input.u8())),
            geometry_count,
            p_geometries: array,
            pp_geometries: pointers,
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: input.u64(),
            },
            ..Default::default()
        });
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
                    primitive_count: if input.bool() {
                        input.u32()
                    } else {
                        u32::from(input.u8())
                    },
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
