use super::ir::*;
use super::*;
use crate::check::check_program;
use crate::diag::{Code, Diagnostic};
use crate::hir::show_const;
use crate::loader::Loader;
use crate::source::{SourceMap, Span};
use crate::types::{Scalar, Type};

/// Checked modules: files named `std_*` count as standard modules.
struct Fx {
    sources: SourceMap,
    program: hir::Program,
    ids: Vec<usize>,
    std: Vec<usize>,
}

fn fx(files: &[(&str, &str)]) -> Fx {
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let mut loader = Loader::new(&mut sources, &mut diags);
    let ids: Vec<usize> = files.iter().map(|(n, t)| loader.load_root_source(n, t.to_string(), None)).collect();
    let graph = loader.finish();
    let program = check_program(&graph, &sources, &mut diags);
    let errors: Vec<String> =
        diags.iter().filter(|d| d.is_error()).map(|d| format!("{} {}", d.code.as_str(), d.message)).collect();
    assert!(errors.is_empty(), "check errors: {errors:?}");
    let std = files.iter().zip(&ids).filter(|((n, _), _)| n.starts_with("std_")).map(|(_, &id)| id).collect();
    Fx { sources, program, ids, std }
}

impl Fx {
    fn plain(&self, i: usize) -> ModuleUse {
        ModuleUse { module: self.ids[i], instances: None, span: Span::DUMMY }
    }

    fn inst(&self, i: usize, names: &[&str]) -> ModuleUse {
        let instances = Some(names.iter().map(|n| n.to_string()).collect());
        ModuleUse { module: self.ids[i], instances, span: Span::DUMMY }
    }

    /// Every module, plain, in order.
    fn all(&self) -> Vec<ModuleUse> {
        (0..self.ids.len()).map(|i| self.plain(i)).collect()
    }

    fn compose_with(&self, uses: &[ModuleUse], required: &[&str]) -> (Composition, Diagnostics) {
        let mut diags = Diagnostics::new();
        let c = compose(&self.program, uses, (PipelineKind::Ray, |m| self.std.contains(&m)), required, &mut diags);
        (c, diags)
    }

    fn compose(&self, uses: &[ModuleUse]) -> (Composition, Diagnostics) {
        self.compose_with(uses, &[])
    }

    /// 1-based line of a span.
    fn line(&self, span: Span) -> usize {
        self.sources.position(span.start).map_or(0, |(_, p)| p.line)
    }
}

fn names(c: &Composition, step: Step) -> Vec<&str> {
    c.step(step).iter().map(|f| f.name.as_str()).collect()
}

fn codes(d: &Diagnostics) -> Vec<&'static str> {
    d.iter().map(|d| d.code.as_str()).collect()
}

fn only(d: &Diagnostics, code: Code) -> &Diagnostic {
    let found: Vec<&Diagnostic> = d.iter().filter(|x| x.code == code).collect();
    assert_eq!(found.len(), 1, "expected one {code:?}, got {:?}", codes(d));
    found[0]
}

/// A pipeline function whose body only counts (it reads and writes its own `@ray` field), so
/// placement tests see no data-flow warnings.
fn pf(name: &str, placement: &str) -> String {
    format!("pipeline {name} {placement} {{ @ray state n: f32 = 0.0; state.n = state.n + 1.0; }}\n")
}

fn module(items: &[(&str, &str)]) -> String {
    items.iter().map(|(n, p)| pf(n, p)).collect()
}

/// A standard-like module filling a few steps.
fn std_base() -> String {
    module(&[("key", "in shading.lights"), ("fill", "in shading.lights"), ("tone", "in shading.tone")])
}

