//! Valid micromap workloads the benchmarks share: N micromap triangles at
//! subdivision level L in the 2-state or 4-state format, built through
//! `vkCmdBuildMicromapsEXT` (EXT) or `vkCmdBuildAccelerationStructuresKHR`
//! of type OPACITY_MICROMAP (KHR), and bottom-level builds whose opacity
//! attachment references a share of a built micromap's triangles.
//!
//! Every workload is checked once when it is prepared and must report
//! nothing: a benchmark measures checking, not the formatting of findings.

// Each bench target uses a part of this module.
#![allow(dead_code)]

use criterion::{BatchSize, Bencher};
use ommcheck::model::accel::*;
use ommcheck::model::micromap::opacity_triangle_bytes;
use ommcheck::model::values::*;
use ommcheck::model::{
    CommandBuffer, MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts,
};
use ommcheck::state::{Buffer, MemoryBinding, Micromap};
use ommcheck::{Device, Profile, Report, Tier, Validator};

/// Buffers, each at its own 4 GiB-aligned device address (so every
/// alignment rule holds and no two ranges meet); their handles lie between
/// those of [`track_other_buffers`], as an application's would among its
/// other buffers.
const DATA: u64 = 0x8000_00d1;
const DATA_ADDRESS: u64 = 1 << 32;
const TRIANGLES: u64 = 0x8000_00d2;
const TRIANGLES_ADDRESS: u64 = 2 << 32;
const INDICES: u64 = 0x8000_00d3;
const INDICES_ADDRESS: u64 = 3 << 32;
const VERTICES: u64 = 0x8000_00d4;
const VERTICES_ADDRESS: u64 = 4 << 32;
const SCRATCH: u64 = 0x8000_00d5;
const SCRATCH_ADDRESS: u64 = 5 << 32;
const STORAGE: u64 = 0x8000_00d6;
const STORAGE_ADDRESS: u64 = 6 << 32;
const STORAGE_SIZE: u64 = 0x10_0000;
/// The EXT micromap (`VkMicromapEXT`) builds write.
const EXT_MICROMAP: u64 = 0xe1;
/// The KHR micromap (an acceleration structure of type OPACITY_MICROMAP).
const KHR_MICROMAP: u64 = 0xe2;
const KHR_MICROMAP_OFFSET: u64 = 0x4_0000;
/// The bottom-level structure the referencing builds write.
const BLAS: u64 = 0xe3;
const BLAS_OFFSET: u64 = 0x8_0000;

/// The most bytes of data a workload holds (a level-12 4-state block is 4
/// MiB: at most 4 distinct ones).
pub const MAX_DATA_BYTES: u64 = 16 << 20;

/// Which API builds the micromap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Api {
    /// `vkCmdBuildMicromapsEXT` into a `VkMicromapEXT`.
    Ext,
    /// `vkCmdBuildAccelerationStructuresKHR` of type OPACITY_MICROMAP.
    Khr,
}

impl Api {
    pub const ALL: [Api; 2] = [Api::Ext, Api::Khr];

    pub fn name(self) -> &'static str {
        match self {
            Api::Ext => "ext",
            Api::Khr => "khr",
        }
    }
}

/// `VkOpacityMicromapFormatKHR`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    TwoState,
    FourState,
}

impl Format {
    pub const ALL: [Format; 2] = [Format::TwoState, Format::FourState];

    pub fn name(self) -> &'static str {
        match self {
            Format::TwoState => "2state",
            Format::FourState => "4state",
        }
    }

    pub fn value(self) -> u32 {
        match self {
            Format::TwoState => OPACITY_MICROMAP_FORMAT_2_STATE,
            Format::FourState => OPACITY_MICROMAP_FORMAT_4_STATE,
        }
    }

    fn bits_per_state(self) -> u64 {
        match self {
            Format::TwoState => 1,
            Format::FourState => 2,
        }
    }
}

/// N micromap triangles at one subdivision level and format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MicromapWorkload {
    pub triangles: u32,
    pub level: u16,
    pub format: Format,
}

impl MicromapWorkload {
    pub fn new(triangles: u32, level: u16, format: Format) -> Self {
        Self {
            triangles,
            level,
            format,
        }
    }

