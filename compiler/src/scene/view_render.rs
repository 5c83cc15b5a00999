//! Per-view render settings and the display convention of slice views.
//!
//! A `[[view]]` may hold a `render` table with any `[render]` key; the view's settings are its
//! own keys over the shared `[render]` table. An inherited key that has no effect in the view
//! (`lights` or `tone` where the view turns shading off, `iso_value` where it picks another
//! compositing mode, `empty_space_skipping` where it picks one that never skips: MinIP, average)
//! is dropped without a warning: only what the view's table says itself is checked for effect.

use super::raw::RawRender;
use super::{Compositing, Cx, Render, Scene, UniformValue, View, ViewKind};
use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

/// How a slice view puts the patient's sides: `radiological` (the default) shows the patient's
/// right on the image's left, as if facing the patient or looking up from the feet;
/// `neurological` shows it on the right.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    /// `radiological` (the default): the patient's right on the image's left.
    #[default]
    Radiological,
    /// `neurological`: the patient's right on the image's right.
    Neurological,
}

impl Compositing {
    /// The name the scene writes (`compositing = "NAME"`).
    pub fn name(self) -> &'static str {
        match self {
            Compositing::Dvr => "dvr",
            Compositing::Mip => "mip",
            Compositing::Iso => "iso",
            Compositing::Minip => "minip",
            Compositing::Average => "average",
            Compositing::Pathtrace => "pathtrace",
        }
    }
}

impl Scene {
    /// Initial uniform values of `view`: `[uniforms]` and what its render settings set.
    pub fn view_uniform_values(&self, view: &View) -> BTreeMap<String, UniformValue> {
        self.uniform_values_with(&view.render)
    }

    /// The lights that cast volume shadows (`shadows = "volume"`) in some view, each once, in
    /// view order: the runtime computes a light volume for each.
    pub fn volume_shadow_lights(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        let shadowed = self.views.iter().filter(|v| v.render.shading && v.render.shadows == super::Shadows::Volume);
        for light in shadowed.flat_map(|v| &v.render.lights) {
            if !out.contains(&light.name) {
                out.push(light.name.clone());
            }
        }
        out
    }

    /// Whether some raycast view skips empty space (the runtime then keeps the primary
    /// volume's samples to build the occupancy grid).
    pub fn skips_empty_space(&self) -> bool {
        self.views.iter().any(|v| v.kind.value == ViewKind::Raycast && v.render.empty_space_skipping)
    }
}

impl Cx<'_> {
    /// A view's render settings: its own `render` table over the shared one, validated.
    pub(super) fn view_render(&mut self, shared: Option<&Spanned<RawRender>>, own: &Spanned<RawRender>) -> Render {
        let r = own.get_ref();
        for (key, value) in [("memory", &r.memory), ("host_memory", &r.host_memory)] {
            if let Some(value) = value {
                self.ignored(value, key, "in a view: memory budgets are the scene's (`[render]`)");
            }
        }
        let merged = merge(shared.map(|s| s.get_ref()), own.get_ref());
        self.render(Some(Spanned::new(own.span(), merged)))
    }
}

