//! Reading `VkAccelerationStructureBuildGeometryInfoKHR` and friends (being written).
