//! Every mistake of a scene's inputs is a diagnostic from `vrsc build` (or, for what only the
//! data can tell, `vrsc render`), at the right line, through the JSON format when asked for,
//! with one exit-code rule: 1 for a mistake in what the scene or a module names, 2 for the
//! command line's own paths, the output folder and the GPU. Fixtures: `tests/fixtures/cli/`.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/cli").join(name).join("scene.toml")
}

/// `vrsc --message-format json ARGS`, to run.
fn vrsc_json_command(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_vrsc"));
    command.args(["--message-format", "json"]).args(args);
    command
}

/// Runs `vrsc --message-format json ARGS`: the exit code and the JSON diagnostics printed.
fn vrsc_json(args: &[&str]) -> (i32, Vec<Value>) {
    run_json(vrsc_json_command(args))
}

/// Runs `command`: the exit code and the JSON diagnostics printed.
fn run_json(mut command: Command) -> (i32, Vec<Value>) {
    let out = command.output().expect("vrsc runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let diags = stdout.lines().filter_map(|l| serde_json::from_str::<Value>(l).ok()).collect();
    (out.status.code().unwrap_or(-1), diags)
}

fn build(scene: &Path) -> (i32, Vec<Value>) {
    let dir = tempfile::tempdir().expect("a folder");
    let out = dir.path().join("out");
    vrsc_json(&["build", &scene.display().to_string(), "-o", &out.display().to_string()])
}

/// The one diagnostic of a run: its code, line and message.
fn only(diags: &[Value]) -> (String, u64, String) {
    assert_eq!(diags.len(), 1, "{diags:#?}");
    let d = &diags[0];
    (
        d["code"].as_str().unwrap_or_default().into(),
        d["line"].as_u64().unwrap_or(0),
        d["message"].as_str().unwrap_or_default().into(),
    )
}

#[test]
fn an_unknown_transfer_function_preset_is_found_by_build() {
    let (code, diags) = build(&fixture("unknown_tf_preset"));
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (1, "E0719", 6), "{message}");
    assert!(message.contains("did you mean `ct_bone`"), "{message}");
}

#[test]
fn a_missing_volume_and_a_missing_tf_file_exit_the_same() {
    let (volume_code, diags) = build(&fixture("missing_volume"));
    let (id, line, message) = only(&diags);
    assert_eq!((id.as_str(), line), ("E0719", 5), "{message}");
    assert!(message.starts_with("cannot read volume `t1_missing.nii.gz`"), "{message}");
    let (tf_code, diags) = build(&fixture("missing_tf_file"));
    let (id, line, message) = only(&diags);
    assert_eq!((id.as_str(), line), ("E0719", 6), "{message}");
    assert_eq!((volume_code, tf_code), (1, 1));
}

#[test]
fn an_absurd_voxel_spacing_is_found_by_build() {
    let (code, diags) = build(&fixture("absurd_spacing"));
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (1, "E0719", 5), "{message}");
    assert!(message.contains("voxel spacing 1e20"), "{message}");
}

#[test]
fn lights_past_the_limit_are_an_error() {
    let (code, diags) = build(&fixture("too_many_lights"));
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (1, "E0702", 4), "{message}");
    assert_eq!(message, "too many lights: 17 (at most 16)");
}

#[test]
fn an_output_folder_that_cannot_be_made_is_exit_2_in_json() {
    let dir = tempfile::tempdir().expect("a folder");
    let file = dir.path().join("a_file");
    std::fs::write(&file, "").expect("a file");
    let out = file.join("out");
    let (code, diags) = vrsc_json(&["build", &fixture("good").display().to_string(), "-o", &out.display().to_string()]);
    let (id, _, message) = only(&diags);
    assert_eq!((code, id.as_str()), (2, "E0902"), "{message}");
    assert!(message.starts_with("cannot create"), "{message}");
}

/// A machine without a graphics adapter, made by pointing the Vulkan loader at a driver list that
/// does not exist: `render` fails with E0903 (exit 2) in the JSON format, and writes no image.
#[test]
fn no_graphics_adapter_is_exit_2_in_json() {
    let dir = tempfile::tempdir().expect("a folder");
    let no_driver = dir.path().join("no_driver.json");
    let mut command = vrsc_json_command(&["render", &fixture("good").display().to_string(), "--output"]);
    command
        .arg(dir.path())
        .env("WGPU_BACKEND", "vulkan")
        .env("VK_ICD_FILENAMES", &no_driver)
        .env("VK_DRIVER_FILES", &no_driver)
        .env_remove("VRS_ADAPTER");
    let (code, diags) = run_json(command);
    let (id, _, message) = only(&diags);
    assert_eq!((code, id.as_str()), (2, "E0903"), "{message}");
    assert!(message.contains("mesa-vulkan-drivers"), "the hint names the software driver: {message}");
    let images = std::fs::read_dir(dir.path()).expect("the folder").count();
    assert_eq!(images, 0, "no image without an adapter");
}

