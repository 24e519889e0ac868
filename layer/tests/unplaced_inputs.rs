//! Build inputs whose place in device memory only the GPU learns, over
//! the fake driver: an indirect build's opacity indices (their extent is
//! in the build range infos the GPU reads) and the instances an array of
//! instance pointers points to. Neither route reads them, and the layer
//! says so at recording, once per device and cause
//! (`OMMCHECK-layer-contents-not-checked`), rather than staying silent; the
//! same inputs placed by the parameters draw no such message.

#![allow(unsafe_code)]

mod fake;

use ash::vk;
use fake::app::{AttachmentBuild, REPORT_EVERYTHING};
use fake::gpu::fake_gpu_write;
use fake::{device_fn, Chain, Collector, Received, USAGE};

const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";

/// The chain with readback on, every severity reported, and its
/// information messages collected apart.
fn chain() -> (Chain, Box<Collector>) {
    let chain = Chain::with_settings(
        &[REPORT_EVERYTHING.as_slice(), &[(c"gpu_readback", c"true")]].concat(),
    );
    let info = chain.info_collector();
    (chain, info)
}

/// A device-local buffer a build reads by address, of `size` bytes.
fn input(chain: &Chain, size: u64) -> vk::Buffer {
    let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
        | vk::BufferUsageFlags::STORAGE_BUFFER;
    chain.buffer(size, usage, 0)
}

/// Records `record` into a command buffer, submits it with a fence and
/// waits; returns the information messages of the recording and all the
/// rest, errors and warnings asserted absent throughout.
fn run(
    chain: &Chain,
    info: &Collector,
    record: impl FnOnce(vk::CommandBuffer),
) -> (Vec<Received>, Vec<Received>) {
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    record(command_buffer);
    chain.end(command_buffer);
    let at_recording = info.take();
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    let later = info.take();
    // The attached micromap is created, never built: its build's inputs
    // would be read and checked too, which is not what these tests are
    // about. So the one error expected is that it was not built before the
    // attachment ran (11632, decided at submission); nothing else.
    let findings: Vec<Received> = chain
        .collector
        .take()
        .into_iter()
        .filter(|m| !m.id.ends_with("-micromap-11632"))
        .collect();
    assert!(findings.is_empty(), "{findings:#?}");
    (at_recording, later)
}

/// Records the fake shader's writes of `writes` (buffer, bytes at 0).
fn shader_writes(chain: &Chain, command_buffer: vk::CommandBuffer, writes: &[(vk::Buffer, &[u8])]) {
    for &(buffer, bytes) in writes {
        fake_gpu_write(command_buffer, buffer, 0, bytes);
    }
    let dispatch: vk::PFN_vkCmdDispatch = device_fn(chain.device, c"vkCmdDispatch");
    // SAFETY: a recording command buffer.
    unsafe { dispatch(command_buffer, 1, 1, 1) };
}

fn not_checked(messages: &[Received]) -> Vec<&Received> {
    messages
        .iter()
        .filter(|m| m.id == CONTENTS_NOT_CHECKED)
        .collect()
}

/// Records and runs `record` twice on one device: the recordings must
/// say, once between them, that inputs are not checked, naming each of
/// `words`; nothing is said after recording.
fn said_not_checked_once(
    chain: &Chain,
    info: &Collector,
    record: impl Fn(vk::CommandBuffer),
    words: &[&str],
) {
    let mut messages = Vec::new();
    for _ in 0..2 {
        let (at_recording, later) = run(chain, info, &record);
        assert!(not_checked(&later).is_empty(), "{later:#?}");
        messages.extend(at_recording);
    }
    let said = not_checked(&messages);
    assert_eq!(said.len(), 1, "{messages:#?}");
    for words in words {
        assert!(said[0].text.contains(words), "{words}: {}", said[0].text);
    }
}

/// The bottom-level build attaching a micromap, its indices in a
/// device-local buffer a shader writes.
fn attachment_build(chain: &Chain) -> (AttachmentBuild<'static>, vk::Buffer) {
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
    let micromap = chain.micromap(storage, 4096);
    let indices = input(chain, 8);
    let scratch = input(chain, 1 << 16);
    let build = AttachmentBuild {
        blas: AttachmentBuild::structure(chain),
        vertices: chain.address(input(chain, 4096)),
        scratch: chain.address(scratch),
        indices: chain.address(indices),
        usage_counts: &USAGE,
        micromap,
    };
    (build, indices)
}

