//! What a test's application does through the layer, shared by the test
//! binaries: layer settings, command buffers, submission and waiting, and
//! the bottom-level build that attaches a micromap.

use std::ffi::CStr;

use ash::vk;

use super::{add_messenger, device_fn, fake_gdpa, Chain, Collector, Serialized};

/// Whom an application's calls go to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Through {
    Layer,
    /// The fake driver's functions, called directly: no layer.
    Driver,
}

/// An application's calls, through the layer or not, and what they
/// returned: tests run the same calls both ways and compare what came back.
pub struct Calls {
    pub through: Through,
    pub device: vk::Device,
    pub queue: vk::Queue,
    /// What the application got back, in order: results, handles, out
    /// parameters.
    pub seen: Vec<String>,
}

impl Calls {
    /// The device function `name`, as [`Calls::through`] offers it.
    pub fn f<F: Copy>(&self, name: &CStr) -> F {
        match self.through {
            Through::Layer => device_fn(self.device, name),
            Through::Driver => {
                // SAFETY: a NUL-terminated name.
                let f = unsafe { fake_gdpa(self.device, name.as_ptr()) }
                    .unwrap_or_else(|| panic!("the fake driver lacks {name:?}"));
                // SAFETY: the caller names the command's function type.
                unsafe { std::mem::transmute_copy(&f) }
            }
        }
    }

    pub fn saw(&mut self, what: impl std::fmt::Debug) {
        self.seen.push(format!("{what:?}"));
    }

    /// A buffer of `size` bytes bound at offset 0 to memory of its own, of
    /// `memory_type` (0: device-local, 1: host-visible), and the memory.
    pub fn buffer(
        &mut self,
        size: u64,
        usage: vk::BufferUsageFlags,
        memory_type: u32,
    ) -> (vk::Buffer, vk::DeviceMemory) {
        let create: vk::PFN_vkCreateBuffer = self.f(c"vkCreateBuffer");
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        let mut buffer = vk::Buffer::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut buffer) };
        self.saw((result, buffer));
        let allocate: vk::PFN_vkAllocateMemory = self.f(c"vkAllocateMemory");
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(size)
            .memory_type_index(memory_type);
        let mut memory = vk::DeviceMemory::null();
        // SAFETY: valid arguments.
        let result = unsafe { allocate(self.device, &info, std::ptr::null(), &mut memory) };
        self.saw((result, memory));
        let bind: vk::PFN_vkBindBufferMemory = self.f(c"vkBindBufferMemory");
        // SAFETY: valid arguments.
        let result = unsafe { bind(self.device, buffer, memory, 0) };
        self.saw(result);
        (buffer, memory)
    }

    pub fn address(&mut self, buffer: vk::Buffer) -> u64 {
        let get: vk::PFN_vkGetBufferDeviceAddress = self.f(c"vkGetBufferDeviceAddress");
        let info = vk::BufferDeviceAddressInfo::default().buffer(buffer);
        // SAFETY: valid arguments.
        let address = unsafe { get(self.device, &info) };
        self.saw(address);
        address
    }
}

