//! In-process chain tests: the test plays the loader and the driver (see
//! `fake/`), calls the layer's exports, and checks what reaches the
//! application's messenger and the driver.
//!
//! The duplicate-limit tests assume OMMCHECK_DUPLICATE_LIMIT and
//! OMMCHECK_REPORT are not set in the environment (variables take
//! precedence over the application's VK_EXT_layer_settings).

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::ffi::CStr;

use ash::vk;
use ash::vk::Handle as _;
use fake::{calls, device_fn, instance_fn, Chain, DeviceBuild, USAGE};
use ommcheck::report::message_id;
use VkLayer_ommcheck as layer;

const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
const DATA_IN_RANGE: &str = "OMMCHECK-build-triangle-data-in-range";

fn cmd_build(chain: &Chain, info: &vk::MicromapBuildInfoEXT<'_>) {
    let build: vk::PFN_vkCmdBuildMicromapsEXT = device_fn(chain.device, c"vkCmdBuildMicromapsEXT");
    // SAFETY: valid pointers for one info.
    unsafe { build(chain.command_buffer, 1, info) };
}

fn ids(received: &[fake::Received]) -> Vec<&str> {
    received.iter().map(|r| r.id.as_str()).collect()
}

#[test]
fn a_device_build_with_both_usage_pointers_reports_07516_in_the_khronos_format() {
    let chain = Chain::new();
    let build = DeviceBuild::new(&chain);
    let valid = build.info();
    cmd_build(&chain, &valid);
    assert!(
        chain.collector.take().is_empty(),
        "the valid build was reported"
    );

    let pointers = [USAGE.as_ptr()];
    let faulty = vk::MicromapBuildInfoEXT {
        pp_usage_counts: pointers.as_ptr(),
        ..valid
    };
    cmd_build(&chain, &faulty);
    let received = chain.collector.take();
    assert_eq!(ids(&received), [BOTH_USAGE_POINTERS], "{received:#?}");
    let message = &received[0];
    assert_eq!(message.number, message_id(BOTH_USAGE_POINTERS) as i32);
    assert_eq!(
        message.severity,
        vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
    );
    assert!(message.text.starts_with(
        "Validation Error: [ VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516 ] | MessageID = 0x"
    ));
    assert!(message.text.contains("vkCmdBuildMicromapsEXT(): pInfos[0]"));
    assert!(message.text.contains("The Vulkan spec states:"));
    assert_eq!(
        message.objects[0],
        (
            vk::ObjectType::COMMAND_BUFFER,
            chain.command_buffer.as_raw()
        )
    );

    // Both builds reached the driver with the application's arguments.
    let builds = calls("vkCmdBuildMicromapsEXT");
    assert_eq!(builds.len(), 2);
    let valid_pointer = (&valid as *const vk::MicromapBuildInfoEXT<'_>).expose_provenance() as u64;
    let faulty_pointer =
        (&faulty as *const vk::MicromapBuildInfoEXT<'_>).expose_provenance() as u64;
    assert_eq!(
        builds[0].args,
        [chain.command_buffer.as_raw(), 1, valid_pointer, 8]
    );
    assert_eq!(
        builds[1].args,
        [chain.command_buffer.as_raw(), 1, faulty_pointer, 8]
    );
}

/// Host memory a host build reads: the micromap data lies at the end of a
/// mapped allocation, the triangle array and scratch in plain host memory.
struct HostBuild {
    micromap: vk::MicromapEXT,
    mapped: Box<[u8; 64]>,
    triangles: [u8; 16],
    scratch: Box<[u8; 256]>,
}

impl HostBuild {
    fn new(chain: &Chain) -> Self {
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
        let micromap = chain.micromap(storage, 4096);
        let mut mapped = Box::new([0u8; 64]);
        // The two triangles' data: the last two bytes of the mapping.
        mapped[62] = 0x1;
        mapped[63] = 0x2;
        let memory = chain.memory(64, 1);
        chain.map(memory, mapped.as_mut_ptr());
        Self {
            micromap,
            mapped,
            // dataOffset 0 and 1, subdivision level 1, format 1 (2-state).
            triangles: [0, 0, 0, 0, 1, 0, 1, 0, 1, 0, 0, 0, 1, 0, 1, 0],
            scratch: Box::new([0u8; 256]),
        }
    }

    fn info(&mut self) -> vk::MicromapBuildInfoEXT<'static> {
        vk::MicromapBuildInfoEXT {
            ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
            mode: vk::BuildMicromapModeEXT::BUILD,
            dst_micromap: self.micromap,
            usage_counts_count: 1,
            p_usage_counts: USAGE.as_ptr(),
            data: vk::DeviceOrHostAddressConstKHR {
                host_address: self.mapped[62..].as_ptr().cast(),
            },
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                host_address: self.triangles.as_ptr().cast(),
            },
            triangle_array_stride: 8,
            scratch_data: vk::DeviceOrHostAddressKHR {
                host_address: self.scratch.as_mut_ptr().cast(),
            },
            ..Default::default()
        }
    }
}

