//! The structures the ash-struct targets build from the input, shared by
//! `raw_reader` (device builds, addresses as plain numbers) and
//! `host_build` (host builds, addresses pointing into the [`Arena`]): pNext
//! chains (cyclic ones included), usage-count arrays and pointer arrays,
//! geometries with opacity attachments, all with counts up to 2^32 − 1.
//!
//! With `host` None every helper reads the input exactly as `raw_reader`
//! always has, so its corpus keeps describing the same structures. With a
//! [`HostGeometry`], each host address the reader of
//! `vkBuildAccelerationStructuresKHR` documents it reads gets an arena
//! allocation of exactly the bytes it may read (see [`Arena::host_bytes`]);
//! addresses it documents it does not read keep the input's number, which
//! is no pointer of this process: reading one would crash.

use std::ffi::c_void;

use ash::vk;
use ommcheck::model::accel::{
    STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA, STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR,
};
use ommcheck::raw::{MAX_ELEMENTS, MAX_HOST_BYTES};
use ommcheck_vuids::khr;

use crate::input::Input;

/// A pNext chain element of a type the target does not model: sType and
/// pNext, then zeros to 256 bytes. Whatever structure its sType names (the
/// fuzzer may name one the reader knows), every member lies inside the node
/// and reads as zero (NULL pointers, zero counts), which makes it a valid
/// structure of that type.
#[repr(C)]
pub(crate) struct Node {
    s_type: vk::StructureType,
    p_next: *const c_void,
    rest: [u64; 30],
}

pub(crate) type OmmExt = vk::AccelerationStructureTrianglesOpacityMicromapEXT<'static>;
pub(crate) type Geometry = vk::AccelerationStructureGeometryKHR<'static>;
pub(crate) type OmmKhr = khr::AccelerationStructureTrianglesOpacityMicromapKHR;
pub(crate) type MicromapData = khr::AccelerationStructureGeometryMicromapDataKHR<'static>;
pub(crate) type Instance = vk::AccelerationStructureInstanceKHR;

/// Every allocation the structures point into; kept alive for the calls.
/// Boxes do not move when the vectors holding them grow (the elements of a
/// `Vec<T>` would), so pointers taken into them stay valid.
#[allow(clippy::vec_box)]
#[derive(Default)]
pub(crate) struct Arena {
    pub(crate) nodes: Vec<Box<Node>>,
    pub(crate) omms: Vec<Box<OmmExt>>,
    pub(crate) usages: Vec<Box<[vk::MicromapUsageEXT]>>,
    pub(crate) usage_pointers: Vec<Box<[*const vk::MicromapUsageEXT]>>,
    pub(crate) single_usages: Vec<Box<vk::MicromapUsageEXT>>,
    pub(crate) bytes: Vec<Box<[u8]>>,
    pub(crate) geometries: Vec<Box<[Geometry]>>,
    pub(crate) geometry_pointers: Vec<Box<[*const Geometry]>>,
    pub(crate) single_geometries: Vec<Box<Geometry>>,
    pub(crate) ranges: Vec<Box<[vk::AccelerationStructureBuildRangeInfoKHR]>>,
    pub(crate) range_pointers: Vec<Box<[*const vk::AccelerationStructureBuildRangeInfoKHR]>>,
    pub(crate) counts: Vec<Box<[u32]>>,
    // Host builds only.
    pub(crate) omms_khr: Vec<Box<OmmKhr>>,
    pub(crate) micromap_data: Vec<Box<MicromapData>>,
    pub(crate) instances: Vec<Box<[Instance]>>,
    pub(crate) instance_pointers: Vec<Box<[*const Instance]>>,
    pub(crate) single_instances: Vec<Box<Instance>>,
}

