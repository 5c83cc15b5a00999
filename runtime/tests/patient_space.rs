//! Patient space and physical sampling on the software adapter: a volume stored with its axes
//! permuted and flipped (and its header in LPS) renders the same pictures as the same anatomy
//! stored axis-aligned in RAS, in 3D and in every slice orientation, unshaded and shaded (lights
//! fixed in patient space); anisotropic voxels shade like isotropic ones; a homogeneous slab is
//! equally opaque through the same physical thickness whatever the voxel spacing along the ray,
//! and as opaque as the opacity correction says.

use crate::common;

use common::write_nrrd;

use std::path::{Path, PathBuf};
use vrs_runtime::volume::{Volume, phantom};
use vrs_runtime::{RenderOptions, SceneRenderer};

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

/// How close two pictures must be: the share of pixels within the golden images' channel
/// tolerance (8/255), and the largest mean difference (/255).
struct Tolerance {
    matching: f64,
    mean: f64,
}

/// The golden images' tolerance: the same data stored another way (the trilinear filter
/// interpolates the axes in another order).
const SAME_DATA: Tolerance = Tolerance { matching: common::MIN_MATCHING, mean: common::MAX_MEAN_DIFF };

/// The same anatomy sampled on another grid (2.5 mm voxels against 1 mm ones: surfaces and
/// gradients differ by the resampling). Measured on lavapipe: at least 96.8% within 8/255 and
/// a mean difference of at most 0.5/255 with lighting in patient space; lit in normalized
/// coordinates instead (the grid's 40 : 54 : 70 stretch tilting the normals), 93.3% and 1.2 to
/// 1.5/255.
const RESAMPLED: Tolerance = Tolerance { matching: 0.96, mean: 0.75 };

/// Within the golden images' tolerance (99.5% of pixels within 8/255, mean under 1/255: the
/// trilinear filter interpolates the axes in another order), and not empty.
fn assert_same_picture(name: &str, a: &image::RgbaImage, b: &image::RgbaImage) {
    assert_similar_picture(name, a, b, SAME_DATA);
}

/// Within `tolerance`, and not empty; on a failure both pictures and their difference are
/// written to `target/golden-failures` for a look.
fn assert_similar_picture(name: &str, a: &image::RgbaImage, b: &image::RgbaImage, tolerance: Tolerance) {
    let (matching, mean, diff) = common::compare(b, a);
    let visible = a.pixels().filter(|p| p[0] > 20 || p[1] > 20 || p[2] > 20).count();
    let shown = visible > (a.width() * a.height() / 10) as usize;
    let close = matching >= tolerance.matching && mean <= tolerance.mean;
    if !(shown && close) {
        let out = common::root().join("target/golden-failures");
        let _ = std::fs::create_dir_all(&out);
        for (suffix, image) in [("a", a), ("b", b), ("diff", &diff)] {
            let _ = image.save(out.join(format!("patient_space_{name}.{suffix}.png")));
        }
    }
    assert!(shown, "{name}: the body is visible ({visible} pixels)");
    assert!(
        close,
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

/// Shading is physical: the permuted and flipped grid, lit by a headlight and by lights fixed
/// in patient space (from superior, from the patient's right), gives the same shaded DVR and
/// iso-surface pictures as the axis-aligned one. Lit in the grid's normalized coordinates, the
/// light "from superior" would come from the permuted grid's k' axis (posterior) instead.
#[test]
fn a_permuted_and_flipped_grid_is_shaded_like_the_axis_aligned_one() {
    let dir = tempfile::tempdir().unwrap();
    write_abdomen_twice(dir.path());
    let scene = |file: &str| {
        format!(
            "[render]\nshading = true\nlights = [\"key\", \"top\", \"right\"]\n\n\
             [[volume]]\nname = \"ct\"\nrole = \"primary\"\npath = \"{file}\"\ntf = \"ct_soft_tissue\"\n\n\
             [uniforms]\nlight_dir_top = [0.0, 0.2, 1.0]\nlight_dir_right = [1.0, 0.0, 0.0]\n\
             light_color_key = [0.4, 0.4, 0.4]\nlight_color_right = [0.6, 0.3, 0.3]\n\n{}",
            // -205 HU on the CT presets' window (-1024 to 3071 HU): the skin.
            shaded_views(0.2)
        )
    };
    let aligned = render(dir.path(), &scene("aligned.nrrd"));
    let stored = render(dir.path(), &scene("permuted.nrrd"));
    assert_eq!(aligned.len(), 3);
    for ((name, a), (_, b)) in aligned.iter().zip(&stored) {
        assert_same_picture(&format!("shaded_{name}"), a, b);
    }
}

/// The views of the shading tests: DVR from two sides and a first-hit iso-surface at
/// `iso_value` (normalized by the window).
fn shaded_views(iso_value: f32) -> String {
    format!(
        "[[view]]\nname = \"front\"\nsize = [96, 96]\ncamera = {{ azimuth = 30.0, elevation = 20.0 }}\n\n\
         [[view]]\nname = \"below\"\nsize = [96, 96]\ncamera = {{ azimuth = -120.0, elevation = -35.0 }}\n\n\
         [[view]]\nname = \"iso\"\nsize = [96, 96]\ncamera = {{ azimuth = 60.0, elevation = 40.0 }}\n\
         render = {{ compositing = \"iso\", iso_value = {iso_value:?} }}\n"
    )
}

/// Writes a smooth ellipsoid (radii 14, 20 and 26 mm along R, A and S, centred at `centre`;
/// its value falls from 100 to 0 across about a quarter of its radius at the surface) sampled
/// at the voxel centres of an axis-aligned RAS grid of `dims` voxels of `spacing` mm centred
/// there too.
fn write_ellipsoid(path: &Path, dims: [u32; 3], spacing: [f32; 3]) {
    let centre = glam::Vec3::new(5.0, -10.0, 20.0);
    let radii = glam::Vec3::new(14.0, 20.0, 26.0);
    let size = glam::Vec3::from(dims.map(|d| d as f32)) * glam::Vec3::from(spacing);
    let first = centre - 0.5 * size + 0.5 * glam::Vec3::from(spacing);
    let mut values = Vec::with_capacity(dims.iter().product::<u32>() as usize);
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let w = first + glam::Vec3::new(i as f32, j as f32, k as f32) * glam::Vec3::from(spacing);
                let q = ((w - centre) / radii).length();
                values.push(100.0 * (0.5 + 2.0 * (1.0 - q)).clamp(0.0, 1.0));
            }
        }
    }
    let directions = [[spacing[0], 0.0, 0.0], [0.0, spacing[1], 0.0], [0.0, 0.0, spacing[2]]];
    write_nrrd(path, "right-anterior-superior", dims, directions, first.to_array(), &values);
}