fn host_build(chain: &Chain, info: &vk::MicromapBuildInfoEXT<'_>) -> vk::Result {
    let build: vk::PFN_vkBuildMicromapsEXT = device_fn(chain.device, c"vkBuildMicromapsEXT");
    // SAFETY: valid pointers for one info; its host addresses are live.
    unsafe { build(chain.device, vk::DeferredOperationKHR::null(), 1, info) }
}

#[test]
fn a_host_build_with_data_past_the_mapped_memory_reports_the_data_range() {
    let chain = Chain::new();
    let mut build = HostBuild::new(&chain);
    let info = build.info();
    assert_eq!(host_build(&chain, &info), vk::Result::SUCCESS);
    assert!(
        chain.collector.take().is_empty(),
        "the valid build was reported"
    );

    // Triangle 1's data at offset 2: one byte past the end of the mapping.
    build.triangles[8] = 2;
    let info = build.info();
    assert_eq!(host_build(&chain, &info), vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert_eq!(ids(&received), [DATA_IN_RANGE], "{received:#?}");
    assert_eq!(received[0].number, message_id(DATA_IN_RANGE) as i32);
    assert!(received[0]
        .text
        .contains("pInfos[0].triangleArray[1].dataOffset"));
    assert_eq!(calls("vkBuildMicromapsEXT").len(), 2);
}

/// Rules the core could not decide are visible at the default report
/// level: the first host build whose micromap data lies in host memory the
/// layer cannot see (not in a mapped allocation) gets one warning naming
/// the cause; the next such build is counted, not said again.
#[test]
fn host_memory_the_layer_cannot_read_is_a_warning_once_per_device() {
    let chain = Chain::new();
    let mut build = HostBuild::new(&chain);
    let unmapped = Box::new([0x1u8, 0x2]);
    let info = vk::MicromapBuildInfoEXT {
        data: vk::DeviceOrHostAddressConstKHR {
            host_address: unmapped.as_ptr().cast(),
        },
        ..build.info()
    };
    assert_eq!(host_build(&chain, &info), vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["OMMCHECK-not-checked-host-memory"],
        "{received:#?}"
    );
    assert_eq!(
        received[0].severity,
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
    );
    assert!(
        received[0]
            .text
            .contains("reported once per device and cause"),
        "{}",
        received[0].text
    );
    assert_eq!(host_build(&chain, &info), vk::Result::SUCCESS);
    assert!(chain.collector.take().is_empty(), "said twice");
    // Data the layer can read is checked, and says nothing.
    let info = build.info();
    assert_eq!(host_build(&chain, &info), vk::Result::SUCCESS);
    assert!(chain.collector.take().is_empty());
}

#[test]
fn a_callback_returning_true_skips_the_call() {
    let chain = Chain::new();
    let mut build = HostBuild::new(&chain);
    chain.collector.answer_with(vk::TRUE);
    build.triangles[8] = 2;
    let info = build.info();
    assert_eq!(
        host_build(&chain, &info),
        vk::Result::ERROR_VALIDATION_FAILED_EXT
    );
    assert!(
        calls("vkBuildMicromapsEXT").is_empty(),
        "the skipped call reached the driver"
    );
    assert_eq!(ids(&chain.collector.take()), [DATA_IN_RANGE]);

    let device = DeviceBuild::new(&chain);
    let pointers = [USAGE.as_ptr()];
    let faulty = vk::MicromapBuildInfoEXT {
        pp_usage_counts: pointers.as_ptr(),
        ..device.info()
    };
    cmd_build(&chain, &faulty);
    assert!(calls("vkCmdBuildMicromapsEXT").is_empty());
    // A valid call is not skipped, whatever the callback would answer.
    cmd_build(&chain, &device.info());
    assert_eq!(calls("vkCmdBuildMicromapsEXT").len(), 1);
}

/// A host build is recorded after the driver accepted it: a skipped one
/// leaves its micromap unconstructed, the next valid one constructs it.
#[test]
fn a_skipped_host_build_is_not_recorded() {
    let chain = Chain::new();
    let mut build = HostBuild::new(&chain);
    let constructed = |chain: &Chain| {
        let kept = layer::testing::kept_per_object(chain.device).expect("a known device");
        kept.iter()
            .find(|(what, _)| *what == "constructed")
            .map(|(_, n)| *n)
            .expect("the constructed objects are counted")
    };
    let before = constructed(&chain);
    chain.collector.answer_with(vk::TRUE);
    // Triangle 1's data one byte past the mapping: reported, and skipped.
    build.triangles[8] = 2;
    let skipped = host_build(&chain, &build.info());
    assert_eq!(skipped, vk::Result::ERROR_VALIDATION_FAILED_EXT);
    assert_eq!(ids(&chain.collector.take()), [DATA_IN_RANGE]);
    assert_eq!(
        constructed(&chain),
        before,
        "the skipped build was recorded"
    );

    // A valid call is not skipped, whatever the callback would answer.
    build.triangles[8] = 1;
    assert_eq!(host_build(&chain, &build.info()), vk::Result::SUCCESS);
    assert!(chain.collector.take().is_empty());
    assert_eq!(constructed(&chain), before + 1);
}

#[test]
fn a_rule_is_reported_up_to_the_duplicate_limit() {
    let chain = Chain::new();
    let build = DeviceBuild::new(&chain);
    let pointers = [USAGE.as_ptr()];
    let faulty = vk::MicromapBuildInfoEXT {
        pp_usage_counts: pointers.as_ptr(),
        ..build.info()
    };
    for _ in 0..12 {
        cmd_build(&chain, &faulty);
    }
    let received = chain.collector.take();
    assert_eq!(
        received.len(),
        layer::settings::DEFAULT_DUPLICATE_LIMIT as usize
    );
    assert!(received[..9]
        .iter()
        .all(|r| r.text.starts_with("Validation Error")));
    assert!(received[9].text.starts_with(
        "(Warning - This VUID has now been reported 10 times, which is the duplicate_message_limit value"
    ));
    assert_eq!(calls("vkCmdBuildMicromapsEXT").len(), 12);
}

/// VK_EXT_layer_settings: a `VkLayerSettingsCreateInfoEXT` for this layer
/// sets the duplicate limit of its instance; settings for another layer
/// are not this layer's business.
#[test]
fn layer_settings_from_the_application_set_the_duplicate_limit() {
    let limit: [u32; 1] = [2];
    let other: [u32; 1] = [5];
    let settings = [
        vk::LayerSettingEXT {
            p_layer_name: c"VK_LAYER_KHRONOS_validation".as_ptr(),
            p_setting_name: c"duplicate_message_limit".as_ptr(),
            ty: vk::LayerSettingTypeEXT::UINT32,
            value_count: 1,
            p_values: other.as_ptr().cast(),
            ..Default::default()
        },
        vk::LayerSettingEXT {
            p_layer_name: layer::LAYER_NAME_C.as_ptr(),
            p_setting_name: c"duplicate_message_limit".as_ptr(),
            ty: vk::LayerSettingTypeEXT::UINT32,
            value_count: 1,
            p_values: limit.as_ptr().cast(),
            ..Default::default()
        },
    ];
    let info = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    let chain = Chain::with_instance_next((&info as *const vk::LayerSettingsCreateInfoEXT).cast());
    let build = DeviceBuild::new(&chain);
    let pointers = [USAGE.as_ptr()];
    let faulty = vk::MicromapBuildInfoEXT {
        pp_usage_counts: pointers.as_ptr(),
        ..build.info()
    };
    for _ in 0..4 {
        cmd_build(&chain, &faulty);
    }
    let received = chain.collector.take();
    assert_eq!(ids(&received), [BOTH_USAGE_POINTERS, BOTH_USAGE_POINTERS]);
    assert!(received[1]
        .text
        .starts_with("(Warning - This VUID has now been reported 2 times"));
}

/// The `tier` setting: at `params` the layer decides what the parameters
/// decide (07516) and leaves what needs tracked objects (an unknown
/// dstMicromap, 07463) alone; the default tier reports both.
#[test]
fn the_tier_setting_limits_what_is_checked() {
    const UNKNOWN_MICROMAP: &str = "VUID-vkCmdBuildMicromapsEXT-dstMicromap-07463";
    let run = |chain: &Chain| {
        let build = DeviceBuild::new(chain);
        let pointers = [USAGE.as_ptr()];
        cmd_build(
            chain,
            &vk::MicromapBuildInfoEXT {
                pp_usage_counts: pointers.as_ptr(),
                dst_micromap: vk::MicromapEXT::from_raw(0xdead),
                ..build.info()
            },
        );
        let mut ids: Vec<String> = chain.collector.take().into_iter().map(|r| r.id).collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    };
    let tier = [c"params".as_ptr()];
    let settings = [vk::LayerSettingEXT {
        p_layer_name: layer::LAYER_NAME_C.as_ptr(),
        p_setting_name: c"tier".as_ptr(),
        ty: vk::LayerSettingTypeEXT::STRING,
        value_count: 1,
        p_values: tier.as_ptr().cast(),
        ..Default::default()
    }];
    let info = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    let params = Chain::with_instance_next((&info as *const vk::LayerSettingsCreateInfoEXT).cast());
    assert_eq!(run(&params), [BOTH_USAGE_POINTERS]);
    assert_eq!(run(&Chain::new()), [BOTH_USAGE_POINTERS, UNKNOWN_MICROMAP]);
}

/// What a debug-report callback received: flags, object type, object,
/// message code, layer prefix.
type Reported = std::sync::Mutex<
    Vec<(
        vk::DebugReportFlagsEXT,
        vk::DebugReportObjectTypeEXT,
        u64,
        i32,
        String,
    )>,
>;

unsafe extern "system" fn record_report(
    flags: vk::DebugReportFlagsEXT,
    object_type: vk::DebugReportObjectTypeEXT,
    object: u64,
    _: usize,
    code: i32,
    prefix: *const std::ffi::c_char,
    _: *const std::ffi::c_char,
    user_data: *mut std::ffi::c_void,
) -> vk::Bool32 {
    // SAFETY: the test registers a `Reported` as user data; the layer
    // passes a NUL-terminated prefix.
    let (reported, prefix) = unsafe {
        (
            &*user_data.cast::<Reported>(),
            std::ffi::CStr::from_ptr(prefix),
        )
    };
    reported.lock().unwrap().push((
        flags,
        object_type,
        object,
        code,
        prefix.to_string_lossy().into(),
    ));
    vk::FALSE
}

#[test]
fn debug_report_callbacks_receive_messages_until_destroyed() {
    let chain = Chain::new();
    let reported = Reported::default();
    let create: vk::PFN_vkCreateDebugReportCallbackEXT =
        instance_fn(chain.instance, c"vkCreateDebugReportCallbackEXT");
    let info = vk::DebugReportCallbackCreateInfoEXT {
        flags: vk::DebugReportFlagsEXT::ERROR | vk::DebugReportFlagsEXT::WARNING,
        pfn_callback: Some(record_report),
        p_user_data: (&reported as *const Reported).cast_mut().cast(),
        ..Default::default()
    };
    let mut callback = vk::DebugReportCallbackEXT::null();
    // SAFETY: a valid create info; `reported` outlives the callback.
    let result = unsafe { create(chain.instance, &info, std::ptr::null(), &mut callback) };
    assert_eq!(result, vk::Result::SUCCESS);
    let build = DeviceBuild::new(&chain);
    build.record_with_both_usage_pointers(&chain);
    assert_eq!(
        *reported.lock().unwrap(),
        [(
            vk::DebugReportFlagsEXT::ERROR,
            vk::DebugReportObjectTypeEXT::COMMAND_BUFFER,
            chain.command_buffer.as_raw(),
            message_id(BOTH_USAGE_POINTERS) as i32,
            "OMMCHECK".to_string()
        )]
    );
    // The debug-utils messenger received it too.
    assert_eq!(ids(&chain.collector.take()), [BOTH_USAGE_POINTERS]);

    let destroy: vk::PFN_vkDestroyDebugReportCallbackEXT =
        instance_fn(chain.instance, c"vkDestroyDebugReportCallbackEXT");
    // SAFETY: the callback created above.
    unsafe { destroy(chain.instance, callback, std::ptr::null()) };
    assert_eq!(
        calls("vkDestroyDebugReportCallbackEXT")
            .iter()
            .filter(|c| c.args == [callback.as_raw()])
            .count(),
        1
    );
    build.record_with_both_usage_pointers(&chain);
    assert_eq!(
        reported.lock().unwrap().len(),
        1,
        "no message after destruction"
    );
}

/// The chain with `break_on_error` set through VK_EXT_layer_settings to
/// `value`, after one faulty build: returns only when the layer did not
/// stop the process.
fn build_with_break_on_error(value: vk::Bool32) {
    let values = [value];
    let settings = [vk::LayerSettingEXT {
        p_layer_name: layer::LAYER_NAME_C.as_ptr(),
        p_setting_name: c"break_on_error".as_ptr(),
        ty: vk::LayerSettingTypeEXT::BOOL32,
        value_count: 1,
        p_values: values.as_ptr().cast(),
        ..Default::default()
    }];
    let info = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    let chain = Chain::with_instance_next((&info as *const vk::LayerSettingsCreateInfoEXT).cast());
    let build = DeviceBuild::new(&chain);
    let pointers = [USAGE.as_ptr()];
    cmd_build(
        &chain,
        &vk::MicromapBuildInfoEXT {
            pp_usage_counts: pointers.as_ptr(),
            ..build.info()
        },
    );
}

/// `break_on_error` raises SIGTRAP after an error, which ends a process no
/// debugger traces; without it the process goes on. Each case runs in a
/// child process (this test binary, filtered to this test).
#[test]
fn break_on_error_stops_the_process_with_sigtrap() {
    use std::os::unix::process::ExitStatusExt;
    const CHILD: &str = "OMMCHECK_TEST_BREAK_CHILD";
    if let Ok(value) = std::env::var(CHILD) {
        build_with_break_on_error(if value == "1" { vk::TRUE } else { vk::FALSE });
        return;
    }
    let run = |value: &str| {
        std::process::Command::new(std::env::current_exe().expect("the test binary"))
            .args([
                "--exact",
                "break_on_error_stops_the_process_with_sigtrap",
                "--test-threads=1",
            ])
            .env(CHILD, value)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .expect("the test binary runs")
    };
    let broke = run("1");
    assert_eq!(broke.signal(), Some(libc::SIGTRAP), "{broke:?}");
    let went_on = run("0");
    assert!(went_on.success(), "{went_on:?}");
}

#[test]
fn a_panic_in_a_check_is_one_error_and_the_call_still_runs() {
    let chain = Chain::new();
    let build = DeviceBuild::new(&chain);
    layer::testing::panic_in_next_check();
    cmd_build(&chain, &build.info());
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        [layer::report::INTERNAL_ERROR],
        "{received:#?}"
    );
    assert!(received[0]
        .text
        .contains("a panic injected by ommcheck's test hook"));
    assert_eq!(calls("vkCmdBuildMicromapsEXT").len(), 1);

    // The device's state survives: the next faulty call is reported as usual.
    let pointers = [USAGE.as_ptr()];
    let faulty = vk::MicromapBuildInfoEXT {
        pp_usage_counts: pointers.as_ptr(),
        ..build.info()
    };
    cmd_build(&chain, &faulty);
    assert_eq!(ids(&chain.collector.take()), [BOTH_USAGE_POINTERS]);
}

