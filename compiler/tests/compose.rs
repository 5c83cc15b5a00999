//! Composition of whole scenes: every example scene composes without errors, every view's WGSL
//! validates in naga and parses back through naga's WGSL front end, and output is deterministic.

mod common;

use std::path::{Path, PathBuf};

fn example_scenes() -> Vec<PathBuf> {
    common::scenes_under(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples"))
}

#[test]
fn example_scenes_compose_to_valid_deterministic_wgsl() {
    let scenes = example_scenes();
    assert!(!scenes.is_empty(), "no example scenes found");
    for scene in scenes {
        let built = vrsc::compose::build::build_scene(&scene, None).expect("scene readable");
        let errors: Vec<_> = built.diags.sorted().into_iter().filter(|d| d.is_error()).collect();
        assert!(errors.is_empty(), "{}:\n{}", scene.display(), vrsc::diag::render_plain(&errors, &built.sources));
        let again = vrsc::compose::build::build_scene(&scene, None).expect("scene readable");
        for (view, view_again) in built.views.iter().zip(&again.views) {
            let shader = view.shader.as_ref().expect("a shader when there are no errors");
            let wgsl = &shader.wgsl;
            let module = naga::front::wgsl::parse_str(wgsl)
                .unwrap_or_else(|e| panic!("{} / {}: {}", scene.display(), view.name, e.emit_to_string(wgsl)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{} / {}: {e:?}", scene.display(), view.name));
            let again = view_again.shader.as_ref().expect("same result twice");
            assert_eq!(wgsl, &again.wgsl, "{} / {}: WGSL differs between two builds", scene.display(), view.name);
            assert_eq!(shader.reflection.structural_hash, again.reflection.structural_hash);
        }
    }
}

/// The views of a scene load their modules into one source map: a file both views use is parsed
/// once, so its syntax error is reported once, not once per view.
#[test]
fn a_module_shared_by_two_views_reports_its_syntax_error_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("broken.vrs"), "pipeline dim after classification.primary {\n    let x = ;\n}\n")
        .expect("write module");
    let scene = "[render]\ncompositing = \"dvr\"\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
                 [[module]]\npath = \"broken.vrs\"\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\n\n\
                 [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"z\"\n";
    std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
    let built = vrsc::compose::build::build_scene(&dir.path().join("scene.toml"), None).expect("scene readable");
    let syntax: Vec<_> = built.diags.iter().filter(|d| d.code.as_str() == "E0104").collect();
    assert_eq!(syntax.len(), 1, "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    assert_eq!(built.views.len(), 2);
}

/// Syntax errors of a scene's module files are reported once each, in the order the scene
/// names the files (scene modules, then the view's).
#[test]
fn syntax_errors_of_module_files_come_in_scene_order() {
    let dir = tempfile::tempdir().expect("temp dir");
    for name in ["first", "second", "third"] {
        let text = format!("pipeline {name} after classification.primary {{\n    let x = ;\n}}\n");
        std::fs::write(dir.path().join(format!("{name}.vrs")), text).expect("write module");
    }
    let scene = "[render]\ncompositing = \"dvr\"\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
                 [[module]]\npath = \"second.vrs\"\n\n[[module]]\npath = \"first.vrs\"\n\n\
                 [[view]]\nname = \"3d\"\nkind = \"raycast\"\nmodules = [{ path = \"third.vrs\" }]\n\n\
                 [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"z\"\n";
    std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
    let built = vrsc::compose::build::build_scene(&dir.path().join("scene.toml"), None).expect("scene readable");
    let files: Vec<String> = built
        .diags
        .iter()
        .filter(|d| d.code.as_str() == "E0104")
        .filter_map(|d| built.sources.locate(d.span).map(|(file, _)| built.sources.file(file).name.clone()))
        .collect();
    let names: Vec<&str> = files.iter().filter_map(|f| Path::new(f).file_stem()?.to_str()).collect();
    assert_eq!(
        names,
        ["second", "first", "third"],
        "{}",
        vrsc::diag::render_plain(&built.diags.sorted(), &built.sources)
    );
}

/// Views composed together (in parallel) give exactly the WGSL each gives composed alone.
#[test]
fn views_composed_together_match_views_composed_alone() {
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/compose/bench_3vol_2lights_4clips/scene.toml");
    let together = vrsc::compose::build::build_scene(&scene, None).expect("scene readable");
    assert_eq!(together.views.len(), 2);
    for view in &together.views {
        let alone = vrsc::compose::build::build_scene(&scene, Some(&view.name)).expect("scene readable");
        let wgsl = |v: &vrsc::compose::build::ViewOutput| v.shader.as_ref().map(|s| s.wgsl.clone());
        assert_eq!(wgsl(view), wgsl(&alone.views[0]), "view {}", view.name);
    }
}

/// A build keeps each view's checked program and naga module only when asked to, and keeping
/// them changes nothing in the output.
#[test]
fn a_build_keeps_the_ir_only_when_asked() {
    use vrsc::compose::build::{Keep, build_scene, build_scene_keeping};
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/compose/bench_3vol_2lights_4clips/scene.toml");
    let lean = build_scene(&scene, None).expect("scene readable");
    let kept = build_scene_keeping(&scene, None, Keep::Ir).expect("scene readable");
    assert_eq!(lean.views.len(), kept.views.len());
    for (lean, kept) in lean.views.iter().zip(&kept.views) {
        assert!(lean.ir.is_none(), "view {}: IR kept unasked", lean.name);
        let ir = kept.ir.as_ref().unwrap_or_else(|| panic!("view {}: IR not kept", kept.name));
        let valid = ir.module.as_ref().expect("a module for a view that composed");
        let rewritten =
            naga::back::wgsl::write_string(&valid.module, &valid.info, naga::back::wgsl::WriterFlags::empty())
                .expect("the kept module writes");
        let wgsl = |v: &vrsc::compose::build::ViewOutput| v.shader.as_ref().map(|s| s.wgsl.clone());
        assert_eq!(wgsl(lean), wgsl(kept), "view {}", lean.name);
        assert_eq!(Some(rewritten), wgsl(kept), "view {}: the kept module is the one written", kept.name);
    }
}

/// Expressions as deep as the nesting limits allow compose in every view, even in a debug build
/// called from a test thread with a small stack (views compose on threads with a stack of their
/// own).
#[test]
fn the_deepest_allowed_expression_composes_in_every_view() {
    let dir = tempfile::tempdir().expect("temp dir");
    let chain = format!("state.value{}", " + 1.0".repeat(250));
    let module = format!(
        "pipeline deep after classification.primary {{\n    state value: f32 = 0.0;\n    \
         state color: vec4f = vec4f(0.0);\n    state.color = vec4f({chain});\n}}\n"
    );
    std::fs::write(dir.path().join("deep.vrs"), module).expect("write module");
    let scene = "[render]\ncompositing = \"dvr\"\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
                 [[module]]\npath = \"deep.vrs\"\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\n\n\
                 [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"z\"\n";
    std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
    let built = vrsc::compose::build::build_scene(&dir.path().join("scene.toml"), None).expect("scene readable");
    assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    assert!(built.views.iter().all(|v| v.shader.is_some()));
}

/// A bricked volume (`bricks = true`) is sampled through its lookup everywhere: the standard
/// sampling, the gradient's library function (a variant of it per bricked volume) and an
/// additional volume's template, in raycast and slice views; the shader declares the brick
/// bindings and no texture of its own.
#[test]
fn bricked_volumes_sample_through_their_lookup() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = "[render]\ncompositing = \"dvr\"\nshading = true\nmemory = \"512 MiB\"\n\n\
                 [[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\nbricks = true\n\n\
                 [[volume]]\nname = \"ct\"\nrole = \"additional\"\nphantom = \"head\"\n\n\
                 [[view]]\nname = \"3d\"\nkind = \"raycast\"\n\n\
                 [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"z\"\n";
    std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
    let built = vrsc::compose::build::build_scene(&dir.path().join("scene.toml"), None).expect("scene readable");
    assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    for view in &built.views {
        let shader = view.shader.as_ref().expect("a shader");
        let wgsl = &shader.wgsl;
        assert!(wgsl.contains("fn volume_sample(p: vec3<f32>) -> f32"), "{}: {wgsl}", view.name);
        assert!(wgsl.contains("volume_sample("), "{}", view.name);
        // The pool is sampled in the lookup only: its exact sample and its sample inside the
        // current brick's segment.
        assert_eq!(wgsl.matches("textureSampleLevel(volume, volume_sampler").count(), 2, "{}", view.name);
        assert!(wgsl.contains("fn volume_sample_in_segment("), "{}", view.name);
        // The additional volume keeps its texture.
        assert!(wgsl.contains("textureSampleLevel(volume_ct, volume_ct_sampler"), "{}", view.name);
        let kinds: Vec<_> =
            shader.reflection.bindings.iter().filter(|b| b.name == "volume").map(|b| format!("{:?}", b.kind)).collect();
        assert_eq!(kinds, ["BrickPool", "VolumeSampler", "PageTable", "BrickLayout", "BrickRequests"], "{}", view.name);
        naga::front::wgsl::parse_str(wgsl).unwrap_or_else(|e| panic!("{}: {}", view.name, e.emit_to_string(wgsl)));
    }
    // Shading's gradient takes the volume as a parameter: its variant calls the lookup.
    let wgsl = &built.views[0].shader.as_ref().expect("3d").wgsl;
    assert!(wgsl.matches("volume_sample(").count() >= 7, "{wgsl}");
    // `vrsc explain` says where the lookup comes from.
    let keep = vrsc::compose::build::Keep::Ir;
    let kept = vrsc::compose::build::build_scene_keeping(&dir.path().join("scene.toml"), None, keep).expect("readable");
    let explained = vrsc::compose::explain::explain(&kept.views[0], &kept.sources).expect("explained");
    let note = "// from stdlib/bricks.wgsl: the lookup of bricked volume `volume` (the runtime keeps it in bricks)\nfn volume_sample(";
    assert!(explained.contains(note), "{explained}");
}

/// A sample that reads a bricked volume's segment asks whether it read outside it right after
/// the last function that reads one, and is taken back in the `@ray` fields written before
/// that question only: unshaded DVR asks right after `sample_primary` and saves nothing, while
/// a `@ray` field written before the read is saved and given back.
#[test]
fn a_sample_asks_for_a_missed_segment_right_after_its_read() {
    let dir = tempfile::tempdir().expect("temp dir");
    let main_of = |module: Option<&str>| {
        let mut scene = "[render]\ncompositing = \"dvr\"\nmemory = \"512 MiB\"\n\n\
                         [[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\nbricks = true\n\n\
                         [[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
            .to_string();
        if let Some(module) = module {
            std::fs::write(dir.path().join("count.vrs"), module).expect("write module");
            scene.push_str("\n[[module]]\npath = \"count.vrs\"\n");
        }
        std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
        let built = vrsc::compose::build::build_scene(&dir.path().join("scene.toml"), None).expect("scene readable");
        assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
        let wgsl = built.views[0].shader.as_ref().expect("a shader").wgsl.clone();
        wgsl[wgsl.find("fn main(").expect("the entry point")..].to_string()
    };
    let main = main_of(None);
    let read = main.find("sample_primary_in_segment((&state));").expect("the segment read");
    let asked = main[read..].find("volume_segment_missed()").expect("the question") + read;
    assert!(!main[read..asked].contains("classify_primary"), "asked after classification: {main}");
    assert!(!main.contains("saved."), "a @ray field saved that nothing before the question writes: {main}");

    let count = "pipeline count before sampling.primary {\n    @ray state looks: f32 = 0.0;\n    \
                 state.looks = state.looks + 1.0;\n}\n";
    let main = main_of(Some(count));
    assert!(main.contains("saved.looks = "), "{main}");
    assert!(main.contains("state.looks = "), "{main}");
    assert!(!main.contains("saved.accum"), "{main}");
}

/// `[render] memory` takes sizes with units; nonsense is an error at the key.
#[test]
fn memory_budgets_are_sizes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let write = |memory: &str| {
        let scene = format!(
            "[render]\nmemory = \"{memory}\"\nhost_memory = \"2 GiB\"\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\n\
             phantom = \"head\"\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
        );
        std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
        vrsc::compose::build::read_scene(&dir.path().join("scene.toml")).expect("readable")
    };
    let scene = write("512 MiB").scene.expect("valid");
    assert_eq!((scene.memory.gpu, scene.memory.host), (512 << 20, 2 << 30));
    assert_eq!(write("1.5GB").scene.expect("valid").memory.gpu, 3 << 29);
    for bad in ["lots", "1 MiB", "-3 GiB"] {
        let parsed = write(bad);
        let text = vrsc::diag::render_plain(&parsed.diags.sorted(), &parsed.sources);
        assert!(text.contains("`memory` must be a size of at least 64 MiB"), "{bad}: {text}");
    }
}

