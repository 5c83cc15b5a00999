//! The scene against the composed views' uniforms: every `[uniforms]` entry must name a
//! uniform that some view reads (E0702 with a did-you-mean otherwise; W0701 where a standard
//! module the scene's options leave out declares it), and its value must have
//! that uniform's type and length (E0702 at the value); every `volume` and `tf` uniform a view
//! reads must be one the runtime binds for this scene (E0608 at its declaration). The runtime
//! sets values and binds resources by the same rules, so a scene that `build` accepts never
//! fails there for its uniforms. A value outside the range the uniform declares (`in lo .. hi`,
//! the span its module means and the viewer's slider covers) is used as given, with a warning
//! (W0702 at the value): `[uniforms]` entries and the `[render]` keys that set uniforms alike.

use super::ir::Composition;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir::{ConstValue, ScalarValue};
use crate::scene::{Role, Scene, UniformSetting, UniformValue};
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};

/// Checks `scene.uniforms` against the uniforms of `views` (the composed views). `all_views`
/// says whether `views` holds every view of the scene without errors: only then is a name that
/// no view reads known to be a mistake.
pub fn check_scene_uniforms(scene: &Scene, views: &[&Composition], all_views: bool, diags: &mut Diagnostics) {
    for (name, setting) in &scene.uniforms {
        let declared = views.iter().flat_map(|c| c.uniforms.iter()).find(|u| u.name == *name);
        match declared {
            Some(u) => {
                if let Some(why) = mismatch(u.ty, &setting.value) {
                    diags.push(wrong_value(name, u.ty, setting, &why));
                }
            }
            None if all_views => diags.push(match std_module_declaring(name) {
                Some(module) => left_out(name, setting, module),
                None => unknown(name, setting, views),
            }),
            None => {}
        }
    }
    check_ranges(scene, views, diags);
}

/// W0702 for every value the scene gives a uniform outside the range a view declares for it
/// (values of another type are E0702 above, and not compared).
fn check_ranges(scene: &Scene, views: &[&Composition], diags: &mut Diagnostics) {
    for (name, value, span) in scene.placed_uniform_values() {
        let declared = views.iter().flat_map(|c| c.uniforms.iter()).filter(|u| u.name == name);
        let Some((u, (lo, hi))) = declared.filter_map(|u| Some((u, u.range.as_ref()?))).next() else { continue };
        if mismatch(u.ty, &value).is_some() {
            continue;
        }
        let (lo_values, hi_values) = (numbers(lo), numbers(hi));
        let outside = value.flatten().iter().enumerate().any(|(i, &x)| {
            let at = |list: &[f64]| list.get(i).or(list.first()).copied();
            at(&lo_values).is_some_and(|lo| x < lo) || at(&hi_values).is_some_and(|hi| x > hi)
        });
        if outside {
            let range = format!("{} .. {}", bound(&lo_values), bound(&hi_values));
            diags.push(
                Diagnostic::new(
                    Code::SceneUniformRange,
                    span,
                    format!("`{name} = {}` is outside its declared range {range}", shown(&value.flatten())),
                )
                .with_label(format!("outside {range}"))
                .with_secondary(u.span, "the range is declared here")
                .with_note("the shader uses the value as given; the range is what the module means it for"),
            );
        }
    }
}

/// The components of a range bound as numbers.
fn numbers(value: &ConstValue) -> Vec<f64> {
    let number = |c: &ScalarValue| match *c {
        ScalarValue::Bool(b) => f64::from(u8::from(b)),
        ScalarValue::I32(i) => f64::from(i),
        ScalarValue::U32(u) => f64::from(u),
        ScalarValue::F32(x) => f64::from(x),
    };
    value.components.iter().map(number).collect()
}

/// Numbers as a scene writes them (`4.0`, not `4`): one alone, several in brackets.
fn shown(values: &[f64]) -> String {
    let each: Vec<String> = values.iter().map(|x| format!("{:?}", *x as f32)).collect();
    match each.as_slice() {
        [one] => one.clone(),
        _ => format!("[{}]", each.join(", ")),
    }
}