/// The layer's settings as VK_EXT_layer_settings strings, kept alive while
/// the instance is created.
///
/// The provenance store is off unless `settings` name it: on by default,
/// under the home directory, it would link one test's serializations to
/// another's and to earlier runs'.
pub fn with_settings<T>(
    settings: &[(&CStr, &CStr)],
    create: impl FnOnce(*const std::ffi::c_void) -> T,
) -> T {
    let mut settings = settings.to_vec();
    if !settings
        .iter()
        .any(|(name, _)| *name == c"provenance_store")
    {
        settings.push((c"provenance_store", c"off"));
    }
    let values: Vec<*const std::ffi::c_char> = settings.iter().map(|(_, v)| v.as_ptr()).collect();
    let settings: Vec<vk::LayerSettingEXT<'_>> = settings
        .iter()
        .zip(&values)
        .map(|((name, _), value)| vk::LayerSettingEXT {
            p_layer_name: VkLayer_ommcheck::LAYER_NAME_C.as_ptr(),
            p_setting_name: name.as_ptr(),
            ty: vk::LayerSettingTypeEXT::STRING,
            value_count: 1,
            p_values: (value as *const *const std::ffi::c_char).cast(),
            ..Default::default()
        })
        .collect();
    let info = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    create((&info as *const vk::LayerSettingsCreateInfoEXT<'_>).cast())
}

/// Settings that report every severity, with no duplicate limit.
pub const REPORT_EVERYTHING: [(&CStr, &CStr); 2] = [
    (c"report_flags", c"error,warning,info"),
    (c"duplicate_message_limit", c"0"),
];

impl Chain {
    /// Serializes micromap `from` on the host (vkCopyMicromapToMemoryEXT)
    /// into `data`.
    pub fn serialize_micromap_on_host(&self, from: vk::MicromapEXT, data: &mut Serialized) {
        let serialize: vk::PFN_vkCopyMicromapToMemoryEXT =
            device_fn(self.device, c"vkCopyMicromapToMemoryEXT");
        let info = vk::CopyMicromapToMemoryInfoEXT {
            src: from,
            dst: vk::DeviceOrHostAddressKHR {
                host_address: data.0.as_mut_ptr().cast(),
            },
            mode: vk::CopyMicromapModeEXT::SERIALIZE,
            ..Default::default()
        };
        // SAFETY: a valid info whose destination is the 64 bytes of `data`
        // (the fake driver writes 64).
        let result = unsafe { serialize(self.device, vk::DeferredOperationKHR::null(), &info) };
        assert_eq!(result, vk::Result::SUCCESS);
    }

    /// Deserializes `data` into micromap `into` on the host
    /// (vkCopyMemoryToMicromapEXT); the ids of the messages the
    /// deserialization drew (those before it are dropped).
    pub fn deserialize_micromap_on_host(
        &self,
        data: &Serialized,
        into: vk::MicromapEXT,
    ) -> Vec<String> {
        self.collector.take();
        let copy: vk::PFN_vkCopyMemoryToMicromapEXT =
            device_fn(self.device, c"vkCopyMemoryToMicromapEXT");
        let info = data.deserialize_into(into);
        // SAFETY: a valid info whose source holds 64 bytes of serialized data.
        let result = unsafe { copy(self.device, vk::DeferredOperationKHR::null(), &info) };
        assert_eq!(result, vk::Result::SUCCESS);
        self.collector.take().into_iter().map(|m| m.id).collect()
    }

    /// A messenger collecting the information messages (the chain's own
    /// collects errors and warnings).
    pub fn info_collector(&self) -> Box<Collector> {
        let info = Box::<Collector>::default();
        add_messenger(
            self.instance,
            vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            &info,
        );
        info
    }

    /// A buffer of `bytes.len()` bytes in host-visible memory the
    /// application keeps mapped, holding `bytes`.
    pub fn mapped_buffer_holding(&self, bytes: &[u8], usage: vk::BufferUsageFlags) -> vk::Buffer {
        let (buffer, memory) = self.buffer_and_memory(bytes.len() as u64, usage, 1);
        // SAFETY: the mapping covers the whole memory, `bytes.len()` long.
        unsafe {
            self.map_backing(memory)
                .copy_from_nonoverlapping(bytes.as_ptr(), bytes.len())
        };
        buffer
    }

    /// An acceleration structure of `ty` in 64 KiB of device-local storage.
    pub fn acceleration_structure(
        &self,
        ty: vk::AccelerationStructureTypeKHR,
    ) -> vk::AccelerationStructureKHR {
        let storage = self.buffer(
            1 << 16,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            0,
        );
        let create: vk::PFN_vkCreateAccelerationStructureKHR =
            device_fn(self.device, c"vkCreateAccelerationStructureKHR");
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage)
            .size(1 << 16)
            .ty(ty);
        let mut structure = vk::AccelerationStructureKHR::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut structure) };
        assert_eq!(result, vk::Result::SUCCESS);
        structure
    }

    /// The chain with `settings` (name, value) given through
    /// VK_EXT_layer_settings, so tests in one process do not share them
    /// through the environment.
    pub fn with_settings(settings: &[(&CStr, &CStr)]) -> Self {
        with_settings(settings, Self::with_instance_next)
    }

    /// As [`Chain::with_settings`], with the micromap features on or off.
    pub fn with_settings_and_micromap_feature(settings: &[(&CStr, &CStr)], micromap: bool) -> Self {
        let (chain, result) = with_settings(settings, |next| {
            Self::with_chains(next, std::ptr::null_mut(), micromap)
        });
        assert_eq!(result, vk::Result::SUCCESS);
        chain
    }

    /// A command pool of queue family 0 (graphics, compute and transfer).
    pub fn command_pool(&self) -> vk::CommandPool {
        self.command_pool_of(0)
    }

    /// A command pool of `family` (0: graphics, compute and transfer; 1:
    /// transfer only).
    pub fn command_pool_of(&self, family: u32) -> vk::CommandPool {
        let create: vk::PFN_vkCreateCommandPool = device_fn(self.device, c"vkCreateCommandPool");
        let info = vk::CommandPoolCreateInfo::default().queue_family_index(family);
        let mut pool = vk::CommandPool::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut pool) };
        assert_eq!(result, vk::Result::SUCCESS);
        pool
    }

    /// A command buffer of `level` from `pool`.
    pub fn command_buffer_from(
        &self,
        pool: vk::CommandPool,
        level: vk::CommandBufferLevel,
    ) -> vk::CommandBuffer {
        let allocate: vk::PFN_vkAllocateCommandBuffers =
            device_fn(self.device, c"vkAllocateCommandBuffers");
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(level)
            .command_buffer_count(1);
        let mut command_buffer = vk::CommandBuffer::null();
        // SAFETY: valid arguments, room for one handle.
        let result = unsafe { allocate(self.device, &info, &mut command_buffer) };
        assert_eq!(result, vk::Result::SUCCESS);
        command_buffer
    }

    /// A primary command buffer from a pool of its own.
    pub fn allocate_command_buffer(&self) -> vk::CommandBuffer {
        self.command_buffer_from(self.command_pool(), vk::CommandBufferLevel::PRIMARY)
    }

    pub fn begin(&self, command_buffer: vk::CommandBuffer) {
        let begin: vk::PFN_vkBeginCommandBuffer = device_fn(self.device, c"vkBeginCommandBuffer");
        let info = vk::CommandBufferBeginInfo::default();
        // SAFETY: valid arguments.
        assert_eq!(unsafe { begin(command_buffer, &info) }, vk::Result::SUCCESS);
    }

    pub fn end(&self, command_buffer: vk::CommandBuffer) {
        let end: vk::PFN_vkEndCommandBuffer = device_fn(self.device, c"vkEndCommandBuffer");
        // SAFETY: valid arguments.
        assert_eq!(unsafe { end(command_buffer) }, vk::Result::SUCCESS);
    }

    /// Queue 0 of family 0, through vkGetDeviceQueue.
    pub fn queue(&self) -> vk::Queue {
        let get: vk::PFN_vkGetDeviceQueue = device_fn(self.device, c"vkGetDeviceQueue");
        let mut queue = vk::Queue::null();
        // SAFETY: valid arguments.
        unsafe { get(self.device, 0, 0, &mut queue) };
        queue
    }

    /// Submits `command_buffer` with vkQueueSubmit, signaling `fence`.
    pub fn submit_with(&self, command_buffer: vk::CommandBuffer, fence: vk::Fence) -> vk::Result {
        let submit: vk::PFN_vkQueueSubmit = device_fn(self.device, c"vkQueueSubmit");
        let command_buffers = [command_buffer];
        let info = vk::SubmitInfo::default().command_buffers(&command_buffers);
        // SAFETY: valid arguments.
        unsafe { submit(self.queue(), 1, &info, fence) }
    }

    /// Submits `command_buffer` with vkQueueSubmit and no fence.
    pub fn submit(&self, command_buffer: vk::CommandBuffer) -> vk::Result {
        self.submit_with(command_buffer, vk::Fence::null())
    }

    /// Maps `memory` where the fake driver keeps its bytes: what the
    /// application writes there, the fake GPU's commands read.
    pub fn map_backing(&self, memory: vk::DeviceMemory) -> *mut u8 {
        let map: vk::PFN_vkMapMemory = device_fn(self.device, c"vkMapMemory");
        let mut mapped = std::ptr::null_mut();
        // SAFETY: valid arguments.
        let result = unsafe {
            map(
                self.device,
                memory,
                0,
                vk::WHOLE_SIZE,
                vk::MemoryMapFlags::empty(),
                &mut mapped,
            )
        };
        assert_eq!(result, vk::Result::SUCCESS);
        mapped.cast()
    }

    pub fn fence(&self) -> vk::Fence {
        let create: vk::PFN_vkCreateFence = device_fn(self.device, c"vkCreateFence");
        let mut fence = vk::Fence::null();
        // SAFETY: valid arguments.
        let result = unsafe {
            create(
                self.device,
                &vk::FenceCreateInfo::default(),
                std::ptr::null(),
                &mut fence,
            )
        };
        assert_eq!(result, vk::Result::SUCCESS);
        fence
    }

    /// A timeline semaphore starting at `initial`.
    pub fn timeline(&self, initial: u64) -> vk::Semaphore {
        let create: vk::PFN_vkCreateSemaphore = device_fn(self.device, c"vkCreateSemaphore");
        let mut kind = vk::SemaphoreTypeCreateInfo::default()
            .semaphore_type(vk::SemaphoreType::TIMELINE)
            .initial_value(initial);
        let info = vk::SemaphoreCreateInfo::default().push_next(&mut kind);
        let mut semaphore = vk::Semaphore::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.device, &info, std::ptr::null(), &mut semaphore) };
        assert_eq!(result, vk::Result::SUCCESS);
        semaphore
    }

    pub fn wait_for_fence(&self, fence: vk::Fence) -> vk::Result {
        let wait: vk::PFN_vkWaitForFences = device_fn(self.device, c"vkWaitForFences");
        // SAFETY: one fence.
        unsafe { wait(self.device, 1, &fence, vk::TRUE, u64::MAX) }
    }

    /// Waits until `semaphore` reaches `value`.
    pub fn wait_semaphore(&self, semaphore: vk::Semaphore, value: u64) -> vk::Result {
        let wait: vk::PFN_vkWaitSemaphores = device_fn(self.device, c"vkWaitSemaphores");
        let semaphores = [semaphore];
        let values = [value];
        let info = vk::SemaphoreWaitInfo::default()
            .semaphores(&semaphores)
            .values(&values);
        // SAFETY: valid arguments.
        unsafe { wait(self.device, &info, u64::MAX) }
    }
}

