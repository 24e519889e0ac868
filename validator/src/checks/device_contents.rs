//! Device builds whose memory contents are read when their command buffer
//! is submitted. A `vkCmdBuild*` command is checked when it is recorded, but
//! the memory it reads (triangle arrays, micromap data, index buffers) is
//! what it holds when the GPU runs the command: an adaptor such as the layer
//! keeps the build's model ([`DeviceBuild`]) and, at submission, hands the
//! bytes it could read back as buffer contents
//! ([`Validator::check_device_build_contents`]), which reports what those
//! contents add to the findings of the recording.

use std::sync::Arc;

use crate::checks::accel_build::{self, BuildCommand};
use crate::checks::micromap_build;
use crate::model::accel::{BuildGeometryInfo, BuildRangeInfo, GeometryData};
use crate::model::accel::{INDEX_TYPE_UINT16, INDEX_TYPE_UINT32, INDEX_TYPE_UINT8};
use crate::model::{CommandBuffer, MicromapBuildInfo};
use crate::report::Report;
use crate::sim::decode::MicromapContent;
use crate::state::Handle;
use crate::validator::Validator;

/// A device build command as recorded, in the owned model.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceBuild {
    /// `vkCmdBuildMicromapsEXT`'s `pInfos`.
    Micromaps(Vec<MicromapBuildInfo>),
    /// `vkCmdBuildAccelerationStructuresKHR`'s `pInfos` and `ppBuildRangeInfos`.
    AccelerationStructures {
        infos: Vec<BuildGeometryInfo>,
        ranges: Vec<Option<Vec<BuildRangeInfo>>>,
    },
}

/// Device memory whose contents a build's checks read: where it starts and
/// which parameter names it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ContentSource {
    pub address: u64,
    pub location: String,
}

impl DeviceBuild {
    /// The command that recorded the build.
    pub fn function(&self) -> &'static str {
        match self {
            DeviceBuild::Micromaps(_) => "vkCmdBuildMicromapsEXT",
            DeviceBuild::AccelerationStructures { .. } => BuildCommand::Cmd.function(),
        }
    }

    /// The device memory whose contents the build's content rules read:
    /// micromap triangle arrays and data, and opacity attachments' index
    /// buffers (an index type of NONE reads none). NULL addresses are left
    /// out: the recording's rules report them.
    pub fn content_sources(&self) -> Vec<ContentSource> {
        let mut sources = Vec::new();
        let mut add = |address: u64, location: String| {
            if address != 0 {
                sources.push(ContentSource { address, location });
            }
        };
        match self {
            DeviceBuild::Micromaps(infos) => {
                for (i, info) in infos.iter().enumerate() {
                    add(info.triangle_array, format!("pInfos[{i}].triangleArray"));
                    add(info.data, format!("pInfos[{i}].data"));
                }
            }
            DeviceBuild::AccelerationStructures { infos, .. } => {
                for (i, info) in infos.iter().enumerate() {
                    let (member, geometries) = info.geometry_entries();
                    for (g, geometry) in geometries {
                        let at = format!("pInfos[{i}].{member}[{g}]");
                        if let Some(m) = &geometry.micromap {
                            let data = format!(
                                "{at}.pNext<VkAccelerationStructureGeometryMicromapDataKHR>"
                            );
                            add(m.triangle_array, format!("{data}.triangleArray"));
                            add(m.data, format!("{data}.data"));
                        }
                        let GeometryData::Triangles(t) = &geometry.geometry else {
                            continue;
                        };
                        for buffer in t.opacity_index_buffers() {
                            if matches!(
                                buffer.index_type,
                                INDEX_TYPE_UINT8 | INDEX_TYPE_UINT16 | INDEX_TYPE_UINT32
                            ) {
                                add(
                                    buffer.address,
                                    format!(
                                        "{at}.geometry.triangles.pNext<{}>.indexBuffer",
                                        buffer.structure
                                    ),
                                );
                            }
                        }
                    }
                }
            }
        }
        sources
    }
}

impl Validator {
    /// The rules of a recorded device build against the state as it is,
    /// without recording anything; with each micromap info's content as far
    /// as it could be read.
    /// `name_unread`: device memory still unreadable is reported as not
    /// checked (else it is the adaptor's to report).
    fn device_build_rules(
        &self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        name_unread: bool,
    ) -> (Report, Vec<Option<MicromapContent>>) {
        let mut ctx = self.ctx(build.function());
        ctx.device_contents_later = !name_unread;
        let contents = match build {
            DeviceBuild::Micromaps(infos) => {
                micromap_build::cmd_build_micromaps_rules(&mut ctx, command_buffer, infos)
            }
            DeviceBuild::AccelerationStructures { infos, ranges } => {
                accel_build::builds(&mut ctx, BuildCommand::Cmd, infos, Some(ranges));
                Vec::new()
            }
        };
        (ctx.finish(), contents)
    }

