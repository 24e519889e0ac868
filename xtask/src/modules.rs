//! `cargo xtask modules`: the import graph between a crate's top-level
//! modules (those its root declares), and its cycles.
//!
//! Imports point one way: a module imports nothing that imports it back,
//! directly or through others. This reads each file of a crate's `src/`
//! as Rust tokens (so comments and strings are not paths, and paths inside
//! macro calls are) and takes an edge from module `a` to module `b`
//! wherever a file of `a` names `crate::b`, names an item the crate root
//! re-exports from `b` (`crate::Validator` is `checks`), or climbs with
//! `super::` to the crate root and names `b` there. Test code counts as
//! well: a test module that imports its caller is a cycle too.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::str::FromStr;

use proc_macro2::{Delimiter, TokenStream, TokenTree};

use crate::Error;

/// The crates whose top-level modules must form no cycle, by their `src/`.
pub const CRATES: [&str; 3] = ["validator/src", "layer/src", "xtask/src"];

/// Edges between the top-level modules of one crate.
#[derive(Debug, Default)]
pub struct Graph {
    /// Every module the crate root declares (`src/a.rs` or `src/a/`).
    pub modules: BTreeSet<String>,
    /// `from` → `to` → the files of `from` that name `to`.
    pub edges: BTreeMap<String, BTreeMap<String, BTreeSet<PathBuf>>>,
}

impl Graph {
    /// Reads the crate whose sources are under `src`.
    pub fn read(src: &Path) -> Result<Self, Error> {
        let mut graph = Graph {
            modules: root_modules(src)?,
            ..Graph::default()
        };
        let reexports = root_reexports(src, &graph.modules)?;
        let mut files = Vec::new();
        collect_rs(src, &mut files)?;
        for file in files {
            let relative = file.strip_prefix(src).unwrap_or(&file).to_path_buf();
            let Some(from) = top_module(&relative, &graph.modules) else {
                continue;
            };
            let text = crate::read(&file)?;
            let tokens = TokenStream::from_str(&text)
                .map_err(|e| Error::Tool(format!("{}: not Rust tokens: {e}", file.display())))?;
            let depth = module_depth(&relative);
            let mut named = BTreeSet::new();
            crate_paths(tokens, depth, &mut named);
            for name in named {
                let to = if graph.modules.contains(&name) {
                    Some(name)
                } else {
                    reexports.get(&name).cloned()
                };
                if let Some(to) = to.filter(|to| *to != from) {
                    graph
                        .edges
                        .entry(from.clone())
                        .or_default()
                        .entry(to)
                        .or_default()
                        .insert(relative.clone());
                }
            }
        }
        Ok(graph)
    }

    /// The groups of modules that import each other, each of more than one
    /// module (Tarjan's strongly connected components), in name order.
    pub fn cycles(&self) -> Vec<BTreeSet<String>> {
        let mut tarjan = Tarjan {
            graph: self,
            next: 0,
            index: BTreeMap::new(),
            low: BTreeMap::new(),
            stack: Vec::new(),
            components: Vec::new(),
        };
        for module in &self.modules {
            if !tarjan.index.contains_key(module.as_str()) {
                tarjan.visit(module);
            }
        }
        let mut cycles: Vec<_> = tarjan
            .components
            .into_iter()
            .filter(|c| c.len() > 1)
            .collect();
        cycles.sort();
        cycles
    }

    /// The modules in layers from the bottom: each module's imports are all
    /// in lower layers. None when there is a cycle.
    pub fn layers(&self) -> Option<Vec<Vec<String>>> {
        let mut placed: BTreeMap<&str, usize> = BTreeMap::new();
        while placed.len() < self.modules.len() {
            let before = placed.len();
            for module in &self.modules {
                if placed.contains_key(module.as_str()) {
                    continue;
                }
                let imports = self.edges.get(module).map(|e| e.keys());
                let mut layer = 0;
                let mut ready = true;
                for to in imports.into_iter().flatten() {
                    match placed.get(to.as_str()) {
                        Some(&below) => layer = layer.max(below + 1),
                        None => ready = false,
                    }
                }
                if ready {
                    placed.insert(module, layer);
                }
            }
            if placed.len() == before {
                return None;
            }
        }
        let mut layers = vec![Vec::new(); placed.values().max().map_or(0, |m| m + 1)];
        for (module, layer) in placed {
            layers[layer].push(module.to_string());
        }
        Some(layers)
    }