/// A bottom-level build of two non-indexed triangles whose geometry
/// attaches a micromap through `VkAccelerationStructureTrianglesOpacityMicromapEXT`.
pub struct AttachmentBuild<'a> {
    pub blas: vk::AccelerationStructureKHR,
    pub vertices: u64,
    pub scratch: u64,
    /// The 32-bit opacity indices' device address.
    pub indices: u64,
    pub usage_counts: &'a [vk::MicromapUsageEXT],
    /// VK_NULL_HANDLE: special indices only.
    pub micromap: vk::MicromapEXT,
}

impl AttachmentBuild<'_> {
    /// A bottom-level acceleration structure for the build, in 64 KiB of
    /// device-local storage.
    pub fn structure(chain: &Chain) -> vk::AccelerationStructureKHR {
        chain.acceleration_structure(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
    }

    /// Records the build with vkCmdBuildAccelerationStructuresKHR.
    pub fn record(&self, chain: &Chain, command_buffer: vk::CommandBuffer) {
        self.with_info(|info| {
            let range = vk::AccelerationStructureBuildRangeInfoKHR {
                primitive_count: 2,
                ..Default::default()
            };
            let ranges = [&range as *const vk::AccelerationStructureBuildRangeInfoKHR];
            let build: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
                device_fn(chain.device, c"vkCmdBuildAccelerationStructuresKHR");
            // SAFETY: valid pointers for one info and its one range.
            unsafe { build(command_buffer, 1, info, ranges.as_ptr()) };
        });
    }

    /// Records the build with vkCmdBuildAccelerationStructuresIndirectKHR,
    /// its one range info (16 bytes, stride 16) at device address `ranges`.
    pub fn record_indirect(&self, chain: &Chain, command_buffer: vk::CommandBuffer, ranges: u64) {
        self.with_info(|info| record_indirect(chain, command_buffer, info, ranges));
    }

    /// Calls `record` with the build's info (one geometry of two triangles).
    pub fn with_info(
        &self,
        record: impl FnOnce(&vk::AccelerationStructureBuildGeometryInfoKHR<'_>),
    ) {
        let attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
            index_type: vk::IndexType::UINT32,
            index_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: self.indices,
            },
            index_stride: 4,
            usage_counts_count: self.usage_counts.len() as u32,
            p_usage_counts: self.usage_counts.as_ptr(),
            micromap: self.micromap,
            ..Default::default()
        };
        let mut triangles = vk::AccelerationStructureGeometryTrianglesDataKHR {
            vertex_format: vk::Format::R32G32B32_SFLOAT,
            vertex_data: vk::DeviceOrHostAddressConstKHR {
                device_address: self.vertices,
            },
            vertex_stride: 12,
            max_vertex: 5,
            index_type: vk::IndexType::NONE_KHR,
            ..Default::default()
        };
        triangles.p_next =
            (&attachment as *const vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>).cast();
        let geometry = vk::AccelerationStructureGeometryKHR {
            geometry_type: vk::GeometryTypeKHR::TRIANGLES,
            geometry: vk::AccelerationStructureGeometryDataKHR { triangles },
            ..Default::default()
        };
        let info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            mode: vk::BuildAccelerationStructureModeKHR::BUILD,
            dst_acceleration_structure: self.blas,
            geometry_count: 1,
            p_geometries: &geometry,
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: self.scratch,
            },
            ..Default::default()
        };
        record(&info);
    }
}