/// A range's bound: one number when it is the same for every component.
fn bound(values: &[f64]) -> String {
    let each: Vec<String> = values.iter().map(|x| format!("{:?}", *x as f32)).collect();
    match each.as_slice() {
        [one, rest @ ..] if rest.iter().all(|r| r == one) => one.clone(),
        _ => format!("[{}]", each.join(", ")),
    }
}

fn unknown(name: &str, setting: &UniformSetting, views: &[&Composition]) -> Diagnostic {
    let mut names: Vec<&str> = views.iter().flat_map(|c| c.uniforms.iter()).map(|u| u.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    let mut d = Diagnostic::new(Code::SceneInvalid, setting.name_span, format!("no view reads a uniform `{name}`"))
        .with_label("not a uniform of any composed view");
    d = match did_you_mean(name, names.iter().copied()) {
        Some(best) => d.with_help(format!("did you mean `{best}`?")),
        None => d.with_note("a `[uniforms]` entry sets the initial value of a uniform that a module declares"),
    };
    d
}

/// W0701 for a value of a uniform that a standard module declares but no view reads: the
/// scene's options leave that module (or the function) out, as `shading = false` leaves out
/// std::light and its `light_dir_NAME`. The value is kept for when the option is on again.
fn left_out(name: &str, setting: &UniformSetting, module: &str) -> Diagnostic {
    Diagnostic::new(Code::SceneIgnored, setting.name_span, format!("no view reads `{name}` with these settings"))
        .with_label("ignored")
        .with_note(format!(
            "`{name}` is a uniform of std::{module}, which the scene's options leave out of every view (`shading = false` leaves out the lights)"
        ))
        .with_help("the value applies again when an option selects the module; remove it to silence this")
}

/// The standard module that declares uniform `name`, as written or as an instance of a template
/// (`light_dir_$` declares `light_dir_key`).
fn std_module_declaring(name: &str) -> Option<&'static str> {
    std_uniforms().iter().find(|(_, declared)| matches_template(declared, name)).map(|(module, _)| *module)
}

/// Whether `name` is `declared`, or an instance of it when it holds `$` (any non-empty name in
/// its place).
fn matches_template(declared: &str, name: &str) -> bool {
    match declared.split_once('$') {
        None => declared == name,
        Some((before, after)) => {
            name.len() > before.len() + after.len() && name.starts_with(before) && name.ends_with(after)
        }
    }
}

