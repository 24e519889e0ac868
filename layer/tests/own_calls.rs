//! Failure injection (issue 29, item 3): the calls the layer makes to the
//! next layer on its own behalf ([`OwnCall`]: its readback memory, the
//! barriers and copies it records before a build, the fence and semaphore
//! queries at a wait for any of several, the driver's sizes and
//! compatibility, the device's properties) fail in the fake driver with
//! each error `vk.xml` lists for them, and only the layer's calls fail
//! (the fake driver reads which own call is under way from
//! `testing::own_call_in_progress`).
//!
//! For each call and error, the same application runs straight into the
//! fake driver and through the layer: it records and submits a device
//! micromap build whose triangle array, in device-local memory a "shader"
//! wrote, places data past its buffer, waits for it and destroys the
//! micromap built, three times; the driver fails the call from the first
//! round until the third. The application must see exactly what it sees
//! without the layer; the layer must say once, as a warning, that the
//! contents were not checked, naming the call and the error, count both
//! builds at `vkDestroyDevice`, report the third build's fault once the
//! driver has recovered, report no error it cannot be sure of (a
//! micromap destroyed in use), give back everything it created, and never
//! hang (each test runs under a watchdog) or panic.
//!
//! Every own call the layer makes is tagged; the baseline test holds the
//! layer's calls to the driver against the application's alone, so a call
//! the layer made outside `own_calls` fails it, and sees every
//! [`OwnCall`] made.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

use ash::vk;
use fake::app::{Calls, Through};
use fake::gpu::{device_bytes, fake_gpu_write};
use fake::{
    device_fn, device_micromap_build, Call, Chain, Received, Serialized, DRIVER_UUID, USAGE,
};
use VkLayer_ommcheck::own_calls::{result_name, OwnCall};

const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";
const DATA_IN_RANGE: &str = "OMMCHECK-build-triangle-data-in-range";

/// How long a test may take before it is called a deadlock: far beyond
/// what the work takes (well under a second), so only a hang trips it.
const DEADLOCK_BOUND: Duration = Duration::from_secs(60);

/// Rounds run while the driver fails the call; one more runs after.
const FAILING_ROUNDS: usize = 2;

/// The micromap data buffer's size: the second triangle's data starts at
/// its end.
const DATA_SIZE: u64 = 16;

/// Runs `body` on a thread of its own (whose fake driver starts afresh)
/// and fails the test if it has not finished within [`DEADLOCK_BOUND`];
/// its panic is the test's.
fn within_bound(body: impl FnOnce() + Send + 'static) {
    let (done, finished) = mpsc::channel();
    let worker = std::thread::spawn(move || {
        body();
        // The receiver is gone only once the test has failed already.
        let _ = done.send(());
    });
    match finished.recv_timeout(DEADLOCK_BOUND) {
        Ok(()) => worker.join().expect("finished"),
        Err(mpsc::RecvTimeoutError::Disconnected) => match worker.join() {
            Err(panic) => std::panic::resume_unwind(panic),
            Ok(()) => unreachable!("the worker sends before it ends"),
        },
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("not finished within {DEADLOCK_BOUND:?}: a deadlock")
        }
    }
}

/// How the application learns its submission is complete: a wait for any
/// of two fences, or of two timeline values, one of which its submission
/// signals. The layer asks the driver which (its own `vkGetFenceStatus`
/// or `vkGetSemaphoreCounterValue`).
#[derive(Clone, Copy, Debug)]
enum Wait {
    AnyFence,
    AnyTimelineValue,
}

impl Wait {
    /// The wait whose run reaches `call`. Each new own call must be placed
    /// here (no wildcard), and the baseline test sees that its run makes it.
    fn reaching(call: OwnCall) -> Wait {
        match call {
            OwnCall::SemaphoreCounterValue => Wait::AnyTimelineValue,
            OwnCall::DeviceMemoryProperties
            | OwnCall::QueueFamilyProperties
            | OwnCall::DeviceLimits
            | OwnCall::ReadbackCreateBuffer
            | OwnCall::ReadbackMemoryRequirements
            | OwnCall::ReadbackAllocateMemory
            | OwnCall::ReadbackBindMemory
            | OwnCall::ReadbackMapMemory
            | OwnCall::ReadbackDestroyBuffer
            | OwnCall::ReadbackFreeMemory
            | OwnCall::ReadbackBarrier
            | OwnCall::ReadbackCopy
            | OwnCall::FenceStatus
            | OwnCall::MicromapBuildSizes
            | OwnCall::MicromapCompatibility => Wait::AnyFence,
        }
    }
}

