//! Device builds whose inputs lie in DEVICE_LOCAL memory the application
//! never maps (issue 14), through the in-process chain over the fake
//! driver, whose GPU holds real bytes and executes transfers at submission
//! (see `fake/gpu.rs`).
//!
//! A micromap build (`vkCmdBuildMicromapsEXT`) and a bottom-level build
//! that attaches it (`VkAccelerationStructureTrianglesOpacityMicromapEXT`)
//! read a triangle array, micromap data and opacity indices, each in a
//! device-local buffer of its own. They get their contents two ways:
//! - route 1: copied from a mapped staging buffer (`vkCmdCopyBuffer`,
//!   `vkCmdCopyBuffer2(KHR)`, `vkCmdUpdateBuffer`, `vkCmdFillBuffer`),
//!   with `gpu_readback` off: findings at `vkQueueSubmit`;
//! - route 2: written by a "shader" (the fake's `vkCmdDispatch` performs
//!   writes the test registered), with `gpu_readback` on: the layer
//!   inserts a barrier, copies into its own host-visible memory and a
//!   barrier before each build, and findings come once the submission is
//!   known complete (`vkWaitForFences`, `vkGetFenceStatus`,
//!   `vkQueueWaitIdle`, `vkDeviceWaitIdle`, `vkWaitSemaphores`,
//!   `vkGetSemaphoreCounterValue`).
//!
//! The behaviour tested is the layer contract of issue 14, which the layer
//! does not implement yet: until it does, the route tests fail because the
//! layer reports `OMMCHECK-layer-contents-not-checked` at submission
//! instead of the findings, and inserts nothing. The tests of the fake
//! GPU and of today's mapped route pass.
//!
//! Each content rule has a faulty scene and a valid twin. What each faulty
//! scene must report is what the same contents report today from mapped
//! host-visible memory (checked here too), so both routes are held to the
//! route that works.
//!
//! Settings go through VK_EXT_layer_settings, per instance, so tests
//! running in parallel in this process do not share the environment.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::ffi::CStr;

use ash::vk;
use ash::vk::Handle as _;
use fake::app::{range_info_bytes, record_micromap_build, AttachmentBuild};
use fake::gpu::{device_bytes, fake_gpu_write, memory_bytes, memory_type_of};
use fake::{
    add_messenger, all_calls, device_fn, device_micromap_build, Call, Chain, Collector, TRIANGLES,
    USAGE,
};

const DATA_IN_RANGE: &str = "OMMCHECK-build-triangle-data-in-range";
const USAGE_MATCHES_TRIANGLES: &str = "OMMCHECK-build-usage-counts-match-triangles";
const INDEX_IN_RANGE: &str = "OMMCHECK-attach-index-in-range";
const USAGE_MATCHES_INDICES: &str = "OMMCHECK-attach-usage-counts-match-indices";
const NULL_MICROMAP_SPECIAL_ONLY: &str = "OMMCHECK-attach-null-micromap-special-only";
const CLUSTER_INDEX_OUTSIDE_CLUSTER: &str = "OMMCHECK-attach-cluster-index-outside-cluster";
const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";

/// The micromap data buffer's size: a triangle whose data starts here runs
/// past its end.
const DATA_SIZE: u32 = 16;
/// Where the staging buffer holds each input.
const STAGED_TRIANGLES: u64 = 0;
const STAGED_DATA: u64 = 16;
const STAGED_INDICES: u64 = 32;
const STAGING_SIZE: u64 = 64;

/// The special opacity indices (VkOpacityMicromapSpecialIndexEXT).
const FULLY_TRANSPARENT: u32 = u32::MAX;
const FULLY_OPAQUE: u32 = u32::MAX - 1;
/// -5, an index only cluster geometry may use.
const CLUSTER_ONLY: u32 = u32::MAX - 4;

/// What the builds read from device memory, and the attachment's own
/// parameters that decide what those bytes must say.
#[derive(Clone, Debug)]
struct Contents {
    triangles: [vk::MicromapTriangleEXT; 2],
    indices: [u32; 2],
    attachment_usage: Vec<vk::MicromapUsageEXT>,
    /// Whether the attachment names the micromap (else VK_NULL_HANDLE).
    attaches_micromap: bool,
}

impl Contents {
    fn valid() -> Self {
        Self {
            triangles: TRIANGLES,
            indices: [0, 1],
            attachment_usage: USAGE.to_vec(),
            attaches_micromap: true,
        }
    }

    fn triangle_bytes(&self) -> Vec<u8> {
        self.triangles
            .iter()
            .flat_map(|t| {
                let mut entry = t.data_offset.to_le_bytes().to_vec();
                entry.extend(t.subdivision_level.to_le_bytes());
                entry.extend(t.format.to_le_bytes());
                entry
            })
            .collect()
    }

    /// Every data byte set, so a read past the data shows as such.
    fn data_bytes(&self) -> Vec<u8> {
        vec![0xA5; DATA_SIZE as usize]
    }

    fn index_bytes(&self) -> Vec<u8> {
        self.indices.iter().flat_map(|i| i.to_le_bytes()).collect()
    }
}

/// The content rules, each with a faulty scene and a valid twin.
#[derive(Clone, Copy, Debug)]
enum Rule {
    /// Micromap data past the end of the data buffer.
    DataPastEnd,
    /// The build's usage-count histogram against the triangle array.
    HistogramMismatch,
    /// An opacity index past the micromap's triangles.
    IndexPastMicromap,
    /// The attachment's usage counts against the triangles its indices
    /// select (after indirection).
    UsageAfterIndirection,
    /// A NULL micromap with indices that are not special.
    NullMicromapSpecialOnly,
    /// A special index only cluster geometry may use.
    ClusterOnlyIndex,
}

impl Rule {
    const ALL: [Rule; 6] = [
        Rule::DataPastEnd,
        Rule::HistogramMismatch,
        Rule::IndexPastMicromap,
        Rule::UsageAfterIndirection,
        Rule::NullMicromapSpecialOnly,
        Rule::ClusterOnlyIndex,
    ];

    /// What the faulty scene reports, as the core reports it from mapped
    /// memory (`mapped_inputs_report_every_content_rule_at_submission`).
    fn expected(self) -> Vec<&'static str> {
        match self {
            Rule::DataPastEnd => vec![DATA_IN_RANGE],
            // One: the level-1 count that is the level-2 triangle's, with
            // a hint, the other level's mismatch folded into it.
            Rule::HistogramMismatch => vec![USAGE_MATCHES_TRIANGLES],
            Rule::IndexPastMicromap => vec![INDEX_IN_RANGE],
            Rule::UsageAfterIndirection => vec![USAGE_MATCHES_INDICES],
            // One per index that is not special.
            Rule::NullMicromapSpecialOnly => vec![NULL_MICROMAP_SPECIAL_ONLY; 2],
            Rule::ClusterOnlyIndex => vec![CLUSTER_INDEX_OUTSIDE_CLUSTER],
        }
    }

    /// The contents that break the rule, or (`faulty` false) its valid twin.
    fn contents(self, faulty: bool) -> Contents {
        let mut c = Contents::valid();
        match self {
            // The last data byte is in range; one past it is not.
            Rule::DataPastEnd => {
                c.triangles[1].data_offset = if faulty { DATA_SIZE } else { DATA_SIZE - 1 };
            }
            // A level-2 triangle where the build's usage counts say two
            // level-1; the attachment counts what its indices select.
            Rule::HistogramMismatch => {
                if faulty {
                    c.triangles[1].subdivision_level = 2;
                    c.attachment_usage = vec![
                        vk::MicromapUsageEXT {
                            count: 1,
                            subdivision_level: 1,
                            format: 1,
                        },
                        vk::MicromapUsageEXT {
                            count: 1,
                            subdivision_level: 2,
                            format: 1,
                        },
                    ];
                }
            }
            Rule::IndexPastMicromap => c.indices[1] = if faulty { 2 } else { 1 },
            // Special indices select no micromap triangle, yet the usage
            // counts say two; the twin selects the two it counts.
            Rule::UsageAfterIndirection => {
                if faulty {
                    c.indices = [FULLY_TRANSPARENT, FULLY_OPAQUE];
                }
            }
            Rule::NullMicromapSpecialOnly => {
                c.attaches_micromap = false;
                c.attachment_usage.clear();
                if !faulty {
                    c.indices = [FULLY_TRANSPARENT, FULLY_OPAQUE];
                }
            }
            Rule::ClusterOnlyIndex => {
                if faulty {
                    c.indices[1] = CLUSTER_ONLY;
                }
            }
        }
        c
    }
}

/// The chain and its messages: errors and warnings in `chain.collector`,
/// information in `info`.
struct App {
    chain: Chain,
    info: Box<Collector>,
}

impl App {
    /// Every severity reported, no duplicate limit, `gpu_readback` as
    /// given, and `extra` settings.
    fn new(readback: bool, extra: &[(&CStr, &CStr)]) -> Self {
        let mut settings: Vec<(&CStr, &CStr)> = vec![
            (c"report_flags", c"error,warning,info"),
            (c"duplicate_message_limit", c"0"),
            (c"gpu_readback", if readback { c"true" } else { c"false" }),
        ];
        settings.extend_from_slice(extra);
        let chain = Chain::with_settings(&settings);
        let info = Box::<Collector>::default();
        add_messenger(
            chain.instance,
            vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            &info,
        );
        Self { chain, info }
    }

