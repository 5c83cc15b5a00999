//! Probes: a state field of a view shown as an image. The composer makes the probe as a variant
//! of the view: it generates a VRS module with two pipeline functions, composes the view with it
//! placed last, and the image the variant renders encodes the field's value exactly. Nothing of
//! the shader is written by hand, so a user's field is probed like a standard one.
//!
//! The generated module (see [`probe_source`]):
//! - `probe_capture after end` copies the field into the `@ray` field `probe_value` (and sets
//!   `probe_hit`) at the sample the uniform `probe_mode` picks: 1, the first sample whose
//!   accumulated opacity `accum.a` reaches `probe_threshold` after that sample is composited;
//!   2, sample number `probe_sample` (0-based). The ray then ends, since nothing after the capture
//!   changes the probe.
//! - `probe_output after ray.finish` writes the value into `out_color` as the 32-bit words of
//!   `std::probe`, one render (pass) after another as `probe_pass` says; with `probe_mode` 0
//!   (`@ray` fields only) it takes the field as it is at `ray.finish` instead.
//!
//! Mode, threshold, sample and pass are uniforms, so changing them needs no new pipeline.
//! `docs/reference.md` ("Probes") states what a radiologist sees; `vrs_runtime::probe` decodes
//! the passes and colours the image.

use super::build::{self, BuiltScene, GeneratedModule, Keep, ViewOutput, ViewPass, ViewShader};
use super::instantiate::subst;
use super::ir::Composition;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir;
use crate::scene::Scene;
use crate::source::{SourceMap, Span};
use crate::steps::PipelineKind;
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};
use std::fmt::Write as _;
use std::path::Path;

/// The uniform that picks where the probe reads its field: [`ProbeAt::mode`].
pub const MODE_UNIFORM: &str = "probe_mode";
/// The accumulated opacity [`ProbeAt::Opacity`] waits for.
pub const THRESHOLD_UNIFORM: &str = "probe_threshold";
/// The sample [`ProbeAt::Sample`] reads.
pub const SAMPLE_UNIFORM: &str = "probe_sample";
/// Which of the value's passes a render shows (0 .. [`ProbeLayout::passes`]).
pub const PASS_UNIFORM: &str = "probe_pass";
/// The threshold of a sample field's probe when none is given.
pub const DEFAULT_THRESHOLD: f32 = 0.5;
/// The field that [`ProbeAt::Opacity`] reads the accumulated opacity from.
const ACCUM: &str = "accum";

/// Where along the ray a probe reads its field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeAt {
    /// As the field is at `ray.finish`: `@ray` fields only.
    Finish,
    /// At the first sample whose accumulated opacity `accum.a` is at least this, after that
    /// sample is composited.
    Opacity(f32),
    /// At this sample of the ray (0-based), after its `end` step.
    Sample(u32),
}

impl ProbeAt {
    /// Where a probe of a field with this lifetime reads it unless told otherwise: a `@ray` field
    /// at `ray.finish`, a sample field at accumulated opacity [`DEFAULT_THRESHOLD`].
    pub fn default_for(ray: bool) -> ProbeAt {
        if ray { ProbeAt::Finish } else { ProbeAt::Opacity(DEFAULT_THRESHOLD) }
    }

    /// The value of the uniform [`MODE_UNIFORM`].
    pub fn mode(self) -> u32 {
        match self {
            ProbeAt::Finish => 0,
            ProbeAt::Opacity(_) => 1,
            ProbeAt::Sample(_) => 2,
        }
    }

    /// "at ray.finish", "at the first sample with accum.a >= 0.5", "at sample 10".
    pub fn describe(self) -> String {
        match self {
            ProbeAt::Finish => "at ray.finish".into(),
            ProbeAt::Opacity(a) => format!("at the first sample with accum.a >= {a}"),
            ProbeAt::Sample(n) => format!("at sample {n}"),
        }
    }
}