#[test]
fn in_appends_in_module_order() {
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("extra", "in shading.lights"))]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["key", "fill", "extra"]);
    assert_eq!(names(&c, Step::ShadingTone), ["tone"]);
    let ray_steps = Step::ALL.iter().copied().filter(|s| s.kind() == PipelineKind::Ray);
    assert_eq!(c.steps.len(), ray_steps.clone().count());
    assert!(c.steps.iter().map(|s| s.step).eq(ray_steps));
    // The placed function points back at its HIR function.
    let extra = &c.step(Step::ShadingLights)[2];
    assert_eq!(f.program.pipelines[extra.pipeline].name, "extra");
    assert_eq!(extra.instance, None);
    assert_eq!(extra.state, [c.field("n")]);
}

#[test]
fn before_and_after_a_step_and_a_group() {
    let user = module(&[
        ("first", "before shading.lights"),
        ("last", "after shading.lights"),
        ("early", "before compositing"),
        ("late", "after compositing"),
    ]);
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["first", "key", "fill", "last"]);
    assert_eq!(names(&c, Step::CompositingPrimaryColor), ["early"]);
    assert_eq!(names(&c, Step::CompositingAdditional), ["late"]);
}

#[test]
fn before_and_after_a_substep() {
    let user = module(&[
        ("before_fill", "before shading.lights[fill]"),
        ("after_key", "after shading.lights[key]"),
        ("before_key", "before shading.lights[key]"),
        ("after_fill", "after shading.lights[fill]"),
    ]);
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["before_key", "key", "after_key", "before_fill", "fill", "after_fill"]);
}

#[test]
fn replace_a_step_and_a_substep() {
    let user = module(&[
        ("soft", "replace shading.lights[key]"),
        ("my_tone", "replace shading.tone"),
        ("after_soft", "after shading.lights[soft]"),
    ]);
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["soft", "after_soft", "fill"]);
    assert_eq!(names(&c, Step::ShadingTone), ["my_tone"]);
    // `replace` of an empty step inserts there.
    let f = fx(&[("user.vrs", &pf("only", "replace shading.boundary"))]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingBoundary), ["only"]);
}

#[test]
fn remove_a_step_and_a_substep() {
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", "remove shading.lights[key];\nremove shading.tone;\n")]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["fill"]);
    assert!(names(&c, Step::ShadingTone).is_empty());
    // Removing from an empty step is fine; a missing substep is E0603.
    let f =
        fx(&[("std_base.vrs", &std_base()), ("user.vrs", "remove shading.boundary;\nremove shading.lights[rim];\n")]);
    let (c, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0603"]);
    assert_eq!(f.line(d.iter().next().unwrap().span), 2);
    assert_eq!(names(&c, Step::ShadingLights), ["key", "fill"]);
}

#[test]
fn removes_and_placements_apply_in_source_order() {
    let user = format!("{}remove shading.tone;\n{}", pf("mine", "in shading.tone"), pf("again", "in shading.tone"));
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingTone), ["again"]);
    let removed: Vec<(&str, bool)> = c.not_placed.iter().map(|n| (n.name.as_str(), n.removed)).collect();
    assert_eq!(removed, [("tone", true), ("mine", true)]);
}

#[test]
fn when_active_on_active_and_inactive_targets() {
    let mut user = module(&[
        ("a1", "after shading.lights[key] when active"),
        ("a2", "after shading.lights[rim] when active"),
        ("a3", "in shading.boundary when active"),
        ("a4", "in shading.lights when active"),
        ("a5", "replace shading.tone[nope] when active"),
        ("a6", "before shading.tone when active"),
    ]);
    user.push_str("remove shading.lights[rim] when active;\nremove shading.boundary when active;\n");
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["key", "a1", "fill", "a4"]);
    assert!(names(&c, Step::ShadingBoundary).is_empty());
    assert_eq!(names(&c, Step::ShadingTone), ["a6", "tone"]);
    let not_placed: Vec<(&str, bool)> = c.not_placed.iter().map(|n| (n.name.as_str(), n.removed)).collect();
    assert_eq!(not_placed, [("a2", false), ("a3", false), ("a5", false)]);
}

