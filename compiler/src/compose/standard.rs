//! The standard modules a view is composed with: the selection policy of `stdlib/README.md`,
//! owned by the composer (the scene only says what the user asked for).

use crate::scene::{
    Compositing, GroupKind, MAX_GROUP_DEPTH, Node, Preintegration, Role, Scene, ShadowLight, Shadows, ToneMapping,
    View, ViewKind,
};

/// A standard module chosen by configuration: `std::NAME`, with instances for a template.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StdModule {
    pub name: &'static str,
    /// Empty for a plain module.
    pub instances: Vec<String>,
}

impl Scene {
    /// The standard modules the composer selects for `view`, in the order it gives them
    /// (before the scene's `[[module]]`s and then the view's own `modules`). See
    /// `stdlib/README.md`.
    pub fn standard_modules(&self, view: &View) -> Vec<StdModule> {
        let mut selection = Selection { view, out: Vec::new(), additional: self.volume_names(Role::Additional) };
        selection.sampling_and_classification(self);
        selection.compositing();
        selection.late_modules();
        if Scene::has_mesh_layer(view) {
            // After `light` and every shadow module: the meshes' shadow joins the volume's
            // just before the light's substep.
            let followed = self.mesh_shadow_lights(view);
            if !followed.is_empty() {
                selection.add("mesh_shadow", followed);
            }
            // Last: `stop_at_meshes` follows the ray setup (and skipping's first walk), and
            // `blend_meshes` runs after `encode_srgb` (mesh colours are display colours).
            selection.add("meshes", vec![]);
            // After `meshes` (its ray setup places the layers on the ray, after
            // `stop_at_meshes`); `finish_translucent` goes first in `ray.finish`, before
            // `expose`.
            if self.peels_translucent_meshes(view) {
                selection.add("translucent", vec![]);
                if tone_operator(view.render.tone_mapping).is_some() {
                    selection.add("translucent_hdr", vec![]);
                }
            }
        }
        selection.out
    }
}

impl Scene {
    /// Whether `view` blends its translucent meshes into the rays in depth order
    /// (std::translucent): a DVR raycast view with meshes under its volume (directly or in depth
    /// groups), whatever
    /// their opacity now (a viewer's panel changes it while the scene is shown, without
    /// composing again). Other views blend them into the mesh layer's colour, behind the volume,
    /// as a group blends its own into its picture.
    pub fn peels_translucent_meshes(&self, view: &View) -> bool {
        view.kind.value == ViewKind::Raycast
            && view.render.compositing.value == Compositing::Dvr
            && self.has_layer_mesh(&view.picture.under, 0)
    }

    /// The lights of `view` whose shading of the volume the meshes of a shadow group in its
    /// tree shadow (`std::mesh_shadow`): the named lights its shadow groups follow, among the
    /// view's lights, each once, when the view shades a raycast picture with them.
    pub fn mesh_shadow_lights(&self, view: &View) -> Vec<String> {
        let r = &view.render;
        let lit = r.shading && view.kind.value == ViewKind::Raycast && r.compositing.value != Compositing::Pathtrace;
        let mut out = Vec::new();
        if lit {
            self.followed_lights(&view.picture.under, 0, &mut out);
        }
        out.retain(|name| r.lights.iter().any(|l| l.name == *name));
        out
    }

    /// The named lights that the shadow groups in `nodes` follow, in tree order, each once.
    fn followed_lights(&self, nodes: &[Node], depth: usize, out: &mut Vec<String>) {
        for node in nodes {
            let Node::Group(g) = node else { continue };
            let Some(group) = self.groups.get(*g).filter(|_| depth < MAX_GROUP_DEPTH) else { continue };
            if let GroupKind::Shadow { light: ShadowLight::Light(name) } = &group.kind
                && !out.contains(&name.name)
            {
                out.push(name.name.clone());
            }
            self.followed_lights(&group.children, depth + 1, out);
        }
    }

