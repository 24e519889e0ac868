//! Rules of ours, `OMMCHECK-<area>-<name>`, for what the specification states
//! in prose without a VUID, and for driver hazards with no VUID at all.
//! Each quotes the sentence it enforces; the README lists them.

/// A rule without a VUID.
#[derive(Debug, PartialEq, Eq, Hash)]
pub struct OwnRule {
    /// `OMMCHECK-<area>-<name>`
    pub id: &'static str,
    /// The specification sentence (or the hazard) the rule enforces.
    pub statement: &'static str,
    /// Where that sentence is published.
    pub link: &'static str,
}

const MICROMAPS: &str =
    "https://docs.vulkan.org/spec/latest/chapters/VK_KHR_opacity_micromap/micromaps.html";

/// EXT micromap builds: the usage counts must describe the triangle array.
pub static HISTOGRAM_MISMATCH: OwnRule = OwnRule {
    id: "OMMCHECK-build-usage-counts-match-triangles",
    statement: "Each element of pUsageCounts or ppUsageCounts contains a count which is the number of micromap triangles of that format and subdivisionLevel contained in the micromap",
    link: MICROMAPS,
};

/// EXT micromap builds: each triangle's data lies inside the data the build reads.
pub static TRIANGLE_DATA_RANGE: OwnRule = OwnRule {
    id: "OMMCHECK-build-triangle-data-in-range",
    statement: "Each micromap triangle refers to one element in triangleArray which contains ... a dataOffset in bytes which is the location relative to data where that triangle's micromap data begins (the triangle's data, ceil(4^subdivisionLevel * bits per state / 8) bytes from dataOffset, must lie inside the memory data points to)",
    link: MICROMAPS,
};

/// EXT micromap builds: every triangle-array entry lies inside the memory the build reads.
pub static TRIANGLE_ARRAY_RANGE: OwnRule = OwnRule {
    id: "OMMCHECK-build-triangle-array-in-range",
    statement: "triangleArray is the address of memory containing the VkMicromapTriangleEXT data, one entry per micromap triangle at triangleArrayStride intervals (the sum of the usage counts gives the number of entries, all of which must lie inside that memory)",
    link: MICROMAPS,
};

/// EXT micromap builds: the stride rule KHR states as 11646/11647.
pub static EXT_TRIANGLE_ARRAY_STRIDE: OwnRule = OwnRule {
    id: "OMMCHECK-build-triangle-array-stride",
    statement: "The data at triangleArray is laid out as a 4 byte unsigned integer for the dataOffset followed by a 2 byte unsigned integer for the subdivision level then a 2 byte unsigned integer for the format (a stride below 8 bytes, other than 0 for a single triangle, makes entries overlap; KHR requires >= 8 and a multiple of 4)",
    link: MICROMAPS,
};

const ACCELERATION_STRUCTURES: &str =
    "https://docs.vulkan.org/spec/latest/chapters/accelstructures.html";

/// EXT (and KHR host-build) attachments without a micromap: only special indices.
pub static NULL_MICROMAP_SPECIAL_ONLY: OwnRule = OwnRule {
    id: "OMMCHECK-attach-null-micromap-special-only",
    statement: "If micromap is VK_NULL_HANDLE, then every value read from indexBuffer must be one of the values in VkOpacityMicromapSpecialIndexEXT",
    link: ACCELERATION_STRUCTURES,
};

/// A non-special index plus baseTriangle selects one of the micromap's
/// triangles: every EXT index, and the KHR cases 11575/11576 do not state
/// (one past the last triangle; index 0 at or past the end). See
/// docs/choices.md.
pub static INDEX_IN_RANGE: OwnRule = OwnRule {
    id: "OMMCHECK-attach-index-in-range",
    statement: "EXT: \"Otherwise that triangle uses the opacity micromap information from micromap at that index plus baseTriangle.\" KHR: \"For each triangle in the geometry, a triangle in the micromap is fetched at index reinterpret_cast<indexType>(indexBuffer + indexStride * geomTriangleIndex) + baseTriangle.\" Both: \"Each element contains a count which is the number of micromap triangles of that format and subdivisionLevel contained in the micromap.\" (A micromap built from counts summing to numTriangles contains triangles 0 to numTriangles - 1, so index plus baseTriangle must be less than numTriangles for the fetch to find a triangle; KHR's 11575 and 11576 state \"less than or equal to numTriangles\", and 11575 only for indices greater than zero.)",
    link: ACCELERATION_STRUCTURES,
};

/// EXT and NV attachments, and KHR ones in host builds (the device command
/// has 11577): every index the build fetches lies inside the index buffer.
pub static INDEX_BUFFER_RANGE: OwnRule = OwnRule {
    id: "OMMCHECK-attach-index-buffer-in-range",
    statement: "\"indexBuffer is the address containing the triangle indices\"; \"For each triangle in the geometry, the acceleration structure build fetches an index from indexBuffer using indexType and indexStride.\" (The primitiveCount indices, at indexStride intervals, must therefore lie inside the memory indexBuffer points into; the device command of KHR states it as 11577.)",
    link: ACCELERATION_STRUCTURES,
};

