//! Expression typing: literals (which take the type their context expects), names, `state.F`,
//! swizzles, indexing and operators. Calls and constructors are in `call`.
//!
//! Every checker function gets a [`Hint`]: the type the context expects, if it knows one. An
//! unsuffixed integer literal takes the hint's scalar (i32, u32 or f32); an unknown name in a
//! pipeline function offers the hint as the type of the missing uniform.

use super::constfold::known_index;
use super::scope::{Binding, FnCx, FnKind, ItemRef};
use super::{Checker, MAX_DEPTH, rules, type_or_placeholder};
use crate::ast::{self, BinaryOp, ExprKind, Ident, UnaryOp};
use crate::diag::{Code, Diagnostic};
use crate::hir::{self, ConstValue, ScalarValue};
use crate::lexer::IntSuffix;
use crate::source::Span;
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};

/// The type the context of an expression expects, if any.
pub(super) type Hint = Option<Type>;

/// How a state field is used where it appears.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum StateUse {
    Read,
    Write,
    ReadWrite,
}

/// The literal-only part of an expression tree that adapts to its context.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Literal {
    Int,
    /// Contains an unsuffixed float literal: the tree can only become f32.
    Float,
}

/// Whether `e` is made only of unsuffixed literals (and arithmetic on them), so that it takes
/// the type of the other operand; `Float` when it contains a float literal.
pub(super) fn literal_kind(e: &ast::Expr) -> Option<Literal> {
    literal_kind_at(e, 0)
}

fn literal_kind_at(e: &ast::Expr, depth: u32) -> Option<Literal> {
    if depth > 32 {
        return None;
    }
    match &e.kind {
        ExprKind::Int { value: Some(_), suffix: None } => Some(Literal::Int),
        ExprKind::Float { suffixed: false, .. } => Some(Literal::Float),
        ExprKind::Unary { op: UnaryOp::Neg, operand } => literal_kind_at(operand, depth + 1),
        ExprKind::Binary { op, lhs, rhs } if is_arithmetic(*op) => {
            Some(literal_kind_at(lhs, depth + 1)?.max(literal_kind_at(rhs, depth + 1)?))
        }
        _ => None,
    }
}

fn is_arithmetic(op: BinaryOp) -> bool {
    matches!(op, BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem)
}

fn is_comparison_or_logic(op: BinaryOp) -> bool {
    use BinaryOp::*;
    matches!(op, Lt | Le | Gt | Ge | Eq | Ne | And | Or)
}

pub(super) fn unary_symbol(op: UnaryOp) -> &'static str {
    match op {
        UnaryOp::Neg => "-",
        UnaryOp::Not => "!",
    }
}

/// A typed expression.
pub(super) fn mk(kind: hir::ExprKind, ty: Type, span: Span) -> hir::Expr {
    hir::Expr { kind, ty, span }
}

fn constant(value: ScalarValue, span: Span) -> hir::Expr {
    let ty = Type::Scalar(value.scalar());
    mk(hir::ExprKind::Const(ConstValue { ty, components: vec![value] }), ty, span)
}

/// The components a swizzle such as `xzy` or `rgb` selects from `ty`, and its result type.
pub(super) fn swizzle(ty: Type, text: &str) -> Result<(Vec<u8>, Type), String> {
    let Type::Vector { size, scalar } = ty else {
        return Err(match ty {
            Type::Matrix { .. } => format!("{ty} has no members; index a column with `[i]`"),
            _ => format!("{ty} has no members"),
        });
    };
    let sets = ["xyzw", "rgba"];
    let Some(set) = sets.iter().find(|set| text.chars().all(|c| set.contains(c))) else {
        return Err(match text.chars().find(|c| !"xyzwrgba".contains(*c)) {
            Some(c) => format!("{ty} has no component `{c}`"),
            None => String::from("a swizzle uses either `xyzw` or `rgba` letters, not both"),
        });
    };
    if text.is_empty() || text.len() > 4 {
        return Err(String::from("a swizzle has 1 to 4 components"));
    }
    let mut components = Vec::new();
    for c in text.chars() {
        let index = set.find(c).unwrap_or(0) as u8;
        if index >= size {
            return Err(format!("{ty} has no component `{c}`"));
        }
        components.push(index);
    }
    let result = match components.len() {
        1 => Type::Scalar(scalar),
        n => Type::vec(n as u8, scalar),
    };
    Ok((components, result))
}

