//! Limits on the counts a scene controls. Each light, instance, module and view adds code that
//! every view composes (a light is a substep with its own uniforms; an instance copies its
//! template), so these counts bound the size of the shaders and the time to build and compile
//! them; volumes are bounded by the textures WebGPU guarantees a shader. A count past its limit
//! is an E0702 at the first entry past it, before anything is composed.

use crate::diag::{Code, Diagnostic};
use crate::scene::{ModuleRef, Scene};
use crate::source::Span;

/// Lights of `[render] lights`.
pub const MAX_LIGHTS: usize = 16;
/// Instances of one template module.
pub const MAX_INSTANCES: usize = 64;
/// Modules a view composes: the scene's `[[module]]`s and its own `modules` together.
pub const MAX_MODULES_PER_VIEW: usize = 64;
/// `[[view]]` tables.
pub const MAX_VIEWS: usize = 32;
/// `[[volume]]` tables: each takes two of the 16 sampled textures (and samplers) WebGPU
/// guarantees a shader, its samples and its transfer function; one is kept for empty-space
/// skipping's occupancy grid.
pub const MAX_VOLUMES: usize = 7;

/// Every count of `scene` past its limit.
pub fn check_counts(scene: &Scene) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let mut limit = |spans: &[Span], max: usize, what: &str, why: &str| {
        if let Some(&span) = spans.get(max) {
            out.push(
                Diagnostic::new(Code::SceneInvalid, span, format!("too many {what}: {} (at most {max})", spans.len()))
                    .with_label(format!("the {}th", max + 1))
                    .with_note(why.to_string()),
            );
        }
    };
    let lights: Vec<Span> = scene.render.lights.iter().map(|l| l.span).collect();
    limit(&lights, MAX_LIGHTS, "lights", "every light is evaluated at every sample of every ray");
    let views: Vec<Span> = scene.views.iter().map(|v| v.span).collect();
    limit(&views, MAX_VIEWS, "views", "every view is a shader of its own");
    let volumes: Vec<Span> = scene.volumes.iter().map(|v| v.span).collect();
    limit(&volumes, MAX_VOLUMES, "volumes", "each volume takes two of the 16 textures a shader can sample");
    let mut seen_modules: Vec<&ModuleRef> = Vec::new();
    for view in &scene.views {
        let modules: Vec<Span> = scene.modules.iter().chain(&view.modules).map(|m| m.span).collect();
        limit(
            &modules,
            MAX_MODULES_PER_VIEW,
            "modules in one view",
            "each module's functions are composed into the view",
        );
        for module in scene.modules.iter().chain(&view.modules) {
            if seen_modules.iter().any(|m| std::ptr::eq(*m, module)) {
                continue;
            }
            seen_modules.push(module);
            let instances: Vec<Span> = module.instances.iter().flatten().map(|i| i.span).collect();
            limit(
                &instances,
                MAX_INSTANCES,
                "instances of one module",
                "each instance is a copy of the template's functions",
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(render: &str, extra: &str) -> Scene {
        let text = format!(
            "[render]\n{render}\n\n[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"head\"\n\n{extra}[[view]]\nname = \"3d\"\nkind = \"raycast\"\n"
        );
        let mut diags = crate::diag::Diagnostics::new();
        crate::scene::parse_scene_text(&text, 1, std::path::Path::new("."), &mut diags).expect("a valid scene")
    }

    fn names(n: usize) -> String {
        (0..n).map(|i| format!("\"l{i}\"")).collect::<Vec<_>>().join(", ")
    }

    #[test]
    fn lights_are_limited() {
        assert!(check_counts(&scene(&format!("shading = true\nlights = [{}]", names(MAX_LIGHTS)), "")).is_empty());
        let over = check_counts(&scene(&format!("shading = true\nlights = [{}]", names(MAX_LIGHTS + 1)), ""));
        assert_eq!(over.len(), 1, "{over:?}");
        assert_eq!(over[0].message, format!("too many lights: {} (at most {MAX_LIGHTS})", MAX_LIGHTS + 1));
    }

    #[test]
    fn instances_are_limited_once_per_module() {
        let module = |n: usize| format!("[[module]]\npath = \"m.vrs\"\ninstances = [{}]\n\n", names(n));
        assert!(check_counts(&scene("", &module(MAX_INSTANCES))).is_empty());
        let over = check_counts(&scene("", &module(MAX_INSTANCES + 1)));
        assert_eq!(over.len(), 1, "{over:?}");
        assert!(over[0].message.starts_with("too many instances of one module"), "{over:?}");
    }

    #[test]
    fn views_and_modules_per_view_are_limited() {
        let view = |i: usize| format!("[[view]]\nname = \"v{i}\"\nkind = \"slice\"\naxis = \"z\"\n\n");
        let views = |n: usize| (0..n).map(view).collect::<String>();
        // The helper adds one view of its own.
        assert!(check_counts(&scene("", &views(MAX_VIEWS - 1))).is_empty());
        let over = check_counts(&scene("", &views(MAX_VIEWS)));
        assert!(over.len() == 1 && over[0].message.starts_with("too many views"), "{over:?}");
        let module = |i: usize| format!("[[module]]\npath = \"m{i}.vrs\"\n\n");
        let modules = |n: usize| (0..n).map(module).collect::<String>();
        assert!(check_counts(&scene("", &modules(MAX_MODULES_PER_VIEW))).is_empty());
        let over = check_counts(&scene("", &modules(MAX_MODULES_PER_VIEW + 1)));
        assert!(over.len() == 1 && over[0].message.starts_with("too many modules in one view"), "{over:?}");
    }

    #[test]
    fn volumes_are_limited() {
        let volume = |i: usize| format!("[[volume]]\nname = \"w{i}\"\nrole = \"additional\"\nphantom = \"head\"\n\n");
        let extra = |n: usize| (0..n).map(volume).collect::<String>();
        assert!(check_counts(&scene("", &extra(MAX_VOLUMES - 1))).is_empty());
        let over = check_counts(&scene("", &extra(MAX_VOLUMES)));
        assert_eq!(over.len(), 1, "{over:?}");
        assert!(over[0].message.starts_with("too many volumes"), "{over:?}");
    }
}
