//! `alphaTextures`: the alpha texture a BLAS geometry's picture is drawn
//! over (`ommcheck draw`, the HTML report), with the texture coordinate of
//! each vertex. The checks read nothing here; it describes the asset the
//! micromap was baked from, which no Vulkan call carries.

use schemars::JsonSchema;
use serde::Deserialize;

/// The alpha texture of one triangles geometry of a bottom-level
/// acceleration structure a call builds.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AlphaTextureDesc {
    /// The bottom-level acceleration structure, by its name in the scene.
    pub acceleration_structure: String,
    /// The geometry's index in the build (default 0).
    #[serde(default)]
    pub geometry: u32,
    /// A PNG file, relative to the scene file: its alpha channel, or its
    /// grey or red channel where it has none (at most 4096 x 4096 texels).
    pub png: String,
    /// The texture coordinate `[u, v]` of each vertex, by the vertex number
    /// the build reads: `firstVertex` plus the vertex index (`firstVertex +
    /// 3t + k` without an index buffer). `[0, 0]` is the image's top-left
    /// corner, `[1, 1]` its bottom-right.
    pub uvs: Vec<[f64; 2]>,
}
