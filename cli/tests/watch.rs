//! `vrsc watch` end to end on the software adapter: an edit of a module writes a new image, a
//! broken edit leaves it alone and prints the diagnostics, a fix writes again, a uniform-only
//! edit compiles no pipeline, and SIGTERM ends the process cleanly.

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

const MODULE: &str = "pipeline dim after classification.primary {\n    uniform k: f32 = 0.5 in 0.0 .. 1.0;\n    \
                      state color: vec4f;\n    state.color = state.color * k;\n}\n";

fn scene(k: f32) -> String {
    format!(
        "[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\ntf = \"ct_bone\"\n\n\
         [[module]]\npath = \"dim.vrs\"\n\n[uniforms]\nk = {k:.2}\n\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [24, 24]\n"
    )
}

/// The JSON lines of the process's standard output, as they come.
fn lines(stdout: ChildStdout) -> Receiver<Value> {
    let (sender, receiver) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Ok(value) = serde_json::from_str::<Value>(&line) {
                let _ = sender.send(value);
            }
        }
    });
    receiver
}

/// The next rebuild or render report (diagnostics lines are collected on the way).
fn next_report(lines: &Receiver<Value>, diagnostics: &mut Vec<Value>) -> Value {
    loop {
        let line = lines.recv_timeout(Duration::from_secs(120)).expect("vrsc watch stopped reporting");
        if line.get("event").is_some() {
            return line;
        }
        diagnostics.push(line);
    }
}

fn image_bytes(dir: &Path) -> Vec<u8> {
    std::fs::read(dir.join("out/3d.png")).expect("3d.png is written")
}

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
    }
}

#[test]
fn watch_follows_edits_keeps_the_last_good_image_and_stops_on_sigterm() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("dim.vrs"), MODULE).unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene(0.5)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["watch", "scene.toml", "-o", "out", "--software", "--message-format", "json"])
        .current_dir(dir.path())
        .env("VRS_ADAPTER", "software")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let lines = lines(child.stdout.take().unwrap());
    let child = Killed(child);
    let mut diagnostics = Vec::new();

    let first = next_report(&lines, &mut diagnostics);
    assert_eq!((first["event"].as_str(), first["ok"].as_bool()), (Some("render"), Some(true)), "{first}");
    let original = image_bytes(dir.path());

    // A structural edit of the module: composed, one pipeline compiled, a new image.
    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* k * 0.5;")).unwrap();
    let edit = next_report(&lines, &mut diagnostics);
    assert_eq!(edit["ok"], true, "{edit}");
    assert_eq!(edit["pipelines_compiled"], 1, "{edit}");
    assert!(edit["changed"].as_array().unwrap().iter().any(|c| c.as_str().unwrap().ends_with("dim.vrs")), "{edit}");
    let edited = image_bytes(dir.path());
    assert_ne!(edited, original, "the edit darkens the image");

    // A broken edit: diagnostics with file and line, the image untouched, the process alive.
    diagnostics.clear();
    std::fs::write(dir.path().join("dim.vrs"), MODULE.replace("* k;", "* kk;")).unwrap();
    let broken = next_report(&lines, &mut diagnostics);
    assert_eq!(broken["ok"], false, "{broken}");
    let error = diagnostics.iter().find(|d| d["code"] == "E0502").unwrap_or_else(|| panic!("{diagnostics:?}"));
    assert!(error.to_string().contains("dim.vrs"), "{error}");
    assert_eq!(image_bytes(dir.path()), edited, "a broken edit must leave the image alone");

    // The fix renders again; then a uniform-only edit of the scene compiles nothing.
    std::fs::write(dir.path().join("dim.vrs"), MODULE).unwrap();
    let fixed = next_report(&lines, &mut diagnostics);
    assert_eq!(fixed["ok"], true, "{fixed}");
    assert_eq!(image_bytes(dir.path()), original, "the fix brings the first picture back");
    std::fs::write(dir.path().join("scene.toml"), scene(0.2)).unwrap();
    let uniform = next_report(&lines, &mut diagnostics);
    assert_eq!((uniform["ok"].as_bool(), uniform["cache_hit"].as_bool()), (Some(true), Some(true)), "{uniform}");
    assert_eq!(uniform["pipelines_compiled"], 0, "{uniform}");
    assert_ne!(image_bytes(dir.path()), original);
    let leftovers: Vec<_> =
        std::fs::read_dir(dir.path().join("out")).unwrap().flatten().map(|e| e.file_name()).collect();
    assert_eq!(leftovers, ["3d.png"], "only whole images are left in the folder");

    let mut child = child;
    let pid = child.0.id().to_string();
    assert!(Command::new("kill").args(["-TERM", &pid]).status().unwrap().success());
    let status = child.0.wait().unwrap();
    assert!(status.success(), "SIGTERM ends vrsc watch cleanly: {status:?}");
}