    /// The most triangles at `level` whose triangle array fits `budget`
    /// bytes (what the content tier reads of a build), at most `cap` and
    /// at least 1. The data stays within [`MAX_DATA_BYTES`] whatever N (see
    /// [`Self::distinct_blocks`]), so every workload is bounded in memory.
    pub fn within_budget(level: u16, format: Format, budget: u64, cap: u32) -> Self {
        let triangles = (budget / MicromapTriangle::SIZE).clamp(1, u64::from(cap));
        Self::new(triangles as u32, level, format)
    }

    /// Bytes of one triangle's data: ceil(4^L * bits / 8).
    pub fn block_bytes(&self) -> u64 {
        opacity_triangle_bytes(self.format.value(), u32::from(self.level))
            .expect("levels 0 to 12 have a size")
    }

    /// How many different blocks the data holds: one per triangle where
    /// the block's used bits can tell that many apart and the blocks fit
    /// [`MAX_DATA_BYTES`]; otherwise triangles share blocks (same offset),
    /// as real micromaps do at levels 0 and 1 (at most 8 used bits; the
    /// hygiene rules report identical blocks stored twice, not shared).
    pub fn distinct_blocks(&self) -> u64 {
        let used_bits = (1u64 << (2 * u32::from(self.level))) * self.format.bits_per_state();
        let representable = 1u64 << used_bits.min(32);
        let fitting = (MAX_DATA_BYTES / self.block_bytes()).max(1);
        u64::from(self.triangles).min(representable).min(fitting)
    }

    /// Bytes of the data buffer.
    pub fn data_bytes(&self) -> u64 {
        self.distinct_blocks() * self.block_bytes()
    }

    /// Bytes the content tier reads for one build: every entry of the
    /// triangle array. It measures each triangle's data block against the
    /// data's memory but reads no byte of it (the hygiene information,
    /// which does, runs at the simulate tier).
    pub fn bytes_read(&self) -> u64 {
        u64::from(self.triangles) * MicromapTriangle::SIZE
    }

    /// Triangle `m` uses block `m mod distinct_blocks`.
    pub fn triangle(&self, m: u64) -> MicromapTriangle {
        let block = m % self.distinct_blocks();
        MicromapTriangle {
            data_offset: u32::try_from(block * self.block_bytes()).expect("data under 4 GiB"),
            subdivision_level: self.level,
            format: self.format.value() as u16,
        }
    }

    pub fn triangle_array(&self) -> Vec<u8> {
        (0..u64::from(self.triangles))
            .flat_map(|m| self.triangle(m).to_bytes())
            .collect()
    }

    /// The data: block d starts with d in its used bits (so no two blocks
    /// are equal and unused bits are zero), then bytes of a fixed
    /// pseudo-random pattern, as real opacity data looks to a reader.
    pub fn data(&self) -> Vec<u8> {
        let size = self.block_bytes() as usize;
        let mut data = vec![0u8; self.data_bytes() as usize];
        let mut pattern = 0x9e37_79b9_7f4a_7c15u64;
        for (d, block) in data.chunks_exact_mut(size).enumerate() {
            let prefix = (d as u64).to_le_bytes();
            let n = size.min(8);
            block[..n].copy_from_slice(&prefix[..n]);
            for byte in &mut block[n..] {
                pattern ^= pattern << 13;
                pattern ^= pattern >> 7;
                pattern ^= pattern << 17;
                *byte = pattern as u8;
            }
        }
        data
    }

    /// The usage counts that describe the triangle array.
    pub fn usage_counts(&self) -> UsageCounts {
        self.usage_counts_in(1)
    }

    /// The usage counts that describe the triangle array in `entries`
    /// entries: its one (format, level) repeated (the specification allows
    /// it), the triangles split as evenly as they go. Real builds carry one
    /// entry per (format, level) in use.
    pub fn usage_counts_in(&self, entries: u32) -> UsageCounts {
        UsageCounts::array(
            (0..entries)
                .map(|k| MicromapUsage {
                    count: self.triangles / entries + u32::from(k < self.triangles % entries),
                    subdivision_level: u32::from(self.level),
                    format: self.format.value(),
                })
                .collect(),
        )
    }

    /// `VkMicromapBuildInfoEXT` of the workload into [`EXT_MICROMAP`].
    pub fn ext_build(&self) -> MicromapBuildInfo {
        MicromapBuildInfo {
            dst_micromap: EXT_MICROMAP,
            usage_counts: self.usage_counts(),
            data: DATA_ADDRESS,
            triangle_array: TRIANGLES_ADDRESS,
            triangle_array_stride: MicromapTriangle::SIZE,
            scratch_data: SCRATCH_ADDRESS,
            ..Default::default()
        }
    }