/// What a geometry of a host build is read with: where the reader reads
/// memory for it, the target gives it exactly that much.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HostGeometry {
    /// `primitiveCount` and `primitiveOffset` of its build range; None when
    /// the call gives none for it (`ppBuildRangeInfos` or its element NULL),
    /// and nothing whose extent they describe is read.
    pub(crate) range: Option<(u32, u32)>,
    /// Whether instance data is read for it: not in MOTION_NV builds, whose
    /// instances are `VkAccelerationStructureMotionInstanceNV`, which the
    /// reader documents it does not read.
    pub(crate) instances: bool,
}

/// The most bytes (or instances) the target allocates for one host array:
/// past this and within the reader's bound the address is NULL instead, as
/// the reader reads nothing at NULL. Allocating everything up to the bound
/// (2^28 bytes) per input would make the target too slow to find anything.
pub(crate) const HOST_ALLOCATION: u64 = 1 << 16;
/// As [`HOST_ALLOCATION`], in instances (64 bytes each) or pointers.
pub(crate) const HOST_INSTANCES: usize = 1 << 12;

/// `VK_GEOMETRY_TYPE_MICROMAP_KHR`.
const GEOMETRY_TYPE_MICROMAP: vk::GeometryTypeKHR = khr::GEOMETRY_TYPE_MICROMAP_KHR;

/// Bytes `count` elements of `size` bytes at `stride` span, as the API
/// describes an index buffer or triangle array: `(count − 1) × stride +
/// size`; Some(0) for none, None past 2^64.
pub(crate) fn strided_extent(count: u64, stride: u64, size: u64) -> Option<u64> {
    match count.checked_sub(1) {
        None => Some(0),
        Some(last) => last.checked_mul(stride)?.checked_add(size),
    }
}

/// Σ count over the usages the reader reads from a usage-count triple the
/// arena holds: the elements of `pUsageCounts` when it is set, else the
/// non-NULL elements of `ppUsageCounts`, up to [`MAX_ELEMENTS`] of either.
pub(crate) fn usage_total(
    count: u32,
    array: *const vk::MicromapUsageEXT,
    pointers: *const *const vk::MicromapUsageEXT,
) -> u64 {
    let n = (count as usize).min(MAX_ELEMENTS);
    if !array.is_null() {
        // SAFETY: the arena holds `n` usages there (`Arena::usage_counts`).
        unsafe { std::slice::from_raw_parts(array, n) }
            .iter()
            .map(|u| u64::from(u.count))
            .sum()
    } else if !pointers.is_null() {
        // SAFETY: the arena holds `n` pointers there, each NULL or to one usage.
        unsafe { std::slice::from_raw_parts(pointers, n) }
            .iter()
            .filter_map(|p| unsafe { p.as_ref() })
            .map(|u| u64::from(u.count))
            .sum()
    } else {
        0
    }
}

/// An index size the reader knows (None: NONE or no index type; nothing read).
fn index_size(index_type: vk::IndexType) -> Option<u64> {
    match index_type {
        vk::IndexType::UINT8_EXT => Some(1),
        vk::IndexType::UINT16 => Some(2),
        vk::IndexType::UINT32 => Some(4),
        _ => None,
    }
}

/// A host index type: the three sizes, NONE, or any value.
fn host_index_type(input: &mut Input<'_>) -> vk::IndexType {
    match input.below(5) {
        0 => vk::IndexType::UINT16,
        1 => vk::IndexType::UINT32,
        2 => vk::IndexType::UINT8_EXT,
        3 => vk::IndexType::NONE_KHR,
        _ => vk::IndexType::from_raw(input.i32()),
    }
}

/// A stride: mostly small, sometimes any (past MAX_HOST_BYTES, or 2^64, in
/// the extent it gives).
fn host_stride(input: &mut Input<'_>) -> u64 {
    if input.below(8) == 0 {
        input.u64()
    } else {
        u64::from(input.u8() % 16)
    }
}

