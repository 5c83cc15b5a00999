//! Every combination of the options a scene documents renders or is refused at build: each cell of
//! the product of compositing mode (in the shared `[render]` table or the view's own `render`
//! table; the path tracer at one sample, without the settings it ignores: see `common::cells`), the
//! volumes beside the primary one, view kind, shading and lights, empty-space skipping and probing
//! either composes and renders a 16x16 image on lavapipe with no wgpu error (and, probed, no NaN or
//! infinite value in its output colour), or `build` refuses it with an error at a scene value.
//! Which cells are refused is stated, not accepted: none of the scene-option cells (bricked or
//! not), and exactly the light cells with shadows but no shading (`LightCell::refusal`); the set
//! refused must equal the set stated. The cells come from `common::cells`.

use crate::common;

use common::cells::{Cell, LightCell, Lighting, MeshCell, Placement};
use std::collections::{BTreeSet, HashMap};
use vrs_runtime::{ProbeSpec, RenderOptions, SceneRenderer};

/// What happened to the cells.
#[derive(Default, Debug)]
struct Tally {
    rendered: usize,
    probed: usize,
    /// The cells `build` refused, described.
    refused: BTreeSet<String>,
    pipelines: u64,
}

/// Fails unless `refused` is exactly `expected`, listing the cells refused that should render
/// and those rendered that should be refused.
fn assert_refused_exactly(refused: &BTreeSet<String>, expected: &BTreeSet<String>) {
    let wrongly: Vec<&String> = refused.difference(expected).collect();
    let missed: Vec<&String> = expected.difference(refused).collect();
    assert!(
        wrongly.is_empty() && missed.is_empty(),
        "{} cells refused that should render:\n{}\n{} cells rendered that should be refused:\n{}",
        wrongly.len(),
        wrongly.iter().take(20).map(|c| format!("  {c}")).collect::<Vec<_>>().join("\n"),
        missed.len(),
        missed.iter().take(20).map(|c| format!("  {c}")).collect::<Vec<_>>().join("\n"),
    );
}

// The matrices run as tests of about half a minute each on lavapipe, each on one core: halves
// of one matrix are two tests, so that the test threads share them out.

#[test]
fn every_combination_renders_or_is_refused_at_build_first_half() {
    every_combination_renders_or_is_refused_at_build(0);
}

#[test]
fn every_combination_renders_or_is_refused_at_build_second_half() {
    every_combination_renders_or_is_refused_at_build(1);
}

