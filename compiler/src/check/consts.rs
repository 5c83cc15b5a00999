//! Constant expressions: `const` items (evaluated on first use, in any order, with cycle
//! detection), defaults and range bounds. An expression is checked like any other (in a
//! [`FnKind::Const`] context, where only constants are in scope), then folded with `consteval`.

use super::Checker;
use super::consteval::{self, ConstError};
use super::scope::{ConstState, FnCx, FnKind};
use crate::ast;
use crate::diag::{Code, Diagnostic};
use crate::hir::{self, ConstValue};
use crate::source::Span;
use crate::types::Type;

impl Checker<'_> {
    /// Evaluates every `const` item, so that unused ones are checked too.
    pub(super) fn eval_all_consts(&mut self) {
        for id in 0..self.consts.len() {
            // The standard modules' constants were checked with the cached standard library;
            // one that a user's module refers to is still evaluated, on that use.
            if self.consts.get(id).is_some_and(|c| self.std.as_ref().is_some_and(|std| std.has_module(c.module))) {
                continue;
            }
            let span = self.const_item(id).map_or(Span::DUMMY, |c| c.name.span);
            self.const_value(id, span);
        }
    }

    /// The value of const `id`, referenced at `at`; `None` after an error (reported once).
    pub(super) fn const_value(&mut self, id: usize, at: Span) -> Option<ConstValue> {
        let info = self.consts.get(id)?;
        match &info.state {
            ConstState::Done(v) => return v.clone(),
            ConstState::Evaluating => {
                self.report_cycle(id, at);
                return None;
            }
            ConstState::Pending => {}
        }
        self.consts[id].state = ConstState::Evaluating;
        self.const_stack.push(id);
        let value = self.eval_const_item(id);
        self.const_stack.pop();
        self.consts[id].state = ConstState::Done(value.clone());
        value
    }

    fn report_cycle(&mut self, id: usize, at: Span) {
        let start = self.const_stack.iter().position(|&c| c == id).unwrap_or(0);
        let mut chain: Vec<&str> = self.const_stack[start..].iter().map(|&c| self.consts[c].name.as_str()).collect();
        chain.push(self.consts[id].name.as_str());
        let d = Diagnostic::new(
            Code::NotConstant,
            at,
            format!("constant `{}` depends on itself: {}", self.consts[id].name, chain.join(" -> ")),
        )
        .with_label("this reference closes the cycle")
        .with_help("give one of these constants a value that does not refer back to the others");
        self.diags.push(d);
    }

    fn eval_const_item(&mut self, id: usize) -> Option<ConstValue> {
        let module = self.consts.get(id)?.module;
        let item = self.const_item(id)?;
        let (name, ty, value) = (item.name.name.clone(), item.ty.clone(), item.value.clone());
        let declared = match &ty {
            Some(t) => {
                let resolved = self.resolve_type(t);
                if resolved.is_error() {
                    return None;
                }
                if !resolved.is_plain() {
                    let d =
                        Diagnostic::new(Code::ResourceMisuse, t.span, format!("a constant cannot be a `{resolved}`"))
                            .with_label("not a plain value")
                            .with_help("declare it as a uniform of a pipeline function");
                    self.diags.push(d);
                    return None;
                }
                Some(resolved)
            }
            None => None,
        };
        self.const_expr(module, &value, declared, declared, &format!("constant `{name}`"))
    }

    /// Checks and folds a constant expression of `module`: `hint` is the type literals should
    /// take, `expected` the type the value must have.
    pub(super) fn const_expr(
        &mut self,
        module: usize,
        e: &ast::Expr,
        hint: Option<Type>,
        expected: Option<Type>,
        what: &str,
    ) -> Option<ConstValue> {
        let mut f = FnCx::new(FnKind::Const, module, what, Type::Void);
        let checked = self.value(&mut f, e, hint);
        if f.failed || checked.ty.is_error() {
            return None;
        }
        if let Some(t) = expected
            && !self.expect_type(&mut f, &checked, t, what)
        {
            return None;
        }
        if !checked.ty.is_plain() {
            let d = Diagnostic::new(Code::ResourceMisuse, e.span, format!("{what} cannot be a `{}`", checked.ty))
                .with_label("not a plain value");
            self.diags.push(d);
            return None;
        }
        match fold(&checked) {
            Ok(v) => Some(v),
            Err((span, err)) => {
                self.diags.push(self.fold_error(span, err));
                None
            }
        }
    }

    fn fold_error(&self, span: Span, err: (ConstError, Type)) -> Diagnostic {
        self.const_error(span, &err.0, err.1)
    }
}

/// Folds a checked constant expression. Its depth is bounded by the checker's nesting limit.
fn fold(e: &hir::Expr) -> Result<ConstValue, (Span, (ConstError, Type))> {
    let at = |err| (e.span, (err, e.ty));
    match &e.kind {
        hir::ExprKind::Const(v) => Ok(v.clone()),
        hir::ExprKind::Unary { op, operand } => consteval::eval_unary(*op, &fold(operand)?).map_err(at),
        hir::ExprKind::Binary { op, lhs, rhs } => consteval::eval_binary(*op, &fold(lhs)?, &fold(rhs)?).map_err(at),
        hir::ExprKind::Construct { args } => {
            let values = args.iter().map(fold).collect::<Result<Vec<_>, _>>()?;
            consteval::eval_constructor(e.ty, &values).map_err(at)
        }
        hir::ExprKind::Convert { arg } => consteval::eval_constructor(e.ty, &[fold(arg)?]).map_err(at),
        hir::ExprKind::Swizzle { base, components } => consteval::eval_swizzle(&fold(base)?, components).map_err(at),
        hir::ExprKind::Index { base, index } => {
            let b = fold(base)?;
            let i = fold(index)?.as_index();
            index_const(&b, i).ok_or(at(ConstError::NotConstant))
        }
        _ => Err(at(ConstError::NotConstant)),
    }
}

/// Component `i` of a constant vector, or column `i` of a constant matrix.
pub(super) fn index_const(base: &ConstValue, i: Option<i64>) -> Option<ConstValue> {
    let i = usize::try_from(i?).ok()?;
    match base.ty {
        Type::Vector { .. } => consteval::eval_swizzle(base, &[u8::try_from(i).ok()?]).ok(),
        Type::Matrix { rows, .. } => {
            let rows = usize::from(rows);
            let column = base.components.get(i * rows..(i + 1) * rows)?.to_vec();
            Some(ConstValue { ty: Type::vec(rows as u8, crate::types::Scalar::F32), components: column })
        }
        _ => None,
    }
}