impl Checker<'_> {
    /// Checks an expression whose value is used: a call that returns nothing is an error here.
    pub(super) fn value(&mut self, f: &mut FnCx, e: &ast::Expr, hint: Hint) -> hir::Expr {
        let out = self.expr(f, e, hint);
        if out.ty != Type::Void {
            return out;
        }
        let d = Diagnostic::new(Code::TypeMismatch, e.span, format!("`{}` returns no value", self.show(e.span)))
            .with_label("used as a value here");
        self.emit(f, d);
        f.poison(e.span)
    }

    /// Checks any expression (a call may return nothing). Follows at most [`MAX_DEPTH`] levels.
    pub(super) fn expr(&mut self, f: &mut FnCx, e: &ast::Expr, hint: Hint) -> hir::Expr {
        if self.expr_depth >= MAX_DEPTH {
            return self.too_deep(f, e.span, "expression");
        }
        self.expr_depth += 1;
        let out = self.expr_kind(f, e, hint);
        self.expr_depth -= 1;
        self.fold_constants(f, out)
    }

    /// E0105, once per function: deeper trees would overflow the stack of every later pass.
    /// `what` is "expression" or "block".
    pub(super) fn too_deep(&mut self, f: &mut FnCx, span: Span, what: &str) -> hir::Expr {
        let reported = f.too_deep || (f.kind == FnKind::Const && self.const_too_deep);
        f.too_deep = true;
        self.const_too_deep |= f.kind == FnKind::Const;
        if !reported {
            let d = Diagnostic::new(
                Code::TooDeep,
                span,
                format!("{what} nested too deeply (more than {MAX_DEPTH} levels)"),
            )
            .with_label("nesting limit reached here")
            .with_help(if what == "block" {
                "move the inner part into a library function"
            } else {
                "split the expression into several `let` statements"
            });
            self.emit(f, d);
        }
        f.poison(span)
    }

    fn expr_kind(&mut self, f: &mut FnCx, e: &ast::Expr, hint: Hint) -> hir::Expr {
        match &e.kind {
            ExprKind::Int { value, suffix } => self.int_literal(f, e.span, *value, *suffix, false, hint),
            ExprKind::Float { value, .. } => self.float_literal(f, e.span, *value, false),
            ExprKind::Bool(b) => constant(ScalarValue::Bool(*b), e.span),
            ExprKind::Name(id) => self.name(f, id, hint),
            ExprKind::State(id) => match self.state_field(f, id, e.span, StateUse::Read, hint) {
                Some((index, ty)) => mk(hir::ExprKind::State(index), ty, e.span),
                None => f.poison(e.span),
            },
            ExprKind::Member { base, member } => self.member(f, base, member, e.span),
            ExprKind::Index { base, index } => self.index(f, base, index, e.span),
            ExprKind::Call { callee, generics, args } => self.call(f, e.span, callee, generics, args, hint),
            ExprKind::Unary { op, operand } => self.unary(f, *op, operand, e.span, hint),
            ExprKind::Binary { op, lhs, rhs } => self.binary(f, *op, lhs, rhs, e.span, hint),
            ExprKind::Error => f.poison(e.span),
        }
    }

    /// An integer literal, negated when `negative` (so `-2147483648` fits i32).
    fn int_literal(
        &mut self,
        f: &mut FnCx,
        span: Span,
        value: Option<u64>,
        suffix: Option<IntSuffix>,
        negative: bool,
        hint: Hint,
    ) -> hir::Expr {
        let Some(magnitude) = value else { return f.poison(span) }; // reported by the lexer
        let scalar = match suffix {
            Some(IntSuffix::I) => Scalar::I32,
            Some(IntSuffix::U) => Scalar::U32,
            None => match hint.and_then(Type::scalar) {
                Some(s @ (Scalar::I32 | Scalar::U32 | Scalar::F32)) => s,
                _ => Scalar::I32,
            },
        };
        let v = if negative { -i128::from(magnitude) } else { i128::from(magnitude) };
        let fitted = match scalar {
            Scalar::I32 => i32::try_from(v).ok().map(ScalarValue::I32),
            Scalar::U32 => u32::try_from(v).ok().map(ScalarValue::U32),
            Scalar::F32 => Some(ScalarValue::F32(v as f32)),
            Scalar::Bool => None,
        };
        if let Some(value) = fitted {
            return constant(value, span);
        }
        let text = self.show(span);
        let (label, help) = match scalar {
            Scalar::U32 if v < 0 => {
                ("u32 has no negative values", "use an i32 (suffix `i`) for a negative value".into())
            }
            Scalar::I32 if v > 0 && v <= i128::from(u32::MAX) && suffix.is_none() => {
                ("i32 holds -2147483648 ..= 2147483647", format!("write `{magnitude}u` for a u32"))
            }
            Scalar::I32 => ("i32 holds -2147483648 ..= 2147483647", "use a float (write `.0`) for such values".into()),
            _ => ("u32 holds 0 ..= 4294967295", "use a float (write `.0`) for such values".into()),
        };
        let d = Diagnostic::new(Code::LiteralOutOfRange, span, format!("`{text}` does not fit in {}", scalar.name()))
            .with_label(label)
            .with_help(help);
        self.emit(f, d);
        f.poison(span)
    }

    fn float_literal(&mut self, f: &mut FnCx, span: Span, value: f64, negative: bool) -> hir::Expr {
        let v = if negative { -value } else { value };
        let narrowed = v as f32;
        // `1e999999` is infinite already as an f64; WGSL rejects both at shader creation.
        if !narrowed.is_finite() {
            let d =
                Diagnostic::new(Code::LiteralOutOfRange, span, format!("`{}` does not fit in f32", self.show(span)))
                    .with_label("f32 holds magnitudes up to about 3.4e38");
            self.emit(f, d);
            return f.poison(span);
        }
        constant(ScalarValue::F32(narrowed), span)
    }

    /// A plain name: local, parameter, uniform or module constant.
    fn name(&mut self, f: &mut FnCx, id: &Ident, hint: Hint) -> hir::Expr {
        if let Some((binding, _)) = f.lookup(&id.name) {
            return binding_expr(f, binding, id.span);
        }
        match self.item(f.module, &id.name) {
            Some(ItemRef::Const(c)) => match self.const_value(c, id.span) {
                Some(v) => mk(hir::ExprKind::Const(v.clone()), v.ty, id.span),
                None => f.poison(id.span),
            },
            Some(ItemRef::Lib(_)) => {
                let d = Diagnostic::new(
                    Code::UnknownName,
                    id.span,
                    format!("`{}` is a library function, not a value", id.name),
                )
                .with_label("used as a value")
                .with_help(format!("call it: `{}(...)`", id.name));
                self.emit(f, d);
                f.poison(id.span)
            }
            None => self.unknown_name(f, id, hint),
        }
    }

    fn unknown_name(&mut self, f: &mut FnCx, id: &Ident, hint: Hint) -> hir::Expr {
        if f.lost_statement || !f.first_report(format!("name {}", id.name)) {
            return f.poison(id.span);
        }
        let name = &id.name;
        let mut candidates = f.visible_names();
        if let Some(scope) = self.scopes.get(f.module) {
            candidates
                .extend(scope.names.iter().filter(|(_, r)| matches!(r, ItemRef::Const(_))).map(|(n, _)| n.clone()));
        }
        let suggestion = did_you_mean(name, candidates.iter().map(String::as_str)).map(str::to_string);
        let mut d = match f.kind {
            FnKind::Pipeline => Diagnostic::new(Code::UndeclaredUniform, id.span, format!("unknown name `{name}`"))
                .with_label("not a local, a constant or a declared uniform"),
            FnKind::Lib => Diagnostic::new(Code::UnknownName, id.span, format!("unknown name `{name}`"))
                .with_label("not a parameter, a local or a constant"),
            FnKind::Const => {
                Diagnostic::new(Code::UnknownName, id.span, format!("unknown name `{name}` in a constant expression"))
                    .with_label("not a constant")
            }
        };
        if let Some(best) = &suggestion {
            d = d.with_help(format!("did you mean `{best}`?"));
        }
        match f.kind {
            FnKind::Pipeline => {
                let ty = type_or_placeholder(hint);
                d = d.with_help(format!("declare it as a uniform: `uniform {name}: {ty};`"));
            }
            FnKind::Lib if self.declared_names().uniforms.contains(name) => {
                d = d.with_note(format!(
                    "`{name}` is a uniform of a pipeline function; library functions cannot read uniforms: pass it in as a parameter"
                ));
            }
            FnKind::Lib if suggestion.is_none() => {
                d = d.with_help(format!("declare it first (`let {name} = ...;`) or add a parameter `{name}`"));
            }
            FnKind::Const => {
                d = d.with_note("constant expressions may use literals, constructors, arithmetic and other constants");
            }
            FnKind::Lib => {}
        }
        self.emit(f, d);
        f.poison(id.span)
    }

    /// `state.F`: its index in the pipeline's declarations and its type, marking the use.
    /// `guess` is the type the context suggests, offered when F is undeclared and unknown.
    pub(super) fn state_field(
        &mut self,
        f: &mut FnCx,
        id: &Ident,
        span: Span,
        how: StateUse,
        guess: Hint,
    ) -> Option<(usize, Type)> {
        let name = &id.name;
        match f.kind {
            FnKind::Pipeline => {}
            FnKind::Lib => {
                let d = Diagnostic::new(
                    Code::ImpureLibrary,
                    span,
                    format!("library function `{}` uses `state.{name}`", f.name),
                )
                .with_label("library functions cannot see the state")
                .with_help(format!(
                    "add a parameter to `{}` and pass `state.{name}` in from a pipeline function",
                    f.name
                ));
                self.emit(f, d);
                return None;
            }
            FnKind::Const => {
                let d = Diagnostic::new(Code::NotConstant, span, format!("`state.{name}` is not a constant"))
                    .with_label("state changes at run time")
                    .with_note("constant expressions may use literals, constructors, arithmetic and other constants");
                self.emit(f, d);
                return None;
            }
        }
        if let Some(index) = f.state.iter().position(|s| s.name == *name) {
            let slot = &mut f.state[index];
            slot.read |= how != StateUse::Write;
            slot.written |= how != StateUse::Read;
            if how != StateUse::Write && slot.first_read.is_none() {
                slot.first_read = Some(span);
            }
            return Some((index, slot.ty));
        }
        if !f.first_report(format!("state {name}")) {
            f.failed = true;
            return None;
        }
        let (ty, ray) = self.state_type_hint(name, guess);
        let decl = format!("{}state {name}: {ty};", if ray { "@ray " } else { "" });
        let d = Diagnostic::new(Code::UndeclaredState, span, format!("`state.{name}` is not declared"))
            .with_label(format!("`{}` has no `state {name}` declaration", f.name))
            .with_help(format!("add `{decl}` to the declarations"));
        self.emit(f, d);
        None
    }

    /// The type (and `@ray`) a state field has elsewhere, or in the standard library's fields.
    fn state_type_hint(&mut self, name: &str, guess: Hint) -> (String, bool) {
        if let Some((ty, ray)) = self.declared_names().state_hints.get(name) {
            return (ty.clone(), *ray);
        }
        const STANDARD: &[(&str, &str, bool)] = &[
            ("pos", "vec3f", false),
            ("t", "f32", false),
            ("ray_dir", "vec3f", true),
            ("value", "f32", false),
            ("gradient", "vec3f", false),
            ("color", "vec4f", false),
            ("accum", "vec4f", true),
            ("out_color", "vec4f", true),
            ("terminate", "bool", true),
        ];
        if let Some((_, ty, ray)) = STANDARD.iter().find(|(n, _, _)| *n == name) {
            return (ty.to_string(), *ray);
        }
        if name.starts_with("value_") {
            return (String::from("f32"), false);
        }
        if name.starts_with("color_") {
            return (String::from("vec4f"), false);
        }
        (type_or_placeholder(guess), false)
    }

    /// `base.member`: a swizzle or one vector component.
    fn member(&mut self, f: &mut FnCx, base: &ast::Expr, member: &Ident, span: Span) -> hir::Expr {
        let b = self.value(f, base, None);
        if b.ty.is_error() {
            return f.poison(span);
        }
        match swizzle(b.ty, &member.name) {
            Ok((components, ty)) => mk(hir::ExprKind::Swizzle { base: Box::new(b), components }, ty, span),
            Err(why) => {
                let text = format!("`{}.{}`: {why}", self.show(base.span), member.name);
                let d = Diagnostic::new(Code::InvalidMember, member.span, text)
                    .with_label(format!("not a member of {}", b.ty));
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    /// `base[index]` of a vector (a component) or a matrix (a column).
    fn index(&mut self, f: &mut FnCx, base: &ast::Expr, index: &ast::Expr, span: Span) -> hir::Expr {
        let b = self.value(f, base, None);
        let i = self.value(f, index, None);
        if b.ty.is_error() || i.ty.is_error() {
            return f.poison(span);
        }
        let Some(elem) = self.check_index(f, b.ty, &i, base.span) else { return f.poison(span) };
        mk(hir::ExprKind::Index { base: Box::new(b), index: Box::new(i) }, elem, span)
    }

    /// The element type of indexing a `base` value with `i`, or an E0306 error.
    pub(super) fn check_index(&mut self, f: &mut FnCx, base: Type, i: &hir::Expr, base_span: Span) -> Option<Type> {
        let (elem, len) = match base {
            Type::Vector { size, scalar } => (Type::Scalar(scalar), size),
            Type::Matrix { cols, rows } => (Type::vec(rows, Scalar::F32), cols),
            _ => {
                let d = Diagnostic::new(Code::InvalidIndex, base_span, format!("cannot index a value of type {base}"))
                    .with_label(format!("this is {base}"))
                    .with_note("only vectors (components) and matrices (columns) can be indexed");
                self.emit(f, d);
                return None;
            }
        };
        if !matches!(i.ty, Type::Scalar(Scalar::I32 | Scalar::U32)) {
            let d = Diagnostic::new(Code::InvalidIndex, i.span, format!("an index must be i32 or u32, not {}", i.ty))
                .with_label(format!("this is {}", i.ty));
            self.emit(f, d);
            return None;
        }
        if let Some(n) = known_index(f, i)
            && (n < 0 || n >= i64::from(len))
        {
            let d = Diagnostic::new(Code::IndexOutOfBounds, i.span, format!("index {n} is out of bounds for {base}"))
                .with_label(format!("valid indices are 0 ..= {}", len - 1))
                .with_help(format!("indices count from 0: the last one of {base} is {}", len - 1));
            self.emit(f, d);
            return None;
        }
        Some(elem)
    }

    fn unary(&mut self, f: &mut FnCx, op: UnaryOp, operand: &ast::Expr, span: Span, hint: Hint) -> hir::Expr {
        if op == UnaryOp::Neg {
            // Folded into the literal, so `-2147483648` is a valid i32.
            match &operand.kind {
                ExprKind::Int { value, suffix } => return self.int_literal(f, span, *value, *suffix, true, hint),
                ExprKind::Float { value, .. } => return self.float_literal(f, span, *value, true),
                _ => {}
            }
        }
        let x = self.value(f, operand, if op == UnaryOp::Not { Some(Type::BOOL) } else { hint });
        if x.ty.is_error() {
            return f.poison(span);
        }
        match rules::unary_result(op, x.ty) {
            Some(ty) if !ty.is_error() => mk(hir::ExprKind::Unary { op, operand: Box::new(x) }, ty, span),
            _ => {
                let sym = unary_symbol(op);
                let mut d = Diagnostic::new(Code::InvalidOperands, span, format!("cannot apply `{sym}` to {}", x.ty))
                    .with_label(format!("`{sym}` of {}", x.ty));
                d = match op {
                    UnaryOp::Not => d.with_help("`!` negates a bool; compare instead, e.g. `x == 0`"),
                    UnaryOp::Neg => d.with_note("`-` applies to i32, f32 and their vectors and matrices"),
                };
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    fn binary(
        &mut self,
        f: &mut FnCx,
        op: BinaryOp,
        lhs: &ast::Expr,
        rhs: &ast::Expr,
        span: Span,
        hint: Hint,
    ) -> hir::Expr {
        let (l, r) = self.operands(f, op, lhs, rhs, hint);
        if l.ty.is_error() || r.ty.is_error() {
            return f.poison(span);
        }
        match rules::binary_result(op, l.ty, r.ty) {
            Some(ty) if !ty.is_error() => {
                mk(hir::ExprKind::Binary { op, lhs: Box::new(l), rhs: Box::new(r) }, ty, span)
            }
            _ => {
                let sym = op.symbol();
                let mut d = Diagnostic::new(
                    Code::InvalidOperands,
                    span,
                    format!("cannot apply `{sym}` to {} and {}", l.ty, r.ty),
                )
                .with_label(format!("{} {sym} {}", l.ty, r.ty));
                if let Some(help) = self.conversion_help(&l, &r, lhs.span, rhs.span) {
                    d = d.with_help(help);
                }
                self.emit(f, d);
                f.poison(span)
            }
        }
    }

    /// Suggests an explicit conversion when a float value meets an integer one.
    fn conversion_help(&self, l: &hir::Expr, r: &hir::Expr, ls: Span, rs: Span) -> Option<String> {
        let (ints, int_span) = match (l.ty.scalar()?, r.ty.scalar()?) {
            (Scalar::F32, s) if s.is_integer() => (r.ty, rs),
            (s, Scalar::F32) if s.is_integer() => (l.ty, ls),
            _ => return None,
        };
        let target = ints.with_scalar(Scalar::F32);
        Some(format!("convert explicitly: `{target}({})`", self.show(int_span)))
    }

    /// Checks both operands. A side made only of literals is checked after the other side and
    /// takes its type (`x * 2` with `x: f32` makes `2` an f32).
    fn operands(
        &mut self,
        f: &mut FnCx,
        op: BinaryOp,
        lhs: &ast::Expr,
        rhs: &ast::Expr,
        hint: Hint,
    ) -> (hir::Expr, hir::Expr) {
        let outer = if is_comparison_or_logic(op) { None } else { hint };
        if matches!(op, BinaryOp::Shl | BinaryOp::Shr) {
            let l = self.value(f, lhs, outer);
            let shift = if l.ty.is_error() { Type::U32 } else { l.ty.with_scalar(Scalar::U32) };
            let r = self.value(f, rhs, Some(shift));
            return (l, r);
        }
        match (literal_kind(lhs), literal_kind(rhs)) {
            (Some(_), None) => {
                let r = self.value(f, rhs, outer);
                let l = self.value(f, lhs, concrete_hint(&r).or(outer));
                (l, r)
            }
            (None, Some(_)) => {
                let l = self.value(f, lhs, outer);
                let r = self.value(f, rhs, concrete_hint(&l).or(outer));
                (l, r)
            }
            (Some(a), Some(b)) => {
                let both = if a.max(b) == Literal::Float && outer.is_none() { Some(Type::F32) } else { outer };
                (self.value(f, lhs, both), self.value(f, rhs, both))
            }
            (None, None) => {
                let l = self.value(f, lhs, outer);
                let r = self.value(f, rhs, concrete_hint(&l).or(outer));
                (l, r)
            }
        }
    }
}

/// The type of a checked operand as a hint for the other one.
pub(super) fn concrete_hint(e: &hir::Expr) -> Hint {
    (e.ty.is_plain() && !e.ty.is_error()).then_some(e.ty)
}

/// The expression for a local name.
fn binding_expr(f: &mut FnCx, binding: Binding, span: Span) -> hir::Expr {
    match binding {
        Binding::Local(l) => match f.locals.get(l) {
            Some(local) => mk(hir::ExprKind::Local(l), local.ty, span),
            None => f.poison(span),
        },
        Binding::Param(p) => match f.params.get(p) {
            Some(param) => mk(hir::ExprKind::Param(p), param.ty, span),
            None => f.poison(span),
        },
        Binding::Uniform(u) => match f.uniforms.get_mut(u) {
            Some(slot) => {
                slot.read = true;
                mk(hir::ExprKind::Uniform(u), slot.ty, span)
            }
            None => f.poison(span),
        },
    }
}
