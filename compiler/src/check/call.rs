//! Calls: type constructors and conversions, built-in functions and library functions
//! (with the `use` rule of pipeline functions).

use super::expr::{Hint, Literal, concrete_hint, literal_kind, mk};
use super::scope::{FnCx, FnKind, ItemRef};
use super::{Checker, rules};
use crate::ast::{self, Ident, TypeExpr};
use crate::diag::{Code, Diagnostic};
use crate::hir::{self, Builtin};
use crate::source::Span;
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

impl Checker<'_> {
    /// `callee(args)`: a constructor, a built-in or a library function.
    pub(super) fn call(
        &mut self,
        f: &mut FnCx,
        span: Span,
        callee: &Ident,
        generics: &[TypeExpr],
        args: &[ast::Expr],
        hint: Hint,
    ) -> hir::Expr {
        let name = callee.name.as_str();
        if !generics.is_empty() {
            let target = self.resolve_type(&TypeExpr { name: callee.clone(), args: generics.to_vec(), span });
            if target.is_error() {
                f.failed = true;
                self.check_args_for_errors(f, args);
                return f.poison(span);
            }
            return self.construct(f, span, target, args);
        }
        if let Some(target) = Type::from_name(name) {
            return self.construct(f, span, target, args);
        }
        if Type::is_generic_name(name) {
            return self.construct_inferred(f, span, callee, args, hint);
        }
        if let Some(builtin) = Builtin::by_name(name) {
            return self.builtin_call(f, span, callee, builtin, args, hint);
        }
        match self.item(f.module, name) {
            Some(ItemRef::Lib(id)) => self.lib_call(f, span, callee, id, args),
            other => {
                self.check_args_for_errors(f, args);
                let d = self.unknown_function(f, callee, other.is_some());
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    /// Checks arguments of a call that is already wrong, so their own mistakes are reported.
    fn check_args_for_errors(&mut self, f: &mut FnCx, args: &[ast::Expr]) {
        for a in args {
            self.value(f, a, None);
        }
    }

    fn unknown_function(&self, f: &FnCx, callee: &Ident, is_const: bool) -> Diagnostic {
        let name = &callee.name;
        if is_const {
            return Diagnostic::new(
                Code::UnknownFunction,
                callee.span,
                format!("`{name}` is a constant, not a function"),
            )
            .with_label("called here");
        }
        let mut known: Vec<&str> = Builtin::ALL.iter().map(|&(_, name)| name).collect();
        if let Some(scope) = self.scopes.get(f.module) {
            known.extend(scope.names.iter().filter(|(_, r)| matches!(r, ItemRef::Lib(_))).map(|(n, _)| n.as_str()));
        }
        let d = Diagnostic::new(Code::UnknownFunction, callee.span, format!("unknown function `{name}`"))
            .with_label("not a built-in or a library function in scope");
        if let Some(help) = self.import_help(name) {
            return d.with_help(help);
        }
        match did_you_mean(name, known.into_iter().filter(|n| !n.is_empty())) {
            Some(best) => d.with_help(format!("did you mean `{best}`?")),
            None => d.with_help(format!("define it with `lib fn {name}(...)`, or import the module that defines it")),
        }
    }

    /// "import the module that defines it", when some module of the graph defines lib fn `name`.
    pub(super) fn import_help(&self, name: &str) -> Option<String> {
        let lib = self.libs.iter().find(|l| l.name == name)?;
        let module = self.graph.modules.get(lib.module)?;
        Some(match &module.std_name {
            Some(std) => format!("`{name}` is defined in `std::{std}`: add `import std::{std};`"),
            None => format!("`{name}` is defined in `{}`: import that module", self.module_name(lib.module)),
        })
    }

    /// `T(args)` for a known type `T`: construction (zero value, splat, components) or conversion.
    fn construct(&mut self, f: &mut FnCx, span: Span, target: Type, args: &[ast::Expr]) -> hir::Expr {
        if !target.is_plain() {
            self.check_args_for_errors(f, args);
            let d = Diagnostic::new(Code::InvalidConstructor, span, format!("a `{target}` cannot be constructed"))
                .with_label("not a plain value")
                .with_note(format!(
                    "`{target}` values come from uniforms and are passed to library functions as parameters"
                ));
            self.emit(f, d);
            return f.poison(span);
        }
        let hint = target.scalar().map(Type::Scalar);
        let checked: Vec<hir::Expr> = args.iter().map(|a| self.value(f, a, hint)).collect();
        self.finish_construct(f, span, target, checked)
    }

    fn finish_construct(&mut self, f: &mut FnCx, span: Span, target: Type, args: Vec<hir::Expr>) -> hir::Expr {
        if args.iter().any(|a| a.ty.is_error()) {
            return f.poison(span);
        }
        let types: Vec<Type> = args.iter().map(|a| a.ty).collect();
        match rules::constructor(target, &types) {
            Ok(rules::ConstructorKind::Construct) => mk(hir::ExprKind::Construct { args }, target, span),
            Ok(rules::ConstructorKind::Convert) => match args.into_iter().next() {
                Some(arg) if types.len() == 1 => mk(hir::ExprKind::Convert { arg: Box::new(arg) }, target, span),
                _ => f.poison(span),
            },
            Err(why) => {
                let shown: Vec<String> = types.iter().map(Type::to_string).collect();
                let msg = if why.is_empty() { format!("no constructor `{target}({})`", shown.join(", ")) } else { why };
                let d = Diagnostic::new(Code::InvalidConstructor, span, msg)
                    .with_label(format!("`{target}` from ({})", shown.join(", ")));
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    /// `vec3(...)` / `mat3x3(...)` without a component type: it comes from the arguments.
    fn construct_inferred(
        &mut self,
        f: &mut FnCx,
        span: Span,
        callee: &Ident,
        args: &[ast::Expr],
        hint: Hint,
    ) -> hir::Expr {
        let checked = self.shared_args(f, args, hint);
        if checked.iter().any(|a| a.ty.is_error()) {
            return f.poison(span);
        }
        let scalar =
            if callee.name.starts_with("mat") { Some(Scalar::F32) } else { checked.iter().find_map(|a| a.ty.scalar()) };
        let target = scalar.and_then(|s| Type::from_generic(&callee.name, Type::Scalar(s)));
        let Some(target) = target else {
            let d = Diagnostic::new(
                Code::InvalidConstructor,
                span,
                format!("cannot tell the component type of `{}(...)`", callee.name),
            )
            .with_label("no argument gives a component type")
            .with_help(format!("write the type: `{0}f(...)` or `{0}<f32>(...)`", callee.name));
            self.emit(f, d);
            return f.poison(span);
        };
        self.finish_construct(f, span, target, checked)
    }

    /// Arguments that share one component type (built-ins, inferred constructors): values are
    /// checked first, then literal-only arguments take the type of the first numeric value.
    fn shared_args(&mut self, f: &mut FnCx, args: &[ast::Expr], outer: Hint) -> Vec<hir::Expr> {
        let kinds: Vec<Option<Literal>> = args.iter().map(literal_kind).collect();
        let mut out: Vec<Option<hir::Expr>> = args.iter().map(|_| None).collect();
        let mut first: Hint = None;
        for ((a, kind), slot) in args.iter().zip(&kinds).zip(out.iter_mut()) {
            if kind.is_none() {
                let e = self.value(f, a, first);
                if first.is_none() && e.ty.scalar().is_some_and(Scalar::is_numeric) {
                    first = concrete_hint(&e);
                }
                *slot = Some(e);
            }
        }
        let literal_hint = first.or(outer).or_else(|| kinds.contains(&Some(Literal::Float)).then_some(Type::F32));
        for ((a, kind), slot) in args.iter().zip(&kinds).zip(out.iter_mut()) {
            if kind.is_some() {
                *slot = Some(self.value(f, a, literal_hint));
            }
        }
        out.into_iter().flatten().collect()
    }

    fn builtin_call(
        &mut self,
        f: &mut FnCx,
        span: Span,
        callee: &Ident,
        builtin: Builtin,
        args: &[ast::Expr],
        hint: Hint,
    ) -> hir::Expr {
        let checked = self.shared_args(f, args, hint);
        let expected = builtin.arity();
        if checked.len() != expected {
            let d = Diagnostic::new(
                Code::ArgumentCount,
                span,
                format!(
                    "`{}` takes {expected} argument{}, but {} {} given",
                    callee.name,
                    plural(expected),
                    checked.len(),
                    if checked.len() == 1 { "was" } else { "were" }
                ),
            )
            .with_label(format!("{} argument{}", checked.len(), plural(checked.len())));
            self.emit(f, d);
            return f.poison(span);
        }
        if checked.iter().any(|a| a.ty.is_error()) {
            return f.poison(span);
        }
        let types: Vec<Type> = checked.iter().map(|a| a.ty).collect();
        match rules::builtin_result(builtin, &types) {
            Ok(ty) if !ty.is_error() => mk(hir::ExprKind::CallBuiltin { builtin, args: checked }, ty, span),
            result => {
                let shown: Vec<String> = types.iter().map(Type::to_string).collect();
                let msg = match result {
                    Err(why) if !why.is_empty() => why,
                    _ => format!("no overload of `{}` takes ({})", callee.name, shown.join(", ")),
                };
                let d = Diagnostic::new(Code::NoOverload, span, msg).with_label(format!(
                    "`{}` called with ({})",
                    callee.name,
                    shown.join(", ")
                ));
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    /// A call of library function `id`; in a pipeline function it must be in the `use` list.
    fn lib_call(&mut self, f: &mut FnCx, span: Span, callee: &Ident, id: usize, args: &[ast::Expr]) -> hir::Expr {
        match f.kind {
            FnKind::Pipeline => self.mark_used(f, callee, id),
            FnKind::Const => {
                self.check_args_for_errors(f, args);
                let d = Diagnostic::new(
                    Code::NotConstant,
                    span,
                    format!("`{}(...)` is not a constant expression", callee.name),
                )
                .with_label("function calls run at run time")
                .with_note("constant expressions may use literals, constructors, arithmetic and other constants");
                self.emit(f, d);
                return f.poison(span);
            }
            FnKind::Lib => {}
        }
        let site = f.calls.len();
        f.calls.push((id, callee.span));
        let Some(lib) = self.libs.get(id) else { return f.poison(span) };
        let (params, ret, def) = (lib.params.iter().map(|p| p.ty).collect::<Vec<_>>(), lib.ret, lib.name_span);
        if params.len() != args.len() {
            self.check_args_for_errors(f, args);
            let d = Diagnostic::new(
                Code::ArgumentCount,
                span,
                format!(
                    "`{}` takes {} argument{}, but {} {} given",
                    callee.name,
                    params.len(),
                    plural(params.len()),
                    args.len(),
                    if args.len() == 1 { "was" } else { "were" }
                ),
            )
            .with_label(format!("{} argument{}", args.len(), plural(args.len())))
            .with_secondary(def, "defined here");
            self.emit(f, d);
            return f.poison(span);
        }
        let mut checked = Vec::new();
        let mut ok = !ret.is_error();
        for (i, (a, &p)) in args.iter().zip(&params).enumerate() {
            let e = self.value(f, a, Some(p));
            if e.ty.is_error() || p.is_error() {
                ok = false;
            } else if e.ty != p {
                ok = false;
                let d = Diagnostic::new(
                    Code::TypeMismatch,
                    a.span,
                    format!("argument {} of `{}` must be {p}, not {}", i + 1, callee.name, e.ty),
                )
                .with_label(format!("this is {}", e.ty))
                .with_secondary(def, "defined here");
                self.emit(f, d);
            }
            checked.push(e);
        }
        if !ok {
            return f.poison(span);
        }
        mk(hir::ExprKind::CallLib { site, args: checked }, ret, span)
    }

    /// Marks a `use` entry as called, or reports the missing `use` (E0503).
    fn mark_used(&mut self, f: &mut FnCx, callee: &Ident, id: usize) {
        if let Some(slot) = f.uses.iter_mut().find(|u| u.lib == id) {
            slot.called = true;
            return;
        }
        if !f.first_report(format!("use {}", callee.name)) {
            f.failed = true;
            return;
        }
        let d = Diagnostic::new(
            Code::UndeclaredLibrary,
            callee.span,
            format!("`{}` is called but not declared with `use`", callee.name),
        )
        .with_label("not in the `use` list")
        .with_help(format!("add `use {};` to the declarations of `{}`", callee.name, f.name));
        self.emit(f, d);
    }
}
