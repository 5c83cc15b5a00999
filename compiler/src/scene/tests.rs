use super::*;
use crate::diag::Diagnostics;
use crate::source::SourceMap;

const EXAMPLE: &str = r#"[render]
compositing = "dvr"            # dvr | mip | iso (iso takes `iso_value`)
shading = true                 # activates gradient + lighting steps of the standard library
lights = ["key"]               # one substep of shading.lights per name

[[volume]]
name = "t1"                    # an identifier; the instance name of this volume's functions
role = "primary"               # primary | additional | mask | tag
path = "t1.nii.gz"             # relative to the scene file; or `phantom = "NAME"` for a built-in one
tf = "grayscale"               # a built-in transfer function preset, or a path to a transfer function file

[[module]]                     # shared by every view
path = "clip_plane.vrs"
instances = ["gm"]             # for a template; omitted for a plain module

[uniforms]                     # initial values, by uniform name
clip_plane_gm = [1.0, 0.0, 0.0, -0.5]

[[view]]
name = "3d"
kind = "raycast"               # raycast | slice
size = [512, 512]
camera = { azimuth = 30.0, elevation = 20.0, distance = 2.5 }
modules = [{ path = "compose_3d.vrs" }]      # only this view

[[view]]
name = "axial"
kind = "slice"
axis = "z"                     # x | y | z
position = 0.5                 # normalized
modules = [{ path = "compose_2d.vrs" }]
"#;

/// What a scene that does not validate reported.
#[derive(Debug)]
struct Invalid {
    diagnostics: Vec<Diagnostic>,
}

/// Parses `text` as `scenes/test.toml` in a fresh source map, with what it reported.
fn parse_reporting(text: &str) -> (SourceMap, Option<Scene>, Vec<Diagnostic>) {
    let mut map = SourceMap::new();
    map.add("x.vrs", None, "// another file first, so bases are not 0\n".into());
    let id = map.add("scenes/test.toml", None, text.to_string());
    let mut diags = Diagnostics::new();
    let scene = parse_scene(&map, id, &mut diags);
    (map, scene, diags.iter().cloned().collect())
}

/// [`parse_reporting`]: the scene, or what it reported when it did not validate.
fn parse(text: &str) -> (SourceMap, Result<Scene, Invalid>) {
    let (map, scene, diagnostics) = parse_reporting(text);
    (map, scene.ok_or(Invalid { diagnostics }))
}

/// The errors of a scene that must fail, as (code, line, column, message).
fn errors(text: &str) -> Vec<(&'static str, usize, usize, String)> {
    let (map, result) = parse(text);
    let err = result.expect_err("the scene should not validate");
    err.diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| {
            let (_, p) = map.position(d.span.start).expect("the span is in the file");
            (d.code.as_str(), p.line, p.column, d.message.clone())
        })
        .collect()
}

const MINIMAL: &str = "[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"sphere\"\n\n[[view]]\nname = \"3d\"\n";