    /// A report of the graph: its layers, or each cycle with its edges.
    pub fn render(&self, crate_src: &str) -> String {
        let mut out = String::new();
        let cycles = self.cycles();
        if cycles.is_empty() {
            out.push_str(&format!("{crate_src}: no cycle; layers from the bottom:\n"));
            for (i, layer) in self.layers().unwrap_or_default().iter().enumerate() {
                out.push_str(&format!("  {i}: {}\n", layer.join(", ")));
            }
            return out;
        }
        for cycle in cycles {
            out.push_str(&format!(
                "{crate_src}: a cycle through {} of {} modules: {}\n",
                cycle.len(),
                self.modules.len(),
                cycle.iter().cloned().collect::<Vec<_>>().join(", ")
            ));
            for from in &cycle {
                for (to, files) in self.edges.get(from).into_iter().flatten() {
                    if cycle.contains(to) {
                        let files: Vec<_> = files.iter().map(|f| f.display().to_string()).collect();
                        out.push_str(&format!("  {from} -> {to}: {}\n", files.join(", ")));
                    }
                }
            }
        }
        out
    }
}

struct Tarjan<'a> {
    graph: &'a Graph,
    next: usize,
    index: BTreeMap<&'a str, usize>,
    low: BTreeMap<&'a str, usize>,
    stack: Vec<&'a str>,
    components: Vec<BTreeSet<String>>,
}

impl<'a> Tarjan<'a> {
    fn visit(&mut self, module: &'a str) {
        self.index.insert(module, self.next);
        self.low.insert(module, self.next);
        self.next += 1;
        self.stack.push(module);
        for to in self
            .graph
            .edges
            .get(module)
            .into_iter()
            .flat_map(|e| e.keys())
        {
            if !self.index.contains_key(to.as_str()) {
                self.visit(to);
                let low = self.low[module].min(self.low[to.as_str()]);
                self.low.insert(module, low);
            } else if self.stack.contains(&to.as_str()) {
                let low = self.low[module].min(self.index[to.as_str()]);
                self.low.insert(module, low);
            }
        }
        if self.low[module] == self.index[module] {
            let mut component = BTreeSet::new();
            while let Some(top) = self.stack.pop() {
                component.insert(top.to_string());
                if top == module {
                    break;
                }
            }
            self.components.push(component);
        }
    }
}

fn read_dir(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut entries = std::fs::read_dir(dir)
        .map_err(io)?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(io)?;
    entries.sort();
    Ok(entries)
}

