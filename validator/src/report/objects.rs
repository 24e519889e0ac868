//! The objects a finding involves, read off its parameter path and the
//! call's arguments: a finding at `pInfos[0].triangleArray[3].format` of a
//! micromap build involves `pInfos[0].dstMicromap`; one at
//! `pInfos[0].pGeometries[1].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer[7]`
//! involves the acceleration structure built and the micromap attached.
//! The checks list the objects they compare; these are added after them,
//! so that every finding of a build names what it builds and attaches.

use super::location::{index_after, steps};
use super::{Finding, ObjectRef, Report};
use crate::model::accel::{BuildGeometryInfo, GeometryData};
use crate::model::MicromapBuildInfo;

/// The index of the step `name[i]` of `path` (a whole step, not part of
/// another name).
pub(crate) fn step_index(path: &str, name: &str) -> Option<usize> {
    let (_, steps) = steps(path);
    index_after(&steps, name).and_then(|i| usize::try_from(i).ok())
}

/// Adds `handle` as a `ty` object of `finding`, unless it is NULL or
/// listed already.
fn involve(finding: &mut Finding, ty: &'static str, handle: u64) {
    if handle != 0 && !finding.objects.iter().any(|o| o.handle == handle) {
        finding.objects.push(ObjectRef { ty, handle });
    }
}

/// A micromap build's findings at `pInfos[i]...` involve its `dstMicromap`.
pub(crate) fn micromap_builds(report: &mut Report, infos: &[MicromapBuildInfo]) {
    for finding in &mut report.findings {
        let info = step_index(&finding.location, "pInfos").and_then(|i| infos.get(i));
        if let Some(info) = info {
            involve(finding, "VkMicromapEXT", info.dst_micromap);
        }
    }
}

/// An acceleration-structure build's findings at `pInfos[i]...` involve
/// its `dstAccelerationStructure`, and those inside an opacity-micromap
/// attachment the micromap attached.
pub(crate) fn acceleration_builds(report: &mut Report, infos: &[BuildGeometryInfo]) {
    for finding in &mut report.findings {
        let Some(info) = step_index(&finding.location, "pInfos").and_then(|i| infos.get(i)) else {
            continue;
        };
        involve(
            finding,
            "VkAccelerationStructureKHR",
            info.dst_acceleration_structure,
        );
        let geometry = match (
            step_index(&finding.location, "pGeometries"),
            step_index(&finding.location, "ppGeometries"),
        ) {
            (Some(g), _) => info.geometries.as_ref().and_then(|g_| g_.get(g)),
            (None, Some(g)) => info
                .geometry_pointers
                .as_ref()
                .and_then(|p| p.get(g))
                .and_then(Option::as_ref),
            (None, None) => None,
        };
        let Some(GeometryData::Triangles(triangles)) = geometry.map(|g| &g.geometry) else {
            continue;
        };
        if finding.location.contains("OpacityMicromapEXT>") {
            if let Some(ext) = &triangles.opacity_ext {
                involve(finding, "VkMicromapEXT", ext.micromap);
            }
        } else if finding.location.contains("OpacityMicromapKHR>") {
            if let Some(khr) = &triangles.opacity_khr {
                involve(finding, "VkAccelerationStructureKHR", khr.micromap);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_found_whole() {
        let path = "calls[2]: pInfos[3].ppGeometries[1].geometry";
        assert_eq!(step_index(path, "pInfos"), Some(3));
        assert_eq!(step_index(path, "ppGeometries"), Some(1));
        // `pGeometries` is inside `ppGeometries`, not a step of its own.
        assert_eq!(step_index(path, "pGeometries"), None);
        assert_eq!(step_index("pInfos", "pInfos"), None);
        assert_eq!(step_index("pInfos[x]", "pInfos"), None);
    }
}