/// Records vkCmdBuildAccelerationStructuresIndirectKHR of `info` (one
/// geometry), its range info at device address `ranges`, stride 16, and a
/// maximum primitive count of 2.
pub fn record_indirect(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    info: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    ranges: u64,
) {
    let indirect: vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR =
        device_fn(chain.device, c"vkCmdBuildAccelerationStructuresIndirectKHR");
    let addresses = [ranges];
    let strides = [16u32];
    let max_counts = [2u32];
    let max_count_pointers = [max_counts.as_ptr()];
    // SAFETY: valid pointers for one info and its one geometry.
    unsafe {
        indirect(
            command_buffer,
            1,
            info,
            addresses.as_ptr(),
            strides.as_ptr(),
            max_count_pointers.as_ptr(),
        )
    };
}

/// The bytes of one VkAccelerationStructureBuildRangeInfoKHR of
/// `primitive_count` primitives from `primitive_offset`.
pub fn range_info_bytes(primitive_count: u32, primitive_offset: u32) -> Vec<u8> {
    [primitive_count, primitive_offset, 0, 0]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect()
}

/// Records `info` with vkCmdBuildMicromapsEXT.
pub fn record_micromap_build(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    info: &vk::MicromapBuildInfoEXT<'_>,
) {
    let build: vk::PFN_vkCmdBuildMicromapsEXT = device_fn(chain.device, c"vkCmdBuildMicromapsEXT");
    // SAFETY: valid pointers for one info.
    unsafe { build(command_buffer, 1, info) };
}
