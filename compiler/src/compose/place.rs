//! Placement: every unit into the steps, in order (`docs/language.md`, "Steps and placement").

use super::instantiate::{Source, Unit, instance_note};
use crate::ast::PlacementKind;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir;
use crate::source::Span;
use crate::steps::Step;
use crate::suggest::did_you_mean;
use rustc_hash::FxHashMap;

/// Who took the place of a substep through `replace`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Replaced {
    /// The `replace` placement.
    span: Span,
    /// The unit that replaced it.
    by: usize,
    /// `replace S` of the whole step, rather than `replace S[x]`.
    whole_step: bool,
}

pub(super) struct Placer<'a> {
    pub(super) program: &'a hir::Program,
    pub(super) units: &'a [Unit],
    /// Per step (in `Step::ALL` order), the units placed there, in order.
    pub(super) steps: Vec<Vec<usize>>,
    /// (step, substep name) → the replacement that took its place.
    pub(super) replaced: FxHashMap<(Step, String), Replaced>,
    pub(super) diags: &'a mut Diagnostics,
}

fn step_index(step: Step) -> usize {
    Step::ALL.iter().position(|s| *s == step).unwrap_or(0)
}

impl<'a> Placer<'a> {
    fn find(&self, s: usize, name: &str) -> Option<usize> {
        self.steps[s].iter().position(|&u| self.units[u].name == name)
    }

    fn pipeline(&self, u: usize) -> Option<&'a hir::PipelineFn> {
        match self.units[u].source {
            Source::Pipeline(i) => self.program.pipelines.get(i),
            Source::Remove(_) => None,
        }
    }

    /// Adds "in instance `gm` of template `clip_$`" for an instantiated unit.
    fn instance_note(&self, d: Diagnostic, u: usize) -> Diagnostic {
        instance_note(self.program, &self.units[u], d)
    }

    pub(super) fn place(&mut self, u: usize) {
        let Some(p) = self.pipeline(u) else { return };
        let pl = &p.placement;
        let step = pl.step;
        let s = step_index(step);
        let sub = pl.substep.as_deref().map(|x| self.units[u].subst(x));
        let pos = match &sub {
            Some(x) => {
                let pos = self.find(s, x);
                // Taken already: gone, or still held by the earlier replacement (named x).
                if pl.kind == PlacementKind::Replace
                    && let Some(r) = self.replaced.get(&(step, x.clone())).copied()
                    && pos.is_none_or(|i| self.steps[s][i] == r.by)
                {
                    self.double_replace(u, step, x, pl.span, r);
                    return;
                }
                match pos {
                    Some(i) => Some(i),
                    None => {
                        if !pl.when_active {
                            self.unknown_substep(u, step, x, pl.span, false);
                        }
                        return;
                    }
                }
            }
            None => {
                if pl.when_active && self.steps[s].is_empty() {
                    return;
                }
                None
            }
        };
        let whole_replace = pl.kind == PlacementKind::Replace && sub.is_none();
        let replaced_pos = if pl.kind == PlacementKind::Replace { pos } else { None };
        if !whole_replace && let Some(j) = self.find(s, &self.units[u].name).filter(|&j| Some(j) != replaced_pos) {
            self.duplicate(u, step, self.steps[s][j]);
            return;
        }
        let span = pl.span;
        let kind = pl.kind;
        let list = &mut self.steps[s];
        match (kind, pos) {
            (PlacementKind::In | PlacementKind::After, None) => list.push(u),
            (PlacementKind::Before, None) => list.insert(0, u),
            (PlacementKind::Replace, None) => {
                for old in std::mem::take(list) {
                    let name = self.units[old].name.clone();
                    self.replaced.insert((step, name), Replaced { span, by: u, whole_step: true });
                }
                self.steps[s].push(u);
            }
            (PlacementKind::Before, Some(i)) => list.insert(i, u),
            (PlacementKind::In | PlacementKind::After, Some(i)) => list.insert(i + 1, u),
            (PlacementKind::Replace, Some(i)) => {
                let old = std::mem::replace(&mut list[i], u);
                let name = self.units[old].name.clone();
                self.replaced.insert((step, name), Replaced { span, by: u, whole_step: false });
            }
        }
    }

    pub(super) fn remove(&mut self, u: usize) {
        let Source::Remove(ri) = self.units[u].source else { return };
        let Some(r) = self.program.removes.get(ri) else { return };
        let s = step_index(r.step);
        match r.substep.as_deref().map(|x| self.units[u].subst(x)) {
            None => self.steps[s].clear(),
            Some(x) => match self.find(s, &x) {
                Some(i) => {
                    self.steps[s].remove(i);
                }
                None if r.when_active => {}
                None => self.unknown_substep(u, r.step, &x, r.span, true),
            },
        }
    }

    fn unknown_substep(&mut self, u: usize, step: Step, x: &str, span: Span, is_remove: bool) {
        let s = step_index(step);
        let names: Vec<&str> = self.steps[s].iter().map(|&v| self.units[v].name.as_str()).collect();
        let mut d = Diagnostic::new(Code::UnknownSubstep, span, format!("step `{step}` has no substep `{x}`"))
            .with_label(format!("no function named `{x}` in `{step}` at this point"));
        if let Some(r) = self.replaced.get(&(step, x.to_string())) {
            let label = if r.whole_step {
                format!("`replace {step}` took the place of `{x}` here")
            } else {
                format!("`{x}` was replaced by `{}` here", self.units[r.by].name)
            };
            d = d.with_secondary(r.span, label);
        }
        if let Some(best) = did_you_mean(x, names.iter().copied()) {
            d = d.with_help(format!("did you mean `{step}[{best}]`?"));
        }
        d = if names.is_empty() {
            d.with_note(format!("`{step}` holds no functions at this point"))
        } else {
            let list: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
            d.with_note(format!("substeps of `{step}` at this point: {}", list.join(", ")))
        };
        d = d.with_note(
            "placements apply in module order: standard modules first, then the scene's, each in source order",
        );
        let what = if is_remove { "remove it" } else { "place it" };
        d = d.with_help(format!("add `when active` to {what} only when the substep exists"));
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }

    fn double_replace(&mut self, u: usize, step: Step, x: &str, span: Span, r: Replaced) {
        let earlier = if r.whole_step {
            format!("`replace {step}` already took the place of every function of the step, `{x}` included")
        } else {
            format!("first replaced here by `{}`", self.units[r.by].name)
        };
        let d = Diagnostic::new(Code::DoubleReplace, span, format!("substep `{x}` of `{step}` is replaced twice"))
            .with_label(format!("second replacement of `{x}`"))
            .with_secondary(r.span, earlier)
            .with_note("two replacements would silently fight over one place")
            .with_help(format!(
                "remove one of them, or place this function `before` or `after` `{step}[{}]`",
                self.units[r.by].name
            ));
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }

    fn duplicate(&mut self, u: usize, step: Step, earlier: usize) {
        let name = self.units[u].name.clone();
        let span = self.pipeline(u).map_or(Span::DUMMY, |p| p.span);
        let mut d = Diagnostic::new(Code::Duplicate, span, format!("`{name}` is placed twice in `{step}`"))
            .with_label(format!("a second `{name}` in `{step}`"));
        if let Some(p) = self.pipeline(earlier) {
            d = d.with_secondary(p.span, "placed first here");
        }
        d = d
            .with_note("a function's name is its substep name, so the functions of one step need distinct names")
            .with_help("rename one of them, or `replace` the first");
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }
}