/// What one run's application builds with.
struct Scene {
    triangles: vk::Buffer,
    data: vk::Buffer,
    pool: vk::CommandPool,
    /// The build's info, but for its destination.
    info: vk::MicromapBuildInfoEXT<'static>,
}

impl Scene {
    /// The inputs in device-local memory (the layer must read them back),
    /// a command pool; and a host deserialization.
    fn new(app: &mut Calls) -> Self {
        let address = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let input = vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::STORAGE_BUFFER
            | address;
        let (triangles, _) = app.buffer(16, input, 0);
        let (data, _) = app.buffer(DATA_SIZE, input, 0);
        let (scratch, _) = app.buffer(4096, vk::BufferUsageFlags::STORAGE_BUFFER | address, 0);
        let info = device_micromap_build(
            vk::MicromapEXT::null(),
            &USAGE,
            app.address(triangles),
            app.address(data),
            app.address(scratch),
        );
        let create_pool: vk::PFN_vkCreateCommandPool = app.f(c"vkCreateCommandPool");
        let mut pool = vk::CommandPool::null();
        let pool_info = vk::CommandPoolCreateInfo::default();
        // SAFETY: valid arguments.
        let result = unsafe { create_pool(app.device, &pool_info, std::ptr::null(), &mut pool) };
        app.saw((result, pool));
        deserialize(app);
        Self {
            triangles,
            data,
            pool,
            info,
        }
    }

