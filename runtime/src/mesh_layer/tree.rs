//! A mesh layer's renderer tree (the scene's `picture` under the volume, see the reference's
//! "Renderer trees"), and the render passes that draw it: children before their parents, each
//! occlusion group's two parts into images of their own, which the parent's pass combines
//! before it draws its own leaves. Depth groups need no images: their leaves are drawn into
//! their parent's pass, where the depth test combines them.

/// A node of a mesh layer's tree.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum LayerNode {
    /// A mesh (index into `Resources::meshes`).
    Mesh(usize),
    /// A slice view's picture on its plane (index into the view's plane pictures).
    Plane(usize),
    /// An occlusion group: where `context`'s opaque surfaces lie in front of `focus`'s, the
    /// focus shows through them with `hidden_opacity`; elsewhere the two combine by depth.
    Occlusion { hidden_opacity: f32, context: Vec<LayerNode>, focus: Vec<LayerNode> },
}

/// Which images a pass draws into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PassTarget {
    /// The layer's own images, which the volume layer reads.
    Layer,
    /// The context (first child) or the focus (the others) of occlusion group `group`
    /// (numbered in the order the plan meets them).
    Context(usize),
    Focus(usize),
}

/// One render pass of a layer: into `target` (cleared), the combination of occlusion groups
/// (`(group, hidden_opacity)`), then the planes and the meshes, depth-tested together.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LayerPass {
    pub target: PassTarget,
    pub combines: Vec<(usize, f32)>,
    pub planes: Vec<usize>,
    pub meshes: Vec<usize>,
}

impl LayerPass {
    /// The layer's only pass, drawing `meshes`.
    pub(crate) fn of_meshes(meshes: Vec<usize>) -> LayerPass {
        LayerPass { target: PassTarget::Layer, combines: Vec::new(), planes: Vec::new(), meshes }
    }
}

/// The passes that draw `tree`, the layer's last, and how many occlusion groups they use.
pub(crate) fn plan(tree: &[LayerNode]) -> (Vec<LayerPass>, usize) {
    let mut passes = Vec::new();
    let mut groups = 0;
    plan_into(tree, PassTarget::Layer, &mut passes, &mut groups);
    (passes, groups)
}

fn plan_into(nodes: &[LayerNode], target: PassTarget, passes: &mut Vec<LayerPass>, groups: &mut usize) {
    let mut pass = LayerPass { target, combines: Vec::new(), planes: Vec::new(), meshes: Vec::new() };
    for node in nodes {
        match node {
            LayerNode::Mesh(i) => pass.meshes.push(*i),
            LayerNode::Plane(i) => pass.planes.push(*i),
            LayerNode::Occlusion { hidden_opacity, context, focus } => {
                let group = *groups;
                *groups += 1;
                plan_into(context, PassTarget::Context(group), passes, groups);
                plan_into(focus, PassTarget::Focus(group), passes, groups);
                pass.combines.push((group, *hidden_opacity));
            }
        }
    }
    passes.push(pass);
}

/// Every mesh of `tree`, in order (a slice view outlines them all, whatever their groups).
pub(crate) fn meshes(tree: &[LayerNode]) -> Vec<usize> {
    let mut out = Vec::new();
    for node in tree {
        match node {
            LayerNode::Mesh(i) => out.push(*i),
            LayerNode::Plane(_) => {}
            LayerNode::Occlusion { context, focus, .. } => {
                out.extend(meshes(context));
                out.extend(meshes(focus));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn children_are_drawn_before_the_pass_that_combines_them() {
        let inner = LayerNode::Occlusion { hidden_opacity: 1.0, context: vec![LayerNode::Mesh(2)], focus: vec![] };
        let outer = LayerNode::Occlusion {
            hidden_opacity: 0.5,
            context: vec![LayerNode::Mesh(0)],
            focus: vec![LayerNode::Mesh(1), inner],
        };
        let (passes, groups) = plan(&[LayerNode::Plane(0), outer, LayerNode::Mesh(3)]);
        assert_eq!(groups, 2);
        let targets: Vec<PassTarget> = passes.iter().map(|p| p.target).collect();
        use PassTarget::*;
        assert_eq!(targets, [Context(0), Context(1), Focus(1), Focus(0), Layer]);
        assert_eq!(passes[3].combines, [(1, 1.0)]);
        assert_eq!(passes[3].meshes, [1]);
        assert_eq!((passes[4].combines.clone(), passes[4].planes.clone()), (vec![(0, 0.5)], vec![0]));
        assert_eq!(passes[4].meshes, [3]);
        assert_eq!(meshes(&[LayerNode::Mesh(3), LayerNode::Plane(0)]), [3]);
    }
}