#[test]
fn the_spec_example_parses() {
    let (map, scene, warnings) = parse_reporting(EXAMPLE);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(scene.render.compositing.value, Compositing::Dvr);
    assert!(scene.render.shading);
    assert_eq!(scene.render.lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(), ["key"]);
    assert_eq!(map.snippet(scene.render.lights[0].span), "\"key\"");
    let t1 = scene.primary().expect("a primary volume");
    assert_eq!(t1.name.name, "t1");
    match &t1.source {
        VolumeSource::File(f) => {
            assert_eq!(f.given, "t1.nii.gz");
            assert_eq!(f.resolved, Path::new("scenes/t1.nii.gz"));
            assert_eq!(map.snippet(f.span), "\"t1.nii.gz\"");
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(&t1.tf, Some(TfRef::Preset(p)) if p.value == "grayscale"));
    assert_eq!(scene.modules.len(), 1);
    let m = &scene.modules[0];
    assert!(matches!(&m.source, ModuleSource::File(f) if f.resolved == Path::new("scenes/clip_plane.vrs")));
    assert_eq!(m.instances.as_ref().map(|i| i[0].name.as_str()), Some("gm"));
    let clip = &scene.uniforms["clip_plane_gm"];
    assert_eq!(clip.value.shape(), [4]);
    assert_eq!(clip.value.flatten(), [1.0, 0.0, 0.0, -0.5]);
    assert_eq!(map.snippet(clip.name_span), "clip_plane_gm");
    assert_eq!(scene.views.len(), 2);
    let v3 = &scene.views[0];
    assert_eq!((v3.name.name.as_str(), v3.kind.value, v3.size), ("3d", ViewKind::Raycast, [512, 512]));
    assert_eq!(v3.camera, Camera { azimuth: 30.0, elevation: 20.0, distance: 2.5, fov: 30.0 });
    assert!(matches!(&v3.modules[0].source, ModuleSource::File(f) if f.given == "compose_3d.vrs"));
    let axial = scene.view("axial").expect("axial view");
    assert_eq!(axial.kind.value, ViewKind::Slice);
    assert_eq!(axial.axis.as_ref().map(|a| a.value), Some(Axis::Z));
    assert_eq!((axial.position, axial.slab, axial.size), (0.5, 0.0, DEFAULT_VIEW_SIZE));
    let values = scene.uniform_values();
    assert!(!values.contains_key("max_samples"), "without `max_samples` the runtime derives it");
    assert!(values.contains_key("clip_plane_gm"));
}

#[test]
fn standard_modules_follow_the_configuration() {
    let (_, result) = parse(EXAMPLE);
    let scene = result.expect("valid");
    let names =
        |view: &str| scene.standard_modules(scene.view(view).expect("view")).iter().map(|m| m.name).collect::<Vec<_>>();
    assert_eq!(
        names("3d"),
        [
            "raycast",
            "march",
            "background",
            "sample_primary",
            "gradient",
            "normal",
            "classify",
            "light",
            "composite",
            "lighting",
            "composite_dvr",
            "skip"
        ]
    );
    assert_eq!(names("axial")[0], "slice");
    assert!(!names("axial").contains(&"skip"), "slice views do not skip");
    let text = format!(
        "[render]\ncompositing = \"iso\"\niso_value = 0.3\n{MINIMAL}\n[[volume]]\nname = \"gm\"\nrole = \"additional\"\nphantom = \"ball\"\n[[volume]]\nname = \"brain\"\nrole = \"mask\"\npath = \"m.nii\"\n"
    );
    let (_, result) = parse(&text);
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let modules = scene.standard_modules(&scene.views[0]);
    let find = |n: &str| modules.iter().find(|m| m.name == n).map(|m| m.instances.clone());
    assert_eq!(find("sample_volume"), Some(vec!["gm".to_string()]));
    assert_eq!(find("mask"), Some(vec!["brain".to_string()]));
    assert_eq!(find("composite_iso"), Some(vec![]));
    assert_eq!(find("composite_volume"), None);
    assert_eq!(find("gradient"), None);
    assert_eq!(find("skip_iso"), Some(vec![]), "iso skips bricks below the surface");
    assert_eq!(scene.uniform_values()["iso_value"], UniformValue::Float(f64::from(0.3f32)));
}

#[test]
fn ambient_occlusion_needs_shading_and_follows_lighting() {
    let errs = errors(&format!("[render]\nambient_occlusion = true\n{MINIMAL}"));
    assert_eq!(errs.len(), 1, "{errs:?}");
    let (code, line, column, message) = &errs[0];
    assert_eq!((*code, *line, *column), ("E0704", 2, 21), "at the value");
    assert_eq!(message, "ambient occlusion needs `shading = true`");
    let (_, result) = parse(&format!("[render]\nshading = true\nambient_occlusion = true\n{MINIMAL}"));
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let names: Vec<&str> = scene.standard_modules(&scene.views[0]).iter().map(|m| m.name).collect();
    let at = |n: &str| names.iter().position(|m| *m == n).unwrap_or_else(|| panic!("{n} in {names:?}"));
    assert!(at("lighting") < at("occlusion"), "it replaces `apply_lighting`: {names:?}");
    // A view without shading does not inherit it.
    let view = "[[view]]\nname = \"flat\"\nrender = { shading = false }\n";
    let (_, result) = parse(&format!("[render]\nshading = true\nambient_occlusion = true\n{MINIMAL}\n{view}"));
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let flat = scene.standard_modules(scene.view("flat").expect("view"));
    assert!(flat.iter().all(|m| m.name != "occlusion"));
}

#[test]
fn path_tracing_selects_its_modules_and_says_which_keys_it_ignores() {
    let text = format!(
        "[render]\ncompositing = \"pathtrace\"\nshading = true\nlights = [\"key\", \"fill\"]\nshadows = \"volume\"\n\
         ambient_occlusion = true\ntone = true\n{MINIMAL}\n\
         [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nrender = {{ compositing = \"pathtrace\" }}\n"
    );
    let (_, scene, diagnostics) = parse_reporting(&text);
    let scene = scene.unwrap_or_else(|| panic!("{diagnostics:?}"));
    let ignored: Vec<String> =
        diagnostics.iter().filter(|d| d.code.as_str() == "W0701").map(|d| d.message.clone()).collect();
    for key in ["shadows", "ambient_occlusion", "tone", "compositing = \"pathtrace\""] {
        assert!(ignored.iter().any(|m| m.starts_with(&format!("`{key}`"))), "{key}: {ignored:?}");
    }
    let modules = scene.standard_modules(&scene.views[0]);
    let names: Vec<&str> = modules.iter().map(|m| m.name).collect();
    for wanted in ["gradient", "normal", "light", "pathtrace", "shadow_ray", "path_light"] {
        assert!(names.contains(&wanted), "{wanted} in {names:?}");
    }
    for unwanted in ["lighting", "composite_dvr", "skip", "occlusion", "shadow_volume", "tone"] {
        assert!(!names.contains(&unwanted), "{unwanted} in {names:?}");
    }
    let at = |n: &str| names.iter().position(|m| *m == n).unwrap_or(usize::MAX);
    assert!(at("light") < at("shadow_ray") && at("shadow_ray") < at("path_light"), "{names:?}");
    let lights = modules.iter().find(|m| m.name == "path_light").map(|m| m.instances.clone());
    assert_eq!(lights, Some(vec!["key".to_string(), "fill".to_string()]));
    // The slice view is composited by DVR; unlit, the path tracer keeps its gradient (surfaces).
    assert_eq!(scene.view("axial").map(|v| v.render.compositing.value), Some(Compositing::Dvr));
    let (_, result) = parse(&format!("[render]\ncompositing = \"pathtrace\"\n{MINIMAL}"));
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let names: Vec<&str> = scene.standard_modules(&scene.views[0]).iter().map(|m| m.name).collect();
    assert!(names.contains(&"gradient") && names.contains(&"pathtrace") && !names.contains(&"path_light"));
}

#[test]
fn every_standard_module_exists() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stdlib");
    let text = format!(
        "[render]\nshading = true\nboundary = true\ntone = true\n{MINIMAL}\n[[volume]]\nname = \"a\"\nrole = \"additional\"\nphantom = \"p\"\n[[volume]]\nname = \"m\"\nrole = \"mask\"\nphantom = \"p\"\n[[volume]]\nname = \"t\"\nrole = \"tag\"\nphantom = \"p\"\n"
    );
    for mode in ["dvr", "mip", "iso", "pathtrace"] {
        let text =
            text.replace("shading = true", &format!("shading = true\ncompositing = \"{mode}\"\niso_value = 0.5"));
        let (_, result) = parse(&text);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        for kind in [ViewKind::Raycast, ViewKind::Slice] {
            let mut view = scene.views[0].clone();
            view.kind.value = kind;
            for m in scene.standard_modules(&view) {
                assert!(dir.join(format!("{}.vrs", m.name)).is_file(), "stdlib/{}.vrs is missing", m.name);
            }
        }
    }
}