#[test]
fn when_active_sees_earlier_placements() {
    // The first module activates `shading.boundary` (and creates `edge`); the second then
    // finds both. Without the first, the second module's functions are left out.
    let first = pf("edge", "in shading.boundary");
    let second =
        module(&[("b1", "in shading.boundary when active"), ("b2", "before shading.boundary[edge] when active")]);
    let f = fx(&[("first.vrs", &first), ("second.vrs", &second)]);
    let (c, d) = f.compose(&[f.plain(0), f.plain(1)]);
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingBoundary), ["b2", "edge", "b1"]);
    let (c, d) = f.compose(&[f.plain(1), f.plain(0)]);
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingBoundary), ["edge"]);
}

#[test]
fn missing_substep_is_e0603_with_a_suggestion() {
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("x", "after shading.lights[kye]"))]);
    let (c, d) = f.compose(&f.all());
    let e = only(&d, Code::UnknownSubstep);
    assert_eq!(codes(&d), ["E0603"]);
    assert_eq!(e.span, f.program.pipelines.iter().find(|p| p.name == "x").unwrap().placement.span);
    assert_eq!(e.message, "step `shading.lights` has no substep `kye`");
    assert!(e.notes.iter().any(|n| n == "help: did you mean `shading.lights[key]`?"), "{:?}", e.notes);
    assert!(e.notes.iter().any(|n| n == "substeps of `shading.lights` at this point: `key`, `fill`"), "{:?}", e.notes);
    assert!(e.notes.iter().any(|n| n.contains("when active")));
    assert_eq!(names(&c, Step::ShadingLights), ["key", "fill"]);
    // A placement on an empty step's substep says the step is empty.
    let f = fx(&[("user.vrs", &pf("x", "before shading.tone[t]"))]);
    let (_, d) = f.compose(&f.all());
    let e = only(&d, Code::UnknownSubstep);
    assert!(e.notes.iter().any(|n| n == "`shading.tone` holds no functions at this point"), "{:?}", e.notes);
}

#[test]
fn second_replace_is_e0604() {
    let one = pf("soft", "replace shading.lights[key]");
    let two = pf("hard", "replace shading.lights[key]");
    let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
    let (c, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0604"]);
    let e = only(&d, Code::DoubleReplace);
    assert_eq!(e.span, f.program.pipelines.iter().find(|p| p.name == "hard").unwrap().placement.span);
    let earlier = f.program.pipelines.iter().find(|p| p.name == "soft").unwrap().placement.span;
    assert_eq!(e.secondary[0].0, earlier);
    assert_eq!(names(&c, Step::ShadingLights), ["soft", "fill"]);
    // Even with `when active`.
    let two = pf("hard", "replace shading.lights[key] when active");
    let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
    let (_, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0604"]);

    // A replacement that keeps the name holds the place: a second replace is still E0604,
    // but other placements find it.
    let one = pf("key", "replace shading.lights[key]");
    let two = module(&[("after_key", "after shading.lights[key]"), ("hard", "replace shading.lights[key]")]);
    let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
    let (c, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0604"]);
    assert_eq!(names(&c, Step::ShadingLights), ["key", "after_key", "fill"]);
    assert_eq!(f.program.pipelines[c.step(Step::ShadingLights)[0].pipeline].module, f.ids[1]);

    // After `replace S` took the whole step, `replace S[x]` is E0604 too, and `after S[x]`
    // is E0603 pointing at the replacement.
    let one = pf("lights", "replace shading.lights");
    let two = module(&[("hard", "replace shading.lights[fill]"), ("later", "after shading.lights[key]")]);
    let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
    let (c, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0604", "E0603"]);
    let e = only(&d, Code::UnknownSubstep);
    assert_eq!(e.secondary.len(), 1);
    assert!(e.secondary[0].1.contains("`replace shading.lights` took the place of `key`"), "{:?}", e.secondary);
    assert_eq!(names(&c, Step::ShadingLights), ["lights"]);

    // A new function that takes the old name later is a fresh substep: replacing it is fine.
    let one = module(&[
        ("soft", "replace shading.lights[key]"),
        ("key", "in shading.lights"),
        ("hard", "replace shading.lights[key]"),
    ]);
    let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one)]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ShadingLights), ["soft", "fill", "hard"]);
}

