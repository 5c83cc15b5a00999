//! The standard modules a view is composed with: the selection policy of `stdlib/README.md`,
//! owned by the composer (the scene only says what the user asked for).

use crate::scene::{Compositing, Role, Scene, Shadows, ToneMapping, View, ViewKind};

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
        let r = &view.render;
        let mut out = Vec::new();
        let mut add = |name: &'static str, instances: Vec<String>| out.push(StdModule { name, instances });
        let additional = self.volume_names(Role::Additional);
        let additional_names = additional.clone();
        let masks = self.volume_names(Role::Mask);
        let tags = self.volume_names(Role::Tag);
        match view.kind.value {
            ViewKind::Raycast => add("raycast", vec![]),
            ViewKind::Slice => add("slice", vec![]),
        }
        add("march", vec![]);
        add("background", vec![]);
        add("sample_primary", vec![]);
        if !additional.is_empty() {
            add("sample_volume", additional.clone());
        }
        if r.shading || r.boundary {
            add("gradient", vec![]);
        }
        // After `gradient`, before `light` and `tone`: its `ray.setup` and `sampling.gradient`
        // functions must run before theirs and after `sample_gradient`.
        if r.shading {
            add("normal", vec![]);
        }
        add("classify", vec![]);
        if !additional.is_empty() {
            add("classify_volume", additional.clone());
        }
        // After `classify`: their functions append to `classification.primary`.
        if !masks.is_empty() {
            add("mask", masks);
        }
        if !tags.is_empty() {
            add("tag", tags);
        }
        if r.shading && !r.lights.is_empty() {
            add("light", r.lights.iter().map(|l| l.name.clone()).collect());
        }
        if r.boundary {
            add("boundary", vec![]);
        }
        if r.tone {
            add("tone", vec![]);
        }
        add("composite", vec![]);
        if r.shading {
            add("lighting", vec![]);
        }
        match r.compositing.value {
            Compositing::Dvr => {
                add("composite_dvr", vec![]);
                if !additional.is_empty() {
                    add("composite_volume", additional);
                }
            }
            Compositing::Mip => add("composite_mip", vec![]),
            Compositing::Iso => add("composite_iso", vec![]),
            Compositing::Minip => add("composite_minip", vec![]),
            Compositing::Average => add("composite_average", vec![]),
        }
        // Last: its functions append to `ray.setup` and `end` after the ones above.
        if r.empty_space_skipping
            && view.kind.value == ViewKind::Raycast
            && let Some(module) = skip_module(r.compositing.value)
        {
            add(module, vec![]);
        }
        // After `classify`: it replaces `classify_primary`.
        if r.preintegration && r.compositing.value == Compositing::Dvr {
            add("preintegrate", vec![]);
        }
        // After `light`: each shadow runs just before its light's substep.
        if let Some(module) = shadow_module(r.shadows)
            && r.shading
            && !r.lights.is_empty()
        {
            add(module, r.lights.iter().map(|l| l.name.clone()).collect());
        }
        // Last: `linear_color` follows every classification function, and `expose`, the
        // operator and `encode_srgb` run in that order just before `blend_background` (after
        // `average_finish`).
        if let Some(operator) = tone_operator(r.tone_mapping) {
            add("hdr", vec![]);
            if !additional_names.is_empty() {
                add("hdr_volume", additional_names);
            }
            add(operator, vec![]);
            if r.auto_exposure {
                add("auto_exposure", vec![]);
            }
        }
        // Last: `stop_at_meshes` follows the ray setup (and skipping's first walk), and
        // `blend_meshes` runs after `encode_srgb` (mesh colours are display colours).
        if Scene::has_mesh_layer(view) {
            add("meshes", vec![]);
        }
        out
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
        Compositing::Minip | Compositing::Average => None,
    }
}
