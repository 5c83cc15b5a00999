//! The layout rules of ARCHITECTURE.md, checked on the sources themselves:
//!
//! - **Floors.** Every workspace crate sits on one floor of `FLOORS`, and every path dependency
//!   (normal, dev or build) of a crate sits on a lower floor: no crate imports one above it.
//! - **No import circles.** Within a crate, file A depends on file B when A `use`s an item of B's
//!   module (`crate::`, `self::` and `super::` paths in `use` lines or written in place, resolved to the deepest module a
//!   file holds). A module and its own ancestors are left out: a parent declares its children and a
//!   child may name its parent's items. The remaining graph has no cycle.
//! - **Short functions.** Every function outside tests (`tests/`, `tests.rs`, `#[cfg(test)]`) is under
//!   100 lines.
//!
//! Each rule reports every offender with its file, so a failure says what to change.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// The floors of the workspace, lowest first. A crate may depend only on crates of lower floors.
const FLOORS: &[&[&str]] = &[
    &["vrs-reflection", "vrsc-alloc"],
    &["vrsc"],
    &["vrs-runtime", "vrsc-lsp"],
    &["vrs-live"],
    &["vrs-viewer"],
    &["vrsc-cli", "vrsc-python"],
];

/// The longest function allowed outside tests, in lines (signature to closing brace).
const MAX_FUNCTION_LINES: usize = 99;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().expect("workspace root")
}

/// A workspace member: its package name, folder and path dependencies (by package name).
struct Member {
    name: String,
    dir: PathBuf,
    path_deps: Vec<String>,
}

fn members(root: &Path) -> Vec<Member> {
    let manifest = read_toml(&root.join("Cargo.toml"));
    let list = manifest["workspace"]["members"].as_array().expect("workspace.members");
    list.iter()
        .map(|m| {
            let dir = root.join(m.as_str().expect("member path"));
            let toml = read_toml(&dir.join("Cargo.toml"));
            let name = toml["package"]["name"].as_str().expect("package.name").to_owned();
            Member { name, path_deps: path_dependencies(&toml, &dir), dir }
        })
        .collect()
}

fn read_toml(path: &Path) -> toml_edit::DocumentMut {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The package names of the path dependencies in every dependency table of a manifest.
fn path_dependencies(toml: &toml_edit::DocumentMut, dir: &Path) -> Vec<String> {
    let mut names = Vec::new();
    for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
        let Some(deps) = toml.get(table).and_then(|t| t.as_table_like()) else { continue };
        for (_, spec) in deps.iter() {
            let Some(path) = spec.get("path").and_then(|p| p.as_str()) else { continue };
            let dep = read_toml(&dir.join(path).join("Cargo.toml"));
            names.push(dep["package"]["name"].as_str().expect("package.name").to_owned());
        }
    }
    names
}

fn floor_of(name: &str) -> Option<usize> {
    FLOORS.iter().position(|floor| floor.contains(&name))
}

