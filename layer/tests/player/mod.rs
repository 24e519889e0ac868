//! Replays a fault-corpus scene (`ommcheck-faults`: an EXT micromap build
//! and a bottom-level build attaching it, as scene JSON) through the layer
//! over the fake driver, with every buffer in device-local memory the
//! application never maps. The scene's buffer contents reach the GPU one of
//! two ways ([`Route`]): uploaded from a mapped staging buffer with
//! `vkCmdCopyBuffer` (readback off: the layer reads them from its shadows
//! at submission), or written by the fake GPU's stand-in for a compute
//! shader (readback on: only the layer's GPU readback sees them, checked
//! at `vkWaitForFences`).
//!
//! The player knows the corpus's scene shape (`faults/src/lib.rs`), not
//! every scene: members it does not expect panic, naming themselves.

#![allow(unsafe_code)]

use std::collections::HashMap;

use ash::vk;
use ommcheck::model::names::{self, Kind};
use serde_json::Value;

use crate::fake::app::{record_micromap_build, REPORT_EVERYTHING};
use crate::fake::gpu::fake_gpu_write;
use crate::fake::{device_fn, Chain, Collector, Received};

/// How the scene's buffer contents reach device-local memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Route {
    /// Route 1: `vkCmdCopyBuffer` from a mapped staging buffer, readback off.
    Upload,
    /// Route 2: the fake shader writes them, readback on.
    ShaderWrite,
}

/// What the layer reported, by when.
#[derive(Debug, Default)]
pub struct Replayed {
    pub at_recording: Vec<Received>,
    pub at_submission: Vec<Received>,
    pub at_completion: Vec<Received>,
}

impl Replayed {
    pub fn all(&self) -> impl Iterator<Item = &Received> {
        self.at_recording
            .iter()
            .chain(&self.at_submission)
            .chain(&self.at_completion)
    }
}

/// A value of enum or bitmask `K` written as its spec name, a number, or
/// (bitmasks) an array of names.
fn enum_value<K: Kind>(value: &Value) -> i64 {
    match value {
        Value::Number(n) => n.as_i64().expect("an integer"),
        Value::String(name) => {
            names::lookup::<K>(name).unwrap_or_else(|| panic!("{name} is not a {}", K::TYPE_NAME))
        }
        Value::Array(items) => items.iter().map(enum_value::<K>).fold(0, |a, b| a | b),
        other => panic!("{other} is not a {}", K::TYPE_NAME),
    }
}

fn uint(value: &Value) -> u64 {
    value
        .as_u64()
        .unwrap_or_else(|| panic!("{value} is not an unsigned integer"))
}

/// The bytes a scene buffer's `contents` give, in the scene's encodings.
fn content_bytes(contents: &Value) -> Vec<u8> {
    if let Some(hex) = contents["hex"].as_str() {
        return (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).expect("hex digits"))
            .collect();
    }
    if let Some(words) = contents["u32"].as_array() {
        return words
            .iter()
            .flat_map(|w| (uint(w) as u32).to_le_bytes())
            .collect();
    }
    if let Some(triangles) = contents["triangles"].as_array() {
        // VkMicromapTriangleEXT: dataOffset (32 bits), subdivisionLevel and format (16 each).
        return triangles
            .iter()
            .flat_map(|t| {
                let mut entry = (uint(&t["dataOffset"]) as u32).to_le_bytes().to_vec();
                entry.extend((uint(&t["subdivisionLevel"]) as u16).to_le_bytes());
                entry.extend((uint(&t["format"]) as u16).to_le_bytes());
                entry
            })
            .collect();
    }
    panic!("contents the player does not know: {contents}")
}

/// A build's or attachment's usage counts, given through `pUsageCounts`,
/// `ppUsageCounts` or (a fault) both, as the scene writes them.
struct UsageCounts {
    direct: Vec<vk::MicromapUsageEXT>,
    indirect: Vec<vk::MicromapUsageEXT>,
    pointers: Vec<*const vk::MicromapUsageEXT>,
}

impl UsageCounts {
    fn of(owner: &Value) -> Self {
        let direct = usage_counts(&owner["pUsageCounts"]);
        let indirect = usage_counts(&owner["ppUsageCounts"]);
        let pointers = indirect.iter().map(std::ptr::from_ref).collect();
        Self {
            direct,
            indirect,
            pointers,
        }
    }