/// What needs a volume's voxels in one texture takes a level of a bricked volume that fits one:
/// light volumes of a bricked primary, a surface extracted from a bricked volume build.
#[test]
fn light_volumes_and_surfaces_of_bricked_volumes_build() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = "[render]\ncompositing = \"dvr\"\nshading = true\nshadows = \"volume\"\n\n\
                 [[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\nbricks = true\n\n\
                 [[mesh]]\nname = \"bone\"\nvolume = \"head\"\nlevel = 300.0\n\n\
                 [[view]]\nname = \"3d\"\nkind = \"raycast\"\n";
    std::fs::write(dir.path().join("scene.toml"), scene).expect("write scene");
    let parsed = vrsc::compose::build::read_scene(&dir.path().join("scene.toml")).expect("readable");
    let text = vrsc::diag::render_plain(&parsed.diags.sorted(), &parsed.sources);
    assert!(!parsed.diags.has_errors(), "{text}");
}

/// A filter among a group's children is a filter pass of every view whose tree holds it: each
/// view composes it (its errors reported once), names it by its place, and explains it.
#[test]
fn filters_in_a_tree_compose_into_passes_of_their_own() {
    let dir = tempfile::tempdir().expect("a folder");
    let scene = "[[volume]]\nname = \"ct\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
        [[mesh]]\nname = \"ball\"\nshape = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 20.0\n\n\
        [[group]]\nname = \"grey\"\nchildren = [\"ball\", { filter = \"std::luminance\" }, { filter = \"std::edges\" }]\n\n\
        [[view]]\nname = \"a\"\nkind = \"raycast\"\npicture = [\"grey\", \"volume\"]\n\n\
        [[view]]\nname = \"b\"\nkind = \"raycast\"\npicture = [\"grey\", \"volume\"]\n";
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).expect("scene written");
    let built =
        vrsc::compose::build::build_scene_keeping(&path, None, vrsc::compose::build::Keep::Ir).expect("readable");
    assert!(!built.diags.has_errors(), "{:?}", built.diags.iter().map(|d| &d.message).collect::<Vec<_>>());
    for view in &built.views {
        let names: Vec<(usize, &str)> = view.tree_filters.iter().map(|(f, p)| (*f, p.name.as_str())).collect();
        assert_eq!(names, [(0, "grey-2.filters"), (1, "grey-3.filters")]);
        let explained = vrsc::compose::explain::explain_with_filters(view, &built.sources).expect("explained");
        for place in ["grey-2", "grey-3"] {
            let marker =
                format!("// ===== the filter pass of view `{}` (the filter `{place}` of its tree) =====", view.name);
            assert!(explained.contains(&marker), "{marker}");
        }
        assert!(explained.contains("fn luminance") && explained.contains("fn edges"));
    }
    // A filter module with an error: shown once, though both views compose it.
    std::fs::write(
        dir.path().join("bad.vrs"),
        "pipeline bad in filter.apply {\n    state color: vec4f;\n    state.color = 1;\n}\n",
    )
    .expect("module written");
    std::fs::write(&path, scene.replace("std::edges", "bad.vrs")).expect("scene written");
    let built = vrsc::compose::build::build_scene(&path, None).expect("readable");
    let shown = built.diags.sorted();
    let errors: Vec<&str> = shown.iter().filter(|d| d.is_error()).map(|d| d.code.as_str()).collect();
    assert_eq!(errors, ["E0301"]);
}
