//! The driver's answers (issue 15, item 9): at `vkCmdBuildMicromapsEXT`
//! the layer asks the next layer's `vkGetMicromapBuildSizesEXT` for the
//! build's shape, keeps the answer per shape, and checks the destination
//! micromap's size (07461) and the scratch range (07509) against it. The
//! fake driver answers `micromapSize` = 1024 + 8 x triangles and
//! `buildScratchSize` = 2048 + triangles. At `vkCopyMemoryToMicromapEXT`
//! the layer reads the serialized data's version and asks the next layer's
//! `vkGetDeviceMicromapCompatibilityEXT` once per version (07549); the fake
//! driver accepts data that starts with its `DRIVER_UUID`.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use ash::vk;
use fake::app::record_micromap_build;
use fake::{
    calls, device_fn, device_micromap_build, reset_calls, Chain, Serialized, DRIVER_UUID,
    SERIALIZATION_SIZE, TRIANGLES, USAGE,
};

const SIZE: &str = "VUID-vkCmdBuildMicromapsEXT-pInfos-07461";
const SCRATCH: &str = "VUID-vkCmdBuildMicromapsEXT-pInfos-07509";
const QUERY: &str = "vkGetMicromapBuildSizesEXT";

/// The fake driver's answer for [`USAGE`] (two triangles).
const MICROMAP_SIZE: u64 = 1024 + 8 * 2;
const SCRATCH_SIZE: u64 = 2048 + 2;

/// A build of [`USAGE`] into a micromap of `micromap_size` bytes, with a
/// scratch buffer of `scratch_size` bytes, recorded through the layer;
/// the ids of the messages it drew.
fn build(chain: &Chain, micromap_size: u64, scratch_size: u64) -> Vec<String> {
    let address = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
    let micromap = chain.micromap(storage, micromap_size);
    let input = chain.buffer(
        4096,
        vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT | address,
        0,
    );
    let scratch = chain.buffer(
        scratch_size,
        vk::BufferUsageFlags::STORAGE_BUFFER | address,
        0,
    );
    let input = chain.address(input);
    let info = device_micromap_build(micromap, &USAGE, input, input + 256, chain.address(scratch));
    record_micromap_build(chain, chain.command_buffer, &info);
    chain.collector.take().into_iter().map(|m| m.id).collect()
}

#[test]
fn sizes_short_of_the_driver_answer_are_reported_and_exact_ones_are_not() {
    let chain = Chain::new();
    let exact = build(&chain, MICROMAP_SIZE, SCRATCH_SIZE);
    assert_eq!(exact, Vec::<String>::new());
    let small_micromap = build(&chain, MICROMAP_SIZE - 1, SCRATCH_SIZE);
    assert_eq!(small_micromap, [SIZE]);
    let short_scratch = build(&chain, MICROMAP_SIZE, SCRATCH_SIZE - 1);
    assert_eq!(short_scratch, [SCRATCH]);
}

#[test]
fn the_driver_is_asked_once_per_shape() {
    let chain = Chain::new();
    reset_calls();
    for _ in 0..3 {
        assert!(build(&chain, MICROMAP_SIZE, SCRATCH_SIZE).is_empty());
    }
    let asked = calls(QUERY);
    assert_eq!(asked.len(), 1, "{asked:?}");
    // The layer asks for a device build; the fake records the build type
    // and the micromapSize it answered.
    assert_eq!(
        asked[0].args,
        [
            vk::AccelerationStructureBuildTypeKHR::DEVICE.as_raw() as u64,
            MICROMAP_SIZE
        ]
    );
}

#[test]
fn a_shape_the_application_asked_about_costs_no_call() {
    let chain = Chain::new();
    // Three triangles: a shape no other test of this thread builds.
    static THREE: [vk::MicromapUsageEXT; 1] = [vk::MicromapUsageEXT {
        count: 3,
        subdivision_level: 1,
        format: 1,
    }];
    let get: vk::PFN_vkGetMicromapBuildSizesEXT =
        device_fn(chain.device, c"vkGetMicromapBuildSizesEXT");
    let query = device_micromap_build(vk::MicromapEXT::null(), &THREE, 0, 0, 0);
    let mut sizes = vk::MicromapBuildSizesInfoEXT::default();
    // SAFETY: a valid build info and a structure to fill.
    unsafe {
        get(
            chain.device,
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            &query,
            &mut sizes,
        )
    };
    assert_eq!(sizes.micromap_size, 1024 + 8 * 3);
    reset_calls();
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
    // One byte short of what the application was told.
    let micromap = chain.micromap(storage, sizes.micromap_size - 1);
    let info = device_micromap_build(micromap, &THREE, 0, 0, 0);
    record_micromap_build(&chain, chain.command_buffer, &info);
    let ids: Vec<String> = chain.collector.take().into_iter().map(|m| m.id).collect();
    assert!(ids.iter().any(|id| id == SIZE), "{ids:?}");
    assert_eq!(calls(QUERY), []);
}

