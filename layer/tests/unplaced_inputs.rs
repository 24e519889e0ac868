//! Build inputs whose place in device memory is decided by other bytes in
//! device memory, over the fake driver: an indirect build's opacity indices
//! and instances (their extent is in the build range infos the GPU reads)
//! and the instances an array of instance pointers points to.
//!
//! The layer reads an indirect build's range infos and those inputs (from
//! their start towards the end of their buffer) by the same routes as any
//! input, and checks them once the range infos are decoded; the instances
//! behind an array of pointers it can read at recording (mapped memory) are
//! read back too. What neither route reads (an array of pointers in
//! device-local memory) is said not checked once per device and cause
//! (`OMMCHECK-layer-contents-not-checked`), rather than left silent.

#![allow(unsafe_code)]

mod fake;

use ash::vk;
use fake::app::{range_info_bytes, record_indirect, AttachmentBuild, REPORT_EVERYTHING};
use fake::gpu::fake_gpu_write;
use fake::{add_messenger, device_fn, Chain, Collector, Received, USAGE};

const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";

/// The chain with readback on, every severity reported, and what the
/// layer says besides findings collected apart.
fn chain() -> (Chain, Box<Collector>) {
    chain_with(true, true)
}

/// The chain with readback as given, every severity reported, the micromap
/// feature as given, and its information messages and warnings collected
/// apart: the layer's warning that contents were not checked among them
/// (the chain's own collector gets that warning too, and [`findings`]
/// leaves it out).
fn chain_with(readback: bool, micromap_feature: bool) -> (Chain, Box<Collector>) {
    let readback = if readback { c"true" } else { c"false" };
    let chain = Chain::with_settings_and_micromap_feature(
        &[REPORT_EVERYTHING.as_slice(), &[(c"gpu_readback", readback)]].concat(),
        micromap_feature,
    );
    let info = Box::<Collector>::default();
    add_messenger(
        chain.instance,
        vk::DebugUtilsMessageSeverityFlagsEXT::INFO
            | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        &info,
    );
    (chain, info)
}

/// The errors and warnings about rules since the last call: what the
/// chain's collector received, less the layer's warnings that contents
/// were not checked.
fn findings(chain: &Chain) -> Vec<Received> {
    chain
        .collector
        .take()
        .into_iter()
        .filter(|m| m.id != CONTENTS_NOT_CHECKED)
        .collect()
}

/// The usage of a buffer an acceleration-structure build reads by address
/// (range infos, pointer arrays, instances).
const READ_BY_ADDRESS: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw()
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw(),
);

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
    let findings: Vec<Received> = findings(chain)
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

/// An indirect build's opacity indices and range info, written by a
/// shader: with readback on both are read back and nothing is said not
/// checked; with it off neither route reads them, and the layer says so
/// once per device at submission, naming the setting.
#[test]
fn an_indirect_builds_opacity_indices_are_read_back_or_said_not_checked_naming_gpu_readback() {
    for readback in [true, false] {
        let (chain, info) = chain_with(readback, true);
        let (build, indices) = attachment_build(&chain);
        let ranges = input(&chain, 16);
        let range_bytes = range_info_bytes(2, 0);
        let record = |command_buffer| {
            shader_writes(
                &chain,
                command_buffer,
                &[(indices, &[0, 0, 0, 0, 1, 0, 0, 0]), (ranges, &range_bytes)],
            );
            build.record_indirect(&chain, command_buffer, chain.address(ranges));
        };
        let mut said = Vec::new();
        for _ in 0..2 {
            let (at_recording, later) = run(&chain, &info, record);
            assert!(not_checked(&at_recording).is_empty(), "{at_recording:#?}");
            said.extend(later);
        }
        let said = not_checked(&said);
        if readback {
            assert!(said.is_empty(), "{said:#?}");
            continue;
        }
        assert_eq!(said.len(), 1, "{said:#?}");
        for words in [
            "vkCmdBuildAccelerationStructuresIndirectKHR",
            "gpu_readback",
            "vkQueueSubmit",
        ] {
            assert!(said[0].text.contains(words), "{words}: {}", said[0].text);
        }
    }
}

/// A top-level build of one instance from device-local `data`, as an
/// array of pointers or of instances.
fn record_top_level(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    data: u64,
    array_of_pointers: bool,
) {
    record_top_level_as(chain, command_buffer, data, array_of_pointers, None);
}