/// Top-level builds: the instances (or pointers to them) the build reads
/// lie inside the memory `data` points into.
pub static INSTANCES_RANGE: OwnRule = OwnRule {
    id: "OMMCHECK-attach-instances-in-range",
    statement: "\"For geometries of type VK_GEOMETRY_TYPE_INSTANCES_KHR, primitiveCount is the number of acceleration structures. primitiveCount VkAccelerationStructureInstanceKHR or VkAccelerationStructureMotionInstanceNV structures are consumed from VkAccelerationStructureGeometryInstancesDataKHR::data, starting at an offset of primitiveOffset.\" (With arrayOfPointers, data holds primitiveCount addresses instead; either array must lie inside the memory data points into. The instances carry the opacity-micromap flags the build reads.)",
    link: ACCELERATION_STRUCTURES,
};

/// EXT (and NV displacement) attachments: the usage counts describe the
/// micromap triangles the index buffer references.
pub static ATTACH_USAGE_COUNTS: OwnRule = OwnRule {
    id: "OMMCHECK-attach-usage-counts-match-indices",
    statement: "usageCountsCount specifies the number of usage counts structures that will be used to determine the size of this micromap; each count is the number of triangles that usage format and subdivision level combination represents (for a geometry: the triangles t < primitiveCount whose index, plus baseTriangle, selects a micromap triangle of that format and subdivisionLevel, each reference counted, special indices not counted)",
    link: ACCELERATION_STRUCTURES,
};

/// Index buffers whose address or stride is not a multiple of the index size.
pub static INDEX_ALIGNMENT: OwnRule = OwnRule {
    id: "OMMCHECK-attach-index-alignment",
    statement: "indexBuffer is the address containing the triangle indices and indexStride is the byte stride between them (an address or stride that is not a multiple of the index size makes misaligned reads, which crash some drivers; EXT and NV state no VUID for it)",
    link: ACCELERATION_STRUCTURES,
};

/// A pNext chain must end: no loops, and no longer than the reader walks.
pub static PNEXT_CHAIN: OwnRule = OwnRule {
    id: "OMMCHECK-reader-pnext-chain",
    statement: "Each pNext member of any structure (including this one) in the pNext chain must be either NULL or a pointer to a valid instance of a structure extending it (a chain that loops back is not such a chain)",
    link: "https://docs.vulkan.org/spec/latest/chapters/fundamentals.html#fundamentals-validusage-pNext",
};

/// ommcheck reads a bounded number of elements of any application array.
pub static READ_BOUND: OwnRule = OwnRule {
    id: "OMMCHECK-reader-bounded",
    statement: "ommcheck reads at most 2^20 elements of one application array and 256 MiB of one host array; elements past that bound are not checked",
    link: "https://docs.vulkan.org/spec/latest/chapters/fundamentals.html#fundamentals-validusage",
};

/// Hygiene: bits of a partly used byte that hold no state.
pub static UNUSED_BITS: OwnRule = OwnRule {
    id: "OMMCHECK-hygiene-unused-bits",
    statement: "The data is packed from LSB to MSB in each byte; at subdivision levels 0 and 1 a triangle uses fewer than 8 bits of its byte, and the rest hold no state (they are best left zero so identical blocks compare equal)",
    link: MICROMAPS,
};

/// Hygiene: identical blocks stored twice.
pub static DUPLICATE_DATA: OwnRule = OwnRule {
    id: "OMMCHECK-hygiene-duplicate-data",
    statement: "Each micromap triangle's dataOffset is the location relative to data where its data begins; triangles with identical data may point at one copy",
    link: MICROMAPS,
};

/// Hygiene: blocks that partly overlap.
pub static OVERLAPPING_DATA: OwnRule = OwnRule {
    id: "OMMCHECK-hygiene-overlapping-data",
    statement: "Each micromap triangle's data is ceil(4^subdivisionLevel * bits / 8) bytes from its dataOffset; two triangles whose data partly overlaps share some states by accident (sharing a whole block is deliberate and not reported)",
    link: MICROMAPS,
};

/// -5 belongs to cluster geometry only.
pub static CLUSTER_INDEX_OUTSIDE_CLUSTER: OwnRule = OwnRule {
    id: "OMMCHECK-attach-cluster-index-outside-cluster",
    statement: "VK_OPACITY_MICROMAP_SPECIAL_INDEX_CLUSTER_GEOMETRY_DISABLE_OPACITY_MICROMAP_NV (-5) disables the opacity micromap for a triangle of cluster geometry (VK_NV_cluster_acceleration_structure); in an ordinary bottom-level acceleration structure it is no special index",
    link: "https://docs.vulkan.org/spec/latest/chapters/accelstructures.html",
};

const SYNCHRONIZATION: &str = "https://docs.vulkan.org/spec/latest/chapters/synchronization.html";