const HOST_OVERLAP: &str = "VUID-vkBuildMicromapsEXT-dstMicromap-11668";

/// A host build of [`USAGE`] into a micromap in the second half of an
/// 8192-byte buffer of host-visible memory the application mapped, with
/// the host scratch `scratch_at` bytes into that mapping; the ids of the
/// messages it drew.
fn host_build_with_scratch_in_the_mapping(chain: &Chain, scratch_at: usize) -> Vec<String> {
    let (storage, memory) = chain.buffer_and_memory(
        8192,
        vk::BufferUsageFlags::MICROMAP_STORAGE_EXT,
        1, // host-visible
    );
    let create: vk::PFN_vkCreateMicromapEXT = device_fn(chain.device, c"vkCreateMicromapEXT");
    let create_info = vk::MicromapCreateInfoEXT {
        buffer: storage,
        offset: 4096,
        size: 4096,
        ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
        ..Default::default()
    };
    let mut micromap = vk::MicromapEXT::null();
    // SAFETY: valid arguments.
    let result = unsafe { create(chain.device, &create_info, std::ptr::null(), &mut micromap) };
    assert_eq!(result, vk::Result::SUCCESS);
    let mapping = chain.map_backing(memory);
    // The triangle array at the start, the data (one byte each) at 256.
    let mut input = [0u8; 512];
    for (k, triangle) in TRIANGLES.iter().enumerate() {
        input[8 * k..8 * k + 4].copy_from_slice(&triangle.data_offset.to_le_bytes());
        input[8 * k + 4..8 * k + 6].copy_from_slice(&triangle.subdivision_level.to_le_bytes());
        input[8 * k + 6..8 * k + 8].copy_from_slice(&triangle.format.to_le_bytes());
    }
    let info = vk::MicromapBuildInfoEXT {
        data: vk::DeviceOrHostAddressConstKHR {
            host_address: input[256..].as_ptr().cast(),
        },
        triangle_array: vk::DeviceOrHostAddressConstKHR {
            host_address: input.as_ptr().cast(),
        },
        scratch_data: vk::DeviceOrHostAddressKHR {
            host_address: mapping.wrapping_add(scratch_at).cast(),
        },
        ..device_micromap_build(micromap, &USAGE, 0, 0, 0)
    };
    let build: vk::PFN_vkBuildMicromapsEXT = device_fn(chain.device, c"vkBuildMicromapsEXT");
    // SAFETY: valid pointers for one info; the layer passes the build on
    // to the fake driver, which does not write the scratch.
    let result = unsafe { build(chain.device, vk::DeferredOperationKHR::null(), 1, &info) };
    assert_eq!(result, vk::Result::SUCCESS);
    chain.collector.take().into_iter().map(|m| m.id).collect()
}

#[test]
fn host_scratch_reaching_into_the_mapped_destination_is_reported() {
    let chain = Chain::new();
    // The scratch's buildScratchSize bytes end where the micromap starts.
    let before = 4096 - SCRATCH_SIZE as usize;
    // The micromap data lies in plain host memory, which the layer cannot
    // see: said once for the device, as a warning.
    assert_eq!(
        host_build_with_scratch_in_the_mapping(&chain, before),
        ["OMMCHECK-not-checked-host-memory"]
    );
    // One byte later its last byte is the micromap's first.
    assert_eq!(
        host_build_with_scratch_in_the_mapping(&chain, before + 1),
        [HOST_OVERLAP]
    );
}

const SERIALIZED_SIZE: &str = "VUID-VkCopyMicromapToMemoryInfoEXT-dst-07541";

/// Asks the serialization size of a micromap as the application does
/// (`vkWriteMicromapsPropertiesEXT`), then serializes it into a buffer of
/// `room` bytes; the ids the serialization drew.
fn serialize_into(chain: &Chain, room: u64) -> Vec<String> {
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    let micromap = chain.micromap(storage, 4096);
    let write: vk::PFN_vkWriteMicromapsPropertiesEXT =
        device_fn(chain.device, c"vkWriteMicromapsPropertiesEXT");
    let mut size = 0u64;
    // SAFETY: one micromap, and room for its one result.
    let result = unsafe {
        write(
            chain.device,
            1,
            &micromap,
            vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT,
            8,
            (&mut size as *mut u64).cast(),
            8,
        )
    };
    assert_eq!((result, size), (vk::Result::SUCCESS, SERIALIZATION_SIZE));
    // What the query drew (the micromap was never built) is not this test's.
    chain.collector.take();
    let serialized = chain.buffer(
        room,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        0,
    );
    let info = vk::CopyMicromapToMemoryInfoEXT {
        src: micromap,
        dst: vk::DeviceOrHostAddressKHR {
            device_address: chain.address(serialized),
        },
        mode: vk::CopyMicromapModeEXT::SERIALIZE,
        ..Default::default()
    };
    let copy: vk::PFN_vkCmdCopyMicromapToMemoryEXT =
        device_fn(chain.device, c"vkCmdCopyMicromapToMemoryEXT");
    // SAFETY: a valid info.
    unsafe { copy(chain.command_buffer, &info) };
    chain.collector.take().into_iter().map(|m| m.id).collect()
}