    /// Whether `nodes` hold a mesh directly or through depth groups (whose meshes are drawn as
    /// if listed in their place), not counting occlusion and shadow groups (which blend their
    /// own); `depth` bounds the search where a scene made by hand has a cycle.
    fn has_layer_mesh(&self, nodes: &[Node], depth: usize) -> bool {
        nodes.iter().any(|node| match node {
            Node::Mesh(_) => true,
            Node::Group(g) => self.groups.get(*g).is_some_and(|group| {
                // Children a filter follows are drawn into the filter's own images.
                let after_filters =
                    group.children.iter().rposition(|c| matches!(c, Node::Filter(_))).map_or(0, |i| i + 1);
                group.kind == GroupKind::Depth
                    && depth < MAX_GROUP_DEPTH
                    && self.has_layer_mesh(&group.children[after_filters..], depth + 1)
            }),
            Node::Plane(_) | Node::Image(_) | Node::Filter(_) => false,
        })
    }
}

/// The standard modules chosen so far for one view, in order.
struct Selection<'v> {
    view: &'v View,
    out: Vec<StdModule>,
    /// The names of the additional volumes (instances of the per-volume modules).
    additional: Vec<String>,
}

impl Selection<'_> {
    fn add(&mut self, name: &'static str, instances: Vec<String>) {
        self.out.push(StdModule { name, instances });
    }

    /// Instances for a per-volume module: one per additional volume (`None`: there are none).
    fn per_additional(&self) -> Option<Vec<String>> {
        (!self.additional.is_empty()).then(|| self.additional.clone())
    }

    /// The ray or slice set-up, sampling, gradients, classification, masks, tags and lights.
    fn sampling_and_classification(&mut self, scene: &Scene) {
        let r = &self.view.render;
        match self.view.kind.value {
            ViewKind::Raycast => self.add("raycast", vec![]),
            ViewKind::Slice => self.add("slice", vec![]),
        }
        self.add("march", vec![]);
        self.add("background", vec![]);
        self.add("sample_primary", vec![]);
        if let Some(volumes) = self.per_additional() {
            self.add("sample_volume", volumes);
        }
        // The path tracer scatters off surfaces along the gradient, lit or not.
        let traced = r.compositing.value == Compositing::Pathtrace;
        if r.shading || r.boundary || traced {
            self.add("gradient", vec![]);
        }
        // After `gradient`, before `light` and `tone`: its `ray.setup` and `sampling.gradient`
        // functions must run before theirs and after `sample_gradient`.
        if r.shading || traced {
            self.add("normal", vec![]);
        }
        self.add("classify", vec![]);
        if let Some(volumes) = self.per_additional() {
            self.add("classify_volume", volumes);
        }
        // After `classify`: their functions append to `classification.primary`.
        let masks = scene.volume_names(Role::Mask);
        if !masks.is_empty() {
            self.add("mask", masks);
        }
        let tags = scene.volume_names(Role::Tag);
        if !tags.is_empty() {
            self.add("tag", tags);
        }
        if r.shading && !r.lights.is_empty() {
            self.add("light", r.lights.iter().map(|l| l.name.clone()).collect());
        }
        if r.boundary {
            self.add("boundary", vec![]);
        }
        if r.tone {
            self.add("tone", vec![]);
        }
    }

    /// The compositing step: its common module, lighting, and the mode's modules.
    fn compositing(&mut self) {
        let r = &self.view.render;
        self.add("composite", vec![]);
        if r.shading && r.compositing.value != Compositing::Pathtrace {
            self.add("lighting", vec![]);
        }
        match r.compositing.value {
            Compositing::Dvr => {
                self.add("composite_dvr", vec![]);
                if let Some(volumes) = self.per_additional() {
                    self.add("composite_volume", volumes);
                }
            }
            Compositing::Mip => self.add("composite_mip", vec![]),
            Compositing::Iso => self.add("composite_iso", vec![]),
            Compositing::Minip => self.add("composite_minip", vec![]),
            Compositing::Average => self.add("composite_average", vec![]),
            Compositing::Pathtrace => {
                self.add("pathtrace", vec![]);
                // After `light`: every light casts shadow rays, which run just before its
                // substep, and then each light's substep is replaced by the path tracer's.
                if r.shading && !r.lights.is_empty() {
                    let lights: Vec<String> = r.lights.iter().map(|l| l.name.clone()).collect();
                    self.add("shadow_ray", lights.clone());
                    self.add("path_light", lights);
                }
            }
        }
    }

    /// Modules that follow every function above: skipping, pre-integration, shadows and HDR.
    fn late_modules(&mut self) {
        let (r, kind) = (&self.view.render, self.view.kind.value);
        // Last: its functions append to `ray.setup` and `end` after the ones above.
        if r.empty_space_skipping
            && kind == ViewKind::Raycast
            && let Some(module) = skip_module(r.compositing.value)
        {
            self.add(module, vec![]);
        }
        // After `classify`: it replaces `classify_primary`.
        if r.preintegration != Preintegration::Off && r.compositing.value == Compositing::Dvr {
            self.add("preintegrate", vec![]);
        }
        // After `lighting`: it replaces `apply_lighting`.
        if r.ambient_occlusion && r.shading {
            self.add("occlusion", vec![]);
        }
        // After `light`: each shadow runs just before its light's substep.
        if let Some(module) = shadow_module(r.shadows)
            && r.shading
            && !r.lights.is_empty()
        {
            self.add(module, r.lights.iter().map(|l| l.name.clone()).collect());
        }
        // After `preintegrate` (it reads the segment's front value) and after every light and
        // shadow (it follows the last substep of `shading.lights`).
        if r.preintegration == Preintegration::Lighting && r.shading && r.compositing.value == Compositing::Dvr {
            self.add("preintegrate_lighting", vec![]);
        }
        // Last: `linear_color` follows every classification function, and `expose`, the
        // operator and `encode_srgb` run in that order just before `blend_background` (after
        // `average_finish`).
        if let Some(operator) = tone_operator(r.tone_mapping) {
            self.add("hdr", vec![]);
            if let Some(volumes) = self.per_additional() {
                self.add("hdr_volume", volumes);
            }
            self.add(operator, vec![]);
            if r.auto_exposure {
                self.add("auto_exposure", vec![]);
            }
        }
    }
}

