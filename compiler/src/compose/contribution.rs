//! Samples that cannot contribute: the `contributes` flag and the order the entry point runs a
//! sample's functions in.
//!
//! The rule (also in `docs/reference.md`, "Samples that do not contribute"): `contributes` is a
//! per-sample `bool` field (default `true`, reset before every sample). A function that leaves it
//! `false` says that the rest of this sample, up to the `end` step, changes nothing that is kept:
//! the functions placed after the last function that writes it, up to `end`, run only while it
//! is `true`. The functions of `end` (marching, accumulation, early termination, skipping) always
//! run; a per-sample field that a skipped function would have written keeps its default there.
//!
//! The data flow decides which earlier functions may wait for the flag too: a function placed
//! before the last writer is deferred past it (and so skipped with the rest) when the flag cannot
//! depend on it and moving it cannot change what it computes, that is when
//! - it writes only per-sample fields, and not `contributes`;
//! - no function between it and the last writer that does not wait too reads what it writes,
//!   or writes what it reads (the waiting ones keep their order, so a chain such as the gradient
//!   and the shading normal made from it waits as a whole);
//! - no function of `end` reads what it writes (there a skip would show as a default).
//!
//! With the standard pipeline this defers the gradient (`sampling.gradient`) past DVR's flag
//! (set after classification), so transparent samples fetch no gradient and light nothing.
//!
//! The flag is tested only when some waiting function reads a volume or a transfer function:
//! otherwise the waiting work is a few arithmetic operations, and the test (with the entry
//! point's inner loop) costs more than it saves (unshaded DVR on lavapipe: 30% slower with it).
//!
//! `selected` (a per-sample `bool`, default `false`) is the flag of compositing that keeps one
//! sample of the ray (MIP): a sample that sets it becomes the ray's selected sample, and the
//! functions that wait for it (found as for `contributes`) run once, after the sample loop and
//! before `ray.finish`, on the last selected sample. Its writer promises that running them for
//! every selected sample would leave only the last one's effect. The entry point saves, at each
//! selected sample, the fields they read that the loop writes ([`Replay`]), and puts them back
//! before they run. Where a function of the loop reads a `@ray` field that they write, running
//! them once at the end would change what it sees, so they run at every selected sample instead
//! ([`Gate::SelectedEach`]; a probe reading `accum` is such a function). With a writer of
//! `selected`, `contributes` is not tested.

use super::ir::{Composition, PlacedFn};
use crate::hir;
use crate::steps::Step;
use crate::types::Type;

/// The state field whose `false` skips the rest of a sample.
pub const CONTRIBUTES: &str = "contributes";
/// The state field whose `true` makes the sample the one the ray keeps: the rest of the sample
/// runs once, after the loop, on the last sample that set it (see the module documentation).
pub const SELECTED: &str = "selected";

/// One placed sample function: its step and index in that step's list.
pub type SampleFn = (Step, usize);

/// Which flag the waiting functions of a [`SampleSchedule`] wait for, and when they run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Gate {
    /// `contributes`: they run for the samples that leave it `true`.
    Contributes,
    /// `selected`, run at every sample that sets it: some function of the loop reads a `@ray`
    /// field they write, so running them once at the end would change what it sees.
    SelectedEach,
    /// `selected`, run once after the loop on the last sample that set it.
    SelectedOnce(Replay),
}

/// What the entry point keeps of a selected sample for running the waiting functions after the
/// loop (field indices into the composition's `fields`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Replay {
    /// Saved at each selected sample and put back before the waiting functions run: the fields
    /// they read that the loop's functions write (every other field they read holds at the end
    /// what it held then).
    pub saved: Vec<usize>,
    /// The `@ray` fields among `saved` that the waiting functions do not write: given back their
    /// values from the end of the loop after the waiting functions ran, for `ray.finish`.
    pub restored: Vec<usize>,
}

/// The order of a sample's functions in the entry point.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleSchedule {
    /// Run for every sample, in this order.
    pub always: Vec<SampleFn>,
    /// Wait for the flag [`SampleSchedule::gate`] names: the deferred functions, then the
    /// functions after its last writer, in pipeline order. Empty without a writer.
    pub contributing: Vec<SampleFn>,
    /// The `end` step, run for every sample after the others.
    pub end: Vec<SampleFn>,
    /// The flag `contributing` waits for; `None` when it is empty.
    pub gate: Option<Gate>,
}

