//! Pipeline functions' headers: placements and `remove` items (step paths), the `state`,
//! `uniform` and `use` declarations with their constant defaults and ranges, unused
//! declarations, and conflicts between declarations of different pipeline functions.

use super::func::PipeOut;
use super::scope::{Binding, FnCx, ItemRef, StateSlot, UniformSlot, UseSlot, duplicate};
use super::{Checker, type_or_placeholder};
use crate::ast::{self, DeclKind, PlacementKind};
use crate::diag::{Code, Diagnostic};
use crate::hir::show_const;
use crate::hir::{self, ConstValue};
use crate::source::Span;
use crate::steps::{Step, StepLookup};
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};
use rustc_hash::FxHashMap;

/// `None` for a `remove` item.
type PlacementWord = Option<PlacementKind>;

fn word(kind: PlacementWord) -> &'static str {
    match kind {
        Some(PlacementKind::In) => "in",
        Some(PlacementKind::Before) => "before",
        Some(PlacementKind::After) => "after",
        Some(PlacementKind::Replace) => "replace",
        None => "remove",
    }
}

impl Checker<'_> {
    /// Resolves a step path: a step, or a group's first/last step for `before`/`after`.
    pub(super) fn resolve_step(&mut self, path: &ast::StepPath, kind: PlacementWord) -> Option<Step> {
        if path.segments.is_empty() || path.segments.iter().any(|s| s.name.is_empty()) {
            return None; // the parser already reported it
        }
        let name = path.step_name();
        match Step::lookup(&name) {
            StepLookup::Step(step) => Some(step),
            StepLookup::Group { first, .. } if kind == Some(PlacementKind::Before) => Some(first),
            StepLookup::Group { last, .. } if kind == Some(PlacementKind::After) => Some(last),
            StepLookup::Group { .. } => {
                let steps: Vec<&str> = Step::ALL.iter().filter(|s| s.group() == name).map(|s| s.name()).collect();
                let w = word(kind);
                let d = Diagnostic::new(
                    Code::GroupNotAllowed,
                    path.span,
                    format!("`{w} {name}` names a group of steps, not one step"),
                )
                .with_label("a group")
                .with_note(format!("the steps of `{name}`: {}", steps.join(", ")))
                .with_help(format!(
                    "name one step, e.g. `{w} {}`; only `before` and `after` accept a group",
                    steps.first().copied().unwrap_or("start")
                ));
                self.diags.push(d);
                None
            }
            StepLookup::Unknown => {
                let mut d = Diagnostic::new(Code::UnknownStep, path.span, format!("unknown step `{name}`"))
                    .with_label("no pipeline step has this name");
                d = match Step::suggest(&name) {
                    Some(best) => d.with_help(format!("did you mean `{best}`?")),
                    None => {
                        let all: Vec<&str> = Step::ALL.iter().map(|s| s.name()).collect();
                        d.with_note(format!("steps: {}", all.join(", ")))
                    }
                };
                self.diags.push(d);
                None
            }
        }
    }

    pub(super) fn placement(&mut self, p: &ast::Placement) -> Option<hir::Placement> {
        let step = self.resolve_step(&p.target, Some(p.kind))?;
        Some(hir::Placement {
            kind: p.kind,
            step,
            substep: p.target.substep.as_ref().map(|s| s.name.clone()),
            when_active: p.when_active,
            span: p.span,
        })
    }

    pub(super) fn remove_item(&mut self, module: usize, r: &ast::Remove, span: Span) -> Option<hir::Remove> {
        let step = self.resolve_step(&r.target, None)?;
        Some(hir::Remove {
            module,
            step,
            substep: r.target.substep.as_ref().map(|s| s.name.clone()),
            when_active: r.when_active,
            span,
        })
    }

    /// Checks a pipeline header into `f` (state, uniforms, uses) and returns the declarations.
    pub(super) fn declarations(
        &mut self,
        f: &mut FnCx,
        decls: &[ast::Decl],
    ) -> (Vec<hir::StateDecl>, Vec<hir::UniformDecl>) {
        let mut states: Vec<hir::StateDecl> = Vec::new();
        let mut uniforms: Vec<hir::UniformDecl> = Vec::new();
        for d in decls {
            match &d.kind {
                DeclKind::State { ray, name, ty, default } => {
                    let t = self.decl_type(f, ty, name, true);
                    let default =
                        self.default_value(f, default.as_ref(), t, &format!("the default of `state {}`", name.name));
                    if let Some(first) = states.iter().find(|s| s.name == name.name) {
                        let dup = duplicate(&name.name, "state field", name.span, first.span);
                        self.emit(f, dup);
                        continue;
                    }
                    f.state.push(StateSlot {
                        name: name.name.clone(),
                        ty: t,
                        read: false,
                        written: false,
                        first_read: None,
                    });
                    states.push(hir::StateDecl {
                        name: name.name.clone(),
                        ty: t,
                        ray: *ray,
                        default,
                        read: false,
                        written: false,
                        first_read: None,
                        span: d.span,
                    });
                }
                DeclKind::Uniform { name, ty, default, range } => {
                    if let Some(u) = self.uniform_decl(f, d, name, ty, default.as_ref(), range.as_ref()) {
                        uniforms.push(u);
                    }
                }
                DeclKind::Use { names } => {
                    for n in names {
                        self.use_decl(f, n);
                    }
                }
            }
        }
        (states, uniforms)
    }

    /// The declared type of a state field (plain only) or uniform (plain or resource).
    fn decl_type(&mut self, f: &mut FnCx, ty: &ast::TypeExpr, name: &ast::Ident, state: bool) -> Type {
        let t = self.resolve_type(ty);
        if t.is_error() {
            f.failed = true;
        } else if t.is_resource() && state {
            let d = Diagnostic::new(Code::ResourceMisuse, ty.span, format!("a state field cannot hold a `{t}`"))
                .with_label(format!("`{t}` is not a plain value"))
                .with_help(format!("declare it as a uniform instead: `uniform {}: {t};`", name.name));
            self.emit(f, d);
            return Type::Error;
        }
        t
    }

    /// Evaluates a default against its declared type.
    fn default_value(&mut self, f: &mut FnCx, e: Option<&ast::Expr>, ty: Type, what: &str) -> Option<ConstValue> {
        let e = e?;
        if ty.is_error() {
            return None;
        }
        let v = self.const_expr(f.module, e, Some(ty), Some(ty), what);
        if v.is_none() {
            f.failed = true;
        }
        v
    }

    fn uniform_decl(
        &mut self,
        f: &mut FnCx,
        d: &ast::Decl,
        name: &ast::Ident,
        ty: &ast::TypeExpr,
        default: Option<&ast::Expr>,
        range: Option<&(ast::Expr, ast::Expr)>,
    ) -> Option<hir::UniformDecl> {
        let t = self.decl_type(f, ty, name, false);
        if t.is_resource() {
            for (present, what, span) in [
                (default.map(|e| e.span), "the default", d.span),
                (range.map(|r| r.0.span.to(r.1.span)), "the range", d.span),
            ] {
                let Some(at) = present else { continue };
                let diag = Diagnostic::new(
                    Code::ResourceMisuse,
                    at,
                    format!("a `{t}` uniform cannot have {}", what.replace("the ", "a ")),
                )
                .with_label("not allowed here")
                .with_secondary(span, format!("`{}` is a {t}", name.name))
                .with_help(format!("the scene binds the {t}: remove {what}"));
                self.emit(f, diag);
            }
        }
        let plain = t.is_plain() && !t.is_error();
        let what = format!("the default of `uniform {}`", name.name);
        let default = if plain { self.default_value(f, default, t, &what) } else { None };
        let range = match range {
            Some((lo, hi)) if plain => self.range(f, name, t, lo, hi),
            _ => None,
        };
        if let Some((_, earlier)) = f.lookup(&name.name) {
            let dup = duplicate(&name.name, "uniform", name.span, earlier);
            self.emit(f, dup);
            return None;
        }
        let index = f.uniforms.len();
        let _ = f.declare(&name.name, Binding::Uniform(index), name.span);
        f.uniforms.push(UniformSlot { name: name.name.clone(), ty: t, read: false });
        Some(hir::UniformDecl { name: name.name.clone(), ty: t, default, range, doc: d.doc.clone(), span: d.span })
    }

    /// Range bounds: of the uniform's type, or scalars that bound every component (splat).
    fn range(
        &mut self,
        f: &mut FnCx,
        name: &ast::Ident,
        ty: Type,
        lo: &ast::Expr,
        hi: &ast::Expr,
    ) -> Option<(ConstValue, ConstValue)> {
        if ty.scalar() == Some(Scalar::Bool) {
            let d = Diagnostic::new(Code::TypeMismatch, lo.span.to(hi.span), format!("a {ty} uniform has no range"))
                .with_label("ranges bound numbers")
                .with_help("remove the `in lo .. hi` part");
            self.emit(f, d);
            return None;
        }
        let lo = self.range_bound(f, name, ty, lo);
        let hi = self.range_bound(f, name, ty, hi);
        Some((lo?, hi?))
    }

    /// One bound, checked with the uniform's type as hint (so literals take its scalar); a scalar
    /// bound of a vector or matrix uniform bounds every component and is splatted.
    fn range_bound(&mut self, f: &mut FnCx, name: &ast::Ident, ty: Type, e: &ast::Expr) -> Option<ConstValue> {
        let what = format!("the range of `uniform {}`", name.name);
        let Some(v) = self.const_expr(f.module, e, Some(ty), None, &what) else {
            f.failed = true;
            return None;
        };
        if v.ty == ty {
            return Some(v);
        }
        let scalar = ty.scalar().map(Type::Scalar);
        match v.components.as_slice() {
            [one] if Some(v.ty) == scalar => Some(ConstValue { ty, components: vec![*one; ty.components()] }),
            _ => {
                let d = Diagnostic::new(
                    Code::TypeMismatch,
                    e.span,
                    format!("{what} needs a {ty} or a {}, not {}", type_or_placeholder(scalar), v.ty),
                )
                .with_label(format!("this is {}", v.ty));
                self.emit(f, d);
                None
            }
        }
    }

    fn use_decl(&mut self, f: &mut FnCx, n: &ast::Ident) {
        match self.item(f.module, &n.name) {
            Some(ItemRef::Lib(lib)) => {
                if let Some(first) = f.uses.iter().find(|u| u.lib == lib) {
                    let dup =
                        Diagnostic::new(Code::Duplicate, n.span, format!("`{}` is listed twice in `use`", n.name))
                            .with_label("listed again here")
                            .with_secondary(first.span, "first listed here")
                            .with_help("remove the second one");
                    self.emit(f, dup);
                    return;
                }
                f.uses.push(UseSlot { lib, span: n.span, called: false });
            }
            Some(ItemRef::Const(_)) => {
                let d = Diagnostic::new(
                    Code::UnknownLibrary,
                    n.span,
                    format!("`{}` is a constant, not a library function", n.name),
                )
                .with_label("not a library function")
                .with_help("constants need no declaration: remove it from `use`");
                self.emit(f, d);
            }
            None => {
                let libs: Vec<String> = self
                    .scopes
                    .get(f.module)
                    .map(|s| {
                        s.names.iter().filter(|(_, r)| matches!(r, ItemRef::Lib(_))).map(|(n, _)| n.clone()).collect()
                    })
                    .unwrap_or_default();
                let mut d =
                    Diagnostic::new(Code::UnknownLibrary, n.span, format!("no library function `{}` in scope", n.name))
                        .with_label("not defined in this module or its imports");
                d = match (self.import_help(&n.name), did_you_mean(&n.name, libs.iter().map(String::as_str))) {
                    (Some(help), _) => d.with_help(help),
                    (None, Some(best)) => d.with_help(format!("did you mean `{best}`?")),
                    (None, None) => {
                        d.with_help(format!("define `lib fn {}` or import the module that defines it", n.name))
                    }
                };
                self.emit(f, d);
            }
        }
    }

    /// W0001-W0003 for a pipeline function that checked cleanly.
    pub(super) fn unused_warnings(&mut self, f: &FnCx, states: &[hir::StateDecl], uniforms: &[hir::UniformDecl]) {
        for u in f.uses.iter().filter(|u| !u.called) {
            let name = self.libs.get(u.lib).map_or("", |l| l.name.as_str());
            self.diags.push(
                Diagnostic::new(Code::UnusedUse, u.span, format!("`{name}` is declared in `use` but never called"))
                    .with_label("never called")
                    .with_help(format!("remove `{name}` from the `use` list")),
            );
        }
        for (u, slot) in uniforms.iter().zip(&f.uniforms).filter(|(_, s)| !s.read) {
            self.diags.push(
                Diagnostic::new(
                    Code::UnusedUniform,
                    u.span,
                    format!("uniform `{}` is declared but never read", slot.name),
                )
                .with_label("never read")
                .with_help("use it in the body, or remove the declaration"),
            );
        }
        for s in states.iter().filter(|s| !s.read && !s.written) {
            self.diags.push(
                Diagnostic::new(
                    Code::UnusedState,
                    s.span,
                    format!("state field `{}` is declared but never used", s.name),
                )
                .with_label("neither read nor written")
                .with_help(format!("use `state.{}` in the body, or remove the declaration", s.name)),
            );
        }
    }

    /// Every declaration of one state field or uniform, across all pipeline functions of the
    /// graph, must agree with the first one (module order, then source order).
    pub(super) fn check_conflicts(&mut self, pipes: &mut [PipeOut]) {
        let mut states: Firsts<hir::StateDecl> = Firsts::default();
        let mut uniforms: Firsts<hir::UniformDecl> = Firsts::default();
        let mut reports = Vec::new();
        for (p, pipe) in pipes.iter().enumerate() {
            let owner = pipe.name.as_str();
            let state = pipe.state.iter().filter_map(|s| states.check(s, owner, state_conflict));
            let found: Vec<Diagnostic> =
                state.chain(pipe.uniforms.iter().filter_map(|u| uniforms.check(u, owner, uniform_conflict))).collect();
            reports.extend(found.into_iter().map(|d| (p, d)));
        }
        for (p, d) in reports {
            self.diags.push(d);
            if let Some(pipe) = pipes.get_mut(p) {
                pipe.failed = true;
            }
        }
    }
}

