//! The fault corpus: seeded scenes, each a valid micromap build and BLAS
//! build of N triangles with one fault of a known class planted at a random
//! place, beside its valid twin (scene JSON, as `ommcheck check` reads it).
//!
//! A crate of its own so that both users reach it without a dependency
//! cycle: `cargo xtask accuracy` (xtask/src/faults.rs) checks the corpus
//! at every tier, and the layer's tests (layer/tests/fault_corpus.rs)
//! replay it through the layer with its inputs in device-local memory.

use rand::{Rng, RngExt as _, SeedableRng};
use rand_xorshift::XorShiftRng;
use serde_json::{json, Value};

/// The numbers of micromap (and geometry) triangles each class is planted in.
pub const SIZES: [usize; 3] = [4, 64, 1024];

/// The seed `cargo xtask accuracy` and the tests use.
pub const SEED: u64 = 0x6f6d_6d63_6865_636b;

/// Micromap triangles are built at this level: 8 (2-state) or 16 (4-state)
/// bytes each, so random data never repeats a block by chance.
const LEVEL: u32 = 3;

/// A valid workload: an EXT micromap of `n` level-3 triangles with random
/// data, and a BLAS of `n` triangles whose opacity indices are a random
/// permutation of them.
#[derive(Clone, Debug)]
struct Workload {
    n: usize,
    /// `VkOpacityMicromapFormatEXT`: 1 (2-state) or 2 (4-state).
    format: u32,
    data: Vec<u8>,
    indices: Vec<u32>,
}

impl Workload {
    fn new(rng: &mut impl Rng, n: usize) -> Self {
        let format = if rng.random::<bool>() { 1 } else { 2 };
        let mut data = vec![0u8; n * Self::block(format)];
        rng.fill_bytes(&mut data);
        let mut indices: Vec<u32> = (0..n as u32).collect();
        for i in (1..indices.len()).rev() {
            let j = rng.random_range(0..=i);
            indices.swap(i, j);
        }
        Self {
            n,
            format,
            data,
            indices,
        }
    }

    /// Bytes of one triangle's data.
    fn block(format: u32) -> usize {
        (1usize << (2 * LEVEL)) * format as usize / 8
    }