#[test]
fn messengers_get_only_what_their_masks_select_until_destroyed() {
    let chain = Chain::new();
    let warnings = Box::<fake::Collector>::default();
    let only_warnings = fake::add_messenger(
        chain.instance,
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        &warnings,
    );
    let build = DeviceBuild::new(&chain);
    build.record_with_both_usage_pointers(&chain);
    assert!(
        warnings.take().is_empty(),
        "an error reached a warnings-only messenger"
    );
    assert_eq!(chain.collector.take().len(), 1);

    let destroy: vk::PFN_vkDestroyDebugUtilsMessengerEXT =
        instance_fn(chain.instance, c"vkDestroyDebugUtilsMessengerEXT");
    // SAFETY: a messenger of this instance.
    unsafe { destroy(chain.instance, chain.messenger, std::ptr::null()) };
    unsafe { destroy(chain.instance, only_warnings, std::ptr::null()) };
    build.record_with_both_usage_pointers(&chain);
    assert!(
        chain.collector.take().is_empty(),
        "a destroyed messenger was called"
    );
    assert_eq!(calls("vkDestroyDebugUtilsMessengerEXT").len(), 2);
}

#[test]
fn micromaps_are_checked_at_creation_and_destruction() {
    let chain = Chain::new();
    // A buffer without VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT.
    let plain = chain.buffer(4096, vk::BufferUsageFlags::STORAGE_BUFFER, 0);
    let micromap = chain.micromap(plain, 4096);
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkMicromapCreateInfoEXT-buffer-07435"]
    );
    assert_eq!(calls("vkCreateMicromapEXT").len(), 1);

    let destroy: vk::PFN_vkDestroyMicromapEXT = device_fn(chain.device, c"vkDestroyMicromapEXT");
    // SAFETY: a micromap of this device.
    unsafe { destroy(chain.device, micromap, std::ptr::null()) };
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkDestroyMicromapEXT")[0].args, [micromap.as_raw()]);
}

