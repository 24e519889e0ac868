//! Objects the checks track across calls: buffers and their memory,
//! micromaps, acceleration structures and query pools.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use crate::model::Handle;
use crate::sim::decode::owned_if_within;
use crate::Bytes;

use serde::{Deserialize, Serialize};

mod buffers;
pub mod execution;
pub mod provenance;
pub use buffers::{BufferMut, Buffers, WALK_AT_MOST};

/// The memory a buffer is bound to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MemoryBinding {
    /// Allocated from a memory type with VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT.
    pub host_visible: bool,
    /// Allocated with multiple instances (device groups).
    pub multi_instance: bool,
}

/// A `VkBuffer`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Buffer {
    pub size: u64,
    /// `VkBufferUsageFlags2` bits (a superset of `VkBufferUsageFlags`).
    pub usage: u64,
    /// `VkBufferCreateFlags` bits.
    pub create_flags: u32,
    /// What `vkGetBufferDeviceAddress` returned, if it was queried.
    pub device_address: Option<u64>,
    /// Set once the buffer is bound to memory.
    pub memory: Option<MemoryBinding>,
    /// The buffer's bytes where the checker can read them (a host-visible
    /// mapping, or the contents a scene or test supplied), starting
    /// `contents_offset` bytes into the buffer.
    pub contents: Option<Bytes>,
    /// Where in the buffer `contents` starts: 0, unless only a window of
    /// the buffer is known (an adaptor that read back just the ranges a
    /// build reads).
    pub contents_offset: u64,
}

impl Buffer {
    /// The known contents from device `address` on, with `address`'s offset
    /// in them; None when `address` lies before the known window or the
    /// buffer has no address or contents. An address one past the window
    /// gives an empty tail.
    fn contents_at(&self, address: u64) -> Option<(&Bytes, usize)> {
        let (start, _) = self.address_range()?;
        let contents = self.contents.as_ref()?;
        let window = start.checked_add(self.contents_offset)?;
        let offset = usize::try_from(address.checked_sub(window)?).ok()?;
        (offset <= contents.len()).then_some((contents, offset))
    }

    /// The device-address range `[start, end)`, if the address is known.
    pub fn address_range(&self) -> Option<(u64, u64)> {
        let start = self.device_address?;
        Some((start, start.saturating_add(self.size)))
    }
}

/// What a completed build recorded about a micromap or acceleration structure.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BuildRecord {
    /// The build's `flags`.
    pub flags: u32,
    /// The build's `type`.
    pub ty: i32,
    /// Sum of the build's usage counts: the number of micromap triangles.
    pub triangle_count: u64,
    /// A micromap build's triangle array (decoded, as far as the checker
    /// could read it) and its data (shared with the buffer or host memory it
    /// was read from, never copied); None when the contents were unreadable.
    pub content: Option<Arc<crate::sim::decode::MicromapContent>>,
    /// A bottom-level build's geometries, by index, for the simulator:
    /// triangles geometries with what locates their vertices and opacity
    /// attachments (None for other geometry types).
    pub geometries: Vec<Option<TriangleGeometryRecord>>,
    /// The build read host addresses (`vkBuildAccelerationStructuresKHR`).
    pub host: bool,
    /// A micromap build's usage counts summed per (format, subdivision
    /// level), keys in order, zero counts left out: kept from the content
    /// tier up (with [`Self::content`]) so that a picture can set them
    /// against the triangle array (`ommcheck draw --usage-counts`).
    pub usage_counts: Vec<((u32, u32), u64)>,
}

/// A triangles geometry of a recorded bottom-level build: where its
/// vertices and indices are, its flags and build range, and its opacity
/// attachment.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TriangleGeometryRecord {
    /// `VkGeometryFlagsKHR` bits (OPAQUE is 0x1).
    pub flags: u32,
    pub vertex_format: i32,
    pub vertex_data: u64,
    pub vertex_stride: u64,
    pub max_vertex: u32,
    pub index_type: i32,
    pub index_data: u64,
    pub transform_data: u64,
    /// The build range (None: the command had none, e.g. an indirect build).
    pub range: Option<crate::model::accel::BuildRangeInfo>,
    /// The EXT or KHR opacity micromap attachment.
    pub opacity: Option<OpacityAttachmentRecord>,
}

