//! What a view shows besides its volume, from its renderer tree in the scene (`picture`): the
//! tree its mesh layer draws, with depth groups flattened into their parents (the depth test
//! combines them) and occlusion and shadow groups kept; the meshes its overlay draws; the slice
//! views and images it shows on planes. Also the live opacity of occlusion groups.

use super::SceneRenderer;
use crate::error::RuntimeError;
use crate::mesh_layer::{LayerNode, ShadowLight, set_hidden_opacity, visit};
use vrsc::scene::{self as vscene, GroupKind, Node, Scene, ViewKind};

/// What the views' renderer trees are made of, shared by them: the scene's meshes as last made,
/// its images as last uploaded, and the names of its groups (which the trees index).
#[derive(Default)]
pub(super) struct TreeContent {
    pub(super) meshes: super::meshes::SceneMeshes,
    pub(super) images: super::images::SceneImages,
    pub(super) group_names: Vec<String>,
}

/// A view's picture as its renderer draws it.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct ViewPicture {
    /// The mesh layer's tree (meshes index the scene's meshes; planes index `planes`).
    pub tree: Vec<LayerNode>,
    /// The meshes drawn over the finished picture (indices into the scene's meshes).
    pub overlay: Vec<usize>,
    /// The pictures shown on planes, each once: slice views ([`Node::Plane`], indices into the
    /// scene's views) and images ([`Node::Image`]); none in a slice view.
    pub planes: Vec<Node>,
    /// The generation of the scene's images last handed to the mesh layer, when `planes` are
    /// images only (they need not be handed again until they change); 0: not yet.
    pub images_shown: u64,
}

impl ViewPicture {
    pub(crate) fn of(scene: &Scene, view: &vscene::View) -> ViewPicture {
        let planes = match view.kind.value {
            ViewKind::Raycast => scene.leaves_under(view).1,
            ViewKind::Slice => Vec::new(),
        };
        let tree = layer_nodes(scene, &view.picture.under, &planes, 0);
        ViewPicture { tree, overlay: view.picture.over.clone(), planes, images_shown: 0 }
    }
}

/// `nodes` as mesh-layer nodes; a plane not in `planes` is left out.
fn layer_nodes(scene: &Scene, nodes: &[Node], planes: &[Node], depth: usize) -> Vec<LayerNode> {
    let mut out = Vec::new();
    for node in nodes {
        match *node {
            Node::Mesh(i) => out.push(LayerNode::Mesh(i)),
            Node::Plane(_) | Node::Image(_) => out.extend(planes.iter().position(|p| p == node).map(LayerNode::Plane)),
            Node::Group(g) if depth < vscene::MAX_GROUP_DEPTH => {
                let Some(group) = scene.groups.get(g) else { continue };
                let children = |nodes: &[Node]| layer_nodes(scene, nodes, planes, depth + 1);
                match &group.kind {
                    GroupKind::Depth => out.extend(filtered(scene, &group.children, planes, depth + 1)),
                    GroupKind::Shadow { light } => {
                        let light = match light {
                            vscene::ShadowLight::Towards(v) => ShadowLight::Towards(*v),
                            vscene::ShadowLight::Light(name) => {
                                ShadowLight::Light { name: name.name.clone(), towards: [0.0; 3] }
                            }
                        };
                        out.push(LayerNode::Shadow { light, children: children(&group.children) })
                    }
                    &GroupKind::Occlusion { hidden_opacity } => {
                        let (context, focus) = group.children.split_at(group.children.len().min(1));
                        out.push(LayerNode::Occlusion {
                            group: g,
                            hidden_opacity,
                            context: children(context),
                            focus: children(focus),
                        });
                    }
                }
            }
            Node::Group(_) | Node::Filter(_) => {}
        }
    }
    out
}

/// A depth group's children as mesh-layer nodes, each filter over the nodes before it.
fn filtered(scene: &Scene, nodes: &[Node], planes: &[Node], depth: usize) -> Vec<LayerNode> {
    let mut out = Vec::new();
    for node in nodes {
        match *node {
            Node::Filter(filter) => out = vec![LayerNode::Filtered { filter, children: std::mem::take(&mut out) }],
            _ => out.extend(layer_nodes(scene, std::slice::from_ref(node), planes, depth)),
        }
    }
    out
}

impl SceneRenderer {
    /// The occlusion groups the views draw, each once in scene order, with the opacity their
    /// hidden children show with now.
    pub fn occlusion_groups(&self) -> Vec<(String, f32)> {
        let mut found: Vec<(usize, f32)> = Vec::new();
        for view in &self.views {
            visit(&view.picture.tree, &mut |node| {
                if let LayerNode::Occlusion { group, hidden_opacity, .. } = node {
                    found.push((*group, *hidden_opacity));
                }
            });
        }
        found.sort_by_key(|(g, _)| *g);
        found.dedup_by_key(|(g, _)| *g);
        found.into_iter().filter_map(|(g, k)| Some((self.tree.group_names.get(g)?.clone(), k))).collect()
    }

    /// Shows what occlusion group `name` hides with `opacity` (clamped to [0, 1]) in every view,
    /// from the next frame; until the scene is loaded again.
    pub fn set_group_opacity(&mut self, name: &str, opacity: f32) -> Result<(), RuntimeError> {
        let Some(group) = self.tree.group_names.iter().position(|g| g == name) else {
            return Err(RuntimeError::Invalid(format!("the scene has no group `{name}`")));
        };
        if !opacity.is_finite() {
            return Err(RuntimeError::Invalid(format!("group `{name}`: an opacity of {opacity}")));
        }
        for view in &mut self.views {
            set_hidden_opacity(&mut view.picture.tree, group, opacity.clamp(0.0, 1.0));
        }
        self.resources.content_changed();
        Ok(())
    }
}
