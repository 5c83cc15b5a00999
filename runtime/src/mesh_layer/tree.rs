//! A mesh layer's renderer tree (the scene's `picture` under the volume, see the reference's
//! "Renderer trees"), and the render passes that draw it: children before their parents, each
//! occlusion group's two parts into images of their own, which the parent's pass combines
//! before it draws its own leaves. Depth and shadow groups need no images: their leaves are
//! drawn into their parent's pass, where the depth test combines them; a shadow group's
//! meshes are drawn into its shadow map first and lit by its light. A filter's children are
//! drawn into images of their own too (an occlusion group's slot, the focus left empty), which
//! the filter's compute pass filters in place before the parent's pass combines them.

/// A node of a mesh layer's tree.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum LayerNode {
    /// A mesh (index into `Resources::meshes`).
    Mesh(usize),
    /// A slice view's picture on its plane (index into the view's plane pictures).
    Plane(usize),
    /// An occlusion group (`group`, its index among the scene's groups): where `context`'s
    /// opaque surfaces lie in front of `focus`'s, the focus shows through them with
    /// `hidden_opacity`; elsewhere the two combine by depth.
    Occlusion { group: usize, hidden_opacity: f32, context: Vec<LayerNode>, focus: Vec<LayerNode> },
    /// A shadow group: `children` lit by a directional light, each mesh shadowing the others.
    Shadow { light: ShadowLight, children: Vec<LayerNode> },
    /// A filter of a depth group (`filter`, its index among the scene's tree filters) over the
    /// picture of `children`, the nodes listed before it.
    Filtered { filter: usize, children: Vec<LayerNode> },
}

/// Where a shadow group's light is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ShadowLight {
    /// Towards the light, in patient space; zero: from the viewer (a headlight).
    Towards([f32; 3]),
    /// Light NAME of the view: the direction its `light_dir_NAME` holds, resolved every frame
    /// into `towards` ([`resolve_lights`]; until then, and where the view has no such uniform,
    /// zero: from the viewer). The volume's shading of that light takes the group's shadow too
    /// (`std::mesh_shadow`).
    Light { name: String, towards: [f32; 3] },
}

/// Calls `f` on every node of `tree`, each before its children, in order.
pub(crate) fn visit(tree: &[LayerNode], f: &mut dyn FnMut(&LayerNode)) {
    for node in tree {
        f(node);
        match node {
            LayerNode::Occlusion { context, focus, .. } => {
                visit(context, f);
                visit(focus, f);
            }
            LayerNode::Shadow { children, .. } | LayerNode::Filtered { children, .. } => visit(children, f),
            LayerNode::Mesh(_) | LayerNode::Plane(_) => {}
        }
    }
}

/// [`visit`] with each node to change.
fn visit_mut(tree: &mut [LayerNode], f: &mut dyn FnMut(&mut LayerNode)) {
    for node in tree {
        f(node);
        match node {
            LayerNode::Occlusion { context, focus, .. } => {
                visit_mut(context, f);
                visit_mut(focus, f);
            }
            LayerNode::Shadow { children, .. } | LayerNode::Filtered { children, .. } => visit_mut(children, f),
            LayerNode::Mesh(_) | LayerNode::Plane(_) => {}
        }
    }
}

/// `tree`'s lights that follow the view's lights, aimed as `value` gives each `light_dir_NAME`
/// uniform (none: from the viewer).
pub(crate) fn resolve_lights(tree: &mut [LayerNode], value: &dyn Fn(&str) -> Option<[f32; 3]>) {
    visit_mut(tree, &mut |node| {
        if let LayerNode::Shadow { light: ShadowLight::Light { name, towards }, .. } = node {
            *towards = value(&format!("light_dir_{name}")).unwrap_or([0.0; 3]);
        }
    });
}

/// Which images a pass draws into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PassTarget {
    /// The layer's own images, which the volume layer reads.
    Layer,
    /// The context (first child) or the focus (the others) of occlusion group `group`
    /// (numbered in the order the plan meets them); a filter's children are its context, its
    /// focus is empty.
    Context(usize),
    Focus(usize),
}

/// A filter's pass in a plan: `filter` (its index among the scene's tree filters) over the
/// context of group slot `group`, in place, right after pass `after` drew it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FilterStep {
    pub filter: usize,
    pub group: usize,
    pub after: usize,
}