#[test]
fn one_name_twice_in_a_step_is_e0203() {
    let f = fx(&[
        ("one.vrs", &pf("dup", "in start")),
        ("two.vrs", &pf("dup", "in start")),
        ("three.vrs", &pf("dup", "in end")),
    ]);
    let (c, d) = f.compose(&f.all());
    assert_eq!(codes(&d), ["E0203"]);
    let e = only(&d, Code::Duplicate);
    let second = f.program.pipelines.iter().find(|p| p.module == f.ids[1]).unwrap();
    let first = f.program.pipelines.iter().find(|p| p.module == f.ids[0]).unwrap();
    assert_eq!(e.span, second.span);
    assert_eq!(e.secondary[0].0, first.span);
    assert_eq!(names(&c, Step::Start), ["dup"]);
    assert_eq!(names(&c, Step::End), ["dup"]);
    assert_eq!(f.program.pipelines[c.step(Step::Start)[0].pipeline].module, f.ids[0]);
    // A `replace` of a function by one of the same name is no duplicate.
    let f = fx(&[("one.vrs", &pf("dup", "in start")), ("two.vrs", &pf("dup", "replace start[dup]"))]);
    let (c, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(f.program.pipelines[c.step(Step::Start)[0].pipeline].module, f.ids[1]);
}

const CLIP: &str = "\
lib fn plane_distance(plane: vec4f, p: vec3f) -> f32 {
return dot(plane.xyz, p) + plane.w;
}

/// Clip one additional volume against a plane.
pipeline clip_$ after classification.additional[$] when active {
/// The clip plane of volume `$`.
uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;
state pos: vec3f;
state color_$: vec4f;
use plane_distance;

if plane_distance(clip_plane_$, state.pos) < 0.0 {
    state.color_$ = vec4f(0.0);
}
}
";

const VOLUMES: &str = "\
pipeline setup in sampling.primary {
state pos: vec3f = vec3f(0.5);
state.pos = state.pos * 1.0;
}
pipeline gm in classification.additional {
state color_gm: vec4f = vec4f(0.0);
state.color_gm = vec4f(1.0);
}
pipeline wm in classification.additional {
state color_wm: vec4f = vec4f(0.0);
state.color_wm = vec4f(0.5);
}
pipeline blend in compositing.additional {
@ray state accum: vec4f = vec4f(0.0);
state color_gm: vec4f;
state color_wm: vec4f;
state.accum = state.accum + state.color_gm + state.color_wm;
}
";

