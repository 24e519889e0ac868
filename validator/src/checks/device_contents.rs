//! Device builds whose memory contents are read when their command buffer
//! is submitted. A `vkCmdBuild*` command is checked when it is recorded, but
//! the memory it reads (triangle arrays, micromap data, index buffers) is
//! what it holds when the GPU runs the command: an adaptor such as the layer
//! keeps the build's model ([`DeviceBuild`]) and, at submission, hands the
//! bytes it could read back as buffer contents
//! ([`Validator::check_device_build_contents`]), which reports what those
//! contents add to the findings of the recording.

use std::sync::Arc;

use crate::build_inputs::{indirect, read_instances, DeviceBuild, KnownBytes};
use crate::checks::accel_build;
use crate::checks::micromap_build;
use crate::checks::Validator;
use crate::model::accel::GeometryData;
use crate::model::CommandBuffer;
use crate::model::Handle;
use crate::report::Report;
use crate::sim::decode::MicromapContent;
use crate::tier::Tier;

impl Validator {
    /// The rules of a recorded device build against the state as it is,
    /// without recording anything.
    /// `name_unread`: device memory still unreadable is reported as not
    /// checked (else it is the adaptor's to report).
    fn device_build_rules(
        &self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        name_unread: bool,
    ) -> Report {
        let mut ctx = self.ctx(build.function());
        ctx.device_contents_later = !name_unread;
        match build {
            DeviceBuild::Micromaps(infos) => {
                micromap_build::cmd_build_micromaps_rules(&mut ctx, command_buffer, infos)
            }
            DeviceBuild::AccelerationStructures {
                infos,
                ranges,
                indirect,
                ..
            } => {
                // An indirect build's ranges are the GPU's to read: they
                // are known here only once read from device memory.
                let known = !indirect || ranges.iter().any(Option::is_some);
                let ranges = known.then_some(ranges.as_slice());
                accel_build::builds(&mut ctx, DeviceBuild::command(*indirect), infos, ranges);
            }
        }
        ctx.finish()
    }

    /// Checks what a recorded device build reads, now that `contents` (a
    /// known window of bytes of each buffer, by handle) are known: the
    /// build's rules run with the contents and without, and the findings
    /// only the contents bring are reported (those of the recording were
    /// reported then). Top-level builds' instances are read from the
    /// contents. The contents are forgotten after the check, except what
    /// the builds made: each destination's recorded content (micromap
    /// triangles and data, shared with these bytes) is replaced, so later
    /// builds that attach it see what the GPU built.
    pub fn check_device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> Report {
        self.device_build_contents(command_buffer, build, contents, false)
            .0
    }