#[test]
fn the_step_size_default_matches_the_stdlib() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stdlib");
    for file in ["raycast.vrs", "slice.vrs"] {
        let text = std::fs::read_to_string(dir.join(file)).expect("stdlib file");
        assert!(
            text.contains(&format!("uniform step_size: f32 = {DEFAULT_STEP_SIZE}")),
            "{file} declares another step_size default than DEFAULT_STEP_SIZE"
        );
    }
}

#[test]
fn unknown_keys_point_at_the_key() {
    let text = EXAMPLE.replace("camera = {", "camra = {");
    let errs = errors(&text);
    assert_eq!(errs.len(), 1, "{errs:?}");
    let (code, line, column, message) = &errs[0];
    assert_eq!((*code, *line, *column), ("E0703", 23, 1));
    assert_eq!(message, "unknown key `camra` in [[view]]");
    let (_, result) = parse(&text);
    let d = &result.expect_err("invalid").diagnostics[0];
    assert!(d.notes.iter().any(|n| n.contains("did you mean `camera`?")), "{:?}", d.notes);
    assert!(d.notes.iter().any(|n| n.starts_with("expected one of `name`, `kind`")), "{:?}", d.notes);

    let errs = errors(&EXAMPLE.replace("azimuth = 30.0", "azimut = 30.0"));
    assert_eq!(errs[0].3, "unknown key `azimut` in the `camera` of a [[view]]");
    assert_eq!((errs[0].1, errs[0].2), (23, 12));

    let errs = errors(&EXAMPLE.replace("shading = true", "shadowing = true"));
    assert_eq!((errs[0].0, errs[0].1, errs[0].3.as_str()), ("E0703", 3, "unknown key `shadowing` in [render]"));

    let errs = errors(&format!("{MINIMAL}modules = [{{ path = \"a.vrs\", instance = [\"x\"] }}]\n"));
    assert_eq!(errs[0].3, "unknown key `instance` in a module of a [[view]]");

    let errs = errors(&format!("{MINIMAL}[[module]]\npaths = \"a.vrs\"\n"));
    assert_eq!(errs[0].3, "unknown key `paths` in [[module]]");

    let errs = errors(&format!("title = \"x\"\n{MINIMAL}"));
    assert_eq!((errs[0].1, errs[0].3.as_str()), (1, "unknown key `title` in the scene's top level"));
}

#[test]
fn a_missing_primary_volume_is_an_error() {
    let errs = errors(&EXAMPLE.replace("role = \"primary\"", "role = \"additional\""));
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert_eq!((errs[0].0, errs[0].1, errs[0].3.as_str()), ("E0705", 8, "the scene has no primary volume"));

    let errs = errors(&format!("{MINIMAL}[[volume]]\nname = \"w\"\nrole = \"primary\"\nphantom = \"sphere\"\n"));
    assert_eq!((errs[0].1, errs[0].3.as_str()), (10, "a scene has exactly one primary volume"));

    let errs = errors("[[view]]\nname = \"3d\"\n");
    assert_eq!(errs[0].3, "the scene has no primary volume");
}

#[test]
fn duplicate_names_are_errors() {
    let errs = errors(&EXAMPLE.replace("name = \"axial\"", "name = \"3d\""));
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0712", 27, 8));
    assert_eq!(errs[0].3, "two views are named `3d`");
    let (_, result) = parse(&EXAMPLE.replace("name = \"axial\"", "name = \"3d\""));
    let d = &result.expect_err("invalid").diagnostics[0];
    assert_eq!(d.secondary.len(), 1);

    let errs = errors(&format!("{MINIMAL}[[volume]]\nname = \"v\"\nrole = \"tag\"\nphantom = \"x\"\n"));
    assert_eq!((errs[0].0, errs[0].3.as_str()), ("E0607", "two volumes are named `v`"));

    let errs = errors(&EXAMPLE.replace("lights = [\"key\"]", "lights = [\"key\", \"fill\", \"key\"]"));
    assert_eq!(errs[0].3, "the light `key` is listed twice");
}

#[test]
fn bad_enum_values_point_at_the_value() {
    let errs = errors(&EXAMPLE.replace("compositing = \"dvr\"", "compositing = \"dvrr\""));
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0715", 2, 15));
    assert_eq!(errs[0].3, "`dvrr` is not one of `dvr`, `mip`, `iso`, `minip`, `average`, `pathtrace`");

    let errs = errors(&EXAMPLE.replace("axis = \"z\"", "axis = \"w\""));
    assert_eq!(
        (errs[0].1, errs[0].3.as_str()),
        (29, "`w` is not one of `sagittal`, `x`, `coronal`, `y`, `axial`, `z`")
    );
}