/// A state or uniform declaration, as the conflict rules see it.
trait Declared {
    /// "state field" or "uniform".
    const WHAT: &'static str;
    fn name(&self) -> &str;
    fn ty(&self) -> Type;
    fn default_value(&self) -> Option<&ConstValue>;
    fn span(&self) -> Span;
}

impl Declared for hir::StateDecl {
    const WHAT: &'static str = "state field";
    fn name(&self) -> &str {
        &self.name
    }
    fn ty(&self) -> Type {
        self.ty
    }
    fn default_value(&self) -> Option<&ConstValue> {
        self.default.as_ref()
    }
    fn span(&self) -> Span {
        self.span
    }
}

impl Declared for hir::UniformDecl {
    const WHAT: &'static str = "uniform";
    fn name(&self) -> &str {
        &self.name
    }
    fn ty(&self) -> Type {
        self.ty
    }
    fn default_value(&self) -> Option<&ConstValue> {
        self.default.as_ref()
    }
    fn span(&self) -> Span {
        self.span
    }
}

/// The first declaration of each name, and the first that gives a default, with the pipeline
/// function that holds it.
struct Firsts<'p, T> {
    decl: FxHashMap<&'p str, (&'p T, &'p str)>,
    default: FxHashMap<&'p str, (&'p T, &'p str)>,
}