/// A state field of a view's composed pipeline, as its functions declare it (kept in the
/// emitted struct or left out because nothing reads it).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeclaredField {
    /// The name a probe asks for: the field's name, instantiated (`color_gm`, not `color_$`);
    /// for a field of a filter in the view's tree, after the filter's label and a dot
    /// (`organs-2.picture_color`), since every filter pass declares the standard ones.
    pub name: String,
    /// The field's declared type.
    pub ty: Type,
    /// `@ray`: lives for the whole ray.
    pub ray: bool,
    /// The pass whose functions declare it: the view's raycaster, or a filter pass (whose fields
    /// all live for the pixel; a probe reads them at `filter.finish`).
    pub pass: ViewPass,
}

impl DeclaredField {
    /// Whether a probe can show the field: scalars and vectors, not matrices (E0802).
    pub fn showable(&self) -> bool {
        matches!(self.ty, Type::Scalar(_) | Type::Vector { .. })
    }

    /// The field's name in its pass's state struct ([`Self::name`] without a filter's label; a
    /// state field's name has no dot).
    pub fn state_name(&self) -> &str {
        self.name.rsplit('.').next().unwrap_or(&self.name)
    }
}

/// Every field the placed functions of `comp` declare, in the order of their first declaration
/// along the pipeline, with template names instantiated (a filter pipeline's as the view's own
/// filter pass's).
pub fn declared_fields(program: &hir::Program, comp: &Composition) -> Vec<DeclaredField> {
    let pass = match comp.kind {
        PipelineKind::Ray => ViewPass::Ray,
        PipelineKind::Filter => ViewPass::Filter,
    };
    let mut out: Vec<DeclaredField> = Vec::new();
    add_declared_fields(&mut out, (program, comp), (pass, ""));
    out
}

/// The fields of a view built with [`Keep::Ir`]: its ray pipeline's ([`declared_fields`]), then
/// those of its filter pass that the ray pipeline does not declare (a name both declare is the
/// ray pipeline's), then those of each filter in its tree, named after the filter
/// ([`DeclaredField::name`]).
pub fn view_fields(view: &ViewOutput) -> Vec<DeclaredField> {
    let mut out = Vec::new();
    if let Some(ir) = &view.ir {
        add_declared_fields(&mut out, (&ir.program, &view.composition), (ViewPass::Ray, ""));
    }
    if let Some(filter) = &view.filter
        && let Some(ir) = &filter.ir
    {
        add_declared_fields(&mut out, (&ir.program, &filter.composition), (ViewPass::Filter, ""));
    }
    for (f, filter) in &view.tree_filters {
        let Some(ir) = &filter.ir else { continue };
        let prefix = format!("{}.", filter.tree_label().unwrap_or(&filter.name));
        add_declared_fields(&mut out, (&ir.program, &filter.composition), (ViewPass::TreeFilter(*f), &prefix));
    }
    out
}

/// Adds the fields `comp`'s functions declare, as fields of `pass` named after `prefix`, that
/// `out` does not hold yet.
fn add_declared_fields(
    out: &mut Vec<DeclaredField>,
    (program, comp): (&hir::Program, &Composition),
    (pass, prefix): (ViewPass, &str),
) {
    for placed in comp.steps.iter().flat_map(|s| &s.functions) {
        let Some(function) = program.pipelines.get(placed.pipeline) else { continue };
        for decl in &function.state {
            let name = format!("{prefix}{}", subst(&decl.name, placed.instance.as_deref()));
            if !out.iter().any(|f| f.name == name) {
                out.push(DeclaredField { name, ty: decl.ty, ray: decl.ray, pass });
            }
        }
    }
}

/// How a probe's value leaves the shader.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeLayout {
    /// The probed view.
    pub view: String,
    /// The probed state field.
    pub field: DeclaredField,
    /// 32-bit words per pixel: the field's component count (1 to 4).
    pub words: u32,
    /// Renders needed to read every word: one per word for its high three bytes, then one per
    /// three words for their low bytes (`std::probe`'s `probe_pass_bytes`).
    pub passes: u32,
    /// Whether the view has `@ray accum: vec4f`, which [`ProbeAt::Opacity`] needs.
    pub opacity: bool,
}

/// Passes for a value of `words` 32-bit words.
fn pass_count(words: u32) -> u32 {
    words + words.div_ceil(3)
}