fn collect_rs(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), Error> {
    for path in read_dir(dir)? {
        if path.is_dir() {
            collect_rs(&path, out)?;
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    Ok(())
}

/// The modules the crate root declares (`mod a;` in `lib.rs`, else in
/// `main.rs`): a binary's own modules beside a library are not the
/// library's.
fn root_modules(src: &Path) -> Result<BTreeSet<String>, Error> {
    let lib = src.join("lib.rs");
    let root = if lib.exists() {
        lib
    } else {
        src.join("main.rs")
    };
    let tokens: Vec<TokenTree> = TokenStream::from_str(&crate::read(&root)?)
        .map_err(|e| Error::Tool(format!("{}: not Rust tokens: {e}", root.display())))?
        .into_iter()
        .collect();
    Ok(tokens
        .windows(3)
        .filter_map(|w| match w {
            [TokenTree::Ident(keyword), TokenTree::Ident(name), TokenTree::Punct(semicolon)]
                if keyword == "mod" && semicolon.as_char() == ';' =>
            {
                Some(name.to_string())
            }
            _ => None,
        })
        .collect())
}

/// The top-level module a file under `src/` belongs to; None for the crate
/// roots (`lib.rs`, `main.rs`) and for files of modules the root does not
/// declare.
fn top_module(relative: &Path, modules: &BTreeSet<String>) -> Option<String> {
    let first = relative.components().next()?.as_os_str().to_string_lossy();
    let name = first.strip_suffix(".rs").unwrap_or(&first);
    modules.contains(name).then(|| name.to_string())
}

/// How many `super::` lead from the file's module to the crate root:
/// `a.rs` is 1, `a/b.rs` 2, `a/mod.rs` 1.
fn module_depth(relative: &Path) -> usize {
    let parts = relative.components().count();
    if relative.file_name().is_some_and(|n| n == "mod.rs") {
        parts - 1
    } else {
        parts
    }
}

/// Names the crate root re-exports (`pub use a::{B, C}` in lib.rs) → the
/// top-level module they come from.
fn root_reexports(
    src: &Path,
    modules: &BTreeSet<String>,
) -> Result<BTreeMap<String, String>, Error> {
    let mut out = BTreeMap::new();
    let lib = src.join("lib.rs");
    if !lib.exists() {
        return Ok(out);
    }
    let tokens: Vec<TokenTree> = TokenStream::from_str(&crate::read(&lib)?)
        .map_err(|e| Error::Tool(format!("{}: not Rust tokens: {e}", lib.display())))?
        .into_iter()
        .collect();
    for (i, token) in tokens.iter().enumerate() {
        if !is_ident(token, "use") || !tokens[..i].last().is_some_and(|t| is_ident(t, "pub")) {
            continue;
        }
        let Some(TokenTree::Ident(first)) = tokens.get(i + 1) else {
            continue;
        };
        let module = first.to_string();
        if !modules.contains(&module) {
            continue;
        }
        // Every name the `use` tree ends in (or renames to).
        let end = tokens[i..]
            .iter()
            .position(|t| matches!(t, TokenTree::Punct(p) if p.as_char() == ';'))
            .map_or(tokens.len(), |p| i + p);
        let mut names = Vec::new();
        last_names(&tokens[i + 1..end], &mut names);
        for name in names {
            out.insert(name, module.clone());
        }
    }
    Ok(out)
}

/// The names a `use` tree makes visible: the last segment of each path, or
/// the name after `as`.
fn last_names(tokens: &[TokenTree], out: &mut Vec<String>) {
    let mut last = None;
    let mut renamed = false;
    for token in tokens {
        match token {
            TokenTree::Ident(ident) if ident == "as" => renamed = true,
            TokenTree::Ident(ident) => {
                last = Some(ident.to_string());
                if renamed {
                    renamed = false;
                }
            }
            TokenTree::Group(group) if group.delimiter() == Delimiter::Brace => {
                let inner: Vec<TokenTree> = group.stream().into_iter().collect();
                last_names(&inner, out);
                last = None;
            }
            TokenTree::Punct(p) if p.as_char() == ',' => {
                out.extend(last.take());
            }
            _ => {}
        }
    }
    out.extend(last);
}

fn is_ident(token: &TokenTree, name: &str) -> bool {
    matches!(token, TokenTree::Ident(ident) if ident == name)
}

fn is_path_sep(tokens: &[TokenTree], at: usize) -> bool {
    matches!(
        (tokens.get(at), tokens.get(at + 1)),
        (Some(TokenTree::Punct(a)), Some(TokenTree::Punct(b))) if a.as_char() == ':' && b.as_char() == ':'
    )
}

/// Collects the first segment after every path to the crate root in
/// `tokens`: `crate::x`, `$crate::x`, `crate::{x, y::z}`, and `super::`
/// chains `depth` long (one longer inside an inline `mod name { … }`).
fn crate_paths(tokens: TokenStream, depth: usize, out: &mut BTreeSet<String>) {
    let tokens: Vec<TokenTree> = tokens.into_iter().collect();
    let mut i = 0;
    while i < tokens.len() {
        if is_ident(&tokens[i], "mod") {
            if let (Some(TokenTree::Ident(_)), Some(TokenTree::Group(body))) =
                (tokens.get(i + 1), tokens.get(i + 2))
            {
                if body.delimiter() == Delimiter::Brace {
                    crate_paths(body.stream(), depth + 1, out);
                    i += 3;
                    continue;
                }
            }
        }
        let root_at = if is_ident(&tokens[i], "crate") && is_path_sep(&tokens, i + 1) {
            Some(i + 3)
        } else if is_ident(&tokens[i], "super") && !after_path_sep(&tokens, i) {
            let mut at = i;
            let mut supers = 0;
            while is_ident_at(&tokens, at, "super") && is_path_sep(&tokens, at + 1) {
                supers += 1;
                at += 3;
            }
            (supers == depth).then_some(at)
        } else {
            None
        };
        if let Some(at) = root_at {
            match tokens.get(at) {
                Some(TokenTree::Ident(name)) => {
                    out.insert(name.to_string());
                }
                Some(TokenTree::Group(group)) if group.delimiter() == Delimiter::Brace => {
                    let inner: Vec<TokenTree> = group.stream().into_iter().collect();
                    let mut segment_start = true;
                    for token in &inner {
                        match token {
                            TokenTree::Ident(name) if segment_start => {
                                out.insert(name.to_string());
                                segment_start = false;
                            }
                            TokenTree::Punct(p) if p.as_char() == ',' => segment_start = true,
                            _ => segment_start = false,
                        }
                    }
                }
                _ => {}
            }
        }
        if let TokenTree::Group(group) = &tokens[i] {
            crate_paths(group.stream(), depth, out);
        }
        i += 1;
    }
}

fn is_ident_at(tokens: &[TokenTree], at: usize, name: &str) -> bool {
    tokens.get(at).is_some_and(|t| is_ident(t, name))
}

/// Whether the token at `at` follows a `::` (so a `super` there is not the
/// start of a path).
fn after_path_sep(tokens: &[TokenTree], at: usize) -> bool {
    at >= 2 && is_path_sep(tokens, at - 2)
}

/// `cargo xtask modules`: each crate's report; an error when any has a cycle.
pub fn run(root: &Path) -> Result<String, Error> {
    let mut out = String::new();
    let mut cyclic = Vec::new();
    for crate_src in CRATES {
        let graph = Graph::read(&root.join(crate_src))?;
        if !graph.cycles().is_empty() {
            cyclic.push(crate_src);
        }
        out.push_str(&graph.render(crate_src));
    }
    if cyclic.is_empty() {
        Ok(out)
    } else {
        Err(Error::Tool(format!(
            "{out}import cycles between top-level modules in {}",
            cyclic.join(", ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn named(text: &str, depth: usize) -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        crate_paths(TokenStream::from_str(text).unwrap(), depth, &mut out);
        out
    }

    #[test]
    fn paths_to_the_crate_root_name_their_first_segment() {
        let text = r#"
            use crate::model::Handle;
            use crate::{report::Finding, state};
            use super::super::sim::decode;
            use super::sibling;
            // crate::in_a_comment
            const TEXT: &str = "crate::in_a_string";
            fn f() { format!("{}", crate::rules::ALL.len()); $crate::tier::Tier::Params; }
            mod tests { use super::super::super::checks; use super::super::Local; }
        "#;
        let want = ["checks", "model", "report", "rules", "sim", "state", "tier"];
        assert_eq!(named(text, 2), want.map(String::from).into());
        // From a top-level file, one `super` reaches the root.
        assert_eq!(
            named("use super::sibling::X;", 1),
            ["sibling".to_string()].into()
        );
    }

    #[test]
    fn cycles_and_layers() {
        let mut graph = Graph::default();
        for m in ["a", "b", "c", "d"] {
            graph.modules.insert(m.into());
        }
        let mut edge = |from: &str, to: &str| {
            graph
                .edges
                .entry(from.into())
                .or_default()
                .entry(to.into())
                .or_default()
                .insert(PathBuf::from(format!("{from}.rs")));
        };
        edge("b", "a");
        edge("c", "b");
        edge("d", "a");
        assert!(graph.cycles().is_empty());
        let layers = graph.layers().unwrap();
        assert_eq!(layers, [vec!["a"], vec!["b", "d"], vec!["c"]]);
        graph
            .edges
            .entry("a".into())
            .or_default()
            .entry("c".into())
            .or_default()
            .insert(PathBuf::from("a.rs"));
        assert_eq!(graph.cycles(), [["a", "b", "c"].map(String::from).into()]);
        assert!(graph.layers().is_none());
        assert!(graph
            .render("x/src")
            .contains("a cycle through 3 of 4 modules"));
    }
}
