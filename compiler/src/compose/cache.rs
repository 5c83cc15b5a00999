//! A composition cache: composing a scene whose structure was composed before (same views,
//! same standard and user modules with the same instances, same module sources) returns the
//! earlier shaders instead of composing again. Changing only uniform values, camera, sizes,
//! volumes' files or transfer functions is such a hit; it costs a scene parse, a read of the
//! module files and the checks of the scene's values against the views, not a composition. A
//! hit is only given where neither the composition nor the scene as it is now has anything to
//! say: otherwise the scene is composed again, so that every diagnostic is the one `vrsc
//! build` gives.

use super::build::{self, BuiltScene, Keep};
use super::reflect::content_hash;
use crate::scene::{ModuleRef, ModuleSource, Scene};
use crate::source::SourceMap;
use std::collections::HashMap;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Composed scenes by structural key.
#[derive(Default)]
pub struct CompositionCache {
    entries: HashMap<String, Entry>,
    stats: CacheStats,
}

/// How often [`CompositionCache::build`] reused a composition.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Builds answered from the cache.
    pub hits: u64,
    /// Builds that composed the scene (and stored it).
    pub misses: u64,
}

struct Entry {
    /// Every user source file the composition read, with the hash of its text then.
    inputs: Vec<(PathBuf, String)>,
    built: Arc<BuiltScene>,
}

/// The outcome of [`CompositionCache::build`].
pub struct CachedBuild {
    /// The composition: shaders, reflection and the diagnostics of when it was composed.
    /// Reflection's uniform `value`s are those of that scene; take current values from `scene`.
    pub built: Arc<BuiltScene>,
    /// The scene as it is now (`None` when it is invalid; then `built` holds its errors).
    pub scene: Option<Scene>,
    /// Whether `built` came from the cache.
    pub hit: bool,
}

impl CompositionCache {
    /// An empty cache.
    pub fn new() -> CompositionCache {
        CompositionCache::default()
    }

    /// Hits and misses so far.
    pub fn stats(&self) -> CacheStats {
        self.stats
    }

    /// Composes every view of the scene at `path`, or reuses an earlier composition of the same
    /// structure whose module files are unchanged.
    pub fn build(&mut self, path: &Path) -> std::io::Result<CachedBuild> {
        let parsed = build::read_scene(path)?;
        let Some(scene) = parsed.scene.clone() else {
            self.stats.misses += 1;
            let built = build::compose_scene(parsed, None, Keep::Outputs);
            return Ok(CachedBuild { built: Arc::new(built), scene: None, hit: false });
        };
        let key = structural_key(&scene);
        if let Some(entry) = self.entries.get(&key)
            && inputs_unchanged(&entry.inputs)
            && still_clean(&parsed, &scene, &entry.built)
        {
            self.stats.hits += 1;
            return Ok(CachedBuild { built: entry.built.clone(), scene: Some(scene), hit: true });
        }
        self.stats.misses += 1;
        let built = Arc::new(build::compose_scene(parsed, None, Keep::Outputs));
        if !built.diags.has_errors() {
            let inputs = user_inputs(&built.sources, path);
            self.entries.insert(key, Entry { inputs, built: built.clone() });
        }
        Ok(CachedBuild { built, scene: Some(scene), hit: false })
    }
}

/// Whether a composition `built` of the same structure, clean when it was made (no diagnostic
/// at all), stays clean for `scene` as parsed now: nothing said of the scene file, and the checks
/// of its values against the views pass ([`build::check_against_views`]: a uniform renamed in
/// `[uniforms]`, a value of another type). Otherwise the scene is composed again, so that what it
/// says is said with the scene as it is: the one path `vrsc build` takes.
fn still_clean(parsed: &build::ParsedScene, scene: &Scene, built: &BuiltScene) -> bool {
    if !parsed.diags.is_empty() || !built.diags.is_empty() {
        return false;
    }
    let mut diags = crate::diag::Diagnostics::new();
    super::limits::check_counts(scene).into_iter().for_each(|d| diags.push(d));
    let every_view = built.views.iter().all(build::view_composed);
    build::check_against_views(scene, &built.views, every_view, &mut diags);
    diags.is_empty()
}

