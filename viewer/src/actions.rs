//! What the panels ask for, applied to the live scene in one place: the panels only draw and
//! report, so they can be tested without a GPU.

use std::path::PathBuf;
use vrs_live::{LiveScene, MeshStyle};
use vrs_runtime::Value;
use vrs_runtime::tf::TfCurve;

/// A change the user asked for in a panel.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// A uniform's new value (the uniform block only: no recompilation).
    SetUniform(String, Value),
    /// Back to the scene's value (or the default).
    ResetUniform(String),
    /// The changed uniforms into the scene file.
    SaveUniforms,
    /// A volume's new transfer function (its table only: no pipeline).
    SetCurve(String, TfCurve),
    /// Back to the scene's transfer function.
    ResetCurve(String),
    /// The volume's transfer function as a ParaView colormap at this path, and the scene's
    /// `tf` of the volume pointed at it.
    SaveCurve(String, PathBuf),
    /// A mesh's colour, opacity and placement.
    SetMeshStyle(String, MeshStyle),
    /// Back to the scene's colour, opacity and placement of the mesh.
    ResetMeshStyle(String),
    /// The opacity an occlusion group shows what it hides with.
    SetGroupOpacity(String, f32),
    /// Back to the scene's opacity of the occlusion group.
    ResetGroupOpacity(String),
}

/// Applies `action`; the message says what happened (or why not), for the status line.
pub fn apply(live: &mut LiveScene, action: Action) -> Result<String, String> {
    match action {
        Action::SetUniform(name, value) => live.set_uniform(&name, value).map(|_| String::new()),
        Action::ResetUniform(name) => live.reset_uniform(&name).map(|_| format!("`{name}` reset")),
        Action::SaveUniforms => {
            let saved = live.save_uniforms().map_err(|e| e.to_string())?;
            return Ok(format!("saved {saved} value(s) into {}", live.renderer().path().display()));
        }
        Action::SetCurve(volume, curve) => live.set_tf_curve(&volume, curve).map(|_| String::new()),
        Action::ResetCurve(volume) => {
            live.reset_tf_curve(&volume).map(|_| format!("`{volume}`: the scene's transfer function"))
        }
        Action::SaveCurve(volume, path) => {
            return live
                .save_tf_curve(&volume, &path)
                .map(|()| format!("saved `{volume}`'s transfer function as {}", path.display()))
                .map_err(|e| e.to_string());
        }
        Action::SetMeshStyle(mesh, style) => live.set_mesh_style(&mesh, style).map(|_| String::new()),
        Action::ResetMeshStyle(mesh) => live.reset_mesh_style(&mesh).map(|_| format!("`{mesh}`: the scene's style")),
        Action::SetGroupOpacity(group, opacity) => live.set_group_opacity(&group, opacity).map(|_| String::new()),
        Action::ResetGroupOpacity(group) => {
            live.reset_group_opacity(&group).map(|_| format!("`{group}`: the scene's opacity"))
        }
    }
    .map_err(|e| e.to_string())
}