/// The probe variant of one view.
pub struct ProbeVariant {
    /// How the probed value is packed into the output and how many renders read it.
    pub layout: ProbeLayout,
    /// The view's shader, with the probe module placed in it for a field of the ray pipeline.
    pub shader: ViewShader,
    /// For a field of a filter pass (the view's own or a filter's of its tree, as the field's
    /// [`DeclaredField::pass`] says), that pass with the probe module placed in it (`None`: a
    /// field of the ray pipeline, which the probe renders without the view's own filter pass).
    pub filter: Option<ViewShader>,
    /// The generated VRS module.
    pub source: String,
}

/// What composing a probe gave.
pub struct ProbeBuild {
    /// Every file read, the generated probe module included, for rendering the diagnostics.
    pub sources: SourceMap,
    /// The scene's and the view's diagnostics, then the probe's own (E0801, E0802).
    pub diags: Diagnostics,
    /// `None` when anything reported an error.
    pub variant: Option<ProbeVariant>,
}

/// The views of a composed scene (built with [`Keep::Ir`]) that declare `field`, by index in
/// `built.views`. When none does, E0801 (with the closest field name) or, when the field is a
/// matrix, E0802.
pub fn views_with_field(built: &BuiltScene, field: &str) -> Result<Vec<usize>, Diagnostic> {
    let fields: Vec<Vec<DeclaredField>> = built.views.iter().map(view_fields).collect();
    let having: Vec<usize> = (0..fields.len()).filter(|&i| fields[i].iter().any(|f| f.name == field)).collect();
    let view_span = |name: &str| {
        let views = built.scene.as_ref().map(|s| s.views.as_slice()).unwrap_or_default();
        views.iter().find(|v| v.name.name == name).map_or(Span::DUMMY, |v| v.name.span)
    };
    if having.is_empty() {
        let named: Vec<(&str, Span, &[DeclaredField])> =
            built.views.iter().zip(&fields).map(|(v, f)| (v.name.as_str(), view_span(&v.name), f.as_slice())).collect();
        return Err(unknown_field(field, &named));
    }
    if let Some(f) = having.iter().flat_map(|&i| &fields[i]).find(|f| f.name == field && !f.showable()) {
        let i = having[0];
        return Err(Diagnostic::new(
            Code::ProbeUnshowable,
            view_span(&built.views[i].name),
            format!("a probe cannot show `{field}`, a `{}`", f.ty),
        )
        .with_label(format!("view `{}` declares `{field}: {}`", built.views[i].name, f.ty))
        .with_note("a probe shows a scalar through a colormap, a vector as RGB and a bool as black and white")
        .with_help(format!(
            "declare a vector field that holds the part of `{field}` to see (a column, or `{field}` times a vector) and probe that"
        )));
    }
    Ok(having)
}

/// E0801 for a field no view in `views` (name, span of its name, its fields) declares.
fn unknown_field(field: &str, views: &[(&str, Span, &[DeclaredField])]) -> Diagnostic {
    let span = views.first().map_or(Span::DUMMY, |v| v.1);
    let message = match views {
        [(name, _, _)] => format!("view `{name}` declares no state field `{field}`"),
        _ => format!("no view declares a state field `{field}`"),
    };
    let mut d = Diagnostic::new(Code::ProbeUnknownField, span, message).with_label("probed here");
    for (_, span, _) in views.iter().skip(1) {
        d = d.with_secondary(*span, "nor does this view");
    }
    let candidates = views.iter().flat_map(|(_, _, fields)| fields.iter().map(|f| f.name.as_str()));
    if let Some(best) = did_you_mean(field, candidates) {
        d = d.with_help(format!("did you mean `{best}`?"));
    }
    // Views with the same fields share one note.
    let mut groups: Vec<(Vec<&str>, Vec<&str>)> = Vec::new();
    for (name, _, fields) in views {
        let list: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
        match groups.iter_mut().find(|(l, _)| *l == list) {
            Some((_, names)) => names.push(name),
            None => groups.push((list, vec![name])),
        }
    }
    for (list, names) in groups {
        let names: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
        let views = if names.len() == 1 { "view" } else { "views" };
        d = d.with_note(format!("fields of {views} {}: {}", names.join(", "), list.join(", ")));
    }
    d
}

