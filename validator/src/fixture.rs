//! Test support: a device, buffers and micromaps in one line each, so a
//! unit test spends its lines on the call it checks.
//!
//! A [`Fixture`] is a [`Validator`] (it dereferences to one) that hands
//! out fresh handles and device addresses: every buffer is created, bound
//! to host-visible memory and given an address of its own; a micromap is
//! created in a storage buffer of its own and, given its triangles, built
//! from an input buffer whose contents the checker knows, so the rules
//! that read a micromap's triangles run on later calls.
//!
//! The fixture's own calls must be valid: each checks its call like any
//! other and **panics** (with the report) when the call reports anything,
//! since a finding there is a mistake in the test, not in the code under
//! test. Calls that should fail are made on the validator itself.
//!
//! ```
//! use ash::vk;
//! use ommcheck::fixture::{packed_triangles, Fixture};
//!
//! let mut f = Fixture::new();
//! let indices = f.input(&[0u32, 1, 2]); // contents known, usage for build inputs
//! let scratch = f.scratch(); // a device address with room to build in
//! let triangles = packed_triangles(3, 2, vk::OpacityMicromapFormatEXT::TYPE_4_STATE);
//! let micromap = f.micromap(&triangles); // created and built
//! assert_eq!(indices.size, 12);
//! # let _ = (scratch, micromap);
//! ```

use std::ops::{Deref, DerefMut};

use ash::vk;
use ommcheck_vuids::khr;

use crate::acceleration_builds::AccelerationStructureBuild;
use crate::checks::Validator;
use crate::device::{Device, Profile};
use crate::model::accel::AccelerationStructureCreateInfo2;
use crate::model::micromap::opacity_triangle_bytes;
use crate::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};
use crate::report::Report;
use crate::state::MemoryBinding;
use crate::tracked::HostBytes;

/// The first device address a fixture hands out; each buffer starts on a
/// multiple of [`ADDRESS_STEP`] (so any alignment a rule asks for, up to
/// that, holds at offset 0), with at least one step free after it.
const FIRST_ADDRESS: u64 = 0x100_0000;
const ADDRESS_STEP: u64 = 0x1_0000;
/// Bytes of scratch memory [`Fixture::scratch`] hands out.
pub const SCRATCH_SIZE: u64 = 0x1_0000;
/// Bytes of an acceleration structure's storage from [`Fixture::blas`].
pub const ACCELERATION_STRUCTURE_SIZE: u64 = 0x1_0000;
/// Where the triangle array starts in a micromap's input buffer: after the
/// data, at a multiple of this (EXT builds need 256-byte alignment of
/// `data` and `triangleArray`, KHR builds 128).
const TRIANGLE_ARRAY_ALIGNMENT: u64 = 256;

/// A buffer the fixture created: its handle, device address and size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixtureBuffer {
    pub buffer: vk::Buffer,
    pub address: vk::DeviceAddress,
    pub size: u64,
}

impl FixtureBuffer {
    /// The address `offset` bytes into the buffer, as the ash structures
    /// of build inputs take it.
    pub fn at(&self, offset: u64) -> vk::DeviceOrHostAddressConstKHR {
        vk::DeviceOrHostAddressConstKHR {
            device_address: self.address + offset,
        }
    }
}

/// A [`Validator`] with one-line set-up of what calls use. See the
/// [module documentation](self).
#[derive(Clone, Debug)]
pub struct Fixture {
    validator: Validator,
    /// The `VkDevice` handle the fixture's device-level calls name.
    device: vk::Device,
    next_handle: u64,
    next_address: u64,
}

impl Default for Fixture {
    fn default() -> Self {
        Self::new()
    }
}

impl Deref for Fixture {
    type Target = Validator;
    fn deref(&self) -> &Validator {
        &self.validator
    }
}

impl DerefMut for Fixture {
    fn deref_mut(&mut self) -> &mut Validator {
        &mut self.validator
    }
}

impl Fixture {
    /// A device with every micromap and acceleration-structure extension
    /// and feature enabled, at the limits every such device meets
    /// ([`Profile::SpecMinimum`]).
    pub fn new() -> Self {
        Self::with_device(Device::with_everything(Profile::SpecMinimum))
    }

    /// A fixture over `device`.
    pub fn with_device(device: Device) -> Self {
        Self {
            validator: Validator::new(device),
            device: vk::Handle::from_raw(0xde),
            next_handle: 0x100,
            next_address: FIRST_ADDRESS,
        }
    }

    /// The validator, for a test that goes on without the fixture.
    pub fn into_validator(self) -> Validator {
        self.validator
    }

    /// A handle no other object of this fixture has.
    pub fn handle<H: vk::Handle>(&mut self) -> H {
        self.next_handle += 1;
        H::from_raw(self.next_handle)
    }

