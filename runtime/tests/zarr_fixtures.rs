//! Stores written by zarr-python 3 and ome-zarr-py (`tests/fixtures/zarr`, made by its
//! `make_fixtures.py`) read as the same samples as their NIfTI twins: level 0 voxel for voxel,
//! the same placement in patient space, and, rendered, the same picture as the twin in one
//! texture (within 0.5/255 on average, the half-float pool's rounding).

use crate::common;

use std::path::{Path, PathBuf};

use serde_json::Value;
use vrs_runtime::bricks::BrickSource;
use vrs_runtime::bricks::zarr::{Choice, StoreLocation, ZarrSelection, ZarrSource};
use vrs_runtime::{RenderOptions, SceneRenderer};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/zarr")
}

/// Each fixture's store, selection and twin file, from `fixtures.json`.
fn cases() -> Vec<(String, ZarrSelection, String)> {
    let text = std::fs::read_to_string(fixtures().join("fixtures.json")).expect("fixtures.json");
    let json: Value = serde_json::from_str(&text).expect("valid JSON");
    let mut out = Vec::new();
    for f in json["fixtures"].as_array().expect("a list") {
        if f.get("corrupt_chunk").is_some() {
            continue;
        }
        let name = f["name"].as_str().expect("a name").to_string();
        let twins = f["nifti"].as_array().expect("twins");
        let selects = f["select"].as_array().expect("selections");
        for (i, twin) in twins.iter().enumerate() {
            let mut selection = ZarrSelection::default();
            // A selection is one {axis, index} or a list of them.
            let chosen: Vec<&Value> = match selects.get(i) {
                Some(Value::Array(list)) => list.iter().collect(),
                Some(one) => vec![one],
                None => vec![],
            };
            for s in chosen {
                let index = s["index"].as_u64().expect("an index");
                match s["axis"].as_str() {
                    Some("c") => selection.channel = Some(Choice::Index(index)),
                    Some("t") => selection.time = Some(index),
                    other => panic!("axis {other:?}"),
                }
            }
            out.push((name.clone(), selection, twin["file"].as_str().expect("a file").to_string()));
        }
    }
    out
}

