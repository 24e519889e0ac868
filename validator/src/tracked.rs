//! Telling the checker about objects and memory with what a program already
//! has: the ash create infos and handles it passes to Vulkan, the device's
//! ash feature and property structures, and the bytes (or typed slices) it
//! builds from.
//!
//! These entry points read the members of the ash structures and never
//! follow their `pNext` pointers, so they are safe to call. The `*_ash`
//! entry points of [`crate::raw`] read the chains as a layer must, and are
//! `unsafe` for it.

use ash::vk;

use crate::checks::Validator;
use crate::device::{ext, Device};
use crate::model::accel::AccelerationStructureCreateInfo;
use crate::model::micromap_objects::MicromapCreateInfo;
use crate::report::Report;
use crate::state::{Buffer, HostRange, MemoryBinding};

mod created_from;
mod driver_answers;

/// Memory a program holds on the host, as the checker reads it: its bytes
/// (little-endian, as Vulkan reads them) and the address a program passes
/// to Vulkan for it (`hostAddress`).
pub trait HostBytes {
    /// The bytes, in memory order.
    fn host_bytes(&self) -> Vec<u8>;
    /// The address of the first byte.
    fn host_address(&self) -> u64;
}

impl HostBytes for [u8] {
    fn host_bytes(&self) -> Vec<u8> {
        self.to_vec()
    }

    fn host_address(&self) -> u64 {
        self.as_ptr().expose_provenance() as u64
    }
}

/// Triangle-array entries (`VkMicromapTriangleEXT`, 8 bytes each).
impl HostBytes for [vk::MicromapTriangleEXT] {
    fn host_bytes(&self) -> Vec<u8> {
        self.iter()
            .flat_map(|t| {
                let mut entry = [0u8; 8];
                entry[..4].copy_from_slice(&t.data_offset.to_le_bytes());
                entry[4..6].copy_from_slice(&t.subdivision_level.to_le_bytes());
                entry[6..].copy_from_slice(&t.format.to_le_bytes());
                entry
            })
            .collect()
    }

    fn host_address(&self) -> u64 {
        self.as_ptr().expose_provenance() as u64
    }
}

/// 32-bit indices (index buffers of `VK_INDEX_TYPE_UINT32`).
impl HostBytes for [u32] {
    fn host_bytes(&self) -> Vec<u8> {
        self.iter().flat_map(|i| i.to_le_bytes()).collect()
    }

    fn host_address(&self) -> u64 {
        self.as_ptr().expose_provenance() as u64
    }
}

/// 16-bit indices (index buffers of `VK_INDEX_TYPE_UINT16`).
impl HostBytes for [u16] {
    fn host_bytes(&self) -> Vec<u8> {
        self.iter().flat_map(|i| i.to_le_bytes()).collect()
    }

    fn host_address(&self) -> u64 {
        self.as_ptr().expose_provenance() as u64
    }
}

impl<T> HostBytes for Vec<T>
where
    [T]: HostBytes,
{
    fn host_bytes(&self) -> Vec<u8> {
        self.as_slice().host_bytes()
    }

    fn host_address(&self) -> u64 {
        self.as_slice().host_address()
    }
}

impl<T, const N: usize> HostBytes for [T; N]
where
    [T]: HostBytes,
{
    fn host_bytes(&self) -> Vec<u8> {
        self.as_slice().host_bytes()
    }

    fn host_address(&self) -> u64 {
        self.as_slice().host_address()
    }
}

impl Validator {
    /// Host memory the program's host commands (`vkBuildMicromapsEXT`,
    /// `vkBuildAccelerationStructuresKHR`, host copies) read: `memory` at
    /// its own address, which is what the program passes as `hostAddress`.
    /// Returns that address. Once any host memory is described, an address
    /// outside all of it is invalid; until then host rules that need the
    /// memory's extent are reported not checked.
    ///
    /// The checker keeps a copy of the bytes, taken now.
    pub fn describe_host_memory(&mut self, memory: &(impl HostBytes + ?Sized)) -> u64 {
        let address = memory.host_address();
        self.state.host_memory.push(HostRange {
            address,
            bytes: crate::Bytes::from(memory.host_bytes()),
        });
        address
    }