    /// The ids reported since the last call, errors and warnings first.
    fn reported(&self) -> Vec<String> {
        let mut ids: Vec<String> = self
            .chain
            .collector
            .take()
            .into_iter()
            .map(|r| r.id)
            .collect();
        ids.extend(self.info.take().into_iter().map(|r| r.id));
        ids
    }

    /// The warnings since the last call, each asserted to be a warning
    /// that contents were not checked (the layer's, at the default report
    /// level) and information and errors asserted absent.
    fn not_checked_only(&self) -> Vec<fake::Received> {
        let info = self.info.take();
        assert!(info.is_empty(), "{info:#?}");
        let warnings = self.chain.collector.take();
        for warning in &warnings {
            assert_eq!(
                (warning.id.as_str(), warning.severity),
                (
                    CONTENTS_NOT_CHECKED,
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                ),
                "{warning:#?}"
            );
        }
        warnings
    }

    fn f<F: Copy>(&self, name: &CStr) -> F {
        device_fn(self.chain.device, name)
    }
}

/// The micromap, the structure that attaches it, and the three input
/// buffers, each bound to memory of its own.
struct Scene {
    micromap: vk::MicromapEXT,
    blas: vk::AccelerationStructureKHR,
    triangles: vk::Buffer,
    data: vk::Buffer,
    indices: vk::Buffer,
    /// The inputs' memory, as the application allocated it.
    input_memory: [vk::DeviceMemory; 3],
    vertices: u64,
    scratch: u64,
    /// Where the bottom-level build's range info is, when it is recorded
    /// with vkCmdBuildAccelerationStructuresIndirectKHR.
    indirect_ranges: Option<u64>,
}

impl Scene {
    /// The scene with its inputs in memory of `memory_type` (0:
    /// device-local, never mapped; 1: host-visible).
    fn new(chain: &Chain, memory_type: u32) -> Self {
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
        let micromap = chain.micromap(storage, 4096);
        let usage = vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::STORAGE_BUFFER;
        let (triangles, triangle_memory) = chain.buffer_and_memory(16, usage, memory_type);
        let (data, data_memory) = chain.buffer_and_memory(u64::from(DATA_SIZE), usage, memory_type);
        let (indices, index_memory) = chain.buffer_and_memory(8, usage, memory_type);
        let address_usage =
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        Self {
            micromap,
            blas: AttachmentBuild::structure(chain),
            triangles,
            data,
            indices,
            input_memory: [triangle_memory, data_memory, index_memory],
            vertices: chain.address(chain.buffer(4096, usage, 0)),
            scratch: chain.address(chain.buffer(1 << 16, address_usage, 0)),
            indirect_ranges: None,
        }
    }

    /// The inputs' buffers with the bytes `contents` puts in each.
    fn inputs(&self, contents: &Contents) -> [(vk::Buffer, Vec<u8>); 3] {
        [
            (self.triangles, contents.triangle_bytes()),
            (self.data, contents.data_bytes()),
            (self.indices, contents.index_bytes()),
        ]
    }

    /// Records the micromap build and the bottom-level build attaching it.
    fn record_builds(&self, chain: &Chain, command_buffer: vk::CommandBuffer, contents: &Contents) {
        let info = device_micromap_build(
            self.micromap,
            &USAGE,
            chain.address(self.triangles),
            chain.address(self.data),
            self.scratch,
        );
        record_micromap_build(chain, command_buffer, &info);
        let attachment = AttachmentBuild {
            blas: self.blas,
            vertices: self.vertices,
            scratch: self.scratch,
            indices: chain.address(self.indices),
            usage_counts: &contents.attachment_usage,
            micromap: if contents.attaches_micromap {
                self.micromap
            } else {
                vk::MicromapEXT::null()
            },
        };
        match self.indirect_ranges {
            Some(ranges) => attachment.record_indirect(chain, command_buffer, ranges),
            None => attachment.record(chain, command_buffer),
        }
    }

    /// The bytes the application's input memory holds now.
    fn input_bytes(&self) -> Vec<Vec<u8>> {
        self.input_memory.iter().map(|&m| memory_bytes(m)).collect()
    }
}

/// How route 1 puts the contents in device-local memory.
#[derive(Clone, Copy, Debug)]
enum Upload {
    CopyBuffer,
    CopyBuffer2,
    /// The same command by its VK_KHR_copy_commands2 name, which the layer
    /// must follow too.
    CopyBuffer2KHR,
    UpdateBuffer,
}

impl Upload {
    const ALL: [Upload; 4] = [
        Upload::CopyBuffer,
        Upload::CopyBuffer2,
        Upload::CopyBuffer2KHR,
        Upload::UpdateBuffer,
    ];
}

/// A host-visible staging buffer the application maps, and its mapping.
struct Staging {
    buffer: vk::Buffer,
    mapped: *mut u8,
}

impl Staging {
    fn new(chain: &Chain) -> Self {
        let usage = vk::BufferUsageFlags::TRANSFER_SRC;
        let (buffer, memory) = chain.buffer_and_memory(STAGING_SIZE, usage, 1);
        Self {
            buffer,
            mapped: chain.map_backing(memory),
        }
    }

    /// Writes `contents` where [`STAGED_TRIANGLES`] and the others say.
    fn write(&self, scene: &Scene, contents: &Contents) {
        let at = [STAGED_TRIANGLES, STAGED_DATA, STAGED_INDICES];
        for ((_, bytes), offset) in scene.inputs(contents).iter().zip(at) {
            // SAFETY: inside the 64-byte mapping.
            unsafe {
                self.mapped
                    .add(offset as usize)
                    .copy_from_nonoverlapping(bytes.as_ptr(), bytes.len())
            };
        }
    }

    /// Records vkCmdCopyBuffer of each input from where [`Staging::write`]
    /// puts it.
    fn record_copies(&self, app: &App, scene: &Scene, command_buffer: vk::CommandBuffer) {
        record_inputs(
            app,
            scene,
            self,
            command_buffer,
            Upload::CopyBuffer,
            &Contents::valid(),
        );
    }
}

/// Records each input's upload by `upload`, without a barrier: a copy
/// from where [`Staging::write`] puts it (whose bytes the application
/// writes after recording, as the GPU sees them at submission), or an
/// inline update of `contents`.
fn record_inputs(
    app: &App,
    scene: &Scene,
    staging: &Staging,
    command_buffer: vk::CommandBuffer,
    upload: Upload,
    contents: &Contents,
) {
    let at = [STAGED_TRIANGLES, STAGED_DATA, STAGED_INDICES];
    for ((dst, bytes), src_offset) in scene.inputs(contents).into_iter().zip(at) {
        let size = bytes.len() as u64;
        match upload {
            Upload::CopyBuffer => {
                let copy: vk::PFN_vkCmdCopyBuffer = app.f(c"vkCmdCopyBuffer");
                let region = vk::BufferCopy {
                    src_offset,
                    dst_offset: 0,
                    size,
                };
                // SAFETY: one region.
                unsafe { copy(command_buffer, staging.buffer, dst, 1, &region) };
            }
            Upload::CopyBuffer2 | Upload::CopyBuffer2KHR => {
                let name = if let Upload::CopyBuffer2 = upload {
                    c"vkCmdCopyBuffer2"
                } else {
                    c"vkCmdCopyBuffer2KHR"
                };
                let copy: vk::PFN_vkCmdCopyBuffer2 = app.f(name);
                let regions = [vk::BufferCopy2::default().src_offset(src_offset).size(size)];
                let info = vk::CopyBufferInfo2::default()
                    .src_buffer(staging.buffer)
                    .dst_buffer(dst)
                    .regions(&regions);
                // SAFETY: valid pointers.
                unsafe { copy(command_buffer, &info) };
            }
            Upload::UpdateBuffer => {
                let update: vk::PFN_vkCmdUpdateBuffer = app.f(c"vkCmdUpdateBuffer");
                // SAFETY: `bytes` holds the size given.
                unsafe { update(command_buffer, dst, 0, size, bytes.as_ptr().cast()) };
            }
        }
    }
}

/// [`record_inputs`], then the barrier to the builds.
fn record_upload(
    app: &App,
    scene: &Scene,
    staging: &Staging,
    command_buffer: vk::CommandBuffer,
    upload: Upload,
    contents: &Contents,
) {
    record_inputs(app, scene, staging, command_buffer, upload, contents);
    transfer_to_build_barrier(app, command_buffer);
}

/// The application's barrier from its writes (transfer and compute) to
/// the builds' reads.
fn transfer_to_build_barrier(app: &App, command_buffer: vk::CommandBuffer) {
    let barrier: vk::PFN_vkCmdPipelineBarrier2 = app.f(c"vkCmdPipelineBarrier2");
    let memory = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COPY | vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(
            vk::PipelineStageFlags2::MICROMAP_BUILD_EXT
                | vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR,
        )
        .dst_access_mask(vk::AccessFlags2::SHADER_READ)];
    let info = vk::DependencyInfo::default().memory_barriers(&memory);
    // SAFETY: valid pointers.
    unsafe { barrier(command_buffer, &info) };
}

/// Records route 2's writes: the fake "shader" of one vkCmdDispatch
/// writes `contents` into the inputs, then a barrier to the builds.
fn record_shader_writes(
    app: &App,
    scene: &Scene,
    command_buffer: vk::CommandBuffer,
    contents: &Contents,
) {
    for (buffer, bytes) in scene.inputs(contents) {
        fake_gpu_write(command_buffer, buffer, 0, &bytes);
    }
    let dispatch: vk::PFN_vkCmdDispatch = app.f(c"vkCmdDispatch");
    // SAFETY: a recording command buffer.
    unsafe { dispatch(command_buffer, 1, 1, 1) };
    transfer_to_build_barrier(app, command_buffer);
}