/// An image larger than the device holds: the scene builds, the GPU refuses the output texture,
/// and `render` reports E0904 (exit 2) with wgpu's reason, in JSON and in human form, and writes
/// no image.
#[test]
fn an_image_beyond_the_device_limit_is_e0904_exit_2() {
    let dir = tempfile::tempdir().expect("a folder");
    let scene = fixture("good").display().to_string();
    let out = dir.path().display().to_string();
    let args = ["render", scene.as_str(), "--software", "--size", "65536x16", "--output", out.as_str()];
    let (code, diags) = vrsc_json(&args);
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (2, "E0904", 0), "{message}");
    assert!(message.contains("exceeds the limit"), "wgpu's reason is kept: {message}");
    let human = Command::new(env!("CARGO_BIN_EXE_vrsc")).args(args).output().expect("vrsc runs");
    let stderr = String::from_utf8_lossy(&human.stderr);
    assert_eq!(human.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("error[E0904]") && !stderr.contains("panicked"), "{stderr}");
    let images = std::fs::read_dir(dir.path()).expect("the folder").count();
    assert_eq!(images, 0, "no image when the GPU refuses");
}

#[test]
fn a_missing_scene_file_is_exit_2_in_json() {
    let (code, diags) = build(Path::new("no/such/scene.toml"));
    let (id, line, _) = only(&diags);
    assert_eq!((code, id.as_str(), line), (2, "E0902", 0));
}

#[test]
fn a_module_that_is_not_utf8_is_one_diagnostic_at_its_first_bad_byte() {
    let dir = tempfile::tempdir().expect("a folder");
    let module = dir.path().join("m.vrs");
    std::fs::write(&module, b"lib fn f() -> f32 {\n    return 1.0; // caf\xE9\n}\n").expect("a file");
    let (code, diags) = vrsc_json(&["check", &module.display().to_string()]);
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line, diags[0]["column"].as_u64()), (1, "E0108", 2, Some(23)), "{message}");
    // A module importing it gets no follow-on errors for the names it would have defined.
    let main = dir.path().join("main.vrs");
    std::fs::write(
        &main,
        "import \"m.vrs\";\n\npipeline p in start {\n    state v: f32 = 0.0;\n    use f;\n    state.v = f();\n}\n",
    )
    .expect("a file");
    let (code, diags) = vrsc_json(&["check", &main.display().to_string()]);
    let (id, _, _) = only(&diags);
    assert_eq!((code, id.as_str()), (1, "E0108"));
}

/// A small compressed file whose header claims 1040^3 voxels: its few compressed bytes cannot
/// expand to the claim, which `build` finds from the header and the file's size, and `render`
/// the same way before any allocation. Needs a Vulkan adapter (lavapipe in CI,
/// `scripts/ensure-vulkan.sh`), as the other render tests.
#[test]
fn a_compressed_volume_claiming_a_huge_size_is_a_clean_build_and_render_error() {
    let dir = tempfile::tempdir().expect("a folder");
    let out = dir.path().join("out");
    let scene = fixture("huge_nii_gz");
    let claim = "header says 2249728000 bytes of data, more than";
    let (code, diags) = build(&scene);
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (1, "E0719", 7), "{message}");
    assert!(message.contains(claim), "{message}");
    let (code, diags) =
        vrsc_json(&["render", "--software", &scene.display().to_string(), "-o", &out.display().to_string()]);
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (1, "E0719", 7), "{message}");
    assert!(message.contains(claim), "{message}");
}