/// Anisotropic voxels shade like isotropic ones: the same ellipsoid on 1 x 1.5 x 2.5 mm voxels
/// (a 40 x 54 x 70 mm grid) and on 1 mm voxels (a 70 mm cube around the same centre, so both
/// views frame it alike) gives the same shaded pictures. The grids' normalized coordinates
/// differ (the first is stretched 40 : 54 : 70), so shading there would tilt the normals of
/// the first.
#[test]
fn anisotropic_voxels_are_shaded_like_isotropic_ones() {
    let dir = tempfile::tempdir().unwrap();
    write_ellipsoid(&dir.path().join("anisotropic.nrrd"), [40, 36, 28], [1.0, 1.5, 2.5]);
    write_ellipsoid(&dir.path().join("isotropic.nrrd"), [70, 70, 70], [1.0, 1.0, 1.0]);
    let scene = |file: &str| {
        format!(
            "[render]\nshading = true\nlights = [\"key\", \"top\"]\nstep_size = 0.5\n\n\
             [[volume]]\nname = \"ball\"\nrole = \"primary\"\npath = \"{file}\"\ntf = \"grayscale\"\n\
             window = [0.0, 100.0]\n\n\
             [uniforms]\nlight_dir_top = [0.3, 0.0, 1.0]\nlight_color_key = [0.5, 0.5, 0.5]\n\n{}",
            shaded_views(0.5)
        )
    };
    let anisotropic = render(dir.path(), &scene("anisotropic.nrrd"));
    let isotropic = render(dir.path(), &scene("isotropic.nrrd"));
    for ((name, a), (_, b)) in isotropic.iter().zip(&anisotropic) {
        assert_similar_picture(&format!("anisotropic_{name}"), a, b, RESAMPLED);
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
/// 8-bit output). Stepping in normalized volume units would give all three the same
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
    // The table holds 0.02 as a half float (to 2e-6; an 8-bit table held 5/255 = 0.0196).
    let a = half::f16::from_f32(0.02).to_f32();
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
    assert!(r.slice_geometry(0).is_none());
    assert_eq!(r.slice_geometry(1).map(|g| g.edge_labels()), Some(["R", "L", "A", "P"]));
    assert_eq!(r.slice_geometry(2).map(|g| g.edge_labels()), Some(["L", "R", "S", "I"]));
}