/// The fields one placed function reads and writes (indices into [`Composition::fields`]).
struct Access {
    reads: Vec<usize>,
    writes: Vec<usize>,
}

fn access(program: &hir::Program, placed: &PlacedFn) -> Access {
    let decls = &program.pipelines[placed.pipeline].state;
    let mut out = Access { reads: Vec::new(), writes: Vec::new() };
    for (decl, field) in decls.iter().zip(&placed.state) {
        let Some(field) = *field else { continue };
        if decl.read {
            out.reads.push(field);
        }
        if decl.written {
            out.writes.push(field);
        }
    }
    out
}

/// The `@ray` fields (indices into `Composition::fields`) that the sample functions `fns`
/// write: what they change that outlives the sample (the rest is reset at each sample's start).
pub fn ray_fields_written_by(
    program: &hir::Program,
    comp: &Composition,
    fns: impl IntoIterator<Item = SampleFn>,
) -> Vec<usize> {
    let mut written: Vec<usize> = fns
        .into_iter()
        .flat_map(|(step, i)| access(program, &comp.step(step)[i]).writes)
        .filter(|&f| comp.fields[f].ray)
        .collect();
    written.sort_unstable();
    written.dedup();
    written
}

/// The per-sample `bool` field `name` and the index (in `accesses`) of its last writer.
fn last_writer(comp: &Composition, accesses: &[Access], name: &str) -> Option<(usize, usize)> {
    let flag = comp.fields.iter().position(|f| f.name == name && !f.ray && f.ty == Type::BOOL)?;
    accesses.iter().rposition(|a| a.writes.contains(&flag)).map(|last| (flag, last))
}

/// The order the entry point runs the sample functions of `comp` in.
pub fn schedule(program: &hir::Program, comp: &Composition) -> SampleSchedule {
    let body: Vec<SampleFn> = Step::ALL
        .iter()
        .filter(|s| s.is_sample_step() && **s != Step::End)
        .flat_map(|&s| (0..comp.step(s).len()).map(move |i| (s, i)))
        .collect();
    let end: Vec<SampleFn> = (0..comp.step(Step::End).len()).map(|i| (Step::End, i)).collect();
    let placed = |(s, i): SampleFn| &comp.step(s)[i];
    let accesses: Vec<Access> = body.iter().map(|&f| access(program, placed(f))).collect();
    let end_accesses: Vec<Access> = end.iter().map(|&f| access(program, placed(f))).collect();
    let end_reads: Vec<usize> = end_accesses.iter().flat_map(|a| a.reads.iter().copied()).collect();

    // `selected` first: with its writer, `contributes` (a promise that skipping changes nothing)
    // is not needed.
    let selecting = last_writer(comp, &accesses, SELECTED);
    let (Some((flag, last)), selecting) =
        (selecting.or_else(|| last_writer(comp, &accesses, CONTRIBUTES)), selecting.is_some())
    else {
        return SampleSchedule { always: body, contributing: Vec::new(), end, gate: None };
    };

    // From the last writer backwards, so that whether each later function waits is known: a
    // function that feeds only functions that wait too may wait with them (their order kept).
    let mut deferred = vec![false; last + 1];
    for k in (0..last).rev() {
        let a = &accesses[k];
        let own = a.writes.iter().all(|&w| w != flag && !comp.fields[w].ray && !end_reads.contains(&w));
        let independent = (k + 1..=last).all(|j| {
            let b = &accesses[j];
            deferred[j]
                || (!b.reads.iter().any(|r| a.writes.contains(r)) && !b.writes.iter().any(|w| a.reads.contains(w)))
        });
        deferred[k] = own && independent;
    }
    let mut always = Vec::new();
    let mut waiting = Vec::new();
    let mut always_k = Vec::new();
    let mut waiting_k = Vec::new();
    for (k, &f) in body.iter().enumerate().take(last + 1) {
        if deferred[k] {
            waiting.push(f);
            waiting_k.push(k);
        } else {
            always.push(f);
            always_k.push(k);
        }
    }
    waiting.extend_from_slice(&body[last + 1..]);
    waiting_k.extend(last + 1..body.len());
    if selecting {
        let loop_fns = always_k.iter().map(|&k| &accesses[k]).chain(&end_accesses);
        let gate = replay(comp, waiting_k.iter().map(|&k| &accesses[k]), loop_fns);
        return SampleSchedule { always, contributing: waiting, end, gate: Some(gate) };
    }
    if !waiting.iter().any(|&f| reads_textures(program, placed(f))) {
        // Without texture reads the waiting work is a few arithmetic operations: testing the
        // flag (and gathering samples in the entry point's inner loop) costs more than it saves.
        always.append(&mut waiting);
        always.sort_by_key(|f| body.iter().position(|g| g == f));
        return SampleSchedule { always, contributing: Vec::new(), end, gate: None };
    }
    SampleSchedule { always, contributing: waiting, end, gate: Some(Gate::Contributes) }
}