fn open(name: &str, selection: &ZarrSelection) -> ZarrSource {
    let location = StoreLocation::Path(fixtures().join(name));
    ZarrSource::open_at(&location, selection, 64 << 20).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn every_fixture_reads_as_its_nifti_twin() {
    let cases = cases();
    assert!(cases.len() >= 20, "{} cases", cases.len());
    for (name, selection, twin) in cases {
        let source = open(&name, &selection);
        let volume = vrs_runtime::volume::load(&fixtures().join(&twin), &mut |_, _| {}).expect("twin");
        let level = source.levels()[0];
        assert_eq!(level.dims, volume.dims, "{name}");
        let values = volume.values();
        let mut worst = 0.0f32;
        for bz in 0..level.bricks[2] {
            for by in 0..level.bricks[1] {
                for bx in 0..level.bricks[0] {
                    let brick = source.read(0, [bx, by, bz]).unwrap_or_else(|e| panic!("{name}: {e}"));
                    for z in 0..64.min(level.dims[2] - bz * 64) {
                        for y in 0..64.min(level.dims[1] - by * 64) {
                            for x in 0..64.min(level.dims[0] - bx * 64) {
                                let p = [bx * 64 + x, by * 64 + y, bz * 64 + z];
                                let i = p[0] as usize
                                    + level.dims[0] as usize * (p[1] as usize + level.dims[1] as usize * p[2] as usize);
                                worst = worst.max((brick.voxel([x, y, z]) - values[i]).abs());
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(worst, 0.0, "{name} {selection:?}: level 0 differs from {twin} by up to {worst}");
        let (a, b) = (source.grid_to_world(), volume.grid_to_world);
        // Voxel sizes of micrometres: compare to a thousandth of a voxel.
        let scale = b.x_axis.length().max(1e-6);
        assert!(a.abs_diff_eq(b, 1e-3 * scale), "{name}: placed at {a} but {twin} at {b}");
        // Every level reads (the pyramid's coarse levels from the store's datasets or built).
        for l in 1..source.levels().len() {
            let b = source.levels()[l].bricks;
            source.read(l, [b[0] - 1, b[1] - 1, b[2] - 1]).unwrap_or_else(|e| panic!("{name} level {l}: {e}"));
        }
        assert!(source.warnings().is_empty(), "{name}: {:?}", source.warnings());
    }
}

#[test]
fn ome_zarr_py_default_pyramids_use_their_datasets() {
    // x and y halved, z kept: levels 1 and 2 average the datasets' voxels along z only.
    for name in ["ome04_default.zarr", "ome05_default.zarr"] {
        let source = open(name, &ZarrSelection::default());
        assert!(source.stored_levels() >= 1, "{name}");
        assert_eq!(source.levels()[0].dims, [40, 48, 24], "{name}");
    }
    // Halved rounding down: every dataset answers its level.
    assert_eq!(open("odd_floor_ome05.zarr", &ZarrSelection::default()).stored_levels(), 1);
}

#[test]
fn unchosen_channels_and_times_are_refused_with_the_way_to_choose() {
    let location = StoreLocation::Path(fixtures().join("channels_czyx_ome05.zarr"));
    let error = ZarrSource::open_at(&location, &ZarrSelection::default(), 1 << 20).err().expect("refused").0;
    assert!(error.contains("3 channels") && error.contains("`channel = 0`"), "{error}");
    let location = StoreLocation::Path(fixtures().join("time_tczyx_ome04.zarr"));
    let error = ZarrSource::open_at(&location, &ZarrSelection::default(), 1 << 20).err().expect("refused").0;
    assert!(error.contains("2 time points") && error.contains("`time = 0`"), "{error}");
}

#[test]
fn a_corrupt_chunk_names_itself_and_its_brick_comes_from_the_next_level() {
    for (name, chunk) in [("corrupt_ome04.zarr", "s0/1/0/1"), ("corrupt_odd_ome05.zarr", "s0/c/0/1/1")] {
        let source = open(name, &ZarrSelection::default());
        let error = source.read(0, [0, 0, 0]).err().unwrap_or_else(|| panic!("{name}: read"));
        assert!(error.0.contains(&format!("chunk `{chunk}`")), "{name}: {error}");
        // The coarser levels read.
        for l in 1..source.levels().len() {
            source.read(l, [0, 0, 0]).unwrap_or_else(|e| panic!("{name} level {l}: {e}"));
        }
    }
}

/// A scene of one volume at `path` (bricked or not), a raycast and a slice view.
fn scene(path: &str, bricks: bool, keys: &str, window: [f32; 2]) -> String {
    let [lo, hi] = window;
    format!(
        r#"
[render]
compositing = "dvr"
jitter = 0.0

[[volume]]
name = "v"
role = "primary"
path = "{path}"
bricks = {bricks}
window = [{lo:?}, {hi:?}]
{keys}

[[view]]
name = "3d"
kind = "raycast"
size = [96, 96]
camera = {{ azimuth = 30.0, elevation = 20.0, distance = 2.2 }}

[[view]]
name = "axial"
kind = "slice"
axis = "axial"
position = 0.45
size = [96, 96]
"#
    )
}

fn render(dir: &Path, name: &str, text: &str) -> Vec<(String, image::RgbaImage)> {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("scene written");
    let mut renderer = SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    renderer.render_all().unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn stores_render_like_their_twins_in_one_texture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = fixtures().canonicalize().expect("fixtures");
    for (store, keys, twin) in [
        ("ome05_default.zarr", "", "ome_default.nii"),
        ("odd_floor_ome05.zarr", "", "odd_floor_ome05.nii"),
        ("translation_um_ome04.zarr", "", "translation_um_ome04.nii"),
        ("channels_czyx_ome05.zarr", "channel = 2", "channels_czyx_ome05_c2.nii"),
        ("v3_sharded_float32.zarr", "", "v3_sharded_float32.nii"),
    ] {
        let store_path = root.join(store).display().to_string();
        let twin_path = root.join(twin).display().to_string();
        // One window for both: the twin's range.
        let range = vrs_runtime::volume::load(&root.join(twin), &mut |_, _| {}).expect("twin").range;
        let bricked = render(dir.path(), "store.toml", &scene(&store_path, true, keys, range));
        let whole = render(dir.path(), "twin.toml", &scene(&twin_path, false, "", range));
        assert_eq!(bricked.len(), whole.len());
        for ((view, a), (_, b)) in bricked.iter().zip(&whole) {
            let total: u64 =
                a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (x as i64 - y as i64).unsigned_abs()).sum();
            let mean = total as f64 / a.as_raw().len() as f64;
            let lit = b.as_raw().iter().filter(|&&v| v > 0).count();
            println!("{store} {view}: mean difference {mean:.4}/255");
            assert!(lit > 100, "{store} {view}: the twin's picture is empty");
            assert!(mean <= 0.5, "{store} {view}: mean difference {mean:.3}/255 to {twin}");
        }
    }
}

/// `channel = [0, 1, 2]` shows every channel as a volume of its own (napari's `channel_axis`),
/// each with its transfer function, the others composited as additional volumes: the same
/// picture as the three NIfTI twins as primary and additional volumes.
#[test]
fn a_channel_list_renders_like_its_channels_as_volumes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = fixtures().canonicalize().expect("fixtures");
    let store = root.join("channels_czyx_ome05.zarr").display().to_string();
    let view = "[[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [96, 96]\ncamera = { azimuth = 30.0, elevation = 20.0, distance = 2.2 }\n";
    let render_table = "[render]\ncompositing = \"dvr\"\njitter = 0.0\n";
    let tfs = ["vessel_red", "grayscale", "vessel_blue"];
    let channels = format!(
        "{render_table}\n[[volume]]\nname = \"cells\"\nrole = \"primary\"\npath = \"{store}\"\nwindow = [0.0, 255.0]\nchannel = [0, 1, 2]\ntf = [\"{}\", \"{}\", \"{}\"]\n\n{view}",
        tfs[0], tfs[1], tfs[2]
    );
    let mut twins = render_table.to_string();
    for (c, tf) in tfs.iter().enumerate() {
        let role = if c == 0 { "primary" } else { "additional" };
        let path = root.join(format!("channels_czyx_ome05_c{c}.nii")).display().to_string();
        twins += &format!(
            "\n[[volume]]\nname = \"cells_{c}\"\nrole = \"{role}\"\npath = \"{path}\"\nwindow = [0.0, 255.0]\ntf = \"{tf}\"\n"
        );
    }
    twins += &format!("\n{view}");
    let a = render(dir.path(), "channels.toml", &channels);
    let b = render(dir.path(), "twins.toml", &twins);
    let (a, b) = (&a[0].1, &b[0].1);
    let total: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (x as i64 - y as i64).unsigned_abs()).sum();
    let mean = total as f64 / a.as_raw().len() as f64;
    println!("three channels as volumes: mean difference {mean:.4}/255 to the twins");
    assert!(b.as_raw().iter().filter(|&&v| v > 0).count() > 100, "the twins' picture is empty");
    assert!(mean <= 0.5, "mean difference {mean:.3}/255");
}

/// What a slice pixel of a grey volume tinted by the labels fixture's segmentation shows: the
/// grey alone, or one label's colour over it (ids 1, 2 and 70000 opaque red, green and yellow,
/// id 3 blue at half strength). Trilinear reads of the ids blend neighbouring labels (and
/// the background) into colours of none of these.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum LabelPixel {
    Grey,
    Red,
    Green,
    Yellow,
    HalfBlue,
    Other,
}

fn label_pixel([r, g, b, _]: [u8; 4]) -> LabelPixel {
    let near = |a: u8, b: u8| a.abs_diff(b) <= 2;
    match () {
        _ if near(r, g) && near(g, b) => LabelPixel::Grey,
        _ if g <= 2 && b <= 2 => LabelPixel::Red,
        _ if r <= 2 && b <= 2 => LabelPixel::Green,
        _ if near(r, g) && b <= 2 => LabelPixel::Yellow,
        _ if near(r, g) && b > g + 2 => LabelPixel::HalfBlue,
        _ => LabelPixel::Other,
    }
}

/// An OME-Zarr label image (ome-zarr-py's `write_labels`: uint64 ids, `image-label` colours, one
/// id beyond 65535) as a tag volume, bricked or not, is shown as labels without a word in the
/// scene: every pixel is the grey of the image or exactly one label's colour from the store,
/// no label blends into its neighbour or the background, and every label shows.
#[test]
fn ome_label_images_show_each_label_in_its_own_colour() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = fixtures().canonicalize().expect("fixtures");
    let image = root.join("labels_image.nii").display().to_string();
    let labels = root.join("labels_ome05.zarr/labels/segmentation").display().to_string();
    let slice = |name: &str, position: f32| {
        format!(
            "[[view]]\nname = \"{name}\"\nkind = \"slice\"\naxis = \"axial\"\nposition = {position}\nsize = [144, 112]\n"
        )
    };
    for bricks in [false, true] {
        let text = format!(
            "[[volume]]\nname = \"image\"\nrole = \"primary\"\npath = \"{image}\"\ntf = \"grayscale\"\n\n\
             [[volume]]\nname = \"seg\"\nrole = \"tag\"\npath = \"{labels}\"\nbricks = {bricks}\n\n{}\n{}",
            slice("low", 0.25),
            slice("high", 0.75)
        );
        let path = dir.path().join("labels.toml");
        std::fs::write(&path, text).expect("scene written");
        let mut renderer =
            SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
                .unwrap_or_else(|e| panic!("bricks = {bricks}: {e}"));
        assert!(
            renderer.notices.iter().any(|n| n.contains("label ids (an OME-Zarr label image)")),
            "bricks = {bricks}: {:?}",
            renderer.notices
        );
        let views = renderer.render_all().unwrap_or_else(|e| panic!("bricks = {bricks}: {e}"));
        assert_eq!(views.len(), 2);
        let mut seen = std::collections::HashMap::new();
        for (view, picture) in &views {
            for p in picture.pixels() {
                let class = label_pixel(p.0);
                assert_ne!(class, LabelPixel::Other, "bricks = {bricks}, view {view}: pixel {:?} blends labels", p.0);
                *seen.entry(class).or_insert(0u32) += 1;
            }
        }
        println!("bricks = {bricks}: {seen:?}");
        for class in [LabelPixel::Grey, LabelPixel::Red, LabelPixel::Green, LabelPixel::Yellow, LabelPixel::HalfBlue] {
            assert!(
                seen.get(&class).copied().unwrap_or(0) > 20,
                "bricks = {bricks}: too few {class:?} pixels: {seen:?}"
            );
        }
    }
}
