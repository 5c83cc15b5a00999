//! The runtime against the compiler's output on the software adapter: every composed view
//! compiles in wgpu, precompiled views load (and stale pairs are refused), uniforms are typed,
//! the pipeline cache spares recompiles, and bad input is an error, never a panic.

use crate::common;

use std::path::{Path, PathBuf};
use vrs_runtime::{PipelineCache, RenderOptions, RuntimeError, SceneRenderer, ViewShader};

fn scenes_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for path in std::fs::read_dir(&dir).expect("readable").filter_map(|e| e.ok().map(|e| e.path())) {
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "toml") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The compiler's shader of each view, as the runtime sees it.
fn view_shaders(scene: &Path) -> Vec<ViewShader> {
    let built = vrsc::compose::build::build_scene(scene, None).expect("scene readable");
    assert!(!built.diags.has_errors(), "{}", vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
    built
        .views
        .iter()
        .map(|v| {
            let shader = v.shader.as_ref().expect("composed");
            let json = serde_json::to_string(&shader.reflection).unwrap();
            let reflection = vrs_runtime::reflection::Reflection::from_json(&json).unwrap();
            ViewShader::new(shader.wgsl.clone(), reflection, scene).unwrap()
        })
        .collect()
}

#[test]
fn every_composed_view_compiles_in_wgpu() {
    let gpu = common::software_gpu();
    let mut cache = PipelineCache::new();
    let root = common::root();
    let mut count = 0;
    for dir in ["tests/fixtures/compose", "tests/fixtures/render", "examples"] {
        for scene in scenes_under(&root.join(dir)) {
            for shader in view_shaders(&scene) {
                cache.get(&gpu, &shader).unwrap_or_else(|e| panic!("{}: {e}", scene.display()));
                count += 1;
            }
        }
    }
    assert!(count >= 25, "only {count} views");
}

fn temp_scene(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

const SCENE: &str = r#"
[render]
compositing = "dvr"
shading = true

[[volume]]
name = "head"
role = "primary"
phantom = "head"

[uniforms]
ambient = AMBIENT

[[view]]
name = "3d"
kind = "raycast"
size = [32, 32]
"#;

fn small() -> RenderOptions {
    RenderOptions { phantom_size: [24, 24, 24], ..RenderOptions::default() }
}

#[test]
fn a_uniform_change_never_recompiles_and_a_structural_one_does() {
    let gpu = common::software_gpu();
    let dir = tempfile::tempdir().unwrap();
    let path = temp_scene(dir.path(), &SCENE.replace("AMBIENT", "0.3"));
    let mut scene = SceneRenderer::open(gpu, &path, small(), &mut |_, _, _| {}).unwrap();
    let before = scene.render_all().unwrap().remove(0).1;
    assert_eq!(scene.pipeline_stats().misses, 1);

    temp_scene(dir.path(), &SCENE.replace("AMBIENT", "0.9"));
    assert!(!scene.reload().unwrap(), "a uniform change must not compile a new shader");
    let brighter = scene.render_all().unwrap().remove(0).1;
    assert_eq!(scene.pipeline_stats().misses, 1);
    assert_ne!(before, brighter, "the new ambient value is used");

    scene.set_uniform("ambient", 0.3f32).unwrap();
    assert_eq!(scene.render_all().unwrap().remove(0).1, before, "setting it back gives the same image");

    temp_scene(dir.path(), &SCENE.replace("AMBIENT", "0.9").replace("\"dvr\"", "\"mip\""));
    assert!(scene.reload().unwrap(), "another compositing mode is a new shader");
    assert_eq!(scene.pipeline_stats().misses, 2);
}

#[test]
fn uniforms_are_typed_by_name() {
    let gpu = common::software_gpu();
    let dir = tempfile::tempdir().unwrap();
    let path = temp_scene(dir.path(), &SCENE.replace("AMBIENT", "0.3"));
    let mut scene = SceneRenderer::open(gpu, &path, small(), &mut |_, _, _| {}).unwrap();
    let err = scene.set_uniform("ambiant", 0.5f32).unwrap_err().to_string();
    assert!(err.contains("no uniform `ambiant`; did you mean `ambient`?"), "{err}");
    let err = scene.set_uniform("ambient", [1.0f32, 2.0, 3.0]).unwrap_err().to_string();
    assert!(err.contains("uniform `ambient` is a f32, not 3 f32 values"), "{err}");
}

#[test]
fn precompiled_views_load_and_stale_pairs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::root().join("examples/basic/scene.toml");
    let built = vrsc::compose::build::build_scene(&scene, Some("3d")).unwrap();
    let shader = built.views[0].shader.as_ref().unwrap();
    let (wgsl, json) = (dir.path().join("3d.wgsl"), dir.path().join("3d.json"));
    std::fs::write(&wgsl, &shader.wgsl).unwrap();
    std::fs::write(&json, serde_json::to_string(&shader.reflection).unwrap()).unwrap();
    let loaded = ViewShader::load_view(dir.path(), "3d").unwrap();
    assert_eq!(loaded.reflection.view, "3d");

    std::fs::write(&wgsl, format!("{}\n// edited\n", shader.wgsl)).unwrap();
    let err = ViewShader::load(&wgsl, &json).unwrap_err().to_string();
    assert!(err.contains("rebuild both with `vrsc build`"), "{err}");

    let old =
        serde_json::to_string(&shader.reflection).unwrap().replace("\"format_version\":1", "\"format_version\":0");
    std::fs::write(&json, old).unwrap();
    let err = ViewShader::load(&wgsl, &json).unwrap_err().to_string();
    assert!(err.contains("reflection format version 0"), "{err}");
}

#[test]
fn bad_volumes_are_errors_with_exit_codes() {
    let gpu = common::software_gpu();
    let dir = tempfile::tempdir().unwrap();
    let missing = SCENE.replace("AMBIENT", "0.3").replace("phantom = \"head\"", "path = \"missing.nii.gz\"");
    let path = temp_scene(dir.path(), &missing);
    let err = SceneRenderer::open(gpu.clone(), &path, small(), &mut |_, _, _| {}).err().expect("missing file");
    // A missing volume is a mistake in the scene, like a missing transfer-function file.
    assert_eq!(err.exit_code(), 1, "{err}");
    assert!(err.to_string().contains("missing.nii.gz"), "{err}");

    std::fs::write(dir.path().join("missing.nii.gz"), b"not a volume").unwrap();
    let err = SceneRenderer::open(gpu.clone(), &path, small(), &mut |_, _, _| {}).err().expect("corrupt file");
    assert_eq!(err.exit_code(), 1, "{err}");

    let unknown = SCENE.replace("AMBIENT", "0.3").replace("phantom = \"head\"", "phantom = \"heart\"");
    let path = temp_scene(dir.path(), &unknown);
    let err = SceneRenderer::open(gpu, &path, small(), &mut |_, _, _| {}).err().expect("unknown phantom");
    assert!(matches!(err, RuntimeError::Invalid(_)) && err.to_string().contains("heart"), "{err}");
}

/// A volume file is streamed into its texture (no copy of its samples is kept); the picture is
/// the one of the same samples uploaded from memory. The head phantom, written as a NRRD file
/// of floats on the phantom's own grid, against the built-in phantom.
#[test]
fn a_streamed_file_renders_like_the_same_volume_uploaded_from_memory() {
    let dims = [40, 36, 32];
    let phantom = vrs_runtime::volume::phantom("head", dims).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let centre = dims.map(|d| (d as f32 - 1.0) / 2.0);
    let mut nrrd = format!(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: {} {} {}\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\
         space origin: ({},{},{})\nendian: little\nencoding: raw\n\n",
        dims[0], dims[1], dims[2], -centre[0], -centre[1], -centre[2]
    )
    .into_bytes();
    nrrd.extend(phantom.values().iter().flat_map(|v| v.to_le_bytes()));
    std::fs::write(dir.path().join("head.nrrd"), nrrd).unwrap();
    let view = "\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [96, 96]\n\
                camera = { azimuth = 30.0, elevation = 20.0 }\n";
    let render = |source: &str| {
        // One window for both: a phantom's automatic window is its range, a file's its
        // percentiles.
        let text = format!(
            "[[volume]]\nname = \"head\"\nrole = \"primary\"\n{source}\ntf = \"mr_default\"\nwindow = [-1000.0, 700.0]\n{view}"
        );
        let scene = temp_scene(dir.path(), &text);
        let options = RenderOptions { phantom_size: dims, ..RenderOptions::default() };
        let mut renderer = SceneRenderer::open(common::software_gpu(), &scene, options, &mut |_, _, _| {}).unwrap();
        renderer.render_all().unwrap().remove(0).1
    };
    let streamed = render("path = \"head.nrrd\"");
    let uploaded = render("phantom = \"head\"");
    assert!(streamed.pixels().any(|p| p[3] > 0), "the head is visible");
    assert_eq!(streamed, uploaded);
}

/// Writes `volume`'s values as an int16 NRRD of its grid (world = RAS, the phantom's own).
fn write_int16_nrrd(path: &Path, volume: &vrs_runtime::volume::Volume) {
    let [x, y, z] = volume.dims;
    let o = volume.grid_to_world.w_axis;
    let mut bytes = format!(
        "NRRD0004\ntype: short\ndimension: 3\nsizes: {x} {y} {z}\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\
         space origin: ({},{},{})\nendian: little\nencoding: raw\n\n",
        o.x, o.y, o.z
    )
    .into_bytes();
    bytes.extend(volume.values().iter().flat_map(|v| (v.round() as i16).to_le_bytes()));
    std::fs::write(path, bytes).unwrap();
}

/// A CT with one 30000 HU voxel (metal) renders like the same CT without it, with a CT preset
/// (its Hounsfield domain is the window) and with the automatic window (percentiles).
#[test]
fn an_outlier_voxel_does_not_change_the_picture() {
    let dims = [48, 48, 40];
    let mut ct = vrs_runtime::volume::phantom("abdomen", dims).unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_int16_nrrd(&dir.path().join("ct.nrrd"), &ct);
    let mut values = ct.values();
    values[(20 * 48 + 24) * 48 + 24] = 30_000.0;
    ct = vrs_runtime::volume::Volume::new(ct.dims, ct.grid_to_world, values);
    write_int16_nrrd(&dir.path().join("metal.nrrd"), &ct);
    for tf in ["ct_bone", "ct_soft_tissue", "grayscale"] {
        let render = |file: &str| {
            let text = format!(
                "[[volume]]\nname = \"ct\"\nrole = \"primary\"\npath = \"{file}\"\ntf = \"{tf}\"\n\n\
                 [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [96, 96]\ncamera = {{ elevation = 30.0 }}\n"
            );
            let scene = temp_scene(dir.path(), &text);
            let mut r =
                SceneRenderer::open(common::software_gpu(), &scene, RenderOptions::default(), &mut |_, _, _| {})
                    .unwrap();
            (r.render_all().unwrap().remove(0).1, r.notices.clone())
        };
        let ((clean, clean_notes), (metal, metal_notes)) = (render("ct.nrrd"), render("metal.nrrd"));
        assert!(clean.pixels().filter(|p| p[3] > 0).count() > 500, "{tf}: the body is visible");
        let (matching, mean, _) = common::compare(&metal, &clean);
        assert!(matching >= common::MIN_MATCHING && mean <= common::MAX_MEAN_DIFF, "{tf}: {matching} {mean}");
        // A CT preset's window is its Hounsfield domain: nothing automatic to state.
        assert_eq!(clean_notes.is_empty(), tf != "grayscale", "{tf}: {clean_notes:?}");
        if tf == "grayscale" {
            assert!(
                metal_notes[0].contains("automatic window [-99") || metal_notes[0].contains("automatic window [-1000")
            );
            assert!(clean_notes[0].contains("percentile"), "{clean_notes:?}");
        }
    }
}

/// wgpu's default answer to an error outside any capture is a panic; the runtime's device keeps
/// it instead, for the caller to take as a value.
#[test]
fn a_wgpu_error_outside_any_capture_is_kept_not_a_panic() {
    let gpu = common::software_gpu();
    let too_wide = gpu.device.limits().max_texture_dimension_2d + 1;
    let _texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("too wide"),
        size: wgpu::Extent3d { width: too_wide, height: 1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let fault = gpu.take_fault().expect("the error is kept");
    assert_eq!(fault.kind, vrs_runtime::gpu::GpuFaultKind::Validation);
    assert!(fault.message.contains("exceeds the limit"), "{fault}");
    assert_eq!(gpu.take_fault(), None, "taken once");
    // The same mistake inside a capture is that capture's error.
    let captured = vrs_runtime::view::create_output(&gpu, [too_wide, 1]).expect_err("refused");
    assert!(matches!(captured, vrs_runtime::RuntimeError::Device(_)), "{captured}");
}

#[test]
fn a_precompiled_view_renders_with_its_own_resources() {
    use vrs_runtime::{Resources, ViewRenderer};
    let gpu = common::software_gpu();
    let dir = tempfile::tempdir().unwrap();
    // Without empty-space skipping the view reads only the volume and its transfer function.
    let text =
        SCENE.replace("AMBIENT", "0.3").replace("shading = true", "shading = true\nempty_space_skipping = false");
    let path = temp_scene(dir.path(), &text);
    let scene = SceneRenderer::open(gpu.clone(), &path, small(), &mut |_, _, _| {}).unwrap();
    let composed = &scene.views()[0].renderer;

    let mut resources = Resources::new(&gpu);
    let head = vrs_runtime::volume::phantom("head", [24, 24, 24]).unwrap();
    resources.bind_volume(&gpu, "volume", &head, None).unwrap();
    resources.bind_tf(&gpu, "tf", &vrs_runtime::tf::preset("ct_bone").unwrap()).unwrap();
    let mut cache = PipelineCache::new();
    let mut view = ViewRenderer::new(&gpu, &mut cache, composed.shader().clone(), composed.size()).unwrap();
    for uniform in &composed.shader().reflection.uniforms {
        if let Some(value) = composed.uniforms().get(&uniform.name) {
            view.set_uniform(&uniform.name, value).unwrap();
        }
    }
    let image = view.render(&gpu, &resources).unwrap();
    assert_eq!([image.width(), image.height()], composed.size());
    assert!(image.pixels().any(|p| p[3] > 0), "the head is drawn");
}