/// `own`'s keys over `shared`'s, without the inherited keys that have no effect with `own`'s
/// compositing mode and shading.
fn merge(shared: Option<&RawRender>, own: &RawRender) -> RawRender {
    let base = shared.cloned().unwrap_or_default();
    let own = own.clone();
    let compositing = own.compositing.or(base.compositing);
    let shading = own.shading.or(base.shading);
    let mode = compositing.as_ref().map_or(Compositing::Dvr, |c| *c.get_ref());
    let shaded = shading.as_ref().is_some_and(|s| *s.get_ref());
    RawRender {
        iso_value: own.iso_value.or(base.iso_value.filter(|_| mode == Compositing::Iso)),
        lights: own.lights.or(base.lights.filter(|_| shaded)),
        tone: own.tone.or(base.tone.filter(|_| shaded)),
        // Every mode that skips takes the shared choice (MIP and iso dropped it, and skipped
        // where the scene said not to); MinIP and average never skip.
        empty_space_skipping: own.empty_space_skipping.or(base
            .empty_space_skipping
            .filter(|_| matches!(mode, Compositing::Dvr | Compositing::Mip | Compositing::Iso))),
        compositing,
        shading,
        boundary: own.boundary.or(base.boundary),
        step_size: own.step_size.or(base.step_size),
        max_samples: own.max_samples.or(base.max_samples),
        jitter: own.jitter.or(base.jitter),
        background: own.background.or(base.background),
        tone_mapping: own.tone_mapping.or(base.tone_mapping),
        exposure: own.exposure.or(base.exposure),
        auto_exposure: own.auto_exposure.or(base.auto_exposure),
        white_point: own.white_point.or(base.white_point),
        preintegration: own.preintegration.or(base.preintegration.filter(|_| mode == Compositing::Dvr)),
        shadows: own.shadows.or(base.shadows.filter(|_| shaded)),
        ambient_occlusion: own.ambient_occlusion.or(base.ambient_occlusion.filter(|_| shaded)),
        // Budgets are the scene's: a view's own is reported as ignored, the shared one not
        // inherited.
        memory: own.memory,
        host_memory: own.host_memory,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_text;
    use std::path::Path;

    const SCENE: &str = "[render]\nshading = true\nlights = [\"key\", \"fill\"]\ntone = true\nstep_size = 0.4\n\n\
        [[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n\n\
        [[view]]\nname = \"3d\"\n\n\
        [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nconvention = \"neurological\"\n\
        render = { shading = false, compositing = \"minip\" }\n";

    /// The scene of `text` and its diagnostics.
    fn parse(text: &str) -> (Option<Scene>, Vec<crate::diag::Diagnostic>) {
        let mut diags = crate::diag::Diagnostics::new();
        let scene = parse_scene_text(text, 0, Path::new("."), &mut diags);
        (scene, diags.sorted())
    }

    fn modules(scene: &Scene, view: &str) -> Vec<&'static str> {
        scene.standard_modules(scene.view(view).expect("view")).iter().map(|m| m.name).collect()
    }

    #[test]
    fn a_view_render_table_overrides_the_shared_one_key_by_key() {
        let (scene, diagnostics) = parse(SCENE);
        assert!(diagnostics.is_empty(), "inherited keys without effect are dropped silently: {diagnostics:?}");
        let scene = scene.expect("a valid scene");
        let (shaded, flat) = (&scene.views[0], &scene.views[1]);
        assert!(shaded.render.shading && shaded.render.tone && shaded.render.lights.len() == 2);
        assert!(!flat.render.shading && !flat.render.tone && flat.render.lights.is_empty());
        assert_eq!(flat.render.compositing.value, Compositing::Minip);
        assert!(modules(&scene, "3d").contains(&"light") && modules(&scene, "3d").contains(&"composite_dvr"));
        let axial = modules(&scene, "axial");
        assert!(axial.contains(&"composite_minip") && !axial.contains(&"light") && !axial.contains(&"gradient"));
        // Shared values the view does not replace carry over.
        let values = scene.view_uniform_values(flat);
        assert_eq!(values["step_size"], UniformValue::Float(f64::from(0.4f32)));
        assert_eq!((shaded.convention, flat.convention), (Convention::Radiological, Convention::Neurological));
        assert_eq!(flat.axis.as_ref().map(|a| a.value), Some(super::super::Axis::Z));
    }

    #[test]
    fn every_mode_that_skips_inherits_the_shared_skipping_choice() {
        for (mode, skips) in [("dvr", true), ("mip", true), ("iso", true), ("minip", false), ("average", false)] {
            let text = format!(
                "[render]\nempty_space_skipping = false\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\n\
                 phantom = \"head\"\n\n[[view]]\nname = \"3d\"\nrender = {{ compositing = \"{mode}\", iso_value = 0.5 }}\n"
            );
            let text = if mode == "iso" { text } else { text.replace(", iso_value = 0.5", "") };
            let (scene, diagnostics) = parse(&text);
            assert!(diagnostics.is_empty(), "{mode}: {diagnostics:?}");
            let scene = scene.expect("a valid scene");
            assert!(!scene.views[0].render.empty_space_skipping, "{mode} inherits `false`");
            assert!(!modules(&scene, "3d").iter().any(|m| m.starts_with("skip")), "{mode}");
            // And with the shared table silent, the mode's own default.
            let (scene, _) = parse(&text.replace("empty_space_skipping = false\n", ""));
            assert_eq!(scene.expect("a valid scene").views[0].render.empty_space_skipping, skips, "{mode}");
        }
    }

    #[test]
    fn a_view_render_table_is_validated_like_render() {
        let text = SCENE.replace("compositing = \"minip\"", "compositing = \"iso\"");
        let (scene, diagnostics) = parse(&text);
        assert!(scene.is_none(), "iso needs iso_value");
        assert!(diagnostics.iter().any(|d| d.message.contains("needs an `iso_value`")), "{diagnostics:?}");
        let text = SCENE.replace("compositing = \"minip\"", "compositing = \"mip\", frobnicate = 1");
        let (scene, diagnostics) = parse(&text);
        assert!(scene.is_none(), "unknown key");
        assert!(diagnostics.iter().any(|d| d.message.contains("unknown key `frobnicate`")), "{diagnostics:?}");
    }

    #[test]
    fn every_compositing_mode_has_a_standard_module() {
        for mode in ["dvr", "mip", "minip", "average"] {
            let text = format!(
                "[render]\ncompositing = \"{mode}\"\n[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n[[view]]\nname = \"3d\"\n"
            );
            let (scene, diagnostics) = parse(&text);
            let scene = scene.unwrap_or_else(|| panic!("{diagnostics:?}"));
            assert_eq!(scene.render.compositing.value.name(), mode);
            let wanted = format!("composite_{mode}");
            assert!(modules(&scene, "3d").iter().any(|m| *m == wanted), "{mode}");
            assert!(crate::stdlib::index(&wanted).is_some(), "stdlib/{wanted}.vrs exists");
        }
    }
}