    /// As [`Validator::check_device_build_contents`], and what an indirect
    /// build's range infos, decoded from `contents`, place outside them
    /// (see [`indirect::resolve`]): one sentence per input, for the
    /// adaptor to report as not checked. Empty for other builds.
    pub fn check_device_build_contents_unread(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> (Report, Vec<String>) {
        self.device_build_contents(command_buffer, build, contents, false)
    }

    /// As [`Validator::check_device_build_contents`], and the memory of
    /// `build` that `contents` does not cover is reported as not checked
    /// (`OMMCHECK-not-checked-*`, naming the rules it skips), for an adaptor
    /// that does not report unread memory itself.
    pub fn check_device_build_contents_naming_unread(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> Report {
        self.device_build_contents(command_buffer, build, contents, true)
            .0
    }

    fn device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
        name_unread: bool,
    ) -> (Report, Vec<String>) {
        let mut previous = Vec::with_capacity(contents.len());
        for known in contents {
            if let Some(mut buffer) = self.state.buffers.get_mut(&known.buffer) {
                let old_offset = std::mem::replace(&mut buffer.contents_offset, known.offset);
                previous.push((
                    known.buffer,
                    buffer.contents.replace(known.bytes),
                    old_offset,
                ));
            }
        }
        // Only instances geometries read their instances from the contents:
        // other builds are checked as recorded, without a copy.
        let reads_instances = match build {
            DeviceBuild::AccelerationStructures { infos, .. } => infos.iter().any(|info| {
                info.geometries
                    .iter()
                    .flatten()
                    .any(|g| matches!(g.geometry, GeometryData::Instances(_)))
            }),
            DeviceBuild::Micromaps(_) => false,
        };
        let recorded = build;
        // An indirect build's ranges, decoded from the contents.
        let (resolved, unread) =
            match indirect::resolve(build, |address, len| self.state.read_device(address, len)) {
                Some(resolved) => (Some(resolved.build), resolved.unread),
                None => (None, Vec::new()),
            };
        let build = resolved.as_ref().unwrap_or(build);
        let with_instances;
        let build = match build {
            DeviceBuild::AccelerationStructures {
                infos,
                ranges,
                indirect,
                indirect_ranges,
            } if reads_instances => {
                let mut infos = infos.clone();
                read_instances(&self.state, &mut infos, ranges, None);
                with_instances = DeviceBuild::AccelerationStructures {
                    infos,
                    ranges: ranges.clone(),
                    indirect: *indirect,
                    indirect_ranges: indirect_ranges.clone(),
                };
                &with_instances
            }
            _ => build,
        };
        let with = self.device_build_rules(command_buffer, build, name_unread);
        let built = self.built_contents(build);
        // Restored in reverse, so a buffer named twice gets its first value back.
        for (handle, old, old_offset) in previous.into_iter().rev() {
            if let Some(mut buffer) = self.state.buffers.get_mut(&handle) {
                buffer.contents = old;
                buffer.contents_offset = old_offset;
            }
        }
        // The findings of the recording (the rules without the contents,
        // which name no unread memory) were reported then. Most builds
        // checked here have no finding at all; only where there are some
        // do the rules run again without the contents to leave those out.
        let findings = if with.findings.is_empty() {
            with.findings
        } else {
            let without = self.device_build_rules(command_buffer, recorded, false);
            with.findings
                .into_iter()
                .filter(|finding| !without.findings.contains(finding))
                .collect()
        };
        self.record_built_contents(built);
        let report = Report {
            findings,
            checked: with.checked,
        };
        (report, unread)
    }

    /// The content of each destination the build made, where it could be
    /// read from the contents known now: by micromap or acceleration
    /// structure handle.
    fn built_contents(&self, build: &DeviceBuild) -> Vec<(Built, MicromapContent)> {
        match build {
            // Below the content tier a build's record keeps no content.
            DeviceBuild::Micromaps(_) if self.tier < Tier::Content => Vec::new(),
            DeviceBuild::Micromaps(infos) => infos
                .iter()
                .filter_map(|info| {
                    let content = micromap_build::built_content(&self.state, None, info)?;
                    Some((Built::Micromap(info.dst_micromap), content))
                })
                .collect(),
            DeviceBuild::AccelerationStructures { infos, .. } => infos
                .iter()
                .filter_map(|info| {
                    let content = info
                        .geometry_entries()
                        .1
                        .iter()
                        .find_map(|(_, g)| g.micromap.as_ref())
                        .and_then(|data| accel_build::micromap_content(&self.state, None, data))?;
                    Some((Built::Structure(info.dst_acceleration_structure), content))
                })
                .collect(),
        }
    }

    /// Replaces the recorded content of each destination the build made
    /// with what [`Validator::built_contents`] read, so later builds that
    /// attach it see what the GPU built.
    fn record_built_contents(&mut self, built: Vec<(Built, MicromapContent)>) {
        for (destination, content) in built {
            let record = match destination {
                Built::Micromap(handle) => self
                    .state
                    .micromaps
                    .get_mut(&handle)
                    .and_then(|m| m.built.as_mut()),
                Built::Structure(handle) => self
                    .state
                    .acceleration_structures
                    .get_mut(&handle)
                    .and_then(|s| s.built.as_mut()),
            };
            if let Some(record) = record {
                record.content = Some(Arc::new(content));
            }
        }
    }
}

/// A destination a device build made.
#[derive(Clone, Copy, Debug)]
enum Built {
    Micromap(Handle),
    Structure(Handle),
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::build_inputs::tests::instances_info;
    use crate::build_inputs::{strided_extent, Extent, ReadKind};
    use crate::model::accel::{
        BuildGeometryInfo, BuildRangeInfo, Geometry, TrianglesData, TrianglesOpacityMicromapExt,
        INDEX_TYPE_UINT32,
    };
    use crate::model::MicromapBuildInfo;
    use crate::state::{Buffer, BuildRecord, Micromap};
    use crate::Bytes;
    use crate::Device;

    /// A micromap of 2 triangles and a BLAS build whose EXT attachment reads
    /// two 32-bit indices from buffer 7 at device address 0x1000.
    fn validator_and_build() -> (Validator, DeviceBuild) {
        let mut validator = Validator::new(Device::default());
        let state = validator.state_mut();
        state.micromaps.insert(
            5,
            Micromap {
                built: Some(BuildRecord {
                    triangle_count: 2,
                    ..BuildRecord::default()
                }),
                ..Micromap::default()
            },
        );
        state.buffers.insert(
            7,
            Buffer {
                size: 8,
                device_address: Some(0x1000),
                ..Buffer::default()
            },
        );
        let triangles = TrianglesData {
            opacity_ext: Some(TrianglesOpacityMicromapExt {
                index_type: INDEX_TYPE_UINT32,
                index_buffer: 0x1000,
                index_stride: 4,
                micromap: 5,
                ..TrianglesOpacityMicromapExt::default()
            }),
            ..TrianglesData::default()
        };
        let info = BuildGeometryInfo {
            geometry_count: 1,
            geometries: Some(vec![Geometry {
                geometry: GeometryData::Triangles(triangles),
                ..Geometry::default()
            }]),
            ..BuildGeometryInfo::default()
        };
        let ranges = vec![Some(vec![BuildRangeInfo {
            primitive_count: 2,
            ..BuildRangeInfo::default()
        }])];
        let build = DeviceBuild::AccelerationStructures {
            infos: vec![info],
            ranges,
            indirect: false,
            indirect_ranges: Vec::new(),
        };
        (validator, build)
    }