    /// `vkCreateBuffer` returned `buffer` for `info`: tracked unbound, with
    /// no known address or contents. `info.usage` is the buffer's usage
    /// (its pNext is not read: a `VkBufferUsageFlags2CreateInfoKHR` there is
    /// for [`Validator::set_buffer_usage2`]).
    pub fn create_buffer(&mut self, buffer: vk::Buffer, info: &vk::BufferCreateInfo<'_>) {
        self.state.buffers.insert(
            vk::Handle::as_raw(buffer),
            Buffer {
                size: info.size,
                usage: u64::from(info.usage.as_raw()),
                create_flags: info.flags.as_raw(),
                ..Buffer::default()
            },
        );
    }

    /// The buffer's usage is `usage` (`VkBufferUsageFlags2CreateInfoKHR`).
    pub fn set_buffer_usage2(&mut self, buffer: vk::Buffer, usage: vk::BufferUsageFlags2KHR) {
        if let Some(mut tracked) = self.state.buffers.get_mut(&vk::Handle::as_raw(buffer)) {
            tracked.usage = usage.as_raw();
        }
    }

    /// `vkBindBufferMemory` bound `buffer` to memory allocated with `memory`'s
    /// properties (host-visible, multi-instance).
    pub fn bind_buffer_memory(&mut self, buffer: vk::Buffer, memory: MemoryBinding) {
        if let Some(mut tracked) = self.state.buffers.get_mut(&vk::Handle::as_raw(buffer)) {
            tracked.memory = Some(memory);
        }
    }

    /// `vkGetBufferDeviceAddress` returned `address` for `buffer`.
    pub fn set_buffer_device_address(&mut self, buffer: vk::Buffer, address: vk::DeviceAddress) {
        if let Some(mut tracked) = self.state.buffers.get_mut(&vk::Handle::as_raw(buffer)) {
            tracked.device_address = Some(address);
        }
    }

    /// The bytes `buffer` holds from its start when the commands that read
    /// it run (what the program uploads): `contents`, which may be shorter
    /// than the buffer (the rest is not known). The checker keeps a copy.
    pub fn set_buffer_contents(
        &mut self,
        buffer: vk::Buffer,
        contents: &(impl HostBytes + ?Sized),
    ) {
        if let Some(mut tracked) = self.state.buffers.get_mut(&vk::Handle::as_raw(buffer)) {
            tracked.contents = Some(crate::Bytes::from(contents.host_bytes()));
        }
    }

    /// Checks `vkCreateMicromapEXT(device, &info, NULL, &micromap)` and
    /// tracks the micromap it created (`micromap`, the program's handle).
    /// `info.p_next` is not read.
    pub fn create_micromap_from(
        &mut self,
        device: vk::Device,
        info: &vk::MicromapCreateInfoEXT<'_>,
        micromap: vk::MicromapEXT,
    ) -> Report {
        let model = MicromapCreateInfo::from_members(info);
        self.create_micromap(
            vk::Handle::as_raw(device),
            Some(&model),
            None,
            Some(vk::Handle::as_raw(micromap)),
        )
    }

    /// Checks `vkCreateAccelerationStructureKHR` with `info` and tracks the
    /// structure it created (`acceleration_structure`, the program's handle).
    /// `info.p_next` is not read.
    pub fn create_acceleration_structure_from(
        &mut self,
        info: &vk::AccelerationStructureCreateInfoKHR<'_>,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) -> Report {
        let model = AccelerationStructureCreateInfo::from_members(info);
        self.create_acceleration_structure(&model, vk::Handle::as_raw(acceleration_structure))
    }
}

/// An ash feature or property structure that describes part of a
/// [`Device`]: what [`Device::with`] takes.
pub trait DescribesDevice {
    /// Sets what the structure says on `device`.
    fn describe(&self, device: &mut Device);
}

fn enabled(flag: vk::Bool32) -> bool {
    flag != vk::FALSE
}