#[test]
fn bad_values_and_syntax() {
    let errs = errors(&EXAMPLE.replace("size = [512, 512]", "size = [512, 0]"));
    assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0708", 22, 8));

    let errs = errors(&EXAMPLE.replace("size = [512, 512]", "size = [512]"));
    assert_eq!((errs[0].0, errs[0].1), ("E0716", 22));

    let errs = errors(&EXAMPLE.replace("shading = true", "shading = \"yes\""));
    assert_eq!((errs[0].0, errs[0].1), ("E0716", 3));

    let errs = errors(&EXAMPLE.replace("[render]", "[render"));
    assert_eq!((errs[0].0, errs[0].1), ("E0701", 1));

    let errs = errors(&EXAMPLE.replace("name = \"t1\"", "name = \"t1\"\nname = \"t2\""));
    assert_eq!((errs[0].0, errs[0].1), ("E0701", 8));

    let errs = errors(&EXAMPLE.replace("name = \"t1\"", "name = \"1t\""));
    assert_eq!((errs[0].0, errs[0].1, errs[0].3.as_str()), ("E0607", 7, "the volume name `1t` is not an identifier"));

    let errs = errors(&EXAMPLE.replace("instances = [\"gm\"]", "instances = [\"g-m\", \"if\"]"));
    assert_eq!(errs.len(), 2, "{errs:?}");

    let errs = errors(&EXAMPLE.replace("path = \"t1.nii.gz\"", "path = \"t1.nii.gz\"\nphantom = \"ball\""));
    assert_eq!(errs[0].3, "a volume has either `path` or `phantom`, not both");

    let errs = errors(&EXAMPLE.replace("path = \"t1.nii.gz\"", ""));
    assert_eq!(errs[0].3, "the volume `t1` has no data");

    let errs = errors(&EXAMPLE.replace("role = \"primary\"", ""));
    assert_eq!((errs[0].1, errs[0].3.as_str()), (6, "missing key `role` in [[volume]]"));

    let errs = errors(&EXAMPLE.replace("axis = \"z\"", ""));
    assert_eq!((errs[0].1, errs[0].3.as_str()), (28, "the slice view `axial` needs an `axis`"));

    let errs = errors(&EXAMPLE.replace("clip_plane_gm = [1.0, 0.0, 0.0, -0.5]", "clip_plane_gm = \"x\""));
    assert_eq!((errs[0].0, errs[0].1), ("E0716", 17));

    let errs = errors(&EXAMPLE.replace("clip_plane_gm = [1.0, 0.0, 0.0, -0.5]", "clip_plane_gm = [1.0, [0.0]]"));
    assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0716", 17, 17));

    let errs = errors(&EXAMPLE.replace("compositing = \"dvr\"", "compositing = \"iso\""));
    assert_eq!((errs[0].1, errs[0].3.as_str()), (2, "`compositing = \"iso\"` needs an `iso_value`"));

    let errs = errors(
        &EXAMPLE
            .replace("[uniforms]", "[uniforms]\nstep_size = 0.01")
            .replace("shading = true", "shading = true\nstep_size = 0.002"),
    );
    assert_eq!(errs[0].3, "`step_size` is set both in [render] and in [uniforms]");
}

#[test]
fn keys_without_effect_are_warnings() {
    let text = EXAMPLE
        .replace("kind = \"raycast\"", "kind = \"raycast\"\naxis = \"x\"")
        .replace("position = 0.5", "position = 0.5\ncamera = { fov = 20.0 }");
    let (map, scene, warnings) = parse_reporting(&text);
    assert!(scene.is_some(), "{warnings:?}");
    let w: Vec<_> = warnings
        .iter()
        .map(|d| (d.code.as_str(), map.position(d.span.start).expect("in file").1.line, d.message.as_str()))
        .collect();
    assert_eq!(
        w,
        [
            ("W0701", 22, "`axis` has no effect on a raycast view"),
            ("W0701", 32, "`camera` has no effect on a slice view")
        ]
    );
}

#[test]
fn defaults() {
    let (_, result) = parse(MINIMAL);
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let r = &scene.render;
    assert_eq!(r.compositing.value, Compositing::Dvr);
    assert!(!r.shading && r.lights.is_empty() && !r.boundary && !r.tone);
    assert!(r.max_samples.is_none() && r.step_size.is_none());
    let v = &scene.views[0];
    assert_eq!((v.kind.value, v.size, v.camera), (ViewKind::Raycast, DEFAULT_VIEW_SIZE, DEFAULT_CAMERA));
    let (_, result) = parse(&format!("[render]\nshading = true\n{MINIMAL}"));
    assert_eq!(result.expect("valid").render.lights[0].name, "key");
}

#[test]
fn standard_module_paths_and_tf_files() {
    let text = MINIMAL.replace("phantom = \"sphere\"", "phantom = \"sphere\"\ntf = \"tfs/bone.json\"")
        + "modules = [{ path = \"std::tone\" }]\n";
    let (_, result) = parse(&text);
    let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    assert!(
        matches!(&scene.primary().expect("a primary volume").tf, Some(TfRef::File(f)) if f.resolved == Path::new("scenes/tfs/bone.json"))
    );
    assert!(matches!(&scene.views[0].modules[0].source, ModuleSource::Std(n) if n.value == "tone"));
    let errs = errors(&(MINIMAL.to_string() + "modules = [{ path = \"std::no such\" }]\n"));
    assert_eq!(errs[0].3, "`std::no such` does not name a standard module");
}

#[test]
fn a_volume_window_is_lo_hi_or_level_width_in_data_units() {
    let with = |keys: &str| MINIMAL.replace("phantom = \"sphere\"", &format!("phantom = \"sphere\"\n{keys}"));
    let window = |keys: &str| {
        let (_, result) = parse(&with(keys));
        result
            .unwrap_or_else(|e| panic!("{:?}", e.diagnostics))
            .primary()
            .expect("a primary volume")
            .window
            .as_ref()
            .map(|w| w.value)
    };
    assert_eq!(window(""), None);
    assert_eq!(window("window = [-1000, 400.5]"), Some([-1000.0, 400.5]));
    assert_eq!(window("level = 40\nwidth = 400"), Some([-160.0, 240.0]));
    let message = |keys: &str| errors(&with(keys))[0].3.clone();
    assert_eq!(message("window = [5, 5]"), "the window [5, 5] must have its low end below its high end");
    assert_eq!(message("level = 40"), "`level` needs `width`");
    assert_eq!(message("width = 40"), "`width` needs `level`");
    assert_eq!(message("level = 40\nwidth = 0"), "the window `width` must be positive, not 0");
    assert_eq!(
        message("window = [0, 1]\nlevel = 1\nwidth = 2"),
        "a volume has either `window` or `level` and `width`, not both"
    );
}

#[test]
fn garbage_never_panics() {
    for text in ["", "[", "[[view]]\nname = 3", "x = [[[[[[1]]]]]]", "\u{feff}[render]\n", "[uniforms]\na = 1e999"] {
        let _ = parse(text);
    }
}