#[test]
fn no_crate_depends_on_one_above_it() {
    let mut wrong = Vec::new();
    for member in members(&workspace_root()) {
        let Some(floor) = floor_of(&member.name) else {
            wrong.push(format!("{} is on no floor: add it to FLOORS and ARCHITECTURE.md", member.name));
            continue;
        };
        for dep in &member.path_deps {
            match floor_of(dep) {
                Some(f) if f < floor => {}
                _ => wrong.push(format!("{} (floor {floor}) depends on {dep}, which is not below it", member.name)),
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// One Rust source file of a crate, with the module path it defines.
struct SourceFile {
    path: PathBuf,
    module: Vec<String>,
    syntax: syn::File,
}

/// The files of a crate's module tree, from its root file through its `mod` lines (test modules
/// left out).
fn module_tree(root_file: &Path) -> Vec<SourceFile> {
    let mut files = Vec::new();
    let mut pending = vec![(root_file.to_path_buf(), Vec::new())];
    while let Some((path, module)) = pending.pop() {
        let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let syntax = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for (name, inline) in child_modules(&syntax.items) {
            if inline {
                continue;
            }
            let mut child = module.clone();
            child.push(name.clone());
            pending.push((child_file(&path, &name), child));
        }
        files.push(SourceFile { path, module, syntax });
    }
    files
}

/// The modules an item list declares, with whether each is inline (`mod x { .. }`).
fn child_modules(items: &[syn::Item]) -> Vec<(String, bool)> {
    items
        .iter()
        .filter_map(|item| match item {
            syn::Item::Mod(m) if !is_test_only(&m.attrs) && !has_path_attribute(&m.attrs) => {
                Some((m.ident.to_string(), m.content.is_some()))
            }
            _ => None,
        })
        .collect()
}

fn is_test_only(attrs: &[syn::Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.parse_args::<syn::Meta>().is_ok_and(|m| m.path().is_ident("test")))
}

fn has_path_attribute(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| a.path().is_ident("path"))
}

/// Where `mod name;` in `parent` lives: beside a `lib.rs`/`main.rs`/`mod.rs`, else in the folder
/// named after the parent file.
fn child_file(parent: &Path, name: &str) -> PathBuf {
    let stem = parent.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    let folder = parent.parent().expect("a source file has a folder");
    let folder = if matches!(stem, "lib" | "main" | "mod") { folder.to_path_buf() } else { folder.join(stem) };
    let flat = folder.join(format!("{name}.rs"));
    if flat.exists() { flat } else { folder.join(name).join("mod.rs") }
}

/// Every crate-relative path a file names outside test modules: its `use` trees, flattened, and
/// paths written in place (`super::bricked::check(..)`).
#[derive(Default)]
struct UsePaths {
    paths: Vec<Vec<String>>,
}

impl<'ast> Visit<'ast> for UsePaths {
    fn visit_item_use(&mut self, item: &'ast syn::ItemUse) {
        flatten_use(&item.tree, &mut Vec::new(), &mut self.paths);
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        let segments: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
        if segments.len() > 1 {
            self.paths.push(segments);
        }
        syn::visit::visit_path(self, path);
    }

    fn visit_item_mod(&mut self, item: &'ast syn::ItemMod) {
        if !is_test_only(&item.attrs) {
            syn::visit::visit_item_mod(self, item);
        }
    }
}

fn flatten_use(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            flatten_use(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) => out.push([prefix.as_slice(), &[n.ident.to_string()]].concat()),
        syn::UseTree::Rename(r) => out.push([prefix.as_slice(), &[r.ident.to_string()]].concat()),
        syn::UseTree::Glob(_) => out.push(prefix.clone()),
        syn::UseTree::Group(g) => g.items.iter().for_each(|t| flatten_use(t, prefix, out)),
    }
}

/// A `use` path as an absolute module path within the crate, or `None` for other crates.
fn absolute(path: &[String], module: &[String]) -> Option<Vec<String>> {
    let mut base: Vec<String> = match path.first().map(String::as_str) {
        Some("crate") => Vec::new(),
        Some("self" | "super") => module.to_vec(),
        _ => return None,
    };
    let mut rest = if path[0] == "crate" || path[0] == "self" { &path[1..] } else { path };
    while rest.first().is_some_and(|s| s == "super") {
        base.pop()?;
        rest = &rest[1..];
    }
    base.extend(rest.iter().cloned());
    Some(base)
}

fn is_prefix(short: &[String], long: &[String]) -> bool {
    long.starts_with(short)
}

/// The file-level dependency graph of one crate: file -> files it uses, ancestors left out.
fn file_graph(files: &[SourceFile]) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let by_module: BTreeMap<&[String], &Path> = files.iter().map(|f| (f.module.as_slice(), f.path.as_path())).collect();
    let mut graph = BTreeMap::new();
    for file in files {
        let mut uses = UsePaths::default();
        uses.visit_file(&file.syntax);
        let targets = graph.entry(file.path.clone()).or_insert_with(BTreeSet::new);
        for path in uses.paths.iter().filter_map(|p| absolute(p, &file.module)) {
            let Some(target) = (0..=path.len()).rev().find_map(|n| by_module.get(&path[..n])) else { continue };
            let target_module = &files.iter().find(|f| f.path == *target).expect("known").module;
            if !is_prefix(target_module, &file.module) && !is_prefix(&file.module, target_module) {
                targets.insert(target.to_path_buf());
            }
        }
    }
    graph
}

/// The strongly connected components of more than one file (Tarjan's algorithm).
fn circles(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    struct State<'g> {
        graph: &'g BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        index: BTreeMap<&'g Path, usize>,
        low: BTreeMap<&'g Path, usize>,
        stack: Vec<&'g Path>,
        on_stack: BTreeSet<&'g Path>,
        found: Vec<Vec<PathBuf>>,
    }
    fn visit<'g>(s: &mut State<'g>, node: &'g Path) {
        let n = s.index.len();
        s.index.insert(node, n);
        s.low.insert(node, n);
        s.stack.push(node);
        s.on_stack.insert(node);
        for next in s.graph.get(node).into_iter().flatten() {
            if !s.index.contains_key(next.as_path()) {
                visit(s, next);
                let low = s.low[node].min(s.low[next.as_path()]);
                s.low.insert(node, low);
            } else if s.on_stack.contains(next.as_path()) {
                let low = s.low[node].min(s.index[next.as_path()]);
                s.low.insert(node, low);
            }
        }
        if s.low[node] == s.index[node] {
            let mut component = Vec::new();
            while let Some(top) = s.stack.pop() {
                s.on_stack.remove(top);
                component.push(top.to_path_buf());
                if top == node {
                    break;
                }
            }
            if component.len() > 1 {
                s.found.push(component);
            }
        }
    }
    let mut state = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for node in graph.keys() {
        if !state.index.contains_key(node.as_path()) {
            visit(&mut state, node);
        }
    }
    state.found
}

