//! Composition grows linearly with the counts a scene controls: each light and each instance
//! of a template adds the same amount of IR and WGSL, at 2, 4, 8 and 16 lights (the limit) and
//! at 8, 16, 32 and 64 instances (the limit). Counted, not timed: the naga expressions and
//! statements of the composed module and the bytes of its WGSL are deterministic, and a pass
//! whose output grew faster than the count (a function duplicated per pair of lights, a
//! uniform block rebuilt per instance) shows as a growing increment.

use std::path::Path;
use vrsc::compose::build::{Keep, build_scene_keeping};

/// A template: one pipeline function and one uniform per instance.
const TINT: &str = "pipeline tint_$ after classification.primary {\n    uniform tint_$: vec4f = vec4f(1.0);\n    \
                    state color: vec4f;\n    state.color = state.color * tint_$;\n}\n";

/// What one composed view is made of: naga expressions, naga statements (nested ones
/// included), WGSL bytes.
#[derive(Clone, Copy, Debug)]
struct Size {
    expressions: usize,
    statements: usize,
    wgsl: usize,
}

fn count_statements(block: &naga::Block) -> usize {
    block
        .iter()
        .map(|s| {
            1 + match s {
                naga::Statement::Block(b) => count_statements(b),
                naga::Statement::If { accept, reject, .. } => count_statements(accept) + count_statements(reject),
                naga::Statement::Loop { body, continuing, .. } => count_statements(body) + count_statements(continuing),
                naga::Statement::Switch { cases, .. } => cases.iter().map(|c| count_statements(&c.body)).sum(),
                _ => 0,
            }
        })
        .sum()
}

/// Composes the one-view scene `render` + `module` (extra scene text) and measures it.
fn size_of(dir: &Path, render: &str, module: &str) -> Size {
    std::fs::write(dir.join("tint.vrs"), TINT).unwrap();
    let text = format!(
        "[render]\n{render}\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n\n{module}\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let built = build_scene_keeping(&path, None, Keep::Ir).expect("scene readable");
    assert!(!built.diags.has_errors(), "{:?}", built.diags.sorted());
    let view = &built.views[0];
    let module = &view.ir.as_ref().and_then(|ir| ir.module.as_ref()).expect("a validated module").module;
    let functions = module.functions.iter().map(|(_, f)| f).chain(module.entry_points.iter().map(|e| &e.function));
    let (mut expressions, mut statements) = (0, 0);
    for f in functions {
        expressions += f.expressions.len();
        statements += count_statements(&f.body);
    }
    Size { expressions, statements, wgsl: view.shader.as_ref().expect("a shader").wgsl.len() }
}

/// One number of a [`Size`].
type Metric = fn(&Size) -> usize;

/// Asserts that `sizes` (measured at the doubling counts `counts`) grow linearly: every
/// doubling adds the same amount per added item, within 10%, and adds something.
fn assert_linear(what: &str, counts: &[usize], sizes: &[Size]) {
    let metrics: [(&str, Metric); 3] =
        [("expressions", |s| s.expressions), ("statements", |s| s.statements), ("WGSL bytes", |s| s.wgsl)];
    for (metric, get) in metrics {
        let per_item: Vec<f64> = counts
            .windows(2)
            .zip(sizes.windows(2))
            .map(|(n, s)| (get(&s[1]) as f64 - get(&s[0]) as f64) / (n[1] - n[0]) as f64)
            .collect();
        let (lo, hi) = per_item.iter().fold((f64::MAX, 0.0f64), |(lo, hi), &d| (lo.min(d), hi.max(d)));
        assert!(lo > 0.0, "{what}: {metric} must grow with the count: {per_item:?} per item");
        assert!(hi <= 1.1 * lo, "{what}: {metric} per added item {per_item:?} (sizes {sizes:?}) is not constant");
    }
}

#[test]
fn lights_grow_the_composed_shader_linearly() {
    let dir = tempfile::tempdir().unwrap();
    let counts = [2, 4, 8, 16];
    let sizes: Vec<Size> = counts
        .iter()
        .map(|&n| {
            let lights: Vec<String> = (0..n).map(|i| format!("\"l{i}\"")).collect();
            size_of(dir.path(), &format!("shading = true\nlights = [{}]", lights.join(", ")), "")
        })
        .collect();
    assert_linear("lights", &counts, &sizes);
}

#[test]
fn template_instances_grow_the_composed_shader_linearly() {
    let dir = tempfile::tempdir().unwrap();
    let counts = [8, 16, 32, 64];
    let sizes: Vec<Size> = counts
        .iter()
        .map(|&n| {
            let names: Vec<String> = (0..n).map(|i| format!("\"i{i}\"")).collect();
            size_of(dir.path(), "", &format!("[[module]]\npath = \"tint.vrs\"\ninstances = [{}]\n", names.join(", ")))
        })
        .collect();
    assert_linear("instances", &counts, &sizes);
}