#[test]
fn meshes_overlays_and_planes_name_what_the_scene_has() {
    let scene = format!(
        "{MINIMAL}kind = \"raycast\"\nmeshes = [\"pin\"]\noverlay = [\"pin\"]\nplanes = [\"axial\"]\n\n\
         [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nmeshes = []\n\n\
         [[mesh]]\nname = \"pin\"\nshape = \"needle\"\ntip = [0.0, 0.0, 0.0]\ndirection = [0.0, 0.0, 1.0]\n\n\
         [[mesh]]\nname = \"skin\"\nvolume = \"v\"\nlevel = 0.3\n"
    );
    let (_, parsed) = parse(&scene);
    let parsed = parsed.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
    let picture = Picture { under: vec![Node::Mesh(0), Node::Plane(1)], over: vec![0] };
    assert_eq!(parsed.views[0].picture, picture);
    assert!(parsed.views[1].picture.under.is_empty() && Scene::has_mesh_layer(&parsed.views[0]));
    assert!(!Scene::has_mesh_layer(&parsed.views[1]));
    assert!(
        matches!(&parsed.meshes[1].source, MeshSource::Surface { volume, level } if volume.value == "v" && *level == 0.3)
    );
    let bad = format!(
        "{MINIMAL}planes = [\"3d\", \"sagital\"]\nmeshes = [\"pn\"]\n\n[[view]]\nname = \"sagittal\"\nkind = \"slice\"\naxis = \"x\"\n\n\
         [[mesh]]\nname = \"pin\"\nshape = \"needle\"\ntip = [0.0, 0.0, 0.0]\ndirection = [0.0, 0.0, 1.0]\n\n\
         [[mesh]]\nname = \"skin\"\nvolume = \"body\"\n"
    );
    let messages: Vec<String> = errors(&bad).into_iter().map(|e| e.3).collect();
    for want in ["`3d` is a raycast view", "no view `sagital`", "no mesh `pn`", "no volume `body`"] {
        assert!(messages.iter().any(|m| m.contains(want)), "{want}: {messages:?}");
    }
}

/// The meshes and groups of the tree tests: a box, two tubes, and a slice view.
const TREE: &str = "[[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\n\n\
    [[mesh]]\nname = \"organ\"\nshape = \"box\"\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\n\n\
    [[mesh]]\nname = \"tube\"\nshape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\ntip = [0.0, 0.0, 9.0]\n\n\
    [[mesh]]\nname = \"pin\"\nshape = \"needle\"\ntip = [0.0, 0.0, 0.0]\ndirection = [0.0, 0.0, 1.0]\n\n";

#[test]
fn a_picture_is_a_tree_of_meshes_groups_and_planes() {
    let scene = format!(
        "{MINIMAL}picture = [\"through\", \"axial\", \"volume\", \"pin\"]\n\n{TREE}\
         [[group]]\nname = \"through\"\nkind = \"occlusion\"\nchildren = [\"organ\", \"tubes\"]\nopacity = 0.3\n\n\
         [[group]]\nname = \"tubes\"\nchildren = [\"tube\", \"pin\"]\n"
    );
    let (_, scene, warnings) = parse_reporting(&scene);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let view = &scene.views[0];
    assert_eq!(view.picture, Picture { under: vec![Node::Group(0), Node::Plane(1)], over: vec![2] });
    assert_eq!(scene.groups[0].kind, GroupKind::Occlusion { hidden_opacity: 0.3 });
    assert_eq!(scene.groups[0].children, [Node::Mesh(0), Node::Group(1)]);
    assert_eq!(
        (scene.groups[1].kind.clone(), &scene.groups[1].children[..]),
        (GroupKind::Depth, &[Node::Mesh(1), Node::Mesh(2)][..])
    );
    assert_eq!(scene.leaves_under(view), (vec![0, 1, 2], vec![Node::Plane(1)]));
    // Without `picture`, the lists make the same kind of tree; `show = "visible"` shows whole.
    let visible = format!(
        "{MINIMAL}\n{TREE}[[group]]\nname = \"g\"\nkind = \"occlusion\"\nshow = \"visible\"\nchildren = [\"organ\", \"tube\"]\n"
    );
    let (_, scene, _) = parse_reporting(&visible);
    let scene = scene.expect("valid");
    assert_eq!(
        scene.views[0].picture,
        Picture { under: vec![Node::Mesh(0), Node::Mesh(1), Node::Mesh(2)], over: vec![] }
    );
    assert_eq!(scene.groups[0].kind, GroupKind::Occlusion { hidden_opacity: 1.0 });
}

#[test]
fn renderer_tree_mistakes_have_their_codes_and_spans() {
    let group = |name: &str, kind: &str, children: &str| {
        format!("[[group]]\nname = \"{name}\"\nkind = \"{kind}\"\nchildren = [{children}]\n\n")
    };
    let cases = [
        (group("g", "occlusion", "\"organ\""), "", "E0720", "occlusion group `g` needs at least two children"),
        (group("g", "depth", ""), "", "E0720", "depth group `g` needs at least a child"),
        (
            group("a", "depth", "\"b\"") + &group("b", "depth", "\"organ\", \"a\""),
            "",
            "E0721",
            "the group `a` contains itself",
        ),
        (String::new(), "picture = [\"organ\"]\n", "E0722", "lists its volume"),
        (String::new(), "picture = [\"volume\", \"organ\", \"volume\"]\n", "E0722", "listed twice"),
        (group("g", "depth", "\"organ\""), "picture = [\"volume\", \"g\"]\n", "E0722", "`g` is a group"),
        (String::new(), "picture = [\"volume\"]\nmeshes = []\n", "E0706", "either `picture` or `meshes`"),
        (
            String::new(),
            "picture = [\"organs\", \"volume\"]\n",
            "E0713",
            "no mesh, group, image or slice view `organs`",
        ),
        (group("organ", "depth", "\"tube\""), "", "E0712", "a group and a mesh are named `organ`"),
        (group("g", "depth", "\"tube\", \"tube\""), "", "E0712", "`tube` is listed twice"),
        (group("g", "shadow", "\"tube\""), "", "E0704", "missing key `light` in a shadow group"),
        (
            group("g", "shadow", "\"tube\"").replace("children", "light = [0.0, 0.0, 0.0]\nchildren"),
            "",
            "E0708",
            "`light` must be a direction",
        ),
    ];
    for (groups, view_keys, code, want) in cases {
        let scene = format!("{MINIMAL}{view_keys}\n{TREE}{groups}");
        let found = errors(&scene);
        assert!(found.iter().any(|e| e.0 == code && e.3.contains(want)), "{want}: {found:?}");
    }
}

