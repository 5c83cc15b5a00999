//! Patient space and physical sampling on the software adapter: a volume stored with its axes
//! permuted and flipped (and its header in LPS) renders the same pictures as the same anatomy
//! stored axis-aligned in RAS, in 3D and in every slice orientation; a homogeneous slab is
//! equally opaque through the same physical thickness whatever the voxel spacing along the ray,
//! and as opaque as the opacity correction says.

mod common;

use std::path::{Path, PathBuf};
use vrs_runtime::volume::{Volume, phantom};
use vrs_runtime::{RenderOptions, SceneRenderer};

/// Writes float samples as a NRRD file with `space`, `space directions` and `space origin`.
fn write_nrrd(path: &Path, space: &str, dims: [u32; 3], directions: [[f32; 3]; 3], origin: [f32; 3], values: &[f32]) {
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

fn render(dir: &Path, text: &str) -> Vec<(String, image::RgbaImage)> {
    let scene: PathBuf = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let mut r = SceneRenderer::open(common::software_gpu(), &scene, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    r.render_all().unwrap()
}

/// Writes the abdomen phantom on an anisotropic grid (1 x 1.5 x 2.5 mm) twice into `dir`:
/// `aligned.nrrd`, axis-aligned in RAS, and `permuted.nrrd`, the same world positions holding
/// the same values with the index axes permuted and two of them reversed (i' inferior-wards, j'
/// right-wards, k' posterior-wards), its header in LPS.
fn write_abdomen_twice(dir: &Path) {
    let dims = [40u32, 36, 28];
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let spacing = [1.0f32, 1.5, 2.5];
    let source: Volume = phantom("abdomen", dims).unwrap();
    let values = source.values();
    let at = |i: usize, j: usize, k: usize| values[(k * ny + j) * nx + i];
    let origin = [-20.0f32, -26.0, -33.0];
    write_nrrd(
        &dir.join("aligned.nrrd"),
        "right-anterior-superior",
        dims,
        [[spacing[0], 0.0, 0.0], [0.0, spacing[1], 0.0], [0.0, 0.0, spacing[2]]],
        origin,
        &values,
    );
    // Stored order: i' runs inferior-wards (A's k reversed), j' right-wards (A's i), k'
    // posterior-wards (A's j reversed): A(i, j, k) = B(nz-1-k, i, ny-1-j).
    let permuted_dims = [dims[2], dims[0], dims[1]];
    let mut permuted = Vec::with_capacity(values.len());
    for kp in 0..ny {
        for jp in 0..nx {
            for ip in 0..nz {
                permuted.push(at(jp, ny - 1 - kp, nz - 1 - ip));
            }
        }
    }
    // In RAS: i' -> (0, 0, -sz), j' -> (sx, 0, 0), k' -> (0, -sy, 0), voxel 0 at A's (0, ny-1,
    // nz-1); LPS negates x and y.
    let ras_origin = [origin[0], origin[1] + (ny - 1) as f32 * spacing[1], origin[2] + (nz - 1) as f32 * spacing[2]];
    write_nrrd(
        &dir.join("permuted.nrrd"),
        "left-posterior-superior",
        permuted_dims,
        [[0.0, 0.0, -spacing[2]], [-spacing[0], 0.0, 0.0], [0.0, spacing[1], 0.0]],
        [-ras_origin[0], -ras_origin[1], ras_origin[2]],
        &permuted,
    );
}

/// Within the golden images' tolerance (99.5% of pixels within 8/255, mean under 1/255: the
/// trilinear filter interpolates the axes in another order), and not empty.
fn assert_same_picture(name: &str, a: &image::RgbaImage, b: &image::RgbaImage) {
    let visible = a.pixels().filter(|p| p[0] > 20 || p[1] > 20 || p[2] > 20).count();
    assert!(visible > (a.width() * a.height() / 10) as usize, "{name}: the body is visible ({visible} pixels)");
    let (matching, mean, _) = common::compare(b, a);
    assert!(
        matching >= common::MIN_MATCHING && mean <= common::MAX_MEAN_DIFF,
        "{name}: {:.2}% of pixels within {}/255, mean difference {mean:.3}/255",
        matching * 100.0,
        common::CHANNEL_TOLERANCE
    );
}

/// The permuted and flipped grid renders the same pictures as the axis-aligned one: an unshaded
/// DVR and a MIP view from two sides, and axial, coronal (neurological) and sagittal (slab)
/// planes.
#[test]
fn a_permuted_and_flipped_grid_renders_like_the_axis_aligned_one() {
    let dir = tempfile::tempdir().unwrap();
    write_abdomen_twice(dir.path());
    let views = "[[view]]\nname = \"dvr\"\nsize = [96, 96]\ncamera = { azimuth = 30.0, elevation = 20.0 }\n\n\
        [[view]]\nname = \"mip\"\nsize = [96, 96]\ncamera = { azimuth = -60.0, elevation = 10.0 }\nrender = { compositing = \"mip\" }\n\n\
        [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.6\nsize = [80, 64]\n\n\
        [[view]]\nname = \"coronal\"\nkind = \"slice\"\naxis = \"coronal\"\nsize = [64, 64]\nconvention = \"neurological\"\n\n\
        [[view]]\nname = \"sagittal\"\nkind = \"slice\"\naxis = \"sagittal\"\nposition = 0.3\nslab = 6.0\nsize = [64, 80]\n";
    let scene = |file: &str| {
        format!("[[volume]]\nname = \"ct\"\nrole = \"primary\"\npath = \"{file}\"\ntf = \"ct_soft_tissue\"\n\n{views}")
    };
    let aligned = render(dir.path(), &scene("aligned.nrrd"));
    let stored = render(dir.path(), &scene("permuted.nrrd"));
    assert_eq!(aligned.len(), 5);
    for ((name, a), (_, b)) in aligned.iter().zip(&stored) {
        assert_same_picture(name, a, b);
    }
}

/// Volumes line up through patient space: the permuted grid as an additional volume over the
/// aligned primary shows what the aligned file does in its place.
#[test]
fn an_additional_volume_on_another_grid_lines_up_in_patient_space() {
    let dir = tempfile::tempdir().unwrap();
    write_abdomen_twice(dir.path());
    let scene = |file: &str| {
        format!(
            "[[volume]]\nname = \"ct\"\nrole = \"primary\"\npath = \"aligned.nrrd\"\ntf = \"ct_soft_tissue\"\n\n\
             [[volume]]\nname = \"bone\"\nrole = \"additional\"\npath = \"{file}\"\ntf = \"ct_bone\"\n\n\
             [[view]]\nname = \"3d\"\nsize = [80, 80]\ncamera = {{ azimuth = 40.0, elevation = 25.0 }}\n\n\
             [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.55\nsize = [80, 64]\n"
        )
    };
    let same_grid = render(dir.path(), &scene("aligned.nrrd"));
    let other_grid = render(dir.path(), &scene("permuted.nrrd"));
    for ((name, a), (_, b)) in same_grid.iter().zip(&other_grid) {
        assert_same_picture(name, a, b);
    }
}

/// The red channel at the centre of a view's image (white transfer function, black
/// background: the accumulated opacity).
fn centre_opacity(image: &image::RgbaImage) -> f32 {
    f32::from(image.get_pixel(image.width() / 2, image.height() / 2)[0]) / 255.0
}

/// A homogeneous volume 64 mm wide (x, 1 mm voxels), 32 mm deep (y, 1 mm voxels) and 32 mm
/// tall (z, 4 mm voxels), with a constant opacity of 0.02 per reference step (1 mm, the
/// smallest spacing). Through its 32 mm depth (from the front) and its 32 mm height (from
/// above) a ray crosses 1 mm and 4 mm voxels; both must show 1 - (1 - 0.02)^32, and the 64 mm
/// width (from the side) 1 - (1 - 0.02)^64, within 3/255 (one sample more or less at the exit,
/// 8-bit tables and output). Stepping in normalized volume units would give all three the same
/// opacity.
#[test]
fn a_homogeneous_slab_is_equally_opaque_through_equal_physical_thickness() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [64u32, 32, 8];
    let values = vec![50.0f32; (dims[0] * dims[1] * dims[2]) as usize];
    let directions = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 4.0]];
    write_nrrd(&dir.path().join("slab.nrrd"), "right-anterior-superior", dims, directions, [0.0; 3], &values);
    let tf = r#"[{"Name": "flat", "RGBPoints": [0, 1, 1, 1, 100, 1, 1, 1], "Points": [0, 0.02, 0.5, 0, 100, 0.02, 0.5, 0]}]"#;
    std::fs::write(dir.path().join("flat.json"), tf).unwrap();
    let text = "[[volume]]\nname = \"slab\"\nrole = \"primary\"\npath = \"slab.nrrd\"\ntf = \"flat.json\"\n\n\
        [[view]]\nname = \"front\"\nsize = [33, 33]\ncamera = { distance = 3.0, fov = 5.0 }\n\n\
        [[view]]\nname = \"top\"\nsize = [33, 33]\ncamera = { elevation = 89.9, distance = 3.0, fov = 5.0 }\n\n\
        [[view]]\nname = \"side\"\nsize = [33, 33]\ncamera = { azimuth = 90.0, distance = 3.0, fov = 5.0 }\n";
    let images = render(dir.path(), text);
    let opacity: Vec<f32> = images.iter().map(|(_, image)| centre_opacity(image)).collect();
    // The table stores 0.02 as an 8-bit value.
    let a = (0.02f32 * 255.0).round() / 255.0;
    let expected = |mm: f32| 1.0 - (1.0 - a).powf(mm);
    let tolerance = 3.0 / 255.0;
    assert!((opacity[0] - opacity[1]).abs() <= tolerance, "front {} and top {} differ", opacity[0], opacity[1]);
    for (i, (name, mm)) in [("front", 32.0), ("top", 32.0), ("side", 64.0)].into_iter().enumerate() {
        assert!(
            (opacity[i] - expected(mm)).abs() <= tolerance,
            "{name}: opacity {} through {mm} mm, expected {}",
            opacity[i],
            expected(mm)
        );
    }
}

/// Edge labels of a scene's slice views follow their orientation and convention.
#[test]
fn slice_views_label_their_edges() {
    let dir = tempfile::tempdir().unwrap();
    let text = "[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
        [[view]]\nname = \"3d\"\nsize = [8, 8]\n\n\
        [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nsize = [8, 8]\n\n\
        [[view]]\nname = \"coronal\"\nkind = \"slice\"\naxis = \"y\"\nconvention = \"neurological\"\nsize = [8, 8]\n";
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let options = RenderOptions { phantom_size: [8, 8, 8], ..RenderOptions::default() };
    let r = SceneRenderer::open(common::software_gpu(), &scene, options, &mut |_, _, _| {}).unwrap();
    assert_eq!(r.slice_edge_labels(0), None);
    assert_eq!(r.slice_edge_labels(1), Some(["R", "L", "A", "P"]));
    assert_eq!(r.slice_edge_labels(2), Some(["L", "R", "S", "I"]));
}