    fn scene(&self) -> Value {
        let n = self.n as u64;
        let format = self.format;
        let block = Self::block(format) as u64;
        let triangles: Vec<Value> = (0..n)
            .map(|m| json!({"dataOffset": m * block, "subdivisionLevel": LEVEL, "format": format}))
            .collect();
        let hex: String = self.data.iter().map(|b| format!("{b:02x}")).collect();
        let input = [
            "VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT",
            "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT",
        ];
        let as_input = [
            "VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR",
            "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT",
        ];
        let usage = json!([{"count": n, "subdivisionLevel": LEVEL, "format": format}]);
        json!({
            "device": {"profile": "spec-minimum"},
            "buffers": [
                {"name": "omm-data", "size": n * block, "usage": input, "contents": {"hex": hex}},
                {"name": "omm-triangles", "size": n * 8, "usage": input, "contents": {"triangles": triangles}},
                {"name": "micromap-storage", "size": 65536, "usage": "VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT"},
                {"name": "scratch", "size": 65536, "usage": ["VK_BUFFER_USAGE_STORAGE_BUFFER_BIT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]},
                {"name": "vertices", "size": n * 36, "usage": as_input},
                {"name": "omm-index", "size": n * 4, "usage": as_input, "contents": {"u32": self.indices}},
                {"name": "blas-storage", "size": 65536, "usage": "VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR"}
            ],
            "calls": [
                {"call": "vkCreateMicromapEXT",
                 "pCreateInfo": {"buffer": "micromap-storage", "size": 65536, "type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT"},
                 "pMicromap": "omm"},
                {"call": "vkCmdBuildMicromapsEXT",
                 "pInfos": [{
                    "type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT",
                    "mode": "VK_BUILD_MICROMAP_MODE_BUILD_EXT",
                    "dstMicromap": "omm",
                    "pUsageCounts": usage,
                    "data": {"buffer": "omm-data"},
                    "scratchData": {"buffer": "scratch"},
                    "triangleArray": {"buffer": "omm-triangles"},
                    "triangleArrayStride": 8}]},
                {"call": "vkCreateAccelerationStructureKHR",
                 "pCreateInfo": {"buffer": "blas-storage", "size": 65536, "type": "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR"},
                 "pAccelerationStructure": "blas"},
                {"call": "vkCmdBuildAccelerationStructuresKHR",
                 "pInfos": [{
                    "type": "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR",
                    "mode": "VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR",
                    "dstAccelerationStructure": "blas",
                    "pGeometries": [{
                        "geometryType": "VK_GEOMETRY_TYPE_TRIANGLES_KHR",
                        "geometry": {"triangles": {
                            "vertexFormat": "VK_FORMAT_R32G32B32_SFLOAT",
                            "vertexData": {"buffer": "vertices"},
                            "vertexStride": 12,
                            "maxVertex": n * 3 - 1,
                            "indexType": "VK_INDEX_TYPE_NONE_KHR",
                            "pNext": [{
                                "sType": "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT",
                                "indexType": "VK_INDEX_TYPE_UINT32",
                                "indexBuffer": {"buffer": "omm-index"},
                                "indexStride": 4,
                                "pUsageCounts": usage,
                                "micromap": "omm"}]}}}],
                    "scratchData": {"buffer": "scratch", "offset": 32768}}],
                 "ppBuildRangeInfos": [[{"primitiveCount": n}]]}
            ]
        })
    }
}

/// Where the parts of the workload's scene live, as JSON pointers.
const MICROMAP_INFO: &str = "/calls/1/pInfos/0";
const ATTACHMENT: &str = "/calls/3/pInfos/0/pGeometries/0/geometry/triangles/pNext/0";
const TRIANGLES: &str = "/buffers/1/contents/triangles";
const INDICES: &str = "/buffers/5/contents/u32";

/// How a fault is planted: the scene, the workload and a random source.
type Plant = fn(&mut Value, &Workload, &mut XorShiftRng);

/// A class of fault: its name, the rule that must report it, and how to plant it.
pub struct FaultClass {
    pub name: &'static str,
    pub rule: &'static str,
    plant: Plant,
}

fn at<'v>(scene: &'v mut Value, pointer: &str) -> &'v mut Value {
    scene
        .pointer_mut(pointer)
        .unwrap_or_else(|| panic!("the workload scene has {pointer}"))
}

/// A random element index below `n`.
fn pick(rng: &mut XorShiftRng, n: usize) -> usize {
    rng.random_range(0..n)
}

macro_rules! class {
    ($name:literal, $rule:literal, $plant:expr) => {
        FaultClass {
            name: $name,
            rule: $rule,
            plant: $plant,
        }
    };
}

