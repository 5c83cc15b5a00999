//! The documentation is the repository's own and says what is true:
//!
//! - every fenced example of `docs/language.md` (and the README's VRS examples) goes through
//!   `vrsc` and gives what its label promises;
//! - the README, `ARCHITECTURE.md` and `docs/` send readers only to files inside the repository;
//! - every repository path `ARCHITECTURE.md` names exists.
//!
//! Labels of fenced blocks (the info string after the three backticks, comma-separated):
//!
//! | label | checked |
//! | --- | --- |
//! | `vrs` | `vrsc check` on the block: no error and no warning |
//! | `vrs,error=E0301` | `vrsc check` fails (exit 1) and its errors have exactly the codes given (`+` between several) |
//! | `vrs,warning=W0001` | `vrsc check` gives no error and exactly the warnings given |
//! | `vrs,file=NAME.vrs` | as `vrs`, and kept as NAME.vrs beside the later blocks of the page (for `import` and scenes) |
//! | `toml,scene` | `vrsc build` of the scene, beside the page's named files: it composes |
//! | `toml,scene,error=E0603` | `vrsc build` fails with exactly these error codes |
//! | `toml,scene,warning=W0005` | `vrsc build` succeeds with exactly these warnings |
//! | `json,output=NAME.vrs` | exactly what `vrsc --message-format json check NAME.vrs` prints (a named block above) |
//! | `text`, `sh`, `json` | not run |
//!
//! In `docs/language.md` every block carries one of these labels, so no example goes unchecked.

