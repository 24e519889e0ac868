//! What the test applications `omm-app` and `omm-stress` share: an
//! instance with named layers and a messenger, a device with its memory
//! types and buffers, and the build infos and sizes they record.

use std::ffi::{c_void, CStr, CString};

use ash::vk;

/// The memory of buffers an application writes through a mapping.
pub const HOST_MAPPABLE: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::from_raw(
    vk::MemoryPropertyFlags::HOST_VISIBLE.as_raw()
        | vk::MemoryPropertyFlags::HOST_COHERENT.as_raw(),
);

/// Two 2-state triangles at subdivision level 1: one byte of data each.
pub const USAGE: [vk::MicromapUsageEXT; 1] = [vk::MicromapUsageEXT {
    count: 2,
    subdivision_level: 1,
    format: 1,
}];

/// An instance through the system's loader and its messenger.
pub struct Instance {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub debug_utils: ash::ext::debug_utils::Instance,
    pub messenger: vk::DebugUtilsMessengerEXT,
}

impl Instance {
    /// A Vulkan 1.3 instance named `application` with `layers` (in
    /// ppEnabledLayerNames order) and VK_EXT_debug_utils, and a messenger
    /// that calls `callback` with `user_data` for `severities` of
    /// validation, general and performance messages. `user_data` must
    /// outlive the messenger.
    pub fn new(
        application: &CStr,
        layers: &[CString],
        severities: vk::DebugUtilsMessageSeverityFlagsEXT,
        callback: vk::PFN_vkDebugUtilsMessengerCallbackEXT,
        user_data: *mut c_void,
    ) -> Result<Self, String> {
        // SAFETY: loading libvulkan.so.1 runs its initialisers; the loader is
        // the system's, installed from the distribution's packages.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| format!("no Vulkan loader: {e}"))?;
        let layer_ptrs: Vec<_> = layers.iter().map(|l| l.as_ptr()).collect();
        let extensions = [ash::ext::debug_utils::NAME.as_ptr()];
        let app = vk::ApplicationInfo::default()
            .application_name(application)
            .api_version(vk::API_VERSION_1_3);
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&extensions);
        // SAFETY: `info` and everything it points to outlive the call.
        let instance = unsafe { entry.create_instance(&info, None) }
            .map_err(|e| format!("vkCreateInstance: {e}"))?;
        let debug_utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(severities)
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(callback)
            .user_data(user_data);
        // SAFETY: a valid create info; the caller keeps the user data alive.
        let messenger = unsafe { debug_utils.create_debug_utils_messenger(&messenger_info, None) }
            .map_err(|e| format!("vkCreateDebugUtilsMessengerEXT: {e}"))?;
        Ok(Self {
            entry,
            instance,
            debug_utils,
            messenger,
        })
    }

    /// Destroys the messenger and the instance (every device must be gone).
    pub fn destroy(&self) {
        // SAFETY: the messenger and instance are this one's; the caller has
        // destroyed the instance's devices.
        unsafe {
            self.debug_utils
                .destroy_debug_utils_messenger(self.messenger, None);
            self.instance.destroy_instance(None);
        }
    }

    /// The scratch offset alignment of `physical`'s acceleration structures.
    pub fn scratch_alignment(&self, physical: vk::PhysicalDevice) -> u64 {
        let mut structure_properties =
            vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        let mut properties =
            vk::PhysicalDeviceProperties2::default().push_next(&mut structure_properties);
        // SAFETY: a physical device of this instance; a valid chain.
        unsafe {
            self.instance
                .get_physical_device_properties2(physical, &mut properties)
        };
        u64::from(
            structure_properties
                .min_acceleration_structure_scratch_offset_alignment
                .max(1),
        )
    }
}

/// A device with one queue of family 0 (the Mock ICD, lavapipe and the
/// fake driver each have one family with graphics, compute and transfer).
pub struct Device {
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub memory: vk::PhysicalDeviceMemoryProperties,
}