impl<T> Default for Firsts<'_, T> {
    fn default() -> Self {
        Firsts { decl: FxHashMap::default(), default: FxHashMap::default() }
    }
}

impl<'p, T: Declared> Firsts<'p, T> {
    /// The conflict of `d` (declared in `owner`) with the earlier declarations, then records it.
    /// `kind` compares type (and lifetime); defaults are compared only when that agrees.
    fn check(&mut self, d: &'p T, owner: &'p str, kind: fn(&T, &str, &T) -> Option<Diagnostic>) -> Option<Diagnostic> {
        if d.ty().is_error() {
            return None;
        }
        let conflict = match self.decl.get(d.name()) {
            None => {
                self.decl.insert(d.name(), (d, owner));
                None
            }
            Some((first, first_owner)) => kind(first, first_owner, d),
        };
        conflict.or_else(|| {
            let found = self.default_conflict(d);
            if d.default_value().is_some() {
                self.default.entry(d.name()).or_insert((d, owner));
            }
            found
        })
    }

    /// E0505 when `d`'s default differs from the first default given for its name.
    fn default_conflict(&self, d: &T) -> Option<Diagnostic> {
        let default = d.default_value()?;
        let (first, owner) = self.default.get(d.name())?;
        let earlier = first.default_value()?;
        if earlier == default || earlier.ty != default.ty {
            return None;
        }
        let (now, then) = (show_const(default), show_const(earlier));
        let message = format!("{} `{}` has default {now} here but {then} in `{owner}`", T::WHAT, d.name());
        Some(
            Diagnostic::new(Code::DefaultConflict, d.span(), message)
                .with_label(format!("default {now}"))
                .with_secondary(first.span(), format!("first declared here with default {then}"))
                .with_help("give every declaration the same default, or leave the default out here"),
        )
    }
}