#[test]
fn template_with_two_instances() {
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
    assert!(d.is_empty(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "wm", "clip_wm"]);
    let fns = c.step(Step::ClassificationAdditional);
    assert_eq!(fns[1].instance.as_deref(), Some("gm"));
    assert_eq!(fns[3].instance.as_deref(), Some("wm"));
    assert_eq!(fns[1].pipeline, fns[3].pipeline);
    // Each instance has its own uniform, with the template's default, range and doc.
    let uniforms: Vec<&str> = c.uniforms.iter().map(|u| u.name.as_str()).collect();
    assert_eq!(uniforms, ["clip_plane_gm", "clip_plane_wm"]);
    assert_eq!(c.uniforms[0].ty, Type::vec(4, Scalar::F32));
    assert_eq!(c.uniforms[1].default.as_ref().map(show_const).as_deref(), Some("vec4f(1.0, 0.0, 0.0, -0.5)"));
    assert!(c.uniforms[1].range.is_some());
    // `$` in a doc names the instance, as in the uniform's name.
    assert_eq!(c.uniforms[0].doc.as_deref().map(str::trim), Some("The clip plane of volume `gm`."));
    assert_eq!(c.uniforms[1].doc.as_deref().map(str::trim), Some("The clip plane of volume `wm`."));
    assert_eq!(fns[1].uniforms, [0]);
    assert_eq!(fns[3].uniforms, [1]);
    // State names are substituted; `pos` is shared.
    let field = |i: Option<usize>| i.map(|i| c.fields[i].name.as_str());
    assert_eq!(fns[1].state.iter().map(|&s| field(s)).collect::<Vec<_>>(), [Some("pos"), Some("color_gm")]);
    assert_eq!(fns[3].state.iter().map(|&s| field(s)).collect::<Vec<_>>(), [Some("pos"), Some("color_wm")]);
    // Without the `wm` volume, `clip_wm` is left out (when active).
    let f = fx(&[("std_volumes.vrs", &VOLUMES.replace("pipeline wm", "pipeline other")), ("clip.vrs", CLIP)]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
    assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "other"]);
    assert!(d.iter().all(|d| !d.is_error()), "{:?}", codes(&d));
    assert_eq!(c.uniforms.len(), 1);
}

#[test]
fn template_without_instances_is_e0606() {
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    for uses in [vec![f.plain(0), f.plain(1)], vec![f.plain(0), f.inst(1, &[])]] {
        let (c, d) = f.compose(&uses);
        let e = only(&d, Code::UninstantiatedTemplate);
        assert_eq!(f.line(e.span), 6, "at the first `$`: the pipeline's name");
        assert!(e.notes.iter().any(|n| n.contains("list instances in the scene")));
        assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "wm"]);
    }
    // The first `$` may be a declaration or a remove.
    let f = fx(&[(
        "t.vrs",
        "pipeline p in start {\n    state a: f32 = 0.0;\n    state b_$: f32 = 0.0;\n    state.a = state.b_$;\n}\nremove end[$];",
    )]);
    let (_, d) = f.compose(&f.all());
    assert_eq!(f.line(only(&d, Code::UninstantiatedTemplate).span), 3);
    let f = fx(&[("t.vrs", "remove end[$];")]);
    let (_, d) = f.compose(&f.all());
    assert_eq!(f.line(only(&d, Code::UninstantiatedTemplate).span), 1);
}

#[test]
fn bad_instance_names_are_e0607() {
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    let mut bad = f.inst(1, &["g-m", "gm", "9x", "gm"]);
    bad.span = Span::new(3, 7);
    let (c, d) = f.compose(&[f.plain(0), bad]);
    assert_eq!(codes(&d), ["E0607", "E0607", "E0607"]);
    assert!(d.iter().all(|x| x.span == Span::new(3, 7)));
    assert_eq!(d.iter().next().unwrap().message, "`g-m` is not a valid instance name");
    assert_eq!(d.iter().nth(2).unwrap().message, "instance `gm` is listed twice");
    assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "wm"]);
}

#[test]
fn plain_module_with_instances_is_placed_once_with_a_warning() {
    let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("extra", "in shading.lights"))]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["a", "b"])]);
    assert_eq!(codes(&d), ["W0701"]);
    assert_eq!(names(&c, Step::ShadingLights), ["key", "fill", "extra"]);
    assert_eq!(c.step(Step::ShadingLights)[2].instance, None);
}

#[test]
fn diagnostics_on_an_instance_name_it() {
    let f = fx(&[("std_base.vrs", &std_base()), ("tint.vrs", &pf("tint_$", "after shading.lights[$]"))]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["key", "rim"])]);
    assert_eq!(codes(&d), ["E0603"]);
    let e = only(&d, Code::UnknownSubstep);
    assert_eq!(e.message, "step `shading.lights` has no substep `rim`");
    assert!(e.notes.iter().any(|n| n == "in instance `rim` of template `tint_$`"), "{:?}", e.notes);
    assert_eq!(names(&c, Step::ShadingLights), ["key", "tint_key", "fill"]);
}

