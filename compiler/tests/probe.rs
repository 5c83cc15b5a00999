//! Probe variants: every showable field of every view of the examples and the rendering fixtures
//! composes into a validated probe variant, and the generated module of a sample field and of a
//! `@ray` field are snapshots.

mod common;

use std::path::{Path, PathBuf};
use vrsc::compose::build::{Keep, ViewPass, build_scene_keeping};
use vrsc::compose::probe::{self, DeclaredField};

fn relative(scene: &Path) -> PathBuf {
    common::pathdiff(scene, &std::env::current_dir().expect("cwd"))
}

/// Every view of `scene` with the fields it declares, of its ray pipeline and its filter passes.
fn view_fields(scene: &Path) -> Vec<(String, Vec<DeclaredField>)> {
    let built = build_scene_keeping(&relative(scene), None, Keep::Ir).expect("scene readable");
    assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    built.views.iter().map(|v| (v.name.clone(), probe::view_fields(v))).collect()
}

#[test]
fn every_field_of_every_view_has_a_probe_variant() {
    let root = common::fixtures().join("../..");
    let mut scenes = common::scenes_under(&root.join("examples"));
    scenes.extend(common::scenes_under(&common::fixtures().join("render")));
    let (mut probed, mut filter_fields) = (0, 0);
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
                // The probe lies in the pass that declares the field: the ray pipeline with its
                // mode, or a filter pass (read at `filter.finish`).
                let (shader, wanted) = match (field.pass, &variant.filter) {
                    (ViewPass::Ray, None) => (&variant.shader, &[probe::MODE_UNIFORM, probe::PASS_UNIFORM][..]),
                    (ViewPass::Filter | ViewPass::TreeFilter(_), Some(filter)) => (filter, &[probe::PASS_UNIFORM][..]),
                    (pass, filter) => {
                        panic!("{view}.{}: a {pass:?} field with filter {}", field.name, filter.is_some())
                    }
                };
                let uniforms: Vec<&str> = shader.reflection.uniforms.iter().map(|u| u.name.as_str()).collect();
                for name in wanted {
                    assert!(uniforms.contains(name), "{view}.{}: no uniform {name}", field.name);
                }
                filter_fields += usize::from(field.pass != ViewPass::Ray);
                probed += 1;
            }
        }
    }
    assert!(probed > 100 && filter_fields > 8, "only {probed} probes, {filter_fields} of filter passes");
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