/// How route 2 learns the submission is complete.
#[derive(Clone, Copy, Debug)]
enum Completion {
    WaitForFences,
    GetFenceStatus,
    QueueWaitIdle,
    DeviceWaitIdle,
    /// vkWaitSemaphores on a timeline semaphore vkQueueSubmit signals
    /// through VkTimelineSemaphoreSubmitInfo.
    WaitSemaphores,
    /// vkWaitSemaphores on one vkQueueSubmit2 signals.
    WaitSemaphoresAfterSubmit2,
    /// vkGetSemaphoreCounterValue reading the value vkQueueSubmit signals.
    GetSemaphoreCounterValue,
}

impl Completion {
    const ALL: [Completion; 7] = [
        Completion::WaitForFences,
        Completion::GetFenceStatus,
        Completion::QueueWaitIdle,
        Completion::DeviceWaitIdle,
        Completion::WaitSemaphores,
        Completion::WaitSemaphoresAfterSubmit2,
        Completion::GetSemaphoreCounterValue,
    ];
}

/// Submits `command_buffer` as `completion` needs; returns what completes it.
fn submit_for(
    app: &App,
    command_buffer: vk::CommandBuffer,
    completion: Completion,
) -> Box<dyn Fn()> {
    let chain = &app.chain;
    let device = chain.device;
    let queue = chain.queue();
    match completion {
        Completion::WaitForFences | Completion::GetFenceStatus => {
            let fence = chain.fence();
            assert_eq!(
                chain.submit_with(command_buffer, fence),
                vk::Result::SUCCESS
            );
            let wait: vk::PFN_vkWaitForFences = app.f(c"vkWaitForFences");
            let status: vk::PFN_vkGetFenceStatus = app.f(c"vkGetFenceStatus");
            Box::new(move || {
                // SAFETY: one fence of this device.
                let result = unsafe {
                    match completion {
                        Completion::WaitForFences => wait(device, 1, &fence, vk::TRUE, u64::MAX),
                        _ => status(device, fence),
                    }
                };
                assert_eq!(result, vk::Result::SUCCESS);
            })
        }
        Completion::QueueWaitIdle => {
            assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
            let wait: vk::PFN_vkQueueWaitIdle = app.f(c"vkQueueWaitIdle");
            // SAFETY: the device's queue.
            Box::new(move || assert_eq!(unsafe { wait(queue) }, vk::Result::SUCCESS))
        }
        Completion::DeviceWaitIdle => {
            assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
            let wait: vk::PFN_vkDeviceWaitIdle = app.f(c"vkDeviceWaitIdle");
            // SAFETY: the device.
            Box::new(move || assert_eq!(unsafe { wait(device) }, vk::Result::SUCCESS))
        }
        Completion::WaitSemaphores
        | Completion::WaitSemaphoresAfterSubmit2
        | Completion::GetSemaphoreCounterValue => {
            let semaphore = chain.timeline(0);
            let command_buffers = [command_buffer];
            let signals = [semaphore];
            let values = [1u64];
            let result = if let Completion::WaitSemaphores | Completion::GetSemaphoreCounterValue =
                completion
            {
                let submit: vk::PFN_vkQueueSubmit = app.f(c"vkQueueSubmit");
                let mut timeline =
                    vk::TimelineSemaphoreSubmitInfo::default().signal_semaphore_values(&values);
                let info = vk::SubmitInfo::default()
                    .command_buffers(&command_buffers)
                    .signal_semaphores(&signals)
                    .push_next(&mut timeline);
                // SAFETY: valid pointers.
                unsafe { submit(queue, 1, &info, vk::Fence::null()) }
            } else {
                let submit: vk::PFN_vkQueueSubmit2 = app.f(c"vkQueueSubmit2");
                let infos = [vk::CommandBufferSubmitInfo::default().command_buffer(command_buffer)];
                let signal = [vk::SemaphoreSubmitInfo::default()
                    .semaphore(semaphore)
                    .value(1)];
                let info = vk::SubmitInfo2::default()
                    .command_buffer_infos(&infos)
                    .signal_semaphore_infos(&signal);
                // SAFETY: valid pointers.
                unsafe { submit(queue, 1, &info, vk::Fence::null()) }
            };
            assert_eq!(result, vk::Result::SUCCESS);
            let wait: vk::PFN_vkWaitSemaphores = app.f(c"vkWaitSemaphores");
            let counter: vk::PFN_vkGetSemaphoreCounterValue = app.f(c"vkGetSemaphoreCounterValue");
            if let Completion::GetSemaphoreCounterValue = completion {
                return Box::new(move || {
                    let mut value = 0;
                    // SAFETY: a timeline semaphore of the device.
                    let result = unsafe { counter(device, semaphore, &mut value) };
                    assert_eq!((result, value), (vk::Result::SUCCESS, 1));
                });
            }
            Box::new(move || {
                let info = vk::SemaphoreWaitInfo::default()
                    .semaphores(&signals)
                    .values(&values);
                // SAFETY: valid pointers.
                assert_eq!(
                    unsafe { wait(device, &info, u64::MAX) },
                    vk::Result::SUCCESS
                );
            })
        }
    }
}

/// How the inputs get their contents.
#[derive(Clone, Copy, Debug)]
enum Route {
    /// Route 1: uploaded by transfer commands.
    Upload(Upload),
    /// Route 2: written by the fake shader.
    Shader,
}

/// The application: the chain, the scene in device-local memory, and a
/// staging buffer.
struct Setup {
    app: App,
    scene: Scene,
    staging: Staging,
    /// A buffer and the bytes written into it before the inputs (an
    /// indirect build's range info in device-local memory), by the fake
    /// shader or (`RangesIn::Updated`) vkCmdUpdateBuffer.
    pending_range_write: Option<(vk::Buffer, Vec<u8>, RangesIn)>,
}

impl Setup {
    fn new(readback: bool, extra: &[(&CStr, &CStr)]) -> Self {
        let app = App::new(readback, extra);
        let scene = Scene::new(&app.chain, 0);
        let staging = Staging::new(&app.chain);
        Self {
            app,
            scene,
            staging,
            pending_range_write: None,
        }
    }

    fn chain(&self) -> &Chain {
        &self.app.chain
    }

    /// Records `route`'s writes of `contents` into the inputs, then the
    /// builds. Staged bytes are written after recording: what the GPU sees
    /// is the mapped memory as it is at submission.
    fn record(&self, command_buffer: vk::CommandBuffer, route: Route, contents: &Contents) {
        let (app, scene) = (&self.app, &self.scene);
        match &self.pending_range_write {
            Some((buffer, bytes, RangesIn::Updated)) => {
                let update: vk::PFN_vkCmdUpdateBuffer = app.f(c"vkCmdUpdateBuffer");
                let size = bytes.len() as u64;
                // SAFETY: `bytes` holds the size given.
                unsafe { update(command_buffer, *buffer, 0, size, bytes.as_ptr().cast()) };
            }
            Some((buffer, bytes, _)) => {
                fake_gpu_write(command_buffer, *buffer, 0, bytes);
                let dispatch: vk::PFN_vkCmdDispatch = app.f(c"vkCmdDispatch");
                // SAFETY: a recording command buffer.
                unsafe { dispatch(command_buffer, 1, 1, 1) };
            }
            None => {}
        }
        match route {
            Route::Upload(upload) => {
                record_upload(app, scene, &self.staging, command_buffer, upload, contents);
            }
            Route::Shader => record_shader_writes(app, scene, command_buffer, contents),
        }
        scene.record_builds(self.chain(), command_buffer, contents);
        self.staging.write(scene, contents);
    }

    /// A primary command buffer holding [`Setup::record`], ended; asserts
    /// nothing was reported while recording (contents are not known yet).
    fn recorded(&self, route: Route, contents: &Contents) -> vk::CommandBuffer {
        let chain = self.chain();
        let command_buffer = chain.allocate_command_buffer();
        chain.begin(command_buffer);
        self.record(command_buffer, route, contents);
        chain.end(command_buffer);
        assert_eq!(self.app.reported(), Vec::<String>::new(), "at recording");
        command_buffer
    }

    /// Submits `command_buffer` with a fence and waits for it: what was
    /// reported at submission, and at completion.
    fn submit_and_wait(&self, command_buffer: vk::CommandBuffer) -> Reported {
        let chain = self.chain();
        let fence = chain.fence();
        assert_eq!(
            chain.submit_with(command_buffer, fence),
            vk::Result::SUCCESS
        );
        let at_submission = self.app.reported();
        assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
        let at_completion = self.app.reported();
        assert_eq!(fake::gpu::faults(), Vec::<String>::new());
        Reported {
            at_submission,
            at_completion,
        }
    }

    /// Records the valid contents' upload from staging, then `overwrite`
    /// (more transfers into the inputs), the barrier, and the builds of
    /// `contents`, what the inputs hold once all of it ran; submits it and
    /// returns what was reported at submission.
    fn submit_staged_then(
        &self,
        contents: &Contents,
        overwrite: impl FnOnce(vk::CommandBuffer),
    ) -> Vec<String> {
        let chain = self.chain();
        let command_buffer = chain.allocate_command_buffer();
        chain.begin(command_buffer);
        self.staging
            .record_copies(&self.app, &self.scene, command_buffer);
        overwrite(command_buffer);
        transfer_to_build_barrier(&self.app, command_buffer);
        self.scene.record_builds(chain, command_buffer, contents);
        chain.end(command_buffer);
        self.staging.write(&self.scene, &Contents::valid());
        assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
        self.assert_inputs_hold(contents);
        sorted(self.app.reported())
    }

