//! Cases for the rules of the raw-structure reader.

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::model::CommandBuffer;
use ommcheck::vuids::vuid;
use ommcheck::{rules, Report};

use crate::fixtures::validator;
use crate::{case, Case};

fn build(info: vk::MicromapBuildInfoEXT<'_>) -> Report {
    // SAFETY: the callers' pointers point to live elements for the counts given.
    unsafe { validator().cmd_build_micromaps_ash(&CommandBuffer::default(), &[info]) }
}

fn usages(n: usize) -> Vec<vk::MicromapUsageEXT> {
    vec![
        vk::MicromapUsageEXT {
            count: 0,
            subdivision_level: 0,
            format: 2
        };
        n
    ]
}

fn with_usages(n: usize) -> Report {
    let list = usages(n);
    build(vk::MicromapBuildInfoEXT {
        usage_counts_count: n as u32,
        p_usage_counts: list.as_ptr(),
        dst_micromap: vk::Handle::from_raw(crate::fixtures::MICROMAP),
        ..crate_build()
    })
}

/// The fixtures' valid device build, as an ash structure without usage counts.
fn crate_build() -> vk::MicromapBuildInfoEXT<'static> {
    let model = crate::fixtures::device_build();
    vk::MicromapBuildInfoEXT {
        dst_micromap: vk::Handle::from_raw(model.dst_micromap),
        data: vk::DeviceOrHostAddressConstKHR {
            device_address: model.data,
        },
        triangle_array: vk::DeviceOrHostAddressConstKHR {
            device_address: model.triangle_array,
        },
        scratch_data: vk::DeviceOrHostAddressKHR {
            device_address: model.scratch_data,
        },
        triangle_array_stride: 8,
        ..Default::default()
    }
}

fn looped_chain() -> Report {
    let mut a = vk::BaseInStructure {
        s_type: vk::StructureType::from_raw(1_000_396_001),
        ..Default::default()
    };
    let b = vk::BaseInStructure {
        s_type: vk::StructureType::from_raw(1_000_396_001),
        p_next: &a,
        ..Default::default()
    };
    a.p_next = &b;
    let info = vk::MicromapBuildInfoEXT {
        p_next: (&a as *const vk::BaseInStructure<'_>).cast(),
        ..crate_build()
    };
    build(info)
}

pub fn cases() -> Vec<Case> {
    vec![
        case(
            vuid::vkCmdBuildMicromapsEXT::pInfos_parameter,
            // SAFETY: a NULL pInfos is never read.
            || unsafe {
                validator().cmd_build_micromaps_raw(&CommandBuffer::default(), 1, std::ptr::null())
            },
            || with_usages(1),
        ),
        case(
            vuid::vkBuildMicromapsEXT::pInfos_parameter,
            // SAFETY: a NULL pInfos is never read.
            || unsafe {
                validator().build_micromaps_raw(
                    vk::Device::from_raw(crate::fixtures::DEVICE),
                    vk::DeferredOperationKHR::null(),
                    1,
                    std::ptr::null(),
                )
            },
            // SAFETY: an empty slice is never read.
            || {
                unsafe {
                    validator().build_micromaps_ash(
                        vk::Device::from_raw(crate::fixtures::DEVICE),
                        vk::DeferredOperationKHR::null(),
                        &[],
                    )
                }
                .findings
                .into_iter()
                .filter(|f| f.rule.as_str() != "VUID-vkBuildMicromapsEXT-infoCount-arraylength")
                .fold(Report::default(), |mut r, f| {
                    r.push(f);
                    r
                })
            },
        ),
        case(&rules::PNEXT_CHAIN, looped_chain, || with_usages(1)),
        case(
            &rules::READ_BOUND,
            || with_usages(ommcheck::raw::MAX_ELEMENTS + 1),
            || with_usages(1),
        ),
    ]
}
