//! WGSL's shader-creation rules for the constant parts of function bodies.
//!
//! WGSL evaluates every expression whose operands are all constant (operators, constructors,
//! swizzles, indexing and most built-ins) when the shader is created, and rejects the shader when
//! that evaluation overflows, divides by zero, shifts too far or leaves a built-in's domain. It
//! also rejects an integer division by a constant zero and a shift by a constant amount of 32 or
//! more even when the other operand is computed at run time. The checker applies the same rules
//! here, so that a program it accepts always lowers to a shader that validates.
//!
//! Each node is folded once, from its operands, which are already folded: a known value becomes
//! an [`ExprKind::Const`] in the HIR, so the cost is linear in the size of the body, and the
//! emitted WGSL holds values instead of constant expressions.

use super::Checker;
use super::builtin_eval::eval_builtin;
use super::consteval::{self, ConstError};
use super::consts::index_const;
use super::scope::FnCx;
use crate::ast::BinaryOp;
use crate::diag::{Code, Diagnostic};
use crate::hir::{self, Builtin, ConstValue, ExprKind, ScalarValue};
use crate::source::Span;
use crate::types::{Scalar, Type};

/// The value of `e` if WGSL knows it at shader creation.
pub(super) fn known_value(f: &FnCx, e: &hir::Expr) -> Option<ConstValue> {
    match &e.kind {
        ExprKind::Const(v) if !e.ty.is_error() => Some(v.clone()),
        ExprKind::Local(l) => f.inlined_lets.get(l).cloned(),
        _ => None,
    }
}

/// The value a `let` initialised with `value` has at every use in the emitted WGSL, if any.
///
/// Lowering binds a `let` to its value's IR expression; a scalar literal or a zero value is not
/// an emitted expression, so the WGSL writer writes it in place at every use, where WGSL treats
/// it as a constant (`let z = 0; x / z` is `x / 0i` in the shader). Any other value gets a WGSL
/// `let`, which is never a constant.
pub(super) fn inlined_value(f: &FnCx, value: &hir::Expr) -> Option<ConstValue> {
    match &value.kind {
        ExprKind::Const(v) if matches!(value.ty, Type::Scalar(_)) => Some(v.clone()),
        ExprKind::Construct { args } if args.is_empty() => known_value(f, value),
        ExprKind::Local(l) => f.inlined_lets.get(l).cloned(),
        _ => None,
    }
}

/// The value of a constant integer index (a literal, a constant or a folded expression).
pub(super) fn known_index(f: &FnCx, e: &hir::Expr) -> Option<i64> {
    e.const_index().or_else(|| known_value(f, e)?.as_index())
}

/// Whether `e`, or a component of the vector it constructs, is a known value satisfying `pred`
/// (naga looks into vector constructors for a zero divisor or a too-large shift).
/// `let` values are looked through too: lowering binds a `let` to its value's IR expression.
fn has_known_component(f: &FnCx, e: &hir::Expr, pred: &dyn Fn(ScalarValue) -> bool) -> bool {
    match &e.kind {
        ExprKind::Const(v) => v.components.iter().any(|&c| pred(c)),
        ExprKind::Construct { args } => args.iter().any(|a| has_known_component(f, a, pred)),
        // Each `let` refers only to earlier ones, so this ends.
        ExprKind::Local(l) => f.let_values.get(l).is_some_and(|v| has_known_component(f, v, pred)),
        _ => false,
    }
}

/// Whether some component of `low` is greater than that of `high` (WGSL rejects `clamp` with
/// such constant bounds even when the value is only known at run time).
fn bounds_cross(low: &ConstValue, high: &ConstValue) -> bool {
    low.components.iter().zip(&high.components).any(|pair| match pair {
        (ScalarValue::F32(l), ScalarValue::F32(h)) => l > h,
        (ScalarValue::I32(l), ScalarValue::I32(h)) => l > h,
        (ScalarValue::U32(l), ScalarValue::U32(h)) => l > h,
        _ => false,
    })
}

fn is_zero(c: ScalarValue) -> bool {
    matches!(c, ScalarValue::I32(0) | ScalarValue::U32(0))
}

fn is_too_far(c: ScalarValue) -> bool {
    matches!(c, ScalarValue::U32(n) if n >= 32)
}

