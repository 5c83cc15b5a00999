//! The scene's inputs that only the runtime can judge: transfer-function presets and files,
//! phantoms, volume files, and the output folder. `vrsc build` and `vrsc render` check them
//! right after composing (before any GPU work), so a scene that `build` accepts fails in
//! `render` only for reasons `build` cannot know (no adapter, out of memory).
//!
//! The check lives here, in the CLI, because the compiler crate does not depend on the runtime
//! (the runtime depends on the compiler). Presets and phantoms are looked up by name (a phantom
//! is made at 1 voxel, which costs nothing); a transfer-function file is parsed in full (it is
//! small); a volume file or DICOM folder must exist and have a valid header (dimensions within
//! the limits, a sane voxel spacing), a Zarr store valid metadata; its voxels are read only by
//! `render`. A mesh file is read
//! in full, within the runtime's limits on size and triangles (its vertices and indices are
//! checked), and a built-in shape whose points are all numbers is made. An image file is
//! decoded in full.

use std::path::Path;
use vrs_runtime::bricks::zarr::{StoreLocation, ZarrSource};
use vrs_runtime::{tf, volume};
use vrsc::diag::{Code, Diagnostic};
use vrsc::scene::{MeshSource, Scene, TfRef, VolumeSource};
use vrsc::source::Span;

/// Every input of `scene` that does not exist or does not parse, as E0719 diagnostics at the
/// value that names it.
pub fn check_scene_inputs(scene: &Scene) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    for v in &scene.volumes {
        match &v.source {
            VolumeSource::Phantom(name) => {
                if let Err(e) = volume::phantom(&name.value, [1, 1, 1]) {
                    out.push(invalid(name.span, e.to_string(), "not a built-in phantom"));
                }
            }
            VolumeSource::Url(url) => {
                let location = StoreLocation::Url(url.value.clone());
                if let Err(e) = ZarrSource::check_at(&location, &vrs_runtime::scene::selection(&v.zarr)) {
                    let d = invalid(url.span, format!("cannot read volume `{}`: {e}", url.value), "this store");
                    out.push(d.with_help("check the URL and that the server answers"));
                }
            }
            VolumeSource::File(file) if !file.resolved.exists() && v.fallback.is_some() => {}
            VolumeSource::File(file) => {
                let header = if vrsc::scene::is_zarr(&file.resolved) {
                    let location = StoreLocation::Path(file.resolved.clone());
                    let selection = vrs_runtime::scene::selection(&v.zarr);
                    ZarrSource::check_at(&location, &selection).map_err(|e| e.to_string())
                } else {
                    volume::header(&file.resolved).map(|_| ()).map_err(|e| e.kind.to_string())
                };
                if let Err(why) = header {
                    let d = invalid(file.span, format!("cannot read volume `{}`: {why}", file.given), "this file")
                        .with_note(format!("resolved to `{}`", file.resolved.display()))
                        .with_help("fix the path (relative to the scene file), or add `fallback = \"head\"` to render a phantom meanwhile");
                    out.push(d);
                }
            }
        }
        if let Some(fallback) = &v.fallback
            && let Err(e) = volume::phantom(&fallback.value, [1, 1, 1])
        {
            out.push(invalid(fallback.span, e.to_string(), "not a built-in phantom"));
        }
        match &v.tf {
            Some(TfRef::Preset(name)) => {
                if let Err(e) = tf::preset(&name.value) {
                    out.push(invalid(name.span, e.to_string(), "not a transfer-function preset"));
                }
            }
            Some(TfRef::File(file)) => {
                if let Err(e) = tf::from_paraview_json(&file.resolved) {
                    let d = invalid(file.span, format!("transfer function `{}`: {e}", file.given), "this file")
                        .with_note(format!("resolved to `{}`", file.resolved.display()));
                    out.push(d);
                }
            }
            None => {}
        }
    }
    out.extend(scene.meshes.iter().filter_map(check_mesh));
    out.extend(scene.images.iter().filter_map(check_image));
    out
}

/// An image whose file cannot be read as a picture, at its path.
fn check_image(image: &vrsc::scene::Image) -> Option<Diagnostic> {
    let why = vrs_runtime::scene::read_image(image).err()?;
    let file = &image.file;
    let message = format!("cannot read image `{}`: {why}", file.given);
    Some(invalid(file.span, message, "this file").with_note(format!("resolved to `{}`", file.resolved.display())))
}

/// A mesh that cannot be made: its file (at the path) or its shape (at the table). Shapes that
/// follow uniforms are made by the runtime from the uniforms' values, and surfaces from the
/// volume's samples, which `render` reads.
fn check_mesh(mesh: &vrsc::scene::Mesh) -> Option<Diagnostic> {
    if !mesh.followed_uniforms().is_empty() || matches!(mesh.source, MeshSource::Surface { .. }) {
        return None;
    }
    let no_volume = |_: &str| Err(vrs_runtime::RuntimeError::Invalid("no volume".into()));
    let error = vrs_runtime::scene::mesh_surface(mesh, &[], &no_volume).err()?.to_string();
    Some(match &mesh.source {
        MeshSource::File { file, .. } => {
            invalid(file.span, error, "this file").with_note(format!("resolved to `{}`", file.resolved.display()))
        }
        _ => invalid(mesh.span, error, "this shape"),
    })
}

