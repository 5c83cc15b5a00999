//! Errors that arise outside the compiler's passes (reading the files named on the command line,
//! writing outputs, the GPU, volumes and transfer functions loaded by the renderer), turned
//! into diagnostics so that they print like every other error and come out as JSON under
//! `--message-format json`.
//!
//! The exit-code rule (docs/reference.md): a mistake in what the user wrote or named inside a
//! scene or module (a volume or transfer function that is missing, unreadable or undecodable
//! included) is exit 1, wherever it is found; the paths given on the command line, the output
//! folder and the GPU are exit 2 (codes E0902 and E0903).

use vrs_runtime::RuntimeError;
use vrsc::diag::{Code, Diagnostic};
use vrsc::scene::{Scene, TfRef, VolumeSource};
use vrsc::source::Span;

/// A file given on the command line that cannot be read, or an output that cannot be written.
pub fn io(message: impl Into<String>) -> Diagnostic {
    Diagnostic::new(Code::Io, Span::DUMMY, message)
}

/// Whether a diagnostic is about the machine rather than the input (exit 2).
pub fn is_environment(d: &Diagnostic) -> bool {
    matches!(d.code, Code::Io | Code::Device | Code::GpuRefused)
}

/// What a refused resource or pipeline means for the user.
const GPU_REFUSED_NOTE: &str = "the scene composed, but this GPU refused the work; a smaller image \
(`--size`) or volume may fit, and if it does not, please report it with the scene";

/// A runtime error of rendering `scene`: about a volume or transfer function of the scene, an
/// E0719 at the value that names it; about the machine, E0902 or E0903.
pub fn runtime(e: &RuntimeError, scene: &Scene) -> Diagnostic {
    let message = e.to_string();
    match e {
        RuntimeError::Gpu(_) => Diagnostic::new(Code::Device, Span::DUMMY, message),
        RuntimeError::Device(_) | RuntimeError::Pipeline { .. } => {
            Diagnostic::new(Code::GpuRefused, Span::DUMMY, message).with_note(GPU_REFUSED_NOTE)
        }
        RuntimeError::Io { .. } => io(message),
        RuntimeError::Volume(load) => {
            let span = volume_span(scene, &load.path);
            Diagnostic::new(Code::SceneInput, span, message).with_label("this volume")
        }
        RuntimeError::Tf(tf) => {
            let span = tf_span(scene, tf);
            Diagnostic::new(Code::SceneInput, span, message).with_label("this transfer function")
        }
        _ => Diagnostic::new(Code::SceneInput, Span::DUMMY, message),
    }
}

/// The scene value naming the volume at `path` (its file, or the phantom standing in for it).
fn volume_span(scene: &Scene, path: &std::path::Path) -> Span {
    let named = scene.volumes.iter().find_map(|v| match &v.source {
        VolumeSource::File(file) if file.resolved == path => Some(file.span),
        _ => None,
    });
    named.unwrap_or(Span::DUMMY)
}

fn tf_span(scene: &Scene, e: &vrs_runtime::tf::TfError) -> Span {
    use vrs_runtime::tf::TfError;
    let refs = scene.volumes.iter().filter_map(|v| v.tf.as_ref());
    let found = match e {
        TfError::UnknownPreset { name } => refs
            .filter_map(|r| match r {
                TfRef::Preset(p) if &p.value == name => Some(p.span),
                _ => None,
            })
            .next(),
        TfError::Io { path, .. } | TfError::Invalid { path, .. } => refs
            .filter_map(|r| match r {
                TfRef::File(file) if &file.resolved == path => Some(file.span),
                _ => None,
            })
            .next(),
        _ => None,
    };
    found.unwrap_or(Span::DUMMY)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(dir: &std::path::Path) -> Scene {
        let text = "[[volume]]\nname = \"v\"\nrole = \"primary\"\npath = \"v.nii\"\ntf = \"lut.json\"\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\n";
        let mut diags = vrsc::diag::Diagnostics::new();
        vrsc::scene::parse_scene_text(text, 10, dir, &mut diags).expect("a valid scene")
    }

    #[test]
    fn volume_and_tf_errors_point_at_the_scene() {
        let dir = std::env::temp_dir().join(format!("vrsc-failure-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a scratch folder");
        let scene = scene(&dir);
        let load = vrs_runtime::volume::load(&dir.join("v.nii"), &mut |_, _| {}).expect_err("no such file");
        let d = runtime(&RuntimeError::Volume(load), &scene);
        assert_eq!(d.code, Code::SceneInput);
        let VolumeSource::File(file) = &scene.volumes[0].source else { panic!("a file volume") };
        assert_eq!(d.span, file.span);
        let tf = vrs_runtime::tf::from_paraview_json(&dir.join("lut.json")).expect_err("no such file");
        let d = runtime(&RuntimeError::Tf(tf), &scene);
        assert!(!d.span.is_dummy() && !is_environment(&d), "{d:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn machine_errors_exit_with_2() {
        let e = RuntimeError::Io { path: "out.png".into(), error: std::io::Error::other("disk full") };
        assert!(is_environment(&runtime(&e, &scene(&std::env::temp_dir()))));
    }
}