    /// Records the shader's writes of the inputs, a barrier and the build
    /// into a new micromap; submits it, waits as `wait` says, and destroys
    /// the micromap, which the wait shows no submission uses any more
    /// (VUID-vkDestroyMicromapEXT-micromap-07441 must not be reported).
    fn build_and_wait(&self, app: &mut Calls, wait: Wait) {
        let allocate: vk::PFN_vkAllocateCommandBuffers = app.f(c"vkAllocateCommandBuffers");
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let mut command_buffer = vk::CommandBuffer::null();
        // SAFETY: valid arguments, room for one handle.
        let result = unsafe { allocate(app.device, &info, &mut command_buffer) };
        app.saw(result);
        let begin: vk::PFN_vkBeginCommandBuffer = app.f(c"vkBeginCommandBuffer");
        // SAFETY: a command buffer of the device.
        let result = unsafe { begin(command_buffer, &vk::CommandBufferBeginInfo::default()) };
        app.saw(result);
        // The second triangle's data starts at the data buffer's end.
        let triangles = [(0u32, 1u16, 1u16), (DATA_SIZE as u32, 1, 1)]
            .iter()
            .flat_map(|&(offset, level, format)| {
                [
                    offset.to_le_bytes().as_slice(),
                    &level.to_le_bytes(),
                    &format.to_le_bytes(),
                ]
                .concat()
            })
            .collect::<Vec<u8>>();
        let info = vk::MicromapBuildInfoEXT {
            dst_micromap: micromap(app, 0),
            ..self.info
        };
        fake_gpu_write(command_buffer, self.triangles, 0, &triangles);
        fake_gpu_write(command_buffer, self.data, 0, &[0xA5; DATA_SIZE as usize]);
        let dispatch: vk::PFN_vkCmdDispatch = app.f(c"vkCmdDispatch");
        let barrier: vk::PFN_vkCmdPipelineBarrier2 = app.f(c"vkCmdPipelineBarrier2");
        let build: vk::PFN_vkCmdBuildMicromapsEXT = app.f(c"vkCmdBuildMicromapsEXT");
        let end: vk::PFN_vkEndCommandBuffer = app.f(c"vkEndCommandBuffer");
        let written = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::MICROMAP_BUILD_EXT)
            .dst_access_mask(vk::AccessFlags2::SHADER_READ)];
        let dependency = vk::DependencyInfo::default().memory_barriers(&written);
        // SAFETY: a recording command buffer; valid pointers.
        let result = unsafe {
            dispatch(command_buffer, 1, 1, 1);
            barrier(command_buffer, &dependency);
            build(command_buffer, 1, &info);
            end(command_buffer)
        };
        app.saw(result);
        let command_buffers = [command_buffer];
        let submit: vk::PFN_vkQueueSubmit = app.f(c"vkQueueSubmit");
        let result = match wait {
            Wait::AnyFence => {
                let fences = [fence(app), fence(app)];
                let info = vk::SubmitInfo::default().command_buffers(&command_buffers);
                // SAFETY: valid arguments.
                let submitted = unsafe { submit(app.queue, 1, &info, fences[0]) };
                app.saw(submitted);
                let wait: vk::PFN_vkWaitForFences = app.f(c"vkWaitForFences");
                // SAFETY: two fences of the device.
                unsafe { wait(app.device, 2, fences.as_ptr(), vk::FALSE, u64::MAX) }
            }
            Wait::AnyTimelineValue => {
                let semaphores = [timeline(app), timeline(app)];
                let values = [1u64, 1];
                let mut timeline_info = vk::TimelineSemaphoreSubmitInfo::default()
                    .signal_semaphore_values(&values[..1]);
                let info = vk::SubmitInfo::default()
                    .command_buffers(&command_buffers)
                    .signal_semaphores(&semaphores[..1])
                    .push_next(&mut timeline_info);
                // SAFETY: valid arguments.
                let submitted = unsafe { submit(app.queue, 1, &info, vk::Fence::null()) };
                app.saw(submitted);
                let wait: vk::PFN_vkWaitSemaphores = app.f(c"vkWaitSemaphores");
                let info = vk::SemaphoreWaitInfo::default()
                    .flags(vk::SemaphoreWaitFlags::ANY)
                    .semaphores(&semaphores)
                    .values(&values);
                // SAFETY: valid pointers.
                unsafe { wait(app.device, &info, u64::MAX) }
            }
        };
        app.saw(result);
        // The application's memory holds what its shader wrote, and nothing
        // the layer did.
        let inputs = (
            device_bytes(self.triangles, 0, 16),
            device_bytes(self.data, 0, DATA_SIZE),
        );
        app.saw(inputs);
        let destroy: vk::PFN_vkDestroyMicromapEXT = app.f(c"vkDestroyMicromapEXT");
        // SAFETY: a micromap of the device that no pending submission uses.
        unsafe { destroy(app.device, info.dst_micromap, std::ptr::null()) };
    }
}

/// A micromap of 4096 bytes in memory of `memory_type` of its own.
fn micromap(app: &mut Calls, memory_type: u32) -> vk::MicromapEXT {
    let (storage, _) = app.buffer(
        4096,
        vk::BufferUsageFlags::MICROMAP_STORAGE_EXT,
        memory_type,
    );
    let create: vk::PFN_vkCreateMicromapEXT = app.f(c"vkCreateMicromapEXT");
    let info = vk::MicromapCreateInfoEXT {
        buffer: storage,
        size: 4096,
        ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
        ..Default::default()
    };
    let mut micromap = vk::MicromapEXT::null();
    // SAFETY: valid arguments.
    let result = unsafe { create(app.device, &info, std::ptr::null(), &mut micromap) };
    app.saw((result, micromap));
    micromap
}

/// Deserializes, on the host, data of the fake driver's version into a
/// micromap in host-visible memory.
fn deserialize(app: &mut Calls) {
    let micromap = micromap(app, 1);
    // The fake driver's version, which the layer asks it about (its own
    // compatibility query).
    let data = Serialized::new(DRIVER_UUID, 0);
    let info = data.deserialize_into(micromap);
    let copy: vk::PFN_vkCopyMemoryToMicromapEXT = app.f(c"vkCopyMemoryToMicromapEXT");
    // SAFETY: a valid info whose source holds a 64-byte serialized header.
    let result = unsafe { copy(app.device, vk::DeferredOperationKHR::null(), &info) };
    app.saw(result);
}