/// An opacity micromap attachment of a recorded geometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpacityAttachmentRecord {
    /// `VkAccelerationStructureTrianglesOpacityMicromapKHR` (the micromap is
    /// an acceleration structure) rather than the EXT structure (a `VkMicromapEXT`).
    pub khr: bool,
    pub index_type: i32,
    pub index_buffer: u64,
    pub index_stride: u64,
    pub base_triangle: u32,
    pub micromap: Handle,
}

/// A `VkMicromapEXT`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Micromap {
    pub buffer: Handle,
    pub offset: u64,
    pub size: u64,
    /// `VkMicromapTypeEXT` it was created with.
    pub ty: i32,
    pub create_flags: u32,
    pub device_address: u64,
    /// Whether `VkAllocationCallbacks` were given at creation.
    pub allocator: bool,
    /// Set by a build the checker saw.
    pub built: Option<BuildRecord>,
}

/// A `VkAccelerationStructureKHR` (KHR opacity micromaps are acceleration
/// structures of type OPACITY_MICROMAP).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AccelerationStructure {
    /// `VkAccelerationStructureTypeKHR` it was created with.
    pub ty: i32,
    /// Created with `vkCreateAccelerationStructure2KHR` (address range) rather
    /// than `vkCreateAccelerationStructureKHR` (buffer + offset).
    pub created_with_2: bool,
    pub buffer: Handle,
    pub offset: u64,
    pub size: u64,
    /// The device-address range `[start, end)` backing it, when known.
    pub address_range: Option<(u64, u64)>,
    pub built: Option<BuildRecord>,
}

/// A `VkQueryPool`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct QueryPool {
    pub query_type: i32,
    pub query_count: u32,
}

/// Host memory an application described to a host command (`hostAddress`
/// ranges), with the bytes the checker may read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostRange {
    pub address: u64,
    pub bytes: Bytes,
}

/// The host memory one call may read: the ranges the application
/// described (kept in [`State`] across calls), then those an adaptor read
/// for this call alone, which nothing keeps after it (the application may
/// change or free that memory once the call returns). Checks and the
/// record of host builds read host memory through this, never through the
/// state.
#[derive(Clone, Copy, Debug)]
pub struct HostMemory<'a> {
    described: &'a [HostRange],
    read_for_call: &'a [HostRange],
}

impl<'a> HostMemory<'a> {
    /// Described ranges first, as an address in both is read from the
    /// application's description.
    fn ranges(self) -> impl Iterator<Item = &'a HostRange> {
        self.described.iter().chain(self.read_for_call)
    }

    /// Whether this is all the host memory the application may use, so
    /// that an address outside it is outside valid memory: only where the
    /// application described memory. What an adaptor read for the call is
    /// not all of it.
    pub fn describes_all(self) -> bool {
        !self.described.is_empty()
    }

    /// The bytes `[address, address + len)`, where one range holds them all.
    pub fn read(self, address: u64, len: u64) -> Option<&'a [u8]> {
        let end = address.checked_add(len)?;
        self.ranges().find_map(|r| {
            let r_end = r.address.checked_add(r.bytes.len() as u64)?;
            if address < r.address || end > r_end {
                return None;
            }
            let from = usize::try_from(address - r.address).ok()?;
            let to = usize::try_from(end - r.address).ok()?;
            r.bytes.get(from..to)
        })
    }

    /// The bytes from `address` to the end of the range holding it.
    pub fn bytes_from(self, address: u64) -> Option<&'a [u8]> {
        self.ranges().find_map(|r| {
            let offset = usize::try_from(address.checked_sub(r.address)?).ok()?;
            // An address one past the end belongs to no range.
            (offset < r.bytes.len()).then(|| &r.bytes[offset..])
        })
    }

    /// The memory from `address` on, shared: the range holding `address`
    /// and the offset of `address` in it.
    pub fn contents_from(self, address: u64) -> Option<(Bytes, usize)> {
        self.ranges().find_map(|r| {
            let offset = usize::try_from(address.checked_sub(r.address)?).ok()?;
            (offset < r.bytes.len()).then(|| (r.bytes.clone(), offset))
        })
    }
}

