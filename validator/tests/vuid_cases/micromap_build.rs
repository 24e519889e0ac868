//! Cases for `VkMicromapBuildInfoEXT`, `vkCmdBuildMicromapsEXT` and `vkBuildMicromapsEXT`.

use ommcheck::model::values::*;
use ommcheck::model::{
    CommandBuffer, MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts,
};
use ommcheck::vuids::vuid::{
    vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd, VkMicromapBuildInfoEXT as info,
};
use ommcheck::{rules, Device, Profile, Report, Tier, Validator};

use crate::fixtures::*;
use crate::{case, Case};

fn cmd_with(v: &mut Validator, build: MicromapBuildInfo) -> Report {
    v.cmd_build_micromaps(&command_buffer(), &[build])
}

fn cmd_build(build: MicromapBuildInfo) -> Report {
    cmd_with(&mut validator(), build)
}

fn host_build_of(build: MicromapBuildInfo) -> Report {
    validator().build_micromaps(DEVICE, 0, &[build])
}

fn ok_cmd() -> Report {
    cmd_build(device_build())
}

fn ok_host() -> Report {
    host_build_of(host_build())
}

fn on_cb(cb: CommandBuffer) -> Report {
    validator().cmd_build_micromaps(&cb, &[device_build()])
}

fn usage(count: u32, level: u32, format: u32) -> MicromapUsage {
    MicromapUsage {
        count,
        subdivision_level: level,
        format,
    }
}

/// A device build whose triangle array holds `triangles` and whose usage counts say `usages`.
fn cmd_build_with_triangles(
    triangles: &[MicromapTriangle],
    usages: Vec<MicromapUsage>,
    device: Device,
) -> Report {
    let mut v = validator_with(device, triangles);
    cmd_with(
        &mut v,
        MicromapBuildInfo {
            usage_counts: UsageCounts::array(usages),
            ..device_build()
        },
    )
}

fn displacement_build(usages: Vec<MicromapUsage>, triangles: &[MicromapTriangle]) -> Report {
    let mut v = validator_with(device(), triangles);
    v.state_mut().micromaps.get_mut(&MICROMAP).unwrap().ty = MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
    cmd_with(
        &mut v,
        MicromapBuildInfo {
            ty: MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV,
            usage_counts: UsageCounts::array(usages),
            ..device_build()
        },
    )
}

fn nv_triangles(format: u16, level: u16) -> Vec<MicromapTriangle> {
    vec![MicromapTriangle {
        data_offset: 0,
        subdivision_level: level,
        format,
    }]
}

fn without_features(f: impl FnOnce(&mut Device)) -> Validator {
    let mut d = device();
    f(&mut d);
    validator_with(d, &two_triangles())
}

fn t(data_offset: u32, subdivision_level: u16, format: u16) -> MicromapTriangle {
    MicromapTriangle {
        data_offset,
        subdivision_level,
        format,
    }
}

/// A build of `triangles` over `data`, checked at the simulate tier, the
/// one that computes the hygiene information.
fn data_build(triangles: &[MicromapTriangle], data: &[u8]) -> Report {
    data_build_at(Tier::Simulate, triangles, data)
}

fn data_build_at(tier: Tier, triangles: &[MicromapTriangle], data: &[u8]) -> Report {
    let mut v = validator_with(device(), triangles);
    v.set_tier(tier);
    let mut input = v.state_mut().buffers.get_mut(&INPUT).unwrap();
    let mut contents = input.contents.as_deref().unwrap().to_vec();
    contents[..data.len()].copy_from_slice(data);
    input.contents = Some(contents.into());
    // The guard re-indexes the buffer when dropped; it borrows the state until then.
    drop(input);
    let mut usage: Vec<MicromapUsage> = Vec::new();
    for tri in triangles {
        usage.push(MicromapUsage {
            count: 1,
            subdivision_level: u32::from(tri.subdivision_level),
            format: u32::from(tri.format),
        });
    }
    cmd_with(
        &mut v,
        MicromapBuildInfo {
            usage_counts: UsageCounts::array(usage),
            ..device_build()
        },
    )
}