/// The module of a shadow method, instantiated per light (`None`: no shadows).
fn shadow_module(shadows: Shadows) -> Option<&'static str> {
    match shadows {
        Shadows::Off => None,
        Shadows::Rays => Some("shadow_ray"),
        Shadows::Volume => Some("shadow_volume"),
    }
}

/// The tone operator module of a tone mapping (`None`: no HDR).
fn tone_operator(tone_mapping: ToneMapping) -> Option<&'static str> {
    match tone_mapping {
        ToneMapping::Off => None,
        ToneMapping::Exposure => Some("tonemap_exposure"),
        ToneMapping::Reinhard => Some("tonemap_reinhard"),
        ToneMapping::Aces => Some("tonemap_aces"),
    }
}

/// The empty-space skipping module of a compositing mode: each skips exactly what cannot change
/// its image (DVR: bricks the transfer function makes transparent; MIP: bricks whose maximum
/// cannot beat the ray's; iso: bricks entirely below the iso value). MinIP and average read
/// every sample of the ray, so nothing can be skipped exactly.
fn skip_module(compositing: Compositing) -> Option<&'static str> {
    match compositing {
        Compositing::Dvr => Some("skip"),
        Compositing::Mip => Some("skip_mip"),
        Compositing::Iso => Some("skip_iso"),
        Compositing::Minip | Compositing::Average | Compositing::Pathtrace => None,
    }
}