    /// The OPACITY_MICROMAP build of the workload into [`KHR_MICROMAP`].
    pub fn khr_build(&self) -> BuildGeometryInfo {
        let geometry = Geometry {
            geometry_type: GEOMETRY_TYPE_MICROMAP,
            geometry: GeometryData::None,
            micromap: Some(GeometryMicromapData {
                usage_counts: self.usage_counts(),
                data: DATA_ADDRESS,
                triangle_array: TRIANGLES_ADDRESS,
                triangle_array_stride: MicromapTriangle::SIZE,
                ..Default::default()
            }),
            ..Default::default()
        };
        BuildGeometryInfo {
            dst_acceleration_structure: KHR_MICROMAP,
            scratch_data: SCRATCH_ADDRESS,
            ..BuildGeometryInfo::with_geometries(
                ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
                vec![geometry],
            )
        }
    }
}

/// A buffer bound to memory at device address `address`.
fn bound_buffer(address: u64, size: u64, usage: u64, contents: Option<Vec<u8>>) -> Buffer {
    Buffer {
        // A buffer of size 0 is invalid; an empty workload still has one byte.
        size: size.max(1),
        usage,
        device_address: Some(address),
        memory: Some(MemoryBinding::default()),
        contents: contents.map(ommcheck::Bytes::from),
        ..Default::default()
    }
}

/// A buffer that micromap and acceleration-structure builds may read.
fn input_buffer(address: u64, size: u64, contents: Option<Vec<u8>>) -> Buffer {
    let usage = BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT
        | BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR;
    bound_buffer(address, size, usage, contents)
}

/// A device with every micromap feature and level-12 limits, the
/// workload's data and triangle array in buffers with contents, scratch
/// and storage buffers, an EXT micromap and a KHR micromap to build into,
/// and a bottom-level structure to build into; checks at `tier`.
pub fn world(workload: &MicromapWorkload, tier: Tier) -> Validator {
    let mut v = Validator::new(Device::with_everything(Profile::Permissive));
    let state = v.state_mut();
    state.buffers.insert(
        DATA,
        input_buffer(DATA_ADDRESS, workload.data_bytes(), Some(workload.data())),
    );
    let array = workload.triangle_array();
    state.buffers.insert(
        TRIANGLES,
        input_buffer(TRIANGLES_ADDRESS, array.len() as u64, Some(array)),
    );
    let scratch = bound_buffer(
        SCRATCH_ADDRESS,
        0x10_0000,
        BUFFER_USAGE_STORAGE_BUFFER_BIT,
        None,
    );
    state.buffers.insert(SCRATCH, scratch);
    let storage_usage =
        BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT | BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR;
    let storage = bound_buffer(STORAGE_ADDRESS, STORAGE_SIZE, storage_usage, None);
    state.buffers.insert(STORAGE, storage);
    state.micromaps.insert(
        EXT_MICROMAP,
        Micromap {
            buffer: STORAGE,
            size: 0x1_0000,
            ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
            ..Default::default()
        },
    );
    let setup = [
        v.create_acceleration_structure2(
            &AccelerationStructureCreateInfo2 {
                address: STORAGE_ADDRESS + KHR_MICROMAP_OFFSET,
                size: 0x1_0000,
                ..Default::default()
            },
            KHR_MICROMAP,
        ),
        v.create_acceleration_structure(
            &AccelerationStructureCreateInfo {
                buffer: STORAGE,
                offset: BLAS_OFFSET,
                size: 0x1_0000,
                ..Default::default()
            },
            BLAS,
        ),
    ];
    for report in setup {
        assert_clean("creating the acceleration structures", &report);
    }
    v.set_tier(tier);
    v
}

/// Panics with the findings unless `report` has none.
pub fn assert_clean(what: &str, report: &Report) {
    assert!(
        report.is_empty(),
        "{what} is not valid; a benchmark of it would measure error reporting:\n{report}"
    );
}

