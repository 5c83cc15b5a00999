//! The rules of a view's layers, checked at `build`. A view is a mesh layer (its `[[mesh]]`es,
//! rasterized with depth) under a volume layer (its composed pipeline). The mesh layer writes
//! depth and premultiplied colour; the volume layer reads them through `geometry_depth` and
//! `geometry_color`. A volume layer that reads either in a view without a mesh layer would read
//! nothing that any layer wrote (E0609 at the field's declaration); a mesh whose shape follows a
//! uniform must follow a `vec3f` uniform that some view reads (E0702 at the name).

use super::entry::{GEOMETRY_COLOR, GEOMETRY_DEPTH, TRANSLUCENT_COLOR, TRANSLUCENT_DEPTH};
use super::ir::Composition;
use super::view::{PICTURE, PICTURE_DEPTH, image_binding_kind};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::scene::{Scene, View};
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};

/// Checks the layers of each composed view (named) of `scene`.
pub fn check_layers(scene: &Scene, views: &[(&str, &Composition)], diags: &mut Diagnostics) {
    for &(name, composition) in views {
        let draws_meshes = scene.view(name).is_some_and(Scene::has_mesh_layer);
        if draws_meshes {
            continue;
        }
        let layer_fields =
            [GEOMETRY_DEPTH, GEOMETRY_COLOR].into_iter().chain(TRANSLUCENT_DEPTH).chain(TRANSLUCENT_COLOR);
        for field in layer_fields {
            if let Some(f) = composition.fields.iter().find(|f| f.name == field) {
                diags.push(
                    Diagnostic::new(
                        Code::LayerRule,
                        f.span,
                        format!("view `{name}` reads `{field}`, but no layer of the view writes it"),
                    )
                    .with_label("read by the volume layer")
                    .with_note("`geometry_depth`, `geometry_color` and the translucent layers are written by a view's mesh layer, which draws its meshes before the volume")
                    .with_help(if scene.meshes.is_empty() {
                        "add a [[mesh]] to the scene (a file, or `shape = \"needle\"`)".to_string()
                    } else {
                        format!("list a mesh in the view's `meshes` (the scene has {})", mesh_names(scene))
                    }),
                );
            }
        }
    }
    check_followed_uniforms(scene, views, diags);
}

fn mesh_names(scene: &Scene) -> String {
    scene.meshes.iter().map(|m| format!("`{}`", m.name.name)).collect::<Vec<_>>().join(", ")
}

/// Every uniform a mesh's shape follows is a `vec3f` some view reads.
fn check_followed_uniforms(scene: &Scene, views: &[(&str, &Composition)], diags: &mut Diagnostics) {
    let vec3f = Type::vec(3, Scalar::F32);
    let uniforms = || views.iter().flat_map(|(_, c)| c.uniforms.iter());
    for mesh in &scene.meshes {
        for followed in mesh.followed_uniforms() {
            let name = &followed.value;
            let found = uniforms().find(|u| u.name == *name);
            let d = match found {
                Some(u) if u.ty == vec3f => continue,
                Some(u) => Diagnostic::new(
                    Code::SceneInvalid,
                    followed.span,
                    format!("mesh `{}` follows `{name}`, a {}; a point follows a vec3f uniform", mesh.name.name, u.ty),
                ),
                None => {
                    let names: Vec<&str> = uniforms().filter(|u| u.ty == vec3f).map(|u| u.name.as_str()).collect();
                    let d = Diagnostic::new(
                        Code::SceneInvalid,
                        followed.span,
                        format!("mesh `{}` follows the uniform `{name}`, which no view reads", mesh.name.name),
                    )
                    .with_label("not a uniform of any composed view");
                    match did_you_mean(name, names.iter().copied()) {
                        Some(best) => d.with_help(format!("did you mean `{best}`?")),
                        None => d.with_help("give the point as `[x, y, z]` (patient space, mm)"),
                    }
                }
            };
            diags.push(d);
        }
    }
}

/// The inputs of a view's filter pass: each `image` uniform names a buffer of the view's
/// picture (E0608 otherwise), and one that a node of the view writes: `picture_depth` only in a
/// view with a mesh layer (E0609). (A filter reads what the nodes before it wrote; the pass runs
/// after the whole picture, so every buffer the picture has is written before it.)
pub fn check_filter_inputs(scene: &Scene, view: &View, comp: &Composition, diags: &mut Diagnostics) {
    let name = &view.name.name;
    for u in comp.uniforms.iter().filter(|u| u.ty == Type::Image) {
        if image_binding_kind(&u.name).is_none() {
            let d = Diagnostic::new(
                Code::UnboundResource,
                u.span,
                format!("the filters of view `{name}` read the image `{}`, which no picture has", u.name),
            )
            .with_label("an `image` uniform")
            .with_note(format!(
                "a filter reads `{PICTURE}` (the picture's colour) and `{PICTURE_DEPTH}` (its meshes' depth)"
            ));
            diags.push(match did_you_mean(&u.name, [PICTURE, PICTURE_DEPTH]) {
                Some(best) => d.with_help(format!("did you mean `{best}`?")),
                None => d,
            });
        } else if u.name == PICTURE_DEPTH && !Scene::has_mesh_layer(view) {
            diags.push(
                Diagnostic::new(
                    Code::LayerRule,
                    u.span,
                    format!(
                        "the filters of view `{name}` read `{PICTURE_DEPTH}`, but no node of the view writes depth"
                    ),
                )
                .with_label("read by a filter")
                .with_note("depth is written by a view's mesh layer; the volume writes none")
                .with_help(if scene.meshes.is_empty() {
                    "add a [[mesh]] to the scene and list it in the view's `picture`".to_string()
                } else {
                    format!("list a mesh in the view's `meshes` or `picture` (the scene has {})", mesh_names(scene))
                }),
            );
        }
    }
}
