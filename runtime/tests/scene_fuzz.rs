//! Scenes mutated at random keep the build's promise (issue 24, item 4): for any scene text and
//! any set of modules, `vrsc`'s build either refuses the scene with error diagnostics (each with
//! a message and a span in a file, unless its code is an I/O or device one, E0902 to E0904), or
//! it composes, loads and renders on lavapipe with no wgpu error, and a probe of `out_color`
//! holds only finite values. Nothing panics, and no build reports E0901 (a compiler bug). A
//! scene that builds may still be refused by the runtime for what only it can check (a volume
//! file, a phantom or transfer-function name), but only with a message, and never by wgpu.
//!
//! Each case starts from a random cell of the combination matrix (`common::cells`), read into a
//! small model of the scene's tables, and applies one to four mutations drawn from
//! [`MUTATIONS`]: `[render]` keys and a view's own `render` table set to good and bad values,
//! volumes added (phantoms, tiny NRRD files, odd names and roles), removed or edited, views
//! edited (kind, axis, slab, size, position, camera, convention), added or removed, modules
//! added (example and fixture modules, `progen` modules, standard modules, templates with
//! instances, missing or broken files), `[uniforms]` entries of right and wrong types, unknown
//! keys and tables, and the scene text itself corrupted (truncated, a byte inserted or deleted,
//! a line repeated).
//!
//! `VRS_SCENE_FUZZ_CASES` cases (default [`DEFAULT_CASES`]) from seed `VRS_SCENE_FUZZ_SEED`
//! (default [`DEFAULT_SEED`]); case `i` has seed `SEED + i`. A failure prints the seed, the
//! mutations, the scene text and the generated files; one case runs again with
//! `VRS_SCENE_FUZZ_SEED=SEED VRS_SCENE_FUZZ_CASES=1` (`VRS_SCENE_FUZZ_VERBOSE=1` prints every
//! case's outcome and mutations). A long campaign:
//!
//! ```text
//! VRS_SCENE_FUZZ_CASES=5000 cargo test --release -p vrs-runtime --test suite scene_fuzz -- --nocapture
//! ```

use crate::common;

use common::cells::Cell;
use std::fmt::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use vrs_runtime::{Gpu, ProbeSpec, RenderOptions, RuntimeError, SceneRenderer};
use vrsc::compose::build::build_scene;
use vrsc::diag::Code;
use vrsc::progen::{Choices, generate};

/// Cases of a plain `cargo test` run.
const DEFAULT_CASES: u64 = 150;
/// The first seed of a plain run (fixed, so CI sees the same cases every time).
const DEFAULT_SEED: u64 = 24_004;
/// Views of at most this width and height render at their own size (odd sizes included);
/// larger ones at 8x8, so no case costs more than a few thousand rays.
const OWN_SIZE_LIMIT: u32 = 8;

#[test]
fn mutated_scenes_render_or_are_refused_with_diagnostics() {
    let cases = env_u64("VRS_SCENE_FUZZ_CASES", DEFAULT_CASES);
    let base = env_u64("VRS_SCENE_FUZZ_SEED", DEFAULT_SEED);
    let verbose = std::env::var_os("VRS_SCENE_FUZZ_VERBOSE").is_some();
    let gpu = common::software_gpu();
    let cells = Cell::all();
    let library = Library::find();
    let mut tally = Tally::default();
    let mut failures = Vec::new();
    let started = Instant::now();
    for i in 0..cases {
        let seed = base.wrapping_add(i);
        let case_start = Instant::now();
        let case = match catch_unwind(AssertUnwindSafe(|| Case::generate(seed, &cells, &library))) {
            Ok(case) => case,
            Err(payload) => {
                failures.push(format!("seed {seed}: the generator panicked: {}", panic_text(&payload)));
                continue;
            }
        };
        let outcome = catch_unwind(AssertUnwindSafe(|| case.run(&gpu)))
            .unwrap_or_else(|payload| Err(format!("panicked: {}", panic_text(&payload))));
        let took = case_start.elapsed();
        if took > tally.slowest.0 {
            tally.slowest = (took, seed);
        }
        tally.cases += 1;
        match outcome {
            Ok(Outcome::Refused(why)) => {
                if verbose {
                    eprintln!("seed {seed}: refused: {why} [{}]", case.mutations[1..].join("; "));
                }
                tally.refused += 1;
            }
            Ok(Outcome::RuntimeRefused(why)) => {
                eprintln!("seed {seed}: built, refused by the runtime: {}", first_line(&why));
                tally.runtime_refused += 1;
            }
            Ok(Outcome::Rendered { views, probed }) => {
                if verbose {
                    eprintln!("seed {seed}: rendered {views} views [{}]", case.mutations[1..].join("; "));
                }
                tally.rendered += 1;
                tally.views += views;
                tally.probed += usize::from(probed);
            }
            Err(error) => {
                let report = case.report(&error);
                eprintln!("{report}");
                failures.push(report);
            }
        }
    }
    eprintln!("scene fuzz: {tally:?} in {:.1?} (seeds {base}..{})", started.elapsed(), base.wrapping_add(cases));
    // The first reports in full (each was printed in full as it happened), then a line each.
    let summary: Vec<&str> =
        failures.iter().enumerate().map(|(i, f)| if i < 3 { f.as_str() } else { first_line(f) }).collect();
    assert!(failures.is_empty(), "{} of {cases} cases broke the promise:\n\n{}", failures.len(), summary.join("\n\n"));
    if cases >= 20 {
        assert!(tally.refused > 0 && tally.rendered > 0, "the generator reaches only one side: {tally:?}");
    }
}

/// What happened to the cases.
#[derive(Default)]
struct Tally {
    cases: usize,
    /// Refused by the build, with diagnostics.
    refused: usize,
    /// Built, then refused by the runtime (a volume or transfer function it could not load).
    runtime_refused: usize,
    /// Built and rendered (every view).
    rendered: usize,
    /// Of those, also probed.
    probed: usize,
    /// Views rendered in all.
    views: usize,
    /// The slowest case and its seed.
    slowest: (Duration, u64),
}

impl std::fmt::Debug for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} cases: {} refused, {} refused by the runtime, {} rendered ({} views), {} probed; slowest {:.2?} (seed {})",
            self.cases,
            self.refused,
            self.runtime_refused,
            self.rendered,
            self.views,
            self.probed,
            self.slowest.0,
            self.slowest.1
        )
    }
}