fn fence(app: &mut Calls) -> vk::Fence {
    let create: vk::PFN_vkCreateFence = app.f(c"vkCreateFence");
    let mut fence = vk::Fence::null();
    let info = vk::FenceCreateInfo::default();
    // SAFETY: valid arguments.
    let result = unsafe { create(app.device, &info, std::ptr::null(), &mut fence) };
    app.saw((result, fence));
    fence
}

/// A timeline semaphore at 0.
fn timeline(app: &mut Calls) -> vk::Semaphore {
    let create: vk::PFN_vkCreateSemaphore = app.f(c"vkCreateSemaphore");
    let mut kind =
        vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE);
    let info = vk::SemaphoreCreateInfo::default().push_next(&mut kind);
    let mut semaphore = vk::Semaphore::null();
    // SAFETY: valid arguments.
    let result = unsafe { create(app.device, &info, std::ptr::null(), &mut semaphore) };
    app.saw((result, semaphore));
    semaphore
}

/// What one run's application saw, what the layer reported after setting
/// up and after each round, and the calls the driver received.
struct Run {
    seen: Vec<String>,
    reported: Vec<Vec<Received>>,
    calls: Vec<Call>,
}

/// The application over `chain`'s device, `through` the layer or not:
/// set up, then [`FAILING_ROUNDS`] rounds while the driver fails the
/// layer's own call `failing` (if any), then one round after it recovers.
fn run(chain: &Chain, through: Through, wait: Wait, failing: Option<(OwnCall, vk::Result)>) -> Run {
    // The same handles in each run: the application's calls are the same.
    fake::reset();
    let mut app = Calls {
        through,
        device: chain.device,
        queue: vk::Queue::null(),
        seen: Vec::new(),
    };
    let get_queue: vk::PFN_vkGetDeviceQueue = app.f(c"vkGetDeviceQueue");
    // SAFETY: valid arguments.
    unsafe { get_queue(app.device, 0, 0, &mut app.queue) };
    let scene = Scene::new(&mut app);
    let mut reported = vec![chain.collector.take()];
    if let Some((call, result)) = failing {
        fake::fail_own(call, result);
    }
    for round in 0..=FAILING_ROUNDS {
        if round == FAILING_ROUNDS {
            fake::heal();
        }
        scene.build_and_wait(&mut app, wait);
        reported.push(chain.collector.take());
    }
    assert_eq!(fake::gpu::faults(), Vec::<String>::new());
    Run {
        seen: app.seen,
        reported,
        calls: fake::all_calls(),
    }
}

/// A chain over a fresh device (each reports a cause once), every
/// finding reported however often it repeats.
fn chain() -> Chain {
    Chain::with_settings(&[(c"duplicate_message_limit", c"0")])
}

/// Destroys the chain's device through the layer; what it reported.
fn destroy_device(chain: &Chain) -> Vec<Received> {
    let destroy: vk::PFN_vkDestroyDevice = device_fn(chain.device, c"vkDestroyDevice");
    // SAFETY: the device, nothing pending on it.
    unsafe { destroy(chain.device, std::ptr::null()) };
    chain.collector.take()
}

fn ids(messages: &[Received]) -> Vec<&str> {
    messages.iter().map(|m| m.id.as_str()).collect()
}

/// Asserts the driver received the same calls `through` the layer, but
/// for the layer's own, as `alone`: names and arguments, in order.
fn assert_same_calls(through: &[Call], alone: &[Call], context: &str) {
    let application = |calls: &[Call]| -> Vec<(&'static str, Vec<u64>)> {
        calls
            .iter()
            .filter(|c| c.own.is_none())
            .map(|c| (c.name, c.args.clone()))
            .collect()
    };
    let (through, alone) = (application(through), application(alone));
    let differs = (0..through.len().max(alone.len())).find(|&k| through.get(k) != alone.get(k));
    if let Some(k) = differs {
        panic!(
            "{context}: call {k} through the layer is {:?}, without it {:?}; a call the layer makes on its own behalf must go through own_calls",
            through.get(k),
            alone.get(k)
        );
    }
}

