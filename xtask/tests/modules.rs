//! Imports point one way: no top-level module of validator/src, layer/src
//! or xtask/src imports anything that imports it back (`cargo xtask
//! modules` prints the layers; docs/architecture.md).

use xtask::modules::{Graph, CRATES};

#[test]
fn no_crate_has_an_import_cycle() {
    let root = xtask::workspace_root();
    for crate_src in CRATES {
        let graph = Graph::read(&root.join(crate_src)).unwrap();
        assert!(graph.modules.len() > 5, "{crate_src}: {:?}", graph.modules);
        assert!(!graph.edges.is_empty(), "{crate_src}: no edges read");
        assert!(graph.cycles().is_empty(), "{}", graph.render(crate_src));
    }
}