/// The usage past the first 8 elements of a usage array (see `raw.rs`): no
/// triangles of the 2-state format at level 0, which no check finds wrong.
pub(crate) const VALID_USAGE: vk::MicromapUsageEXT = vk::MicromapUsageEXT {
    count: 0,
    subdivision_level: 0,
    format: 1,
};

/// As [`VALID_USAGE`] in the 4-state format, for the usages of a KHR
/// micromap geometry: in a MICROMAP_LOSSY build every one of them must be
/// 4-state (VUID 11712), so a 2-state fill made each of up to 2^20 elements
/// a finding, and such an input a libFuzzer timeout (2 × 1 s in release).
pub(crate) const VALID_LOSSY_USAGE: vk::MicromapUsageEXT = vk::MicromapUsageEXT {
    format: 2,
    ..VALID_USAGE
};

/// A count: mostly small, one time in eight any u32 (up to 2^32 − 1).
pub(crate) fn count(input: &mut Input<'_>) -> u32 {
    let c = input.u8();
    if c & 7 == 7 {
        input.u32()
    } else {
        u32::from(c >> 3) % 5
    }
}

/// `n` elements, the first few from `make`, the rest `fill`.
pub(crate) fn elements<T: Copy>(n: usize, fill: T, mut make: impl FnMut() -> T) -> Box<[T]> {
    let mut list = vec![fill; n];
    for slot in list.iter_mut().take(8) {
        *slot = make();
    }
    list.into_boxed_slice()
}

/// Moves `value` into a box `list` keeps and returns its address, which
/// stays valid while the arena lives (a box's contents do not move when
/// `list` grows).
#[allow(clippy::vec_box)]
fn keep<T>(list: &mut Vec<Box<T>>, value: T) -> *const T {
    let boxed = Box::new(value);
    let address: *const T = &*boxed;
    list.push(boxed);
    address
}