/// Reads and composes the scene at `path`, then the probe variant of view `view` for `field`.
/// An unreadable scene file is an I/O error; everything else is in the diagnostics.
pub fn build_probe(path: &Path, view: &str, field: &str) -> std::io::Result<ProbeBuild> {
    let built = build::build_scene_keeping(path, Some(view), Keep::Ir)?;
    Ok(compose_probe(built, field))
}

/// The probe variant of the (single) view of `built` (composed with [`Keep::Ir`]) for `field`.
pub fn compose_probe(built: BuiltScene, field: &str) -> ProbeBuild {
    let checked = probed_field(&built, field);
    let BuiltScene { sources, mut diags, scene, views } = built;
    let (found, opacity, scene, view) = match (checked, scene, views.into_iter().next()) {
        (Ok((found, opacity)), Some(scene), Some(view)) => (found, opacity, scene, view.name),
        (checked, _, _) => {
            if let Err(Some(d)) = checked {
                diags.push(d);
            }
            return ProbeBuild { sources, diags, variant: None };
        }
    };
    let words = found.ty.components() as u32;
    let layout = ProbeLayout { view, field: found, words, passes: pass_count(words), opacity };
    let source = match layout.field.pass.pipeline() {
        PipelineKind::Ray => probe_source(&layout),
        PipelineKind::Filter => filter_probe_source(&layout),
    };
    compose_variant(sources, scene, layout, source, diags)
}

/// The field a probe of the single view of `built` shows, and whether the view has `accum`
/// ([`ProbeLayout::opacity`]). `Err(None)` when the view did not compose (its errors are
/// reported already), `Err(Some(_))` for E0801 and E0802.
fn probed_field(built: &BuiltScene, field: &str) -> Result<(DeclaredField, bool), Option<Diagnostic>> {
    let [output] = built.views.as_slice() else { return Err(None) };
    if output.ir.is_none() || built.diags.has_errors() {
        return Err(None);
    }
    views_with_field(built, field).map_err(Some)?;
    let fields = view_fields(output);
    let found = fields.iter().find(|f| f.name == field).cloned().ok_or(None)?;
    let opacity = fields.iter().any(|f| f.name == ACCUM && f.ray && f.ty == Type::vec(4, Scalar::F32));
    Ok((found, opacity))
}

/// Composes the view of `layout` again with the generated module placed last.
fn compose_variant(
    sources: SourceMap,
    scene: Scene,
    layout: ProbeLayout,
    source: String,
    mut diags: Diagnostics,
) -> ProbeBuild {
    let pass = layout.field.pass;
    let module = GeneratedModule { name: format!("<probe of {}>", layout.field.name), text: source.clone(), pass };
    let built = build::compose_scene_with(
        build::ParsedScene { sources, scene: Some(scene), diags: Diagnostics::new() },
        Some(&layout.view),
        Keep::Outputs,
        crate::loader::ParsedFiles::default(),
        &[module],
    );
    // The view's own warnings were reported with the view; only the variant's errors are new
    // (a name of the generated module that the view already uses differently).
    built.diags.iter().filter(|d| d.is_error()).cloned().for_each(|d| diags.push(d));
    // A probe of the ray pipeline shows its value without the filter pass; one of a filter
    // pass needs that pass's variant.
    let (shader, filter) = match built.views.into_iter().next() {
        Some(view) => {
            let filter = match pass {
                ViewPass::Ray => Some(None),
                ViewPass::Filter => view.filter.and_then(|f| f.shader).map(Some),
                ViewPass::TreeFilter(t) => {
                    view.tree_filters.into_iter().find(|(f, _)| *f == t).and_then(|(_, f)| f.shader).map(Some)
                }
            };
            (view.shader, filter)
        }
        None => (None, None),
    };
    let variant = match (shader, filter) {
        (Some(shader), Some(filter)) if !diags.has_errors() => Some(ProbeVariant { layout, shader, filter, source }),
        _ => None,
    };
    ProbeBuild { sources: built.sources, diags, variant }
}

