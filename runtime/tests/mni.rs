//! The MNI152 template volumes in `../shared/data/mni152` (see that folder's README): grid,
//! spacing, orientation and value range as the NIfTI headers say. Skipped, saying why, when the
//! folder is absent (it is not part of the project).

use crate::common;

use std::path::Path;

const FILES: [&str; 3] = [
    "mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
    "mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
    "mni_icbm152_wm_tal_nlin_sym_09a_converted.nii.gz",
];

#[test]
fn mni152_volumes_load_on_one_grid() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/mni152");
    if !dir.is_dir() {
        println!("skipped: {} is absent (see ../shared/data/README.md for how to get it)", dir.display());
        return;
    }
    let mut grids = Vec::new();
    for file in FILES {
        let volume = vrs_runtime::volume::load(&dir.join(file), &mut |_, _| {}).expect("MNI volume loads");
        assert_eq!(volume.dims, [197, 233, 189], "{file}");
        assert_eq!(volume.spacing, [1.0, 1.0, 1.0], "{file}");
        assert!(volume.range[0] >= 0.0 && volume.range[1] > volume.range[0], "{file}: range {:?}", volume.range);
        // RAS, 1 mm, origin near the anterior commissure: voxel (98, 134, 72) is close to world 0.
        let centre = volume.grid_to_world.transform_point3(glam::Vec3::new(98.0, 134.0, 72.0));
        assert!(centre.length() < 2.0, "{file}: voxel (98, 134, 72) is at {centre}");
        grids.push((volume.dims, volume.grid_to_world));
    }
    assert!(grids.windows(2).all(|w| w[0] == w[1]), "the three volumes share one grid");
}

/// The MNI T1 template as a user opens it: the automatic window (percentiles, stated as a
/// note), a 3D view and an axial slice, against golden images. Skipped, saying why, without
/// the data.
#[test]
fn mni152_t1_renders_with_its_automatic_window() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/mni152");
    if !dir.is_dir() {
        println!("skipped: {} is absent (see ../shared/data/README.md for how to get it)", dir.display());
        return;
    }
    let scene_dir = tempfile::tempdir().unwrap();
    let text = format!(
        "[[volume]]\nname = \"t1\"\nrole = \"primary\"\npath = \"{}\"\ntf = \"mr_default\"\n\n\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [128, 128]\ncamera = {{ azimuth = 30.0, elevation = 15.0 }}\n\n\
         [[view]]\nname = \"axial\"\nkind = \"slice\"\nsize = [128, 128]\naxis = \"z\"\nposition = 0.55\n",
        dir.join(FILES[0]).display()
    );
    let mut renderer = open(scene_dir.path(), &text);
    assert!(renderer.notices.iter().any(|n| n.contains("automatic window")), "{:?}", renderer.notices);
    let failures = golden_failures(&mut renderer, "mni152_t1__");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The MNI T1 template in the projection modes and patient-space planes: an average-intensity
/// 3D view, a 20 mm axial MIP slab and a 10 mm coronal MinIP slab, each with its own `render`
/// table, and a coronal slice in the neurological convention, against golden images. Skipped, saying why,
/// without the data.
#[test]
fn mni152_t1_projections_and_planes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/mni152");
    if !dir.is_dir() {
        println!("skipped: {} is absent (see ../shared/data/README.md for how to get it)", dir.display());
        return;
    }
    let scene_dir = tempfile::tempdir().unwrap();
    let text = format!(
        "[[volume]]\nname = \"t1\"\nrole = \"primary\"\npath = \"{}\"\ntf = \"grayscale\"\n\n\
         [[view]]\nname = \"average\"\nkind = \"raycast\"\nsize = [96, 96]\nrender = {{ compositing = \"average\" }}\n\n\
         [[view]]\nname = \"mip_axial\"\nkind = \"slice\"\nsize = [96, 96]\naxis = \"axial\"\nposition = 0.6\nslab = 20.0\n\
         render = {{ compositing = \"mip\" }}\n\n\
         [[view]]\nname = \"minip_coronal\"\nkind = \"slice\"\nsize = [96, 96]\naxis = \"coronal\"\nslab = 10.0\n\
         render = {{ compositing = \"minip\" }}\n\n\
         [[view]]\nname = \"coronal_neuro\"\nkind = \"slice\"\nsize = [96, 96]\naxis = \"coronal\"\nposition = 0.45\n\
         convention = \"neurological\"\n",
        dir.join(FILES[0]).display()
    );
    let mut renderer = open(scene_dir.path(), &text);
    assert_eq!(renderer.slice_geometry(3).map(|g| g.edge_labels()), Some(["L", "R", "S", "I"]));
    let failures = golden_failures(&mut renderer, "mni152_t1_modes__");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Opens the scene `text`, written into `dir`, on the software adapter.
fn open(dir: &Path, text: &str) -> vrs_runtime::SceneRenderer {
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let options = vrs_runtime::RenderOptions::default();
    vrs_runtime::SceneRenderer::open(common::software_gpu(), &scene, options, &mut |_, _, _| {}).unwrap()
}

/// Every view rendered and compared with its golden image `PREFIXVIEW`: the failures.
fn golden_failures(renderer: &mut vrs_runtime::SceneRenderer, prefix: &str) -> Vec<String> {
    let images = renderer.render_all().unwrap();
    images
        .into_iter()
        .filter_map(|(view, image)| common::check_golden(&format!("{prefix}{view}"), &image).err())
        .collect()
}
