//! Merging: the state and uniform declarations of the placed functions into the composed state
//! and uniforms, with their conflicts and the data-flow warnings of the linear pipeline.

use super::instantiate::{Source, Unit, instance_note};
use super::ir::{Composition, Field, PlacedFn, StepFunctions, Uniform};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir::show_const;
use crate::hir::{self, ConstValue, ScalarValue};
use crate::source::Span;
use crate::steps::Step;
use crate::types::{Scalar, Type};
use rustc_hash::FxHashMap;

/// A declaration: (unit, index of the declaration in its function).
type DeclRef = (usize, usize);

/// A field being merged.
struct FieldAcc {
    name: String,
    first: DeclRef,
    first_default: Option<DeclRef>,
    /// (position along the pipeline, phase, unit, decl index, read, written).
    uses: Vec<Use>,
}

#[derive(Clone, Copy)]
struct Use {
    position: usize,
    phase: u8,
    unit: usize,
    decl: usize,
    read: bool,
    written: bool,
}

struct UniformAcc {
    first: DeclRef,
    first_default: Option<DeclRef>,
    range: Option<DeclRef>,
    doc: Option<DeclRef>,
}

/// The declarations merged so far, by name, and each placed unit's indices into them.
#[derive(Default)]
struct Merged {
    fields: Vec<FieldAcc>,
    field_index: FxHashMap<String, usize>,
    uniforms: Vec<(String, UniformAcc)>,
    uniform_index: FxHashMap<String, usize>,
    /// Per unit: the field / uniform index of each declaration.
    unit_fields: FxHashMap<usize, Vec<usize>>,
    unit_uniforms: FxHashMap<usize, Vec<usize>>,
}

/// 0 before the sample loop, 1 in it, 2 after it.
fn phase(step: Step) -> u8 {
    match step {
        Step::RaySetup => 0,
        Step::RayFinish => 2,
        _ => 1,
    }
}

pub(super) struct Merger<'a, F: Fn(usize) -> bool> {
    pub(super) program: &'a hir::Program,
    pub(super) units: &'a [Unit],
    pub(super) is_std: &'a F,
    pub(super) required: &'a [&'a str],
    pub(super) kind: crate::steps::PipelineKind,
    pub(super) diags: &'a mut Diagnostics,
}