    /// Checks what a recorded device build reads, now that `contents` (bytes
    /// from the start of each buffer, by handle) are known: the build's rules
    /// run with the contents and without, and the findings only the contents
    /// bring are reported (those of the recording were reported then). The
    /// contents are forgotten after the check, except what the builds made:
    /// each destination's recorded content (micromap triangles and data,
    /// shared with these bytes) is replaced, so later builds that attach it
    /// see what the GPU built.
    pub fn check_device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<(Handle, Arc<[u8]>)>,
    ) -> Report {
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
        contents: Vec<(Handle, Arc<[u8]>)>,
    ) -> Report {
        self.device_build_contents(command_buffer, build, contents, true)
    }

    fn device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<(Handle, Arc<[u8]>)>,
        name_unread: bool,
    ) -> Report {
        // The recording's findings: no unread memory is named there.
        let (without, _) = self.device_build_rules(command_buffer, build, false);
        let mut previous = Vec::new();
        for (handle, bytes) in contents {
            if let Some(mut buffer) = self.state.buffers.get_mut(&handle) {
                previous.push((handle, buffer.contents.replace(bytes)));
            }
        }
        let (with, micromap_contents) = self.device_build_rules(command_buffer, build, name_unread);
        self.record_built_contents(build, micromap_contents);
        // Restored in reverse, so a buffer named twice gets its first value back.
        for (handle, old) in previous.into_iter().rev() {
            if let Some(mut buffer) = self.state.buffers.get_mut(&handle) {
                buffer.contents = old;
            }
        }
        Report {
            findings: with
                .findings
                .into_iter()
                .filter(|finding| !without.findings.contains(finding))
                .collect(),
            checked: with.checked,
        }
    }

    /// Replaces the recorded content of each destination the build made,
    /// where its content could be read now.
    fn record_built_contents(
        &mut self,
        build: &DeviceBuild,
        micromap_contents: Vec<Option<MicromapContent>>,
    ) {
        match build {
            DeviceBuild::Micromaps(infos) => {
                for (info, content) in infos.iter().zip(micromap_contents) {
                    let built = self
                        .state
                        .micromaps
                        .get_mut(&info.dst_micromap)
                        .and_then(|m| m.built.as_mut());
                    if let (Some(built), Some(content)) = (built, content) {
                        built.content = Some(Arc::new(content));
                    }
                }
            }
            DeviceBuild::AccelerationStructures { infos, .. } => {
                for info in infos {
                    let content = info
                        .geometry_entries()
                        .1
                        .iter()
                        .find_map(|(_, g)| g.micromap.as_ref())
                        .and_then(|data| accel_build::micromap_content(&self.state, false, data));
                    let built = self
                        .state
                        .acceleration_structures
                        .get_mut(&info.dst_acceleration_structure)
                        .and_then(|s| s.built.as_mut());
                    if let (Some(built), Some(content)) = (built, content) {
                        built.content = Some(Arc::new(content));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::accel::{Geometry, TrianglesData, TrianglesOpacityMicromapExt};
    use crate::state::{Buffer, BuildRecord, Micromap};
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
        };
        (validator, build)
    }

    fn indices(values: [u32; 2]) -> Arc<[u8]> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    #[test]
    fn the_index_buffer_is_a_content_source() {
        let (_, build) = validator_and_build();
        let sources = build.content_sources();
        assert_eq!(sources.len(), 1);
        assert_eq!(sources[0].address, 0x1000);
        assert!(sources[0]
            .location
            .ends_with("pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer"));
    }

    #[test]
    fn only_findings_the_contents_bring_are_reported_and_contents_are_forgotten() {
        let (mut validator, build) = validator_and_build();
        let cb = CommandBuffer::default();
        let report = validator.check_device_build_contents(&cb, &build, vec![(7, indices([0, 2]))]);
        let ids: Vec<&str> = report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-attach-index-in-range"], "{report:#?}");
        assert_eq!(
            report.findings[0].function,
            "vkCmdBuildAccelerationStructuresKHR"
        );
        assert_eq!(validator.state().buffers[&7].contents, None);

        let valid = validator.check_device_build_contents(&cb, &build, vec![(7, indices([0, 1]))]);
        assert!(valid.findings.is_empty(), "{valid:#?}");
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
            vec![(7, indices([0, 1]))],
        );
        let ids: Vec<&str> = read.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-not-checked-build-not-seen"], "{read:#?}");
    }
}