pub fn cases() -> Vec<Case> {
    vec![
        // VkMicromapBuildInfoEXT
        case(
            info::sType_sType,
            || {
                cmd_build(MicromapBuildInfo {
                    s_type: 0,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::pNext_pNext,
            || {
                cmd_build(MicromapBuildInfo {
                    next: vec![1_000_396_001],
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::type_parameter,
            || {
                cmd_build(MicromapBuildInfo {
                    ty: 7,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::flags_parameter,
            || {
                cmd_build(MicromapBuildInfo {
                    flags: 0x10,
                    ..device_build()
                })
            },
            || {
                cmd_build(MicromapBuildInfo {
                    flags: BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT,
                    ..device_build()
                })
            },
        ),
        case(
            info::pUsageCounts_07516,
            || {
                let mut counts = two_triangle_usage();
                counts.pointers = Some(vec![Some(usage(2, 1, 2))]);
                cmd_build(MicromapBuildInfo {
                    usage_counts: counts,
                    ..device_build()
                })
            },
            || {
                cmd_build(MicromapBuildInfo {
                    usage_counts: UsageCounts::pointers(vec![usage(2, 1, 2)]),
                    ..device_build()
                })
            },
        ),
        case(
            info::pUsageCounts_parameter,
            || {
                let mut counts = two_triangle_usage();
                counts.count = 2;
                cmd_build(MicromapBuildInfo {
                    usage_counts: counts,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::ppUsageCounts_parameter,
            || {
                let counts = UsageCounts {
                    count: 2,
                    array: None,
                    pointers: Some(vec![Some(usage(2, 1, 2)), None]),
                };
                cmd_build(MicromapBuildInfo {
                    usage_counts: counts,
                    ..device_build()
                })
            },
            || {
                cmd_build(MicromapBuildInfo {
                    usage_counts: UsageCounts::pointers(vec![usage(1, 1, 2), usage(1, 1, 2)]),
                    ..device_build()
                })
            },
        ),
        case(
            info::format_11652,
            || {
                cmd_build(MicromapBuildInfo {
                    usage_counts: UsageCounts::array(vec![usage(2, 1, 3)]),
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            info::format_11653,
            || displacement_build(vec![usage(1, 1, 4)], &nv_triangles(1, 1)),
            || displacement_build(vec![usage(1, 1, 1)], &nv_triangles(1, 1)),
        ),
        case(
            info::subdivisionLevel_11654,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 3,
                        format: 1,
                    }],
                    vec![usage(1, 4, 1)],
                    device(),
                )
            },
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 3,
                        format: 1,
                    }],
                    vec![usage(1, 3, 1)],
                    device(),
                )
            },
        ),
        case(
            info::subdivisionLevel_11655,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 3,
                        format: 2,
                    }],
                    vec![usage(1, 4, 2)],
                    device(),
                )
            },
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 3,
                        format: 2,
                    }],
                    vec![usage(1, 3, 2)],
                    device(),
                )
            },
        ),
        case(
            info::subdivisionLevel_11656,
            || displacement_build(vec![usage(1, 4, 1)], &nv_triangles(1, 3)),
            || displacement_build(vec![usage(1, 3, 1)], &nv_triangles(1, 3)),
        ),
        case(
            info::format_11657,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 1,
                        format: 5,
                    }],
                    vec![usage(1, 1, 2)],
                    device(),
                )
            },
            ok_cmd,
        ),
        case(
            info::format_11658,
            || displacement_build(vec![usage(1, 1, 1)], &nv_triangles(9, 1)),
            || displacement_build(vec![usage(1, 1, 2)], &nv_triangles(2, 1)),
        ),
        case(
            info::subdivisionLevel_11659,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 5,
                        format: 1,
                    }],
                    vec![usage(1, 3, 1)],
                    device(),
                )
            },
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 5,
                        format: 1,
                    }],
                    vec![usage(1, 5, 1)],
                    Device::with_everything(Profile::Permissive),
                )
            },
        ),
        case(
            info::subdivisionLevel_11660,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 4,
                        format: 2,
                    }],
                    vec![usage(1, 3, 2)],
                    device(),
                )
            },
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: 0,
                        subdivision_level: 4,
                        format: 2,
                    }],
                    vec![usage(1, 4, 2)],
                    Device::with_everything(Profile::Permissive),
                )
            },
        ),
        case(
            info::subdivisionLevel_11661,
            || displacement_build(vec![usage(1, 3, 1)], &nv_triangles(1, 4)),
            || displacement_build(vec![usage(1, 3, 1)], &nv_triangles(1, 3)),
        ),
        // Rules of ours on the same content.
        case(
            &rules::HISTOGRAM_MISMATCH,
            || {
                cmd_build(MicromapBuildInfo {
                    usage_counts: UsageCounts::array(vec![usage(1, 1, 2), usage(1, 2, 2)]),
                    ..device_build()
                })
            },
            || {
                cmd_build(MicromapBuildInfo {
                    usage_counts: UsageCounts::array(vec![
                        usage(1, 1, 2),
                        usage(0, 2, 2),
                        usage(1, 1, 2),
                    ]),
                    ..device_build()
                })
            },
        ),
        case(
            &rules::TRIANGLE_DATA_RANGE,
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: INPUT_SIZE as u32 - 1,
                        subdivision_level: 3,
                        format: 2,
                    }],
                    vec![usage(1, 3, 2)],
                    device(),
                )
            },
            || {
                cmd_build_with_triangles(
                    &[MicromapTriangle {
                        data_offset: INPUT_SIZE as u32 - 16,
                        subdivision_level: 3,
                        format: 2,
                    }],
                    vec![usage(1, 3, 2)],
                    device(),
                )
            },
        ),
        case(
            &rules::TRIANGLE_ARRAY_RANGE,
            || {
                cmd_build(MicromapBuildInfo {
                    triangle_array: INPUT_ADDRESS + INPUT_SIZE - 12,
                    usage_counts: UsageCounts::array(vec![usage(2, 0, 2)]),
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            &rules::EXT_TRIANGLE_ARRAY_STRIDE,
            || {
                cmd_build(MicromapBuildInfo {
                    triangle_array_stride: 4,
                    usage_counts: UsageCounts::array(vec![usage(2, 0, 0)]),
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        // Hygiene information about the data.
        case(
            &rules::UNUSED_BITS,
            || data_build(&[t(0, 0, 1)], &[0b10]),
            || data_build(&[t(0, 0, 1)], &[0b01]),
        ),
        case(
            &rules::DUPLICATE_DATA,
            || data_build(&[t(0, 2, 2), t(4, 2, 2)], &[1, 2, 3, 4, 1, 2, 3, 4]),
            || {
                data_build(
                    &[t(0, 2, 2), t(0, 2, 2), t(4, 2, 2)],
                    &[1, 2, 3, 4, 5, 6, 7, 8],
                )
            },
        ),
        case(
            &rules::OVERLAPPING_DATA,
            || data_build(&[t(0, 2, 2), t(2, 2, 2)], &[1, 2, 3, 4, 5, 6]),
            || {
                data_build(
                    &[t(0, 2, 2), t(0, 2, 2), t(4, 2, 2)],
                    &[1, 2, 3, 4, 5, 6, 7, 8],
                )
            },
        ),
        // vkCmdBuildMicromapsEXT
        case(
            cmd::commandBuffer_parameter,
            || {
                on_cb(CommandBuffer {
                    handle: 0,
                    ..command_buffer()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::commandBuffer_recording,
            || {
                on_cb(CommandBuffer {
                    recording: false,
                    ..command_buffer()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::commandBuffer_cmdpool,
            || {
                on_cb(CommandBuffer {
                    queue_flags: 0x4,
                    ..command_buffer()
                })
            },
            || {
                on_cb(CommandBuffer {
                    queue_flags: 0x2,
                    ..command_buffer()
                })
            },
        ),
        case(
            cmd::renderpass,
            || {
                on_cb(CommandBuffer {
                    in_render_pass: true,
                    ..command_buffer()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::videocoding,
            || {
                on_cb(CommandBuffer {
                    in_video_coding: true,
                    ..command_buffer()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::suspended,
            || {
                on_cb(CommandBuffer {
                    suspended: true,
                    ..command_buffer()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::infoCount_arraylength,
            || validator().cmd_build_micromaps(&command_buffer(), &[]),
            ok_cmd,
        ),
        case(
            cmd::micromap_11648,
            || {
                cmd_with(
                    &mut without_features(|d| d.features.micromap_ext = false),
                    device_build(),
                )
            },
            ok_cmd,
        ),
        case(
            cmd::mode_07462,
            || {
                cmd_build(MicromapBuildInfo {
                    mode: 1,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::dstMicromap_07463,
            || {
                cmd_build(MicromapBuildInfo {
                    dst_micromap: 0x999,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_07464,
            || {
                let mut v = validator();
                v.state_mut().micromaps.get_mut(&MICROMAP).unwrap().ty =
                    MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
                cmd_with(&mut v, device_build())
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_07508,
            || {
                let mut v = validator();
                v.state_mut().buffers.get_mut(&STORAGE).unwrap().memory = None;
                cmd_with(&mut v, device_build())
            },
            ok_cmd,
        ),
        case(
            cmd::data_07510,
            || {
                let mut v = validator();
                v.state_mut().buffers.get_mut(&INPUT).unwrap().usage =
                    BUFFER_USAGE_STORAGE_BUFFER_BIT;
                cmd_with(&mut v, device_build())
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_07511,
            || {
                let mut v = validator();
                v.state_mut().buffers.get_mut(&SCRATCH).unwrap().usage =
                    BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT;
                cmd_with(&mut v, device_build())
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_07512,
            || {
                cmd_build(MicromapBuildInfo {
                    scratch_data: 0x9000_0000,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_07514,
            || {
                cmd_build(MicromapBuildInfo {
                    scratch_data: SCRATCH_ADDRESS + 8,
                    ..device_build()
                })
            },
            || {
                cmd_build(MicromapBuildInfo {
                    scratch_data: SCRATCH_ADDRESS + 256,
                    ..device_build()
                })
            },
        ),
        case(
            cmd::pInfos_07515,
            || {
                cmd_build(MicromapBuildInfo {
                    triangle_array: INPUT_ADDRESS + TRIANGLES_OFFSET + 128,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_10896,
            || {
                cmd_build(MicromapBuildInfo {
                    data: 0,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::pInfos_10897,
            || {
                cmd_build(MicromapBuildInfo {
                    triangle_array: 0x9000_0000,
                    ..device_build()
                })
            },
            ok_cmd,
        ),
        case(
            cmd::dstMicromap_11649,
            || {
                let mut v = validator();
                v.state_mut().micromaps.get_mut(&MICROMAP_2).unwrap().offset = 0x800;
                v.cmd_build_micromaps(
                    &command_buffer(),
                    &[
                        device_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            scratch_data: SCRATCH_ADDRESS + 0x8000,
                            ..device_build()
                        },
                    ],
                )
            },
            || {
                validator().cmd_build_micromaps(
                    &command_buffer(),
                    &[
                        device_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            scratch_data: SCRATCH_ADDRESS + 0x8000,
                            ..device_build()
                        },
                    ],
                )
            },
        ),
        case(
            cmd::dstMicromap_11650,
            || {
                let mut v = validator();
                v.state_mut().buffers.get_mut(&STORAGE).unwrap().usage |=
                    BUFFER_USAGE_STORAGE_BUFFER_BIT;
                cmd_with(
                    &mut v,
                    MicromapBuildInfo {
                        scratch_data: STORAGE_ADDRESS + 0x100,
                        ..device_build()
                    },
                )
            },
            ok_cmd,
        ),
        case(
            cmd::scratchData_11651,
            || {
                validator().cmd_build_micromaps(
                    &command_buffer(),
                    &[
                        device_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            ..device_build()
                        },
                    ],
                )
            },
            || {
                validator().cmd_build_micromaps(
                    &command_buffer(),
                    &[
                        device_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            scratch_data: SCRATCH_ADDRESS + 0x8000,
                            ..device_build()
                        },
                    ],
                )
            },
        ),
        // vkBuildMicromapsEXT
        case(
            host::device_parameter,
            || validator().build_micromaps(0, 0, &[host_build()]),
            ok_host,
        ),
        case(
            host::deferredOperation_parameter,
            || validator().build_micromaps(DEVICE, 0xbad, &[host_build()]),
            ok_host,
        ),
        case(
            host::deferredOperation_parent,
            || {
                let mut v = validator();
                v.state_mut().other_device_objects.insert(0xf0);
                v.build_micromaps(DEVICE, 0xf0, &[host_build()])
            },
            || {
                let mut v = validator();
                v.create_deferred_operation(0xdef);
                v.build_micromaps(DEVICE, 0xdef, &[host_build()])
            },
        ),
        case(
            host::infoCount_arraylength,
            || validator().build_micromaps(DEVICE, 0, &[]),
            ok_host,
        ),
        case(
            host::micromapHostCommands_07555,
            || {
                without_features(|d| d.features.micromap_host_commands = false).build_micromaps(
                    DEVICE,
                    0,
                    &[host_build()],
                )
            },
            ok_host,
        ),
        case(
            host::mode_07462,
            || {
                host_build_of(MicromapBuildInfo {
                    mode: 3,
                    ..host_build()
                })
            },
            ok_host,
        ),
        case(
            host::dstMicromap_07463,
            || {
                host_build_of(MicromapBuildInfo {
                    dst_micromap: 0,
                    ..host_build()
                })
            },
            ok_host,
        ),
        case(
            host::pInfos_07464,
            || {
                let mut v = validator();
                v.state_mut().micromaps.get_mut(&MICROMAP).unwrap().ty =
                    MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
                v.build_micromaps(DEVICE, 0, &[host_build()])
            },
            ok_host,
        ),
        case(
            host::pInfos_07552,
            || {
                let mut v = validator();
                v.state_mut()
                    .buffers
                    .get_mut(&STORAGE)
                    .unwrap()
                    .memory
                    .as_mut()
                    .unwrap()
                    .host_visible = false;
                v.build_micromaps(DEVICE, 0, &[host_build()])
            },
            ok_host,
        ),
        case(
            host::pInfos_07553,
            || {
                host_build_of(MicromapBuildInfo {
                    data: 0,
                    ..host_build()
                })
            },
            ok_host,
        ),
        case(
            host::pInfos_07554,
            || {
                host_build_of(MicromapBuildInfo {
                    triangle_array: 0x1234,
                    ..host_build()
                })
            },
            ok_host,
        ),
        case(
            host::pInfos_07556,
            || {
                host_build_of(MicromapBuildInfo {
                    scratch_data: 0,
                    ..host_build()
                })
            },
            ok_host,
        ),
        case(
            host::pInfos_07557,
            || {
                let mut v = validator();
                v.state_mut()
                    .buffers
                    .get_mut(&STORAGE)
                    .unwrap()
                    .memory
                    .as_mut()
                    .unwrap()
                    .multi_instance = true;
                v.build_micromaps(DEVICE, 0, &[host_build()])
            },
            ok_host,
        ),
        case(
            host::dstMicromap_11667,
            || validator().build_micromaps(DEVICE, 0, &[host_build(), host_build()]),
            || {
                validator().build_micromaps(
                    DEVICE,
                    0,
                    &[
                        host_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            scratch_data: HOST_SCRATCH + 0x800,
                            ..host_build()
                        },
                    ],
                )
            },
        ),
        case(
            host::scratchData_11669,
            || {
                validator().build_micromaps(
                    DEVICE,
                    0,
                    &[
                        host_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            ..host_build()
                        },
                    ],
                )
            },
            || {
                validator().build_micromaps(
                    DEVICE,
                    0,
                    &[
                        host_build(),
                        MicromapBuildInfo {
                            dst_micromap: MICROMAP_2,
                            scratch_data: HOST_SCRATCH + 0x800,
                            ..host_build()
                        },
                    ],
                )
            },
        ),
    ]
}

#[test]
fn stride_zero_reads_one_entry_for_any_count() {
    // 4 × (2^32 − 1) triangles all reading the fixture's first entry (level 1, 4-state).
    let counts = UsageCounts::array(vec![usage(u32::MAX, 1, 2); 4]);
    let report = cmd_build(MicromapBuildInfo {
        triangle_array_stride: 0,
        usage_counts: counts,
        ..device_build()
    });
    assert!(!report.contains(&rules::HISTOGRAM_MISMATCH), "{report}");
    assert!(!report.has_errors(), "{report}");
}

#[test]
fn the_content_tier_reads_no_data_block_for_hygiene() {
    // Each hygiene case's failing build, at the default tier and above.
    let faulty: [(&[MicromapTriangle], &[u8]); 3] = [
        (&[t(0, 0, 1)], &[0b10]),
        (&[t(0, 2, 2), t(4, 2, 2)], &[1, 2, 3, 4, 1, 2, 3, 4]),
        (&[t(0, 2, 2), t(2, 2, 2)], &[1, 2, 3, 4, 5, 6]),
    ];
    for (triangles, data) in faulty {
        let simulate = data_build_at(Tier::Simulate, triangles, data);
        assert!(!simulate.is_empty(), "{triangles:?}");
        for tier in [Tier::Params, Tier::State, Tier::Content] {
            let report = data_build_at(tier, triangles, data);
            assert!(report.is_empty(), "{tier}: {report}");
        }
    }
}