/// When the functions waiting for `selected` run: once after the loop unless a function of the
/// loop (`loop_fns`: those that always run, and `end`) reads a `@ray` field they write, and
/// which fields that needs saved.
fn replay<'a>(
    comp: &Composition,
    waiting: impl Iterator<Item = &'a Access> + Clone,
    loop_fns: impl Iterator<Item = &'a Access> + Clone,
) -> Gate {
    let written_by_waiting = |f: usize| waiting.clone().any(|a| a.writes.contains(&f));
    let read_in_loop = |f: usize| loop_fns.clone().any(|a| a.reads.contains(&f));
    let written_in_loop = |f: usize| loop_fns.clone().any(|a| a.writes.contains(&f));
    let ray_fields_seen =
        (0..comp.fields.len()).any(|f| comp.fields[f].ray && written_by_waiting(f) && read_in_loop(f));
    if ray_fields_seen {
        return Gate::SelectedEach;
    }
    let mut saved: Vec<usize> =
        waiting.clone().flat_map(|a| a.reads.iter().copied()).filter(|&f| written_in_loop(f)).collect();
    saved.sort_unstable();
    saved.dedup();
    let restored = saved.iter().copied().filter(|&f| comp.fields[f].ray && !written_by_waiting(f)).collect();
    Gate::SelectedOnce(Replay { saved, restored })
}

