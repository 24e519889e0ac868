//! Query pool commands that name no micromap rule but change what later
//! commands may do with a query pool's queries.

use serde::{Deserialize, Serialize};

use crate::state::Handle;

/// A reset of `query_count` queries of `query_pool` from `first_query`:
/// `vkCmdResetQueryPool` (when a submission executes it) or
/// `vkResetQueryPool` (on the host, at once). A reset makes the queries
/// unavailable, which is what vkCmdWriteMicromapsPropertiesEXT's 12417
/// asks of the queries it writes.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct QueryReset {
    pub query_pool: Handle,
    pub first_query: u32,
    pub query_count: u32,
}
