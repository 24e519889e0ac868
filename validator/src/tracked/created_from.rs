//! Objects whose creation has no micromap rule of its own, or whose create
//! info is a generated KHR structure, tracked from the ash structures a
//! program has (value members only: no pointer is followed).

use ash::vk;
use ommcheck_vuids::khr;

use crate::checks::Validator;
use crate::model::accel::AccelerationStructureCreateInfo2;
use crate::report::Report;
use crate::state::QueryPool;

impl Validator {
    /// `vkCreateQueryPool(device, &info, NULL, &query_pool)` returned
    /// `query_pool` (null: none): tracked with its type and count, which
    /// decide the micromap query rules. `info.p_next` is not read.
    pub fn create_query_pool_from(
        &mut self,
        info: &vk::QueryPoolCreateInfo<'_>,
        query_pool: vk::QueryPool,
    ) {
        if query_pool != vk::QueryPool::null() {
            // A new pool's queries are uninitialized, whatever an earlier
            // pool with the same handle left.
            self.state
                .execution
                .forget_query_pool(vk::Handle::as_raw(query_pool));
            self.state.query_pools.insert(
                vk::Handle::as_raw(query_pool),
                QueryPool {
                    query_type: info.query_type.as_raw(),
                    query_count: info.query_count,
                },
            );
        }
    }

    /// Checks `vkCreateAccelerationStructure2KHR` with `info` (how a KHR
    /// opacity micromap is created) and tracks the structure it created
    /// (`acceleration_structure`, the program's handle; null: none).
    /// `info.p_next` is not read.
    pub fn create_acceleration_structure2_from(
        &mut self,
        info: &khr::AccelerationStructureCreateInfo2KHR,
        acceleration_structure: vk::AccelerationStructureKHR,
    ) -> Report {
        let model = AccelerationStructureCreateInfo2::from_members(info);
        self.create_acceleration_structure2(&model, vk::Handle::as_raw(acceleration_structure))
    }
}