/// Where [`track_other_buffers`] puts its buffers: above every workload
/// buffer, so none of them holds an address a workload build names.
const OTHER_BUFFERS_ADDRESS: u64 = 16 << 32;
/// Half of the other buffers' handles are below the workload's, half above.
const OTHER_BUFFERS_HANDLE_BELOW: u64 = 0x1_0000;
const OTHER_BUFFERS_HANDLE_ABOVE: u64 = 0x1_0000_0000;

/// Tracks `count` more bound buffers of 64 KiB, each at its own address
/// and none holding the workload's addresses: the application's other
/// buffers, which a state-tier check must not pay for when it resolves an
/// address.
pub fn track_other_buffers(validator: &mut Validator, count: u64) {
    let buffers = &mut validator.state_mut().buffers;
    for i in 0..count {
        let base = if i % 2 == 0 {
            OTHER_BUFFERS_HANDLE_BELOW
        } else {
            OTHER_BUFFERS_HANDLE_ABOVE
        };
        buffers.insert(
            base + i,
            bound_buffer(
                OTHER_BUFFERS_ADDRESS + i * 0x1_0000,
                0x1_0000,
                BUFFER_USAGE_STORAGE_BUFFER_BIT,
                None,
            ),
        );
    }
}

/// One micromap build, ready to be checked again and again: a prepared
/// validator to clone and the call's parameters.
pub struct MicromapBuild {
    pub validator: Validator,
    pub api: Api,
    ext: MicromapBuildInfo,
    khr: BuildGeometryInfo,
}

impl MicromapBuild {
    /// The workload's build through `api`, checked once here at the content
    /// tier so that it is known to be valid; `validator.set_tier` picks the
    /// tier the benchmark checks at.
    pub fn new(workload: &MicromapWorkload, api: Api) -> Self {
        let mut validator = world(workload, Tier::Content);
        let build = Self {
            validator: validator.clone(),
            api,
            ext: workload.ext_build(),
            khr: workload.khr_build(),
        };
        assert_clean(
            &format!("{} build of {workload:?}", api.name()),
            &build.check(&mut validator),
        );
        build
    }

    /// The build with its usage counts in `entries` entries (see
    /// [`MicromapWorkload::usage_counts_in`]), checked once at the content
    /// tier so that it is known to be valid.
    pub fn with_usage_entries(mut self, workload: &MicromapWorkload, entries: u32) -> Self {
        let counts = workload.usage_counts_in(entries);
        self.ext.usage_counts = counts.clone();
        for geometry in self.khr.geometries.iter_mut().flatten() {
            if let Some(micromap) = &mut geometry.micromap {
                micromap.usage_counts = counts.clone();
            }
        }
        let mut validator = self.validator.clone();
        validator.set_tier(Tier::Content);
        assert_clean(
            &format!("{} build in {entries} usage entries", self.api.name()),
            &self.check(&mut validator),
        );
        self
    }

    /// Checks the build on `validator` (which records it).
    pub fn check(&self, validator: &mut Validator) -> Report {
        match self.api {
            Api::Ext => validator
                .cmd_build_micromaps(&CommandBuffer::default(), std::slice::from_ref(&self.ext)),
            Api::Khr => validator.cmd_build_acceleration_structures(
                &CommandBuffer::default(),
                std::slice::from_ref(&self.khr),
                &[None],
            ),
        }
    }
}

/// A bottom-level build of one triangles geometry whose opacity attachment
/// references `referenced` of a built micromap's triangles (indices spread
/// evenly over the micromap), with primitiveCount = `referenced`.
pub struct ReferencingBuild {
    pub validator: Validator,
    build: BuildGeometryInfo,
    ranges: Vec<Option<Vec<BuildRangeInfo>>>,
}

impl ReferencingBuild {
    /// `micromap` built through `api`, then the bottom-level build; both
    /// are checked once here at the content tier so that they are known to
    /// be valid; `validator.set_tier` picks the tier the benchmark checks at.
    pub fn new(micromap: &MicromapWorkload, referenced: u32, api: Api) -> Self {
        Self::with_index_bytes(micromap, referenced, api, 4)
    }