impl Checker<'_> {
    /// Applies the shader-creation rules to a checked expression node: folds it when its operands
    /// are known, and reports (and poisons) a node that WGSL would reject.
    pub(super) fn fold_constants(&mut self, f: &mut FnCx, e: hir::Expr) -> hir::Expr {
        if e.ty.is_error() {
            return e;
        }
        if let ExprKind::Binary { op, lhs, rhs } = &e.kind
            && let Some(d) = self.operand_rule(f, *op, lhs.ty, rhs, e.span)
        {
            self.emit(f, d);
            return f.poison(e.span);
        }
        if let ExprKind::CallBuiltin { builtin: Builtin::Clamp, args } = &e.kind
            && let [_, low, high] = args.as_slice()
            && let (Some(l), Some(h)) = (known_value(f, low), known_value(f, high))
            && bounds_cross(&l, &h)
        {
            let err = ConstError::Domain("`clamp` with `low` greater than `high`");
            let d = self.const_error(e.span, &err, e.ty).with_secondary(low.span.to(high.span), "constant bounds");
            self.emit(f, d);
            return f.poison(e.span);
        }
        match fold_node(f, &e) {
            // Folded in the HIR, so the WGSL holds the value WGSL would compute: naga's own
            // evaluator then never sees the expression (and cannot disagree with this one).
            Ok(Some(v)) => hir::Expr { kind: ExprKind::Const(v), ty: e.ty, span: e.span },
            Ok(None) => e,
            Err(err) => {
                let d = self.const_error(e.span, &err, e.ty);
                self.emit(f, d);
                f.poison(e.span)
            }
        }
    }

    /// The rules on a constant right operand that hold whatever the left one is: no integer
    /// division or remainder by zero, no shift by 32 or more. `span` is the whole operation.
    pub(super) fn operand_rule(
        &self,
        f: &FnCx,
        op: BinaryOp,
        lhs: Type,
        rhs: &hir::Expr,
        span: Span,
    ) -> Option<Diagnostic> {
        let integer = matches!(lhs, Type::Scalar(s) | Type::Vector { scalar: s, .. } if s.is_integer());
        let err = match op {
            BinaryOp::Div | BinaryOp::Rem if integer && has_known_component(f, rhs, &is_zero) => {
                ConstError::DivisionByZero
            }
            BinaryOp::Shl | BinaryOp::Shr if has_known_component(f, rhs, &is_too_far) => ConstError::ShiftTooLarge,
            _ => return None,
        };
        let label = match err {
            ConstError::DivisionByZero => "this divisor is zero",
            _ => "this shift amount is 32 or more",
        };
        Some(self.const_error(span, &err, lhs).with_secondary(rhs.span, label))
    }

    /// The diagnostic for a constant evaluation that WGSL rejects; `ty` is the type of the
    /// expression at `span`.
    pub(super) fn const_error(&self, span: Span, err: &ConstError, ty: Type) -> Diagnostic {
        let text = self.show(span);
        match err {
            ConstError::Overflow if ty.scalar() == Some(Scalar::F32) => {
                Diagnostic::new(Code::ConstEvalFailed, span, format!("`{text}` overflows {ty}"))
                    .with_label("the result is infinite or not a number")
                    .with_note("WGSL evaluates constant expressions when the shader is created; f32 holds magnitudes up to about 3.4e38")
                    .with_help("use smaller values")
            }
            ConstError::Overflow => Diagnostic::new(Code::ConstEvalFailed, span, format!("`{text}` overflows {ty}"))
                .with_label(format!("the result does not fit in {ty}"))
                .with_help("use smaller values, or a wider type such as f32"),
            ConstError::DivisionByZero => {
                Diagnostic::new(Code::DivisionByZero, span, format!("`{text}` divides by zero"))
                    .with_label("division by a constant zero")
                    .with_note("WGSL rejects an integer division or remainder by a constant zero, and any constant division by zero, when the shader is created")
                    .with_help("divide by a non-zero value, or by a uniform when the divisor must change")
            }
            ConstError::ShiftTooLarge => {
                Diagnostic::new(Code::ShiftTooLarge, span, format!("`{text}` shifts by 32 bits or more"))
                    .with_label("the shift amount is at or past the bit width")
                    .with_note("WGSL rejects a constant shift amount that is not below the 32 bits of i32 and u32")
                    .with_help("shift by an amount in 0 ..= 31")
            }
            ConstError::Domain(why) => Diagnostic::new(Code::MathDomain, span, format!("`{text}`: {why}"))
                .with_label("outside the domain of the built-in")
                .with_note("WGSL evaluates a built-in with constant arguments when the shader is created, and rejects one without a finite result")
                .with_help("change the constant argument, or pass the value in as a uniform"),
            ConstError::NotConstant => Diagnostic::new(
                Code::NotConstant,
                span,
                format!("`{text}` is not a constant expression"),
            )
            .with_label("computed at run time")
            .with_note(
                "constant expressions may use literals, constructors, unary minus, arithmetic and other constants",
            ),
        }
    }
}

/// The value of one node from its operands' known values: `Ok(None)` when an operand is only
/// known at run time (or the node is one WGSL does not fold).
fn fold_node(f: &FnCx, e: &hir::Expr) -> Result<Option<ConstValue>, ConstError> {
    let known = |x: &hir::Expr| known_value(f, x);
    let all_known = |xs: &[hir::Expr]| xs.iter().map(known).collect::<Option<Vec<_>>>();
    let result = match &e.kind {
        ExprKind::Unary { op, operand } => match known(operand) {
            Some(v) => consteval::eval_unary(*op, &v),
            None => return Ok(None),
        },
        ExprKind::Binary { op, lhs, rhs } => match (known(lhs), known(rhs)) {
            (Some(l), Some(r)) => consteval::eval_binary(*op, &l, &r),
            _ => return Ok(None),
        },
        ExprKind::Construct { args } => match all_known(args) {
            Some(values) => consteval::eval_constructor(e.ty, &values),
            None => return Ok(None),
        },
        ExprKind::Convert { arg } => match known(arg) {
            Some(v) => consteval::eval_constructor(e.ty, &[v]),
            None => return Ok(None),
        },
        ExprKind::Swizzle { base, components } => match known(base) {
            Some(v) => consteval::eval_swizzle(&v, components),
            None => return Ok(None),
        },
        ExprKind::Index { base, index } => match (known(base), known_index(f, index)) {
            (Some(b), Some(i)) => index_const(&b, Some(i)).ok_or(ConstError::NotConstant),
            _ => return Ok(None),
        },
        ExprKind::CallBuiltin { builtin, args } => match all_known(args) {
            Some(values) => eval_builtin(*builtin, &values),
            None => return Ok(None),
        },
        _ => return Ok(None),
    };
    match result {
        Ok(v) => Ok(Some(v)),
        Err(ConstError::NotConstant) => Ok(None),
        Err(err) => Err(err),
    }
}