fn state_conflict(first: &hir::StateDecl, owner: &str, s: &hir::StateDecl) -> Option<Diagnostic> {
    let name = &s.name;
    if first.ty != s.ty {
        return Some(
            Diagnostic::new(
                Code::StateConflict,
                s.span,
                format!("state field `{name}` is declared as {} here but as {} in `{owner}`", s.ty, first.ty),
            )
            .with_label(format!("declared as {}", s.ty))
            .with_secondary(first.span, format!("first declared here as {}", first.ty))
            .with_help(format!("every declaration of `state {name}` must have the same type")),
        );
    }
    if first.ray != s.ray {
        let lifetime = |ray: bool| if ray { "`@ray`" } else { "per-sample" };
        return Some(
            Diagnostic::new(
                Code::StateConflict,
                s.span,
                format!("state field `{name}` is {} here but {} in `{owner}`", lifetime(s.ray), lifetime(first.ray)),
            )
            .with_label(format!("{} here", lifetime(s.ray)))
            .with_secondary(first.span, format!("first declared here as {}", lifetime(first.ray)))
            .with_help(if first.ray {
                "add `@ray` to this declaration"
            } else {
                "remove `@ray` from this declaration"
            }),
        );
    }
    None
}

fn uniform_conflict(first: &hir::UniformDecl, owner: &str, u: &hir::UniformDecl) -> Option<Diagnostic> {
    if first.ty == u.ty {
        return None;
    }
    let name = &u.name;
    Some(
        Diagnostic::new(
            Code::UniformConflict,
            u.span,
            format!("uniform `{name}` is declared as {} here but as {} in `{owner}`", u.ty, first.ty),
        )
        .with_label(format!("declared as {}", u.ty))
        .with_secondary(first.span, format!("first declared here as {}", first.ty))
        .with_help(format!("every declaration of `uniform {name}` must have the same type")),
    )
}