/// Asserts every buffer and allocation the layer created has been given
/// back, and that it gave back nothing of the application's.
fn assert_nothing_leaked(calls: &[Call], context: &str) {
    let own = |name: &str, k: usize| -> Vec<u64> {
        let mut handles: Vec<u64> = calls
            .iter()
            .filter(|c| c.own.is_some() && c.name == name)
            .filter_map(|c| c.args.get(k).copied())
            .collect();
        handles.sort_unstable();
        handles
    };
    // A failed call is logged with no arguments: it created nothing.
    assert_eq!(
        own("vkCreateBuffer", 1),
        own("vkDestroyBuffer", 0),
        "{context}"
    );
    assert_eq!(
        own("vkAllocateMemory", 0),
        own("vkFreeMemory", 0),
        "{context}"
    );
}

#[test]
fn every_own_call_is_made_and_tagged_and_the_layer_adds_no_other() {
    within_bound(|| {
        let mut made: Vec<OwnCall> = Vec::new();
        for wait in [Wait::AnyFence, Wait::AnyTimelineValue] {
            let chain = chain();
            // The device's creation, where the layer asks its properties.
            let created = fake::all_calls();
            let alone = run(&chain, Through::Driver, wait, None);
            let through = run(&chain, Through::Layer, wait, None);
            assert_eq!(through.seen, alone.seen, "{wait:?}");
            // Each round's fault, checked after its wait.
            assert!(through.reported[0].is_empty(), "{:#?}", through.reported[0]);
            for round in &through.reported[1..] {
                assert_eq!(ids(round), [DATA_IN_RANGE], "{wait:?}: {round:#?}");
            }
            assert!(alone.reported.iter().all(Vec::is_empty));
            // Without its own calls, the layer passed on exactly the
            // application's calls.
            assert!(alone.calls.iter().all(|c| c.own.is_none()));
            assert_same_calls(&through.calls, &alone.calls, &format!("{wait:?}"));
            let reported = destroy_device(&chain);
            assert!(reported.is_empty(), "{reported:#?}");
            let all = [created, fake::all_calls()].concat();
            assert_nothing_leaked(&all, &format!("{wait:?}"));
            for call in &all {
                if let Some(own) = call.own {
                    // The tag names the call the driver received.
                    assert_eq!(call.name, own.command(), "{call:?}");
                    made.push(own);
                }
            }
        }
        for &call in OwnCall::ALL {
            assert!(made.contains(&call), "{call:?} was never made");
        }
    });
}

#[test]
fn each_own_call_failing_with_each_error_is_said_once_and_checked_again_after() {
    within_bound(|| {
        let mut injected = 0;
        for &call in OwnCall::ALL {
            for &error in call.errors() {
                let context = format!("{} failing with {}", call.command(), result_name(error));
                let wait = Wait::reaching(call);
                let chain = chain();
                let alone = run(&chain, Through::Driver, wait, None);
                let through = run(&chain, Through::Layer, wait, Some((call, error)));
                // The application sees what it sees without the layer.
                assert_eq!(through.seen, alone.seen, "{context}");
                // The driver failed the layer's call, and only it.
                let failed = fake::failed_own();
                assert!(!failed.is_empty(), "{context}: the call was not made");
                assert!(
                    failed.iter().all(|&f| f == (call, call.command(), error)),
                    "{context}: {failed:?}"
                );
                // Said once, at the first round, naming the call, the error
                // and the cause; nothing else until the driver recovers.
                let [set_up, first, second, recovered] = &through.reported[..] else {
                    panic!("{context}: {:#?}", through.reported);
                };
                assert!(set_up.is_empty(), "{context}: {set_up:#?}");
                assert_eq!(ids(first), [CONTENTS_NOT_CHECKED], "{context}: {first:#?}");
                let said = &first[0];
                assert_eq!(
                    said.severity,
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                    "{context}"
                );
                for named in [
                    format!("the layer's own {} (", call.command()),
                    format!(") returned {}", result_name(error)),
                    format!("(`{}`)", call.cause()),
                ] {
                    assert!(
                        said.text.contains(&named),
                        "{context}: {named} in {}",
                        said.text
                    );
                }
                assert!(second.is_empty(), "{context}: {second:#?}");
                // Checked again once the driver recovered.
                assert_eq!(ids(recovered), [DATA_IN_RANGE], "{context}: {recovered:#?}");
                // Both builds counted at vkDestroyDevice.
                let at_destruction = destroy_device(&chain);
                assert_eq!(ids(&at_destruction), [CONTENTS_NOT_CHECKED], "{context}");
                let total = format!(
                    "the contents of {FAILING_ROUNDS} device builds on VkDevice {:#x} were not checked for the cause `{}`",
                    vk::Handle::as_raw(chain.device),
                    call.cause()
                );
                assert!(
                    at_destruction[0].text.contains(&total),
                    "{context}: {}",
                    at_destruction[0].text
                );
                assert_nothing_leaked(&fake::all_calls(), &context);
                fake::heal();
                injected += 1;
            }
        }
        // Every error of every call that returns one (see docs/hostile-input.md).
        assert_eq!(injected, 31);
    });
}