/// A mesh as a pass draws it: `shadow`, the shadow group (index into [`LayerPlan::shadows`])
/// whose light and shadow map light it; none, the headlight.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct LitMesh {
    pub mesh: usize,
    pub shadow: Option<usize>,
}

/// One render pass of a layer: into `target` (cleared), the combination of occlusion groups
/// (`(group, hidden_opacity)`), then the planes and the meshes, depth-tested together.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LayerPass {
    pub target: PassTarget,
    pub combines: Vec<(usize, f32)>,
    pub planes: Vec<usize>,
    pub meshes: Vec<LitMesh>,
}

/// A shadow group's shadow map: drawn from `light` (towards the light; zero: from the viewer)
/// with every mesh of the group; `follows`, the view's light it follows, if it does.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ShadowCast {
    pub light: [f32; 3],
    pub follows: Option<String>,
    pub meshes: Vec<usize>,
}

/// How a tree is drawn: its shadow maps first, then its passes (the layer's last), with
/// `groups` occlusion groups' (and filters') images, and its filters' passes between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct LayerPlan {
    pub shadows: Vec<ShadowCast>,
    pub passes: Vec<LayerPass>,
    pub groups: usize,
    pub filters: Vec<FilterStep>,
}

impl LayerPlan {
    /// The plan of `tree`.
    pub(crate) fn of(tree: &[LayerNode]) -> LayerPlan {
        let mut plan = LayerPlan::default();
        plan.pass(tree, PassTarget::Layer, None);
        plan
    }

    /// One pass drawing `meshes` with the headlight (a slice view's outlines).
    pub(crate) fn of_meshes(meshes: Vec<usize>) -> LayerPlan {
        let meshes = meshes.into_iter().map(|mesh| LitMesh { mesh, shadow: None }).collect();
        let pass = LayerPass { target: PassTarget::Layer, combines: Vec::new(), planes: Vec::new(), meshes };
        LayerPlan { shadows: Vec::new(), passes: vec![pass], groups: 0, filters: Vec::new() }
    }

    /// The pass into `target` of `nodes`, after those of its occlusion groups' parts.
    fn pass(&mut self, nodes: &[LayerNode], target: PassTarget, shadow: Option<usize>) {
        let mut pass = LayerPass { target, combines: Vec::new(), planes: Vec::new(), meshes: Vec::new() };
        self.collect(nodes, &mut pass, shadow);
        self.passes.push(pass);
    }

    /// `nodes` into `pass`: leaves, depth and shadow groups' leaves, occlusion groups'
    /// combinations (their parts planned as passes of their own).
    fn collect(&mut self, nodes: &[LayerNode], pass: &mut LayerPass, shadow: Option<usize>) {
        for node in nodes {
            match node {
                LayerNode::Mesh(mesh) => pass.meshes.push(LitMesh { mesh: *mesh, shadow }),
                LayerNode::Plane(i) => pass.planes.push(*i),
                LayerNode::Occlusion { hidden_opacity, context, focus, .. } => {
                    let group = self.groups;
                    self.groups += 1;
                    self.pass(context, PassTarget::Context(group), shadow);
                    self.pass(focus, PassTarget::Focus(group), shadow);
                    pass.combines.push((group, *hidden_opacity));
                }
                LayerNode::Shadow { light, children } => {
                    let (light, follows) = match light {
                        ShadowLight::Towards(v) => (*v, None),
                        ShadowLight::Light { name, towards } => (*towards, Some(name.clone())),
                    };
                    self.shadows.push(ShadowCast { light, follows, meshes: meshes(children) });
                    self.collect(children, pass, Some(self.shadows.len() - 1));
                }
                LayerNode::Filtered { filter, children } => {
                    let group = self.groups;
                    self.groups += 1;
                    self.pass(children, PassTarget::Context(group), shadow);
                    self.filters.push(FilterStep { filter: *filter, group, after: self.passes.len() - 1 });
                    // An empty focus: the combination is then the filtered context, at its depth.
                    self.pass(&[], PassTarget::Focus(group), shadow);
                    pass.combines.push((group, 1.0));
                }
            }
        }
    }
}