/// How a case kept the promise.
enum Outcome {
    /// The first error's code and message.
    Refused(String),
    RuntimeRefused(String),
    Rendered {
        views: usize,
        probed: bool,
    },
}

// ---------------------------------------------------------------------------------------------
// Choices.

/// The case's decisions: `progen`'s seeded PRNG, its seed mixed first (splitmix64) so that
/// neighbouring seeds start far apart.
struct Rng(Choices<'static>);

impl Rng {
    fn new(seed: u64) -> Rng {
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        Rng(Choices::Seeded(z ^ (z >> 31)))
    }

    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }

    fn chance(&mut self, percent: usize) -> bool {
        self.below(100) < percent
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }

    /// A good value most of the time, else a bad one.
    fn value(&mut self, good: &[&str], bad: &[&str]) -> String {
        if bad.is_empty() || (!good.is_empty() && self.chance(85)) {
            self.pick(good).to_string()
        } else {
            self.pick(bad).to_string()
        }
    }

    fn seed(&mut self) -> u64 {
        ((self.below(1 << 30) as u64) << 30) | self.below(1 << 30) as u64
    }
}

// ---------------------------------------------------------------------------------------------
// Module files to draw from.

/// The folders of example and fixture modules, and the standard module names.
struct Library {
    /// (label, folder, its `.vrs` files).
    dirs: Vec<(String, PathBuf, Vec<String>)>,
    /// (`std::NAME`, whether it is a template).
    std: Vec<(String, bool)>,
}

impl Library {
    fn find() -> Library {
        let root = common::root();
        let mut dirs = Vec::new();
        for (prefix, parent) in [("examples", root.join("examples")), ("fixtures", root.join("tests/fixtures/compose"))]
        {
            for dir in sorted_entries(&parent).into_iter().filter(|p| p.is_dir()) {
                let files: Vec<String> = sorted_entries(&dir)
                    .iter()
                    .filter(|p| p.extension().is_some_and(|e| e == "vrs"))
                    .filter_map(|p| p.file_name()?.to_str().map(String::from))
                    .collect();
                if !files.is_empty() {
                    let label = format!("{prefix}_{}", dir.file_name().and_then(|n| n.to_str()).unwrap_or("dir"));
                    dirs.push((label, dir, files));
                }
            }
        }
        // The standard modules compiled into `vrsc` (the same list the build resolves against).
        let std: Vec<(String, bool)> =
            vrsc::stdlib::modules().map(|(n, text)| (format!("std::{n}"), text.contains('$'))).collect();
        assert!(!dirs.is_empty() && !std.is_empty(), "no module files found under {}", root.display());
        Library { dirs, std }
    }
}

fn sorted_entries(dir: &Path) -> Vec<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    entries
}

// ---------------------------------------------------------------------------------------------
// The scene model: tables of `key = value text`, as TOML writes them.

/// One table: `[name]` or `[[name]]`, its keys in order, values as TOML text.
#[derive(Clone, Debug)]
struct Section {
    array: bool,
    name: String,
    keys: Vec<(String, String)>,
}

impl Section {
    fn new(array: bool, name: &str) -> Section {
        Section { array, name: name.to_string(), keys: Vec::new() }
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.keys.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn set(&mut self, key: &str, value: String) {
        match self.keys.iter_mut().find(|(k, _)| k == key) {
            Some((_, v)) => *v = value,
            None => self.keys.push((key.to_string(), value)),
        }
    }

    fn remove(&mut self, key: &str) {
        self.keys.retain(|(k, _)| k != key);
    }
}

/// A file of the case besides the scene.
#[derive(Clone, Debug)]
enum FileContent {
    Bytes(Vec<u8>),
    /// A float NRRD volume (LPS space, diagonal spacing).
    Nrrd {
        dims: [u32; 3],
        spacing: f32,
        values: Vec<f32>,
    },
    /// The `.vrs` files of a folder, copied into a folder of this name (imports keep working).
    CopyDir(PathBuf),
}

#[derive(Default)]
struct Model {
    /// Keys before the first table.
    top: Vec<(String, String)>,
    sections: Vec<Section>,
    files: Vec<(String, FileContent)>,
    /// A counter for fresh names.
    fresh: usize,
}

impl Model {
    /// Reads the scene text `cells.rs` writes: `[table]`, `[[table]]` and `key = value` lines.
    fn parse(text: &str) -> Model {
        let mut model = Model::default();
        for line in text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')) {
            if let Some(name) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
                model.sections.push(Section::new(true, name));
            } else if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                model.sections.push(Section::new(false, name));
            } else if let Some((key, value)) = line.split_once('=') {
                let entry = (key.trim().to_string(), value.trim().to_string());
                match model.sections.last_mut() {
                    Some(section) => section.keys.push(entry),
                    None => model.top.push(entry),
                }
            } else {
                panic!("a cell's scene has a line this test cannot read: {line}");
            }
        }
        model
    }

    fn to_toml(&self) -> String {
        let mut text = String::new();
        for (k, v) in &self.top {
            let _ = writeln!(text, "{k} = {v}");
        }
        for s in &self.sections {
            let (open, close) = if s.array { ("[[", "]]") } else { ("[", "]") };
            let _ = writeln!(text, "\n{open}{}{close}", s.name);
            for (k, v) in &s.keys {
                let _ = writeln!(text, "{k} = {v}");
            }
        }
        text
    }

    fn fresh(&mut self, prefix: &str) -> String {
        self.fresh += 1;
        format!("{prefix}{}", self.fresh)
    }

    /// The indices of the sections named `name`.
    fn indices(&self, name: &str) -> Vec<usize> {
        (0..self.sections.len()).filter(|&i| self.sections[i].name == name).collect()
    }

    /// One section named `name` at random, if any.
    fn pick(&self, rng: &mut Rng, name: &str) -> Option<usize> {
        let all = self.indices(name);
        (!all.is_empty()).then(|| *rng.pick(&all))
    }

    /// The plain table `name`, made when there is none.
    fn table(&mut self, name: &str) -> &mut Section {
        let i = match self.sections.iter().position(|s| s.name == name && !s.array) {
            Some(i) => i,
            None => {
                self.sections.push(Section::new(false, name));
                self.sections.len() - 1
            }
        };
        &mut self.sections[i]
    }

    /// The names the scene's volumes have now (for instances and duplicates).
    fn volume_names(&self) -> Vec<String> {
        self.indices("volume").iter().filter_map(|&i| self.sections[i].get("name").map(unquote)).collect()
    }

    fn has_file(&self, name: &str) -> bool {
        self.files.iter().any(|(n, _)| n == name)
    }
}

