//! How a front is displayed, in terms the renderer, the viewer's settings and scripts share (no GPU
//! here, so that scripts parse and are fuzzed without one).

/// How surfaces are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum ColorBy {
    /// The model's vertex colours when it has them, else a neutral grey; lit — except a lit mesh
    /// from `vunify radiosity` (one-sided, with colours), drawn as [`ColorBy::Baked`].
    #[default]
    Auto,
    /// Neutral grey, lit.
    Shaded,
    /// The vertex colours as they are, unlit: for meshes with baked lighting (`vunify radiosity`),
    /// whose 8-bit display colours then reach the screen unchanged.
    Baked,
    /// Hue by the node's depth in the tree.
    Depth,
    /// The node's error projected on screen: blue at 0, green at τ, red at 2τ and above.
    Error,
    /// The base colour texture, lit (what [`ColorBy::Auto`] draws for a textured model); vertex
    /// colours where a vertex has no texture.
    Texture,
    /// A checker over the texture coordinates (eight squares across a texture), lit: to see
    /// stretch and seams.
    Uv,
}