/// Everything tracked.
#[derive(Clone, Debug, Default)]
pub struct State {
    /// By handle, with an index of their device addresses.
    pub buffers: Buffers,
    pub micromaps: BTreeMap<Handle, Micromap>,
    pub acceleration_structures: BTreeMap<Handle, AccelerationStructure>,
    pub query_pools: BTreeMap<Handle, QueryPool>,
    /// Host memory the application described to the checker (a scene, or
    /// [`crate::Validator::describe_host_memory`]), kept across calls. What
    /// an adaptor reads for one call alone never comes here: it reaches
    /// that call's rules and record beside this, in a [`HostMemory`].
    pub host_memory: Vec<HostRange>,
    /// `VkDeferredOperationKHR` handles the application created
    /// (`vkCreateDeferredOperationKHR`) and has not destroyed.
    pub deferred_operations: BTreeSet<Handle>,
    /// Deferred operations a host command was deferred to and that have not
    /// completed yet (`vkDeferredOperationJoinKHR` / `vkGetDeferredOperationResultKHR`
    /// not yet reported completion).
    pub pending_deferred_operations: BTreeSet<Handle>,
    /// Handles of objects that belong to another `VkDevice`: valid handles,
    /// but not of the device being checked (the layer tracks every device).
    pub other_device_objects: BTreeSet<Handle>,
    /// Pipelines created through the checker: their flags and what their
    /// shaders declare (pipeline and draw/dispatch/trace checks).
    pub pipelines: BTreeMap<Handle, crate::model::pipeline::PipelineRecord>,
    /// `VkShaderEXT` objects created through the checker.
    pub shader_objects: BTreeMap<Handle, crate::model::pipeline::ShaderObjectRecord>,
    /// The SPIR-V words of `VkShaderModule`s created through the checker.
    pub shader_modules: BTreeMap<Handle, Arc<[u32]>>,
    /// What each acceleration structure's known build put in it that the
    /// draw, dispatch and trace-rays micromap rules ask about.
    pub micromap_geometry: BTreeMap<Handle, crate::model::pipeline::MicromapGeometry>,
    /// What the original build of each acceleration structure chained to its
    /// triangles geometries as KHR opacity attachments (update builds must
    /// chain the same); recorded by `checks::accel_attach::record_original_attachments`.
    pub original_attachments: BTreeMap<Handle, crate::model::accel::OriginalAttachments>,
    /// What recorded work does when it runs, the submissions that ran it,
    /// and what the host saw complete (`checks::execution`).
    pub execution: execution::Execution,
    /// The driver's answers (build sizes) stated or asked for, which the
    /// rules comparing against them read (`checks::driver_sizes`).
    pub driver: crate::driver::DriverAnswers,
    /// Micromap → the host address where the application has mapped the
    /// memory backing it, all of it: what a host build's scratch may
    /// collide with (`VUID-vkBuildMicromapsEXT-dstMicromap-11668`). An
    /// adaptor that follows `vkMapMemory` (the layer) sets it before a host
    /// build; scenes do not describe mappings.
    pub mapped_micromaps: BTreeMap<Handle, u64>,
    /// Where serialized bytes came from: the serializations seen, by where
    /// they wrote and by the fingerprint of their bytes, and what each
    /// deserialization constructed (`checks::provenance`).
    pub provenance: provenance::Provenance,
}

impl State {
    /// Makes every byte view the state keeps of host memory in `within`
    /// (addresses) a copy, which `copy` makes (an adaptor may reuse memory
    /// for it): host ranges and built micromap contents
    /// (buffer contents an adaptor hands a check are its own again after
    /// it, see [`crate::Validator::check_device_build_contents`]). An adaptor calls it before that memory changes
    /// (the layer's readback memory, before a submission copies into it
    /// again).
    pub fn own_bytes_within(
        &mut self,
        within: &std::ops::Range<usize>,
        copy: &mut dyn FnMut(&[u8]) -> Bytes,
    ) {
        let built = self
            .micromaps
            .values_mut()
            .filter_map(|m| m.built.as_mut())
            .chain(
                self.acceleration_structures
                    .values_mut()
                    .filter_map(|s| s.built.as_mut()),
            );
        for record in built {
            if let Some(content) = record.content.as_mut().filter(|c| c.views_within(within)) {
                Arc::make_mut(content).own_bytes_within(within, copy);
            }
        }
        for range in &mut self.host_memory {
            owned_if_within(&mut range.bytes, within, copy);
        }
    }

