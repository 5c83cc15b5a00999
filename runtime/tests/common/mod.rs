//! Shared set-up of the runtime's integration tests.
#![allow(dead_code)]

pub mod cells;
pub mod difference;

use image::RgbaImage;
use std::path::{Path, PathBuf};
use vrs_runtime::{AdapterChoice, Gpu};

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The software adapter (lavapipe), so images are the same on every machine. Never skips: a
/// machine without it fails with the command that installs it (`.ci/run` runs that command).
pub fn software_gpu() -> Gpu {
    static ENVIRONMENT: std::sync::Once = std::sync::Once::new();
    // SAFETY (both `set_var`s): the drivers read the environment (from C) only once a device
    // exists, and every test makes its device here, after this: no thread reads it concurrently.
    ENVIRONMENT.call_once(|| {
        // Most of this suite's time is lavapipe compiling shaders (the option matrices compile
        // hundreds, each rendered once at 16x16): without LLVM's optimization passes the suite
        // runs in 212 s instead of 282 s from an empty shader cache on two cores, with the same
        // images within the stated tolerances. A value the caller set is kept.
        if std::env::var_os("GALLIVM_PERF").is_none() {
            unsafe { std::env::set_var("GALLIVM_PERF", "nopt") };
        }
        if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
            let dir = std::env::temp_dir().join("vrs-xdg");
            let _ = std::fs::create_dir_all(&dir);
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
            }
            unsafe { std::env::set_var("XDG_RUNTIME_DIR", dir) };
        }
    });
    Gpu::headless(AdapterChoice::Software).unwrap_or_else(|e| {
        panic!(
            "rendering tests need the software Vulkan driver (lavapipe): {e}\n\
             install it with: apt-get install -y mesa-vulkan-drivers libvulkan1"
        )
    })
}

pub const CHANNEL_TOLERANCE: u8 = 8;
pub const MIN_MATCHING: f64 = 0.995;
pub const MAX_MEAN_DIFF: f64 = 1.0;

/// How far `actual` is from `golden`: (fraction of matching pixels, mean absolute difference,
/// difference image).
pub fn compare(actual: &RgbaImage, golden: &RgbaImage) -> (f64, f64, RgbaImage) {
    let mut matching = 0usize;
    let mut total_diff = 0u64;
    let mut diff = RgbaImage::new(actual.width(), actual.height());
    for ((a, g), d) in actual.pixels().zip(golden.pixels()).zip(diff.pixels_mut()) {
        let worst = (0..4).map(|c| a[c].abs_diff(g[c])).max().unwrap_or(0);
        total_diff += (0..4).map(|c| u64::from(a[c].abs_diff(g[c]))).sum::<u64>();
        if worst <= CHANNEL_TOLERANCE {
            matching += 1;
        }
        let shown = worst.saturating_mul(8);
        *d = image::Rgba([shown, if worst > CHANNEL_TOLERANCE { 0 } else { shown }, 0, 255]);
    }
    let pixels = (actual.width() * actual.height()).max(1) as f64;
    (matching as f64 / pixels, total_diff as f64 / (pixels * 4.0), diff)
}

/// Compares `actual` with `tests/golden/NAME.png` (see golden.rs for the tolerance).
pub fn check_golden(name: &str, actual: &RgbaImage) -> Result<(), String> {
    let golden_path = &root().join(format!("tests/golden/{name}.png"));
    if std::env::var_os("VRS_UPDATE_GOLDEN").is_some() {
        actual.save(golden_path).map_err(|e| e.to_string())?;
        return Ok(());
    }
    let golden = image::open(golden_path)
        .map_err(|e| format!("{name}: cannot read {}: {e} (VRS_UPDATE_GOLDEN=1 writes it)", golden_path.display()))?
        .to_rgba8();
    if golden.dimensions() != actual.dimensions() {
        return Err(format!("{name}: size {:?}, golden {:?}", actual.dimensions(), golden.dimensions()));
    }
    let (matching, mean, diff) = compare(actual, &golden);
    if matching >= MIN_MATCHING && mean <= MAX_MEAN_DIFF {
        return Ok(());
    }
    let out = root().join("target/golden-failures");
    let _ = std::fs::create_dir_all(&out);
    let _ = actual.save(out.join(format!("{name}.actual.png")));
    let _ = diff.save(out.join(format!("{name}.diff.png")));
    Err(format!(
        "{name}: {:.2}% of pixels within {CHANNEL_TOLERANCE}/255 (need {:.1}%), mean difference {mean:.2}/255 \
         (at most {MAX_MEAN_DIFF}); actual and difference images in {}",
        matching * 100.0,
        MIN_MATCHING * 100.0,
        out.display()
    ))
}

/// Writes `scene` into `dir` with `cube.nrrd` (32^3 voxels of 1 mm, all 1000, RAS) and
/// `clear.json` (a transfer function clear everywhere: the volume shows nothing, so a picture is
/// its meshes over the background), and opens it.
pub fn open_with_clear_cube(dir: &Path, scene: &str) -> vrs_runtime::SceneRenderer {
    let values = vec![1000.0f32; 32 * 32 * 32];
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    write_nrrd(&dir.join("cube.nrrd"), "RAS", [32; 3], identity, [0.0; 3], &values);
    let tf =
        r#"[{"Name": "clear", "RGBPoints": [0, 1, 1, 1, 1000, 1, 1, 1], "Points": [0, 0, 0.5, 0, 1000, 0, 0.5, 0]}]"#;
    std::fs::write(dir.join("clear.json"), tf).expect("tf written");
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).expect("scene written");
    vrs_runtime::SceneRenderer::open(software_gpu(), &path, vrs_runtime::RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Writes float samples as a NRRD file with `space`, `space directions` and `space origin`.
pub fn write_nrrd(
    path: &Path,
    space: &str,
    dims: [u32; 3],
    directions: [[f32; 3]; 3],
    origin: [f32; 3],
    values: &[f32],
) {
    let v = |a: [f32; 3]| format!("({},{},{})", a[0], a[1], a[2]);
    let header = format!(
        "NRRD0004\ntype: float\ndimension: 3\nspace: {space}\nsizes: {} {} {}\nspace directions: {} {} {}\n\
         space origin: {}\nendian: little\nencoding: raw\n\n",
        dims[0],
        dims[1],
        dims[2],
        v(directions[0]),
        v(directions[1]),
        v(directions[2]),
        v(origin)
    );
    let mut bytes = header.into_bytes();
    bytes.extend(values.iter().flat_map(|x| x.to_le_bytes()));
    std::fs::write(path, bytes).unwrap();
}