#[test]
fn field_without_default_is_e0605() {
    let user = "\
pipeline w in start { state weight: f32; state.weight = 1.0; }
pipeline r in end { state weight: f32; state color: vec4f = vec4f(0.0); state.color.a = state.weight; }
";
    let f = fx(&[("user.vrs", user)]);
    let (c, d) = f.compose(&f.all());
    let e = only(&d, Code::NoDefault);
    assert_eq!(f.line(e.span), 1);
    assert!(e.notes.iter().any(|n| n == "help: give a default: `state weight: f32 = ...;`"), "{:?}", e.notes);
    // The field is still there, with its type's zero value.
    let w = c.field("weight").unwrap();
    assert_eq!(show_const(&c.fields[w].default), "0.0");
}

#[test]
fn conflicts_across_an_instantiated_template_and_a_plain_module() {
    let plain = "\
pipeline base in start {
state value_gm: f32 = 0.0;
state level_gm: f32 = 0.0;
uniform gain_gm: f32 = 1.0;
uniform bias_gm: f32;
state.value_gm = gain_gm + bias_gm;
state.level_gm = 1.0;
}
";
    let template = "\
pipeline use_$ in end {
state value_$: f32 = 1.0;
@ray state level_$: f32 = 0.0;
uniform gain_$: f32 = 2.0;
uniform bias_$: vec2f;
state.value_$ = state.value_$ + gain_$ + bias_$.x + state.level_$;
}
";
    let f = fx(&[("plain.vrs", plain), ("tmpl.vrs", template)]);
    let (_, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"])]);
    let mut got: Vec<(&str, usize)> =
        d.iter().filter(|x| x.is_error()).map(|x| (x.code.as_str(), f.line(x.span))).collect();
    got.sort();
    assert_eq!(got, [("E0504", 3), ("E0505", 2), ("E0505", 4), ("E0506", 5)]);
    let e = only(&d, Code::StateConflict);
    assert_eq!(f.line(e.secondary[0].0), 3, "the earlier declaration, in plain.vrs");
    assert!(e.notes.iter().any(|n| n == "in instance `gm` of template `use_$`"));
    let e = d.iter().find(|x| x.code == Code::DefaultConflict && f.line(x.span) == 2).unwrap();
    assert_eq!(e.message, "state field `value_gm` has default 1.0 here but 0.0 in `base`");
    // With another instance nothing conflicts.
    let (_, d) = f.compose(&[f.plain(0), f.inst(1, &["wm"])]);
    assert!(!d.has_errors(), "{:?}", codes(&d));
}

#[test]
fn conflicts_as_written_are_left_to_the_checker() {
    // Two templates agreeing as written, and a plain module: no conflict reported here twice.
    let one = "pipeline a_$ in start { state v_$: f32 = 1.0; state.v_$ = 2.0; }";
    let two = "pipeline b_$ in end { state v_$: f32 = 1.0; state o: f32 = 0.0; state.o = state.v_$; }";
    let f = fx(&[("one.vrs", one), ("two.vrs", two)]);
    let (c, d) = f.compose(&[f.inst(0, &["x", "y"]), f.inst(1, &["x"])]);
    assert!(!d.has_errors(), "{:?}", codes(&d));
    assert_eq!(names(&c, Step::Start), ["a_x", "a_y"]);
    assert_eq!(names(&c, Step::End), ["b_x"]);
    // v_x is read (by b_x); v_y only written (by a_y), so left out.
    assert!(c.field("v_x").is_some() && c.field("v_y").is_none());
    // Two plain declarations that conflict as written: the checker reports it (and drops
    // the later function), the composer does not report it again.
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let mut loader = Loader::new(&mut sources, &mut diags);
    loader.load_root_source("p.vrs", "pipeline p in start { state w: f32 = 0.0; state.w = 1.0; }\npipeline q in end { state w: f32 = 1.0; state o: f32 = 0.0; state.o = state.w; }".into(), None);
    let graph = loader.finish();
    let program = check_program(&graph, &sources, &mut diags);
    let checker_errors = diags.error_count();
    assert_eq!(checker_errors, 1, "the checker reports the conflict");
    let mut again = Diagnostics::new();
    compose(
        &program,
        &[ModuleUse { module: 0, instances: None, span: Span::DUMMY }],
        (PipelineKind::Ray, |_| false),
        &[],
        &mut again,
    );
    assert!(!again.has_errors(), "{:?}", codes(&again));
}

