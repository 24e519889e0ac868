//! The driver's answers (issue 15, item 9): at `vkCmdBuildMicromapsEXT`
//! the layer asks the next layer's `vkGetMicromapBuildSizesEXT` for the
//! build's shape, keeps the answer per shape, and checks the destination
//! micromap's size (07461) and the scratch range (07509) against it. The
//! fake driver answers `micromapSize` = 1024 + 8 x triangles and
//! `buildScratchSize` = 2048 + triangles.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use ash::vk;
use fake::app::record_micromap_build;
use fake::{calls, device_fn, device_micromap_build, reset_calls, Chain, USAGE};

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