/// An `[[image]]` table named `name` on the 20 mm square at z = 5 facing up.
fn image_table(name: &str) -> String {
    format!(
        "[[image]]\nname = \"{name}\"\npath = \"plan.png\"\norigin = [0.0, 20.0, 5.0]\nright = [20.0, 0.0, 0.0]\ndown = [0.0, -20.0, 0.0]\n\n"
    )
}

#[test]
fn an_image_is_a_leaf_on_its_rectangle() {
    let scene = format!(
        "{MINIMAL}picture = [\"g\", \"plan\", \"volume\"]\n\n{TREE}{}\
         [[group]]\nname = \"g\"\nchildren = [\"organ\", \"plan\"]\n",
        image_table("plan")
    );
    let (_, scene, warnings) = parse_reporting(&scene);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let view = &scene.views[0];
    assert_eq!(view.picture, Picture { under: vec![Node::Group(0), Node::Image(0)], over: vec![] });
    assert_eq!(scene.groups[0].children, [Node::Mesh(0), Node::Image(0)]);
    // Each leaf once, in the tree's order.
    assert_eq!(scene.leaves_under(view), (vec![0], vec![Node::Image(0)]));
    assert_eq!(scene.describe_picture(view), "g (depth) [organ, plan (image)], plan (image), volume");
    let image = &scene.images[0];
    assert_eq!(image.file.resolved, std::path::Path::new("scenes/plan.png"));
    assert_eq!(image.corners(), [[0.0, 20.0, 5.0], [20.0, 20.0, 5.0], [20.0, 0.0, 5.0], [0.0, 0.0, 5.0]]);
}

#[test]
fn image_mistakes_have_their_codes() {
    let view = |picture: &str| format!("{MINIMAL}picture = {picture}\n\n{TREE}");
    let cases = [
        (view("[\"plan\", \"volume\"]") + &image_table("organ"), "E0712", "an image and a mesh are named `organ`"),
        (view("[\"plan\", \"volume\"]") + &image_table("plan") + &image_table("plan"), "E0712", "two images"),
        (
            view("[\"plan\", \"volume\"]")
                + &image_table("plan")
                + "[[group]]\nname = \"plan\"\nchildren = [\"tube\"]\n",
            "E0712",
            "a group and an image are named `plan`",
        ),
        (view("[\"volume\", \"plan\"]") + &image_table("plan"), "E0722", "`plan` is an image"),
        (view("[\"plam\", \"volume\"]") + &image_table("plan"), "E0713", "image or slice view `plam`"),
        (
            view("[\"plan\", \"volume\"]") + &image_table("plan").replace("[0.0, -20.0, 0.0]", "[-40.0, 0.0, 0.0]"),
            "E0708",
            "the sides of a rectangle",
        ),
        (
            view("[\"plan\", \"volume\"]") + &image_table("plan").replace("origin = [0.0, 20.0, 5.0]\n", ""),
            "E0704",
            "origin",
        ),
    ];
    for (scene, code, want) in cases {
        let found = errors(&scene);
        assert!(found.iter().any(|e| e.0 == code && e.3.contains(want)), "{want}: {found:?}");
    }
    // A slice view has no depth to place a plane in.
    let slice = format!("{TREE}{}", image_table("plan"))
        .replace("axis = \"axial\"\n", "axis = \"axial\"\npicture = [\"plan\", \"volume\"]\n");
    let (_, scene, warnings) = parse_reporting(&format!("{MINIMAL}\n{slice}"));
    assert!(scene.is_some(), "{warnings:?}");
    assert!(warnings.iter().any(|w| w.code.as_str() == "W0701" && w.message.contains("`plan`")), "{warnings:?}");
}

#[test]
fn a_filter_among_a_depth_groups_children_filters_those_before_it() {
    let groups = "[[group]]\nname = \"g\"\nchildren = [\"organ\", { filter = \"std::edges\" }, \"tube\", { filter = \"soft.vrs\", instances = [\"a\"] }]\n";
    let scene = format!("{MINIMAL}picture = [\"g\", \"volume\"]\n\n{TREE}{groups}");
    let (_, parsed, warnings) = parse_reporting(&scene);
    let parsed = parsed.unwrap_or_else(|| panic!("{warnings:?}"));
    assert_eq!(parsed.groups[0].children, [Node::Mesh(0), Node::Filter(0), Node::Mesh(1), Node::Filter(1)]);
    assert_eq!(parsed.tree_filters.len(), 2);
    assert!(matches!(&parsed.tree_filters[0].source, ModuleSource::Std(n) if n.value == "edges"));
    assert!(matches!(&parsed.tree_filters[1].source, ModuleSource::File(f) if f.given == "soft.vrs"));
    let instances: Vec<&str> = parsed.tree_filters[1].instances.iter().flatten().map(|i| i.name.as_str()).collect();
    assert_eq!(instances, ["a"]);
    assert_eq!(parsed.filters_under(&parsed.views[0]), [0, 1]);
    assert_eq!((parsed.tree_filter_label(0), parsed.tree_filter_label(1)), ("g-2".into(), "g-4".into()));
    assert_eq!(parsed.module_refs().count(), 2, "the filters are modules the scene names");
    assert_eq!(
        parsed.describe_picture(&parsed.views[0]),
        "g (depth) [organ, filter std::edges, tube, filter soft.vrs], volume"
    );
    // A filter first, a filter in an occlusion group, an entry that is neither.
    let first = groups.replace("[\"organ\", { filter", "[{ filter");
    let found = errors(&format!("{MINIMAL}picture = [\"g\", \"volume\"]\n\n{TREE}{first}"));
    assert!(found.iter().any(|e| e.0 == "E0723" && e.3.contains("first child of the group `g`")), "{found:?}");
    let occlusion = groups.replace("name = \"g\"\n", "name = \"g\"\nkind = \"occlusion\"\n");
    let found = errors(&format!("{MINIMAL}picture = [\"g\", \"volume\"]\n\n{TREE}{occlusion}"));
    assert!(found.iter().any(|e| e.0 == "E0724" && e.3.contains("occlusion group `g`")), "{found:?}");
    let neither = groups.replace("{ filter = \"std::edges\" }", "{ path = \"std::edges\" }");
    let found = errors(&format!("{MINIMAL}picture = [\"g\", \"volume\"]\n\n{TREE}{neither}"));
    assert!(found.iter().any(|e| e.0 == "E0716" && e.3.contains("`children` expects names and")), "{found:?}");
}

