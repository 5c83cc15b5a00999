//! The project's conformance cases (`tests/conformance/`, its README says how to write one): each
//! case is a module checked with `vrsc check`, or a scene built with `vrsc build`, and the
//! diagnostics it gives must be exactly the ones its `expect:` lines list, by code and line, with
//! the exit code that goes with them (1 when an error is expected, else 0).

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn cases_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/conformance")
}

/// A case: its name and the file `vrsc` is run on.
struct Case {
    name: String,
    entry: PathBuf,
    scene: bool,
}

fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(cases_dir()).expect("tests/conformance exists") {
        let path = entry.expect("a directory entry").path();
        let name = path.file_name().unwrap_or_default().to_string_lossy().into_owned();
        if path.is_dir() {
            let (main, scene) = (path.join("main.vrs"), path.join("scene.toml"));
            if scene.is_file() {
                out.push(Case { name, entry: scene, scene: true });
            } else {
                assert!(main.is_file(), "case folder {name} has neither main.vrs nor scene.toml");
                out.push(Case { name, entry: main, scene: false });
            }
        } else if name.ends_with(".vrs") {
            out.push(Case { name, entry: path, scene: false });
        }
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}

/// A case's text; a case about bytes that are not UTF-8 (E0108) has its `expect:` lines in
/// UTF-8 before them.
fn read_case(path: &Path) -> std::io::Result<String> {
    Ok(String::from_utf8_lossy(&std::fs::read(path)?).into_owned())
}

/// The `expect:` lines of a case's entry file (`// expect:` in VRS, `# expect:` in a scene):
/// `ok`, or `CODE at LINE` (`E0301 at 4`, `W0002 at 3`), sorted.
fn expectations(text: &str) -> Result<Vec<(String, u64)>, String> {
    let mut out = Vec::new();
    let mut ok = false;
    for line in text.lines() {
        let t = line.trim_start();
        let Some(rest) = t.strip_prefix("//").or_else(|| t.strip_prefix('#')) else { continue };
        let Some(what) = rest.trim().strip_prefix("expect:") else { continue };
        let what = what.trim();
        if what == "ok" {
            ok = true;
            continue;
        }
        let parts: Vec<&str> = what.split_whitespace().collect();
        match parts.as_slice() {
            [code, "at", line] if code.len() == 5 && (code.starts_with('E') || code.starts_with('W')) => {
                let line = line.parse().map_err(|_| format!("bad line number in `{what}`"))?;
                out.push((code.to_string(), line));
            }
            _ => return Err(format!("cannot read `expect: {what}` (write `ok` or `CODE at LINE`)")),
        }
    }
    if ok != out.is_empty() {
        return Err("a case needs `expect: ok` or at least one `expect: CODE at LINE`, not both".into());
    }
    out.sort();
    Ok(out)
}

/// Runs one case; `Err` says how it failed.
fn run(case: &Case) -> Result<(), String> {
    let text = read_case(&case.entry).map_err(|e| e.to_string())?;
    let want = expectations(&text)?;
    let out_dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let mut command = Command::new(env!("CARGO_BIN_EXE_vrsc"));
    command.args(["--message-format", "json"]);
    if case.scene {
        command.arg("build").arg(&case.entry).arg("-o").arg(out_dir.path().join("out"));
    } else {
        command.arg("check").arg(&case.entry);
    }
    let output = command.output().map_err(|e| e.to_string())?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let diags: Vec<Value> = stdout.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
    let mut got: Vec<(String, u64)> = diags
        .iter()
        .map(|d| (d["code"].as_str().unwrap_or("?").to_string(), d["line"].as_u64().unwrap_or(0)))
        .collect();
    got.sort();
    let code = output.status.code().unwrap_or(-1);
    let want_code = if want.iter().any(|(c, _)| c.starts_with('E')) { 1 } else { 0 };
    if got != want || code != want_code {
        let messages: Vec<String> = diags
            .iter()
            .map(|d| format!("{} line {}: {}", d["code"].as_str().unwrap_or("?"), d["line"], d["message"]))
            .collect();
        return Err(format!(
            "exit {code} (want {want_code}); got {got:?}, want {want:?}\n    {}\n    stderr: {}",
            messages.join("\n    "),
            String::from_utf8_lossy(&output.stderr).lines().last().unwrap_or("")
        ));
    }
    if let Some(d) = diags.iter().find(|d| d["message"].as_str().unwrap_or("").is_empty()) {
        return Err(format!("a diagnostic without a message: {d}"));
    }
    Ok(())
}