#[test]
fn unknown_commands_pass_through_and_missing_ones_stay_missing() {
    let chain = Chain::new();
    let name = c"vkOmmcheckTestUnknownCommand";
    let fake_unknown = fake::unknown_command as unsafe extern "system" fn() as usize;
    // SAFETY: NUL-terminated names.
    let through_instance = unsafe { layer::vkGetInstanceProcAddr(chain.instance, name.as_ptr()) };
    let through_device = unsafe { layer::vkGetDeviceProcAddr(chain.device, name.as_ptr()) };
    assert_eq!(through_instance.map(|f| f as usize), Some(fake_unknown));
    assert_eq!(through_device.map(|f| f as usize), Some(fake_unknown));

    // The layer intercepts vkCreateDeferredOperationKHR, but the driver
    // lacks it: the application must get NULL.
    let missing = c"vkCreateDeferredOperationKHR";
    // SAFETY: NUL-terminated names.
    assert!(unsafe { layer::vkGetDeviceProcAddr(chain.device, missing.as_ptr()) }.is_none());
    assert!(unsafe { layer::vkGetInstanceProcAddr(chain.instance, missing.as_ptr()) }.is_none());

    // Intercepted commands are the layer's own, not the driver's.
    let build = c"vkCmdBuildMicromapsEXT";
    let fake_build = unsafe { fake::fake_gdpa(chain.device, build.as_ptr()) };
    let layer_build = unsafe { layer::vkGetDeviceProcAddr(chain.device, build.as_ptr()) };
    assert!(
        layer_build.is_some() && layer_build.map(|f| f as usize) != fake_build.map(|f| f as usize)
    );
    assert!(layer::intercepts(build));
}