/// Whether the feature `flag` is enabled; an enabled feature enables the
/// extension that declares it.
fn feature(device: &mut Device, flag: vk::Bool32, extension: &str) -> bool {
    if enabled(flag) {
        device.extensions.insert(extension.to_string());
    }
    enabled(flag)
}

impl DescribesDevice for vk::PhysicalDeviceOpacityMicromapFeaturesEXT<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.micromap_ext = feature(device, self.micromap, ext::EXT_OPACITY_MICROMAP);
        device.features.micromap_capture_replay = enabled(self.micromap_capture_replay);
        device.features.micromap_host_commands = enabled(self.micromap_host_commands);
    }
}

impl DescribesDevice for ommcheck_vuids::khr::PhysicalDeviceOpacityMicromapFeaturesKHR {
    fn describe(&self, device: &mut Device) {
        device.features.micromap_khr = feature(device, self.micromap, ext::KHR_OPACITY_MICROMAP);
    }
}

impl DescribesDevice for vk::PhysicalDeviceDisplacementMicromapFeaturesNV<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.displacement_micromap = feature(
            device,
            self.displacement_micromap,
            ext::NV_DISPLACEMENT_MICROMAP,
        );
    }
}

impl DescribesDevice for vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.acceleration_structure = feature(
            device,
            self.acceleration_structure,
            ext::KHR_ACCELERATION_STRUCTURE,
        );
        device.features.acceleration_structure_host_commands =
            enabled(self.acceleration_structure_host_commands);
    }
}

impl DescribesDevice for vk::PhysicalDeviceBufferDeviceAddressFeatures<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.buffer_device_address = enabled(self.buffer_device_address);
        device.features.buffer_device_address_multi_device =
            enabled(self.buffer_device_address_multi_device);
    }
}

impl DescribesDevice for vk::PhysicalDeviceSynchronization2Features<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.synchronization2 = enabled(self.synchronization2);
    }
}

impl DescribesDevice for vk::PhysicalDeviceRayQueryFeaturesKHR<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.ray_query = feature(device, self.ray_query, ext::KHR_RAY_QUERY);
    }
}

impl DescribesDevice for vk::PhysicalDeviceRayTracingPipelineFeaturesKHR<'_> {
    fn describe(&self, device: &mut Device) {
        device.features.ray_tracing_pipeline = feature(
            device,
            self.ray_tracing_pipeline,
            ext::KHR_RAY_TRACING_PIPELINE,
        );
    }
}

impl DescribesDevice for vk::PhysicalDeviceOpacityMicromapPropertiesEXT<'_> {
    fn describe(&self, device: &mut Device) {
        device.limits.max_opacity2_state_subdivision_level =
            self.max_opacity2_state_subdivision_level;
        device.limits.max_opacity4_state_subdivision_level =
            self.max_opacity4_state_subdivision_level;
    }
}

impl DescribesDevice for ommcheck_vuids::khr::PhysicalDeviceOpacityMicromapPropertiesKHR {
    fn describe(&self, device: &mut Device) {
        let limits = &mut device.limits;
        limits.max_opacity2_state_subdivision_level = self.max_opacity2_state_subdivision_level;
        limits.max_opacity4_state_subdivision_level = self.max_opacity4_state_subdivision_level;
        limits.max_opacity_lossy4_state_subdivision_level =
            self.max_opacity_lossy4_state_subdivision_level;
        limits.max_micromap_triangles = self.max_micromap_triangles;
    }
}

impl DescribesDevice for vk::PhysicalDeviceDisplacementMicromapPropertiesNV<'_> {
    fn describe(&self, device: &mut Device) {
        device.limits.max_displacement_micromap_subdivision_level =
            self.max_displacement_micromap_subdivision_level;
    }
}

impl DescribesDevice for vk::PhysicalDeviceAccelerationStructurePropertiesKHR<'_> {
    fn describe(&self, device: &mut Device) {
        device
            .limits
            .min_acceleration_structure_scratch_offset_alignment =
            self.min_acceleration_structure_scratch_offset_alignment;
    }
}