/// Everything of a scene that shapes its shaders: per view, its name and kind and the modules
/// composed for it (standard ones with their instances, then the scene's and the view's, then
/// its filters and the filters of its tree).
pub fn structural_key(scene: &Scene) -> String {
    let mut key = String::new();
    for view in &scene.views {
        let _ = write!(key, "view {} {:?}:", view.name.name, view.kind.value);
        for std in scene.standard_modules(view) {
            let _ = write!(key, " std::{}{:?}", std.name, std.instances);
        }
        for module in scene.modules.iter().chain(&view.modules) {
            key.push(' ');
            module_key(&mut key, module);
        }
        // The filter pass is a shader of its own.
        key.push_str(" filters:");
        for module in &view.filters {
            key.push(' ');
            module_key(&mut key, module);
        }
        // So is each filter of its tree, which the runtime finds by its index.
        key.push_str(" tree filters:");
        for f in scene.filters_under(view) {
            let _ = write!(key, " {f}=");
            scene.tree_filters.get(f).inspect(|module| module_key(&mut key, module));
        }
        key.push('\n');
    }
    for (binding, lookup) in scene.bricked_bindings() {
        let _ = writeln!(key, "bricked {binding} {:?}", lookup.map(|l| &l.resolved));
    }
    key
}

fn module_key(key: &mut String, module: &ModuleRef) {
    match &module.source {
        ModuleSource::Std(name) => key.push_str(&name.value),
        ModuleSource::File(file) => key.push_str(&file.resolved.display().to_string()),
    }
    if let Some(instances) = &module.instances {
        let names: Vec<&str> = instances.iter().map(|i| i.name.as_str()).collect();
        let _ = write!(key, "{names:?}");
    }
}

/// The user files a composition read (every source with a path but the scene file itself).
fn user_inputs(sources: &SourceMap, scene: &Path) -> Vec<(PathBuf, String)> {
    sources
        .files()
        .filter_map(|(_, f)| Some((f.path.clone()?, &f.text)))
        .filter(|(p, _)| p != scene)
        .map(|(p, text)| (p, content_hash(text)))
        .collect()
}