/// The root files of every target's source tree in a member (library, binary, build script).
fn root_files(member: &Member) -> Vec<PathBuf> {
    ["src/lib.rs", "src/main.rs", "build.rs"].iter().map(|f| member.dir.join(f)).filter(|p| p.exists()).collect()
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root).unwrap_or(path).display().to_string()
}

#[test]
fn no_import_circles_between_files() {
    let root = workspace_root();
    let mut report = Vec::new();
    for member in members(&root) {
        for root_file in root_files(&member) {
            for circle in circles(&file_graph(&module_tree(&root_file))) {
                let names: Vec<String> = circle.iter().map(|p| relative(&root, p)).collect();
                report.push(format!("{}: {}", member.name, names.join(" <-> ")));
            }
        }
    }
    assert!(report.is_empty(), "import circles:\n{}", report.join("\n"));
}

/// Functions (free, in impls and in traits) with their first and last lines.
#[derive(Default)]
struct Functions {
    found: Vec<(String, usize, usize)>,
}

impl Functions {
    /// A function from its signature to its closing brace (doc comments and attributes left out).
    fn note(&mut self, sig: &syn::Signature, body: &syn::Block) {
        let first = syn::spanned::Spanned::span(sig).start().line;
        self.found.push((sig.ident.to_string(), first, body.brace_token.span.close().end().line));
    }
}

impl<'ast> Visit<'ast> for Functions {
    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.note(&f.sig, &f.block);
        syn::visit::visit_item_fn(self, f);
    }

    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.note(&f.sig, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }

    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(body) = &f.default {
            self.note(&f.sig, body);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }

    fn visit_item_mod(&mut self, item: &'ast syn::ItemMod) {
        if !is_test_only(&item.attrs) {
            syn::visit::visit_item_mod(self, item);
        }
    }
}

#[test]
fn functions_outside_tests_are_under_100_lines() {
    let root = workspace_root();
    let mut long = Vec::new();
    for member in members(&root) {
        for root_file in root_files(&member) {
            for file in module_tree(&root_file) {
                let mut functions = Functions::default();
                functions.visit_file(&file.syntax);
                for (name, first, last) in functions.found {
                    let lines = last - first + 1;
                    if lines > MAX_FUNCTION_LINES {
                        long.push(format!("{}:{first}: `{name}` is {lines} lines", relative(&root, &file.path)));
                    }
                }
            }
        }
    }
    assert!(long.is_empty(), "functions of {} lines or more:\n{}", MAX_FUNCTION_LINES + 1, long.join("\n"));
}

#[test]
fn the_rules_find_what_they_name() {
    // A circle of two files and an ancestor pair that is not one, from the same code paths.
    let a = PathBuf::from("a.rs");
    let b = PathBuf::from("b.rs");
    let graph = BTreeMap::from([(a.clone(), BTreeSet::from([b.clone()])), (b.clone(), BTreeSet::from([a.clone()]))]);
    assert_eq!(circles(&graph).len(), 1);
    let module = vec!["scene".to_owned(), "validate".to_owned()];
    let path: Vec<String> = ["super", "model", "Scene"].iter().map(|s| s.to_string()).collect();
    assert_eq!(absolute(&path, &module), Some(vec!["scene".into(), "model".into(), "Scene".into()]));
    assert_eq!(absolute(&["std".to_owned(), "fs".to_owned()], &module), None);
    // Line numbers need proc-macro2's span locations: without them every function has one line.
    let mut functions = Functions::default();
    functions.visit_file(&syn::parse_file("fn f() {\n    let x = 1;\n}\n").expect("parses"));
    assert_eq!(functions.found, vec![("f".to_owned(), 1, 3)]);
}
