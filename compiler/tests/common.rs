//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use vrsc::compose::build::{Keep, build_scene_keeping};
use vrsc::driver::{self, Checked};

/// The workspace's `tests/fixtures` folder.
pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures")
}

/// The entries of a fixture folder, sorted: `NAME.vrs` files and `NAME/` folders (entry `main.vrs`).
pub fn cases(folder: &str) -> Vec<(String, PathBuf)> {
    let dir = fixtures().join(folder);
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .filter_map(Result::ok)
        .filter_map(|e| {
            let path = e.path();
            let name = path.file_stem()?.to_str()?.to_string();
            if path.join("scene.toml").is_file() {
                Some((name, path.join("scene.toml")))
            } else if path.is_dir() {
                Some((name, path.join("main.vrs")))
            } else if path.extension().is_some_and(|x| x == "vrs") {
                Some((name, path))
            } else {
                None
            }
        })
        .collect();
    out.sort();
    out
}

/// Checks a fixture, naming single files by their file name so snapshots do not depend on
/// where the checkout lives.
pub fn check_fixture(path: &Path) -> Checked {
    if path.file_name().is_some_and(|n| n == "main.vrs") {
        let cwd = std::env::current_dir().expect("cwd");
        let rel = pathdiff(path, &cwd);
        return driver::check_files(&[rel]).expect("fixture readable");
    }
    let text = std::fs::read_to_string(path).expect("fixture readable");
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("fixture.vrs");
    driver::check_source(name, &text, path.parent())
}

/// Composes a scene fixture; returns its rendered diagnostics and their codes. A file `probe`
/// beside the scene names a field to probe (as `vrsc render --probe` does): its diagnostic is
/// added.
pub fn build_fixture(path: &Path) -> (String, Vec<String>) {
    let cwd = std::env::current_dir().expect("cwd");
    let probe = std::fs::read_to_string(path.with_file_name("probe")).ok();
    let keep = if probe.is_some() { Keep::Ir } else { Keep::Outputs };
    let mut built = build_scene_keeping(&pathdiff(path, &cwd), None, keep).expect("fixture readable");
    if let Some(Err(d)) = probe.map(|field| vrsc::compose::probe::views_with_field(&built, field.trim())) {
        built.diags.push(d);
    }
    let diags = built.diags.sorted();
    let codes = diags.iter().map(|d| d.code.as_str().to_string()).collect();
    (vrsc::diag::render_plain(&diags, &built.sources), codes)
}

/// `path` relative to `base` when it lies below base's parent (tests run in `compiler/`).
pub fn pathdiff(path: &Path, base: &Path) -> PathBuf {
    let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    match base.parent().and_then(|p| path.strip_prefix(p.canonicalize().ok()?).ok()) {
        Some(rest) => Path::new("..").join(rest),
        None => path,
    }
}

/// Every `.toml` file under `root`, sorted.
pub fn scenes_under(root: &Path) -> Vec<PathBuf> {
    let mut scenes = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("folder readable").filter_map(Result::ok) {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "toml") {
                scenes.push(path);
            }
        }
    }
    scenes.sort();
    scenes
}