/// Sets the hidden opacity of every occlusion node of `tree` made from scene group `group`.
pub(crate) fn set_hidden_opacity(tree: &mut [LayerNode], group: usize, opacity: f32) {
    visit_mut(tree, &mut |node| {
        if let LayerNode::Occlusion { group: g, hidden_opacity, .. } = node
            && *g == group
        {
            *hidden_opacity = opacity;
        }
    });
}

/// Every mesh of `tree`, in order (a slice view outlines them all, whatever their groups).
pub(crate) fn meshes(tree: &[LayerNode]) -> Vec<usize> {
    let mut out = Vec::new();
    visit(tree, &mut |node| {
        if let LayerNode::Mesh(i) = node {
            out.push(*i);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn children_are_drawn_before_the_pass_that_combines_them() {
        let inner =
            LayerNode::Occlusion { group: 1, hidden_opacity: 1.0, context: vec![LayerNode::Mesh(2)], focus: vec![] };
        let outer = LayerNode::Occlusion {
            group: 0,
            hidden_opacity: 0.5,
            context: vec![LayerNode::Mesh(0)],
            focus: vec![LayerNode::Mesh(1), inner],
        };
        let plan = LayerPlan::of(&[LayerNode::Plane(0), outer, LayerNode::Mesh(3)]);
        assert_eq!(plan.groups, 2);
        let targets: Vec<PassTarget> = plan.passes.iter().map(|p| p.target).collect();
        use PassTarget::*;
        assert_eq!(targets, [Context(0), Context(1), Focus(1), Focus(0), Layer]);
        let lit = |mesh| LitMesh { mesh, shadow: None };
        assert_eq!(plan.passes[3].combines, [(1, 1.0)]);
        assert_eq!(plan.passes[3].meshes, [lit(1)]);
        assert_eq!((plan.passes[4].combines.clone(), plan.passes[4].planes.clone()), (vec![(0, 0.5)], vec![0]));
        assert_eq!(plan.passes[4].meshes, [lit(3)]);
        assert_eq!(meshes(&[LayerNode::Mesh(3), LayerNode::Plane(0)]), [3]);
    }

    #[test]
    fn a_filter_runs_on_its_childrens_images_before_the_parent_combines_them() {
        let inner = LayerNode::Filtered { filter: 4, children: vec![LayerNode::Mesh(0)] };
        let outer = LayerNode::Filtered { filter: 7, children: vec![inner, LayerNode::Mesh(1)] };
        let plan = LayerPlan::of(&[outer, LayerNode::Mesh(2)]);
        use PassTarget::*;
        let targets: Vec<PassTarget> = plan.passes.iter().map(|p| p.target).collect();
        assert_eq!(targets, [Context(1), Focus(1), Context(0), Focus(0), Layer]);
        assert_eq!(
            plan.filters,
            [FilterStep { filter: 4, group: 1, after: 0 }, FilterStep { filter: 7, group: 0, after: 2 }]
        );
        assert!(plan.passes[1].meshes.is_empty() && plan.passes[3].meshes.is_empty());
        assert_eq!(plan.passes[2].combines, [(1, 1.0)]);
        assert_eq!(plan.passes[4].combines, [(0, 1.0)]);
        assert_eq!(plan.passes[4].meshes, [LitMesh { mesh: 2, shadow: None }]);
    }

    #[test]
    fn a_shadow_groups_meshes_are_drawn_in_their_parents_pass_with_its_light() {
        let occluded = LayerNode::Occlusion {
            group: 0,
            hidden_opacity: 0.5,
            context: vec![LayerNode::Mesh(1)],
            focus: vec![LayerNode::Mesh(2)],
        };
        let light = [0.0, 0.0, 1.0];
        let shadow =
            LayerNode::Shadow { light: ShadowLight::Towards(light), children: vec![LayerNode::Mesh(0), occluded] };
        let plan = LayerPlan::of(&[shadow, LayerNode::Mesh(3)]);
        assert_eq!(plan.shadows, [ShadowCast { light, follows: None, meshes: vec![0, 1, 2] }]);
        let lit = |mesh, shadow| LitMesh { mesh, shadow };
        assert_eq!(plan.passes[0].meshes, [lit(1, Some(0))]);
        assert_eq!(plan.passes[1].meshes, [lit(2, Some(0))]);
        assert_eq!(plan.passes[2].meshes, [lit(0, Some(0)), lit(3, None)]);
    }
}