fn invalid(span: Span, message: String, label: &str) -> Diagnostic {
    Diagnostic::new(Code::SceneInput, span, message).with_label(label)
}

/// Creates `dir` if needed and proves it writable by creating and removing a file in it.
pub fn check_output_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create `{}`: {e}", dir.display()))?;
    let probe = dir.join(format!(".vrsc-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| format!("cannot write in `{}`: {e}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder under the system's temporary folder.
    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("vrsc-inputs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("a scratch folder");
        dir
    }

    fn messages(volume: &str, dir: &Path) -> Vec<String> {
        let text = format!(
            "[[volume]]\nname = \"v\"\nrole = \"primary\"\n{volume}\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
        );
        let scene =
            vrsc::scene::parse_scene_text(&text, 0, dir, &mut vrsc::diag::Diagnostics::new()).expect("a valid scene");
        check_scene_inputs(&scene).into_iter().map(|d| d.message).collect()
    }

    #[test]
    fn every_missing_input_is_a_diagnostic() {
        let dir = scratch("missing");
        assert_eq!(messages("phantom = \"head\"\ntf = \"grayscale\"", &dir), Vec::<String>::new());
        let m = messages("phantom = \"haed\"", &dir);
        assert!(m.len() == 1 && m[0].contains("did you mean `head`"), "{m:?}");
        let m = messages("phantom = \"head\"\ntf = \"greyscale\"", &dir);
        assert!(m.len() == 1 && m[0].contains("greyscale"), "{m:?}");
        let m = messages("path = \"nowhere.nii.gz\"", &dir);
        assert!(m.len() == 1 && m[0].starts_with("cannot read volume `nowhere.nii.gz`"), "{m:?}");
        assert_eq!(messages("path = \"nowhere.nii.gz\"\nfallback = \"head\"", &dir), Vec::<String>::new());
        let m = messages("path = \"nowhere.nii.gz\"\nfallback = \"nobody\"", &dir);
        assert!(m.len() == 1 && m[0].contains("nobody"), "{m:?}");
        // A volume file is read as far as its header.
        std::fs::write(dir.join("garbage.nii"), "not a volume").expect("a file");
        let m = messages("path = \"garbage.nii\"", &dir);
        assert!(m.len() == 1 && m[0].contains("too short for a NIfTI-1 header"), "{m:?}");
        let mhd = "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementSpacing = 1e-7 1e-7 1e-7\nElementDataFile = v.raw\n";
        std::fs::write(dir.join("tiny.mhd"), mhd).expect("a file");
        std::fs::write(dir.join("v.raw"), [0u8; 8]).expect("a file");
        let m = messages("path = \"tiny.mhd\"", &dir);
        assert!(m.len() == 1 && m[0].contains("voxel spacing"), "{m:?}");
        std::fs::write(dir.join("tiny.mhd"), mhd.replace("1e-7 1e-7 1e-7", "1 1 1")).expect("a file");
        assert_eq!(messages("path = \"tiny.mhd\"", &dir), Vec::<String>::new());
        let m = messages("phantom = \"head\"\ntf = \"lut.json\"", &dir);
        assert!(m.len() == 1 && m[0].starts_with("transfer function `lut.json`"), "{m:?}");
        std::fs::write(dir.join("lut.json"), "not json").expect("a file");
        let m = messages("phantom = \"head\"\ntf = \"lut.json\"", &dir);
        assert!(m.len() == 1 && m[0].starts_with("transfer function `lut.json`"), "{m:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_image_that_is_no_picture_is_a_diagnostic_at_its_path() {
        let dir = scratch("image");
        let image = "\n\n[[image]]\nname = \"plan\"\npath = \"plan.png\"\norigin = [0.0, 0.0, 0.0]\nright = [10.0, 0.0, 0.0]\ndown = [0.0, 0.0, -10.0]";
        let with_image = format!("phantom = \"head\"{image}");
        let m = messages(&with_image, &dir);
        assert!(m.len() == 1 && m[0].starts_with("cannot read image `plan.png`"), "{m:?}");
        std::fs::write(dir.join("plan.png"), "not a picture").expect("a file");
        let m = messages(&with_image, &dir);
        assert!(m.len() == 1 && m[0].starts_with("cannot read image `plan.png`"), "{m:?}");
        image::RgbaImage::new(3, 2).save(dir.join("plan.png")).expect("a picture");
        assert_eq!(messages(&with_image, &dir), Vec::<String>::new());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_output_folder_that_cannot_be_made_is_an_error() {
        let dir = scratch("output");
        assert_eq!(check_output_dir(&dir.join("out")), Ok(()));
        std::fs::write(dir.join("file"), "").expect("a file");
        let err = check_output_dir(&dir.join("file").join("out"));
        assert!(err.as_ref().is_err_and(|e| e.starts_with("cannot create")), "{err:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