impl Device {
    /// This device as `structure` (an ash feature or property structure)
    /// describes it: enabled features (and the extension they belong to),
    /// or limits.
    ///
    /// ```
    /// use ash::vk;
    /// use ommcheck::Device;
    ///
    /// let device = Device::default()
    ///     .with(&vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default().micromap(true))
    ///     .with(&vk::PhysicalDeviceOpacityMicromapPropertiesEXT {
    ///         max_opacity2_state_subdivision_level: 12,
    ///         max_opacity4_state_subdivision_level: 12,
    ///         ..Default::default()
    ///     });
    /// assert!(device.features.micromap_ext);
    /// assert!(device.has_extension("VK_EXT_opacity_micromap"));
    /// assert_eq!(device.limits.max_opacity4_state_subdivision_level, 12);
    /// ```
    pub fn with(mut self, structure: &impl DescribesDevice) -> Self {
        structure.describe(&mut self);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_bytes_are_little_endian_and_at_the_slice() {
        let triangles = [vk::MicromapTriangleEXT {
            data_offset: 0x0102_0304,
            subdivision_level: 3,
            format: 2,
        }];
        assert_eq!(triangles.host_bytes(), [4, 3, 2, 1, 3, 0, 2, 0]);
        assert_eq!(
            triangles.host_address(),
            triangles.as_ptr().expose_provenance() as u64
        );
        let indices = vec![1u32, 0xffff_fffe];
        assert_eq!(indices.host_bytes(), [1, 0, 0, 0, 0xfe, 0xff, 0xff, 0xff]);
        assert_eq!([7u16].host_bytes(), [7, 0]);
    }

    #[test]
    fn buffers_are_created_bound_and_filled_by_handle() {
        let mut v = Validator::new(Device::default());
        let buffer = vk::Handle::from_raw(0x42);
        let info = vk::BufferCreateInfo::default()
            .size(64)
            .usage(vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT);
        v.create_buffer(buffer, &info);
        v.bind_buffer_memory(buffer, MemoryBinding::default());
        v.set_buffer_device_address(buffer, 0x1_0000);
        v.set_buffer_contents(buffer, &[1u32, 2]);
        let tracked = &v.state().buffers[&0x42];
        assert_eq!(tracked.size, 64);
        assert_eq!(
            tracked.usage,
            u64::from(vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT.as_raw())
        );
        assert_eq!(tracked.memory, Some(MemoryBinding::default()));
        assert_eq!(
            v.state().read_device(0x1_0004, 4),
            Some(&[2u8, 0, 0, 0][..])
        );
        v.set_buffer_usage2(buffer, vk::BufferUsageFlags2KHR::STORAGE_BUFFER);
        assert_eq!(
            v.state().buffers[&0x42].usage,
            vk::BufferUsageFlags2KHR::STORAGE_BUFFER.as_raw()
        );
    }

    #[test]
    fn described_host_memory_is_read_at_its_address() {
        let mut v = Validator::new(Device::default());
        let data = vec![0xabu8; 16];
        let address = v.describe_host_memory(data.as_slice());
        assert_eq!(address, data.as_ptr().expose_provenance() as u64);
        let host = v.state().host_memory(&[]);
        assert_eq!(host.read(address + 8, 8), Some(&[0xab; 8][..]));
        assert!(host.describes_all());
    }

    #[test]
    fn devices_are_described_by_ash_structures() {
        let device = Device::default()
            .with(
                &vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
                    .acceleration_structure(true),
            )
            .with(&vk::PhysicalDeviceAccelerationStructurePropertiesKHR {
                min_acceleration_structure_scratch_offset_alignment: 128,
                ..Default::default()
            })
            .with(
                &ommcheck_vuids::khr::PhysicalDeviceOpacityMicromapFeaturesKHR {
                    micromap: vk::TRUE,
                    ..Default::default()
                },
            );
        assert!(device.features.acceleration_structure);
        assert!(device.features.micromap_khr);
        assert!(!device.features.micromap_ext);
        assert!(device.has_extension("VK_KHR_opacity_micromap"));
        assert_eq!(
            device
                .limits
                .min_acceleration_structure_scratch_offset_alignment,
            128
        );
    }
}