/// The generated module of a probe of a filter pass's field: `probe_output` after
/// `filter.finish` writes the field's value as it is there, in the passes of `std::probe`.
pub fn filter_probe_source(layout: &ProbeLayout) -> String {
    let f = &layout.field;
    let (name, ty) = (f.state_name(), f.ty);
    let lifetime = if f.ray { "@ray " } else { "" };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "// The probe of `{}` in a filter pass of view `{}`, generated by vrsc (compose/probe.rs).",
        f.name, layout.view
    );
    out.push_str("import std::probe;\n\n");
    let mut output = Decls::default();
    output.line(PASS_UNIFORM, format!("uniform {PASS_UNIFORM}: u32 = 0u;"));
    output.line(name, format!("{lifetime}state {name}: {ty};"));
    output.line("out_color", "state out_color: vec4f;".into());
    output.line("use", uses_line(ty));
    out.push_str("/// Writes pass `probe_pass` of the probed value into the pixel.\n");
    out.push_str("pipeline probe_output after filter.finish {\n");
    out.push_str(&output.text);
    let _ = writeln!(out, "\n    let value: {ty} = state.{name};");
    write_value(&mut out, layout, "true");
    out
}

/// The generated module of a probe: `probe_capture` in the sample loop and `probe_output` in
/// `ray.finish` (see the module documentation).
pub fn probe_source(layout: &ProbeLayout) -> String {
    let f = &layout.field;
    let (name, ty) = (f.state_name(), f.ty);
    let lifetime = if f.ray { "@ray " } else { "" };
    let default_mode = ProbeAt::default_for(f.ray).mode();
    let mut out = String::new();
    let _ = writeln!(out, "// The probe of `{name}` in view `{}`, generated by vrsc (compose/probe.rs).", layout.view);
    out.push_str("import std::probe;\n\n");

    let mut capture = Decls::default();
    capture.line(MODE_UNIFORM, format!("uniform {MODE_UNIFORM}: u32 = {default_mode}u;"));
    if layout.opacity {
        capture.line(
            THRESHOLD_UNIFORM,
            format!("uniform {THRESHOLD_UNIFORM}: f32 = {DEFAULT_THRESHOLD:?} in 0.0 .. 1.0;"),
        );
    }
    capture.line(SAMPLE_UNIFORM, format!("uniform {SAMPLE_UNIFORM}: u32 = 0u;"));
    if layout.opacity {
        capture.line(ACCUM, format!("@ray state {ACCUM}: vec4f;"));
    }
    capture.line(name, format!("{lifetime}state {name}: {ty};"));
    capture.line("terminate", "@ray state terminate: bool;".into());
    capture.line("probe_value", format!("@ray state probe_value: {ty} = {};", zero(ty)));
    capture.line("probe_hit", "@ray state probe_hit: bool = false;".into());
    capture.line("probe_samples", "@ray state probe_samples: u32 = 0u;".into());
    out.push_str("/// Keeps the probed field at the sample `probe_mode` picks, then ends the ray.\n");
    out.push_str("pipeline probe_capture after end {\n");
    out.push_str(&capture.text);
    let _ = write!(
        out,
        "\n    if state.probe_hit || {MODE_UNIFORM} == 0u {{\n        return;\n    }}\n\
         \x20   var now = {MODE_UNIFORM} == 2u && state.probe_samples == {SAMPLE_UNIFORM};\n"
    );
    if layout.opacity {
        let _ = writeln!(
            out,
            "    if {MODE_UNIFORM} == 1u && state.{ACCUM}.a >= {THRESHOLD_UNIFORM} {{\n        now = true;\n    }}"
        );
    }
    let _ = write!(
        out,
        "    state.probe_samples += 1u;\n    if now {{\n        state.probe_value = state.{name};\n\
         \x20       state.probe_hit = true;\n        state.terminate = true;\n    }}\n}}\n\n"
    );

    let mut output = Decls::default();
    output.line(MODE_UNIFORM, format!("uniform {MODE_UNIFORM}: u32 = {default_mode}u;"));
    output.line(PASS_UNIFORM, format!("uniform {PASS_UNIFORM}: u32 = 0u;"));
    if f.ray {
        output.line(name, format!("@ray state {name}: {ty};"));
    }
    output.line("probe_value", format!("@ray state probe_value: {ty};"));
    output.line("probe_hit", "@ray state probe_hit: bool;".into());
    output.line("out_color", "@ray state out_color: vec4f;".into());
    output.line("use", uses_line(ty));
    out.push_str("/// Writes pass `probe_pass` of the probed value into the pixel.\n");
    out.push_str("pipeline probe_output after ray.finish {\n");
    out.push_str(&output.text);
    let _ = write!(out, "\n    var value: {ty} = state.probe_value;\n    var has_value = state.probe_hit;\n");
    if f.ray {
        let _ = writeln!(
            out,
            "    if {MODE_UNIFORM} == 0u {{\n        value = state.{name};\n        has_value = true;\n    }}"
        );
    }
    write_value(&mut out, layout, "has_value");
    out
}