/// Every uniform the standard modules' pipeline functions declare, with the module: parsed once.
fn std_uniforms() -> &'static [(&'static str, String)] {
    static UNIFORMS: std::sync::OnceLock<Vec<(&'static str, String)>> = std::sync::OnceLock::new();
    UNIFORMS.get_or_init(|| {
        let mut out = Vec::new();
        for (module, text) in crate::stdlib::modules() {
            let mut diags = Diagnostics::new();
            let lexed = crate::lexer::lex(text, 0, &mut diags);
            let parsed = crate::parser::parse_module(&lexed, 0, text.len() as u32, &mut diags);
            for item in &parsed.items {
                let crate::ast::ItemKind::Pipeline(f) = &item.kind else { continue };
                for decl in &f.decls {
                    if let crate::ast::DeclKind::Uniform { name, .. } = &decl.kind {
                        out.push((module, name.name.clone()));
                    }
                }
            }
        }
        out
    })
}

fn wrong_value(name: &str, ty: Type, setting: &UniformSetting, why: &str) -> Diagnostic {
    Diagnostic::new(Code::SceneInvalid, setting.span, format!("`{name}` is a {ty}, but {why}"))
        .with_label(format!("not a value of type {ty}"))
        .with_help(format!("write {}", example(ty)))
}

/// A value of `ty` as TOML, for the help line.
fn example(ty: Type) -> String {
    let scalar = |s: Scalar| match s {
        Scalar::F32 => "0.5",
        Scalar::I32 => "1",
        Scalar::U32 => "1",
        Scalar::Bool => "true",
    };
    match ty {
        Type::Scalar(s) => format!("a {}: `{}`", s.name(), scalar(s)),
        Type::Vector { size, scalar: s } => {
            format!("{size} {}s: `[{}]`", s.name(), vec![scalar(s); size as usize].join(", "))
        }
        Type::Matrix { cols, rows } => {
            let column = format!("[{}]", vec!["0.0"; rows as usize].join(", "));
            format!("{cols} columns of {rows} f32s: `[{}]`", vec![column; cols as usize].join(", "))
        }
        other => format!("no value: a {other} is bound by the renderer"),
    }
}

/// Why `value` cannot initialise a uniform of type `ty`, if it cannot.
fn mismatch(ty: Type, value: &UniformValue) -> Option<String> {
    let (shape, scalar) = match ty {
        Type::Scalar(s) => (vec![], s),
        Type::Vector { size, scalar } => (vec![size as usize], scalar),
        Type::Matrix { cols, rows } => (vec![cols as usize, rows as usize], Scalar::F32),
        _ => return Some(String::from("it is a resource, which `[uniforms]` cannot set")),
    };
    let got = value.shape();
    if got != shape {
        return Some(match got.as_slice() {
            [] => String::from("this value is a single number"),
            [n] => format!("this value is an array of {n}"),
            [c, r] => format!("this value is {c} arrays of {r}"),
            _ => String::from("this value nests too deep"),
        });
    }
    leaves(value).into_iter().find_map(|v| scalar_mismatch(scalar, v))
}

fn leaves(value: &UniformValue) -> Vec<&UniformValue> {
    match value {
        UniformValue::Array(items) => items.iter().flat_map(leaves).collect(),
        leaf => vec![leaf],
    }
}

fn scalar_mismatch(scalar: Scalar, v: &UniformValue) -> Option<String> {
    match (scalar, v) {
        (Scalar::Bool, UniformValue::Bool(_)) => None,
        (Scalar::Bool, _) => Some(String::from("this value is a number (write `true` or `false`)")),
        (_, UniformValue::Bool(_)) => Some(String::from("this value is a bool")),
        (Scalar::F32, UniformValue::Float(x)) if x.is_finite() && x.abs() <= f64::from(f32::MAX) => None,
        (Scalar::F32, UniformValue::Float(x)) => Some(format!("{x} does not fit in f32")),
        (Scalar::F32, UniformValue::Int(_)) => None,
        (Scalar::I32, UniformValue::Int(i)) if i32::try_from(*i).is_ok() => None,
        (Scalar::U32, UniformValue::Int(i)) if u32::try_from(*i).is_ok() => None,
        (Scalar::I32 | Scalar::U32, UniformValue::Int(i)) => Some(format!("{i} does not fit in {}", scalar.name())),
        (Scalar::I32 | Scalar::U32, _) => Some(String::from("this value is not a whole number")),
        (_, UniformValue::Array(_)) => Some(String::from("this value nests too deep")),
    }
}

/// The `volume`, `tf` and `image` uniforms the runtime binds for `scene`'s ray pipelines: `volume` and `tf` (the primary
/// volume), `volume_NAME` for every other volume and `tf_NAME` for those with a transfer
/// function (all but masks), `tf_preint` and `tf_preint_back` (built from the primary's
/// transfer function when a view reads them), the grids of empty-space skipping, `occupancy` and `brick_max`, when
/// some raycast view skips, the light volumes, and `mesh_shadow_map_NAME` for each light a
/// shadow group follows in a view that shades with it.
pub fn bound_resources(scene: &Scene) -> Vec<(String, Type)> {
    let mut out = vec![("volume".to_string(), Type::Volume), ("tf".to_string(), Type::Tf)];
    out.push((PREINTEGRATION_TABLE.to_string(), Type::Tf));
    out.push((PREINTEGRATION_WEIGHTS.to_string(), Type::Tf));
    for v in scene.volumes.iter().filter(|v| v.role.value != Role::Primary) {
        out.push((format!("volume_{}", v.name.name), Type::Volume));
        if v.role.value != Role::Mask {
            out.push((format!("tf_{}", v.name.name), Type::Tf));
        }
    }
    if scene.skips_empty_space() {
        out.extend(["occupancy", "brick_max"].map(|n| (n.to_string(), Type::Volume)));
    }
    for light in scene.volume_shadow_lights() {
        out.push((format!("{LIGHT_VOLUME_PREFIX}{light}"), Type::Volume));
    }
    for light in scene.views.iter().flat_map(|v| scene.mesh_shadow_lights(v)) {
        let name = format!("{}{light}", super::view::MESH_SHADOW_MAP_PREFIX);
        if !out.iter().any(|(n, _)| *n == name) {
            out.push((name, Type::Image));
        }
    }
    out
}

/// The uniform of light NAME's light volume (`std::shadow_volume`) is this prefix and NAME.
pub const LIGHT_VOLUME_PREFIX: &str = "shadow_volume_";

/// The uniform of `std::preintegrate`'s table.
pub const PREINTEGRATION_TABLE: &str = "tf_preint";

/// The uniform of `std::preintegrate_lighting`'s table of segment weights.
pub const PREINTEGRATION_WEIGHTS: &str = "tf_preint_back";

/// Checks that every resource uniform of each composed view (named) is one the runtime binds.
pub fn check_resources(scene: &Scene, views: &[(&str, &Composition)], diags: &mut Diagnostics) {
    let bound = bound_resources(scene);
    for (view, composition) in views {
        for u in composition.uniforms.iter().filter(|u| u.ty.is_resource()) {
            if bound.iter().any(|(name, ty)| *name == u.name && *ty == u.ty) {
                continue;
            }
            diags.push(unbound(view, u, &bound));
        }
    }
}

fn unbound(view: &str, u: &super::ir::Uniform, bound: &[(String, Type)]) -> Diagnostic {
    let kind = match u.ty {
        Type::Volume => "volume",
        Type::Image => "image",
        _ => "transfer function",
    };
    let names: Vec<&str> = bound.iter().filter(|(_, ty)| *ty == u.ty).map(|(n, _)| n.as_str()).collect();
    let mut d = Diagnostic::new(
        Code::UnboundResource,
        u.span,
        format!("view `{view}` reads the {kind} `{}`, which this scene does not have", u.name),
    )
    .with_label(format!("a `{}` uniform", u.ty))
    .with_note(format!("this scene binds: {}", names.join(", ")));
    if u.ty == Type::Image {
        return d.with_help("an image is a buffer of the view's picture, which only a filter pass reads: list the module in the view's `filters`");
    }
    d = match did_you_mean(&u.name, names.iter().copied()) {
        Some(best) => d.with_help(format!("did you mean `{best}`?")),
        None => d.with_help(
            "a volume's uniform is `volume_NAME` and its transfer function's `tf_NAME` for a [[volume]] named \
             NAME (`volume` and `tf` for the primary one); add that volume to the scene",
        ),
    };
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use UniformValue::{Array, Bool, Float, Int};

    #[test]
    fn a_uniform_of_a_left_out_standard_module_is_told_from_a_typo() {
        assert_eq!(std_module_declaring("light_dir_key"), Some("light"), "an instance of `light_dir_$`");
        assert_eq!(std_module_declaring("exposure"), Some("hdr"));
        assert_eq!(std_module_declaring("light_dri_key"), None, "a typo");
        assert_eq!(std_module_declaring("light_dir_"), None, "`$` stands for a non-empty name");
    }

    #[test]
    fn shapes_and_kinds() {
        let vec2f = Type::vec(2, Scalar::F32);
        assert_eq!(mismatch(vec2f, &Array(vec![Float(0.1), Int(1)])), None);
        assert!(
            mismatch(vec2f, &Array(vec![Float(0.07), Float(0.11), Float(0.2)]))
                .is_some_and(|m| m.contains("array of 3"))
        );
        assert!(mismatch(Type::BOOL, &Int(0)).is_some_and(|m| m.contains("true")));
        assert_eq!(mismatch(Type::BOOL, &Bool(false)), None);
        assert!(mismatch(Type::U32, &Int(-1)).is_some());
        assert!(mismatch(Type::I32, &Float(1.5)).is_some());
        assert!(mismatch(Type::F32, &Float(1e300)).is_some());
        let m2 = Type::Matrix { cols: 2, rows: 2 };
        assert_eq!(mismatch(m2, &Array(vec![Array(vec![Int(1), Int(0)]), Array(vec![Int(0), Int(1)])])), None);
        assert!(mismatch(m2, &Array(vec![Int(1), Int(0)])).is_some());
    }
}