    /// Asserts the inputs hold `contents`: the fake GPU ran the writes.
    fn assert_inputs_hold(&self, contents: &Contents) {
        for (buffer, bytes) in self.scene.inputs(contents) {
            assert_eq!(device_bytes(buffer, 0, bytes.len() as u64), bytes);
        }
    }
}

/// What was reported: at submission, and at completion.
#[derive(Debug)]
struct Reported {
    at_submission: Vec<String>,
    at_completion: Vec<String>,
}

impl Reported {
    fn all(self) -> Vec<String> {
        sorted([self.at_submission, self.at_completion].concat())
    }
}

/// Route 1 for `rule`: uploaded contents, readback off.
fn route_1(rule: Rule, faulty: bool, upload: Upload) -> Reported {
    let setup = Setup::new(false, &[]);
    let contents = rule.contents(faulty);
    let command_buffer = setup.recorded(Route::Upload(upload), &contents);
    let reported = setup.submit_and_wait(command_buffer);
    setup.assert_inputs_hold(&contents);
    reported
}

/// Route 2 for `rule`: shader-written contents, readback on, completion
/// learnt through `completion`.
fn route_2(rule: Rule, faulty: bool, completion: Completion) -> Reported {
    let setup = Setup::new(true, &[]);
    let contents = rule.contents(faulty);
    let command_buffer = setup.recorded(Route::Shader, &contents);
    let complete = submit_for(&setup.app, command_buffer, completion);
    let at_submission = setup.app.reported();
    complete();
    let at_completion = setup.app.reported();
    setup.assert_inputs_hold(&contents);
    assert_eq!(fake::gpu::faults(), Vec::<String>::new());
    Reported {
        at_submission,
        at_completion,
    }
}

/// Runs every rule's faulty scene and valid twin each `way`: the faulty
/// scene must report the rule's findings, at completion where
/// `at_completion` (else at submission), and nothing anywhere else; the
/// twin nothing at all. Returns what went otherwise.
fn failures_over_every_rule<W: Copy + std::fmt::Debug>(
    ways: &[W],
    at_completion: bool,
    run: impl Fn(Rule, bool, W) -> Reported,
) -> Vec<String> {
    let mut failures = Vec::new();
    for rule in Rule::ALL {
        for &way in ways {
            let faulty = run(rule, true, way);
            let (when, elsewhere) = if at_completion {
                (&faulty.at_completion, &faulty.at_submission)
            } else {
                (&faulty.at_submission, &faulty.at_completion)
            };
            if sorted(when.clone()) != strings(&rule.expected()) || !elsewhere.is_empty() {
                failures.push(format!("{rule:?} {way:?}: {faulty:?}"));
            }
            let twin = run(rule, false, way);
            if !twin.at_submission.is_empty() || !twin.at_completion.is_empty() {
                failures.push(format!("{rule:?} {way:?} valid twin: {twin:?}"));
            }
        }
    }
    failures
}

fn sorted(mut ids: Vec<String>) -> Vec<String> {
    ids.sort_unstable();
    ids
}

fn strings(ids: &[&str]) -> Vec<String> {
    sorted(ids.iter().map(|s| (*s).to_owned()).collect())
}

// The fake GPU itself: what the tests below rely on.

#[test]
fn the_fake_gpu_executes_transfers_and_shader_writes_in_order_at_submission() {
    let app = App::new(false, &[]);
    let chain = &app.chain;
    let usage = vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
    let target = chain.buffer(64, usage, 0);
    let staging = Staging::new(chain);
    // SAFETY: inside the 64-byte mapping.
    unsafe {
        staging
            .mapped
            .copy_from_nonoverlapping([1u8, 2, 3, 4, 5, 6, 7, 8].as_ptr(), 8)
    };
    let primary = chain.allocate_command_buffer();
    let secondary =
        chain.command_buffer_from(chain.command_pool(), vk::CommandBufferLevel::SECONDARY);
    chain.begin(secondary);
    fake_gpu_write(secondary, target, 40, &[9, 9]);
    let dispatch: vk::PFN_vkCmdDispatch = app.f(c"vkCmdDispatch");
    // SAFETY: a recording command buffer.
    unsafe { dispatch(secondary, 1, 1, 1) };
    chain.end(secondary);
    chain.begin(primary);
    let copy: vk::PFN_vkCmdCopyBuffer = app.f(c"vkCmdCopyBuffer");
    let region = vk::BufferCopy {
        src_offset: 2,
        dst_offset: 0,
        size: 4,
    };
    // SAFETY: one region.
    unsafe { copy(primary, staging.buffer, target, 1, &region) };
    let copy2: vk::PFN_vkCmdCopyBuffer2 = app.f(c"vkCmdCopyBuffer2");
    let regions = [vk::BufferCopy2::default()
        .src_offset(0)
        .dst_offset(8)
        .size(2)];
    let info = vk::CopyBufferInfo2::default()
        .src_buffer(staging.buffer)
        .dst_buffer(target)
        .regions(&regions);
    // SAFETY: valid pointers.
    unsafe { copy2(primary, &info) };
    let fill: vk::PFN_vkCmdFillBuffer = app.f(c"vkCmdFillBuffer");
    // SAFETY: valid arguments.
    unsafe { fill(primary, target, 16, 8, 0xAABB_CCDD) };
    let update: vk::PFN_vkCmdUpdateBuffer = app.f(c"vkCmdUpdateBuffer");
    let words = [0x1111_2222u32];
    // SAFETY: 4 bytes at `words`.
    unsafe { update(primary, target, 32, 4, words.as_ptr().cast()) };
    transfer_to_build_barrier(&app, primary);
    // The fake logs what a barrier orders (the inserted-commands test reads it).
    let logged = fake::calls("vkCmdPipelineBarrier2");
    let barrier = dependency(logged.last().unwrap());
    assert_eq!(barrier.dst_access, vk::AccessFlags2::SHADER_READ);
    assert_eq!(
        barrier.src_access,
        vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::SHADER_STORAGE_WRITE
    );
    assert!(barrier
        .dst_stages
        .contains(vk::PipelineStageFlags2::MICROMAP_BUILD_EXT));
    let execute: vk::PFN_vkCmdExecuteCommands = app.f(c"vkCmdExecuteCommands");
    // SAFETY: one secondary.
    unsafe { execute(primary, 1, &secondary) };
    // A later copy over the fill wins: commands run in recording order.
    let over = vk::BufferCopy {
        src_offset: 0,
        dst_offset: 20,
        size: 1,
    };
    // SAFETY: one region.
    unsafe { copy(primary, staging.buffer, target, 1, &over) };
    chain.end(primary);
    assert_eq!(
        device_bytes(target, 0, 64),
        vec![0; 64],
        "executed before submission"
    );

    assert_eq!(chain.submit(primary), vk::Result::SUCCESS);
    let mut expected = vec![0u8; 64];
    expected[0..4].copy_from_slice(&[3, 4, 5, 6]);
    expected[8..10].copy_from_slice(&[1, 2]);
    expected[16..24].copy_from_slice(&[0xDD, 0xCC, 0xBB, 0xAA, 0xDD, 0xCC, 0xBB, 0xAA]);
    expected[20] = 1;
    expected[32..36].copy_from_slice(&0x1111_2222u32.to_le_bytes());
    expected[40..42].copy_from_slice(&[9, 9]);
    assert_eq!(device_bytes(target, 0, 64), expected);
    assert_eq!(fake::gpu::faults(), Vec::<String>::new());

    // Out of range is a fault, not a write.
    let beyond = vk::BufferCopy {
        src_offset: 0,
        dst_offset: 62,
        size: 4,
    };
    chain.begin(primary);
    // SAFETY: one region (out of range on purpose).
    unsafe { copy(primary, staging.buffer, target, 1, &beyond) };
    chain.end(primary);
    assert_eq!(chain.submit(primary), vk::Result::SUCCESS);
    assert_eq!(fake::gpu::faults().len(), 1);
    assert_eq!(device_bytes(target, 0, 64), expected);

    // So is a copy out of a buffer created without TRANSFER_SRC.
    let no_source = chain.buffer(64, vk::BufferUsageFlags::TRANSFER_DST, 0);
    chain.begin(primary);
    // SAFETY: one region (the usage is missing on purpose).
    unsafe { copy(primary, no_source, target, 1, &region) };
    chain.end(primary);
    assert_eq!(chain.submit(primary), vk::Result::SUCCESS);
    let faults = fake::gpu::faults();
    assert!(
        faults.len() == 1 && faults[0].contains("TRANSFER_SRC"),
        "{faults:?}"
    );
    assert_eq!(device_bytes(target, 0, 64), expected);
}