#[test]
fn a_picture_describes_itself_in_one_line() {
    let groups = "[[group]]\nname = \"seen\"\nkind = \"occlusion\"\nchildren = [\"organ\", \"tube\"]\n\n\
                  [[group]]\nname = \"lit\"\nkind = \"shadow\"\nlight = [0.0, 0.0, 1.0]\nchildren = [\"seen\"]\n";
    let scene = format!("{MINIMAL}picture = [\"lit\", \"volume\", \"pin\"]\n\n{TREE}{groups}");
    let (_, parsed, warnings) = parse_reporting(&scene);
    let parsed = parsed.unwrap_or_else(|| panic!("{warnings:?}"));
    assert_eq!(
        parsed.describe_picture(&parsed.views[0]),
        "lit (shadow, light towards [0.0, 0.0, 1.0]) [seen (occlusion 0.50) [organ | tube]], volume, over it: pin"
    );
}

#[test]
fn a_shadow_group_has_its_light_and_other_groups_ignore_one() {
    let shadow = "[[group]]\nname = \"lit\"\nkind = \"shadow\"\nlight = [1.0, 0.0, 2.0]\nchildren = [\"organ\"]\n";
    let scene = format!("{MINIMAL}picture = [\"lit\", \"volume\"]\n\n{TREE}{shadow}");
    let (_, parsed, warnings) = parse_reporting(&scene);
    let parsed = parsed.unwrap_or_else(|| panic!("{warnings:?}"));
    assert_eq!(parsed.groups[0].kind, GroupKind::Shadow { light: ShadowLight::Towards([1.0, 0.0, 2.0]) });
    let named = scene
        .replace("light = [1.0, 0.0, 2.0]", "light = \"key\"")
        .replace("picture = [", "render = { shading = true, lights = [\"key\"] }\npicture = [");
    let (_, parsed, warnings) = parse_reporting(&named);
    let kind = parsed.unwrap_or_else(|| panic!("{warnings:?}")).groups[0].kind.clone();
    assert!(matches!(kind, GroupKind::Shadow { light: ShadowLight::Light(ref l) } if l.name == "key"), "{kind:?}");
    let found = errors(&named.replace("light = \"key\"", "light = \"kye\""));
    assert!(found.iter().any(|e| e.0 == "E0713" && e.3.contains("no view has a light `kye`")), "{found:?}");
    let depth = scene.replace("kind = \"shadow\"", "kind = \"depth\"");
    let (_, parsed, warnings) = parse_reporting(&depth);
    assert_eq!(parsed.map(|p| p.groups[0].kind.clone()), Some(GroupKind::Depth));
    let w: Vec<_> = warnings.iter().map(|d| (d.code.as_str(), d.message.as_str())).collect();
    assert_eq!(w, [("W0701", "`light` has no effect on this group (it is for shadow groups)")]);
}

#[test]
fn a_lookup_belongs_to_a_bricked_volume() {
    let bricked =
        MINIMAL.replace("phantom = \"sphere\"\n", "phantom = \"sphere\"\nbricks = true\nlookup = \"mine.wgsl\"\n");
    let (_, scene, warnings) = parse_reporting(&bricked);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let lookups = scene.bricked_bindings();
    assert_eq!(lookups.len(), 1);
    assert_eq!((lookups[0].0.as_str(), lookups[0].1.map(|l| l.given.as_str())), ("volume", Some("mine.wgsl")));
    let single = bricked.replace("bricks = true", "bricks = false");
    let (_, scene, warnings) = parse_reporting(&single);
    assert!(scene.is_some_and(|s| s.bricked_bindings().is_empty()));
    let w: Vec<_> = warnings.iter().map(|d| (d.code.as_str(), d.message.as_str())).collect();
    assert_eq!(
        w,
        [("W0701", "`lookup` has no effect on a volume kept in one texture (`bricks = true` keeps it in bricks)")]
    );
}

#[test]
fn zarr_keys_choose_what_a_store_shows() {
    let store = MINIMAL.replace(
        "phantom = \"sphere\"\n",
        "path = \"https://example.org/cells.ome.zarr\"\nmultiscale = \"raw\"\nchannel = 2\ntime = 0\n",
    );
    let (_, scene, warnings) = parse_reporting(&store);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let v = scene.primary().expect("a primary volume");
    assert!(matches!(&v.source, VolumeSource::Url(u) if u.value == "https://example.org/cells.ome.zarr"));
    assert!(v.bricked, "a remote store is kept in bricks");
    assert_eq!(v.zarr.multiscale.as_ref().map(|m| &m.value), Some(&Entry::Name("raw".into())));
    assert_eq!(v.zarr.channel.as_ref().map(|m| &m.value), Some(&Entry::Index(2)));
    assert_eq!(v.zarr.time.as_ref().map(|t| t.value), Some(0));
    // On a volume that is no store they do nothing; a negative index is an error.
    let phantom = MINIMAL.replace("phantom = \"sphere\"\n", "phantom = \"sphere\"\nchannel = 1\n");
    let (_, scene, warnings) = parse_reporting(&phantom);
    assert!(scene.is_some_and(|s| s.primary().is_some_and(|p| p.zarr.channel.is_none())));
    let w: Vec<_> = warnings.iter().map(|d| (d.code.as_str(), d.message.as_str())).collect();
    assert_eq!(w, [("W0701", "`channel` has no effect on a volume that is not a Zarr store")]);
    let negative = store.replace("time = 0", "time = -1");
    let e = errors(&negative);
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!((e[0].0, e[0].3.as_str()), ("E0708", "`time = -1` is negative"));
}