/// Whether a placed function reads a volume or a transfer function (declares such a uniform):
/// the cost that makes waiting for `contributes` worth its test.
fn reads_textures(program: &hir::Program, placed: &PlacedFn) -> bool {
    let uniforms = &program.pipelines[placed.pipeline].uniforms;
    uniforms.iter().any(|u| matches!(u.ty, Type::Volume | Type::Tf))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::check_program;
    use crate::compose::compose;
    use crate::compose::ir::ModuleUse;
    use crate::diag::Diagnostics;
    use crate::loader::Loader;
    use crate::source::{SourceMap, Span};

    /// The schedule of one user module composed alone, as substep names.
    fn names(src: &str) -> [Vec<String>; 3] {
        scheduled(src).0
    }

    /// The schedule of one user module composed alone, as substep names, and its gate in words:
    /// `none`, `contributes`, `each` or `once saved=[..] restored=[..]` (field names).
    fn scheduled(src: &str) -> ([Vec<String>; 3], String) {
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let mut loader = Loader::new(&mut sources, &mut diags);
        let module = loader.load_root_source("m.vrs", src.to_string(), None);
        let graph = loader.finish();
        let program = check_program(&graph, &sources, &mut diags);
        assert!(!diags.iter().any(|d| d.is_error()), "check errors");
        let uses = vec![ModuleUse { module, instances: None, span: Span::DUMMY }];
        let comp = compose(
            &program,
            &uses,
            (crate::steps::PipelineKind::Ray, |_| false),
            &["out_color", CONTRIBUTES, SELECTED],
            &mut diags,
        );
        let s = schedule(&program, &comp);
        let show = |fs: &[SampleFn]| fs.iter().map(|&(st, i)| comp.step(st)[i].name.clone()).collect();
        let fields = |fs: &[usize]| fs.iter().map(|&f| comp.fields[f].name.as_str()).collect::<Vec<_>>().join(",");
        let gate = match &s.gate {
            None => "none".to_string(),
            Some(Gate::Contributes) => "contributes".to_string(),
            Some(Gate::SelectedEach) => "each".to_string(),
            Some(Gate::SelectedOnce(r)) => {
                format!("once saved=[{}] restored=[{}]", fields(&r.saved), fields(&r.restored))
            }
        };
        ([show(&s.always), show(&s.contributing), show(&s.end)], gate)
    }

    /// MIP's shape: the writer keeps the largest value; classification, a gradient and the
    /// selection of the colour wait for `selected`.
    const SELECTING: &str = r#"
pipeline place in start { @ray state t_next: f32 = 0.0; state pos: vec3f = vec3f(0.0); state.pos = vec3f(state.t_next); }
pipeline value in sampling.primary { uniform v: volume; state pos: vec3f = vec3f(0.0); state value: f32 = 0.0; state.value = sample(v, state.pos); }
pipeline grad in sampling.gradient { uniform v: volume; state pos: vec3f = vec3f(0.0); state g: f32 = 0.0; state.g = sample(v, state.pos); }
pipeline keep before classification {
    state value: f32 = 0.0; @ray state best: f32 = -1.0; state selected: bool = false;
    if state.value > state.best { state.best = state.value; state.selected = true; }
}
pipeline colour in classification.primary { uniform t: tf; state value: f32 = 0.0; state g: f32 = 0.0; state c: vec4f = vec4f(0.0); state.c = lookup(t, state.value) * state.g; }
pipeline pick in compositing.alpha { state c: vec4f = vec4f(0.0); @ray state out_color: vec4f = vec4f(0.0); state.out_color = state.c; }
pipeline walk in end { @ray state best: f32 = -1.0; @ray state t_next: f32 = 0.0; state.t_next += state.best; }
"#;

    #[test]
    fn functions_waiting_for_selected_run_once_on_the_saved_fields_of_the_kept_sample() {
        let ([always, waiting, end], gate) = scheduled(SELECTING);
        assert_eq!(always, ["place", "value", "keep"]);
        assert_eq!(waiting, ["grad", "colour", "pick"]);
        assert_eq!(end, ["walk"]);
        // `grad` reads `pos`, `colour` reads `value` (both written in the loop); `g` and `c` are
        // computed by the waiting functions themselves.
        assert_eq!(gate, "once saved=[pos,value] restored=[]");
    }

    #[test]
    fn a_ray_field_the_loop_writes_is_saved_and_given_back_after_the_waiting_functions() {
        let src = SELECTING
            .replace("state c: vec4f = vec4f(0.0); state.c = lookup(t, state.value) * state.g;", "state c: vec4f = vec4f(0.0); @ray state best: f32 = -1.0; state.c = lookup(t, state.value) * state.g * state.best;");
        let (_, gate) = scheduled(&src);
        assert_eq!(gate, "once saved=[pos,value,best] restored=[best]");
    }

    #[test]
    fn a_ray_field_the_loop_reads_makes_selected_functions_run_at_each_selected_sample() {
        let src = SELECTING.replace("state.t_next += state.best;", "state.t_next += state.best + state.out_color.a;");
        let src = src.replace(
            "@ray state t_next: f32 = 0.0;",
            "@ray state t_next: f32 = 0.0; @ray state out_color: vec4f = vec4f(0.0);",
        );
        let (_, gate) = scheduled(&src);
        assert_eq!(gate, "each");
    }

    #[test]
    fn with_a_writer_of_selected_contributes_is_not_tested() {
        let src = SELECTING.replace(
            "state.c = lookup(t, state.value) * state.g; }",
            "state.c = lookup(t, state.value) * state.g; }\npipeline flag in shading.lights { state contributes: bool = true; state c: vec4f = vec4f(0.0); state.contributes = state.c.a > 0.0; }",
        );
        let ([_, waiting, _], gate) = scheduled(&src);
        assert!(gate.starts_with("once"), "{gate}");
        assert_eq!(waiting, ["grad", "colour", "flag", "pick"]);
    }

    #[test]
    fn without_texture_reads_selected_functions_still_wait() {
        // Running them for every sample would change the image: they are not folded back.
        let src = SELECTING.replace("uniform t: tf; ", "").replace("lookup(t, state.value)", "vec4f(state.value)");
        let src = src.replace(
            "uniform v: volume; state pos: vec3f = vec3f(0.0); state g: f32 = 0.0; state.g = sample(v, state.pos);",
            "state g: f32 = 0.0; state.g = 1.0;",
        );
        let ([_, waiting, _], gate) = scheduled(&src);
        assert_eq!(waiting, ["grad", "colour", "pick"]);
        assert_eq!(gate, "once saved=[value] restored=[]");
    }

    const PIPELINE: &str = r#"
pipeline value in sampling.primary { state value: f32 = 0.0; state.value = 0.5; }
pipeline grad in sampling.gradient { uniform v: volume; state g: f32 = 0.0; state.g = sample(v, vec3f(0.5)); }
pipeline classify in classification.primary {
    state value: f32 = 0.0; state a: f32 = 0.0; state contributes: bool = true;
    state.a = state.value; state.contributes = state.a > 0.0;
}
pipeline shade in shading.lights {
    uniform t: tf; state g: f32 = 0.0; state a: f32 = 0.0; state.a = state.a * state.g * lookup(t, 0.5).a;
}
pipeline add in end { state a: f32 = 0.0; @ray state out_color: vec4f = vec4f(0.0); state.out_color.a += state.a; }
"#;

    #[test]
    fn functions_after_the_writer_wait_for_the_flag_and_independent_ones_are_deferred() {
        let [always, contributing, end] = names(PIPELINE);
        assert_eq!(always, ["value", "classify"]);
        assert_eq!(contributing, ["grad", "shade"]);
        assert_eq!(end, ["add"]);
    }

    #[test]
    fn a_chain_of_functions_that_feed_only_waiting_ones_waits_as_a_whole() {
        // `normal` turns the gradient into what `shade` reads; both wait, in their order.
        let src = PIPELINE
            .replace(
                "pipeline classify in",
                "pipeline normal after sampling.gradient { state g: f32 = 0.0; state n: f32 = 0.0; state.n = 2.0 * state.g; }\n\
                 pipeline classify in",
            )
            .replace("state.a = state.a * state.g * lookup", "state.a = state.a * state.n * lookup")
            .replace("uniform t: tf; state g: f32 = 0.0;", "uniform t: tf; state n: f32 = 0.0;");
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "classify"]);
        assert_eq!(contributing, ["grad", "normal", "shade"]);
        // A chain the flag depends on does not wait: `classify` reads `n`.
        let src = src.replace("state.a = state.value;", "state.a = state.value + 0.0 * state.n;").replace(
            "state value: f32 = 0.0; state a: f32",
            "state value: f32 = 0.0; state n: f32 = 0.0; state a: f32",
        );
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "grad", "normal", "classify"]);
        assert_eq!(contributing, ["shade"]);
    }

    #[test]
    fn a_function_the_flag_depends_on_is_not_deferred() {
        // `grad` now feeds the opacity the flag is computed from.
        let src = PIPELINE.replace("state.a = state.value;", "state.a = state.value; state.a += 0.0 * state.g;");
        let src = src.replace(
            "state value: f32 = 0.0; state a: f32",
            "state value: f32 = 0.0; state g: f32 = 0.0; state a: f32",
        );
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "grad", "classify"]);
        assert_eq!(contributing, ["shade"]);
    }

    #[test]
    fn a_function_whose_output_end_reads_is_not_deferred() {
        let src = PIPELINE.replace(
            "pipeline add in end { state a: f32 = 0.0;",
            "pipeline add in end { state g: f32 = 0.0; state a: f32 = 0.0;",
        );
        let src = src.replace("state.out_color.a += state.a;", "state.out_color.a += state.a + state.g;");
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "grad", "classify"]);
        assert_eq!(contributing, ["shade"]);
    }

    #[test]
    fn without_texture_reads_to_save_nothing_waits() {
        let src = PIPELINE
            .replace(
                "uniform v: volume; state g: f32 = 0.0; state.g = sample(v, vec3f(0.5));",
                "state g: f32 = 0.0; state.g = 1.0;",
            )
            .replace(" * lookup(t, 0.5).a;", ";")
            .replace("uniform t: tf; ", "");
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "grad", "classify", "shade"]);
        assert!(contributing.is_empty());
    }

    #[test]
    fn without_a_writer_every_function_always_runs() {
        let src = PIPELINE.replace("state.contributes = state.a > 0.0;", "");
        let [always, contributing, _] = names(&src);
        assert_eq!(always, ["value", "grad", "classify", "shade"]);
        assert!(contributing.is_empty());
    }
}