    /// Buffers whose device-address range contains `address`, lowest handle
    /// first; through the address index, not a walk over every buffer (see
    /// [`Buffers::containing`] for the cost).
    pub fn buffers_at(&self, address: u64) -> impl Iterator<Item = (Handle, &Buffer)> {
        self.buffers.containing(address)
    }

    /// The device address of byte `offset` of `buffer`, where the buffer's
    /// address is known (None too where the sum passes 2^64).
    pub fn device_address_in(&self, buffer: Handle, offset: u64) -> Option<u64> {
        self.buffers
            .get(&buffer)
            .and_then(|b| b.device_address)
            .and_then(|start| start.checked_add(offset))
    }

    /// Whether some buffer holds all of `[address, address + len)`.
    pub fn range_in_one_buffer(&self, address: u64, len: u64) -> bool {
        let Some(end) = address.checked_add(len) else {
            return false;
        };
        self.buffers_at(address)
            .any(|(_, b)| b.address_range().is_some_and(|(_, e)| end <= e))
    }

    /// Whether the checker knows the buffers behind device addresses at all
    /// (no buffer has a known address: address rules cannot be decided).
    pub fn knows_addresses(&self) -> bool {
        self.buffers.any_with_address()
    }

    /// The bytes `[address, address + len)` of device memory, if one buffer
    /// with readable contents holds them all.
    pub fn read_device(&self, address: u64, len: u64) -> Option<&[u8]> {
        let len = usize::try_from(len).ok()?;
        self.buffers_at(address).find_map(|(_, b)| {
            let (contents, from) = b.contents_at(address)?;
            contents.get(from..from.checked_add(len)?)
        })
    }

    /// The host memory a call reads that the application described, and
    /// `read_for_call`, what an adaptor read for this call alone (empty
    /// for the static API and scenes).
    pub fn host_memory<'a>(&'a self, read_for_call: &'a [HostRange]) -> HostMemory<'a> {
        HostMemory {
            described: &self.host_memory,
            read_for_call,
        }
    }

    /// The bytes from `address` to the end of the range of host memory the
    /// application described that holds it (what an adaptor read for one
    /// call is never here: checks read [`Self::host_memory`] instead).
    pub fn host_bytes_from(&self, address: u64) -> Option<&[u8]> {
        self.host_memory(&[]).bytes_from(address)
    }

    /// The device memory from `address` on, shared: the contents of the
    /// buffer holding `address` and the offset of `address` in them.
    pub fn device_contents_from(&self, address: u64) -> Option<(Bytes, usize)> {
        self.buffers_at(address).find_map(|(_, b)| {
            let (contents, offset) = b.contents_at(address)?;
            Some((contents.clone(), offset))
        })
    }