#[test]
fn the_fake_gpu_signals_fences_and_timeline_semaphores_at_submission() {
    let app = App::new(false, &[]);
    let chain = &app.chain;
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    chain.end(command_buffer);
    let fence = chain.fence();
    let status: vk::PFN_vkGetFenceStatus = app.f(c"vkGetFenceStatus");
    assert_eq!(chain.wait_for_fence(fence), vk::Result::TIMEOUT);
    // SAFETY: a fence of the device.
    assert_eq!(
        unsafe { status(chain.device, fence) },
        vk::Result::NOT_READY
    );
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    // SAFETY: as above.
    assert_eq!(unsafe { status(chain.device, fence) }, vk::Result::SUCCESS);
    let reset: vk::PFN_vkResetFences = app.f(c"vkResetFences");
    // SAFETY: one fence.
    assert_eq!(
        unsafe { reset(chain.device, 1, &fence) },
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::TIMEOUT);

    let semaphore = chain.timeline(3);
    let counter: vk::PFN_vkGetSemaphoreCounterValue = app.f(c"vkGetSemaphoreCounterValue");
    let value = || {
        let mut value = 0;
        // SAFETY: a timeline semaphore of the device.
        assert_eq!(
            unsafe { counter(chain.device, semaphore, &mut value) },
            vk::Result::SUCCESS
        );
        value
    };
    assert_eq!(value(), 3);
    assert_eq!(chain.wait_semaphore(semaphore, 7), vk::Result::TIMEOUT);
    let submit2: vk::PFN_vkQueueSubmit2 = app.f(c"vkQueueSubmit2");
    let infos = [vk::CommandBufferSubmitInfo::default().command_buffer(command_buffer)];
    let signal = [vk::SemaphoreSubmitInfo::default()
        .semaphore(semaphore)
        .value(7)];
    let info = vk::SubmitInfo2::default()
        .command_buffer_infos(&infos)
        .signal_semaphore_infos(&signal);
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { submit2(chain.queue(), 1, &info, vk::Fence::null()) },
        vk::Result::SUCCESS
    );
    assert_eq!(value(), 7);
    assert_eq!(chain.wait_semaphore(semaphore, 7), vk::Result::SUCCESS);
    assert_eq!(chain.queue(), chain.queue(), "one queue handle per index");

    let buffer = chain.buffer(100, vk::BufferUsageFlags::TRANSFER_DST, 1);
    let requirements: vk::PFN_vkGetBufferMemoryRequirements =
        app.f(c"vkGetBufferMemoryRequirements");
    let mut needed = vk::MemoryRequirements::default();
    // SAFETY: a buffer of the device.
    unsafe { requirements(chain.device, buffer, &mut needed) };
    assert_eq!(
        (needed.size, needed.alignment, needed.memory_type_bits),
        (256, 256, 0b11)
    );
}

#[test]
fn the_fake_gpu_forgets_what_reset_command_buffers_and_pools_recorded() {
    let app = App::new(false, &[]);
    let chain = &app.chain;
    let target = chain.buffer(16, vk::BufferUsageFlags::TRANSFER_DST, 0);
    let pool = chain.command_pool();
    let record_fill = |command_buffer| {
        chain.begin(command_buffer);
        let fill: vk::PFN_vkCmdFillBuffer = app.f(c"vkCmdFillBuffer");
        // SAFETY: valid arguments.
        unsafe { fill(command_buffer, target, 0, vk::WHOLE_SIZE, 0x0101_0101) };
        chain.end(command_buffer);
    };
    let reset: vk::PFN_vkResetCommandBuffer = app.f(c"vkResetCommandBuffer");
    let reset_pool: vk::PFN_vkResetCommandPool = app.f(c"vkResetCommandPool");
    let command_buffer = chain.command_buffer_from(pool, vk::CommandBufferLevel::PRIMARY);
    record_fill(command_buffer);
    // SAFETY: a command buffer not pending.
    assert_eq!(
        unsafe { reset(command_buffer, vk::CommandBufferResetFlags::empty()) },
        vk::Result::SUCCESS
    );
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    record_fill(command_buffer);
    // SAFETY: a pool none of whose command buffers is pending.
    assert_eq!(
        unsafe { reset_pool(chain.device, pool, vk::CommandPoolResetFlags::empty()) },
        vk::Result::SUCCESS
    );
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    assert_eq!(device_bytes(target, 0, 16), vec![0; 16]);
    record_fill(command_buffer);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    assert_eq!(device_bytes(target, 0, 16), vec![1; 16]);
}

// Today's route, the reference for both new ones.

/// What the builds report at submission when the inputs hold `contents`
/// in host-visible memory the application maps (today's route), sorted.
fn reported_from_mapped_memory(contents: &Contents) -> Vec<String> {
    let app = App::new(false, &[]);
    let chain = &app.chain;
    let scene = Scene::new(chain, 1);
    for (&memory, (_, bytes)) in scene.input_memory.iter().zip(scene.inputs(contents)) {
        let mapped = chain.map_backing(memory);
        // SAFETY: the buffer's whole memory is `bytes.len()` long.
        unsafe { mapped.copy_from_nonoverlapping(bytes.as_ptr(), bytes.len()) };
    }
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    scene.record_builds(chain, command_buffer, contents);
    chain.end(command_buffer);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    sorted(app.reported())
}

#[test]
fn mapped_inputs_report_every_content_rule_at_submission() {
    for rule in Rule::ALL {
        assert_eq!(
            reported_from_mapped_memory(&rule.contents(true)),
            strings(&rule.expected()),
            "{rule:?}"
        );
        assert_eq!(
            reported_from_mapped_memory(&rule.contents(false)),
            Vec::<String>::new(),
            "{rule:?} valid twin"
        );
    }
}

// Route 1: uploads, readback off, findings at submission.