use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(relative: &str) -> String {
    std::fs::read_to_string(root().join(relative)).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

/// One fenced block of a Markdown page.
struct Block {
    /// The 1-based line of its opening fence.
    line: usize,
    /// The info string's parts: the language first, then the attributes.
    labels: Vec<String>,
    text: String,
}

impl Block {
    fn lang(&self) -> &str {
        self.labels.first().map(String::as_str).unwrap_or("")
    }

    fn flag(&self, name: &str) -> bool {
        self.labels.iter().skip(1).any(|l| l == name)
    }

    fn value(&self, key: &str) -> Option<&str> {
        self.labels.iter().skip(1).find_map(|l| l.strip_prefix(key)?.strip_prefix('='))
    }

    /// The codes an `error=` or `warning=` attribute lists.
    fn codes(&self, key: &str) -> BTreeSet<String> {
        self.value(key).map(|v| v.split('+').map(|c| c.trim().to_string()).collect()).unwrap_or_default()
    }
}

/// The fenced blocks of `text`, in order (fences of three or more backticks).
fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<(usize, String, Vec<String>, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        match &mut open {
            None => {
                if let Some(rest) = trimmed.strip_prefix("```") {
                    let ticks = 3 + rest.chars().take_while(|&c| c == '`').count();
                    let info = rest.trim_start_matches('`').trim();
                    let labels = info.split(',').map(|s| s.trim().to_string()).filter(|s| !s.is_empty()).collect();
                    open = Some((i + 1, "`".repeat(ticks), labels, String::new()));
                }
            }
            Some((start, fence, labels, body)) => {
                if trimmed.starts_with(fence.as_str()) && trimmed.trim_start_matches('`').trim().is_empty() {
                    out.push(Block { line: *start, labels: std::mem::take(labels), text: std::mem::take(body) });
                    open = None;
                } else {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
    }
    assert!(open.is_none(), "a fenced block is never closed");
    out
}

/// Runs `vrsc --message-format json ARGS` in `dir`: the exit code and the (severity, code,
/// line, message) of each diagnostic.
fn vrsc(dir: &Path, args: &[&str]) -> (i32, Vec<(String, String, u64, String)>) {
    let out = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .current_dir(dir)
        .args(["--message-format", "json"])
        .args(args)
        .output()
        .expect("vrsc runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let diags = stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .map(|d| {
            (
                d["severity"].as_str().unwrap_or_default().to_lowercase(),
                d["code"].as_str().unwrap_or_default().to_string(),
                d["line"].as_u64().unwrap_or(0),
                d["message"].as_str().unwrap_or_default().to_string(),
            )
        })
        .collect();
    (out.status.code().unwrap_or(-1), diags)
}

/// What went wrong with one block's outcome, if anything.
fn judge(block: &Block, code: i32, diags: &[(String, String, u64, String)]) -> Option<String> {
    let of = |severity: &str| -> BTreeSet<String> {
        diags.iter().filter(|d| d.0 == severity).map(|d| d.1.clone()).collect()
    };
    let (errors, warnings) = (of("error"), of("warning"));
    let want_errors = block.codes("error");
    let want_warnings = block.codes("warning");
    let want_code = if want_errors.is_empty() { 0 } else { 1 };
    if code != want_code || errors != want_errors || warnings != want_warnings {
        let listed: Vec<String> = diags.iter().map(|d| format!("{} {} line {}: {}", d.0, d.1, d.2, d.3)).collect();
        return Some(format!(
            "exit {code} (want {want_code}), errors {errors:?} (want {want_errors:?}), warnings {warnings:?} \
             (want {want_warnings:?})\n    {}",
            listed.join("\n    ")
        ));
    }
    None
}

/// Runs every checkable block of `page` (a path from the repository root); returns how many ran.
/// `strict`: every block must carry a known label.
fn check_page(page: &str, strict: bool) -> usize {
    let text = read(page);
    let dir = tempfile::tempdir().expect("a folder");
    let mut failures = Vec::new();
    let mut ran = 0;
    for (index, block) in blocks(&text).iter().enumerate() {
        let place = format!("{page}:{} ({})", block.line, block.labels.join(","));
        let known = |label: &String| {
            label == "scene" || ["error=", "warning=", "file=", "output="].iter().any(|k| label.starts_with(k))
        };
        if strict && !block.labels.iter().skip(1).all(known) {
            failures.push(format!("{place}: an attribute other than scene, error=, warning=, file=, output="));
            continue;
        }
        match block.lang() {
            "vrs" => {
                let name = block.value("file").map(str::to_string).unwrap_or_else(|| format!("block_{index}.vrs"));
                let path = dir.path().join(&name);
                std::fs::write(&path, &block.text).expect("the block is written");
                let (code, diags) = vrsc(dir.path(), &["check", &name]);
                if let Some(why) = judge(block, code, &diags) {
                    failures.push(format!("{place}: {why}"));
                }
                ran += 1;
            }
            "toml" if block.flag("scene") => {
                let name = block.value("file").map(str::to_string).unwrap_or_else(|| format!("scene_{index}.toml"));
                std::fs::write(dir.path().join(&name), &block.text).expect("the scene is written");
                let out = dir.path().join(format!("out_{index}"));
                let (code, diags) = vrsc(dir.path(), &["build", &name, "-o", &out.display().to_string()]);
                if let Some(why) = judge(block, code, &diags) {
                    failures.push(format!("{place}: {why}"));
                }
                ran += 1;
            }
            "json" if block.value("output").is_some() => {
                let name = block.value("output").unwrap_or_default();
                let out = Command::new(env!("CARGO_BIN_EXE_vrsc"))
                    .current_dir(dir.path())
                    .args(["--message-format", "json", "check", name])
                    .output()
                    .expect("vrsc runs");
                let printed = String::from_utf8_lossy(&out.stdout);
                if printed != block.text {
                    failures.push(format!("{place}: vrsc prints\n{printed}"));
                }
                ran += 1;
            }
            "text" | "sh" | "json" if strict => {}
            _ if strict => {
                failures.push(format!("{place}: a block without a checked label (vrs, toml,scene, text, sh, json)"))
            }
            _ => {}
        }
    }
    assert!(
        failures.is_empty(),
        "{} example(s) do not do what their label says:\n{}",
        failures.len(),
        failures.join("\n")
    );
    ran
}

#[test]
fn every_example_of_the_language_guide_checks_as_labelled() {
    let ran = check_page("docs/language.md", true);
    assert!(ran >= 20, "docs/language.md has only {ran} checked examples");
}

#[test]
fn the_readme_vrs_examples_check_clean() {
    assert!(check_page("README.md", false) >= 1);
}

/// The Markdown pages of the repository's own documentation.
fn documentation_pages() -> Vec<String> {
    let mut pages = vec!["README.md".to_string(), "ARCHITECTURE.md".to_string()];
    let mut docs: Vec<String> = std::fs::read_dir(root().join("docs"))
        .expect("docs/ exists")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

#[test]
fn the_documentation_points_only_inside_the_repository() {
    let mut offenders = Vec::new();
    for page in documentation_pages() {
        let text = read(&page);
        let base = root().join(&page).parent().expect("a folder").to_path_buf();
        for (i, line) in text.lines().enumerate() {
            for outside in ["../shared", "LANGUAGE.md"] {
                if line.contains(outside) {
                    offenders.push(format!("{page}:{}: mentions `{outside}`", i + 1));
                }
            }
            // Relative Markdown links: [text](target) must name a file or folder of the repository.
            let mut rest = line;
            while let Some(at) = rest.find("](") {
                rest = &rest[at + 2..];
                let Some(end) = rest.find(')') else { break };
                let target = rest[..end].split('#').next().unwrap_or("").trim();
                rest = &rest[end..];
                if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let path = base.join(target);
                let inside =
                    path.canonicalize().ok().zip(root().canonicalize().ok()).is_some_and(|(p, r)| p.starts_with(r));
                if !inside {
                    offenders.push(format!("{page}:{}: link `{target}` is not a path inside the repository", i + 1));
                }
            }
        }
    }
    assert!(offenders.is_empty(), "{}", offenders.join("\n"));
}

/// Whether a backticked span of `ARCHITECTURE.md` names a repository path: only path characters,
/// and a `/` or a file extension of the repository's sources; placeholders (`VIEW.json`,
/// `DIR/VIEW.wgsl`) and globs (`stdlib/*.vrs`) are not paths.
fn looks_like_path(span: &str) -> bool {
    const EXTENSIONS: &[&str] = &[".rs", ".md", ".toml", ".vrs", ".wgsl", ".sh", ".py", ".json", ".lock"];
    const PLACEHOLDERS: &[&str] = &["VIEW", "FILE", "DIR", "NAME", "SCENE", "OUT"];
    let chars_ok = !span.is_empty()
        && span.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/'))
        && !span.starts_with('.')
        && !span.contains("//");
    let shaped = span.contains('/') || EXTENSIONS.iter().any(|e| span.ends_with(e));
    let placeholder = span.split('/').any(|part| PLACEHOLDERS.contains(&part.split('.').next().unwrap_or(part)));
    chars_ok && shaped && !placeholder
}

/// The backticked spans of `text`.
fn backticked(text: &str) -> Vec<&str> {
    text.split('`').skip(1).step_by(2).collect()
}

/// The paths a heading gives its section: `## Passes (compiler/src)` → `compiler/src`;
/// `## Live loop (live/, viewer/)` → `live/`, `viewer/`.
fn heading_bases(heading: &str) -> Vec<PathBuf> {
    let Some(open) = heading.rfind('(') else { return Vec::new() };
    let inner = heading[open + 1..].trim_end().trim_end_matches(')');
    inner
        .split(',')
        .map(str::trim)
        .filter(|p| looks_like_path(p) || (!p.is_empty() && root().join(p).is_dir()))
        .map(|p| root().join(p))
        .collect()
}

/// Every path `ARCHITECTURE.md` names that does not exist, as `line: path`.
///
/// A path is looked up from the repository's root, from the folders its section's heading names,
/// and from the folders of the paths named before it in the same table row or paragraph
/// (`volume/` (`header.rs`, `nifti.rs`) names `runtime/src/volume/header.rs`).
fn missing_architecture_paths(text: &str) -> Vec<String> {
    let mut missing = Vec::new();
    let mut section: Vec<PathBuf> = Vec::new();
    let mut unit: Vec<PathBuf> = Vec::new();
    let mut in_code = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code {
            continue;
        }
        if line.starts_with('#') {
            section = heading_bases(line);
            unit.clear();
            continue;
        }
        // A table row is a unit of its own; a paragraph (lines up to a blank one) is another.
        if line.trim().is_empty() || line.trim_start().starts_with('|') {
            unit.clear();
        }
        for span in backticked(line) {
            if !looks_like_path(span) {
                continue;
            }
            let bases = std::iter::once(root()).chain(section.iter().cloned()).chain(unit.iter().rev().cloned());
            let found = bases.map(|b| b.join(span)).find(|p| p.exists());
            match found {
                Some(path) => {
                    unit.push(if path.is_dir() { path } else { path.parent().expect("a folder").to_path_buf() })
                }
                None => missing.push(format!("line {}: `{span}`", i + 1)),
            }
        }
        if line.trim().is_empty() {
            unit.clear();
        }
    }
    missing
}

#[test]
fn every_path_architecture_names_exists() {
    let missing = missing_architecture_paths(&read("ARCHITECTURE.md"));
    assert!(missing.is_empty(), "ARCHITECTURE.md names paths that do not exist:\n{}", missing.join("\n"));
}

#[test]
fn the_path_check_finds_a_missing_file_and_resolves_relative_ones() {
    let text = "## Passes (compiler/src)\n\n| a | `check/` (`std_cache.rs`) |\n| b | `nowhere.rs`, `compose/nothing.rs` |\n\n\
                `runtime/src/volume/` holds `nifti.rs`; `VIEW.json` and `stdlib/*.vrs` are no paths.\n";
    let missing = missing_architecture_paths(text);
    assert_eq!(missing, ["line 4: `nowhere.rs`", "line 4: `compose/nothing.rs`"]);
}

#[test]
fn the_block_reader_reads_labels() {
    let page = "text\n```vrs,error=E0301+E0203\nlib fn f() {}\n```\n````toml,scene\n```\n````\n";
    let found = blocks(page);
    assert_eq!(found.len(), 2);
    assert_eq!((found[0].line, found[0].lang()), (2, "vrs"));
    assert_eq!(found[0].codes("error"), BTreeSet::from(["E0203".to_string(), "E0301".to_string()]));
    assert!(found[1].flag("scene"));
    assert_eq!(found[1].text, "```\n");
}