#[test]
fn a_serialization_into_less_than_the_reported_size_is_reported() {
    let chain = Chain::new();
    let short = serialize_into(&chain, SERIALIZATION_SIZE - 1);
    assert_eq!(short, [SERIALIZED_SIZE]);
    let exact = serialize_into(&chain, SERIALIZATION_SIZE);
    assert_eq!(exact, Vec::<String>::new());
}

const INCOMPATIBLE: &str = "VUID-VkCopyMemoryToMicromapInfoEXT-src-07549";
const COMPATIBILITY: &str = "vkGetDeviceMicromapCompatibilityEXT";

/// Deserializes, on the host, data whose version is `driver_uuid` then 16
/// bytes of `compatibility`, into a micromap in host-visible memory; the
/// ids the deserialization drew.
fn deserialize(chain: &Chain, driver_uuid: [u8; 16], compatibility: u8) -> Vec<String> {
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    let micromap = chain.micromap(storage, 4096);
    chain.deserialize_micromap_on_host(&Serialized::new(driver_uuid, compatibility), micromap)
}

#[test]
fn data_the_driver_does_not_accept_is_reported_and_accepted_data_is_not() {
    let chain = Chain::new();
    assert_eq!(deserialize(&chain, DRIVER_UUID, 0), Vec::<String>::new());
    let mut other_driver = DRIVER_UUID;
    other_driver[0] ^= 1;
    assert_eq!(deserialize(&chain, other_driver, 0), [INCOMPATIBLE]);
}

#[test]
fn the_driver_is_asked_once_per_version() {
    let chain = Chain::new();
    reset_calls();
    for _ in 0..3 {
        assert!(deserialize(&chain, DRIVER_UUID, 7).is_empty());
    }
    let asked = calls(COMPATIBILITY);
    assert_eq!(asked.len(), 1, "{asked:?}");
    assert_eq!(asked[0].args, [1]);
    // Other compatibility data is another version: asked once more.
    assert!(deserialize(&chain, DRIVER_UUID, 8).is_empty());
    assert_eq!(calls(COMPATIBILITY).len(), 2);
}

#[test]
fn a_version_the_application_asked_about_costs_no_call() {
    let chain = Chain::new();
    let mut other_driver = DRIVER_UUID;
    other_driver[15] ^= 1;
    let mut version = [9u8; 32];
    version[..16].copy_from_slice(&other_driver);
    let get: vk::PFN_vkGetDeviceMicromapCompatibilityEXT =
        device_fn(chain.device, c"vkGetDeviceMicromapCompatibilityEXT");
    let info = vk::MicromapVersionInfoEXT {
        p_version_data: &version,
        ..Default::default()
    };
    let mut answer = vk::AccelerationStructureCompatibilityKHR::COMPATIBLE;
    // SAFETY: a valid version info and a value to fill.
    unsafe { get(chain.device, &info, &mut answer) };
    assert_eq!(
        answer,
        vk::AccelerationStructureCompatibilityKHR::INCOMPATIBLE
    );
    chain.collector.take();
    reset_calls();
    assert_eq!(deserialize(&chain, other_driver, 9), [INCOMPATIBLE]);
    assert_eq!(calls(COMPATIBILITY), []);
}

/// Serializes micromap `from` on the host into `data`, then deserializes
/// `data` into `into`; the ids the deserialization drew.
fn serialize_then_deserialize(
    chain: &Chain,
    data: &mut Serialized,
    from: vk::MicromapEXT,
    into: vk::MicromapEXT,
) -> Vec<String> {
    chain.serialize_micromap_on_host(from, data);
    chain.deserialize_micromap_on_host(data, into)
}

#[test]
fn a_host_deserialization_is_linked_to_the_serialization_at_its_address() {
    const SMALLER: &str = "VUID-VkCopyMemoryToMicromapInfoEXT-dst-07550";
    // In memory: a test leaves nothing in the user's cache directory.
    let chain = Chain::with_settings(&[(c"provenance_store", c"off")]);
    let micromap = |size| {
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
        chain.micromap(storage, size)
    };
    let (large, small) = (micromap(4096), micromap(2048));
    let mut data = Serialized::new(DRIVER_UUID, 0);
    let ids = serialize_then_deserialize(&chain, &mut data, large, small);
    assert!(ids.iter().any(|id| id == SMALLER), "{ids:?}");
    let ids = serialize_then_deserialize(&chain, &mut data, small, large);
    assert!(!ids.iter().any(|id| id == SMALLER), "{ids:?}");
}