#[test]
fn read_before_write_is_w0005() {
    let user = "\
pipeline reads in start {
state weight: f32 = 0.5;
@ray state hits: f32 = 0.0;
state late: f32 = 0.0;
state.late = state.weight + state.hits;
}
pipeline writes in end {
state weight: f32;
@ray state hits: f32;
state.weight = 1.0;
state.hits = state.hits + 1.0;
}
pipeline setup in ray.setup { state early: f32 = 0.0; state.early = 1.0; }
pipeline uses_early in compositing.alpha {
state early: f32;
state late: f32;
state sum: f32 = 0.0;
state.sum = state.early + state.late;
}
pipeline finish in ray.finish { state sum: f32; @ray state hits: f32; state.hits = state.sum; }
";
    let f = fx(&[("user.vrs", user)]);
    let (_, d) = f.compose(&f.all());
    let warnings: Vec<(&str, usize)> = d.iter().map(|x| (x.code.as_str(), f.line(x.span))).collect();
    // `weight` (per-sample) is read in `start` but written only in `end`: W0005. `hits` is
    // `@ray`: the previous sample's write reaches it. `early` is written in `ray.setup` but
    // reset before every sample: W0005 with a note. `late`, `sum` are written in time.
    // Each W0005 points at the read. The writes that no read reaches are W0006: `weight` in
    // `end` (line 8), `early` in `ray.setup` (13), `hits` in `ray.finish` (20).
    let mut sorted = warnings.clone();
    sorted.sort();
    assert_eq!(sorted, [("W0005", 5), ("W0005", 18), ("W0006", 8), ("W0006", 13), ("W0006", 20)]);
    let lost = d.iter().find(|x| f.line(x.span) == 20).unwrap();
    assert_eq!(lost.message, "`finish` writes state field `hits`, but no later function reads it");
    let e = d.iter().find(|x| f.line(x.span) == 18).unwrap();
    assert!(e.notes.iter().any(|n| n.contains("reset to its default before every sample")), "{:?}", e.notes);
    // The same functions in a standard module get no warnings.
    let f = fx(&[("std_user.vrs", user)]);
    let (_, d) = f.compose(&f.all());
    assert!(d.is_empty(), "{:?}", codes(&d));
}