/// Bad mesh files are build errors at their `path` (line 8 of the scene below), exit 1, with a
/// message that says what is wrong; memory stays bounded (a header claiming a million triangles
/// in 1 KB is refused before anything is allocated); nothing panics. Render refuses them the same.
#[test]
fn bad_mesh_files_are_build_errors_at_their_path() {
    let triangle = |z: f32| -> Vec<u8> {
        let mut t = vec![0u8; 12];
        for v in [[0.0f32, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]] {
            t.extend(v.iter().flat_map(|c| c.to_le_bytes()));
        }
        t.extend([0u8; 2]);
        t
    };
    let stl = |count: u32, body: Vec<u8>| [vec![0u8; 80], count.to_le_bytes().to_vec(), body].concat();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("claims.stl", stl(1_000_000, vec![0u8; 940]), "claims 1000000 triangles"),
        ("truncated.stl", stl(10, triangle(0.0)), "truncated"),
        ("nan.stl", stl(1, triangle(f32::NAN)), "not all finite"),
        ("empty.stl", stl(0, Vec::new()), "no triangles"),
        ("range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(), "out of"),
        ("faceless.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n".to_vec(), "no triangles"),
        ("junk.ply", b"not a ply file at all".to_vec(), "PLY"),
    ];
    for (file, bytes, expected) in cases {
        let dir = tempfile::tempdir().expect("a folder");
        std::fs::write(dir.path().join(file), bytes).expect("mesh written");
        let scene = dir.path().join("scene.toml");
        let text = format!(
            "[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n[[mesh]]\nname = \"bad\"\npath = \"{file}\"\n\n[[view]]\nname = \"3d\"\n"
        );
        std::fs::write(&scene, text).expect("scene written");
        let (code, diags) = build(&scene);
        let (id, line, message) = only(&diags);
        assert_eq!((code, id.as_str(), line), (1, "E0719", 8), "{file}: {message}");
        assert!(message.contains(expected), "{file}: {message}");
    }
}

/// Zarr stores that cannot be read: `build` reports E0719 at the path with the reason (a dtype
/// it does not read, metadata that is not JSON), and a store whose chunk is corrupt renders
/// with that brick shown coarser and a note naming the chunk, never a panic.
#[test]
fn bad_zarr_stores_are_build_errors_or_render_notes() {
    let dir = tempfile::tempdir().expect("a folder");
    let zarray = |dtype: &str| {
        format!(
            r#"{{"zarr_format": 2, "shape": [70, 70, 70], "chunks": [64, 64, 64], "dtype": "{dtype}",
               "compressor": null, "fill_value": 0, "order": "C", "filters": null}}"#
        )
    };
    let scene = |store: &str| {
        format!(
            "[[volume]]\nname = \"z\"\nrole = \"primary\"\npath = \"{store}\"\nwindow = [0.0, 100.0]\n\n\
             [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [32, 32]\n"
        )
    };
    let store = |name: &str, metadata: &str| {
        let path = dir.path().join(name);
        std::fs::create_dir_all(&path).expect("a store");
        std::fs::write(path.join(".zarray"), metadata).expect("metadata");
        let scene_path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&scene_path, scene(name)).expect("scene");
        scene_path
    };
    for (name, metadata, expected) in
        [("complex.zarr", zarray("<c8"), "c8"), ("broken.zarr", "{ not json".to_string(), "")]
    {
        let (code, diags) = build(&store(name, &metadata));
        let (id, line, message) = only(&diags);
        assert_eq!((code, id.as_str(), line), (1, "E0719", 4), "{name}: {message}");
        assert!(
            message.starts_with(&format!("cannot read volume `{name}`")) && message.contains(expected),
            "{message}"
        );
    }
    // Chunk 0.0.0 is 3 bytes where 64^3 uint16 are due; the others are missing (fill value).
    let corrupt = store("corrupt.zarr", &zarray("<u2"));
    std::fs::write(dir.path().join("corrupt.zarr/0.0.0"), [1u8, 2, 3]).expect("a chunk");
    let out = dir.path().join("out");
    let rendered = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["render", &corrupt.display().to_string(), "--software", "-o", &out.display().to_string()])
        .output()
        .expect("vrsc runs");
    let stderr = String::from_utf8_lossy(&rendered.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("0.0.0"), "the corrupt chunk is named: {stderr}");
}

/// A step so small that the derived `max_samples` reaches its cap: `build` warns that the value
/// is outside `step_size`'s declared range (W0702, exit 0), and `render` notes that the longest
/// rays stop short instead of cutting them silently.
#[test]
fn a_step_too_small_for_the_sample_cap_is_warned_and_noted() {
    let dir = tempfile::tempdir().expect("a folder");
    let scene = dir.path().join("scene.toml");
    let text = "[render]\nstep_size = 0.0025\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n[[view]]\nname = \"3d\"\nsize = [4, 4]\n";
    std::fs::write(&scene, text).expect("scene written");
    let (code, diags) = build(&scene);
    let (id, line, message) = only(&diags);
    assert_eq!((code, id.as_str(), line), (0, "W0702", 2), "{message}");
    let out = dir.path().join("out");
    let output = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["render", "--software", &scene.display().to_string(), "-o", &out.display().to_string()])
        .output()
        .expect("vrsc runs");
    let said = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{said}");
    assert!(said.contains("note: view `3d`: rays need") && said.contains("a larger `step_size`"), "{said}");
}
