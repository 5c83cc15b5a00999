//! What a view shows besides its volume, from its renderer tree in the scene (`picture`): the
//! tree its mesh layer draws, with depth groups flattened into their parents (the depth test
//! combines them) and occlusion groups kept; the meshes its overlay draws; the slice views it
//! shows on planes.

use crate::mesh_layer::LayerNode;
use vrsc::scene::{self as vscene, GroupKind, Node, Scene, ViewKind};

/// Groups deeper than this are left out: validation refuses cycles, and a scene made by hand
/// with one must still end.
const MAX_DEPTH: usize = 64;

/// A view's picture as its renderer draws it.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct ViewPicture {
    /// The mesh layer's tree (meshes index the scene's meshes; planes index `planes`).
    pub tree: Vec<LayerNode>,
    /// The meshes drawn over the finished picture (indices into the scene's meshes).
    pub overlay: Vec<usize>,
    /// The slice views shown on their planes, each once (indices into the scene's views); none
    /// in a slice view.
    pub planes: Vec<usize>,
}

impl ViewPicture {
    pub(crate) fn of(scene: &Scene, view: &vscene::View) -> ViewPicture {
        let planes = match view.kind.value {
            ViewKind::Raycast => scene.leaves_under(view).1,
            ViewKind::Slice => Vec::new(),
        };
        let tree = layer_nodes(scene, &view.picture.under, &planes, 0);
        ViewPicture { tree, overlay: view.picture.over.clone(), planes }
    }
}

/// `nodes` as mesh-layer nodes; a plane not in `planes` is left out.
fn layer_nodes(scene: &Scene, nodes: &[Node], planes: &[usize], depth: usize) -> Vec<LayerNode> {
    let mut out = Vec::new();
    for node in nodes {
        match *node {
            Node::Mesh(i) => out.push(LayerNode::Mesh(i)),
            Node::Plane(v) => out.extend(planes.iter().position(|&p| p == v).map(LayerNode::Plane)),
            Node::Group(g) if depth < MAX_DEPTH => {
                let Some(group) = scene.groups.get(g) else { continue };
                let children = |nodes: &[Node]| layer_nodes(scene, nodes, planes, depth + 1);
                match group.kind {
                    GroupKind::Depth => out.extend(children(&group.children)),
                    GroupKind::Shadow { light } => {
                        out.push(LayerNode::Shadow { light, children: children(&group.children) })
                    }
                    GroupKind::Occlusion { hidden_opacity } => {
                        let (context, focus) = group.children.split_at(group.children.len().min(1));
                        out.push(LayerNode::Occlusion {
                            hidden_opacity,
                            context: children(context),
                            focus: children(focus),
                        });
                    }
                }
            }
            Node::Group(_) => {}
        }
    }
    out
}