#[test]
fn written_never_read_is_w0006_and_left_out() {
    let std = "\
pipeline init in ray.setup {
@ray state out_color: vec4f = vec4f(0.0);
@ray state scratch: f32 = 0.0;
state.out_color = vec4f(1.0);
state.scratch = 1.0;
}
";
    let user = "\
pipeline debug in end {
state debug: vec4f = vec4f(0.0);
state unused: f32 = 0.0;
@ray state scratch: f32;
state.debug = vec4f(1.0);
}
";
    let px = "pipeline px in start { state pixel: vec2f = vec2f(0.0); @ray state n: f32 = 0.0; state.n = state.n + state.pixel.x; }";
    let f = fx(&[("std_init.vrs", std), ("user.vrs", user), ("px.vrs", px)]);
    let (c, d) = f.compose_with(&f.all(), &["out_color", "terminate", "pixel"]);
    let warnings: Vec<(&str, usize)> = d.iter().map(|x| (x.code.as_str(), f.line(x.span))).collect();
    // `debug`: W0006 at the user's writer. `scratch` written only by the standard module:
    // left out without a warning. `out_color` is required by the entry point: kept.
    // `pixel` is the entry point's: read without a writer, but no W0005.
    assert_eq!(warnings, [("W0006", 2)]);
    let kept: Vec<&str> = c.fields.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(kept, ["out_color", "pixel", "n"]);
    assert!(c.fields[0].written && !c.fields[0].read && c.fields[0].ray);
    assert_eq!(c.step(Step::RaySetup)[0].state, [Some(0), None]);
    assert_eq!(c.step(Step::End)[0].state, [None, None, None]);
}

#[test]
fn unread_fields_are_left_out() {
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"])]);
    assert!(d.is_empty(), "{:?}", codes(&d));
    // `color_wm` is read by `blend`, `accum` by `blend` itself; all read fields are kept in
    // first-declaration order along the pipeline.
    let kept: Vec<(&str, bool)> = c.fields.iter().map(|x| (x.name.as_str(), x.ray)).collect();
    assert_eq!(kept, [("pos", false), ("color_gm", false), ("color_wm", false), ("accum", true)]);
    // Remove the reader: the colours are written only. `color_wm` has only a standard
    // writer (no warning); `color_gm` is also written by `clip_gm`: W0006 there.
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP), ("user.vrs", "remove compositing.additional;")]);
    let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"]), f.plain(2)]);
    let kept: Vec<&str> = c.fields.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(kept, ["pos"]);
    let fns = c.step(Step::ClassificationAdditional);
    assert_eq!(fns[0].state, [None]);
    assert_eq!(fns[1].state, [Some(0), None]);
    assert_eq!(fns[2].state, [None]);
    assert_eq!(codes(&d), ["W0006"]);
    let e = only(&d, Code::WrittenNeverRead);
    assert_eq!(f.line(e.span), 10);
    assert!(e.notes.iter().any(|n| n == "in instance `gm` of template `clip_$`"), "{:?}", e.notes);
}

#[test]
fn pipeline_map_text() {
    let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    let (c, _) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
    let text = c.render_pipeline_map(&f.program, &f.sources);
    let expected = "\
ray.setup (empty)
start (empty)
sampling.primary
  setup    std_volumes.vrs:1
sampling.mask (empty)
sampling.tag (empty)
sampling.additional (empty)
sampling.gradient (empty)
classification.primary (empty)
classification.additional
  gm       std_volumes.vrs:5
  clip_gm  clip.vrs:6          (instance gm)
  wm       std_volumes.vrs:9
  clip_wm  clip.vrs:6          (instance wm)
shading.lights (empty)
shading.boundary (empty)
shading.tone (empty)
compositing.primary_color (empty)
compositing.shading (empty)
compositing.alpha (empty)
compositing.additional
  blend    std_volumes.vrs:13
end (empty)
ray.finish (empty)
";
    assert_eq!(text, expected);
    let map = c.pipeline_map(&f.program, &f.sources);
    assert_eq!(map.len(), 6);
    assert_eq!((map[2].file.as_str(), map[2].line, map[2].instance.as_deref()), ("clip.vrs", 6, Some("gm")));
}

#[test]
fn composition_is_deterministic() {
    let f = fx(&[("std_base.vrs", &std_base()), ("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
    let uses = [f.plain(0), f.plain(1), f.inst(2, &["wm", "gm"])];
    let (a, da) = f.compose(&uses);
    let (b, db) = f.compose(&uses);
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    assert_eq!(da.sorted(), db.sorted());
    assert_eq!(names(&a, Step::ClassificationAdditional), ["gm", "clip_gm", "wm", "clip_wm"]);
}