pub(crate) fn usage(input: &mut Input<'_>) -> vk::MicromapUsageEXT {
    vk::MicromapUsageEXT {
        count: input.u32_mostly_below(8),
        subdivision_level: input.u32_mostly_below(14),
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
    pub(crate) fn chain(&mut self, input: &mut Input<'_>, tail: *const c_void) -> *const c_void {
        let n = input.below(4) as usize;
        let first = self.nodes.len();
        for _ in 0..n {
            let s_type = match input.below(4) {
                0 => vk::StructureType::from_raw(input.i32()),
                1 => vk::StructureType::ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT,
                2 => vk::StructureType::from_raw(STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA),
                _ => vk::StructureType::from_raw(STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR),
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
    pub(crate) fn usage_counts(
        &mut self,
        input: &mut Input<'_>,
        valid: vk::MicromapUsageEXT,
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
        if which & 1 == 1 {
            let list = elements(n, valid, || usage(input));
            array = list.as_ptr();
            self.usages.push(list);
        }
        if which & 2 == 2 {
            let fill = keep(&mut self.single_usages, valid);
            let list = elements(n, fill, || {
                if input.below(4) == 0 {
                    std::ptr::null()
                } else {
                    keep(&mut self.single_usages, usage(input))
                }
            });
            pointers = list.as_ptr();
            self.usage_pointers.push(list);
        }
        (count, array, pointers)
    }

    pub(crate) fn bytes(&mut self, len: usize, seed: &[u8]) -> *const u8 {
        let list: Box<[u8]> = (0..len)
            .map(|k| seed.get(k % seed.len().max(1)).copied().unwrap_or(0))
            .collect();
        let p = list.as_ptr();
        self.bytes.push(list);
        p
    }

    /// An EXT opacity attachment whose pNext chain ends in `tail`. For a
    /// host build, its index buffer holds the indices its geometry's
    /// `primitiveCount` describes (see [`Self::host_bytes`]).
    pub(crate) fn omm(
        &mut self,
        input: &mut Input<'_>,
        tail: *const c_void,
        host: Option<HostGeometry>,
    ) -> *const c_void {
        let (count, array, pointers) = self.usage_counts(input, VALID_USAGE);
        let next = if input.below(4) == 0 {
            self.chain(input, tail)
        } else {
            tail
        };
        let mut omm = OmmExt {
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
        };
        if let Some(host) = host {
            // The members above are read as `raw_reader` reads them (its
            // corpus stays what it was); a host build picks the index type
            // and stride again from wider sets (UINT8, strides past
            // MAX_HOST_BYTES), and backs the index buffer they describe.
            omm.index_type = host_index_type(input);
            omm.index_stride = host_stride(input);
            // SAFETY: the union was written as a u64 just above.
            let number = unsafe { omm.index_buffer.device_address };
            let address = self.index_buffer(input, host, omm.index_type, omm.index_stride, number);
            omm.index_buffer = vk::DeviceOrHostAddressConstKHR {
                device_address: address,
            };
        }
        keep(&mut self.omms, omm).cast()
    }

    /// A KHR opacity attachment of a host build (`raw_reader` builds only
    /// zeroed ones, in [`Self::chain`]), its index buffer as for the EXT one.
    fn omm_khr(&mut self, input: &mut Input<'_>, host: HostGeometry) -> *const c_void {
        let next = self.chain(input, std::ptr::null());
        let index_type = host_index_type(input);
        let index_stride = host_stride(input);
        let number = input.u64();
        let omm = OmmKhr {
            p_next: next.cast_mut(),
            index_type,
            index_buffer: self.index_buffer(input, host, index_type, index_stride, number),
            index_stride,
            base_triangle: input.u32(),
            micromap: vk::Handle::from_raw(u64::from(input.u8())),
            ..Default::default()
        };
        keep(&mut self.omms_khr, omm).cast()
    }

    /// An opacity index buffer for `host`'s geometry: read for
    /// `(primitiveCount − 1) × stride + index size` bytes when the build
    /// range is there and the type has a size; `number` (no pointer) where
    /// nothing is read.
    fn index_buffer(
        &mut self,
        input: &mut Input<'_>,
        host: HostGeometry,
        index_type: vk::IndexType,
        stride: u64,
        number: u64,
    ) -> u64 {
        let extent = match (host.range, index_size(index_type)) {
            (Some((count, _)), Some(size)) => strided_extent(u64::from(count), stride, size),
            _ => Some(0),
        };
        self.host_bytes(input, extent, number)
    }

    /// The address of a host array the reader reads for `extent` bytes
    /// (None: past 2^64): an allocation of exactly that many bytes, or,
    /// where the reader documents it reads nothing (no bytes, or more than
    /// [`MAX_HOST_BYTES`]), `number`, which is no pointer of this process;
    /// between [`HOST_ALLOCATION`] and the bound, NULL (not read).
    pub(crate) fn host_bytes(
        &mut self,
        input: &mut Input<'_>,
        extent: Option<u64>,
        number: u64,
    ) -> u64 {
        let seed = input.bytes(32);
        match extent {
            Some(0) | None => number,
            Some(e) if e > MAX_HOST_BYTES => number,
            Some(e) if e <= HOST_ALLOCATION => {
                self.bytes(e as usize, seed).expose_provenance() as u64
            }
            Some(_) => 0,
        }
    }

    /// A `VkAccelerationStructureGeometryMicromapDataKHR` of a host build,
    /// its triangle array holding the `(Σ usage counts − 1) × stride + 8`
    /// bytes the reader reads; `data` is not read (its extent comes from
    /// the entries).
    fn micromap_data(&mut self, input: &mut Input<'_>) -> *const c_void {
        let (count, array, pointers) = self.usage_counts(input, VALID_LOSSY_USAGE);
        let next = if input.below(4) == 0 {
            self.chain(input, std::ptr::null())
        } else {
            std::ptr::null()
        };
        let stride = host_stride(input);
        let extent = strided_extent(usage_total(count, array, pointers), stride, 8);
        let number = input.u64();
        let triangle_array = self.host_bytes(input, extent, number);
        let data = MicromapData {
            p_next: next,
            usage_counts_count: count,
            // VkMicromapUsageKHR and VkMicromapUsageEXT have one layout.
            p_usage_counts: array.cast(),
            pp_usage_counts: pointers.cast(),
            data: input.u64(),
            triangle_array,
            triangle_array_stride: stride,
            ..Default::default()
        };
        keep(&mut self.micromap_data, data).cast()
    }

    /// The `data` of an instances geometry of a host build: `count`
    /// instances (or, with `arrayOfPointers`, pointers, each NULL or to one
    /// instance) from `data + primitiveOffset`, the first few from the
    /// input. `number` where nothing is read (no range, a MOTION_NV build);
    /// NULL for more instances than the target allocates; for more than
    /// the reader's bound ([`MAX_ELEMENTS`]), exactly that many (one time
    /// in four, where affordable) or NULL.
    fn host_instances(
        &mut self,
        input: &mut Input<'_>,
        host: HostGeometry,
        pointers: bool,
        number: u64,
    ) -> u64 {
        let Some((count, offset)) = host.range.filter(|_| host.instances) else {
            return number;
        };
        let mut n = count as usize;
        if n > MAX_ELEMENTS {
            // Past the reader's bound: exactly the bound, one time in four,
            // where the target can afford it (pointers: 8 MiB at the real
            // bound; instances only at cargo-fuzz's small one); else NULL.
            let affordable = pointers || MAX_ELEMENTS <= HOST_INSTANCES;
            if affordable && input.below(4) == 0 {
                n = MAX_ELEMENTS;
            } else {
                return 0;
            }
        } else if n > HOST_INSTANCES {
            return 0;
        }
        let start = if pointers {
            let list = elements(n, std::ptr::null(), || {
                if input.below(4) == 0 {
                    std::ptr::null()
                } else {
                    keep(&mut self.single_instances, instance(input))
                }
            });
            let p = list.as_ptr().expose_provenance();
            self.instance_pointers.push(list);
            p
        } else {
            let zero = instance(&mut Input::new(&[]));
            let list = elements(n, zero, || instance(input));
            let p = list.as_ptr().expose_provenance();
            self.instances.push(list);
            p
        };
        // The API reads from data + primitiveOffset: data lies that far
        // before the allocation (outside it, for a non-zero offset).
        (start as u64).wrapping_sub(u64::from(offset))
    }

    /// `pGeometries` and `ppGeometries` for `n` geometries: either, both
    /// or neither (NULL), elements of `ppGeometries` NULL one time in four.
    /// Geometry `g` of either array is made with `host(g)`.
    pub(crate) fn geometry_arrays(
        &mut self,
        input: &mut Input<'_>,
        n: usize,
        host: impl Fn(usize) -> Option<HostGeometry>,
    ) -> (*const Geometry, *const *const Geometry) {
        let which = input.below(4);
        let mut array = std::ptr::null();
        let mut pointers = std::ptr::null();
        if which & 1 == 1 {
            let mut g = 0;
            let list = elements(n, Geometry::default(), || {
                g += 1;
                self.geometry(input, host(g - 1))
            });
            array = list.as_ptr();
            self.geometries.push(list);
        }
        if which & 2 == 2 {
            let mut g = 0;
            let list = elements(n, std::ptr::null(), || {
                g += 1;
                if input.below(4) == 0 {
                    std::ptr::null()
                } else {
                    let one = self.geometry(input, host(g - 1));
                    keep(&mut self.single_geometries, one)
                }
            });
            pointers = list.as_ptr();
            self.geometry_pointers.push(list);
        }
        (array, pointers)
    }

    /// A build geometry info of `ty` and `flags` (chosen by the caller: a
    /// host build sizes its reads by them) over the given geometries.
    pub(crate) fn build_info(
        &mut self,
        input: &mut Input<'_>,
        next: *const c_void,
        ty: vk::AccelerationStructureTypeKHR,
        flags: u32,
        geometry_count: u32,
        (array, pointers): (*const Geometry, *const *const Geometry),
    ) -> vk::AccelerationStructureBuildGeometryInfoKHR<'static> {
        vk::AccelerationStructureBuildGeometryInfoKHR {
            p_next: next,
            ty,
            flags: vk::BuildAccelerationStructureFlagsKHR::from_raw(flags),
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
        }
    }

    /// A geometry. For a host build (`host` set), also of micromap type,
    /// with a micromap-data structure and KHR opacity attachments, and
    /// every host address the reader reads backed as [`Self::host_bytes`]
    /// describes.
    pub(crate) fn geometry(
        &mut self,
        input: &mut Input<'_>,
        host: Option<HostGeometry>,
    ) -> Geometry {
        let ty = match input.below(5) {
            0 | 1 => vk::GeometryTypeKHR::TRIANGLES,
            2 => vk::GeometryTypeKHR::AABBS,
            3 => vk::GeometryTypeKHR::INSTANCES,
            _ if host.is_some() && input.bool() => GEOMETRY_TYPE_MICROMAP,
            _ => vk::GeometryTypeKHR::from_raw(input.i32()),
        };
        // The micromap data is read from any geometry's chain (a micromap
        // geometry without one breaks a VUID, and its chain is read all the same).
        let tail = match host {
            Some(_) if ty == GEOMETRY_TYPE_MICROMAP || input.below(4) == 0 => {
                self.micromap_data(input)
            }
            _ => std::ptr::null(),
        };
        let next = self.chain(input, tail);
        let mut geometry = Geometry {
            p_next: next,
            geometry_type: ty,
            flags: vk::GeometryFlagsKHR::from_raw(input.u32()),
            ..Default::default()
        };
        match ty {
            vk::GeometryTypeKHR::TRIANGLES => {
                let khr = match host {
                    Some(host) if input.bool() => self.omm_khr(input, host),
                    _ => std::ptr::null(),
                };
                let omm = if input.below(4) != 0 {
                    self.omm(input, khr, host)
                } else {
                    khr
                };
                let next = self.chain(input, omm);
                // Vertex, index and transform data are not read by any
                // reader (no check looks at them): numbers, for a host
                // build too.
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
                let mut instances = vk::AccelerationStructureGeometryInstancesDataKHR {
                    p_next: self.chain(input, std::ptr::null()),
                    array_of_pointers: u32::from(input.bool()),
                    data: vk::DeviceOrHostAddressConstKHR {
                        device_address: input.u64(),
                    },
                    ..Default::default()
                };
                if let Some(host) = host {
                    // SAFETY: the union was written as a u64 just above.
                    let number = unsafe { instances.data.device_address };
                    let pointers = instances.array_of_pointers != 0;
                    instances.data = vk::DeviceOrHostAddressConstKHR {
                        device_address: self.host_instances(input, host, pointers, number),
                    };
                }
                geometry.geometry.instances = instances;
            }
            // Another type: the union stays zero (no member is selected).
            _ => {}
        }
        geometry
    }
}

/// One instance: any custom index, mask, binding-table offset, flags and
/// reference (the members the checks look at), an identity-free transform.
fn instance(input: &mut Input<'_>) -> Instance {
    let (index, offset) = (input.u32(), input.u32());
    Instance {
        transform: vk::TransformMatrixKHR { matrix: [0.0; 12] },
        instance_custom_index_and_mask: vk::Packed24_8::new(index & 0xff_ffff, (index >> 24) as u8),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            offset & 0xff_ffff,
            (offset >> 24) as u8,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
            device_handle: input.u64(),
        },
    }
}
