//! The scenes of the workspace, and which modules each lists.
//!
//! A scene is a TOML file that `vrsc::scene` accepts; it lists a module when one of its
//! `[[module]]` tables or a view's `modules` names the file. Files are found under the
//! workspace folders (hidden folders, `target` and `node_modules` skipped) and in the folder of
//! each checked module, and parsed again only when their modification time or size changes.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;
use vrsc::scene::{self, ModuleSource};

/// How deep below a workspace folder scene files are looked for.
const MAX_DEPTH: usize = 8;

/// Scene files and the modules they list.
#[derive(Debug, Default)]
pub struct Scenes {
    /// Workspace folders.
    roots: Vec<PathBuf>,
    /// Every `*.toml` file found under the roots at the last scan.
    found: Vec<PathBuf>,
    parsed: HashMap<PathBuf, Parsed>,
}

#[derive(Debug)]
struct Parsed {
    stamp: Option<(SystemTime, u64)>,
    /// Canonical paths of the listed module files; empty for a file that is not a valid scene.
    modules: Vec<PathBuf>,
}

impl Scenes {
    pub fn new(roots: Vec<PathBuf>) -> Scenes {
        let mut scenes = Scenes { roots, ..Scenes::default() };
        scenes.rescan();
        scenes
    }

    /// Looks for scene files under the workspace folders again (a scene was created or saved).
    pub fn rescan(&mut self) {
        let mut found = Vec::new();
        for root in &self.roots {
            collect_toml(root, MAX_DEPTH, &mut found);
        }
        found.sort();
        found.dedup();
        self.found = found;
    }

    /// The scene files (canonical paths, sorted) that list the module at `module` (canonical).
    pub fn listing(&mut self, module: &Path) -> Vec<PathBuf> {
        let mut candidates = self.found.clone();
        if let Some(dir) = module.parent() {
            collect_toml(dir, 0, &mut candidates);
        }
        candidates.sort();
        candidates.dedup();
        candidates.into_iter().filter(|scene| self.lists(scene, module)).collect()
    }

    fn lists(&mut self, scene_path: &Path, module: &Path) -> bool {
        let stamp = std::fs::metadata(scene_path).ok().and_then(|m| Some((m.modified().ok()?, m.len())));
        let fresh = self.parsed.get(scene_path).is_some_and(|p| p.stamp.is_some() && p.stamp == stamp);
        if !fresh {
            let modules = listed_modules(scene_path);
            self.parsed.insert(scene_path.to_path_buf(), Parsed { stamp, modules });
        }
        self.parsed.get(scene_path).is_some_and(|p| p.modules.iter().any(|m| m == module))
    }
}

/// The module files a scene lists, canonical; empty when the file is not a valid scene.
fn listed_modules(path: &Path) -> Vec<PathBuf> {
    let Ok(text) = std::fs::read_to_string(path) else { return Vec::new() };
    // Cheap test first: every scene has a view, and most TOML files (Cargo.toml) are no scenes.
    if !text.contains("[[view]]") {
        return Vec::new();
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let Some(scene) = scene::parse_scene_text(&text, 1, dir, &mut vrsc::diag::Diagnostics::new()) else {
        return Vec::new();
    };
    scene
        .module_refs()
        .filter_map(|m| match &m.source {
            ModuleSource::File(file) => Some(canonical(&file.resolved)),
            ModuleSource::Std(_) => None,
        })
        .collect()
}

/// The path with links and `..` resolved, or as given when it does not exist.
pub fn canonical(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

/// Adds the `*.toml` files of `dir`, and of its folders down to `depth` more levels.
fn collect_toml(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let Ok(kind) = entry.file_type() else { continue };
        if kind.is_dir() {
            let skipped = name.starts_with('.') || name == "target" || name == "node_modules";
            if depth > 0 && !skipped {
                collect_toml(&path, depth - 1, out);
            }
        } else if name.ends_with(".toml") {
            out.push(canonical(&path));
        }
    }
}