fn unquote(v: &str) -> String {
    v.trim_matches('"').to_string()
}

fn quoted(names: &[String]) -> String {
    let items: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    format!("[{}]", items.join(", "))
}

/// Splits `text` at the commas outside brackets, braces and strings.
fn split_top(text: &str) -> Vec<String> {
    let (mut parts, mut current, mut depth, mut in_string) = (Vec::new(), String::new(), 0i32, false);
    for c in text.chars() {
        match c {
            '"' => in_string = !in_string,
            '[' | '{' if !in_string => depth += 1,
            ']' | '}' if !in_string => depth -= 1,
            ',' if !in_string && depth == 0 => {
                parts.push(std::mem::take(&mut current));
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    parts.push(current);
    parts.into_iter().map(|p| p.trim().to_string()).filter(|p| !p.is_empty()).collect()
}

/// The keys of an inline table `{ a = 1, b = [2, 3] }` (none when `text` is not one).
fn parse_inline(text: &str) -> Section {
    let mut table = Section::new(false, "inline");
    if let Some(inner) = text.trim().strip_prefix('{').and_then(|t| t.strip_suffix('}')) {
        for part in split_top(inner) {
            if let Some((k, v)) = part.split_once('=') {
                table.keys.push((k.trim().to_string(), v.trim().to_string()));
            }
        }
    }
    table
}

fn inline(table: &Section) -> String {
    if table.keys.is_empty() {
        return "{}".into();
    }
    let keys: Vec<String> = table.keys.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    format!("{{ {} }}", keys.join(", "))
}

/// The items of an array `[a, b]` (none when `text` is not one).
fn parse_array(text: &str) -> Vec<String> {
    text.trim().strip_prefix('[').and_then(|t| t.strip_suffix(']')).map(split_top).unwrap_or_default()
}

// ---------------------------------------------------------------------------------------------
// Vocabularies: good and bad values of each key, as TOML text.

const RENDER_KEYS: &[&str] = &[
    "compositing",
    "shading",
    "lights",
    "step_size",
    "jitter",
    "iso_value",
    "empty_space_skipping",
    "tone",
    "boundary",
    "max_samples",
    "background",
];

fn render_value(rng: &mut Rng, key: &str) -> String {
    match key {
        "compositing" => rng.value(
            &["\"dvr\"", "\"mip\"", "\"minip\"", "\"average\"", "\"iso\""],
            &["\"DVR\"", "\"xray\"", "\"\"", "1", "[\"dvr\"]", "\"dvr \""],
        ),
        "shading" | "tone" | "boundary" | "empty_space_skipping" => {
            rng.value(&["true", "false"], &["\"yes\"", "1", "[true]"])
        }
        "lights" => {
            let many = |n: usize| quoted(&(0..n).map(|i| format!("l{i}")).collect::<Vec<_>>());
            match rng.below(10) {
                0 => many(20),
                1 => many(16),
                2 => many(17),
                _ => rng.value(
                    &["[]", "[\"key\"]", "[\"key\", \"fill\"]", "[\"key\", \"fill\", \"back\"]", "[\"rim\"]"],
                    &["[\"key\", \"key\"]", "[\"bad name\"]", "\"key\"", "[1]", "[\"\"]", "[\"$\"]", "[\"1st\"]"],
                ),
            }
        }
        "step_size" => rng.value(
            &["0.5", "0.25", "1.0", "2", "1e-3"],
            &["0", "-1", "1e-9", "1e9", "nan", "inf", "-0.0", "\"small\""],
        ),
        "jitter" => rng.value(&["0.0", "1.0", "0.5"], &["-1.0", "2.0", "nan", "inf", "true"]),
        "iso_value" => rng.value(&["0.45", "0.0", "1.0", "0.2"], &["-5.0", "1e30", "nan", "inf", "\"high\""]),
        "max_samples" => {
            rng.value(&["1", "64", "256", "4096"], &["0", "65536", "65537", "1000000000000", "-1", "1.5", "4294967296"])
        }
        "background" => rng.value(
            &["[0.0, 0.0, 0.0, 1.0]", "[1, 1, 1, 1]", "[0.1, 0.2, 0.3, 0.0]"],
            &[
                "[0.0, 0.0, 0.0]",
                "[nan, 0.0, 0.0, 1.0]",
                "[2.0, -1.0, 0.0, 1.0]",
                "\"black\"",
                "[0, 0, 0, 0, 0]",
                "[inf, 0, 0, 1]",
            ],
        ),
        _ => rng.value(&["true"], &["1"]),
    }
}

const VOLUME_KEYS: &[&str] = &["name", "role", "phantom", "path", "fallback", "tf", "tf", "window", "level", "width"];

fn volume_value(rng: &mut Rng, key: &str, model: &Model) -> String {
    match key {
        "name" => {
            let names = model.volume_names();
            if !names.is_empty() && rng.chance(25) {
                format!("\"{}\"", rng.pick(&names))
            } else {
                rng.value(
                    &["\"gm\"", "\"wm\"", "\"a\"", "\"t1\"", "\"extra9\"", "\"mask9\""],
                    &[
                        "\"1bad\"",
                        "\"\"",
                        "\"with space\"",
                        "\"x$\"",
                        "\"volume\"",
                        "\"tf\"",
                        "\"occupancy\"",
                        "\"brick_max\"",
                        "\"key\"",
                        "\"primary\"",
                        "\"fn\"",
                        "3",
                    ],
                )
            }
        }
        "role" => rng.value(
            &["\"primary\"", "\"additional\"", "\"mask\"", "\"tag\"", "\"additional\""],
            &["\"secondary\"", "\"Primary\"", "1", "\"\""],
        ),
        "phantom" => rng.value(&["\"head\"", "\"abdomen\""], &["\"lungs\"", "\"\"", "\"bad name\"", "1"]),
        "path" => rng.value(&["\"missing.nii\""], &["\"\"", "\"scene.toml\"", "\"mods\"", "\"missing.nrrd\"", "2"]),
        "fallback" => rng.value(&["\"head\"", "\"abdomen\""], &["\"nope\"", "\"\"", "\"not an id\""]),
        "tf" => rng.value(
            &["\"ct_bone\"", "\"ct_soft_tissue\"", "\"hot_metal\"", "\"labels\"", "\"grayscale\"", "\"ct_mip\""],
            &["\"unknown_tf\"", "\"\"", "\"tf.json\"", "\"scene.toml\"", "1"],
        ),
        "window" => rng.value(
            &["[0.0, 100.0]", "[-1000.0, 3000.0]", "[0, 1]"],
            &["[100.0, 0.0]", "[0.0, 0.0]", "[nan, 1.0]", "[1.0]", "[-inf, inf]", "\"auto\""],
        ),
        "level" => rng.value(&["40.0", "0.5"], &["nan", "\"mid\"", "1e38"]),
        "width" => rng.value(&["400.0", "1.0"], &["0.0", "-1.0", "inf"]),
        _ => rng.value(&["\"red\""], &["1"]),
    }
}

const VIEW_KEYS: &[&str] = &["name", "kind", "axis", "slab", "size", "position", "convention", "camera", "camera"];

fn view_value(rng: &mut Rng, key: &str, model: &Model) -> String {
    match key {
        "name" => {
            let names: Vec<String> =
                model.indices("view").iter().filter_map(|&i| model.sections[i].get("name").map(unquote)).collect();
            if !names.is_empty() && rng.chance(30) {
                format!("\"{}\"", rng.pick(&names))
            } else {
                rng.value(&["\"w\"", "\"3d\"", "\"axial\""], &["\"\"", "\"a b\"", "\"\\u00e9\"", "1", "\"x/y\""])
            }
        }
        "kind" => rng.value(&["\"raycast\"", "\"slice\""], &["\"volume\"", "3", "\"Slice\""]),
        "axis" => {
            rng.value(&["\"x\"", "\"y\"", "\"z\"", "\"axial\"", "\"coronal\"", "\"sagittal\""], &["\"w\"", "\"\"", "0"])
        }
        "slab" => rng.value(&["6.0", "0.0", "1.0"], &["-1.0", "1e30", "nan", "inf", "\"thick\""]),
        "size" => rng.value(
            &["[8, 8]", "[1, 1]", "[3, 5]", "[16, 4]", "[7, 1]"],
            &["[0, 0]", "[8193, 2]", "[8192, 1]", "[8]", "[-1, 8]", "[4294967296, 1]", "[2.5, 2]", "\"big\""],
        ),
        "position" => rng.value(&["0.5", "0.0", "1.0", "0.1"], &["-1.0", "2.0", "nan", "inf", "true"]),
        "convention" => rng.value(&["\"radiological\"", "\"neurological\""], &["\"left\"", "1"]),
        "camera" => rng.value(
            &[
                "{ azimuth = 30.0 }",
                "{ azimuth = 30.0, elevation = 20.0, distance = 2.3 }",
                "{ elevation = 90.0 }",
                "{ elevation = -90.0, fov = 120.0 }",
                "{}",
            ],
            &[
                "{ distance = 0.0 }",
                "{ fov = 180.0 }",
                "{ fov = 0.0 }",
                "{ distance = -2.0, fov = 1e-6 }",
                "{ zoom = 2.0 }",
                "{ azimuth = nan }",
                "{ distance = inf }",
                "[30.0, 20.0]",
            ],
        ),
        _ => rng.value(&["2.0"], &["true"]),
    }
}

/// Uniforms a scene may set, each with a value of its type: the standard pipeline's, those of
/// the example and fixture modules, `progen`'s names, resources and what the renderer sets.
const UNIFORMS: &[(&str, &str)] = &[
    ("ambient", "0.3"),
    ("diffuse", "0.7"),
    ("specular", "0.2"),
    ("shininess", "16.0"),
    ("step_size", "0.5"),
    ("max_samples", "128"),
    ("jitter", "0.5"),
    ("background", "[0.0, 0.0, 0.0, 1.0]"),
    ("iso_value", "0.4"),
    ("ref_step", "1.0"),
    ("ert_threshold", "0.95"),
    ("light_color_key", "[1.0, 0.9, 0.8]"),
    ("light_dir_key", "[0.0, 0.0, 1.0]"),
    ("mask_threshold_mask0", "0.5"),
    ("clip_plane_gm", "[0.0, 1.0, 0.0, -0.4]"),
    ("clip_plane_wm", "[1.0, 0.0, 0.0, -0.5]"),
    ("zone_centre_a", "[0.76, 0.56, 0.65]"),
    ("zone_enabled_a", "true"),
    ("tint", "[1.0, 0.5, 0.5]"),
    ("tone_strength", "0.5"),
    ("u1", "1"),
    ("u2", "0.5"),
    ("u3", "true"),
    ("u4", "[1, 2]"),
    ("volume", "1"),
    ("tf", "0.5"),
    ("occupancy", "0.5"),
    ("inv_view_proj", "[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]"),
    ("gradient_to_world", "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]"),
    ("slab", "2.0"),
    ("primary_to_extra1", "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"),
    ("nope", "1.0"),
];

/// Values of every type and of none, for a uniform of another type.
const UNIFORM_VALUES: &[&str] = &[
    "0.5",
    "1",
    "-1",
    "0",
    "true",
    "[1.0, 2.0, 3.0]",
    "[0.0, 1.0, 0.0, -0.4]",
    "[0.5, 0.5]",
    "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]",
    "1e39",
    "4294967296",
    "-2147483649",
    "nan",
    "inf",
    "-inf",
    "\"text\"",
    "[]",
    "[true, false]",
    "[1, 2.5, true]",
    "[[1.0, 0.0], [0.0]]",
    "{ x = 1 }",
];

// ---------------------------------------------------------------------------------------------
// Mutations.

/// The kinds of mutation, with their weights.
const MUTATIONS: &[(&str, usize)] = &[
    ("render key", 4),
    ("view render key", 2),
    ("add volume", 2),
    ("add volumes", 1),
    ("remove volume", 1),
    ("edit volume", 2),
    ("edit view", 3),
    ("add view", 2),
    ("remove view", 1),
    ("add module", 4),
    ("uniform", 2),
    ("add mesh", 2),
    ("unknown key", 1),
    ("corrupt text", 1),
];

/// A change to the scene's text after it is written.
#[derive(Clone, Copy, Debug)]
enum Corruption {
    Truncate,
    Insert(u8),
    Delete,
    RepeatLine,
}

const INSERTED: &[u8] = b"\"[]{}=\n#x0\\,.$ \t\xff\xc3";

impl Corruption {
    fn apply(self, rng: &mut Rng, text: &mut Vec<u8>) -> String {
        let at = rng.below(text.len() + 1);
        match self {
            Corruption::Truncate => {
                text.truncate(at);
                format!("text truncated at byte {at}")
            }
            Corruption::Insert(b) => {
                text.insert(at, b);
                format!("byte {b:#04x} inserted at {at}")
            }
            Corruption::Delete => {
                let at = at.min(text.len().saturating_sub(1));
                if !text.is_empty() {
                    text.remove(at);
                }
                format!("byte {at} deleted")
            }
            Corruption::RepeatLine => {
                let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').collect();
                let n = rng.below(lines.len());
                let mut out = Vec::new();
                for (i, line) in lines.iter().enumerate() {
                    out.extend_from_slice(line);
                    out.push(b'\n');
                    if i == n {
                        out.extend_from_slice(line);
                        out.push(b'\n');
                    }
                }
                *text = out;
                format!("line {} repeated", n + 1)
            }
        }
    }
}

impl Model {
    /// Applies one random mutation; a description of it, and the corruption it asks for.
    fn mutate(&mut self, rng: &mut Rng, library: &Library) -> (String, Option<Corruption>) {
        let total: usize = MUTATIONS.iter().map(|(_, w)| w).sum();
        let mut roll = rng.below(total);
        let kind = MUTATIONS
            .iter()
            .find(|(_, w)| {
                let hit = roll < *w;
                roll = roll.saturating_sub(*w);
                hit
            })
            .map_or(MUTATIONS[0].0, |(k, _)| k);
        let what = match kind {
            "render key" => {
                let key = *rng.pick(RENDER_KEYS);
                let table = self.table("render");
                if rng.chance(12) {
                    table.remove(key);
                    format!("[render] {key} removed")
                } else {
                    let value = render_value(rng, key);
                    let what = format!("[render] {key} = {value}");
                    table.set(key, value);
                    what
                }
            }
            "view render key" => match self.pick(rng, "view") {
                None => "no view for a render key".into(),
                Some(i) => {
                    let mut table = parse_inline(self.sections[i].get("render").unwrap_or("{}"));
                    let key = *rng.pick(RENDER_KEYS);
                    let value = render_value(rng, key);
                    let what = format!("view render {key} = {value}");
                    table.set(key, value);
                    self.sections[i].set("render", inline(&table));
                    what
                }
            },
            "add volume" => self.add_volume(rng),
            "add volumes" => {
                // Up to and past the limit of seven (two of a shader's 16 textures each, with the
                // two of empty-space skipping).
                let n = 3 + rng.below(5);
                for _ in 0..n {
                    let mut v = Section::new(true, "volume");
                    v.keys.push(("name".into(), format!("\"{}\"", self.fresh("v"))));
                    let role = *rng.pick(&["additional", "additional", "mask", "tag"]);
                    v.keys.push(("role".into(), format!("\"{role}\"")));
                    v.keys.push(("phantom".into(), rng.pick(&["\"head\"", "\"abdomen\""]).to_string()));
                    if role != "mask" {
                        let tf = if role == "tag" { "\"labels\"" } else { "\"hot_metal\"" };
                        v.keys.push(("tf".into(), tf.into()));
                    }
                    self.sections.push(v);
                }
                format!("{n} volumes added")
            }
            "remove volume" => match self.pick(rng, "volume") {
                None => "no volume to remove".into(),
                Some(i) => {
                    let name = self.sections[i].get("name").unwrap_or("?").to_string();
                    self.sections.remove(i);
                    format!("volume {name} removed")
                }
            },
            "edit volume" => match self.pick(rng, "volume") {
                None => "no volume to edit".into(),
                Some(i) => {
                    let key = *rng.pick(VOLUME_KEYS);
                    if rng.chance(15) {
                        self.sections[i].remove(key);
                        format!("volume key {key} removed")
                    } else {
                        let value = volume_value(rng, key, self);
                        let what = format!("volume {key} = {value}");
                        self.sections[i].set(key, value);
                        what
                    }
                }
            },
            "edit view" => match self.pick(rng, "view") {
                None => "no view to edit".into(),
                Some(i) => {
                    let key = *rng.pick(VIEW_KEYS);
                    if rng.chance(15) {
                        self.sections[i].remove(key);
                        format!("view key {key} removed")
                    } else {
                        let value = view_value(rng, key, self);
                        let what = format!("view {key} = {value}");
                        self.sections[i].set(key, value);
                        what
                    }
                }
            },
            "add view" => self.add_view(rng),
            "remove view" => {
                match self.pick(rng, "view").filter(|_| self.indices("view").len() > 1 || rng.chance(10)) {
                    None => "no view removed".into(),
                    Some(i) => {
                        self.sections.remove(i);
                        "a view removed".into()
                    }
                }
            }
            "add module" => self.add_module(rng, library),
            "add mesh" => self.add_mesh(rng),
            "uniform" => {
                let (name, good) = *rng.pick(UNIFORMS);
                let value = if rng.chance(60) { good.to_string() } else { rng.pick(UNIFORM_VALUES).to_string() };
                let what = format!("[uniforms] {name} = {value}");
                self.table("uniforms").set(name, value);
                what
            }
            "unknown key" => match rng.below(4) {
                0 => {
                    self.top.push(("colour".into(), "1".into()));
                    "top-level key colour".into()
                }
                1 => {
                    let mut s = Section::new(false, "camera");
                    s.keys.push(("azimuth".into(), "1.0".into()));
                    self.sections.push(s);
                    "[camera] table".into()
                }
                2 => {
                    self.sections.push(Section::new(true, "render"));
                    "[[render]] array table".into()
                }
                _ => {
                    let i = rng.below(self.sections.len().max(1));
                    match self.sections.get_mut(i) {
                        Some(s) => {
                            s.keys.push(("bogus".into(), "1".into()));
                            format!("bogus key in [{}]", s.name)
                        }
                        None => "no table for a bogus key".into(),
                    }
                }
            },
            _ => {
                let corruption = match rng.below(4) {
                    0 => Corruption::Truncate,
                    1 => Corruption::Insert(*rng.pick(INSERTED)),
                    2 => Corruption::Delete,
                    _ => Corruption::RepeatLine,
                };
                return ("text corrupted".into(), Some(corruption));
            }
        };
        (what, None)
    }

    /// A `[[mesh]]`: a built-in shape with good and bad parameters, or a file of good or bad
    /// bytes (a binary STL, one that claims more than it holds, a NaN vertex, junk); sometimes
    /// named in a view's `meshes`, or one view given `meshes = []`.
    fn add_mesh(&mut self, rng: &mut Rng) -> String {
        let mut m = Section::new(true, "mesh");
        let name = self.fresh("m");
        m.keys.push(("name".into(), format!("\"{name}\"")));
        let point = |rng: &mut Rng| {
            rng.value(
                &["[0.0, 0.0, 0.0]", "[3.0, -2.0, 5.0]", "[50.0, 0.0, 0.0]", "\"clip_plane_gm\""],
                &["[0.0, 0.0]", "[nan, 0.0, 0.0]", "\"no_such_uniform\"", "\"step_size\"", "1.0"],
            )
        };
        let what = match rng.below(6) {
            0 => {
                m.keys.push(("shape".into(), "\"needle\"".into()));
                m.keys.push(("tip".into(), point(rng)));
                m.keys.push((
                    "direction".into(),
                    rng.value(&["[0.0, 0.0, 1.0]", "[1.0, 1.0, 0.0]"], &["[0.0, 0.0, 0.0]"]),
                ));
                m.keys.push(("radius".into(), rng.value(&["1.0", "0.2", "10.0"], &["0.0", "-1.0", "nan", "1e30"])));
                "needle"
            }
            1 => {
                m.keys.push(("shape".into(), rng.value(&["\"sphere\""], &["\"cube\"", "\"\"", "3"])));
                m.keys.push(("centre".into(), point(rng)));
                m.keys.push(("radius".into(), rng.value(&["5.0", "100.0"], &["0.0", "inf"])));
                m.keys.push(("opacity".into(), rng.value(&["1.0", "0.3", "0.0"], &["-0.5", "2.0", "nan"])));
                "sphere"
            }
            2 => {
                m.keys.push(("shape".into(), "\"box\"".into()));
                m.keys.push(("min".into(), point(rng)));
                m.keys
                    .push(("max".into(), rng.value(&["[10.0, 10.0, 10.0]"], &["[0.0, 0.0, 0.0]", "[1e30, 0.0, 1.0]"])));
                m.keys.push(("color".into(), rng.value(&["[1.0, 0.0, 0.0]"], &["[2.0, 0.0, 0.0]", "[1.0]"])));
                "box"
            }
            3 => {
                m.keys.push(("shape".into(), "\"cylinder\"".into()));
                m.keys.push(("base".into(), point(rng)));
                m.keys.push(("tip".into(), point(rng)));
                m.keys.push((
                    "transform".into(),
                    rng.value(
                        &[
                            "[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [5.0, 0.0, 0.0, 1.0]]",
                            "[[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]",
                        ],
                        &[
                            "[[1.0]]",
                            "[[nan, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]",
                        ],
                    ),
                ));
                "cylinder"
            }
            _ => {
                let file = format!("{name}.stl");
                let triangle = |z: f32| -> Vec<u8> {
                    let mut t = vec![0u8; 12];
                    for v in [[0.0f32, 0.0, z], [10.0, 0.0, z], [0.0, 10.0, z]] {
                        t.extend(v.iter().flat_map(|c| c.to_le_bytes()));
                    }
                    t.extend([0u8; 2]);
                    t
                };
                let (count, body): (u32, Vec<u8>) = match rng.below(5) {
                    0 | 1 => (2, [triangle(0.0), triangle(5.0)].concat()),
                    2 => (1_000_000, triangle(0.0)),
                    3 => (1, triangle(f32::NAN)),
                    _ => (0, Vec::new()),
                };
                let mut bytes = vec![0u8; 80];
                bytes.extend(count.to_le_bytes());
                bytes.extend(body);
                if rng.chance(15) {
                    bytes = b"solid junk\nnot an stl".to_vec();
                }
                m.keys.push(("path".into(), format!("\"{file}\"")));
                self.files.push((file, FileContent::Bytes(bytes)));
                "file"
            }
        };
        self.sections.push(m);
        if rng.chance(20)
            && let Some(i) = self.pick(rng, "view")
        {
            let list = if rng.chance(50) { format!("[\"{name}\"]") } else { "[]".to_string() };
            self.sections[i].set("meshes", list);
        }
        format!("mesh {name} ({what})")
    }

    fn add_volume(&mut self, rng: &mut Rng) -> String {
        let mut v = Section::new(true, "volume");
        let name = if rng.chance(80) { format!("\"{}\"", self.fresh("v")) } else { volume_value(rng, "name", self) };
        v.keys.push(("name".into(), name));
        let role = volume_value(rng, "role", self);
        v.keys.push(("role".into(), role.clone()));
        let what = match rng.below(10) {
            0..=5 => {
                let phantom = volume_value(rng, "phantom", self);
                v.keys.push(("phantom".into(), phantom.clone()));
                format!("phantom {phantom}")
            }
            6 | 7 => {
                let file = format!("{}.nrrd", self.fresh("vol"));
                let dims = *rng.pick(&[[4, 4, 4], [1, 1, 1], [2, 3, 5], [16, 1, 1], [5, 5, 2]]);
                let spacing = *rng.pick(&[1.0f32, 1.0, 0.5, 2.0, 0.0, -1.0, 1e-6]);
                let n = dims.iter().product::<u32>() as usize;
                let values: Vec<f32> = match rng.below(5) {
                    0 => vec![7.0; n],
                    1 => (0..n).map(|i| if i % 3 == 0 { f32::NAN } else { i as f32 }).collect(),
                    2 => (0..n).map(|i| i as f32 * 1e30).collect(),
                    _ => (0..n).map(|i| (i * 37 % 101) as f32).collect(),
                };
                let desc = format!("{file} {dims:?} spacing {spacing}");
                self.files.push((file.clone(), FileContent::Nrrd { dims, spacing, values }));
                v.keys.push(("path".into(), format!("\"{file}\"")));
                desc
            }
            8 => {
                let file = format!("{}.nii", self.fresh("junk"));
                self.files.push((file.clone(), FileContent::Bytes(b"not a volume at all".to_vec())));
                v.keys.push(("path".into(), format!("\"{file}\"")));
                format!("{file} (junk)")
            }
            _ => {
                v.keys.push(("path".into(), "\"absent.nii\"".into()));
                let fallback = volume_value(rng, "fallback", self);
                v.keys.push(("fallback".into(), fallback.clone()));
                format!("absent file, fallback {fallback}")
            }
        };
        if role != "\"mask\"" || rng.chance(20) {
            let tf = volume_value(rng, "tf", self);
            v.keys.push(("tf".into(), tf));
        }
        if rng.chance(20) {
            let window = volume_value(rng, "window", self);
            v.keys.push(("window".into(), window));
        }
        let desc = format!("volume added: {} role {role}, {what}", v.get("name").unwrap_or("?"));
        // Usually after the others, sometimes first (the primary need not come first).
        let at = if rng.chance(20) {
            self.sections.iter().position(|s| s.name == "volume").unwrap_or(self.sections.len())
        } else {
            self.sections.len()
        };
        self.sections.insert(at, v);
        desc
    }

    fn add_view(&mut self, rng: &mut Rng) -> String {
        let mut v = Section::new(true, "view");
        let name = if rng.chance(85) { format!("\"{}\"", self.fresh("view")) } else { view_value(rng, "name", self) };
        v.keys.push(("name".into(), name.clone()));
        let slice = rng.chance(40);
        v.keys.push(("kind".into(), if slice { "\"slice\"" } else { "\"raycast\"" }.into()));
        if slice && rng.chance(70) {
            let axis = view_value(rng, "axis", self);
            v.keys.push(("axis".into(), axis));
        }
        v.keys.push(("size".into(), if rng.chance(80) { "[8, 8]".into() } else { view_value(rng, "size", self) }));
        if rng.chance(50) {
            let mut table = Section::new(false, "inline");
            for _ in 0..1 + rng.below(3) {
                let key = *rng.pick(RENDER_KEYS);
                let value = render_value(rng, key);
                table.set(key, value);
            }
            v.keys.push(("render".into(), inline(&table)));
        }
        let desc = format!("view added: {name} {}", inline(&v));
        self.sections.push(v);
        desc
    }

    fn add_module(&mut self, rng: &mut Rng, library: &Library) -> String {
        let volumes = self.volume_names();
        let (path, template) = match rng.below(10) {
            0..=3 => {
                let (label, dir, files) = rng.pick(&library.dirs);
                let file = rng.pick(files);
                let folder = format!("mods/{label}");
                if !self.has_file(&folder) {
                    self.files.push((folder.clone(), FileContent::CopyDir(dir.clone())));
                }
                let template = std::fs::read_to_string(dir.join(file)).is_ok_and(|t| t.contains('$'));
                (format!("{folder}/{file}"), template)
            }
            4 | 5 => {
                let file = format!("{}.vrs", self.fresh("gen"));
                let text = generate(&mut Choices::Seeded(rng.seed()));
                self.files.push((file.clone(), FileContent::Bytes(text.into_bytes())));
                (file, false)
            }
            6 | 7 => {
                let (name, template) = rng.pick(&library.std).clone();
                (name, template)
            }
            8 => {
                let file = format!("{}.vrs", self.fresh("broken"));
                let bytes: Vec<u8> = match rng.below(3) {
                    0 => b"pipeline broken in start {\n    state.out_color = ;\n".to_vec(),
                    1 => vec![b'p', 0xff, 0xfe, b'\n'],
                    _ => b"import \"broken_self.vrs\";\n".to_vec(),
                };
                self.files.push((file.clone(), FileContent::Bytes(bytes)));
                (file, false)
            }
            _ => {
                let bad = *rng.pick(&["std::nope", "missing.vrs", "", "mods", "scene.toml", "../outside.vrs", "std::"]);
                (bad.to_string(), false)
            }
        };
        // A template gets instances most of the time, a plain module rarely.
        let give_instances = if template { rng.chance(85) } else { rng.chance(15) };
        let instances = if give_instances {
            let list = match rng.below(8) {
                0 if !volumes.is_empty() => volumes.clone(),
                0 | 1 => vec!["a".into(), "b".into()],
                2 => vec!["gm".into(), "wm".into()],
                3 => vec!["key".into()],
                4 => vec!["a".into(), "a".into()],
                5 => vec!["1x".into()],
                6 => Vec::new(),
                _ => (0..65).map(|i| format!("i{i}")).collect(),
            };
            Some(quoted(&list))
        } else {
            None
        };
        let mut table = Section::new(true, "module");
        table.keys.push(("path".into(), format!("\"{path}\"")));
        if let Some(list) = &instances {
            table.keys.push(("instances".into(), list.clone()));
        }
        let desc = format!("module {path} instances {}", instances.as_deref().unwrap_or("-"));
        match self.pick(rng, "view").filter(|_| rng.chance(30)) {
            Some(i) => {
                let mut items = parse_array(self.sections[i].get("modules").unwrap_or("[]"));
                items.push(inline(&table));
                self.sections[i].set("modules", format!("[{}]", items.join(", ")));
                format!("view {desc}")
            }
            None => {
                self.sections.push(table);
                format!("[[module]] {desc}")
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A case: generated, written, built, rendered.

struct Case {
    seed: u64,
    mutations: Vec<String>,
    text: Vec<u8>,
    files: Vec<(String, FileContent)>,
    probe: bool,
    /// The folder the case was written into, kept while the case lives.
    dir: tempfile::TempDir,
}

impl Case {
    fn generate(seed: u64, cells: &[Cell], library: &Library) -> Case {
        let mut rng = Rng::new(seed);
        let cell = rng.pick(cells);
        let mut model = Model::parse(&cell.scene());
        let mut mutations = vec![format!("from cell: {}", cell.describe())];
        let mut corruptions = Vec::new();
        for _ in 0..1 + rng.below(4) {
            let (what, corruption) = model.mutate(&mut rng, library);
            mutations.push(what);
            corruptions.extend(corruption);
        }
        let mut text = model.to_toml().into_bytes();
        for c in corruptions {
            mutations.push(c.apply(&mut rng, &mut text));
        }
        let probe = rng.chance(50);
        let dir = tempfile::tempdir().expect("a temporary folder");
        Case { seed, mutations, text, files: model.files, probe, dir }
    }

    fn path(&self) -> PathBuf {
        self.dir.path().join("scene.toml")
    }

    fn write(&self) {
        let dir = self.dir.path();
        std::fs::write(self.path(), &self.text).expect("scene written");
        for (name, content) in &self.files {
            let path = dir.join(name);
            match content {
                FileContent::Bytes(bytes) => std::fs::write(&path, bytes).expect("file written"),
                FileContent::Nrrd { dims, spacing, values } => {
                    let s = *spacing;
                    let directions = [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
                    common::write_nrrd(&path, "left-posterior-superior", *dims, directions, [0.0; 3], values);
                }
                FileContent::CopyDir(src) => {
                    std::fs::create_dir_all(&path).expect("folder made");
                    for file in sorted_entries(src).iter().filter(|p| p.extension().is_some_and(|e| e == "vrs")) {
                        let name = file.file_name().expect("a file name");
                        std::fs::copy(file, path.join(name)).expect("module copied");
                    }
                }
            }
        }
    }

    /// Builds the case; renders it when it builds. `Err` when the promise is broken.
    fn run(&self, gpu: &Gpu) -> Result<Outcome, String> {
        self.write();
        let path = self.path();
        let built = build_scene(&path, None).map_err(|e| format!("build_scene failed on an existing file: {e}"))?;
        let sorted = built.diags.sorted();
        // Rendering the diagnostics must not panic either (their spans are real offsets).
        let rendered = vrsc::diag::render_plain(&sorted, &built.sources);
        if built.diags.has_errors() {
            for d in sorted.iter().filter(|d| d.is_error()) {
                let code = d.code.as_str();
                if d.code == Code::Internal {
                    return Err(format!("a compiler bug (E0901): {}\n{rendered}", d.message));
                }
                if d.message.trim().is_empty() {
                    return Err(format!("an error {code} without a message\n{rendered}"));
                }
                let exempt = matches!(d.code, Code::Io | Code::Device | Code::GpuRefused);
                if !exempt && (d.span.is_dummy() || built.sources.locate(d.span).is_none()) {
                    return Err(format!("error {code} does not point into a file: {}\n{rendered}", d.message));
                }
            }
            let first = sorted.iter().find(|d| d.is_error()).map(|d| format!("{}: {}", d.code.as_str(), d.message));
            return Ok(Outcome::Refused(first.unwrap_or_default()));
        }
        let scene = built.scene.as_ref().ok_or("a build without errors and without a scene")?;
        let small = scene.views.iter().all(|v| v.size[0] <= OWN_SIZE_LIMIT && v.size[1] <= OWN_SIZE_LIMIT);
        let options =
            RenderOptions { size: (!small).then_some([8, 8]), phantom_size: [16, 16, 16], ..RenderOptions::default() };
        let _ = gpu.take_fault();
        let opened = SceneRenderer::from_built(gpu.clone(), &path, scene, &built, options, &mut |_, _, _| {});
        let fault = |stage: &str| gpu.take_fault().map(|f| format!("a wgpu error escaped while {stage}: {f}"));
        let mut renderer = match opened {
            Ok(renderer) => renderer,
            Err(e) => {
                if let Some(f) = fault("loading") {
                    return Err(f);
                }
                return match &e {
                    RuntimeError::Volume(_)
                    | RuntimeError::Tf(_)
                    | RuntimeError::Invalid(_)
                    | RuntimeError::Io { .. }
                        if !e.to_string().trim().is_empty() =>
                    {
                        Ok(Outcome::RuntimeRefused(e.to_string()))
                    }
                    _ => Err(format!("built cleanly, but the runtime refused it: {e:?}: {e}")),
                };
            }
        };
        if let Some(f) = fault("loading") {
            return Err(f);
        }
        let images = renderer.render_all().map_err(|e| format!("built and loaded, but did not render: {e:?}: {e}"))?;
        if let Some(f) = fault("rendering") {
            return Err(f);
        }
        if images.len() != scene.views.len() {
            return Err(format!("{} views, {} images", scene.views.len(), images.len()));
        }
        let probed = self.probe && !renderer.views().is_empty();
        if probed {
            let probe = renderer
                .render_probe(0, &ProbeSpec::of("out_color"))
                .map_err(|e| format!("rendered, but its out_color probe failed: {e:?}: {e}"))?;
            if let Some(f) = fault("probing") {
                return Err(f);
            }
            let (w, h) = probe.image.dimensions();
            for (x, y) in (0..h).flat_map(|y| (0..w).map(move |x| (x, y))) {
                let value = probe.values.at(x, y).ok_or_else(|| format!("probe pixel ({x}, {y}) has no colour"))?;
                if !value.iter().all(|c| c.is_finite()) {
                    return Err(format!("probe pixel ({x}, {y}) of view `{}` is {value:?}", probe.view));
                }
            }
        }
        Ok(Outcome::Rendered { views: images.len(), probed })
    }

    /// Everything needed to see and reproduce a failure.
    fn report(&self, error: &str) -> String {
        let mut text = format!(
            "seed {seed}: {error}\nrerun: VRS_SCENE_FUZZ_SEED={seed} VRS_SCENE_FUZZ_CASES=1 cargo test --release \
             -p vrs-runtime --test suite scene_fuzz -- --nocapture\nprobe: {}\nmutations:\n",
            self.probe,
            seed = self.seed
        );
        for m in &self.mutations {
            let _ = writeln!(text, "  - {m}");
        }
        let _ = writeln!(text, "--- scene.toml ---\n{}", String::from_utf8_lossy(&self.text));
        for (name, content) in &self.files {
            match content {
                FileContent::Bytes(bytes) => {
                    let _ = writeln!(text, "--- {name} ---\n{}", String::from_utf8_lossy(bytes));
                }
                FileContent::Nrrd { dims, spacing, values } => {
                    let _ = writeln!(text, "--- {name}: NRRD {dims:?}, spacing {spacing}, values {values:?}");
                }
                FileContent::CopyDir(src) => {
                    let _ = writeln!(text, "--- {name}: the .vrs files of {}", src.display());
                }
            }
        }
        text
    }
}

fn env_u64(name: &str, default: u64) -> u64 {
    match std::env::var(name) {
        Ok(v) => v.trim().parse().unwrap_or_else(|_| panic!("{name}={v} is not a number")),
        Err(_) => default,
    }
}

fn panic_text(payload: &Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

fn first_line(text: &str) -> &str {
    text.lines().next().unwrap_or("")
}