fn inputs_unchanged(inputs: &[(PathBuf, String)]) -> bool {
    inputs.iter().all(|(path, hash)| std::fs::read_to_string(path).is_ok_and(|text| &content_hash(&text) == hash))
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODULE: &str = "pipeline dim after classification.primary {\n    uniform k: f32 = 0.5;\n    \
                          state color: vec4f;\n    state.color = state.color * k;\n}\n";

    fn scene(k: f32, compositing: &str) -> String {
        format!(
            "[render]\ncompositing = \"{compositing}\"\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\n\
             phantom = \"head\"\n\n[[module]]\npath = \"dim.vrs\"\n\n[uniforms]\nk = {k:.2}\n\n\
             [[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
        )
    }

    /// A value change the composition rejects (a uniform renamed in `[uniforms]`, a value of
    /// another type) is not a hit: the scene is composed again and says what `build` says.
    #[test]
    fn a_renamed_or_mistyped_uniform_value_is_said_as_build_says_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(dir.path().join("dim.vrs"), MODULE).unwrap();
        std::fs::write(&path, scene(0.5, "dvr")).unwrap();
        let mut cache = CompositionCache::new();
        assert!(!cache.build(&path).unwrap().hit);
        for (text, what) in [
            (scene(0.5, "dvr").replace("k = 0.50", "kk = 0.50"), "no view reads a uniform `kk`"),
            (scene(0.5, "dvr").replace("k = 0.50", "k = [0.5, 0.5]"), "`k`"),
        ] {
            std::fs::write(&path, &text).unwrap();
            let cached = cache.build(&path).unwrap();
            let built = build::build_scene(&path, None).unwrap();
            let said = |b: &BuiltScene| b.diags.iter().map(|d| d.message.clone()).collect::<Vec<_>>();
            assert!(!cached.hit, "{what}: composed again");
            assert!(cached.built.diags.has_errors(), "{what}: an error, as build gives");
            assert_eq!(said(&cached.built), said(&built), "{what}: the same diagnostics as build");
            assert!(said(&built).iter().any(|m| m.contains(what)), "{what}: {:?}", said(&built));
        }
        // Fixed again: a hit on the first composition.
        std::fs::write(&path, scene(0.25, "dvr")).unwrap();
        assert!(cache.build(&path).unwrap().hit);
    }

    #[test]
    fn uniform_changes_hit_structural_changes_miss() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(dir.path().join("dim.vrs"), MODULE).unwrap();
        std::fs::write(&path, scene(0.5, "dvr")).unwrap();
        let mut cache = CompositionCache::new();
        let first = cache.build(&path).unwrap();
        assert!(!first.hit && !first.built.diags.has_errors());

        std::fs::write(&path, scene(0.25, "dvr")).unwrap();
        let second = cache.build(&path).unwrap();
        assert!(second.hit, "a uniform-only change reuses the composition");
        assert!(Arc::ptr_eq(&first.built, &second.built));
        let k = second.scene.as_ref().unwrap().uniform_values().get("k").cloned();
        assert_eq!(k, Some(crate::scene::UniformValue::Float(0.25)));

        std::fs::write(&path, scene(0.25, "mip")).unwrap();
        assert!(!cache.build(&path).unwrap().hit, "another compositing mode is another shader");

        let filtered = scene(0.25, "mip") + "filters = [{ path = \"std::luminance\" }]\n";
        std::fs::write(&path, &filtered).unwrap();
        let with_filters = cache.build(&path).unwrap();
        assert!(!with_filters.hit, "a filter pass is a shader of its own");
        assert!(with_filters.built.views[0].filter.as_ref().is_some_and(|f| f.shader.is_some()));
        std::fs::write(&path, scene(0.25, "mip")).unwrap();
        let without = cache.build(&path).unwrap();
        assert!(without.hit && without.built.views[0].filter.is_none(), "the composition without filters again");
        let tree = |filter: &str| {
            scene(0.25, "mip")
                + "picture = [\"g\", \"volume\"]\n\n[[mesh]]\nname = \"m\"\nshape = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 5.0\n\n\
                   [[group]]\nname = \"g\"\nchildren = [\"m\""
                + filter
                + "]\n"
        };
        std::fs::write(&path, tree("")).unwrap();
        assert!(!cache.build(&path).unwrap().hit, "meshes under the volume: another shader");
        std::fs::write(&path, tree(", { filter = \"std::luminance\" }")).unwrap();
        let filtered = cache.build(&path).unwrap();
        assert!(!filtered.hit, "a filter in the tree is a shader of its own");
        assert!(filtered.built.views[0].tree_filters.len() == 1 && build::view_composed(&filtered.built.views[0]));
        std::fs::write(&path, scene(0.25, "mip")).unwrap();
        assert!(cache.build(&path).unwrap().hit);

        std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("0.5", "0.75")).unwrap();
        assert!(!cache.build(&path).unwrap().hit, "an edited module file is composed again");

        std::fs::write(&path, scene(0.25, "dvr").replace("[render]", "[render]\nshadnig = true")).unwrap();
        let invalid = cache.build(&path).unwrap();
        assert!(!invalid.hit && invalid.scene.is_none() && invalid.built.diags.has_errors());
        assert_eq!(cache.stats(), CacheStats { hits: 3, misses: 7 });
    }
}
