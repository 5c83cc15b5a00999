//! Embeds every `stdlib/*.vrs` file of the workspace into the compiler.

use std::fmt::Write;
use std::path::Path;

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stdlib");
    println!("cargo::rerun-if-changed={}", dir.display());
    // A standard library that cannot be read fails the build: an empty one would compose every
    // scene into an empty pipeline.
    let read = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()));
    let mut entries: Vec<(String, String)> = read
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "vrs"))
        .map(|p| {
            let name = p.file_stem().and_then(|s| s.to_str()).expect("stdlib file names are UTF-8").to_string();
            let path = p.canonicalize().unwrap_or_else(|e| panic!("cannot resolve {}: {e}", p.display()));
            (name, path.display().to_string())
        })
        .collect();
    assert!(!entries.is_empty(), "{} holds no standard module (*.vrs)", dir.display());
    entries.sort();
    let mut table =
        String::from("/// Standard modules: (name, source), sorted by name.\nstatic STDLIB: &[(&str, &str)] = &[\n");
    for (name, path) in &entries {
        println!("cargo::rerun-if-changed={path}");
        let _ = writeln!(table, "    ({name:?}, include_str!({path:?})),");
    }
    table.push_str("];\n");
    let out = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("stdlib_table.rs");
    std::fs::write(out, table).expect("OUT_DIR is writable");
}
