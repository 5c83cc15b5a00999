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

use super::ir::{Composition, PlacedFn};
use crate::hir;
use crate::steps::Step;

/// The state field whose `false` skips the rest of a sample.
pub const CONTRIBUTES: &str = "contributes";

/// One placed sample function: its step and index in that step's list.
pub type SampleFn = (Step, usize);

/// The order of a sample's functions in the entry point.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleSchedule {
    /// Run for every sample, in this order.
    pub always: Vec<SampleFn>,
    /// Run after `always` only while `contributes` is true: the deferred functions, then the
    /// functions after the last writer, in pipeline order. Empty without a writer.
    pub contributing: Vec<SampleFn>,
    /// The `end` step, run for every sample after the others.
    pub end: Vec<SampleFn>,
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

/// The order the entry point runs the sample functions of `comp` in.
pub fn schedule(program: &hir::Program, comp: &Composition) -> SampleSchedule {
    let body: Vec<SampleFn> = Step::ALL
        .iter()
        .filter(|s| !s.is_per_ray() && **s != Step::End)
        .flat_map(|&s| (0..comp.step(s).len()).map(move |i| (s, i)))
        .collect();
    let end: Vec<SampleFn> = (0..comp.step(Step::End).len()).map(|i| (Step::End, i)).collect();
    let placed = |(s, i): SampleFn| &comp.step(s)[i];
    let accesses: Vec<Access> = body.iter().map(|&f| access(program, placed(f))).collect();
    let end_reads: Vec<usize> = end.iter().flat_map(|&f| access(program, placed(f)).reads).collect();

    let flag = comp.fields.iter().position(|f| f.name == CONTRIBUTES && !f.ray && f.ty == crate::types::Type::BOOL);
    let last_writer = flag.and_then(|flag| accesses.iter().rposition(|a| a.writes.contains(&flag)));
    let (Some(flag), Some(last)) = (flag, last_writer) else {
        return SampleSchedule { always: body, contributing: Vec::new(), end };
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
    let mut contributing = Vec::new();
    for (k, &f) in body.iter().enumerate().take(last + 1) {
        if deferred[k] {
            contributing.push(f);
        } else {
            always.push(f);
        }
    }
    contributing.extend_from_slice(&body[last + 1..]);
    if !contributing.iter().any(|&f| reads_textures(program, placed(f))) {
        // Without texture reads the waiting work is a few arithmetic operations: testing the
        // flag (and gathering samples in the entry point's inner loop) costs more than it saves.
        always.append(&mut contributing);
        always.sort_by_key(|f| body.iter().position(|g| g == f));
    }
    SampleSchedule { always, contributing, end }
}

/// Whether a placed function reads a volume or a transfer function (declares such a uniform):
/// the cost that makes waiting for `contributes` worth its test.
fn reads_textures(program: &hir::Program, placed: &PlacedFn) -> bool {
    let uniforms = &program.pipelines[placed.pipeline].uniforms;
    uniforms.iter().any(|u| matches!(u.ty, crate::types::Type::Volume | crate::types::Type::Tf))
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
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let mut loader = Loader::new(&mut sources, &mut diags);
        let module = loader.load_root_source("m.vrs", src.to_string(), None);
        let graph = loader.finish();
        let program = check_program(&graph, &sources, &mut diags);
        assert!(!diags.iter().any(|d| d.is_error()), "check errors");
        let uses = vec![ModuleUse { module, instances: None, span: Span::DUMMY }];
        let comp = compose(&program, &uses, |_| false, &["out_color", CONTRIBUTES], &mut diags);
        let s = schedule(&program, &comp);
        let show = |fs: &[SampleFn]| fs.iter().map(|&(st, i)| comp.step(st)[i].name.clone()).collect();
        [show(&s.always), show(&s.contributing), show(&s.end)]
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