    fn count(&self) -> u32 {
        self.direct.len().max(self.indirect.len()) as u32
    }

    /// `pUsageCounts`: NULL where the scene gives none.
    fn direct(&self) -> *const vk::MicromapUsageEXT {
        if self.direct.is_empty() {
            std::ptr::null()
        } else {
            self.direct.as_ptr()
        }
    }

    /// `ppUsageCounts`: NULL where the scene gives none.
    fn indirect(&self) -> *const *const vk::MicromapUsageEXT {
        if self.pointers.is_empty() {
            std::ptr::null()
        } else {
            self.pointers.as_ptr()
        }
    }
}

fn usage_counts(counts: &Value) -> Vec<vk::MicromapUsageEXT> {
    counts
        .as_array()
        .map(|counts| {
            counts
                .iter()
                .map(|c| vk::MicromapUsageEXT {
                    count: uint(&c["count"]) as u32,
                    subdivision_level: uint(&c["subdivisionLevel"]) as u32,
                    format: enum_value::<names::MicromapFormat>(&c["format"]) as u32,
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The chain the scene runs on, its buffers by name, and what each
/// buffer's contents are.
struct Player<'s> {
    chain: Chain,
    info: Box<Collector>,
    scene: &'s Value,
    buffers: HashMap<&'s str, vk::Buffer>,
    micromaps: HashMap<&'s str, vk::MicromapEXT>,
    structures: HashMap<&'s str, vk::AccelerationStructureKHR>,
    /// The stages the barrier before the builds waits for: the micromap
    /// build stage only where the micromap feature is on (a barrier may
    /// not name it otherwise).
    build_stages: vk::PipelineStageFlags2,
}

impl<'s> Player<'s> {
    /// The device of the scene (the micromap feature off where its
    /// features say so) and its buffers, each in device-local memory of
    /// its own (or none where the scene says `"memory": "unbound"`).
    fn new(scene: &'s Value, route: Route) -> Self {
        let readback = if route == Route::ShaderWrite {
            c"true"
        } else {
            c"false"
        };
        let settings = [
            REPORT_EVERYTHING.as_slice(),
            &[(c"tier", c"content"), (c"gpu_readback", readback)],
        ]
        .concat();
        let features = &scene["device"]["features"];
        let micromap = features.is_null()
            || features["VkPhysicalDeviceOpacityMicromapFeaturesEXT"]["micromap"] == true;
        let chain = Chain::with_settings_and_micromap_feature(&settings, micromap);
        let info = chain.info_collector();
        let mut player = Self {
            chain,
            info,
            scene,
            buffers: HashMap::new(),
            micromaps: HashMap::new(),
            structures: HashMap::new(),
            build_stages: if micromap {
                vk::PipelineStageFlags2::MICROMAP_BUILD_EXT
                    | vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR
            } else {
                vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR
            },
        };
        for buffer in scene["buffers"].as_array().expect("buffers") {
            player.create_buffer(buffer);
        }
        player
    }

    fn create_buffer(&mut self, buffer: &'s Value) {
        let chain = &self.chain;
        let name = buffer["name"].as_str().expect("a buffer name");
        let size = uint(&buffer["size"]);
        // Every buffer may be an upload's destination.
        let usage = vk::BufferUsageFlags::from_raw(enum_value::<names::BufferUsageFlags>(
            &buffer["usage"],
        ) as u32)
            | vk::BufferUsageFlags::TRANSFER_DST;
        let handle = if buffer["memory"] == "unbound" {
            let create: vk::PFN_vkCreateBuffer = device_fn(chain.device, c"vkCreateBuffer");
            let info = vk::BufferCreateInfo::default().size(size).usage(usage);
            let mut handle = vk::Buffer::null();
            // SAFETY: valid arguments.
            let result = unsafe { create(chain.device, &info, std::ptr::null(), &mut handle) };
            assert_eq!(result, vk::Result::SUCCESS);
            handle
        } else {
            chain.buffer(size, usage, 0)
        };
        self.buffers.insert(name, handle);
    }

    /// The scene's buffers with contents, and those contents.
    fn contents(&self) -> Vec<(vk::Buffer, Vec<u8>)> {
        self.scene["buffers"]
            .as_array()
            .expect("buffers")
            .iter()
            .filter(|b| !b["contents"].is_null())
            .map(|b| {
                let name = b["name"].as_str().expect("a buffer name");
                (self.buffers[name], content_bytes(&b["contents"]))
            })
            // A copy or write of no bytes is no command.
            .filter(|(_, bytes)| !bytes.is_empty())
            .collect()
    }

    /// A device address as the scene writes it: `{"buffer", "offset"}`
    /// (the buffer's address from vkGetBufferDeviceAddress), a number, or
    /// null (0).
    fn address(&self, value: &Value) -> u64 {
        match value {
            Value::Null => 0,
            Value::Number(_) => uint(value),
            Value::Object(at) => {
                let name = at["buffer"].as_str().expect("a buffer name");
                let offset = at.get("offset").map_or(0, uint);
                self.chain.address(self.buffers[name]) + offset
            }
            other => panic!("{other} is not an address"),
        }
    }

    fn handle<T: vk::Handle + Copy>(named: &HashMap<&str, T>, value: &Value) -> T {
        match value {
            Value::Null => T::from_raw(0),
            Value::Number(_) => T::from_raw(uint(value)),
            Value::String(name) => named[name.as_str()],
            other => panic!("{other} is not a handle"),
        }
    }

    /// Runs the scene's create calls now; returns its build calls.
    fn create_objects(&mut self) -> Vec<&'s Value> {
        let device = self.chain.device;
        let mut builds = Vec::new();
        for call in self.scene["calls"].as_array().expect("calls") {
            let info = &call["pCreateInfo"];
            match call["call"].as_str().expect("a call name") {
                "vkCreateMicromapEXT" => {
                    let create: vk::PFN_vkCreateMicromapEXT =
                        device_fn(device, c"vkCreateMicromapEXT");
                    let create_info = vk::MicromapCreateInfoEXT {
                        buffer: self.buffers[info["buffer"].as_str().expect("a buffer")],
                        size: uint(&info["size"]),
                        ty: vk::MicromapTypeEXT::from_raw(enum_value::<names::MicromapType>(
                            &info["type"],
                        ) as i32),
                        ..Default::default()
                    };
                    let mut micromap = vk::MicromapEXT::null();
                    // SAFETY: valid arguments.
                    let result =
                        unsafe { create(device, &create_info, std::ptr::null(), &mut micromap) };
                    assert_eq!(result, vk::Result::SUCCESS);
                    let name = call["pMicromap"].as_str().expect("a micromap name");
                    self.micromaps.insert(name, micromap);
                }
                "vkCreateAccelerationStructureKHR" => {
                    let create: vk::PFN_vkCreateAccelerationStructureKHR =
                        device_fn(device, c"vkCreateAccelerationStructureKHR");
                    let create_info = vk::AccelerationStructureCreateInfoKHR {
                        buffer: self.buffers[info["buffer"].as_str().expect("a buffer")],
                        size: uint(&info["size"]),
                        ty: vk::AccelerationStructureTypeKHR::from_raw(enum_value::<
                            names::AccelerationStructureType,
                        >(
                            &info["type"]
                        )
                            as i32),
                        ..Default::default()
                    };
                    let mut structure = vk::AccelerationStructureKHR::null();
                    // SAFETY: valid arguments.
                    let result =
                        unsafe { create(device, &create_info, std::ptr::null(), &mut structure) };
                    assert_eq!(result, vk::Result::SUCCESS);
                    let name = call["pAccelerationStructure"]
                        .as_str()
                        .expect("a structure name");
                    self.structures.insert(name, structure);
                }
                "vkCmdBuildMicromapsEXT" | "vkCmdBuildAccelerationStructuresKHR" => {
                    builds.push(call);
                }
                other => panic!("the player does not replay {other}"),
            }
        }
        builds
    }

    /// Records `vkCmdBuildMicromapsEXT` as the scene gives it.
    fn record_micromap_build(&self, command_buffer: vk::CommandBuffer, call: &Value) {
        let infos = call["pInfos"].as_array().expect("pInfos");
        let Some(info) = infos.first() else {
            let build: vk::PFN_vkCmdBuildMicromapsEXT =
                device_fn(self.chain.device, c"vkCmdBuildMicromapsEXT");
            // SAFETY: no infos, as the scene says.
            unsafe { build(command_buffer, 0, std::ptr::null()) };
            return;
        };
        assert_eq!(infos.len(), 1, "the corpus builds one micromap");
        let counts = UsageCounts::of(info);
        let build_info = vk::MicromapBuildInfoEXT {
            ty: vk::MicromapTypeEXT::from_raw(
                enum_value::<names::MicromapType>(&info["type"]) as i32
            ),
            flags: vk::BuildMicromapFlagsEXT::from_raw(
                info.get("flags")
                    .map_or(0, enum_value::<names::BuildMicromapFlags>) as u32,
            ),
            mode: vk::BuildMicromapModeEXT::from_raw(enum_value::<names::BuildMicromapMode>(
                &info["mode"],
            ) as i32),
            dst_micromap: Self::handle(&self.micromaps, &info["dstMicromap"]),
            usage_counts_count: counts.count(),
            p_usage_counts: counts.direct(),
            pp_usage_counts: counts.indirect(),
            data: vk::DeviceOrHostAddressConstKHR {
                device_address: self.address(&info["data"]),
            },
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: self.address(&info["scratchData"]),
            },
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                device_address: self.address(&info["triangleArray"]),
            },
            triangle_array_stride: uint(&info["triangleArrayStride"]),
            ..Default::default()
        };
        record_micromap_build(&self.chain, command_buffer, &build_info);
    }

    /// Records the scene's bottom-level build: one triangles geometry
    /// with a `VkAccelerationStructureTrianglesOpacityMicromapEXT`.
    fn record_structure_build(&self, command_buffer: vk::CommandBuffer, call: &Value) {
        let infos = call["pInfos"].as_array().expect("pInfos");
        assert_eq!(infos.len(), 1, "the corpus builds one structure");
        let info = &infos[0];
        let geometries = info["pGeometries"].as_array().expect("pGeometries");
        assert_eq!(geometries.len(), 1, "the corpus builds one geometry");
        let geometry = &geometries[0];
        let triangles = &geometry["geometry"]["triangles"];
        let attachments = triangles["pNext"].as_array().expect("an attachment");
        assert_eq!(attachments.len(), 1, "the corpus chains one attachment");
        let attachment = &attachments[0];
        let counts = UsageCounts::of(attachment);
        let opacity = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
            index_type: vk::IndexType::from_raw(enum_value::<names::IndexType>(
                &attachment["indexType"],
            ) as i32),
            index_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: self.address(&attachment["indexBuffer"]),
            },
            index_stride: uint(&attachment["indexStride"]),
            base_triangle: 0,
            usage_counts_count: counts.count(),
            p_usage_counts: counts.direct(),
            pp_usage_counts: counts.indirect(),
            micromap: Self::handle(&self.micromaps, &attachment["micromap"]),
            ..Default::default()
        };
        let mut triangles_data = vk::AccelerationStructureGeometryTrianglesDataKHR {
            vertex_format: vk::Format::from_raw(enum_value::<names::Format>(
                &triangles["vertexFormat"],
            ) as i32),
            vertex_data: vk::DeviceOrHostAddressConstKHR {
                device_address: self.address(&triangles["vertexData"]),
            },
            vertex_stride: uint(&triangles["vertexStride"]),
            max_vertex: uint(&triangles["maxVertex"]) as u32,
            index_type: vk::IndexType::from_raw(enum_value::<names::IndexType>(
                &triangles["indexType"],
            ) as i32),
            ..Default::default()
        };
        triangles_data.p_next = std::ptr::from_ref(&opacity).cast();
        let geometry = vk::AccelerationStructureGeometryKHR {
            geometry_type: vk::GeometryTypeKHR::from_raw(enum_value::<names::GeometryType>(
                &geometry["geometryType"],
            ) as i32),
            geometry: vk::AccelerationStructureGeometryDataKHR {
                triangles: triangles_data,
            },
            ..Default::default()
        };
        let build_info = vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::from_raw(enum_value::<
                names::AccelerationStructureType,
            >(&info["type"]) as i32),
            mode: vk::BuildAccelerationStructureModeKHR::from_raw(enum_value::<
                names::BuildAccelerationStructureMode,
            >(&info["mode"])
                as i32),
            dst_acceleration_structure: Self::handle(
                &self.structures,
                &info["dstAccelerationStructure"],
            ),
            geometry_count: 1,
            p_geometries: &geometry,
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: self.address(&info["scratchData"]),
            },
            ..Default::default()
        };
        let range = vk::AccelerationStructureBuildRangeInfoKHR {
            primitive_count: uint(&call["ppBuildRangeInfos"][0][0]["primitiveCount"]) as u32,
            ..Default::default()
        };
        let ranges = [std::ptr::from_ref(&range)];
        let build: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
            device_fn(self.chain.device, c"vkCmdBuildAccelerationStructuresKHR");
        // SAFETY: valid pointers for one info and its one range.
        unsafe { build(command_buffer, 1, &build_info, ranges.as_ptr()) };
    }

    /// Records `route`'s writes of the scene's contents, then a barrier to
    /// the builds. Upload: the contents go to a mapped staging buffer one
    /// after the other, and `vkCmdCopyBuffer` copies each to its buffer.
    fn record_contents(&self, command_buffer: vk::CommandBuffer, route: Route) {
        let contents = self.contents();
        let device = self.chain.device;
        match route {
            Route::Upload => {
                let total: usize = contents.iter().map(|(_, bytes)| bytes.len()).sum();
                let (staging, memory) = self.chain.buffer_and_memory(
                    total.max(1) as u64,
                    vk::BufferUsageFlags::TRANSFER_SRC,
                    1,
                );
                let mapped = self.chain.map_backing(memory);
                let copy: vk::PFN_vkCmdCopyBuffer = device_fn(device, c"vkCmdCopyBuffer");
                let mut at = 0;
                for (buffer, bytes) in &contents {
                    // SAFETY: inside the staging buffer's memory, `total` long.
                    unsafe {
                        mapped
                            .add(at)
                            .copy_from_nonoverlapping(bytes.as_ptr(), bytes.len())
                    };
                    let region = vk::BufferCopy {
                        src_offset: at as u64,
                        dst_offset: 0,
                        size: bytes.len() as u64,
                    };
                    // SAFETY: one region.
                    unsafe { copy(command_buffer, staging, *buffer, 1, &region) };
                    at += bytes.len();
                }
            }
            Route::ShaderWrite => {
                for (buffer, bytes) in &contents {
                    fake_gpu_write(command_buffer, *buffer, 0, bytes);
                }
                let dispatch: vk::PFN_vkCmdDispatch = device_fn(device, c"vkCmdDispatch");
                // SAFETY: a recording command buffer.
                unsafe { dispatch(command_buffer, 1, 1, 1) };
            }
        }
        let barrier: vk::PFN_vkCmdPipelineBarrier2 = device_fn(device, c"vkCmdPipelineBarrier2");
        let memory = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY | vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(
                vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )
            .dst_stage_mask(self.build_stages)
            .dst_access_mask(vk::AccessFlags2::SHADER_READ)];
        let info = vk::DependencyInfo::default().memory_barriers(&memory);
        // SAFETY: valid pointers.
        unsafe { barrier(command_buffer, &info) };
    }

    /// Everything reported since the last call.
    fn reported(&self) -> Vec<Received> {
        let mut all = self.chain.collector.take();
        all.extend(self.info.take());
        all
    }
}

/// Replays `scene` through the layer by `route`: creates its objects,
/// records the contents' writes and the builds in one command buffer,
/// submits it with a fence and waits for the fence.
pub fn replay(scene: &Value, route: Route) -> Replayed {
    let mut player = Player::new(scene, route);
    let builds = player.create_objects();
    let chain = &player.chain;
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    player.record_contents(command_buffer, route);
    for call in builds {
        match call["call"].as_str() {
            Some("vkCmdBuildMicromapsEXT") => player.record_micromap_build(command_buffer, call),
            _ => player.record_structure_build(command_buffer, call),
        }
    }
    chain.end(command_buffer);
    let at_recording = player.reported();
    let fence = chain.fence();
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    let at_submission = player.reported();
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    let at_completion = player.reported();
    Replayed {
        at_recording,
        at_submission,
        at_completion,
    }
}