/// The cells of the volume roles' groups of parity `half`: every view-table cell composes the
/// shader of its shared-table twin, which is in the same group.
fn every_combination_renders_or_is_refused_at_build(half: usize) {
    let gpu = common::software_gpu();
    let all = Cell::all();
    let groups: Vec<&[Cell]> = all.chunk_by(|a, b| a.roles == b.roles).skip(half).step_by(2).collect();
    let cells: Vec<&Cell> = groups.iter().flat_map(|g| g.iter()).collect();
    let mut tally = Tally::default();
    // The shader of each cell written in the shared table, to compare the view-table cells with.
    let mut shared_shaders: HashMap<String, String> = HashMap::new();
    for group in groups {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, group[0].scene()).expect("scene written");
        let options =
            RenderOptions { size: Some([16, 16]), phantom_size: [24, 24, 24], samples: 1, ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(gpu.clone(), &path, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", group[0].describe()));
        for cell in group {
            std::fs::write(&path, cell.scene()).expect("scene written");
            if let Some(hash) = run_cell(&mut renderer, cell, &mut tally) {
                let key = cell_key(cell);
                match cell.placement {
                    Placement::Shared => {
                        shared_shaders.insert(key, hash);
                    }
                    Placement::Own | Placement::Inherited => assert_eq!(
                        shared_shaders.get(&key),
                        Some(&hash),
                        "{}: a view's render table composes another shader than the shared table saying the same",
                        cell.describe()
                    ),
                }
            }
        }
        tally.pipelines += renderer.pipeline_stats().misses;
    }
    eprintln!(
        "{} cells: {} rendered, {} probed, {} refused",
        cells.len(),
        tally.rendered,
        tally.probed,
        tally.refused.len()
    );
    // Every value of every axis is a documented option that combines with all the others:
    // `build` refuses no cell of this matrix, and a refusal of any is a regression.
    assert_refused_exactly(&tally.refused, &BTreeSet::new());
    assert_eq!(tally.rendered + tally.probed, cells.len());
    assert_eq!(tally.probed, cells.iter().filter(|c| c.probe).count(), "every probe cell probed");
}

/// The same cells with every volume kept in bricks (`bricks = true`), in the shared render
/// table, with shading off or one light (placement, skipping, which bricked volumes turn off,
/// and more lights are covered above): each renders through the bricked lookup, probed or
/// not, or is refused at build.
#[test]
fn every_combination_with_bricked_volumes_renders_or_is_refused_at_build() {
    let gpu = common::software_gpu();
    let cells: Vec<Cell> = Cell::all()
        .into_iter()
        .filter(|c| c.placement == Placement::Shared && !c.skipping)
        .filter(|c| matches!(c.lighting, Lighting::Off | Lighting::Lights(1)))
        .collect();
    let bricked = |cell: &Cell| {
        let mut text = cell.scene();
        for role in ["primary", "mask", "tag", "additional"] {
            text = text.replace(&format!("role = \"{role}\"\n"), &format!("role = \"{role}\"\nbricks = true\n"));
        }
        text
    };
    let mut tally = Tally::default();
    for group in cells.chunk_by(|a, b| a.roles == b.roles) {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, bricked(&group[0])).expect("scene written");
        let options =
            RenderOptions { size: Some([16, 16]), phantom_size: [24, 24, 24], samples: 1, ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(gpu.clone(), &path, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{} (bricked): {e}", group[0].describe()));
        assert!(renderer.brick_residency().is_some(), "{}: no bricked volume", group[0].describe());
        for cell in group {
            std::fs::write(&path, bricked(cell)).expect("scene written");
            run_cell(&mut renderer, cell, &mut tally);
        }
    }
    eprintln!(
        "{} bricked cells: {} rendered, {} probed, {} refused",
        cells.len(),
        tally.rendered,
        tally.probed,
        tally.refused.len()
    );
    // As above: bricks refuse no cell.
    assert_refused_exactly(&tally.refused, &BTreeSet::new());
    assert_eq!(tally.rendered + tally.probed, cells.len());
    assert_eq!(tally.probed, cells.iter().filter(|c| c.probe).count(), "every probe cell probed");
}

/// Every combination of tone mapping, pre-integration and shadows with the compositing modes,
/// view kinds, shading and an additional volume renders or is refused by `build` (with an
/// error at a scene value: shadows without shading), and no rendered pixel's colour is NaN.
#[test]
fn every_light_option_renders_or_is_refused_at_build_alone() {
    every_light_option_renders_or_is_refused_at_build(false);
}

#[test]
fn every_light_option_renders_or_is_refused_at_build_with_an_additional_volume() {
    every_light_option_renders_or_is_refused_at_build(true);
}

/// The light cells with an additional volume, or without.
fn every_light_option_renders_or_is_refused_at_build(additional: bool) {
    let gpu = common::software_gpu();
    let cells: Vec<LightCell> = LightCell::all().into_iter().filter(|c| c.additional == additional).collect();
    assert!(!cells.is_empty(), "light cells with additional = {additional}");
    let (mut rendered, mut refused) = (0, BTreeSet::new());
    for group in cells.chunk_by(|a, b| a.additional == b.additional) {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("scene.toml");
        let first = LightCell { shadows: "off", occlusion: false, ..group[0] };
        std::fs::write(&path, first.scene()).expect("scene written");
        let options =
            RenderOptions { size: Some([16, 16]), phantom_size: [24, 24, 24], samples: 1, ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(gpu.clone(), &path, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", first.describe()));
        for cell in group {
            let what = cell.describe();
            std::fs::write(&path, cell.scene()).expect("scene written");
            let cached = renderer.compose().unwrap_or_else(|e| panic!("{what}: {e}"));
            if cached.built.diags.has_errors() {
                for d in cached.built.diags.sorted().iter().filter(|d| d.is_error()) {
                    assert!(!d.span.is_dummy(), "{what}: refused without naming a scene value: {}", d.message);
                }
                refused.insert(what);
                continue;
            }
            renderer.apply(&cached).unwrap_or_else(|e| panic!("{what}: composed but did not load: {e}"));
            let probe = renderer.render_probe(0, &ProbeSpec::of("out_color")).unwrap_or_else(|e| panic!("{what}: {e}"));
            let values = (0..16 * 16).filter_map(|i| probe.values.at(i % 16, i / 16));
            assert!(values.flatten().all(|c| c.is_finite()), "{what}: a colour is not finite");
            if let Some(fault) = renderer.gpu().take_fault() {
                panic!("{what}: a wgpu error escaped: {fault}");
            }
            rendered += 1;
        }
    }
    eprintln!("{} light cells: {rendered} rendered, {} refused", cells.len(), refused.len());
    let expected: BTreeSet<String> = cells.iter().filter(|c| c.refusal().is_some()).map(LightCell::describe).collect();
    assert_refused_exactly(&refused, &expected);
    assert_eq!(rendered + refused.len(), cells.len());
}

/// Every mesh set (none, opaque, opaque and translucent, one that follows a module's uniform,
/// a slice view shown on its plane) with every compositing mode, view kind, shading, tone mapping and an additional volume
/// renders, with finite colours and a mesh layer that the view reads (`geometry_depth` probed:
/// 1 where no mesh is, within [0, 1] everywhere).
#[test]
fn every_mesh_option_renders() {
    let gpu = common::software_gpu();
    let cells = MeshCell::all();
    let mut rendered = 0;
    for group in cells.chunk_by(|a, b| a.additional == b.additional) {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("scene.toml");
        std::fs::write(dir.path().join("target.vrs"), MeshCell::TARGET_MODULE).expect("module written");
        std::fs::write(&path, group[0].scene()).expect("scene written");
        let options =
            RenderOptions { size: Some([16, 16]), phantom_size: [24, 24, 24], samples: 1, ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(gpu.clone(), &path, options, &mut |_, _, _| {})
            .unwrap_or_else(|e| panic!("{}: {e}", group[0].describe()));
        for cell in group {
            let what = cell.describe();
            std::fs::write(&path, cell.scene()).expect("scene written");
            let cached = renderer.compose().unwrap_or_else(|e| panic!("{what}: {e}"));
            assert!(!cached.built.diags.has_errors(), "{what}: refused: {:?}", cached.built.diags.sorted());
            renderer.apply(&cached).unwrap_or_else(|e| panic!("{what}: composed but did not load: {e}"));
            let probe = renderer.render_probe(0, &ProbeSpec::of("out_color")).unwrap_or_else(|e| panic!("{what}: {e}"));
            let values = (0..16 * 16).filter_map(|i| probe.values.at(i % 16, i / 16));
            assert!(values.flatten().all(|c| c.is_finite()), "{what}: a colour is not finite");
            let reads_layer = renderer.views()[0].renderer.reads_mesh_layer();
            assert_eq!(reads_layer, cell.meshes != "none", "{what}: a mesh layer exactly when there are meshes");
            if reads_layer {
                let depth = renderer.render_probe(0, &ProbeSpec::of("geometry_depth")).expect("depth probes");
                let depths: Vec<f64> =
                    (0..16 * 16).filter_map(|i| depth.values.at(i % 16, i / 16)).map(|v| v[0]).collect();
                assert!(depths.iter().all(|d| (0.0..=1.0).contains(d)), "{what}: depth outside [0, 1]: {depths:?}");
            }
            if let Some(fault) = renderer.gpu().take_fault() {
                panic!("{what}: a wgpu error escaped: {fault}");
            }
            rendered += 1;
        }
    }
    eprintln!("{} mesh cells rendered", cells.len());
    assert_eq!(rendered, cells.len());
}

/// Builds and renders one cell; the structural hash of its view's shader when it rendered.
fn run_cell(renderer: &mut SceneRenderer, cell: &Cell, tally: &mut Tally) -> Option<String> {
    let what = cell.describe();
    let cached = renderer.compose().unwrap_or_else(|e| panic!("{what}: {e}"));
    let diags = &cached.built.diags;
    if diags.has_errors() {
        for d in diags.sorted().iter().filter(|d| d.is_error()) {
            assert!(!d.span.is_dummy(), "{what}: refused without naming a scene value: {}", d.message);
        }
        tally.refused.insert(what);
        return None;
    }
    renderer.apply(&cached).unwrap_or_else(|e| panic!("{what}: composed but did not load: {e}"));
    if cell.probe {
        let probe = renderer.render_probe(0, &ProbeSpec::of("out_color")).unwrap_or_else(|e| panic!("{what}: {e}"));
        let (w, h) = probe.image.dimensions();
        for (x, y) in (0..h).flat_map(|y| (0..w).map(move |x| (x, y))) {
            let value = probe.values.at(x, y).unwrap_or_else(|| panic!("{what}: pixel ({x}, {y}) has no colour"));
            assert!(value.iter().all(|c| c.is_finite()), "{what}: pixel ({x}, {y}) is {value:?}");
        }
        tally.probed += 1;
    } else {
        let images = renderer.render_all().unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(images.len(), 1, "{what}");
        tally.rendered += 1;
    }
    if let Some(fault) = renderer.gpu().take_fault() {
        panic!("{what}: a wgpu error escaped: {fault}");
    }
    Some(renderer.views()[0].renderer.shader().reflection.structural_hash.clone())
}

/// A cell without its placement and probe: cells equal but for these compose the same view.
fn cell_key(cell: &Cell) -> String {
    let plain = Cell { placement: Placement::Shared, probe: false, ..*cell };
    plain.describe()
}
