//! Diagnostic fixtures: each `tests/fixtures/diagnostics/CODE_name.vrs` (checked), `CODE_name/main.vrs`
//! (checked, with imports) or `CODE_name/scene.toml` (composed) must produce `CODE`;
//! the rendered diagnostics are snapshots. The catalogue in `docs/reference.md` must list every
//! code, and every code must have a fixture.

mod common;

use std::collections::BTreeSet;
use vrsc::diag::{Code, render_plain};

#[test]
fn every_fixture_reports_its_code() {
    for (name, path) in common::cases("diagnostics") {
        let (rendered, codes) = if path.ends_with("scene.toml") {
            common::build_fixture(&path)
        } else {
            let checked = common::check_fixture(&path);
            let diags = checked.diags.sorted();
            let codes = diags.iter().map(|d| d.code.as_str().to_string()).collect();
            (render_plain(&diags, &checked.sources), codes)
        };
        let want = name.split('_').next().unwrap_or_default();
        assert!(codes.iter().any(|c| c == want), "{name}: expected {want}, got {codes:?}");
        insta::assert_snapshot!(name, rendered);
    }
}

/// Codes no fixture can trigger, with the reason.
const UNTRIGGERABLE: &[(Code, &str)] = [
    (Code::Internal, "a compiler bug by definition; the lowering unit tests feed malformed IR to produce it"),
    (Code::SceneInput, "the compiler reads no volume, transfer function or mesh; the CLI's tests produce it"),
    (Code::Io, "about the file system, not an input file; the CLI's tests produce it"),
    (Code::Device, "depends on the machine's GPU; the CLI prints it when no adapter opens"),
    (Code::GpuRefused, "depends on the device's limits; the CLI's tests provoke it with an image beyond them"),
]
.as_slice();

#[test]
fn every_code_has_a_fixture_and_a_catalogue_entry() {
    let fixtures: BTreeSet<String> = common::cases("diagnostics")
        .into_iter()
        .filter_map(|(name, _)| name.split('_').next().map(String::from))
        .collect();
    let reference =
        std::fs::read_to_string(common::fixtures().join("../../docs/reference.md")).expect("docs/reference.md exists");
    for &code in Code::ALL {
        let code_str = code.as_str();
        assert!(
            reference.contains(&format!("### {code_str}")),
            "docs/reference.md has no `### {code_str}` entry ({})",
            code.title()
        );
        if UNTRIGGERABLE.iter().all(|(c, _)| *c != code) {
            assert!(
                fixtures.contains(code_str),
                "no fixture tests/fixtures/diagnostics/{code_str}_*.vrs triggers {code_str}"
            );
        }
    }
}