    fn indices(values: [u32; 2]) -> Bytes {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    fn known(buffer: Handle, offset: u64, bytes: Bytes) -> Vec<KnownBytes> {
        vec![KnownBytes {
            buffer,
            offset,
            bytes,
        }]
    }

    #[test]
    fn the_index_buffer_is_read_for_its_primitive_count() {
        let (_, build) = validator_and_build();
        let reads = build.content_reads();
        assert_eq!(reads.len(), 1);
        assert_eq!(reads[0].address, 0x1000);
        assert_eq!(reads[0].extent, Extent::Bytes(8));
        assert_eq!(reads[0].kind, ReadKind::OpacityIndices);
        assert!(reads[0]
            .location
            .ends_with("pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer"));
    }

    #[test]
    fn micromap_builds_read_their_triangle_array_and_data_to_the_buffer_end() {
        let counts = crate::model::UsageCounts::array(vec![crate::model::MicromapUsage {
            count: 3,
            subdivision_level: 0,
            format: 1,
        }]);
        let build = DeviceBuild::Micromaps(vec![MicromapBuildInfo {
            usage_counts: counts,
            triangle_array: 0x2000,
            triangle_array_stride: 12,
            data: 0x3000,
            ..MicromapBuildInfo::default()
        }]);
        let reads = build.content_reads();
        assert_eq!(reads.len(), 2);
        // Two strides and the last entry's 8 bytes.
        assert_eq!(
            (reads[0].address, reads[0].extent),
            (0x2000, Extent::Bytes(32))
        );
        assert_eq!(
            (reads[1].address, reads[1].extent),
            (0x3000, Extent::ToBufferEnd)
        );
        assert_eq!(strided_extent(u64::MAX, u64::MAX, 8), Extent::Overflow);
    }

    /// A top-level build of one instances geometry of `count` instances (or
    /// pointers) at device address 0x8000 + 64.
    fn top_level_build(pointers: bool, count: u32) -> DeviceBuild {
        let info = instances_info(pointers, 0x8000);
        DeviceBuild::AccelerationStructures {
            infos: vec![info],
            ranges: vec![Some(vec![BuildRangeInfo {
                primitive_count: count,
                primitive_offset: 64,
                ..BuildRangeInfo::default()
            }])],
            indirect: false,
            indirect_ranges: Vec::new(),
        }
    }

    fn instance_bytes(flags: u8, reference: u64) -> Vec<u8> {
        let mut bytes = vec![0u8; 64];
        bytes[55] = flags;
        bytes[56..].copy_from_slice(&reference.to_le_bytes());
        bytes
    }

    #[test]
    fn instances_are_read_from_the_primitive_offset_and_their_flags_checked() {
        let build = top_level_build(false, 2);
        let reads = build.content_reads();
        assert_eq!(reads.len(), 1);
        assert_eq!(
            (reads[0].address, reads[0].extent),
            (0x8040, Extent::Bytes(128))
        );
        assert_eq!(reads[0].kind, ReadKind::Instances);

        let mut validator = Validator::new(Device::default());
        validator.state_mut().buffers.insert(
            9,
            Buffer {
                size: 256,
                device_address: Some(0x8000),
                ..Buffer::default()
            },
        );
        let cb = CommandBuffer::default();
        // Only the instances' window is known: bytes 64..192 of the buffer.
        let mut window = instance_bytes(0, 0x1);
        window.extend(instance_bytes(0x10, 0x1)); // FORCE_OPACITY_MICROMAP_2_STATE
        let report =
            validator.check_device_build_contents(&cb, &build, known(9, 64, window.into()));
        let found: Vec<(&str, &str)> = report
            .findings
            .iter()
            .map(|f| (f.rule.as_str(), f.location.as_str()))
            .collect();
        assert_eq!(
            found,
            [(
                "VUID-VkAccelerationStructureInstanceKHR-micromap-11580",
                "pInfos[0].pGeometries[0].geometry.instances.data[1].flags"
            )],
            "{report:#?}"
        );
        let valid = instance_bytes(0, 0x1).repeat(2);
        let report = validator.check_device_build_contents(&cb, &build, known(9, 64, valid.into()));
        assert!(report.findings.is_empty(), "{report:#?}");
        // A window that misses the second instance decides nothing.
        let short = instance_bytes(0x10, 0x1);
        let report = validator.check_device_build_contents(&cb, &build, known(9, 64, short.into()));
        assert!(report.findings.is_empty(), "{report:#?}");
    }

    #[test]
    fn instance_pointers_are_followed_into_known_contents() {
        let build = top_level_build(true, 2);
        assert_eq!(build.content_reads()[0].extent, Extent::Bytes(16));
        let mut validator = Validator::new(Device::default());
        validator.state_mut().buffers.insert(
            9,
            Buffer {
                size: 512,
                device_address: Some(0x8000),
                ..Buffer::default()
            },
        );
        // Pointers at 0x8040: NULL and 0x8100; the instance at 0x8100.
        let mut bytes = vec![0u8; 512];
        bytes[72..80].copy_from_slice(&0x8100u64.to_le_bytes());
        bytes[256..320].copy_from_slice(&instance_bytes(0x20, 0x1));
        let cb = CommandBuffer::default();
        let report = validator.check_device_build_contents(&cb, &build, known(9, 0, bytes.into()));
        assert_eq!(
            report
                .findings
                .iter()
                .map(|f| f.location.as_str())
                .collect::<Vec<_>>(),
            ["pInfos[0].pGeometries[0].geometry.instances.data[1].flags"],
            "{report:#?}"
        );
    }

    #[test]
    fn only_findings_the_contents_bring_are_reported_and_contents_are_forgotten() {
        let (mut validator, build) = validator_and_build();
        let cb = CommandBuffer::default();
        let report =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 2])));
        let ids: Vec<&str> = report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-attach-index-in-range"], "{report:#?}");
        assert_eq!(
            report.findings[0].function,
            "vkCmdBuildAccelerationStructuresKHR"
        );
        assert_eq!(validator.state().buffers[&7].contents, None);

        let valid =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 1])));
        assert!(valid.findings.is_empty(), "{valid:#?}");
    }

    /// A parameter fault the recording reported is not reported again
    /// beside what the contents bring, and not at all when they bring
    /// nothing.
    #[test]
    fn the_recordings_findings_are_not_reported_again() {
        let (mut validator, mut build) = validator_and_build();
        // Both usage-count pointers set (07335), each with no element.
        if let DeviceBuild::AccelerationStructures { infos, .. } = &mut build {
            for geometry in infos[0].geometries.iter_mut().flatten() {
                if let GeometryData::Triangles(t) = &mut geometry.geometry {
                    let counts = &mut t.opacity_ext.as_mut().expect("attached").usage_counts;
                    counts.array = Some(Vec::new());
                    counts.pointers = Some(Vec::new());
                }
            }
        }
        let cb = CommandBuffer::default();
        let recorded = validator.check_device_build_contents(&cb, &build, Vec::new());
        assert!(recorded.findings.is_empty(), "{recorded:#?}");
        let report =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 2])));
        let ids: Vec<&str> = report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-attach-index-in-range"], "{report:#?}");
        let valid =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 1])));
        assert!(valid.findings.is_empty(), "{valid:#?}");
        // The fault is there: the rules report it where nothing filters it.
        let all = validator.device_build_rules(&cb, &build, false);
        assert!(
            all.findings.iter().any(|f| f.rule.as_str()
                == "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-pUsageCounts-07335"),
            "{all:#?}"
        );
    }

    #[test]
    fn unread_memory_is_named_only_when_asked() {
        let (mut validator, build) = validator_and_build();
        let cb = CommandBuffer::default();
        let silent = validator.check_device_build_contents(&cb, &build, Vec::new());
        assert!(silent.findings.is_empty(), "{silent:#?}");
        let named = validator.check_device_build_contents_naming_unread(&cb, &build, Vec::new());
        let ids: Vec<&str> = named.findings.iter().map(|f| f.rule.as_str()).collect();
        // The index buffer is unread, and micromap 5 is known only by its
        // triangle count.
        assert_eq!(
            ids,
            [
                "OMMCHECK-not-checked-contents",
                "OMMCHECK-not-checked-build-not-seen"
            ],
            "{named:#?}"
        );
        assert!(named.findings[0]
            .not_checked
            .contains(&(&crate::rules::INDEX_IN_RANGE).into()));
        let read = validator.check_device_build_contents_naming_unread(
            &cb,
            &build,
            known(7, 0, indices([0, 1])),
        );
        let ids: Vec<&str> = read.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-not-checked-build-not-seen"], "{read:#?}");
    }
}
