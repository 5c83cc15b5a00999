//! Probe variants: every showable field of every view of the examples and the rendering fixtures
//! composes into a validated probe variant, and the generated module of a sample field and of a
//! `@ray` field are snapshots.

mod common;

use std::path::{Path, PathBuf};
use vrsc::compose::build::{Keep, build_scene_keeping};
use vrsc::compose::probe::{self, DeclaredField};

fn relative(scene: &Path) -> PathBuf {
    common::pathdiff(scene, &std::env::current_dir().expect("cwd"))
}

/// Every view of `scene` with the fields it declares.
fn view_fields(scene: &Path) -> Vec<(String, Vec<DeclaredField>)> {
    let built = build_scene_keeping(&relative(scene), None, Keep::Ir).expect("scene readable");
    assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    built
        .views
        .iter()
        .map(|v| {
            let ir = v.ir.as_ref().expect("kept");
            (v.name.clone(), probe::declared_fields(&ir.program, &v.composition))
        })
        .collect()
}

#[test]
fn every_field_of_every_view_has_a_probe_variant() {
    let root = common::fixtures().join("../..");
    let mut scenes = common::scenes_under(&root.join("examples"));
    scenes.extend(common::scenes_under(&common::fixtures().join("render")));
    let mut probed = 0;
    for scene in scenes {
        for (view, fields) in view_fields(&scene) {
            for field in fields.iter().filter(|f| f.showable()) {
                let built = probe::build_probe(&relative(&scene), &view, &field.name).expect("scene readable");
                let rendered = vrsc::diag::render_plain(&built.diags.sorted(), &built.sources);
                let variant = built.variant.unwrap_or_else(|| {
                    panic!("{} view {view} field {}: no variant\n{rendered}", scene.display(), field.name)
                });
                assert!(!built.diags.has_errors(), "{rendered}");
                assert_eq!(&variant.layout.field, field);
                let uniforms: Vec<&str> = variant.shader.reflection.uniforms.iter().map(|u| u.name.as_str()).collect();
                for name in [probe::MODE_UNIFORM, probe::PASS_UNIFORM] {
                    assert!(uniforms.contains(&name), "{view}.{}: no uniform {name}", field.name);
                }
                probed += 1;
            }
        }
    }
    assert!(probed > 100, "only {probed} probes");
}

#[test]
fn standard_and_user_fields_are_found() {
    let ablation = common::fixtures().join("../../examples/ablation/scene.toml");
    let fields = view_fields(&ablation);
    let names = |view: &str| -> Vec<String> {
        fields.iter().find(|(v, _)| v == view).map(|(_, f)| f.iter().map(|f| f.name.clone()).collect()).unwrap()
    };
    for view in ["3d", "axial"] {
        let names = names(view);
        for field in ["t", "pos", "value", "gradient", "accum", "out_color", "terminate", "zone_a", "zone_b"] {
            assert!(names.iter().any(|n| n == field), "{view} has no {field}: {names:?}");
        }
    }
}

fn generated(scene: &str, view: &str, field: &str) -> String {
    let path = common::fixtures().join(scene);
    let built = probe::build_probe(&relative(&path), view, field).expect("scene readable");
    built.variant.expect("a variant").source
}

#[test]
fn generated_module_of_a_sample_field() {
    insta::assert_snapshot!("probe_gradient", generated("render/head_dvr.toml", "3d", "gradient"));
}

#[test]
fn generated_module_of_a_ray_field() {
    insta::assert_snapshot!("probe_accum", generated("render/head_dvr.toml", "3d", "accum"));
}

#[test]
fn an_unknown_field_names_the_closest() {
    let path = common::fixtures().join("render/head_dvr.toml");
    let built = probe::build_probe(&relative(&path), "3d", "gradiant").expect("scene readable");
    assert!(built.variant.is_none());
    let rendered = vrsc::diag::render_plain(&built.diags.sorted(), &built.sources);
    insta::assert_snapshot!("probe_unknown_field", rendered);
}