/// vkCmdBuildAccelerationStructuresIndirectKHR of `build`, its range info
/// (two triangles) in device memory at `ranges`.
fn record_indirect(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    build: &AttachmentBuild<'_>,
    ranges: u64,
) {
    let indirect: vk::PFN_vkCmdBuildAccelerationStructuresIndirectKHR =
        device_fn(chain.device, c"vkCmdBuildAccelerationStructuresIndirectKHR");
    build.with_info(|info| {
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
    });
}

#[test]
fn an_indirect_builds_opacity_indices_are_reported_not_checked_once_per_device() {
    let (chain, info) = chain();
    let (build, indices) = attachment_build(&chain);
    let ranges = input(&chain, 16);
    let range = [2u32, 0, 0, 0]; // primitiveCount 2, offsets 0.
    let range_bytes: Vec<u8> = range.iter().flat_map(|w| w.to_le_bytes()).collect();
    let record = |command_buffer| {
        // Indices past the micromap's two triangles: a fault no route sees.
        let past: &[u8] = &[0, 0, 0, 0, 9, 0, 0, 0];
        shader_writes(
            &chain,
            command_buffer,
            &[(indices, past), (ranges, &range_bytes)],
        );
        record_indirect(&chain, command_buffer, &build, chain.address(ranges));
    };
    said_not_checked_once(
        &chain,
        &info,
        record,
        &[
            "vkCmdBuildAccelerationStructuresIndirectKHR",
            "pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer",
            "pIndirectDeviceAddresses",
        ],
    );

    // The direct build of the same inputs reads them back (the content
    // rules over them are tested in device_memory.rs): nothing is said
    // not checked.
    let (chain, info) = self::chain();
    let (build, indices) = attachment_build(&chain);
    let (at_recording, later) = run(&chain, &info, |command_buffer| {
        shader_writes(
            &chain,
            command_buffer,
            &[(indices, &[0, 0, 0, 0, 1, 0, 0, 0])],
        );
        build.record(&chain, command_buffer);
    });
    let all = [at_recording, later].concat();
    assert!(not_checked(&all).is_empty(), "{all:#?}");
}

/// A top-level build of one instance from device-local `data`, as an
/// array of pointers or of instances.
fn record_top_level(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    data: u64,
    array_of_pointers: bool,
) {
    let tlas = chain.acceleration_structure(vk::AccelerationStructureTypeKHR::TOP_LEVEL);
    let geometry = vk::AccelerationStructureGeometryKHR {
        geometry_type: vk::GeometryTypeKHR::INSTANCES,
        geometry: vk::AccelerationStructureGeometryDataKHR {
            instances: vk::AccelerationStructureGeometryInstancesDataKHR {
                array_of_pointers: array_of_pointers.into(),
                data: vk::DeviceOrHostAddressConstKHR {
                    device_address: data,
                },
                ..Default::default()
            },
        },
        ..Default::default()
    };
    let scratch = chain.address(input(chain, 1 << 16));
    let info = vk::AccelerationStructureBuildGeometryInfoKHR {
        ty: vk::AccelerationStructureTypeKHR::TOP_LEVEL,
        mode: vk::BuildAccelerationStructureModeKHR::BUILD,
        dst_acceleration_structure: tlas,
        geometry_count: 1,
        p_geometries: &geometry,
        scratch_data: vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        },
        ..Default::default()
    };
    let range = vk::AccelerationStructureBuildRangeInfoKHR {
        primitive_count: 1,
        ..Default::default()
    };
    let ranges = [std::ptr::from_ref(&range)];
    let build: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
        device_fn(chain.device, c"vkCmdBuildAccelerationStructuresKHR");
    // SAFETY: valid pointers for one info and its one range.
    unsafe { build(command_buffer, 1, &info, ranges.as_ptr()) };
}

#[test]
fn instances_behind_an_array_of_pointers_are_reported_not_checked_once_per_device() {
    let (chain, info) = chain();
    let instances = input(&chain, 64);
    let pointers = input(&chain, 8);
    let pointer = chain.address(instances).to_le_bytes();
    let record = |command_buffer| {
        shader_writes(&chain, command_buffer, &[(pointers, &pointer)]);
        record_top_level(&chain, command_buffer, chain.address(pointers), true);
    };
    said_not_checked_once(
        &chain,
        &info,
        record,
        &[
            "vkCmdBuildAccelerationStructuresKHR",
            "pInfos[0].pGeometries[0].geometry.instances.data",
            "arrayOfPointers",
        ],
    );

    // The instances themselves are read back: nothing is said not checked.
    let (chain, info) = self::chain();
    let instances = input(&chain, 64);
    let (at_recording, later) = run(&chain, &info, |command_buffer| {
        record_top_level(&chain, command_buffer, chain.address(instances), false);
    });
    let all = [at_recording, later].concat();
    assert!(not_checked(&all).is_empty(), "{all:#?}");
}