#[test]
fn instance_creation_needs_the_loader_link() {
    let (result, _, _) = fake::create_instance_through_layer(false);
    assert_eq!(result, vk::Result::ERROR_INITIALIZATION_FAILED);
    let (result, instance, advanced) = fake::create_instance_through_layer(true);
    assert_eq!(result, vk::Result::SUCCESS);
    assert!(advanced);
    assert_eq!(calls("vkCreateInstance").last().unwrap().args, [1]);
    let destroy: vk::PFN_vkDestroyInstance = instance_fn(instance, c"vkDestroyInstance");
    // SAFETY: the instance just created.
    unsafe { destroy(instance, std::ptr::null()) };
    assert_eq!(calls("vkDestroyInstance")[0].args, [instance.as_raw()]);
}

#[test]
fn negotiation_offers_interface_2_and_the_layer_entry_points() {
    let mut negotiate = layer::abi::NegotiateLayerInterface {
        s_type: layer::abi::LAYER_NEGOTIATE_INTERFACE_STRUCT,
        p_next: std::ptr::null_mut(),
        loader_layer_interface_version: 5,
        pfn_get_instance_proc_addr: None,
        pfn_get_device_proc_addr: None,
        pfn_get_physical_device_proc_addr: None,
    };
    // SAFETY: a valid negotiation structure.
    let result = unsafe { layer::vkNegotiateLoaderLayerInterfaceVersion(&mut negotiate) };
    assert_eq!(result, vk::Result::SUCCESS);
    assert_eq!(negotiate.loader_layer_interface_version, 2);
    assert_eq!(
        negotiate.pfn_get_instance_proc_addr.map(|f| f as usize),
        Some(layer::vkGetInstanceProcAddr as vk::PFN_vkGetInstanceProcAddr as usize)
    );
    assert!(negotiate.pfn_get_device_proc_addr.is_some());
    assert!(negotiate.pfn_get_physical_device_proc_addr.is_none());
    negotiate.loader_layer_interface_version = 1;
    // SAFETY: as above.
    let result = unsafe { layer::vkNegotiateLoaderLayerInterfaceVersion(&mut negotiate) };
    assert_eq!(result, vk::Result::ERROR_INITIALIZATION_FAILED);
}

