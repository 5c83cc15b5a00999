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