impl Device {
    /// The device of `physical` with `extensions`, the feature
    /// `bufferDeviceAddress` and the features in `features`.
    pub fn new<F: vk::ExtendsDeviceCreateInfo + ?Sized>(
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        extensions: &[&CStr],
        features: &mut F,
    ) -> Result<Self, String> {
        let mut address =
            vk::PhysicalDeviceBufferDeviceAddressFeatures::default().buffer_device_address(true);
        let extensions: Vec<_> = extensions.iter().map(|e| e.as_ptr()).collect();
        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(0)
            .queue_priorities(&priorities)];
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&extensions)
            .push_next(features)
            .push_next(&mut address);
        // SAFETY: `info` is valid and outlives the call.
        let device = unsafe { instance.create_device(physical, &info, None) }
            .map_err(|e| format!("vkCreateDevice: {e}"))?;
        // SAFETY: family 0, queue 0 was requested in `info`.
        let queue = unsafe { device.get_device_queue(0, 0) };
        // SAFETY: a physical device of this instance.
        let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
        Ok(Self {
            device,
            queue,
            memory,
        })
    }

    /// The first memory type in `bits` with `flags`.
    pub fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Result<u32, String> {
        (0..self.memory.memory_type_count)
            .find(|&i| {
                bits & (1 << i) != 0
                    && self.memory.memory_types[i as usize]
                        .property_flags
                        .contains(flags)
            })
            .ok_or_else(|| format!("no memory type with {flags:?} in {bits:#x}"))
    }

    /// Memory of `size` bytes of the first type in `bits` with `flags`.
    pub fn allocate(
        &self,
        size: u64,
        bits: u32,
        flags: vk::MemoryPropertyFlags,
        device_address: bool,
    ) -> Result<vk::DeviceMemory, String> {
        let index = self.memory_type(bits, flags)?;
        let mut address_flags =
            vk::MemoryAllocateFlagsInfo::default().flags(vk::MemoryAllocateFlags::DEVICE_ADDRESS);
        let mut info = vk::MemoryAllocateInfo::default()
            .allocation_size(size)
            .memory_type_index(index);
        if device_address {
            info = info.push_next(&mut address_flags);
        }
        // SAFETY: valid arguments.
        unsafe { self.device.allocate_memory(&info, None) }
            .map_err(|e| format!("vkAllocateMemory: {e}"))
    }

    /// Maps all of `memory`; the pointer stays valid until the memory is
    /// freed (nothing here unmaps).
    pub fn map(&self, memory: vk::DeviceMemory) -> Result<*mut u8, String> {
        // SAFETY: host-visible memory of this device, not mapped yet.
        unsafe {
            self.device
                .map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
        }
        .map(|p| p.cast())
        .map_err(|e| format!("vkMapMemory: {e}"))
    }

    /// A buffer of `size` bytes bound to memory of its own of the first
    /// type with `flags`: the buffer and its memory.
    pub fn bound_buffer(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<(vk::Buffer, vk::DeviceMemory), String> {
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        // SAFETY: valid arguments.
        let buffer = unsafe { self.device.create_buffer(&info, None) }
            .map_err(|e| format!("vkCreateBuffer: {e}"))?;
        // SAFETY: a buffer of this device.
        let requirements = unsafe { self.device.get_buffer_memory_requirements(buffer) };
        let memory = self.allocate(
            requirements.size.max(size),
            requirements.memory_type_bits,
            flags,
            usage.contains(vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS),
        )?;
        // SAFETY: fresh memory large enough for the buffer.
        unsafe { self.device.bind_buffer_memory(buffer, memory, 0) }
            .map_err(|e| format!("vkBindBufferMemory: {e}"))?;
        Ok((buffer, memory))
    }

    /// A buffer of `size` bytes bound to host-visible memory of its own,
    /// mapped: the buffer, its memory and the mapping.
    pub fn mapped(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<(vk::Buffer, vk::DeviceMemory, *mut u8), String> {
        let (buffer, memory) = self.bound_buffer(size, usage, HOST_MAPPABLE)?;
        Ok((buffer, memory, self.map(memory)?))
    }

    pub fn address(&self, buffer: vk::Buffer) -> u64 {
        let info = vk::BufferDeviceAddressInfo::default().buffer(buffer);
        // SAFETY: a buffer created with SHADER_DEVICE_ADDRESS usage.
        unsafe { self.device.get_buffer_device_address(&info) }
    }

    /// An opacity micromap of `size` bytes at the start of `storage`.
    pub fn micromap(
        &self,
        omm: &ash::ext::opacity_micromap::Device,
        storage: vk::Buffer,
        size: u64,
    ) -> Result<vk::MicromapEXT, String> {
        let info = vk::MicromapCreateInfoEXT::default()
            .buffer(storage)
            .size(size)
            .ty(vk::MicromapTypeEXT::OPACITY_MICROMAP);
        let mut micromap = vk::MicromapEXT::null();
        // SAFETY: valid arguments.
        let result = unsafe {
            (omm.fp().create_micromap_ext)(
                self.device.handle(),
                &info,
                std::ptr::null(),
                &mut micromap,
            )
        };
        result
            .result()
            .map_err(|e| format!("vkCreateMicromapEXT: {e}"))?;
        Ok(micromap)
    }
}

/// A build of the two triangles of [`USAGE`] into `micromap`: the triangle
/// array (stride 8), the data and the scratch at the addresses given.
pub fn build_info(
    micromap: vk::MicromapEXT,
    triangle_array: vk::DeviceOrHostAddressConstKHR,
    data: vk::DeviceOrHostAddressConstKHR,
    scratch_data: vk::DeviceOrHostAddressKHR,
) -> vk::MicromapBuildInfoEXT<'static> {
    vk::MicromapBuildInfoEXT {
        ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
        mode: vk::BuildMicromapModeEXT::BUILD,
        dst_micromap: micromap,
        usage_counts_count: 1,
        p_usage_counts: USAGE.as_ptr(),
        data,
        triangle_array,
        triangle_array_stride: 8,
        scratch_data,
        ..Default::default()
    }
}