    /// As [`Self::new`], with `index_bytes`-byte (2 or 4) opacity indices.
    pub fn with_index_bytes(
        micromap: &MicromapWorkload,
        referenced: u32,
        api: Api,
        index_bytes: usize,
    ) -> Self {
        let index_type = match index_bytes {
            2 => INDEX_TYPE_UINT16,
            4 => INDEX_TYPE_UINT32,
            _ => panic!("opacity indices of 2 or 4 bytes, not {index_bytes}"),
        };
        assert!(
            (1..=micromap.triangles).contains(&referenced),
            "a geometry references 1 to {} triangles",
            micromap.triangles
        );
        let micromap_build = MicromapBuild::new(micromap, api);
        let mut validator = micromap_build.validator.clone();
        assert_clean("the micromap build", &micromap_build.check(&mut validator));

        let spacing = micromap.triangles / referenced;
        let indices: Vec<u8> = (0..referenced)
            .flat_map(|j| (j * spacing).to_le_bytes()[..index_bytes].to_vec())
            .collect();
        assert!(
            index_bytes == 4 || micromap.triangles <= 0xFFFB,
            "16-bit indices select at most 0xFFFB triangles"
        );
        let vertex_bytes = 3 * 12 * u64::from(referenced);
        let state = validator.state_mut();
        state.buffers.insert(
            INDICES,
            input_buffer(INDICES_ADDRESS, indices.len() as u64, Some(indices)),
        );
        // The build checks read no vertex: the buffer has no contents.
        state
            .buffers
            .insert(VERTICES, input_buffer(VERTICES_ADDRESS, vertex_bytes, None));

        let triangles = TrianglesData {
            vertex_data: VERTICES_ADDRESS,
            max_vertex: 3 * referenced - 1,
            ..Default::default()
        };
        let triangles = match api {
            Api::Ext => TrianglesData {
                opacity_ext: Some(TrianglesOpacityMicromapExt {
                    index_type,
                    index_stride: index_bytes as u64,
                    index_buffer: INDICES_ADDRESS,
                    usage_counts: MicromapWorkload {
                        triangles: referenced,
                        ..*micromap
                    }
                    .usage_counts(),
                    micromap: EXT_MICROMAP,
                    ..Default::default()
                }),
                ..triangles
            },
            Api::Khr => TrianglesData {
                opacity_khr: Some(TrianglesOpacityMicromapKhr {
                    index_type,
                    index_stride: index_bytes as u64,
                    index_buffer: INDICES_ADDRESS,
                    micromap: KHR_MICROMAP,
                    ..Default::default()
                }),
                ..triangles
            },
        };
        let geometry = Geometry {
            geometry: GeometryData::Triangles(triangles),
            ..Default::default()
        };
        let build = BuildGeometryInfo {
            dst_acceleration_structure: BLAS,
            scratch_data: SCRATCH_ADDRESS,
            ..BuildGeometryInfo::with_geometries(
                ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
                vec![geometry],
            )
        };
        let ranges = vec![Some(vec![BuildRangeInfo {
            primitive_count: referenced,
            ..Default::default()
        }])];
        let prepared = Self {
            validator,
            build,
            ranges,
        };
        let mut check = prepared.validator.clone();
        assert_clean("the bottom-level build", &prepared.check(&mut check));
        prepared
    }

    /// The EXT attachment's usage counts in `entries` entries (see
    /// [`MicromapWorkload::usage_counts_in`]; KHR attachments have none),
    /// checked once at the content tier so that it is known to be valid.
    pub fn with_usage_entries(mut self, referenced: &MicromapWorkload, entries: u32) -> Self {
        for geometry in self.build.geometries.iter_mut().flatten() {
            if let GeometryData::Triangles(t) = &mut geometry.geometry {
                if let Some(ext) = &mut t.opacity_ext {
                    ext.usage_counts = referenced.usage_counts_in(entries);
                }
            }
        }
        let mut validator = self.validator.clone();
        validator.set_tier(Tier::Content);
        assert_clean(
            &format!("the bottom-level build in {entries} usage entries"),
            &self.check(&mut validator),
        );
        self
    }

    pub fn check(&self, validator: &mut Validator) -> Report {
        validator.cmd_build_acceleration_structures(
            &CommandBuffer::default(),
            std::slice::from_ref(&self.build),
            &self.ranges,
        )
    }
}

/// Times `check` on a fresh clone of `prepared` per iteration: the clone
/// is made, and the validator with what the call recorded is dropped,
/// outside the timing.
pub fn time_check(
    b: &mut Bencher<'_>,
    prepared: &Validator,
    check: impl Fn(&mut Validator) -> Report,
    batch: BatchSize,
) {
    b.iter_batched_ref(|| prepared.clone(), |validator| check(validator), batch)
}