#[test]
fn every_conformance_case_gives_exactly_its_expected_diagnostics() {
    let cases = cases();
    assert!(cases.len() >= 60, "only {} conformance cases", cases.len());
    // A few threads: each case is one short process.
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(2, 8);
    let chunks: Vec<&[Case]> = cases.chunks(cases.len().div_ceil(threads)).collect();
    let failures: Vec<String> = std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .iter()
            .map(|chunk| {
                s.spawn(move || {
                    chunk
                        .iter()
                        .filter_map(|c| run(c).err().map(|why| format!("FAIL {}: {why}", c.name)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a case thread")).collect()
    });
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

#[test]
fn a_case_named_after_a_code_expects_that_code() {
    for case in cases() {
        let prefix = case.name.split('_').next().unwrap_or_default();
        let text = read_case(&case.entry).expect("the case reads");
        let want = expectations(&text).unwrap_or_else(|why| panic!("{}: {why}", case.name));
        if prefix == "ok" {
            assert!(want.is_empty(), "{}: an ok_ case expects no diagnostic", case.name);
        } else {
            assert!(want.iter().any(|(c, _)| c == prefix), "{}: named after {prefix} but expects {want:?}", case.name);
        }
    }
}

/// Codes no case here gives, with the reason: they are about a render, the machine or the
/// compiler itself, not about what a module or scene says (`compiler/tests/diagnostics.rs` and
/// the CLI's tests produce them).
const NOT_CASES: &[(&str, &str)] = &[
    ("E0610", "a bricked volume's own WGSL lookup: a Zarr store or `bricks = true` and a WGSL file"),
    ("E0801", "probes are asked for on `vrsc render`'s command line, which needs a GPU"),
    ("E0802", "probes are asked for on `vrsc render`'s command line, which needs a GPU"),
    ("E0719", "a volume, TF or mesh file the renderer cannot read: `vrsc build` reads no inputs"),
    ("E0901", "a compiler bug by definition"),
    ("E0902", "a file of the command line or an output, not the input's content"),
    ("E0903", "the machine's GPU"),
    ("E0904", "the machine's GPU"),
];

#[test]
fn every_code_a_module_or_scene_can_cause_has_a_case() {
    let names: Vec<String> = cases().into_iter().map(|c| c.name).collect();
    let mut missing = Vec::new();
    for code in vrsc::diag::Code::ALL {
        let code = code.as_str();
        let exempt = NOT_CASES.iter().any(|(c, _)| *c == code);
        let covered = names.iter().any(|n| n.starts_with(&format!("{code}_")));
        if exempt && covered {
            missing.push(format!("{code} has a case now: take it out of NOT_CASES"));
        } else if !exempt && !covered {
            missing.push(format!("{code}: no case tests/conformance/{code}_*"));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn expectations_are_read_strictly() {
    assert_eq!(expectations("// expect: ok\n"), Ok(vec![]));
    assert_eq!(
        expectations("// expect: W0002 at 3\n# expect: E0301 at 2\n"),
        Ok(vec![("E0301".into(), 2), ("W0002".into(), 3)])
    );
    assert!(expectations("lib fn f() {}\n").is_err());
    assert!(expectations("// expect: ok\n// expect: E0301 at 2\n").is_err());
    assert!(expectations("// expect: error somewhere\n").is_err());
}