    /// A buffer of `size` bytes with `usage` (and
    /// `SHADER_DEVICE_ADDRESS`), bound to host-visible memory, at an
    /// address of its own; its contents are not known.
    pub fn buffer(&mut self, size: u64, usage: vk::BufferUsageFlags) -> FixtureBuffer {
        let buffer: vk::Buffer = self.handle();
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS);
        self.validator.create_buffer(buffer, &info);
        let memory = MemoryBinding {
            host_visible: true,
            multi_instance: false,
        };
        self.validator.bind_buffer_memory(buffer, memory);
        let address = self.next_address;
        self.validator.set_buffer_device_address(buffer, address);
        let steps = size.div_ceil(ADDRESS_STEP).max(1) + 1;
        self.next_address += steps * ADDRESS_STEP;
        FixtureBuffer {
            buffer,
            address,
            size,
        }
    }

    /// A buffer holding `contents` (its size is theirs), as
    /// [`Self::buffer`], with the contents known to the checker.
    pub fn buffer_with(
        &mut self,
        usage: vk::BufferUsageFlags,
        contents: &(impl HostBytes + ?Sized),
    ) -> FixtureBuffer {
        let size = contents.host_bytes().len() as u64;
        let buffer = self.buffer(size, usage);
        self.validator.set_buffer_contents(buffer.buffer, contents);
        buffer
    }

    /// A build-input buffer (micromap and acceleration-structure build
    /// inputs, read only) holding `contents`: index buffers, triangle
    /// arrays, micromap data.
    pub fn input(&mut self, contents: &(impl HostBytes + ?Sized)) -> FixtureBuffer {
        let usage = vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR;
        self.buffer_with(usage, contents)
    }

    /// The device address of a fresh scratch buffer of [`SCRATCH_SIZE`]
    /// bytes (`STORAGE_BUFFER` usage).
    pub fn scratch(&mut self) -> vk::DeviceAddress {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        self.buffer(SCRATCH_SIZE, usage).address
    }

    /// A micromap of `size` bytes created (`vkCreateMicromapEXT`) in a
    /// storage buffer of its own, not built.
    ///
    /// # Panics
    /// When the creation reports anything.
    pub fn micromap_unbuilt(&mut self, size: u64) -> vk::MicromapEXT {
        let storage = self.buffer(size, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT);
        let micromap = self.handle();
        let info = vk::MicromapCreateInfoEXT::default()
            .buffer(storage.buffer)
            .size(size)
            .ty(vk::MicromapTypeEXT::OPACITY_MICROMAP);
        let device = self.device;
        let report = self.validator.create_micromap_from(device, &info, micromap);
        expect_clean("vkCreateMicromapEXT", &report);
        micromap
    }

    /// A micromap created and built (`vkCmdBuildMicromapsEXT`) from
    /// `triangles`, whose data offsets count from the start of a data
    /// block of zeros as long as they need; the usage counts are those of
    /// the triangles ([`usage_counts`]).
    ///
    /// # Panics
    /// When the creation or the build reports anything (a triangle of an
    /// unknown format, say).
    pub fn micromap(&mut self, triangles: &[vk::MicromapTriangleEXT]) -> vk::MicromapEXT {
        let (input, array_offset) = self.micromap_input(triangles);
        let micromap = self.micromap_unbuilt(input.size.max(ADDRESS_STEP));
        let usages = usage_counts(triangles).iter().map(model_usage).collect();
        let build = MicromapBuildInfo {
            dst_micromap: vk::Handle::as_raw(micromap),
            usage_counts: UsageCounts::array(usages),
            data: input.address,
            triangle_array: input.address + array_offset,
            triangle_array_stride: 8,
            scratch_data: self.scratch(),
            ..MicromapBuildInfo::default()
        };
        let report = self
            .validator
            .cmd_build_micromaps(&CommandBuffer::default(), &[build]);
        expect_clean("vkCmdBuildMicromapsEXT", &report);
        micromap
    }

    /// A KHR opacity micromap: an acceleration structure of type
    /// OPACITY_MICROMAP created (`vkCreateAccelerationStructure2KHR`) in a
    /// storage buffer of its own and built
    /// (`vkCmdBuildAccelerationStructuresKHR`, one micromap geometry) from
    /// `triangles`, laid out as for [`Self::micromap`].
    ///
    /// # Panics
    /// When the creation or the build reports anything.
    pub fn micromap_khr(
        &mut self,
        triangles: &[vk::MicromapTriangleEXT],
    ) -> vk::AccelerationStructureKHR {
        let (input, array_offset) = self.micromap_input(triangles);
        let size = input.size.max(ADDRESS_STEP);
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR;
        let storage = self.buffer(size, usage);
        let micromap = self.handle();
        let create = AccelerationStructureCreateInfo2 {
            address: storage.address,
            size,
            ..AccelerationStructureCreateInfo2::default()
        };
        let report = self
            .validator
            .create_acceleration_structure2(&create, vk::Handle::as_raw(micromap));
        expect_clean("vkCreateAccelerationStructure2KHR", &report);
        let usages: Vec<khr::MicromapUsageKHR> = usage_counts(triangles)
            .iter()
            .map(|u| khr::MicromapUsageKHR {
                count: u.count,
                subdivision_level: u.subdivision_level,
                format: khr::OpacityMicromapFormatKHR::from_raw(u.format as i32),
            })
            .collect();
        let data = khr::AccelerationStructureGeometryMicromapDataKHR {
            data: input.address,
            triangle_array: input.address + array_offset,
            triangle_array_stride: 8,
            ..Default::default()
        };
        let build = AccelerationStructureBuild::opacity_micromap(micromap, self.scratch())
            .micromap_data(&data, &usages);
        let report = self
            .validator
            .cmd_build_acceleration_structures_from(&CommandBuffer::default(), &[build]);
        expect_clean("vkCmdBuildAccelerationStructuresKHR", &report);
        micromap
    }

    /// An input buffer holding zeroed data for `triangles` from offset 0,
    /// then their triangle array; and where the array starts.
    fn micromap_input(&mut self, triangles: &[vk::MicromapTriangleEXT]) -> (FixtureBuffer, u64) {
        let data_end = triangles
            .iter()
            .map(|t| {
                let bytes =
                    opacity_triangle_bytes(u32::from(t.format), u32::from(t.subdivision_level));
                u64::from(t.data_offset) + bytes.unwrap_or(0)
            })
            .max()
            .unwrap_or(0);
        let array_offset = data_end.div_ceil(TRIANGLE_ARRAY_ALIGNMENT) * TRIANGLE_ARRAY_ALIGNMENT;
        let array = triangles.host_bytes();
        let mut contents = vec![0u8; array_offset as usize];
        contents.extend_from_slice(&array);
        (self.input(contents.as_slice()), array_offset)
    }

    /// An acceleration structure of type `ty` created
    /// (`vkCreateAccelerationStructureKHR`) over `size` bytes of a storage
    /// buffer of its own.
    ///
    /// # Panics
    /// When the creation reports anything.
    pub fn acceleration_structure(
        &mut self,
        ty: vk::AccelerationStructureTypeKHR,
        size: u64,
    ) -> vk::AccelerationStructureKHR {
        let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR;
        let storage = self.buffer(size, usage);
        let structure = self.handle();
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage.buffer)
            .size(size)
            .ty(ty);
        let report = self
            .validator
            .create_acceleration_structure_from(&info, structure);
        expect_clean("vkCreateAccelerationStructureKHR", &report);
        structure
    }

    /// A bottom-level acceleration structure of
    /// [`ACCELERATION_STRUCTURE_SIZE`] bytes, created, not built.
    pub fn blas(&mut self) -> vk::AccelerationStructureKHR {
        let ty = vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL;
        self.acceleration_structure(ty, ACCELERATION_STRUCTURE_SIZE)
    }

    /// Triangles geometry data for `triangle_count` unindexed triangles:
    /// three `R32G32B32_SFLOAT` vertices each (zeros), in a build-input
    /// buffer of their own.
    pub fn vertices(
        &mut self,
        triangle_count: u32,
    ) -> vk::AccelerationStructureGeometryTrianglesDataKHR<'static> {
        let vertices = 3 * triangle_count.max(1);
        let buffer = self.input(vec![0u8; 12 * vertices as usize].as_slice());
        vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(buffer.at(0))
            .vertex_stride(12)
            .max_vertex(vertices - 1)
            .index_type(vk::IndexType::NONE_KHR)
    }
}

