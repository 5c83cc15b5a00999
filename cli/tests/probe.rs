//! `vrsc render --probe`: the command writes DIR/VIEW.FIELD.png for every view that declares the
//! field and prints each image's range and mapping; an unknown field is E0801 with exit code 1.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh, empty folder under the system's temporary folder.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vrsc-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn vrsc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vrsc")).args(args).current_dir(root()).output().expect("vrsc runs")
}

#[test]
fn render_probe_writes_one_image_per_view_and_prints_its_range() {
    let dir = fresh_dir("probe");
    let out = dir.to_str().expect("utf-8 path");
    let run = vrsc(&[
        "render",
        "tests/fixtures/render/head_dvr.toml",
        "-o",
        out,
        "--size",
        "32x32",
        "--software",
        "--probe",
        "gradient",
        "--probe-threshold",
        "0.3",
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stdout}\n{stderr}");
    for view in ["3d", "axial"] {
        let image = image::open(dir.join(format!("{view}.gradient.png"))).expect("probe image").to_rgba8();
        assert_eq!(image.dimensions(), (32, 32));
        assert!(image.pixels().any(|p| p[3] == 255), "{view}: no pixel has a value");
        assert!(!dir.join(format!("{view}.png")).exists(), "a probe writes only probe images");
        let legend = format!("{view}.gradient: vec3f sample field at the first sample with accum.a >= 0.3");
        assert!(stdout.contains(&legend), "no `{legend}` in\n{stdout}");
    }
    assert!(stdout.contains("R, G, B = x, y, z linearly from"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unknown_probe_field_is_an_input_error() {
    let dir = fresh_dir("unknown");
    let out = dir.to_str().expect("utf-8 path");
    let run = vrsc(&[
        "render",
        "tests/fixtures/render/head_dvr.toml",
        "-o",
        out,
        "--software",
        "--probe",
        "gradiant",
        "--message-format",
        "json",
    ]);
    assert_eq!(run.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&run.stdout);
    let line: serde_json::Value = serde_json::from_str(stdout.lines().next().unwrap_or_default()).expect("JSON");
    assert_eq!(line["code"], "E0801");
    assert!(line["notes"].to_string().contains("did you mean `gradient`?"), "{line}");
    assert!(!dir.exists(), "nothing is written");
}
