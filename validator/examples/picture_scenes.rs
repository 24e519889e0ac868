//! Writes the scenes docs/pictures.md measures `ommcheck draw` on, into
//! the folder given: `level12.json` (one level-12 4-state micromap
//! triangle, 16,777,216 micro-triangles), `geometry64k.json` (a BLAS
//! geometry of 65,536 triangles over 256 level-4 micromap triangles),
//! `geometry64k-textured.json` (the same over a 1024 x 1024 alpha texture)
//! and `usage64k.json` (a micromap of 65,536 triangles, whose usage counts
//! a histogram sets against its array).
//!
//! `cargo run --release -p ommcheck --example picture_scenes -- DIR`

#[path = "../tests/support/picture_scenes.rs"]
mod picture_scenes;

use picture_scenes::{write, Spec};

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "picture-scenes".into());
    let dir = std::path::Path::new(&dir);
    for (name, spec) in [
        (
            "level12",
            Spec {
                level: 12,
                micromap_triangles: 1,
                geometry_triangles: 0,
                texture: 0,
            },
        ),
        (
            "geometry64k",
            Spec {
                level: 4,
                micromap_triangles: 256,
                geometry_triangles: 65_536,
                texture: 0,
            },
        ),
        (
            "geometry64k-textured",
            Spec {
                level: 4,
                micromap_triangles: 256,
                geometry_triangles: 65_536,
                texture: 1024,
            },
        ),
        (
            "usage64k",
            Spec {
                level: 1,
                micromap_triangles: 65_536,
                geometry_triangles: 0,
                texture: 0,
            },
        ),
    ] {
        println!("{}", write(dir, name, &spec).display());
    }
}