/// Where a bottom-level build attaching a micromap reads and writes, each
/// a device or a host address.
pub struct Attaching<'a> {
    /// Six vertices (R32G32B32_SFLOAT, stride 12): two triangles, not indexed.
    pub vertices: vk::DeviceOrHostAddressConstKHR,
    /// The two 32-bit opacity indices.
    pub indices: vk::DeviceOrHostAddressConstKHR,
    pub usage_counts: &'a [vk::MicromapUsageEXT],
    pub micromap: vk::MicromapEXT,
    pub blas: vk::AccelerationStructureKHR,
    pub scratch: vk::DeviceOrHostAddressKHR,
}

impl Attaching<'_> {
    /// Calls `build` with the info of the bottom-level build of the two
    /// triangles, whose geometry attaches the micromap through
    /// `VkAccelerationStructureTrianglesOpacityMicromapEXT`, and the
    /// pointer to its one range info (two primitives): what
    /// vkCmdBuildAccelerationStructuresKHR and vkBuildAccelerationStructuresKHR
    /// take for one info.
    pub fn with_info<R>(
        &self,
        build: impl FnOnce(
            &vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
            *const *const vk::AccelerationStructureBuildRangeInfoKHR,
        ) -> R,
    ) -> R {
        let mut attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT::default()
            .index_type(vk::IndexType::UINT32)
            .index_buffer(self.indices)
            .index_stride(4)
            .usage_counts(self.usage_counts)
            .micromap(self.micromap);
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(self.vertices)
            .vertex_stride(12)
            .max_vertex(5)
            .index_type(vk::IndexType::NONE_KHR)
            .push_next(&mut attachment);
        let geometries = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geometries)
            .dst_acceleration_structure(self.blas)
            .scratch_data(self.scratch);
        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(2)];
        let range_pointers = [ranges.as_ptr()];
        build(&info, range_pointers.as_ptr())
    }
}

/// The structure size and build scratch size the driver gives a device
/// build of `info` with `primitives` primitives in its one geometry.
pub fn build_sizes(
    accel: &ash::khr::acceleration_structure::Device,
    info: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
    primitives: u32,
) -> [u64; 2] {
    let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    // SAFETY: a valid build info with one geometry.
    unsafe {
        accel.get_acceleration_structure_build_sizes(
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            info,
            &[primitives],
            &mut sizes,
        )
    };
    [sizes.acceleration_structure_size, sizes.build_scratch_size]
}

/// An instance of the structure at device address `reference` with the
/// identity transform, mask 0xFF and `flags`, as 32-bit words.
pub fn instance_words(reference: u64, flags: vk::GeometryInstanceFlagsKHR) -> [u32; 16] {
    let instance = vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR {
            matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        },
        instance_custom_index_and_mask: vk::Packed24_8::new(0, 0xFF),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            0,
            flags.as_raw() as u8,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
            device_handle: reference,
        },
    };
    let mut words = [0u32; 16];
    // SAFETY: the instance is 64 plain bytes (16 words), all initialised.
    unsafe {
        std::ptr::copy_nonoverlapping(
            (&instance as *const vk::AccelerationStructureInstanceKHR).cast::<u32>(),
            words.as_mut_ptr(),
            words.len(),
        )
    };
    words
}

/// The bytes of `words`, as vkCmdUpdateBuffer and the mappings take them.
pub fn word_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_ne_bytes()).collect()
}