#[test]
fn uploaded_inputs_report_every_content_rule_at_submission() {
    let failures = failures_over_every_rule(&Upload::ALL, false, route_1);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// vkCmdFillBuffer writes one repeated word into the opacity indices
/// after the valid ones are staged: all 2 (past the micromap), all -5
/// (cluster only), or all 0 (valid: both triangles select triangle 0,
/// whose level and format the usage counts count twice). Each reports
/// what the same indices report from mapped memory.
#[test]
fn filled_indices_report_at_submission() {
    for word in [2, CLUSTER_ONLY, 0] {
        let filled = Contents {
            indices: [word; 2],
            ..Contents::valid()
        };
        let expected = reported_from_mapped_memory(&filled);
        assert_eq!(expected.is_empty(), word == 0, "{expected:?}");
        let setup = Setup::new(false, &[]);
        let fill: vk::PFN_vkCmdFillBuffer = setup.app.f(c"vkCmdFillBuffer");
        let reported = setup.submit_staged_then(&filled, |command_buffer| {
            // SAFETY: valid arguments.
            unsafe { fill(command_buffer, setup.scene.indices, 0, vk::WHOLE_SIZE, word) };
        });
        assert_eq!(reported, expected, "indices filled with {word:#x}");
    }
}

/// Where the staging buffer holds the indices that reach their buffer
/// through an intermediate one.
const STAGED_HOP: u64 = 48;

/// The indices reach their buffer through a device-local intermediate:
/// staging to intermediate, intermediate to indices, after the valid
/// indices' own upload. The layer follows the second copy's source from
/// the first copy's shadow.
#[test]
fn inputs_copied_through_an_intermediate_device_local_buffer_are_checked_at_submission() {
    for (indices, expected) in [([0u32, 2], vec![INDEX_IN_RANGE]), ([0, 1], vec![])] {
        let setup = Setup::new(false, &[]);
        let chain = setup.chain();
        let usage = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
        let intermediate = chain.buffer(64, usage, 0);
        let hopped = Contents {
            indices,
            ..Contents::valid()
        };
        let hop_bytes = hopped.index_bytes();
        // SAFETY: inside the 64-byte mapping.
        unsafe {
            setup
                .staging
                .mapped
                .add(STAGED_HOP as usize)
                .copy_from_nonoverlapping(hop_bytes.as_ptr(), hop_bytes.len())
        };
        let copy: vk::PFN_vkCmdCopyBuffer = setup.app.f(c"vkCmdCopyBuffer");
        let hops = [
            (setup.staging.buffer, intermediate, STAGED_HOP, 24),
            (intermediate, setup.scene.indices, 24, 0),
        ];
        let reported = setup.submit_staged_then(&hopped, |command_buffer| {
            for (src, dst, src_offset, dst_offset) in hops {
                let region = vk::BufferCopy {
                    src_offset,
                    dst_offset,
                    size: 8,
                };
                // SAFETY: one region.
                unsafe { copy(command_buffer, src, dst, 1, &region) };
            }
        });
        assert_eq!(reported, strings(&expected), "{indices:?}");
    }
}

/// Uploads run in submission order: a valid copy recorded after a faulty
/// fill of the indices leaves nothing to report.
#[test]
fn a_later_upload_replaces_an_earlier_one() {
    let setup = Setup::new(false, &[]);
    let chain = setup.chain();
    let contents = Contents::valid();
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    let fill: vk::PFN_vkCmdFillBuffer = setup.app.f(c"vkCmdFillBuffer");
    // SAFETY: valid arguments.
    unsafe { fill(command_buffer, setup.scene.indices, 0, vk::WHOLE_SIZE, 2) };
    setup.record(command_buffer, Route::Upload(Upload::CopyBuffer), &contents);
    chain.end(command_buffer);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    setup.assert_inputs_hold(&contents);
    assert_eq!(setup.app.reported(), Vec::<String>::new());
}

/// The upload in one command buffer, the builds in another submitted after
/// it (in the same vkQueueSubmit, or a later one): the builds are checked
/// against what the earlier command buffer wrote, at the submission that
/// holds them.
#[test]
fn uploads_in_an_earlier_command_buffer_reach_a_later_build() {
    for same_submit in [true, false] {
        let setup = Setup::new(false, &[]);
        let chain = setup.chain();
        let faulty = Rule::IndexPastMicromap.contents(true);
        let upload = chain.allocate_command_buffer();
        chain.begin(upload);
        record_upload(
            &setup.app,
            &setup.scene,
            &setup.staging,
            upload,
            Upload::CopyBuffer,
            &faulty,
        );
        chain.end(upload);
        let build = chain.allocate_command_buffer();
        chain.begin(build);
        setup.scene.record_builds(chain, build, &faulty);
        chain.end(build);
        setup.staging.write(&setup.scene, &faulty);
        let reported = if same_submit {
            let submit: vk::PFN_vkQueueSubmit = setup.app.f(c"vkQueueSubmit");
            let command_buffers = [upload, build];
            let info = vk::SubmitInfo::default().command_buffers(&command_buffers);
            // SAFETY: valid pointers.
            let result = unsafe { submit(chain.queue(), 1, &info, vk::Fence::null()) };
            assert_eq!(result, vk::Result::SUCCESS);
            setup.app.reported()
        } else {
            assert_eq!(chain.submit(upload), vk::Result::SUCCESS);
            assert_eq!(setup.app.reported(), Vec::<String>::new(), "upload alone");
            assert_eq!(chain.submit(build), vk::Result::SUCCESS);
            setup.app.reported()
        };
        setup.assert_inputs_hold(&faulty);
        assert_eq!(
            reported,
            [INDEX_IN_RANGE],
            "same vkQueueSubmit: {same_submit}"
        );
    }
}

// Route 2: shader writes, readback on, findings on completion.

#[test]
fn shader_written_inputs_report_every_content_rule_on_completion() {
    let failures = failures_over_every_rule(&Completion::ALL, true, route_2);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Each finding is reported once, with the build's location and command
/// buffer and the words saying it was read from device memory after
/// execution; waiting again on the same completed work adds nothing.
#[test]
fn a_readback_finding_names_the_build_and_is_reported_once() {
    let setup = Setup::new(true, &[]);
    let chain = setup.chain();
    let contents = Rule::IndexPastMicromap.contents(true);
    let command_buffer = setup.recorded(Route::Shader, &contents);
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert_eq!(received.len(), 1, "{received:#?}");
    let finding = &received[0];
    assert_eq!(finding.id, INDEX_IN_RANGE);
    for words in [
        "vkCmdBuildAccelerationStructuresKHR(): pInfos[0].pGeometries[0]",
        "indexBuffer[1]",
        "device memory",
    ] {
        assert!(finding.text.contains(words), "{words}: {}", finding.text);
    }
    assert_eq!(
        finding.objects[0],
        (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw())
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    let wait_idle: vk::PFN_vkDeviceWaitIdle = setup.app.f(c"vkDeviceWaitIdle");
    // SAFETY: the device.
    assert_eq!(unsafe { wait_idle(chain.device) }, vk::Result::SUCCESS);
    assert_eq!(setup.app.reported(), Vec::<String>::new());
}

/// Readback on and the contents uploaded from staging: both routes could
/// apply. The readback is what executed, so the check at submission is
/// skipped and each finding arrives once, at completion.
#[test]
fn uploaded_inputs_with_readback_on_are_reported_once_at_completion() {
    let failures = failures_over_every_rule(&Upload::ALL, true, |rule, faulty, upload| {
        let setup = Setup::new(true, &[]);
        let contents = rule.contents(faulty);
        let command_buffer = setup.recorded(Route::Upload(upload), &contents);
        setup.submit_and_wait(command_buffer)
    });
    assert!(failures.is_empty(), "{failures:#?}");
}

/// One recording, submitted twice: each submission is read back and
/// checked; staged contents fixed between two submissions leave the second
/// one clean (the verdict follows what ran).
#[test]
fn a_command_buffer_submitted_twice_is_checked_twice() {
    let faulty = Rule::IndexPastMicromap.contents(true);
    let setup = Setup::new(true, &[]);
    let command_buffer = setup.recorded(Route::Shader, &faulty);
    for submission in 0..2 {
        let reported = setup.submit_and_wait(command_buffer);
        assert_eq!(reported.all(), [INDEX_IN_RANGE], "submission {submission}");
    }

    let setup = Setup::new(false, &[]);
    let command_buffer = setup.recorded(Route::Upload(Upload::CopyBuffer), &faulty);
    assert_eq!(
        setup.submit_and_wait(command_buffer).all(),
        [INDEX_IN_RANGE]
    );
    setup.staging.write(&setup.scene, &Contents::valid());
    assert_eq!(
        setup.submit_and_wait(command_buffer).all(),
        Vec::<String>::new()
    );
}

/// One recording begun with SIMULTANEOUS_USE, submitted twice before
/// either completes: both executions copy into the one readback the
/// recording holds, so the layer checks it once, when the later
/// submission is seen complete (checking at the first fence could read
/// bytes the second execution is still writing).
#[test]
fn a_simultaneous_use_command_buffer_pending_twice_is_checked_when_the_later_completes() {
    let setup = Setup::new(true, &[]);
    let chain = setup.chain();
    let faulty = Rule::IndexPastMicromap.contents(true);
    let command_buffer = chain.allocate_command_buffer();
    let begin: vk::PFN_vkBeginCommandBuffer = setup.app.f(c"vkBeginCommandBuffer");
    let info =
        vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::SIMULTANEOUS_USE);
    // SAFETY: valid arguments.
    assert_eq!(unsafe { begin(command_buffer, &info) }, vk::Result::SUCCESS);
    setup.record(command_buffer, Route::Shader, &faulty);
    chain.end(command_buffer);
    let fences = [chain.fence(), chain.fence()];
    for fence in fences {
        assert_eq!(
            chain.submit_with(command_buffer, fence),
            vk::Result::SUCCESS
        );
    }
    assert_eq!(setup.app.reported(), Vec::<String>::new(), "at submission");
    assert_eq!(chain.wait_for_fence(fences[0]), vk::Result::SUCCESS);
    assert_eq!(setup.app.reported(), Vec::<String>::new(), "first fence");
    assert_eq!(chain.wait_for_fence(fences[1]), vk::Result::SUCCESS);
    assert_eq!(setup.app.reported(), [INDEX_IN_RANGE], "second fence");
}

/// The writes and the builds recorded in a secondary command buffer, run
/// by vkCmdExecuteCommands: checked on completion (route 2) and at
/// submission (route 1).
#[test]
fn a_secondary_command_buffers_builds_are_checked() {
    for (readback, route) in [
        (true, Route::Shader),
        (false, Route::Upload(Upload::CopyBuffer)),
    ] {
        let setup = Setup::new(readback, &[]);
        let chain = setup.chain();
        let contents = Rule::IndexPastMicromap.contents(true);
        let pool = chain.command_pool();
        let secondary = chain.command_buffer_from(pool, vk::CommandBufferLevel::SECONDARY);
        let begin: vk::PFN_vkBeginCommandBuffer = setup.app.f(c"vkBeginCommandBuffer");
        let inheritance = vk::CommandBufferInheritanceInfo::default();
        let info = vk::CommandBufferBeginInfo::default().inheritance_info(&inheritance);
        // SAFETY: valid arguments.
        assert_eq!(unsafe { begin(secondary, &info) }, vk::Result::SUCCESS);
        setup.record(secondary, route, &contents);
        chain.end(secondary);
        let primary = chain.command_buffer_from(pool, vk::CommandBufferLevel::PRIMARY);
        chain.begin(primary);
        let execute: vk::PFN_vkCmdExecuteCommands = setup.app.f(c"vkCmdExecuteCommands");
        // SAFETY: one secondary.
        unsafe { execute(primary, 1, &secondary) };
        chain.end(primary);
        let reported = setup.submit_and_wait(primary);
        let (at_submission, at_completion) = if readback {
            (vec![], vec![INDEX_IN_RANGE])
        } else {
            (vec![INDEX_IN_RANGE], vec![])
        };
        assert_eq!(reported.at_submission, at_submission, "{route:?}");
        assert_eq!(reported.at_completion, at_completion, "{route:?}");
        setup.assert_inputs_hold(&contents);
    }
}

/// A recorded build's readback holds layer memory until its command
/// buffer is reset or freed. With `gpu_readback_max_bytes` short of what
/// all of them would hold, many recordings dropped by reset, pool reset and free
/// leave room for the next build's readback: it is checked, not reported
/// as not checked, and the dropped recordings report nothing.
#[test]
fn reset_and_freed_command_buffers_drop_their_readbacks() {
    // 2048 recordings read at least 40 bytes each (16 of triangles, 16 of
    // data, 8 of indices): 80 KiB, more than the 64 KiB allowed, however
    // the layer rounds its allocations.
    const DROPPED: usize = 2048;
    let setup = Setup::new(true, &[(c"gpu_readback_max_bytes", c"65536")]);
    let chain = setup.chain();
    let faulty = Rule::IndexPastMicromap.contents(true);
    let pool = chain.command_pool();
    let reset: vk::PFN_vkResetCommandBuffer = setup.app.f(c"vkResetCommandBuffer");
    let reset_pool: vk::PFN_vkResetCommandPool = setup.app.f(c"vkResetCommandPool");
    let free: vk::PFN_vkFreeCommandBuffers = setup.app.f(c"vkFreeCommandBuffers");
    for round in 0..DROPPED {
        let command_buffer = chain.command_buffer_from(pool, vk::CommandBufferLevel::PRIMARY);
        chain.begin(command_buffer);
        setup.record(command_buffer, Route::Shader, &faulty);
        chain.end(command_buffer);
        // SAFETY: never submitted, so not pending.
        let result = unsafe {
            match round % 3 {
                0 => reset(command_buffer, vk::CommandBufferResetFlags::empty()),
                1 => reset_pool(chain.device, pool, vk::CommandPoolResetFlags::empty()),
                _ => {
                    free(chain.device, pool, 1, &command_buffer);
                    vk::Result::SUCCESS
                }
            }
        };
        assert_eq!(result, vk::Result::SUCCESS);
    }
    // The dropped recordings' readbacks are gone: an idle wait reports nothing.
    let wait_idle: vk::PFN_vkDeviceWaitIdle = setup.app.f(c"vkDeviceWaitIdle");
    // SAFETY: the device.
    assert_eq!(unsafe { wait_idle(chain.device) }, vk::Result::SUCCESS);
    assert_eq!(setup.app.reported(), Vec::<String>::new());

    let command_buffer = setup.recorded(Route::Shader, &faulty);
    assert_eq!(
        setup.submit_and_wait(command_buffer).all(),
        [INDEX_IN_RANGE]
    );
}

/// A readback larger than `gpu_readback_max_bytes` is not made: one
/// information message says the build's contents were not checked and
/// names the setting to raise; nothing else is reported.
#[test]
fn a_readback_over_gpu_readback_max_bytes_is_reported_not_checked_naming_the_setting() {
    let setup = Setup::new(true, &[(c"gpu_readback_max_bytes", c"4")]);
    let chain = setup.chain();
    let contents = Rule::IndexPastMicromap.contents(true);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    setup.record(command_buffer, Route::Shader, &contents);
    chain.end(command_buffer);
    // Whether it is said at recording, submission or completion is the
    // layer's choice: all three are gathered.
    let mut warnings = setup.app.not_checked_only();
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    warnings.extend(setup.app.not_checked_only());
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    warnings.extend(setup.app.not_checked_only());
    assert_eq!(warnings.len(), 1, "{warnings:#?}");
    assert!(
        warnings[0].text.contains("gpu_readback_max_bytes"),
        "{}",
        warnings[0].text
    );
}

/// With `gpu_readback` off, inputs a shader wrote are what neither route
/// can read: one warning per device and cause (three submissions, one
/// warning) names the build, the reason, and the setting that would
/// check them; no finding is made up. vkDestroyDevice then says how many
/// builds the cause kept from being checked in all.
#[test]
fn with_readback_off_shader_written_inputs_are_reported_not_checked_naming_gpu_readback() {
    let setup = Setup::new(false, &[]);
    let faulty = Rule::IndexPastMicromap.contents(true);
    let command_buffer = setup.recorded(Route::Shader, &faulty);
    let chain = setup.chain();
    let mut warnings = Vec::new();
    for _ in 0..3 {
        let fence = chain.fence();
        assert_eq!(
            chain.submit_with(command_buffer, fence),
            vk::Result::SUCCESS
        );
        assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
        warnings.extend(setup.app.not_checked_only());
    }
    assert_eq!(warnings.len(), 1, "{warnings:#?}");
    for words in ["vkCmdBuild", "device-local", "gpu_readback"] {
        assert!(
            warnings[0].text.contains(words),
            "{words}: {}",
            warnings[0].text
        );
    }
    let destroy: vk::PFN_vkDestroyDevice = setup.app.f(c"vkDestroyDevice");
    // SAFETY: the chain's device, destroyed once; nothing uses it after.
    unsafe { destroy(chain.device, std::ptr::null()) };
    // The command buffer holds two builds (the micromap's and the
    // structure's that attaches it), each counted at each of the three
    // submissions.
    let totals = setup.app.not_checked_only();
    assert_eq!(totals.len(), 1, "{totals:#?}");
    assert!(
        totals[0].text.contains(&format!(
            "vkDestroyDevice(): the contents of 6 device builds on VkDevice {:#x} were not checked for the cause `readback-off`",
            chain.device.as_raw()
        )),
        "{}",
        totals[0].text
    );
}

/// A device whose builds were all checked says nothing when destroyed.
#[test]
fn a_device_whose_builds_were_all_checked_says_nothing_when_destroyed() {
    let setup = Setup::new(true, &[]);
    let valid = Rule::IndexPastMicromap.contents(false);
    let command_buffer = setup.recorded(Route::Shader, &valid);
    let chain = setup.chain();
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    let destroy: vk::PFN_vkDestroyDevice = setup.app.f(c"vkDestroyDevice");
    // SAFETY: the chain's device, destroyed once; nothing uses it after.
    unsafe { destroy(chain.device, std::ptr::null()) };
    assert_eq!(setup.app.reported(), Vec::<String>::new());
}

/// The layer writes only its own memory: the application's device-local
/// inputs hold nothing after recording and exactly what the application's
/// own commands wrote after completion, through both routes.
#[test]
fn the_layer_never_writes_application_memory() {
    for (readback, route) in [
        (true, Route::Shader),
        (false, Route::Upload(Upload::CopyBuffer)),
    ] {
        let setup = Setup::new(readback, &[]);
        let contents = Rule::IndexPastMicromap.contents(true);
        let command_buffer = setup.recorded(route, &contents);
        let untouched: Vec<Vec<u8>> = setup
            .scene
            .input_bytes()
            .iter()
            .map(|m| vec![0; m.len()])
            .collect();
        assert_eq!(
            setup.scene.input_bytes(),
            untouched,
            "{route:?}: written at recording"
        );
        let reported = setup.submit_and_wait(command_buffer);
        let written: Vec<Vec<u8>> = setup
            .scene
            .inputs(&contents)
            .into_iter()
            .map(|(_, bytes)| bytes)
            .collect();
        assert_eq!(setup.scene.input_bytes(), written, "{route:?}");
        assert_eq!(reported.all(), [INDEX_IN_RANGE], "{route:?}");
    }
}

/// The device commands recorded into `command_buffer`, in order.
fn recorded_into(command_buffer: vk::CommandBuffer) -> Vec<Call> {
    all_calls()
        .into_iter()
        .filter(|c| c.name.starts_with("vkCmd") && c.args.first() == Some(&command_buffer.as_raw()))
        .collect()
}

/// What a barrier the fake logged orders, as synchronization2 flags.
struct Dependency {
    src_access: vk::AccessFlags2,
    dst_stages: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
}

fn dependency(call: &Call) -> Dependency {
    assert!(
        matches!(call.name, "vkCmdPipelineBarrier" | "vkCmdPipelineBarrier2"),
        "not a barrier: {call:?}"
    );
    Dependency {
        src_access: vk::AccessFlags2::from_raw(call.args[2]),
        dst_stages: vk::PipelineStageFlags2::from_raw(call.args[3]),
        dst_access: vk::AccessFlags2::from_raw(call.args[4]),
    }
}

/// Whether `flags` holds any of `bits`.
fn any<F: std::ops::BitAnd<Output = F> + PartialEq + Default + Copy>(flags: F, bits: F) -> bool {
    flags & bits != F::default()
}

/// The barrier before the copies: the application's earlier writes made
/// visible to transfer reads.
fn assert_orders_writes_before_transfer_reads(call: &Call) {
    let d = dependency(call);
    assert!(
        !d.src_access.is_empty(),
        "no writes made available: {call:?}"
    );
    assert!(
        any(
            d.dst_stages,
            vk::PipelineStageFlags2::TRANSFER
                | vk::PipelineStageFlags2::COPY
                | vk::PipelineStageFlags2::ALL_COMMANDS
        ),
        "{call:?}"
    );
    assert!(
        any(
            d.dst_access,
            vk::AccessFlags2::TRANSFER_READ | vk::AccessFlags2::MEMORY_READ
        ),
        "{call:?}"
    );
}

/// The barrier after the copies: their writes made visible to the host.
fn assert_orders_copies_before_host_reads(call: &Call) {
    let d = dependency(call);
    assert!(
        any(
            d.src_access,
            vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::MEMORY_WRITE
        ),
        "{call:?}"
    );
    assert!(any(d.dst_stages, vk::PipelineStageFlags2::HOST), "{call:?}");
    assert!(
        any(
            d.dst_access,
            vk::AccessFlags2::HOST_READ | vk::AccessFlags2::MEMORY_READ
        ),
        "{call:?}"
    );
}

/// What an inserted copy reads: (source buffer, offset, size) per region.
fn copied_ranges(call: &Call) -> Vec<(u64, u64, u64)> {
    assert!(
        matches!(call.name, "vkCmdCopyBuffer" | "vkCmdCopyBuffer2"),
        "not a copy: {call:?}"
    );
    let destination = vk::Buffer::from_raw(call.args[2]);
    assert_eq!(
        memory_type_of(destination),
        Some(1),
        "the readback copies into host-visible memory the layer owns: {call:?}"
    );
    call.args[4..]
        .chunks(3)
        .map(|r| (call.args[1], r[0], r[2]))
        .collect()
}

/// Exactly what the contract names is inserted before each build: a
/// barrier, copies of exactly the ranges the build reads into layer-owned
/// host-visible memory, a barrier; with readback off, nothing.
#[test]
fn exactly_the_contract_commands_are_inserted_before_each_build() {
    for readback in [true, false] {
        let setup = Setup::new(readback, &[]);
        let (chain, scene) = (setup.chain(), &setup.scene);
        let contents = Contents::valid();
        let command_buffer = chain.allocate_command_buffer();
        chain.begin(command_buffer);
        record_shader_writes(&setup.app, scene, command_buffer, &contents);
        fake::reset_calls();
        scene.record_builds(chain, command_buffer, &contents);
        chain.end(command_buffer);
        let calls = recorded_into(command_buffer);
        let names: Vec<&str> = calls.iter().map(|c| c.name).collect();
        if !readback {
            assert_eq!(
                names,
                [
                    "vkCmdBuildMicromapsEXT",
                    "vkCmdBuildAccelerationStructuresKHR"
                ]
            );
            continue;
        }
        let micromap_build = names
            .iter()
            .position(|&n| n == "vkCmdBuildMicromapsEXT")
            .unwrap();
        let blas_build = names
            .iter()
            .position(|&n| n == "vkCmdBuildAccelerationStructuresKHR")
            .unwrap();
        let triangles = scene.triangles.as_raw();
        let data = scene.data.as_raw();
        let indices = scene.indices.as_raw();
        for (inserted, mut expected) in [
            (
                &calls[..micromap_build],
                vec![(triangles, 0, 16), (data, 0, u64::from(DATA_SIZE))],
            ),
            (
                &calls[micromap_build + 1..blas_build],
                vec![(indices, 0, 8)],
            ),
        ] {
            let names: Vec<&str> = inserted.iter().map(|c| c.name).collect();
            let mut contract = vec!["vkCmdPipelineBarrier"];
            contract.extend(vec!["vkCmdCopyBuffer"; names.len().saturating_sub(2)]);
            contract.push("vkCmdPipelineBarrier");
            assert!(names.len() >= 3 && names == contract, "{inserted:#?}");
            assert_orders_writes_before_transfer_reads(&inserted[0]);
            assert_orders_copies_before_host_reads(&inserted[inserted.len() - 1]);
            let mut ranges: Vec<(u64, u64, u64)> = inserted[1..inserted.len() - 1]
                .iter()
                .flat_map(copied_ranges)
                .collect();
            ranges.sort_unstable();
            expected.sort_unstable();
            assert_eq!(ranges, expected);
        }
        assert_eq!(blas_build, calls.len() - 1);
        // The copies read the application's build inputs, so the layer
        // created them with the transfer-source usage they lacked.
        for buffer in [scene.triangles, scene.data, scene.indices] {
            let usage = fake::gpu::usage_of(buffer);
            assert!(
                usage.is_some_and(|u| u.contains(vk::BufferUsageFlags::TRANSFER_SRC)),
                "{usage:?}"
            );
        }
    }
}

// Indirect builds: the range infos and the inputs they place, read back.

/// Where an indirect build's range info lies.
#[derive(Clone, Copy, Debug)]
enum RangesIn {
    /// Device-local memory the fake shader writes (before the inputs).
    DeviceLocal,
    /// Host-visible memory the application keeps mapped, written before
    /// recording.
    Mapped,
    /// Device-local memory vkCmdUpdateBuffer writes (route 1).
    Updated,
}

/// The scene with its bottom-level build recorded indirectly, its range
/// info (two triangles) in `ranges_in`, readback as given, `extra`
/// settings.
fn indirect_setup(readback: bool, ranges_in: RangesIn, extra: &[(&CStr, &CStr)]) -> Setup {
    let mut setup = Setup::new(readback, extra);
    let chain = setup.chain();
    let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
        | vk::BufferUsageFlags::STORAGE_BUFFER;
    let range = range_info_bytes(2, 0);
    let (ranges, pending) = match ranges_in {
        // The fake GPU writes it when the command buffer runs.
        RangesIn::DeviceLocal | RangesIn::Updated => {
            let buffer = chain.buffer(16, usage | vk::BufferUsageFlags::TRANSFER_DST, 0);
            (buffer, Some((buffer, range, ranges_in)))
        }
        RangesIn::Mapped => {
            let (buffer, memory) = chain.buffer_and_memory(16, usage, 1);
            // SAFETY: inside the 16-byte mapping.
            unsafe {
                chain
                    .map_backing(memory)
                    .copy_from_nonoverlapping(range.as_ptr(), range.len())
            };
            (buffer, None)
        }
    };
    setup.scene.indirect_ranges = Some(chain.address(ranges));
    setup.pending_range_write = pending;
    setup
}

/// Route 2 through an indirect build: shader-written inputs (and range
/// info where device-local), read back and checked at vkWaitForFences.
fn indirect_route_2(faulty: bool, ranges_in: RangesIn, extra: &[(&CStr, &CStr)]) -> Reported {
    let setup = indirect_setup(true, ranges_in, extra);
    let contents = Rule::IndexPastMicromap.contents(faulty);
    let command_buffer = setup.recorded(Route::Shader, &contents);
    setup.submit_and_wait(command_buffer)
}

/// An indirect build's opacity index past the micromap, in device-local
/// memory a shader wrote: the layer reads back the range info (from
/// device-local memory, or reads it from mapped memory) and the index
/// buffer towards its end, decodes primitiveCount and reports the index
/// at completion, as a direct build's; the valid twin is silent.
#[test]
fn an_indirect_builds_index_past_the_micromap_is_reported_at_completion() {
    for ranges_in in [RangesIn::DeviceLocal, RangesIn::Mapped] {
        let setup = indirect_setup(true, ranges_in, &[]);
        let chain = setup.chain();
        let contents = Rule::IndexPastMicromap.contents(true);
        let command_buffer = setup.recorded(Route::Shader, &contents);
        let complete = submit_for(&setup.app, command_buffer, Completion::WaitForFences);
        assert_eq!(setup.app.reported(), Vec::<String>::new(), "{ranges_in:?}");
        complete();
        let received = chain.collector.take();
        assert_eq!(received.len(), 1, "{ranges_in:?}: {received:#?}");
        assert_eq!(received[0].id, INDEX_IN_RANGE);
        for words in [
            "vkCmdBuildAccelerationStructuresIndirectKHR(): pInfos[0].pGeometries[0]",
            "indexBuffer[1]",
            "Read back from device memory after the build ran",
            "seen complete at vkWaitForFences",
        ] {
            assert!(
                received[0].text.contains(words),
                "{words}: {}",
                received[0].text
            );
        }
        assert_eq!(
            received[0].objects[0],
            (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw())
        );
        assert_eq!(setup.app.reported(), Vec::<String>::new(), "{ranges_in:?}");

        let twin = indirect_route_2(false, ranges_in, &[]);
        assert!(
            twin.at_submission.is_empty() && twin.at_completion.is_empty(),
            "{ranges_in:?}: {twin:?}"
        );
    }
}

/// Range info and index buffer both in memory the host knows at
/// submission (the range info mapped or written by vkCmdUpdateBuffer, the
/// indices uploaded from staging), readback off: the indirect build is
/// checked at vkQueueSubmit.
#[test]
fn an_indirect_build_with_known_ranges_and_uploaded_indices_is_checked_at_submission() {
    for ranges_in in [RangesIn::Mapped, RangesIn::Updated] {
        for faulty in [true, false] {
            let setup = indirect_setup(false, ranges_in, &[]);
            let contents = Rule::IndexPastMicromap.contents(faulty);
            let command_buffer = setup.recorded(Route::Upload(Upload::CopyBuffer), &contents);
            let reported = setup.submit_and_wait(command_buffer);
            let expected = if faulty {
                strings(&[INDEX_IN_RANGE])
            } else {
                Vec::new()
            };
            assert_eq!(
                reported.at_submission, expected,
                "{ranges_in:?} faulty {faulty}"
            );
            assert!(reported.at_completion.is_empty(), "{reported:?}");
        }
    }
}

/// The index buffer is read towards its end only up to
/// gpu_readback_indirect_max_bytes: with 4 bytes, the second index the
/// range info asks for is not read, so it is not decided and the layer
/// says so once per device, naming the input and the setting; no finding
/// is made up.
#[test]
fn indices_an_indirect_build_reads_past_the_cap_are_reported_not_checked_naming_the_setting() {
    let extra = [(c"gpu_readback_indirect_max_bytes", c"4")];
    let reported = indirect_route_2(true, RangesIn::DeviceLocal, &extra);
    assert!(reported.at_submission.is_empty(), "{reported:?}");
    // The core names the index it could not read too (each time, where
    // the layer's message is once per device).
    assert_eq!(
        sorted(reported.at_completion.clone()),
        strings(&[CONTENTS_NOT_CHECKED, "OMMCHECK-not-checked-contents"]),
        "{reported:?}"
    );

    let setup = indirect_setup(true, RangesIn::DeviceLocal, &extra);
    let command_buffer = setup.recorded(Route::Shader, &Rule::IndexPastMicromap.contents(true));
    submit_for(&setup.app, command_buffer, Completion::WaitForFences)();
    // The core's own not-checked information comes too; the layer's
    // warning is what shows at the default report level.
    let info = setup.app.info.take();
    assert!(
        info.iter().all(|m| m.id == "OMMCHECK-not-checked-contents"),
        "{info:#?}"
    );
    let warnings = setup.app.not_checked_only();
    assert_eq!(warnings.len(), 1, "{warnings:#?}");
    for words in [
        "gpu_readback_indirect_max_bytes",
        "OMMCHECK_GPU_READBACK_INDIRECT_MAX_BYTES",
        "pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer (8 bytes",
        "vkWaitForFences",
    ] {
        assert!(
            warnings[0].text.contains(words),
            "{words}: {}",
            warnings[0].text
        );
    }
    // Under the default cap the same build is checked.
    let reported = indirect_route_2(true, RangesIn::DeviceLocal, &[]);
    assert_eq!(reported.at_completion, [INDEX_IN_RANGE], "{reported:?}");
}