    /// The device bytes from `address` to the end of the buffer holding it.
    pub fn device_bytes_from(&self, address: u64) -> Option<&[u8]> {
        self.buffers_at(address).find_map(|(_, b)| {
            let (contents, offset) = b.contents_at(address)?;
            contents.get(offset..)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state_with_buffer() -> State {
        let mut state = State::default();
        state.buffers.insert(
            1,
            Buffer {
                size: 16,
                device_address: Some(0x1000),
                contents: Some(crate::Bytes::from((0u8..16).collect::<Vec<u8>>())),
                ..Default::default()
            },
        );
        state
    }

    #[test]
    fn device_reads_stay_inside_one_buffer() {
        let state = state_with_buffer();
        assert_eq!(state.read_device(0x1004, 4), Some(&[4u8, 5, 6, 7][..]));
        assert_eq!(state.read_device(0x100c, 8), None);
        assert_eq!(state.read_device(u64::MAX - 1, 4), None);
        assert!(state.range_in_one_buffer(0x1000, 16));
        assert!(!state.range_in_one_buffer(0x1000, 17));
        assert!(!state.range_in_one_buffer(u64::MAX, 2));
    }

    #[test]
    fn device_reads_of_a_known_window_stay_inside_it() {
        let mut state = state_with_buffer();
        let mut buffer = state.buffers.get_mut(&1).unwrap();
        // Bytes 8..12 of the buffer are known, nothing else.
        buffer.contents = Some(crate::Bytes::from(vec![8u8, 9, 10, 11]));
        buffer.contents_offset = 8;
        drop(buffer);
        assert_eq!(state.read_device(0x1008, 4), Some(&[8u8, 9, 10, 11][..]));
        assert_eq!(state.read_device(0x100a, 2), Some(&[10u8, 11][..]));
        assert_eq!(
            state.read_device(0x1004, 8),
            None,
            "starts before the window"
        );
        assert_eq!(state.read_device(0x100a, 4), None, "ends past the window");
        assert_eq!(state.device_bytes_from(0x1009), Some(&[9u8, 10, 11][..]));
        assert_eq!(state.device_bytes_from(0x1007), None);
        let (bytes, offset) = state.device_contents_from(0x100b).unwrap();
        assert_eq!((bytes.len(), offset), (4, 3));
    }

    #[test]
    fn host_reads_stay_inside_the_described_range() {
        let mut state = State::default();
        state.host_memory.push(HostRange {
            address: 0x50,
            bytes: crate::Bytes::from(vec![9u8; 8]),
        });
        let host = state.host_memory(&[]);
        assert_eq!(host.read(0x52, 4), Some(&[9u8; 4][..]));
        assert_eq!(host.read(0x56, 4), None);
        assert_eq!(host.read(0x40, 4), None);
        assert_eq!(host.bytes_from(0x57).map(<[u8]>::len), Some(1));
        assert_eq!(host.bytes_from(0x58), None);
        assert!(host.describes_all());
    }

    /// What an adaptor read for a call is read after the described memory
    /// and is not all the memory there is; the state does not keep it.
    #[test]
    fn host_memory_read_for_a_call_is_seen_beside_the_described_memory() {
        let mut state = State::default();
        let read = [HostRange {
            address: 0x90,
            bytes: crate::Bytes::from(vec![3u8; 4]),
        }];
        let call = state.host_memory(&read);
        assert_eq!(call.read(0x90, 4), Some(&[3u8; 4][..]));
        assert!(!call.describes_all(), "only what was read for the call");
        state.host_memory.push(HostRange {
            address: 0x90,
            bytes: crate::Bytes::from(vec![9u8; 8]),
        });
        let both = state.host_memory(&read);
        assert_eq!(both.read(0x90, 4), Some(&[9u8; 4][..]), "described first");
        assert!(both.describes_all());
        assert_eq!(state.host_memory(&[]).read(0x94, 4), Some(&[9u8; 4][..]));
    }

    #[test]
    fn views_of_memory_about_to_change_become_copies_and_others_stay_shared() {
        use crate::sim::decode::{MicromapContent, TriangleEntries};
        let memory = crate::Bytes::from(vec![0u8; 64]);
        let outside = crate::Bytes::from(vec![1u8; 8]);
        let start = memory.as_ptr().addr();
        let triangles = TriangleEntries::shared(memory.slice(8..24), 0, 8, 2).expect("inside");
        let content = MicromapContent::new(triangles, outside.clone());
        let mut state = State::default();
        state.micromaps.insert(
            1,
            Micromap {
                built: Some(BuildRecord {
                    content: Some(Arc::new(content.clone())),
                    ..BuildRecord::default()
                }),
                ..Micromap::default()
            },
        );
        state.host_memory.push(HostRange {
            address: 0x50,
            bytes: memory.slice(32..),
        });
        let kept = |state: &State| {
            let content = state.micromaps[&1].built.as_ref().unwrap().content.clone();
            content.expect("kept")
        };
        // Memory elsewhere: nothing changes.
        let mut copy = |bytes: &[u8]| crate::Bytes::copy_from_slice(bytes);
        state.own_bytes_within(&(0..1), &mut copy);
        assert!(kept(&state).views_within(&(start..start + 64)));
        state.own_bytes_within(&(start..start + 64), &mut copy);
        let after = kept(&state);
        assert!(!after.views_within(&(start..start + 64)), "copied");
        assert_eq!(*after, content, "the same bytes");
        assert_eq!(after.data.as_ptr(), outside.as_ptr(), "still shared");
        assert_ne!(state.host_memory[0].bytes.as_ptr().addr(), start + 32);
        assert_eq!(state.host_memory[0].bytes, memory.slice(32..));
    }
}