impl<'a, F: Fn(usize) -> bool> Merger<'a, F> {
    fn pipe(&self, u: usize) -> &'a hir::PipelineFn {
        match self.units[u].source {
            Source::Pipeline(i) => &self.program.pipelines[i],
            Source::Remove(_) => unreachable!("only pipeline functions are placed"),
        }
    }

    fn state(&self, (u, j): DeclRef) -> &'a hir::StateDecl {
        &self.pipe(u).state[j]
    }

    fn uniform(&self, (u, j): DeclRef) -> &'a hir::UniformDecl {
        &self.pipe(u).uniforms[j]
    }

    /// A uniform's doc comment, with `$` replaced by the instance as in the uniform's name.
    fn uniform_doc(&self, r: DeclRef) -> Option<String> {
        let doc = self.uniform(r).doc.as_ref()?;
        Some(match &self.units[r.0].instance {
            Some(instance) => doc.replace('$', instance),
            None => doc.clone(),
        })
    }

    fn unit_is_std(&self, u: usize) -> bool {
        (self.is_std)(self.pipe(u).module)
    }

    /// "in `name`" or "in `name` (instance `gm`)" for messages about an earlier declaration.
    fn owner(&self, u: usize) -> String {
        match &self.units[u].instance {
            Some(i) => format!("`{}` (instance `{i}`)", self.units[u].name),
            None => format!("`{}`", self.units[u].name),
        }
    }

    fn push(&mut self, u: usize, d: Diagnostic) {
        let d = instance_note(self.program, &self.units[u], d);
        self.diags.push(d);
    }

    pub(super) fn merge(mut self, placed: &[Vec<usize>]) -> Composition {
        // The placed units along the pipeline.
        let order: Vec<(Step, usize)> =
            Step::ALL.iter().zip(placed).flat_map(|(step, units)| units.iter().map(move |&u| (*step, u))).collect();
        let mut merged = Merged::default();
        for (position, &(step, u)) in order.iter().enumerate() {
            let fields = self.merge_state(&mut merged, position, step, u);
            merged.unit_fields.insert(u, fields);
            let uniforms = self.merge_uniforms(&mut merged, u);
            merged.unit_uniforms.insert(u, uniforms);
        }
        // Defaults, data flow, and which fields are kept.
        let mut kept: Vec<Option<usize>> = vec![None; merged.fields.len()];
        let mut fields = Vec::new();
        for (fi, acc) in merged.fields.iter().enumerate() {
            if let Some(field) = self.finish_field(acc) {
                kept[fi] = Some(fields.len());
                fields.push(field);
            }
        }
        let uniforms = merged.uniforms.iter().map(|(name, acc)| self.finish_uniform(name, acc)).collect();
        // Only the steps of the composition's pipeline (the other's hold nothing after
        // `leave_out_other_pipeline`).
        let steps = Step::ALL
            .iter()
            .zip(placed)
            .filter(|(step, _)| step.kind() == self.kind)
            .map(|(&step, units)| StepFunctions {
                step,
                functions: units.iter().map(|&u| self.placed_fn(u, &merged, &kept)).collect(),
            })
            .collect();
        Composition { steps, fields, uniforms, not_placed: Vec::new(), kind: self.kind }
    }

    /// The state declarations of unit `u` (at `position` along the pipeline) into the merged
    /// fields; their field indices.
    fn merge_state(&mut self, merged: &mut Merged, position: usize, step: Step, u: usize) -> Vec<usize> {
        let decls = self.pipe(u).state.len();
        let mut indices = Vec::with_capacity(decls);
        for j in 0..decls {
            let decl = self.state((u, j));
            let name = self.units[u].subst(&decl.name);
            let use_ = Use { position, phase: phase(step), unit: u, decl: j, read: decl.read, written: decl.written };
            let fi = match merged.field_index.get(&name) {
                Some(&fi) => {
                    self.check_state(&mut merged.fields[fi], (u, j));
                    fi
                }
                None => {
                    merged.field_index.insert(name.clone(), merged.fields.len());
                    let first_default = decl.default.is_some().then_some((u, j));
                    merged.fields.push(FieldAcc { name, first: (u, j), first_default, uses: Vec::new() });
                    merged.fields.len() - 1
                }
            };
            merged.fields[fi].uses.push(use_);
            indices.push(fi);
        }
        indices
    }

    /// The uniform declarations of unit `u` into the merged uniforms; their uniform indices.
    fn merge_uniforms(&mut self, merged: &mut Merged, u: usize) -> Vec<usize> {
        let decls = self.pipe(u).uniforms.len();
        let mut indices = Vec::with_capacity(decls);
        for j in 0..decls {
            let decl = self.uniform((u, j));
            let name = self.units[u].subst(&decl.name);
            let ui = match merged.uniform_index.get(&name) {
                Some(&ui) => {
                    self.check_uniform(&name, &mut merged.uniforms[ui].1, (u, j));
                    ui
                }
                None => {
                    merged.uniform_index.insert(name.clone(), merged.uniforms.len());
                    let has = |b: bool| b.then_some((u, j));
                    let acc = UniformAcc {
                        first: (u, j),
                        first_default: has(decl.default.is_some()),
                        range: has(decl.range.is_some()),
                        doc: has(decl.doc.is_some()),
                    };
                    merged.uniforms.push((name, acc));
                    merged.uniforms.len() - 1
                }
            };
            indices.push(ui);
        }
        indices
    }

    /// A merged field's default (E0605 without one) and data flow (W0005, W0006); the field,
    /// unless it is left out because nothing reads it.
    fn finish_field(&mut self, acc: &FieldAcc) -> Option<Field> {
        let first = self.state(acc.first);
        if acc.first_default.is_none() {
            let d = Diagnostic::new(
                Code::NoDefault,
                first.span,
                format!("no declaration of state field `{}` gives a default", acc.name),
            )
            .with_label("declared here without a default")
            .with_note("a field is reset to its default before every sample (an `@ray` field before every ray)")
            .with_help(format!("give a default: `state {}: {} = ...;`", acc.name, first.ty));
            self.push(acc.first.0, d);
        }
        let read = acc.uses.iter().any(|x| x.read);
        let written = acc.uses.iter().any(|x| x.written);
        let required = self.required.contains(&acc.name.as_str());
        if !required {
            self.read_before_write(acc, first.ray);
            if read {
                self.dead_writes(acc, first.ray);
            }
        }
        if written && !read && !required {
            self.never_read(acc);
        }
        if !(read || required) {
            return None;
        }
        let default = match acc.first_default {
            Some(r) => self.state(r).default.clone().unwrap_or_else(|| zero_value(first.ty)),
            None => zero_value(first.ty),
        };
        Some(Field { name: acc.name.clone(), ty: first.ty, ray: first.ray, default, read, written, span: first.span })
    }

    /// W0006 for the first write of a field no function reads, by a non-standard function.
    fn never_read(&mut self, acc: &FieldAcc) {
        let Some(w) = acc.uses.iter().find(|x| x.written && !self.unit_is_std(x.unit)) else { return };
        let d = Diagnostic::new(
            Code::WrittenNeverRead,
            self.state((w.unit, w.decl)).span,
            format!("state field `{}` is written but no function of the pipeline reads it", acc.name),
        )
        .with_label("written here, never read")
        .with_note("the field is left out of the composed state, so the write has no effect")
        .with_help("read it in a later step, or remove the write");
        self.push(w.unit, d);
    }

    /// A merged uniform: the first type, and the first default, range and doc given.
    fn finish_uniform(&self, name: &str, acc: &UniformAcc) -> Uniform {
        let first = self.uniform(acc.first);
        Uniform {
            name: name.to_string(),
            ty: first.ty,
            default: acc.first_default.and_then(|r| self.uniform(r).default.clone()),
            range: acc.range.and_then(|r| self.uniform(r).range.clone()),
            doc: acc.doc.and_then(|r| self.uniform_doc(r)),
            span: first.span,
        }
    }

    /// Placed unit `u` with its declarations' indices into the composed state and uniforms.
    fn placed_fn(&self, u: usize, merged: &Merged, kept: &[Option<usize>]) -> PlacedFn {
        let Source::Pipeline(pipeline) = self.units[u].source else {
            unreachable!("only pipeline functions are placed")
        };
        PlacedFn {
            pipeline,
            name: self.units[u].name.clone(),
            instance: self.units[u].instance.clone(),
            state: merged.unit_fields[&u].iter().map(|&fi| kept[fi]).collect(),
            uniforms: merged.unit_uniforms[&u].clone(),
        }
    }

    /// Type, lifetime and default of a later declaration against the first ones. Declarations
    /// whose names are equal as written were compared by the checker already.
    fn check_state(&mut self, acc: &mut FieldAcc, later: DeclRef) {
        let decl = self.state(later);
        let first = self.state(acc.first);
        let name = &acc.name;
        if first.name != decl.name {
            let owner = self.owner(acc.first.0);
            if first.ty != decl.ty {
                let d = Diagnostic::new(
                    Code::StateConflict,
                    decl.span,
                    format!("state field `{name}` is declared as {} here but as {} in {owner}", decl.ty, first.ty),
                )
                .with_label(format!("declared as {}", decl.ty))
                .with_secondary(first.span, format!("first declared here as {}", first.ty))
                .with_help(format!("every declaration of `state {name}` must have the same type"));
                self.push(later.0, d);
                return;
            }
            if first.ray != decl.ray {
                let lifetime = |ray: bool| if ray { "`@ray`" } else { "per-sample" };
                let d = Diagnostic::new(
                    Code::StateConflict,
                    decl.span,
                    format!(
                        "state field `{name}` is {} here but {} in {owner}",
                        lifetime(decl.ray),
                        lifetime(first.ray)
                    ),
                )
                .with_label(format!("{} here", lifetime(decl.ray)))
                .with_secondary(first.span, format!("first declared here as {}", lifetime(first.ray)))
                .with_help(if first.ray {
                    "add `@ray` to this declaration"
                } else {
                    "remove `@ray` from this declaration"
                });
                self.push(later.0, d);
                return;
            }
        }
        let Some(value) = &decl.default else { return };
        let Some(earlier_ref) = acc.first_default else {
            acc.first_default = Some(later);
            return;
        };
        let earlier = self.state(earlier_ref);
        if let Some(d) = default_conflict("state field", name, earlier, earlier.default.as_ref(), decl, value, || {
            self.owner(earlier_ref.0)
        }) {
            self.push(later.0, d);
        }
    }

    fn check_uniform(&mut self, name: &str, acc: &mut UniformAcc, later: DeclRef) {
        let decl = self.uniform(later);
        let first = self.uniform(acc.first);
        if first.name != decl.name && first.ty != decl.ty {
            let owner = self.owner(acc.first.0);
            let d = Diagnostic::new(
                Code::UniformConflict,
                decl.span,
                format!("uniform `{name}` is declared as {} here but as {} in {owner}", decl.ty, first.ty),
            )
            .with_label(format!("declared as {}", decl.ty))
            .with_secondary(first.span, format!("first declared here as {}", first.ty))
            .with_help(format!("every declaration of `uniform {name}` must have the same type"));
            self.push(later.0, d);
            return;
        }
        if acc.range.is_none() && decl.range.is_some() {
            acc.range = Some(later);
        }
        if acc.doc.is_none() && decl.doc.is_some() {
            acc.doc = Some(later);
        }
        let Some(value) = &decl.default else { return };
        let Some(earlier_ref) = acc.first_default else {
            acc.first_default = Some(later);
            return;
        };
        let earlier = self.uniform(earlier_ref);
        let conflict = default_conflict("uniform", name, earlier, earlier.default.as_ref(), decl, value, || {
            self.owner(earlier_ref.0)
        });
        if let Some(d) = conflict {
            self.push(later.0, d);
        }
    }

    /// W0006 for a write by a non-standard function that no read reaches (the field is read, but
    /// only before the write, or in a sample the write does not live into): the function's work
    /// is lost, typically because it is placed after the last step that uses the field.
    fn dead_writes(&mut self, acc: &FieldAcc, ray: bool) {
        let lost: Vec<&Use> = acc
            .uses
            .iter()
            .filter(|w| w.written && !self.unit_is_std(w.unit))
            .filter(|w| !acc.uses.iter().any(|r| r.read && later_read(w, r, ray)))
            .collect();
        for w in lost {
            let function = self.pipe(w.unit).name.clone();
            let d = Diagnostic::new(
                Code::WrittenNeverRead,
                self.state((w.unit, w.decl)).span,
                format!("`{function}` writes state field `{}`, but no later function reads it", acc.name),
            )
            .with_label("this write has no effect")
            .with_note("the functions that read the field run before this one in the composed pipeline")
            .with_help("place the function before the step that uses the field (see `vrsc pipeline`)");
            self.push(w.unit, d);
        }
    }

    /// W0005 for every read of the field by a non-standard function that no earlier write
    /// reaches.
    fn read_before_write(&mut self, acc: &FieldAcc, ray: bool) {
        let reaches = |w: &Use, r: &Use| reaches(w, r, ray);
        for r in acc.uses.iter().filter(|r| r.read) {
            if self.unit_is_std(r.unit) || acc.uses.iter().any(|w| reaches(w, r)) {
                continue;
            }
            let decl = self.state((r.unit, r.decl));
            let mut d = Diagnostic::new(
                Code::ReadBeforeWrite,
                decl.first_read.unwrap_or(decl.span),
                format!("state field `{}` is read before any function of the pipeline writes it", acc.name),
            )
            .with_label("read here; it still holds its default");
            if decl.first_read.is_some() {
                d = d.with_secondary(decl.span, "declared here");
            }
            if !ray && acc.uses.iter().any(|w| w.written && w.phase == 0 && r.phase == 1) {
                d = d.with_note("a per-sample field is reset to its default before every sample: a write in `ray.setup` does not reach the sample steps");
            }
            d = d.with_help(format!(
                "write `state.{}` in an earlier step, or place this function after the one that writes it",
                acc.name
            ));
            self.push(r.unit, d);
        }
    }
}