/// Every class the corpus plants, grouped by what decides it.
pub fn classes() -> Vec<FaultClass> {
    vec![
        // The micromap build's parameters.
        class!(
            "both usage-count pointers",
            "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516",
            |s, _, _| {
                let usage = at(s, &format!("{MICROMAP_INFO}/pUsageCounts")).clone();
                at(s, MICROMAP_INFO)["ppUsageCounts"] = usage;
            }
        ),
        class!(
            "usage-count format",
            "VUID-VkMicromapBuildInfoEXT-format-11652",
            |s, _, r| {
                at(s, &format!("{MICROMAP_INFO}/pUsageCounts/0"))["format"] =
                    json!(r.random_range(3..1000));
            }
        ),
        class!(
            "usage-count level above the limit",
            "VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11654",
            |s, w, r| {
                let usage = at(s, &format!("{MICROMAP_INFO}/pUsageCounts/0"));
                usage["format"] = json!(1);
                usage["subdivisionLevel"] = json!(r.random_range(4..=12));
                let _ = w;
            }
        ),
        class!(
            "build mode",
            "VUID-vkCmdBuildMicromapsEXT-mode-07462",
            |s, _, r| {
                at(s, MICROMAP_INFO)["mode"] = json!(r.random_range(1..100));
            }
        ),
        class!(
            "micromap type",
            "VUID-VkMicromapBuildInfoEXT-type-parameter",
            |s, _, r| {
                at(s, MICROMAP_INFO)["type"] = json!(r.random_range(2..100));
            }
        ),
        class!(
            "undefined build flag",
            "VUID-VkMicromapBuildInfoEXT-flags-parameter",
            |s, _, r| {
                at(s, MICROMAP_INFO)["flags"] = json!(1u32 << r.random_range(8..31));
            }
        ),
        class!(
            "no build infos",
            "VUID-vkCmdBuildMicromapsEXT-infoCount-arraylength",
            |s, _, _| {
                at(s, "/calls/1")["pInfos"] = json!([]);
            }
        ),
        class!(
            "unaligned triangle array",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07515",
            |s, _, r| {
                at(s, MICROMAP_INFO)["triangleArray"] = json!({"buffer": "omm-triangles", "offset": r.random_range(1..256) / 4 * 4 + 4});
            }
        ),
        class!(
            "null data address",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-10896",
            |s, _, _| {
                at(s, MICROMAP_INFO)["data"] = Value::Null;
            }
        ),
        class!(
            "overlapping triangle-array entries",
            "OMMCHECK-build-triangle-array-stride",
            |s, _, r| {
                at(s, MICROMAP_INFO)["triangleArrayStride"] = json!(r.random_range(1..8));
            }
        ),
        class!(
            "micromap feature off",
            "VUID-vkCmdBuildMicromapsEXT-micromap-11648",
            |s, _, _| {
                s["device"]["features"] = json!({"VkPhysicalDeviceAccelerationStructureFeaturesKHR": {"accelerationStructure": true}, "VkPhysicalDeviceBufferDeviceAddressFeatures": {"bufferDeviceAddress": true}});
            }
        ),
        // The objects and memory the build names.
        class!(
            "unknown destination micromap",
            "VUID-vkCmdBuildMicromapsEXT-dstMicromap-07463",
            |s, _, r| {
                at(s, MICROMAP_INFO)["dstMicromap"] = json!(r.random_range(0x1000..0x10000));
            }
        ),
        class!(
            "data buffer without build-input usage",
            "VUID-vkCmdBuildMicromapsEXT-data-07510",
            |s, _, _| {
                at(s, "/buffers/0")["usage"] = json!("VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT");
            }
        ),
        class!(
            "scratch without storage usage",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07511",
            |s, _, _| {
                at(s, "/buffers/3")["usage"] = json!("VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT");
            }
        ),
        class!(
            "scratch address in no buffer",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07512",
            |s, _, r| {
                at(s, MICROMAP_INFO)["scratchData"] = json!(r.random_range(1u64..0x1000) * 256);
            }
        ),
        class!(
            "triangle array in no buffer",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-10897",
            |s, _, r| {
                at(s, MICROMAP_INFO)["triangleArray"] = json!(r.random_range(1u64..0x1000) * 256);
            }
        ),
        class!(
            "destination not bound to memory",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07508",
            |s, _, _| {
                at(s, "/buffers/2")["memory"] = json!("unbound");
            }
        ),
        class!(
            "destination of the other micromap type",
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07464",
            |s, _, _| {
                at(s, "/calls/0/pCreateInfo")["type"] =
                    json!("VK_MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV");
            }
        ),
        class!(
            "attachment to an unknown micromap",
            "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-micromap-parameter",
            |s, _, r| {
                at(s, ATTACHMENT)["micromap"] = json!(r.random_range(0x1000..0x10000));
            }
        ),
        class!(
            "attachment index type",
            "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-indexType-10719",
            |s, _, _| {
                at(s, ATTACHMENT)["indexType"] = json!("VK_INDEX_TYPE_UINT8_EXT");
            }
        ),
        class!(
            "attachment stride not a multiple of the index size",
            "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-indexType-10722",
            |s, _, r| {
                at(s, ATTACHMENT)["indexStride"] = json!(r.random_range(1..4) + 4);
            }
        ),
        class!(
            "attachment with both usage-count pointers",
            "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-pUsageCounts-07335",
            |s, _, _| {
                let usage = at(s, &format!("{ATTACHMENT}/pUsageCounts")).clone();
                at(s, ATTACHMENT)["ppUsageCounts"] = usage;
            }
        ),
        // What the build reads.
        class!(
            "data offset past the data",
            "OMMCHECK-build-triangle-data-in-range",
            |s, w, r| {
                let m = pick(r, w.n);
                let past = w.data.len() as u64 + r.random_range(0..64u64);
                at(s, &format!("{TRIANGLES}/{m}"))["dataOffset"] = json!(past);
            }
        ),
        class!(
            "histogram disagrees with the triangle array",
            "OMMCHECK-build-usage-counts-match-triangles",
            |s, w, r| {
                let m = pick(r, w.n);
                at(s, &format!("{TRIANGLES}/{m}"))["subdivisionLevel"] =
                    json!(LEVEL - 1 - r.random_range(0..LEVEL));
            }
        ),
        class!(
            "triangle format",
            "VUID-VkMicromapBuildInfoEXT-format-11657",
            |s, w, r| {
                let m = pick(r, w.n);
                at(s, &format!("{TRIANGLES}/{m}"))["format"] = json!(r.random_range(3..1000));
            }
        ),
        class!(
            "triangle level above the limit",
            "VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11660",
            |s, w, r| {
                let m = pick(r, w.n);
                let triangle = at(s, &format!("{TRIANGLES}/{m}"));
                triangle["format"] = json!(2);
                triangle["subdivisionLevel"] = json!(r.random_range(4..=12));
            }
        ),
        class!(
            "triangle array past its buffer",
            "OMMCHECK-build-triangle-array-in-range",
            |s, w, r| {
                let short = r.random_range(1..=w.n.min(8)) * 8;
                at(s, "/buffers/1")["size"] = json!(w.n * 8 - short);
                let _ = at(s, TRIANGLES)
                    .as_array_mut()
                    .map(|t| t.truncate(w.n - short / 8));
            }
        ),
        class!(
            "opacity index past the micromap",
            "OMMCHECK-attach-index-in-range",
            |s, w, r| {
                let t = pick(r, w.n);
                at(s, &format!("{INDICES}/{t}"))
                    .clone_from(&json!(w.n as u64 + r.random_range(0..1000u64)));
            }
        ),
        class!(
            "micromap indices with a null micromap",
            "OMMCHECK-attach-null-micromap-special-only",
            |s, _, _| {
                at(s, ATTACHMENT)["micromap"] = Value::Null;
                at(s, ATTACHMENT)["pUsageCounts"] = json!([]);
            }
        ),
        class!(
            "attachment usage counts disagree with the indices",
            "OMMCHECK-attach-usage-counts-match-indices",
            |s, w, r| {
                let t = pick(r, w.n);
                at(s, &format!("{INDICES}/{t}"))
                    .clone_from(&json!(u32::MAX - r.random_range(0..4u32)));
            }
        ),
        class!(
            "misaligned index buffer",
            "OMMCHECK-attach-index-alignment",
            |s, w, r| {
                let _ = w;
                at(s, ATTACHMENT)["indexBuffer"] =
                    json!({"buffer": "omm-index", "offset": r.random_range(1..4)});
                at(s, ATTACHMENT)["indexStride"] = json!(4);
            }
        ),
        class!(
            "cluster-only special index",
            "OMMCHECK-attach-cluster-index-outside-cluster",
            |s, w, r| {
                let t = pick(r, w.n);
                at(s, &format!("{INDICES}/{t}")).clone_from(&json!(u32::MAX - 4));
            }
        ),
    ]
}

/// One planted fault and its valid twin.
pub struct FaultCase {
    pub class: &'static str,
    pub rule: &'static str,
    pub size: usize,
    pub faulty: Value,
    pub twin: Value,
}

/// The corpus: every class planted at every size, from `seed`.
pub fn corpus(seed: u64) -> Vec<FaultCase> {
    let mut rng = XorShiftRng::seed_from_u64(seed);
    let mut cases = Vec::new();
    for class in classes() {
        for size in SIZES {
            let workload = Workload::new(&mut rng, size);
            let twin = workload.scene();
            let mut faulty = twin.clone();
            (class.plant)(&mut faulty, &workload, &mut rng);
            cases.push(FaultCase {
                class: class.name,
                rule: class.rule,
                size,
                faulty,
                twin,
            });
        }
    }
    cases
}