#[test]
fn labels_mark_tag_volumes_of_ids_and_nothing_else() {
    let tag = "\n[[volume]]\nname = \"seg\"\nrole = \"tag\"\nphantom = \"sphere\"\nlabels = true\n";
    let scene_with = |extra: &str| MINIMAL.replace("\n[[view]]", &format!("{extra}\n[[view]]"));
    let (_, scene, warnings) = parse_reporting(&scene_with(tag));
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let seg = scene.volumes.iter().find(|v| v.name.name == "seg").expect("the tag volume");
    assert_eq!(seg.labels.as_ref().map(|l| l.value), Some(true));
    let codes = |text: &str| -> Vec<(String, String)> {
        let (_, _, warnings) = parse_reporting(text);
        warnings.iter().map(|d| (d.code.as_str().to_string(), d.message.clone())).collect()
    };
    // A window beside it has no effect; `labels = false` keeps the window.
    assert_eq!(
        codes(&scene_with(&format!("{tag}window = [0.0, 4.0]\n"))),
        [(
            "W0701".to_string(),
            "`window` has no effect beside `labels = true` (label id k reads entry k of the transfer function)"
                .to_string()
        )]
    );
    assert!(codes(&scene_with(&format!("{}window = [0.0, 4.0]\n", tag.replace("true", "false")))).is_empty());
    // Another role has no label reading.
    let additional = tag.replace("\"tag\"", "\"additional\"");
    assert_eq!(
        codes(&scene_with(&additional)),
        [("W0701".to_string(), "`labels` has no effect on a volume whose role is not `tag`".to_string())]
    );
    let (_, scene, _) = parse_reporting(&scene_with(&additional));
    assert!(scene.is_some_and(|s| s.volumes.iter().all(|v| v.labels.is_none())));
}

#[test]
fn only_http_urls_name_remote_stores() {
    for (url, scheme) in [("s3://bucket/cells.zarr", "s3"), ("gs://b/c.zarr", "gs"), ("file:///tmp/c.zarr", "file")] {
        let text = MINIMAL.replace("phantom = \"sphere\"\n", &format!("path = \"{url}\"\n"));
        let e = errors(&text);
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!((e[0].0, e[0].3.clone()), ("E0718", format!("`{scheme}://` stores are not supported")));
    }
    assert!(is_url("http://host/a.zarr") && !is_url("data/a.zarr") && !is_url("C:\\data\\a.zarr"));
}

#[test]
fn a_channel_list_makes_one_volume_per_channel() {
    let store = MINIMAL.replace(
        "phantom = \"sphere\"\n",
        "path = \"https://example.org/cells.ome.zarr\"\nchannel = [0, 2, \"DAPI\"]\ntf = [\"vessel_red\", \"grayscale\", \"vessel_blue\"]\n",
    );
    let (_, scene, warnings) = parse_reporting(&store);
    let scene = scene.unwrap_or_else(|| panic!("{warnings:?}"));
    let made: Vec<_> = scene
        .volumes
        .iter()
        .map(|v| {
            let tf = match &v.tf {
                Some(TfRef::Preset(p)) => p.value.clone(),
                other => panic!("{other:?}"),
            };
            (v.name.name.as_str(), v.role.value, v.zarr.channel.as_ref().map(|c| c.value.clone()), tf)
        })
        .collect();
    assert_eq!(
        made,
        [
            ("v_0", Role::Primary, Some(Entry::Index(0)), "vessel_red".to_string()),
            ("v_1", Role::Additional, Some(Entry::Index(2)), "grayscale".to_string()),
            ("v_2", Role::Additional, Some(Entry::Name("DAPI".into())), "vessel_blue".to_string()),
        ]
    );
    // As many transfer functions as channels, or one for all.
    let e = errors(&store.replace(", \"vessel_blue\"]", "]"));
    assert_eq!((e[0].0, e[0].3.as_str()), ("E0717", "2 transfer functions for 3 channels"));
    let e = errors(&store.replace("channel = [0, 2, \"DAPI\"]", "channel = 1"));
    assert_eq!((e[0].0, e[0].3.as_str()), ("E0704", "a list of `tf` needs a list of `channel`"));
}

#[test]
fn preintegration_is_a_flag_or_what_it_integrates() {
    let with =
        |value: &str, shading: bool| format!("[render]\nshading = {shading}\npreintegration = {value}\n{MINIMAL}");
    for (value, expected) in [
        ("false", Preintegration::Off),
        ("true", Preintegration::Classification),
        ("\"classification\"", Preintegration::Classification),
        ("\"lighting\"", Preintegration::Lighting),
    ] {
        let (_, scene, warnings) = parse_reporting(&with(value, true));
        let scene = scene.unwrap_or_else(|| panic!("{value}: {warnings:?}"));
        assert!(warnings.is_empty(), "{value}: {warnings:?}");
        assert_eq!(scene.render.preintegration, expected, "{value}");
    }
    // Lighting without shading: the segments are still classified, and a warning says so.
    let (_, scene, warnings) = parse_reporting(&with("\"lighting\"", false));
    assert_eq!(scene.map(|s| s.render.preintegration), Some(Preintegration::Classification));
    let w: Vec<_> = warnings.iter().map(|d| (d.code.as_str(), d.message.as_str())).collect();
    assert_eq!(
        w,
        [("W0701", "`preintegration = \"lighting\"` lights nothing without shading: the segments are classified only")]
    );
    // Anything else is refused at the value.
    let e = errors(&with("\"shading\"", true));
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!((e[0].1, e[0].2), (3, 18), "{e:?}");
    assert_eq!(e[0].3, "`shading` is not one of `true`, `false`, `classification`, `lighting`");
}