/// `count` triangles of one subdivision level and format, each with its
/// own data, one after the other from offset 0.
pub fn packed_triangles(
    count: u32,
    subdivision_level: u16,
    format: vk::OpacityMicromapFormatEXT,
) -> Vec<vk::MicromapTriangleEXT> {
    let format = format.as_raw() as u16;
    let bytes =
        opacity_triangle_bytes(u32::from(format), u32::from(subdivision_level)).unwrap_or(0) as u32;
    (0..count)
        .map(|i| vk::MicromapTriangleEXT {
            data_offset: i * bytes,
            subdivision_level,
            format,
        })
        .collect()
}

/// The usage counts of `triangles`: how many there are of each format and
/// subdivision level, in the order they first appear.
pub fn usage_counts(triangles: &[vk::MicromapTriangleEXT]) -> Vec<vk::MicromapUsageEXT> {
    let mut counts: Vec<vk::MicromapUsageEXT> = Vec::new();
    for t in triangles {
        let (level, format) = (u32::from(t.subdivision_level), u32::from(t.format));
        match counts
            .iter_mut()
            .find(|u| u.subdivision_level == level && u.format == format)
        {
            Some(usage) => usage.count += 1,
            None => counts.push(vk::MicromapUsageEXT {
                count: 1,
                subdivision_level: level,
                format,
            }),
        }
    }
    counts
}

fn model_usage(usage: &vk::MicromapUsageEXT) -> MicromapUsage {
    MicromapUsage {
        count: usage.count,
        subdivision_level: usage.subdivision_level,
        format: usage.format,
    }
}

/// Panics, naming `call` and showing `report`, unless the fixture's call
/// found nothing (not even a rule it could not check).
fn expect_clean(call: &str, report: &Report) {
    assert!(
        report.is_empty(),
        "fixture set-up: {call} reported findings (the fixture's calls must be valid):\n{report}"
    );
}