/// The `VkResult` names `vk.xml` uses for the errors of the own calls,
/// as ash names their values.
const RESULT_NAMES: [(&str, vk::Result); 8] = [
    (
        "VK_ERROR_OUT_OF_HOST_MEMORY",
        vk::Result::ERROR_OUT_OF_HOST_MEMORY,
    ),
    (
        "VK_ERROR_OUT_OF_DEVICE_MEMORY",
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
    ),
    ("VK_ERROR_DEVICE_LOST", vk::Result::ERROR_DEVICE_LOST),
    (
        "VK_ERROR_MEMORY_MAP_FAILED",
        vk::Result::ERROR_MEMORY_MAP_FAILED,
    ),
    (
        "VK_ERROR_INVALID_EXTERNAL_HANDLE",
        vk::Result::ERROR_INVALID_EXTERNAL_HANDLE,
    ),
    (
        "VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS_KHR",
        vk::Result::ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS,
    ),
    ("VK_ERROR_UNKNOWN", vk::Result::ERROR_UNKNOWN),
    (
        "VK_ERROR_VALIDATION_FAILED",
        vk::Result::ERROR_VALIDATION_FAILED_EXT,
    ),
];

/// `vk.xml` beside the workspace; None (after saying so) where the
/// checkout has no `../shared`, which CI must have.
fn vk_xml() -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/vulkan-registry/vk.xml");
    match std::fs::read_to_string(&path) {
        Ok(text) => Some(text),
        Err(e) => {
            let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
            assert!(!ci, "{}: {e}; CI must have ../shared", path.display());
            eprintln!("skipping: {} not readable ({e})", path.display());
            None
        }
    }
}

/// The return type and the `errorcodes` that `vk.xml` gives `command`,
/// which it defines once.
fn registry_entry(xml: &str, command: &str) -> (String, Vec<String>) {
    let proto = format!("<name>{command}</name></proto>");
    assert_eq!(xml.matches(&proto).count(), 1, "{command}");
    let at = xml.find(&proto).expect("counted");
    let start = xml[..at].rfind("<command").expect("inside a <command>");
    let head = &xml[start..at];
    let return_type = head
        .rsplit("<proto><type>")
        .next()
        .and_then(|t| t.split("</type>").next())
        .expect("a return type")
        .to_owned();
    let tag = head.split('>').next().expect("the <command> tag");
    let errors = tag
        .split("errorcodes=\"")
        .nth(1)
        .and_then(|e| e.split('"').next())
        .map(|e| e.split(',').map(str::to_owned).collect())
        .unwrap_or_default();
    (return_type, errors)
}

#[test]
fn each_own_call_injects_exactly_the_errors_vk_xml_lists() {
    let Some(xml) = vk_xml() else {
        return;
    };
    for &call in OwnCall::ALL {
        let (return_type, errors) = registry_entry(&xml, call.command());
        let named: Vec<vk::Result> = errors
            .iter()
            .map(|name| {
                RESULT_NAMES
                    .iter()
                    .find(|(n, _)| n == name)
                    .unwrap_or_else(|| panic!("{call:?}: add {name} to RESULT_NAMES"))
                    .1
            })
            .collect();
        assert_eq!(call.errors(), named, "{call:?}: {errors:?}");
        // A command that returns no VkResult has no error to inject.
        assert_eq!(return_type == "VkResult", !errors.is_empty(), "{call:?}");
    }
}