/// A serialized bottom-level header of `size` bytes with one block of
/// `block_type` holding `addresses`.
fn serialized_header(block_type: u32, addresses: &[u64], size: usize) -> Vec<u8> {
    let mut bytes = vec![0u8; size];
    bytes[32..40].copy_from_slice(&(size as u64).to_le_bytes());
    bytes[48..56].copy_from_slice(&(0xFFFF_FFFF_0000_0001u64).to_le_bytes());
    bytes[56..60].copy_from_slice(&block_type.to_le_bytes());
    bytes[64..72].copy_from_slice(&(addresses.len() as u64).to_le_bytes());
    for (k, a) in addresses.iter().enumerate() {
        bytes[72 + 8 * k..80 + 8 * k].copy_from_slice(&a.to_le_bytes());
    }
    bytes
}

#[test]
fn a_host_deserialization_reads_the_blocks_of_its_header() {
    // A device with the KHR micromap feature, which opacity-micromap blocks need.
    let mut khr_micromap = ommcheck::vuids::khr::PhysicalDeviceOpacityMicromapFeaturesKHR {
        micromap: vk::TRUE,
        ..Default::default()
    };
    let (chain, result) = Chain::with_device_chain((&raw mut khr_micromap).cast());
    assert_eq!(result, vk::Result::SUCCESS);
    let blas = fake::app::AttachmentBuild::structure(&chain);
    let copy: vk::PFN_vkCopyMemoryToAccelerationStructureKHR =
        device_fn(chain.device, c"vkCopyMemoryToAccelerationStructureKHR");
    let deserialize = |header: &[u8]| {
        let info = vk::CopyMemoryToAccelerationStructureInfoKHR::default()
            .src(vk::DeviceOrHostAddressConstKHR {
                host_address: header.as_ptr().cast(),
            })
            .dst(blas)
            .mode(vk::CopyAccelerationStructureModeKHR::DESERIALIZE);
        // SAFETY: the header is readable for the size it states.
        unsafe { copy(chain.device, vk::DeferredOperationKHR::null(), &info) }
    };
    // A block of type 7, no VkAccelerationStructureSerializedBlockTypeKHR.
    let _ = deserialize(&serialized_header(7, &[], 128));
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkCopyMemoryToAccelerationStructureInfoKHR-src-11583"],
        "{received:#?}"
    );
    // An opacity-micromap block whose one address is NULL.
    assert_eq!(
        deserialize(&serialized_header(0, &[0], 128)),
        vk::Result::SUCCESS
    );
    let received = chain.collector.take();
    assert!(received.is_empty(), "{received:#?}");
    // A block that claims more addresses than the stated size holds is read
    // only as far as that size: the one address inside is checked.
    let mut header = serialized_header(0, &[0x1234_0000], 80);
    header[64..72].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let _ = deserialize(&header);
    assert_eq!(
        ids(&chain.collector.take()),
        ["VUID-VkCopyMemoryToAccelerationStructureInfoKHR-dst-11585"]
    );
    assert_eq!(calls("vkCopyMemoryToAccelerationStructureKHR").len(), 3);
}