/// Whether read `r` comes after write `w` and sees it: a function's own read counts only for a
/// ray field in the sample loop (the next sample sees the write).
fn later_read(w: &Use, r: &Use, ray: bool) -> bool {
    if r.unit == w.unit {
        return ray && w.phase == 1;
    }
    reaches(w, r, ray)
}

/// Whether write `w` reaches read `r` of a field (`ray`: a field that lives for the whole ray).
fn reaches(w: &Use, r: &Use, ray: bool) -> bool {
    if !w.written {
        return false;
    }
    if w.position <= r.position {
        // A per-sample field is reset before every sample: a write before the loop is lost.
        ray || !(w.phase == 0 && r.phase == 1)
    } else {
        // A ray field written later in the loop reaches the next sample's read.
        ray && w.phase == 1 && r.phase == 1
    }
}

/// E0505 when a later declaration's default differs from the first default given, unless both
/// names are equal as written (the checker compared those).
fn default_conflict<D: HasName>(
    what: &str,
    name: &str,
    earlier: &D,
    earlier_value: Option<&ConstValue>,
    later: &D,
    value: &ConstValue,
    owner: impl FnOnce() -> String,
) -> Option<Diagnostic> {
    let earlier_value = earlier_value?;
    if earlier.name() == later.name() || earlier_value == value || earlier_value.ty != value.ty {
        return None;
    }
    Some(
        Diagnostic::new(
            Code::DefaultConflict,
            later.span(),
            format!(
                "{what} `{name}` has default {} here but {} in {}",
                show_const(value),
                show_const(earlier_value),
                owner()
            ),
        )
        .with_label(format!("default {}", show_const(value)))
        .with_secondary(earlier.span(), format!("first declared here with default {}", show_const(earlier_value)))
        .with_help("give every declaration the same default, or leave the default out here"),
    )
}

trait HasName {
    fn name(&self) -> &str;
    fn span(&self) -> Span;
}

impl HasName for hir::StateDecl {
    fn name(&self) -> &str {
        &self.name
    }
    fn span(&self) -> Span {
        self.span
    }
}

impl HasName for hir::UniformDecl {
    fn name(&self) -> &str {
        &self.name
    }
    fn span(&self) -> Span {
        self.span
    }
}

/// The zero value of a plain type (no components for anything else).
pub fn zero_value(ty: Type) -> ConstValue {
    let zero = |s: Scalar| match s {
        Scalar::Bool => ScalarValue::Bool(false),
        Scalar::I32 => ScalarValue::I32(0),
        Scalar::U32 => ScalarValue::U32(0),
        Scalar::F32 => ScalarValue::F32(0.0),
    };
    let components = match ty {
        Type::Scalar(s) => vec![zero(s)],
        Type::Vector { size, scalar } => vec![zero(scalar); usize::from(size)],
        Type::Matrix { cols, rows } => vec![ScalarValue::F32(0.0); usize::from(cols) * usize::from(rows)],
        _ => Vec::new(),
    };
    ConstValue { ty, components }
}