/// [`record_top_level`], or (`indirect_ranges`) the indirect build whose
/// range info is at that device address.
fn record_top_level_as(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    data: u64,
    array_of_pointers: bool,
    indirect_ranges: Option<u64>,
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
    if let Some(ranges) = indirect_ranges {
        record_indirect(chain, command_buffer, &info, ranges);
        return;
    }
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

const INSTANCE_FLAGS_11580: &str = "VUID-VkAccelerationStructureInstanceKHR-micromap-11580";

/// One VkAccelerationStructureInstanceKHR, with
/// VK_GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_BIT_EXT where
/// `faulty` (11580 without the micromap feature), else no flag.
fn instance(faulty: bool) -> [u8; 64] {
    let mut bytes = [0u8; 64];
    bytes[52] = 0xff; // mask
    bytes[55] = if faulty { 0x10 } else { 0 };
    bytes[56..].copy_from_slice(&0x1000u64.to_le_bytes());
    bytes
}

/// Records `record`, submits with a fence and waits; asserts nothing but
/// information was reported before the wait, and returns the errors and
/// warnings reported at it.
fn findings_at_completion(chain: &Chain, record: impl FnOnce(vk::CommandBuffer)) -> Vec<Received> {
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    record(command_buffer);
    chain.end(command_buffer);
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    let early = findings(chain);
    assert!(early.is_empty(), "{early:#?}");
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    findings(chain)
}

/// What [`ids_at`] gives for the faulty instance (11580 at its flags), or
/// its valid twin (nothing).
fn expected_11580(faulty: bool) -> Vec<(&'static str, bool)> {
    if faulty {
        vec![(INSTANCE_FLAGS_11580, true)]
    } else {
        Vec::new()
    }
}

/// The ids of `findings`, each with whether it names the instance's flags.
fn ids_at(findings: &[Received]) -> Vec<(&str, bool)> {
    findings
        .iter()
        .map(|m| {
            let at = m
                .text
                .contains("pInfos[0].pGeometries[0].geometry.instances.data[0].flags");
            (m.id.as_str(), at)
        })
        .collect()
}

/// An indirect top-level build whose one instance (device-local, written
/// by a shader) carries an opacity-micromap flag without the micromap
/// feature: its range info, in device-local memory or mapped, is read,
/// the instances read back, and 11580 reported at completion naming the
/// instance's flags; the valid twin is silent.
#[test]
fn an_indirect_top_level_builds_instance_flags_are_checked_at_completion() {
    for mapped_ranges in [false, true] {
        for faulty in [true, false] {
            let (chain, info) = chain_with(true, false);
            let instances = input(&chain, 64);
            let bytes = instance(faulty);
            let range = range_info_bytes(1, 0);
            let usage = READ_BY_ADDRESS;
            let mut writes: Vec<(vk::Buffer, &[u8])> = vec![(instances, &bytes)];
            let ranges = if mapped_ranges {
                chain.mapped_buffer_holding(&range, usage)
            } else {
                let ranges = chain.buffer(16, usage, 0);
                writes.push((ranges, &range));
                ranges
            };
            let found = findings_at_completion(&chain, |command_buffer| {
                shader_writes(&chain, command_buffer, &writes);
                let data = chain.address(instances);
                let at = Some(chain.address(ranges));
                record_top_level_as(&chain, command_buffer, data, false, at);
            });
            assert_eq!(
                ids_at(&found),
                expected_11580(faulty),
                "mapped ranges {mapped_ranges}: {found:#?}"
            );
            if faulty {
                assert!(found[0]
                    .text
                    .contains("vkCmdBuildAccelerationStructuresIndirectKHR"));
                assert!(found[0].text.contains("Read back from device memory"));
            }
            let said = info.take();
            assert!(not_checked(&said).is_empty(), "{said:#?}");
        }
    }
}

/// An array of instance pointers in memory the application keeps mapped,
/// pointing to an instance in device-local memory a shader writes: the
/// layer reads the pointers at recording, reads the instance back, and
/// reports its flags at completion; the valid twin is silent.
#[test]
fn instances_behind_a_mapped_array_of_pointers_are_read_back_and_checked() {
    for faulty in [true, false] {
        let (chain, info) = chain_with(true, false);
        let instances = input(&chain, 64);
        let usage = READ_BY_ADDRESS;
        let pointer = chain.address(instances).to_le_bytes();
        let pointers = chain.mapped_buffer_holding(&pointer, usage);
        let bytes = instance(faulty);
        let found = findings_at_completion(&chain, |command_buffer| {
            shader_writes(&chain, command_buffer, &[(instances, &bytes)]);
            record_top_level(&chain, command_buffer, chain.address(pointers), true);
        });
        assert_eq!(ids_at(&found), expected_11580(faulty), "{found:#?}");
        let said = info.take();
        assert!(not_checked(&said).is_empty(), "{said:#?}");
    }
}

/// Readback off, the array of pointers uploaded into device-local memory
/// with vkCmdUpdateBuffer (not known at recording, which says so), the
/// instance in mapped memory: at submission the layer follows the pointers
/// the transfer wrote into the mapped instance and reports its flag there;
/// the valid twin is silent.
#[test]
fn instances_behind_uploaded_pointers_are_checked_at_submission() {
    for faulty in [true, false] {
        let (chain, info) = chain_with(false, false);
        let usage = READ_BY_ADDRESS | vk::BufferUsageFlags::TRANSFER_DST;
        let instances = chain.mapped_buffer_holding(&instance(faulty), usage);
        let pointers = chain.buffer(8, usage, 0);
        let pointer = chain.address(instances).to_le_bytes();
        let command_buffer = chain.allocate_command_buffer();
        chain.begin(command_buffer);
        let update: vk::PFN_vkCmdUpdateBuffer = device_fn(chain.device, c"vkCmdUpdateBuffer");
        // SAFETY: 8 bytes at a valid pointer.
        unsafe { update(command_buffer, pointers, 0, 8, pointer.as_ptr().cast()) };
        record_top_level(&chain, command_buffer, chain.address(pointers), true);
        chain.end(command_buffer);
        let at_recording = info.take();
        assert_eq!(not_checked(&at_recording).len(), 1, "{at_recording:#?}");
        assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
        let found = findings(&chain);
        assert_eq!(ids_at(&found), expected_11580(faulty), "{found:#?}");
        let later = info.take();
        assert!(not_checked(&later).is_empty(), "{later:#?}");
    }
}