/// What a messenger chained to `VkInstanceCreateInfo` receives at
/// `vkCreateInstance` when the application gives `settings` (name and
/// string value) through VK_EXT_layer_settings: the severity and text of
/// each message, by id.
fn instance_creation_messages(settings: &[(&CStr, &CStr)]) -> Vec<(String, String, String)> {
    let collector = Box::<fake::Collector>::default();
    let chain = fake::app::with_settings(settings, |next| {
        let messenger = vk::DebugUtilsMessengerCreateInfoEXT {
            p_next: next,
            message_severity: vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            message_type: vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
            pfn_user_callback: Some(fake::collect),
            p_user_data: (&*collector as *const fake::Collector).cast_mut().cast(),
            ..Default::default()
        };
        Chain::with_instance_next(
            (&messenger as *const vk::DebugUtilsMessengerCreateInfoEXT).cast(),
        )
    });
    // Chained messengers hear only instance creation and destruction.
    DeviceBuild::new(&chain).record_with_both_usage_pointers(&chain);
    collector
        .take()
        .into_iter()
        .map(|m| (m.id, format!("{:?}", m.severity), m.text))
        .collect()
}

/// With information reported, vkCreateInstance lists the settings in
/// effect and where each came from; at the default report level it does
/// not, and correct settings draw no warning.
#[test]
fn the_effective_settings_are_listed_at_instance_creation_when_info_is_reported() {
    let said = instance_creation_messages(&[(c"report_flags", c"error,warning,info")]);
    assert_eq!(said.len(), 1, "{said:#?}");
    let (id, severity, text) = &said[0];
    assert_eq!(id, "OMMCHECK-layer-effective-settings");
    assert_eq!(severity, "INFO");
    for part in [
        r#"vkCreateInstance(): the settings in effect"#,
        r#"report_flags = "error,warning,info" (VK_EXT_layer_settings)"#,
        "tier = \"content\" (default)",
    ] {
        assert!(text.contains(part), "{part}: {text}");
    }
    assert_eq!(
        instance_creation_messages(&[(c"tier", c"content")]),
        Vec::new()
    );
}

/// A filter entry that names no message is a settings warning at
/// vkCreateInstance, with the id it was likely meant to be, whatever the
/// report level; one that names a message is not.
#[test]
fn a_misspelled_filter_id_given_by_the_application_is_reported_at_instance_creation() {
    let said = instance_creation_messages(&[(
        c"message_id_filter",
        c"OMMCHECK-build-triangle-data-in-rnage",
    )]);
    assert_eq!(said.len(), 1, "{said:#?}");
    let (id, severity, text) = &said[0];
    assert_eq!(
        (id.as_str(), severity.as_str()),
        ("OMMCHECK-layer-settings", "WARNING")
    );
    assert!(
        text.ends_with("VkLayerSettingEXT message_id_filter names `OMMCHECK-build-triangle-data-in-rnage`, which is no message this layer reports, so it mutes nothing; did you mean `OMMCHECK-build-triangle-data-in-range`?"),
        "{text}"
    );
    let said = instance_creation_messages(&[(
        c"message_id_filter",
        c"OMMCHECK-build-triangle-data-in-range",
    )]);
    assert_eq!(said, Vec::new());
}