/// An access needs a stage able to perform it on the queue the barrier runs
/// on; ALL_COMMANDS there is only the stages that queue supports.
pub static ACCESS_STAGE_ON_QUEUE: OwnRule = OwnRule {
    id: "OMMCHECK-sync-access-stage-on-queue",
    statement: "\"An application must not specify an access flag in a synchronization command if it does not include a pipeline stage in the corresponding stage mask that is able to perform accesses of that type.\" \"VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT specifies all operations performed by all commands supported on the queue it is used with.\" (On a queue family with neither VK_QUEUE_GRAPHICS_BIT nor VK_QUEUE_COMPUTE_BIT, ALL_COMMANDS includes no stage that can perform VK_ACCESS_2_SHADER_READ_BIT: the shader stages, ACCELERATION_STRUCTURE_BUILD and MICROMAP_BUILD all need one of them. 07454 lists ALL_COMMANDS itself, so this case is reported under this id rather than 07454.)",
    link: SYNCHRONIZATION,
};

// The not-checked information ids below are about the checker, not rules a
// call is checked against (like the layer's own ids), so they are not in
// `ALL`; `crate::report::not_checked::Cause` lists them.

const CHECKER: &str =
    "https://docs.vulkan.org/spec/latest/chapters/fundamentals.html#fundamentals-validusage";

/// Not checked: host memory a host command reads was not described.
pub static NOT_CHECKED_HOST_MEMORY: OwnRule = OwnRule {
    id: "OMMCHECK-not-checked-host-memory",
    statement: "ommcheck decides the rules that read host memory only from host memory it was told of, and says which rules it did not check when a host command reads memory it was not told of (its extent is unknown)",
    link: CHECKER,
};

/// Not checked: the bytes of device memory a command reads were not given.
pub static NOT_CHECKED_CONTENTS: OwnRule = OwnRule {
    id: "OMMCHECK-not-checked-contents",
    statement: "ommcheck decides the rules that read device memory only from contents it was given, and says which rules it did not check when a command reads a buffer whose contents it does not have",
    link: CHECKER,
};

/// Not checked: no buffer with a known device address holds an address.
pub static NOT_CHECKED_UNKNOWN_ADDRESS: OwnRule = OwnRule {
    id: "OMMCHECK-not-checked-unknown-address",
    statement: "ommcheck resolves a device address through the buffers whose device addresses it knows, and says which rules it did not check when it knows no buffer's address",
    link: CHECKER,
};

/// Not checked: the build of a micromap or structure a command uses was not seen.
pub static NOT_CHECKED_BUILD_NOT_SEEN: OwnRule = OwnRule {
    id: "OMMCHECK-not-checked-build-not-seen",
    statement: "ommcheck knows what a micromap or acceleration structure holds from the build it checked, and says which rules it did not check when a command uses one whose build it did not see",
    link: CHECKER,
};

/// Not checked: no serialization the checker saw wrote the bytes deserialized.
pub static NOT_CHECKED_SERIALIZATION_NOT_SEEN: OwnRule = OwnRule {
    id: "OMMCHECK-not-checked-serialization-not-seen",
    statement: "ommcheck knows what serialized bytes hold from the serialization it saw write them, and says which rules it did not check when a command deserializes, or uses what was deserialized from, bytes no serialization it saw wrote",
    link: CHECKER,
};

/// Every own rule, for the README and the coverage report.
pub static ALL: &[&OwnRule] = &[
    &HISTOGRAM_MISMATCH,
    &TRIANGLE_DATA_RANGE,
    &TRIANGLE_ARRAY_RANGE,
    &EXT_TRIANGLE_ARRAY_STRIDE,
    &NULL_MICROMAP_SPECIAL_ONLY,
    &INDEX_IN_RANGE,
    &INDEX_BUFFER_RANGE,
    &INSTANCES_RANGE,
    &ATTACH_USAGE_COUNTS,
    &INDEX_ALIGNMENT,
    &PNEXT_CHAIN,
    &READ_BOUND,
    &UNUSED_BITS,
    &DUPLICATE_DATA,
    &OVERLAPPING_DATA,
    &CLUSTER_INDEX_OUTSIDE_CLUSTER,
    &ACCESS_STAGE_ON_QUEUE,
];

/// The rules the checks decide only from the simulate tier up: the hygiene
/// information, which reads every byte of every data block and is no
/// validity rule, so the content tier (the default) leaves it out and reads
/// no data byte. `validator/tests/corpus.rs` holds this list to the tier
/// measured over the corpus.
pub static SIMULATE_TIER: &[&OwnRule] = &[&UNUSED_BITS, &DUPLICATE_DATA, &OVERLAPPING_DATA];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_unique_and_well_formed() {
        let mut ids: Vec<&str> = ALL.iter().map(|r| r.id).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), ALL.len());
        for id in ids {
            assert!(
                id.starts_with("OMMCHECK-") && id.split('-').count() >= 3,
                "{id}"
            );
        }
    }
}