/// Declaration lines of a generated function, each name once (the probed field may be one the
/// probe needs anyway, such as `accum` or `terminate`).
#[derive(Default)]
struct Decls {
    names: Vec<String>,
    text: String,
}

impl Decls {
    fn line(&mut self, name: &str, line: String) {
        if !self.names.iter().any(|n| n == name) {
            self.names.push(name.to_string());
            let _ = writeln!(self.text, "    {line}");
        }
    }
}

/// The `use` line of `probe_output`: `std::probe`'s colouring, and its bits of an f32.
fn uses_line(ty: Type) -> String {
    let uses = if ty.scalar() == Some(Scalar::F32) { "probe_color, probe_f32_bits" } else { "probe_color" };
    format!("use {uses};")
}

/// The end of `probe_output`: the local `value` as words, written into `out_color` as pass
/// `probe_pass` shows them where `has_value` (a VRS expression) holds.
fn write_value(out: &mut String, layout: &ProbeLayout, has_value: &str) {
    let _ = write!(
        out,
        "    let words = vec4u({});\n    state.out_color = probe_color(words, {}u, {PASS_UNIFORM}, {has_value});\n}}\n",
        value_words(layout.field.ty).join(", "),
        layout.words
    );
}

/// The four 32-bit words of the local `value` of type `ty` (unused ones 0u), as VRS source.
fn value_words(ty: Type) -> Vec<String> {
    let scalar = ty.scalar().unwrap_or(Scalar::F32);
    (0..4)
        .map(|i| match ty {
            Type::Vector { size, .. } if i < size => {
                word(scalar, &format!("value.{}", ['x', 'y', 'z', 'w'][i as usize]))
            }
            Type::Scalar(_) if i == 0 => word(scalar, "value"),
            _ => "0u".into(),
        })
        .collect()
}

/// The 32-bit word of a scalar expression of kind `scalar`.
fn word(scalar: Scalar, expr: &str) -> String {
    match scalar {
        Scalar::F32 => format!("probe_f32_bits({expr})"),
        Scalar::I32 => format!("u32({expr})"),
        Scalar::U32 => expr.to_string(),
        Scalar::Bool => format!("select(0u, 1u, {expr})"),
    }
}

/// The zero value of a scalar or vector type, as VRS source.
fn zero(ty: Type) -> String {
    let scalar = match ty.scalar() {
        Some(Scalar::F32) | None => "0.0",
        Some(Scalar::I32) => "0",
        Some(Scalar::U32) => "0u",
        Some(Scalar::Bool) => "false",
    };
    match ty {
        Type::Vector { .. } => format!("{ty}({scalar})"),
        _ => scalar.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_cover_every_word() {
        assert_eq!([1, 2, 3, 4].map(pass_count), [2, 3, 4, 6]);
    }

    #[test]
    fn zero_values_are_vrs_literals() {
        assert_eq!(zero(Type::F32), "0.0");
        assert_eq!(zero(Type::vec(3, Scalar::F32)), "vec3f(0.0)");
        assert_eq!(zero(Type::vec(2, Scalar::Bool)), "vec2<bool>(false)");
        assert_eq!(zero(Type::U32), "0u");
    }

    #[test]
    fn a_typo_gets_the_closest_field() {
        let fields =
            [DeclaredField { name: "gradient".into(), ty: Type::vec(3, Scalar::F32), ray: false, pass: ViewPass::Ray }];
        let d = unknown_field("gradiant", &[("3d", Span::DUMMY, &fields)]);
        assert_eq!(d.code, Code::ProbeUnknownField);
        assert!(d.notes.iter().any(|n| n.contains("did you mean `gradient`")), "{:?}", d.notes);
    }
}
