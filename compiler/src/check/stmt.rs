//! Statements, local scopes and control flow: `let`/`var`, assignment targets, `if`, `for`,
//! `break`/`continue`, `return`, and the flow facts the function rules need (does a block
//! always return? is a statement unreachable?).

use super::constfold::inlined_value;
use super::expr::{Hint, StateUse, concrete_hint, literal_kind, swizzle};
use super::scope::{Binding, FnCx, FnKind, LocalKind};
use super::{Checker, MAX_DEPTH, rules};
use crate::ast::{self, AssignOp, BinaryOp, ExprKind, StmtKind};
use crate::diag::{Code, Diagnostic};
use crate::hir::{self, Access, Place, PlaceRoot};
use crate::source::Span;
use crate::types::{Scalar, Type};

/// What is known about how control leaves a statement or block.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Flow {
    /// Every path ends in `return`.
    pub returns: bool,
    /// No path reaches the next statement (`return`, `break`, `continue`).
    pub diverges: bool,
}

fn assign_symbol(op: AssignOp) -> &'static str {
    match op {
        AssignOp::Assign => "=",
        AssignOp::Add => "+=",
        AssignOp::Sub => "-=",
        AssignOp::Mul => "*=",
        AssignOp::Div => "/=",
    }
}

fn compound_op(op: AssignOp) -> Option<BinaryOp> {
    match op {
        AssignOp::Assign => None,
        AssignOp::Add => Some(BinaryOp::Add),
        AssignOp::Sub => Some(BinaryOp::Sub),
        AssignOp::Mul => Some(BinaryOp::Mul),
        AssignOp::Div => Some(BinaryOp::Div),
    }
}

impl Checker<'_> {
    /// Checks a block; `new_scope` is false for a function's top-level block, which shares
    /// scope 0 with the parameters (lib fns) or uniforms (pipelines), as in WGSL.
    pub(super) fn block(&mut self, f: &mut FnCx, b: &ast::Block, new_scope: bool) -> (hir::Block, Flow) {
        if self.block_depth >= MAX_DEPTH {
            self.too_deep(f, b.span, "block");
            return (hir::Block { stmts: Vec::new(), span: b.span }, Flow { returns: true, diverges: false });
        }
        self.block_depth += 1;
        if new_scope {
            f.push_scope();
        }
        let mut stmts = Vec::new();
        let mut flow = Flow::default();
        let mut dead: Option<(Span, Span)> = None; // (what ended the flow, first unreachable statement)
        let mut ended_by: Option<Span> = None;
        for s in &b.stmts {
            if let Some(end) = ended_by
                && dead.is_none()
                && !matches!(s.kind, StmtKind::Error)
            {
                dead = Some((end, s.span));
            }
            let (checked, sf) = self.stmt(f, s);
            stmts.extend(checked);
            flow.returns |= sf.returns;
            if sf.diverges && ended_by.is_none() {
                flow.diverges = true;
                ended_by = Some(s.span);
            }
        }
        if let Some((end, first)) = dead {
            let last = b.stmts.last().map_or(first, |s| s.span);
            self.diags.push(
                Diagnostic::new(Code::UnreachableCode, first.to(last), "unreachable code")
                    .with_label("this never runs")
                    .with_secondary(end, "control never gets past this statement")
                    .with_help("remove the unreachable statements"),
            );
        }
        if new_scope {
            f.pop_scope();
        }
        self.block_depth -= 1;
        (hir::Block { stmts, span: b.span }, flow)
    }

    fn stmt(&mut self, f: &mut FnCx, s: &ast::Stmt) -> (Option<hir::Stmt>, Flow) {
        let span = s.span;
        let wrap = |kind| Some(hir::Stmt { kind, span });
        match &s.kind {
            StmtKind::Let { mutable, name, ty, value } => {
                (self.let_stmt(f, *mutable, name, ty.as_ref(), value.as_ref(), span).and_then(wrap), Flow::default())
            }
            StmtKind::Assign { target, op, value } => {
                (self.assign(f, target, *op, value).and_then(wrap), Flow::default())
            }
            StmtKind::If { cond, then, otherwise } => {
                let c = self.value(f, cond, Some(Type::BOOL));
                if !c.ty.is_error() && c.ty != Type::BOOL {
                    let d = Diagnostic::new(
                        Code::ConditionNotBool,
                        cond.span,
                        format!("an `if` condition must be bool, not {}", c.ty),
                    )
                    .with_label(format!("this is {}", c.ty))
                    .with_help("compare it, e.g. `x > 0.0`");
                    self.emit(f, d);
                }
                let (then, tf) = self.block(f, then, true);
                let (otherwise, of) = match otherwise {
                    Some(b) => {
                        let (b, flow) = self.block(f, b, true);
                        (Some(b), flow)
                    }
                    None => (None, Flow::default()),
                };
                let flow = Flow { returns: tf.returns && of.returns, diverges: tf.diverges && of.diverges };
                (wrap(hir::StmtKind::If { cond: c, then, otherwise }), flow)
            }
            StmtKind::For { var, start, end, body } => {
                (self.for_stmt(f, var, start, end, body).and_then(wrap), Flow::default())
            }
            StmtKind::Break | StmtKind::Continue => {
                let is_break = matches!(s.kind, StmtKind::Break);
                if f.loops == 0 {
                    let word = if is_break { "break" } else { "continue" };
                    let d = Diagnostic::new(Code::BreakOutsideLoop, span, format!("`{word}` outside a `for` loop"))
                        .with_label("not inside a loop")
                        .with_help("use `return;` to leave a function early");
                    self.emit(f, d);
                }
                let kind = if is_break { hir::StmtKind::Break } else { hir::StmtKind::Continue };
                (wrap(kind), Flow { returns: false, diverges: true })
            }
            StmtKind::Return(value) => {
                let checked = self.return_stmt(f, value.as_ref(), span);
                (wrap(hir::StmtKind::Return(checked)), Flow { returns: true, diverges: true })
            }
            StmtKind::Expr(e) => (self.expr_stmt(f, e).and_then(wrap), Flow::default()),
            StmtKind::Block(b) => {
                let (b, flow) = self.block(f, b, true);
                (wrap(hir::StmtKind::Block(b)), flow)
            }
            StmtKind::Error => {
                // Already reported by the parser; assume it returned, so no E0401 follows from it.
                f.failed = true;
                f.lost_statement = true;
                (None, Flow { returns: true, diverges: false })
            }
        }
    }

    fn let_stmt(
        &mut self,
        f: &mut FnCx,
        mutable: bool,
        name: &ast::Ident,
        ty: Option<&ast::TypeExpr>,
        value: Option<&ast::Expr>,
        span: Span,
    ) -> Option<hir::StmtKind> {
        let declared = ty.map(|t| {
            let resolved = self.resolve_type(t);
            if resolved.is_error() {
                f.failed = true;
            }
            (resolved, t.span)
        });
        let checked = value.map(|v| self.value(f, v, declared.map(|(t, _)| t)));
        let keyword = if mutable { "var" } else { "let" };
        let ty = match (declared, &checked) {
            (Some((t, _)), Some(v)) => {
                self.expect_type(f, v, t, &format!("`{keyword} {}: {t}`", name.name));
                t
            }
            (Some((t, _)), None) => t,
            (None, Some(v)) => v.ty,
            (None, None) => Type::Error,
        };
        if value.is_none() && declared.is_none() && mutable {
            let d = Diagnostic::new(Code::Syntax, span, format!("`var {}` needs a type or a value", name.name))
                .with_label("no `: type` and no `= value`")
                .with_help(format!(
                    "give it a type (`var {0}: f32;`, which starts at zero) or a value (`var {0} = 0.0;`)",
                    name.name
                ));
            self.emit(f, d);
        } else if value.is_none() && !mutable {
            let d = Diagnostic::new(Code::Syntax, span, format!("`let {}` needs a value", name.name))
                .with_label("no `= value`")
                .with_help("give it a value, or declare it with `var` to assign it later");
            self.emit(f, d);
        }
        if ty.is_resource() {
            let at = declared.map_or(span, |(_, s)| s);
            let d = Diagnostic::new(Code::ResourceMisuse, at, format!("a local variable cannot hold a `{ty}`"))
                .with_label(format!("`{}` would be a {ty}", name.name))
                .with_help(format!("pass the {ty} directly to `sample`/`lookup`/`dims` or to a library function"));
            self.emit(f, d);
        }
        let kind = if mutable { LocalKind::Var } else { LocalKind::Let };
        let local = f.add_local(&name.name, ty, kind, name.span);
        if !mutable && let Some(value) = checked.as_ref().and_then(|v| inlined_value(f, v)) {
            f.inlined_lets.insert(local, value);
        }
        if !mutable
            && let Some(v) = &checked
            && matches!(v.kind, hir::ExprKind::Const(_) | hir::ExprKind::Construct { .. } | hir::ExprKind::Local(_))
        {
            f.let_values.insert(local, v.clone());
        }
        self.declare_local(f, name, Binding::Local(local));
        Some(hir::StmtKind::Let { local, value: checked })
    }

    /// Makes a local visible; E0203 when its scope already has the name.
    fn declare_local(&mut self, f: &mut FnCx, name: &ast::Ident, binding: Binding) {
        if name.name.is_empty() {
            return;
        }
        if let Err(earlier) = f.declare(&name.name, binding, name.span) {
            let d = Diagnostic::new(
                Code::Duplicate,
                name.span,
                format!("`{}` is already declared in this scope", name.name),
            )
            .with_label("declared again here")
            .with_secondary(earlier, "first declared here")
            .with_help("choose another name (an inner block may shadow a name, the same block may not)");
            self.emit(f, d);
        }
    }

    /// Reports E0301 when `e` does not have type `expected`.
    pub(super) fn expect_type(&mut self, f: &mut FnCx, e: &hir::Expr, expected: Type, what: &str) -> bool {
        if e.ty == expected || e.ty.is_error() || expected.is_error() {
            return true;
        }
        let mut d = Diagnostic::new(Code::TypeMismatch, e.span, format!("{what} expects {expected}, found {}", e.ty))
            .with_label(format!("this is {}", e.ty));
        if e.ty.scalar() == Some(Scalar::F32) && expected.scalar().is_some_and(Scalar::is_integer) {
            d = d.with_note("a float value never becomes an integer implicitly");
        }
        if e.ty.components() == expected.components()
            && e.ty.components() > 0
            && !matches!(expected, Type::Matrix { .. })
        {
            d = d.with_help(format!("convert it explicitly: `{expected}({})`", self.show(e.span)));
        }
        self.emit(f, d);
        false
    }

    fn assign(&mut self, f: &mut FnCx, target: &ast::Expr, op: AssignOp, value: &ast::Expr) -> Option<hir::StmtKind> {
        if let ExprKind::State(id) = &target.kind
            && f.kind == FnKind::Pipeline
            && !f.state.iter().any(|s| s.name == id.name)
        {
            // Undeclared: the value's type is the best guess for the declaration to offer.
            let v = self.value(f, value, None);
            self.state_field(f, id, target.span, StateUse::Write, concrete_hint(&v));
            return None;
        }
        let place = self.place(f, target, op != AssignOp::Assign);
        let hint: Hint = place.as_ref().map(|p| p.ty).filter(|t| !t.is_error());
        let v = self.value(f, value, hint);
        let place = place?;
        if v.ty.is_error() || place.ty.is_error() {
            f.failed = true;
            return None;
        }
        match compound_op(op) {
            None => {
                let what = format!("assigning to `{}`", self.show(target.span));
                self.expect_type(f, &v, place.ty, &what);
            }
            Some(bin) => {
                if rules::binary_result(bin, place.ty, v.ty) != Some(place.ty) {
                    let sym = assign_symbol(op);
                    let d = Diagnostic::new(
                        Code::InvalidOperands,
                        v.span.to(target.span),
                        format!("cannot apply `{sym}` to {} and {}", place.ty, v.ty),
                    )
                    .with_label(format!("{} {sym} {}", place.ty, v.ty))
                    .with_note(format!("`a {sym} b` needs `a {} b` to have the type of `a`", bin.symbol()));
                    self.emit(f, d);
                } else if let Some(d) = self.operand_rule(f, bin, place.ty, &v, target.span.to(v.span)) {
                    self.emit(f, d);
                }
            }
        }
        Some(hir::StmtKind::Assign { place, op, value: v })
    }

    /// The assignment target `e`; `compound` targets are read as well as written.
    fn place(&mut self, f: &mut FnCx, e: &ast::Expr, compound: bool) -> Option<Place> {
        let (root, path, ty, _) = self.place_parts(f, e, compound)?;
        Some(Place { root, path, ty, span: e.span })
    }

    /// Root, accesses, type, and whether the path ends in a multi-component swizzle.
    fn place_parts(
        &mut self,
        f: &mut FnCx,
        e: &ast::Expr,
        compound: bool,
    ) -> Option<(PlaceRoot, Vec<Access>, Type, bool)> {
        if self.expr_depth >= MAX_DEPTH {
            self.too_deep(f, e.span, "expression");
            return None;
        }
        self.expr_depth += 1;
        let out = self.place_kind(f, e, compound);
        self.expr_depth -= 1;
        out
    }

    fn place_kind(
        &mut self,
        f: &mut FnCx,
        e: &ast::Expr,
        compound: bool,
    ) -> Option<(PlaceRoot, Vec<Access>, Type, bool)> {
        match &e.kind {
            ExprKind::Name(id) => self.place_root(f, id).map(|(root, ty)| (root, Vec::new(), ty, false)),
            ExprKind::State(id) => {
                let how = if compound { StateUse::ReadWrite } else { StateUse::Write };
                let (index, ty) = self.state_field(f, id, e.span, how, None)?;
                Some((PlaceRoot::State(index), Vec::new(), ty, false))
            }
            ExprKind::Member { base, member } => {
                let (root, mut path, ty, swizzled) = self.place_parts(f, base, compound)?;
                self.no_access_after_swizzle(f, swizzled, e.span)?;
                match swizzle(ty, &member.name) {
                    Ok((components, result)) => {
                        let many = components.len() > 1;
                        if many && !distinct(&components) {
                            let d = Diagnostic::new(
                                Code::NotAssignable,
                                member.span,
                                format!("`.{}` names a component twice; it cannot be assigned", member.name),
                            )
                            .with_label("repeated component")
                            .with_help("a swizzle assignment needs distinct components, e.g. `.xy`");
                            self.emit(f, d);
                            return None;
                        }
                        path.push(match components.as_slice() {
                            [one] => Access::Component(*one),
                            _ => Access::Swizzle(components),
                        });
                        Some((root, path, result, many))
                    }
                    Err(why) => {
                        let text = format!("`{}.{}`: {why}", self.show(base.span), member.name);
                        let d = Diagnostic::new(Code::InvalidMember, member.span, text)
                            .with_label(format!("not a member of {ty}"));
                        self.emit(f, d);
                        None
                    }
                }
            }
            ExprKind::Index { base, index } => {
                let (root, mut path, ty, swizzled) = self.place_parts(f, base, compound)?;
                self.no_access_after_swizzle(f, swizzled, e.span)?;
                let i = self.value(f, index, None);
                if i.ty.is_error() || ty.is_error() {
                    f.failed = true;
                    return None;
                }
                let elem = self.check_index(f, ty, &i, base.span)?;
                path.push(Access::Index(Box::new(i)));
                Some((root, path, elem, false))
            }
            ExprKind::Error => {
                f.failed = true;
                None
            }
            _ => {
                // Check it anyway, for its own mistakes.
                self.expr(f, e, None);
                let d = Diagnostic::new(Code::NotAssignable, e.span, "cannot assign to this expression")
                    .with_label("not a variable")
                    .with_help("assign to a `var`, a state field, or a component of one");
                self.emit(f, d);
                None
            }
        }
    }

    fn no_access_after_swizzle(&mut self, f: &mut FnCx, swizzled: bool, span: Span) -> Option<()> {
        if !swizzled {
            return Some(());
        }
        let d = Diagnostic::new(Code::NotAssignable, span, "cannot assign through a swizzle of several components")
            .with_label("access after a swizzle")
            .with_help("name the components directly, e.g. `v.y = ...` instead of `v.xy.y = ...`");
        self.emit(f, d);
        None
    }

    /// A name as an assignment target: only `var` locals.
    fn place_root(&mut self, f: &mut FnCx, id: &ast::Ident) -> Option<(PlaceRoot, Type)> {
        let name = &id.name;
        let d = match f.lookup(name) {
            Some((Binding::Local(l), decl)) => {
                let ty = f.locals.get(l).map_or(Type::Error, |local| local.ty);
                match f.local_kinds.get(l) {
                    Some(LocalKind::Var) => return Some((PlaceRoot::Local(l), ty)),
                    Some(LocalKind::Let) => Diagnostic::new(
                        Code::NotAssignable,
                        id.span,
                        format!("cannot assign to `{name}`: it is declared with `let`"),
                    )
                    .with_label("assigned here")
                    .with_secondary(decl, "declared with `let` here")
                    .with_help(format!("declare it with `var` to change it: `var {name} = ...;`")),
                    _ => Diagnostic::new(
                        Code::NotAssignable,
                        id.span,
                        format!("cannot assign to loop variable `{name}`"),
                    )
                    .with_label("assigned here")
                    .with_secondary(decl, "the loop sets it")
                    .with_help(format!("copy it into a variable: `var j = {name};`")),
                }
            }
            Some((Binding::Param(_), decl)) => {
                Diagnostic::new(Code::NotAssignable, id.span, format!("cannot assign to parameter `{name}`"))
                    .with_label("assigned here")
                    .with_secondary(decl, "parameters are immutable")
                    .with_help(format!("copy it into a variable first: `var {name}_v = {name};`"))
            }
            Some((Binding::Uniform(_), decl)) => {
                Diagnostic::new(Code::NotAssignable, id.span, format!("cannot assign to uniform `{name}`"))
                    .with_label("assigned here")
                    .with_secondary(decl, "uniforms are read-only")
                    .with_help(format!("copy it into a variable first: `var {name}_v = {name};`"))
            }
            None if f.lost_statement => {
                f.failed = true;
                return None;
            }
            None if self.item(f.module, name).is_some() => {
                Diagnostic::new(Code::NotAssignable, id.span, format!("cannot assign to `{name}`"))
                    .with_label("a module constant or function")
                    .with_help(format!("declare a variable: `var {name}_v = ...;`"))
            }
            None => Diagnostic::new(Code::UnknownName, id.span, format!("unknown name `{name}`"))
                .with_label("assigned but never declared")
                .with_help(format!("declare it first: `var {name} = ...;`")),
        };
        self.emit(f, d);
        None
    }

    fn for_stmt(
        &mut self,
        f: &mut FnCx,
        var: &ast::Ident,
        start: &ast::Expr,
        end: &ast::Expr,
        body: &ast::Block,
    ) -> Option<hir::StmtKind> {
        // A bound made of literals takes the type of the other bound; both literals give i32.
        let (s, e) = match (literal_kind(start), literal_kind(end)) {
            (Some(_), None) => {
                let e = self.value(f, end, None);
                (self.value(f, start, concrete_hint(&e)), e)
            }
            _ => {
                let s = self.value(f, start, Some(Type::I32));
                let e = self.value(f, end, concrete_hint(&s));
                (s, e)
            }
        };
        let ty = if s.ty.is_error() || e.ty.is_error() {
            Type::Error
        } else if s.ty == e.ty && matches!(s.ty, Type::Scalar(Scalar::I32 | Scalar::U32)) {
            s.ty
        } else {
            let d = Diagnostic::new(
                Code::RangeNotInteger,
                s.span.to(e.span),
                format!("a `for` range needs two i32 or two u32 bounds, not {} and {}", s.ty, e.ty),
            )
            .with_label(format!("{} .. {}", s.ty, e.ty))
            .with_help("convert the bounds, e.g. `0 .. i32(n)`");
            self.emit(f, d);
            Type::Error
        };
        f.push_scope();
        let local = f.add_local(&var.name, ty, LocalKind::Loop, var.span);
        self.declare_local(f, var, Binding::Local(local));
        f.loops += 1;
        let (body, _) = self.block(f, body, true);
        f.loops -= 1;
        f.pop_scope();
        Some(hir::StmtKind::For { var: local, start: s, end: e, body })
    }

    fn return_stmt(&mut self, f: &mut FnCx, value: Option<&ast::Expr>, span: Span) -> Option<hir::Expr> {
        let hint = Some(f.ret).filter(|t| *t != Type::Void);
        let checked = value.map(|v| self.value(f, v, hint));
        let d = match (f.kind, &checked) {
            (FnKind::Pipeline, Some(_)) => Diagnostic::new(
                Code::ReturnMismatch,
                span,
                format!("pipeline function `{}` cannot return a value", f.name),
            )
            .with_label("returns a value")
            .with_help(
                "pipeline functions write their results to state: assign it to a `state` field and write `return;`",
            ),
            (FnKind::Lib, Some(_)) if f.ret == Type::Void => Diagnostic::new(
                Code::ReturnMismatch,
                span,
                format!("`{}` has no return type, so it cannot return a value", f.name),
            )
            .with_label("returns a value")
            .with_help(format!("add the return type to the signature: `lib fn {}(...) -> T`", f.name)),
            (FnKind::Lib, None) if f.ret != Type::Void && !f.ret.is_error() => Diagnostic::new(
                Code::ReturnMismatch,
                span,
                format!("`{}` must return a value of type {}", f.name, f.ret),
            )
            .with_label("returns no value")
            .with_help(format!("return a value: `return ...;` of type {}", f.ret)),
            (FnKind::Lib, Some(v)) => {
                let what = format!("the return value of `{}`", f.name);
                let ret = f.ret;
                self.expect_type(f, v, ret, &what);
                return checked;
            }
            _ => return checked,
        };
        self.emit(f, d);
        checked
    }

    /// An expression statement: only a call may stand alone.
    fn expr_stmt(&mut self, f: &mut FnCx, e: &ast::Expr) -> Option<hir::StmtKind> {
        match &e.kind {
            ExprKind::Call { .. } => Some(hir::StmtKind::Expr(self.expr(f, e, None))),
            ExprKind::Error => {
                f.poison(e.span);
                None
            }
            _ => {
                self.expr(f, e, None);
                let d = Diagnostic::new(
                    Code::Syntax,
                    e.span,
                    "this expression does nothing: only a call can be a statement",
                )
                .with_label("value is never used")
                .with_help("store it: `let x = ...;`, or assign it to a variable or state field");
                self.emit(f, d);
                None
            }
        }
    }
}

fn distinct(components: &[u8]) -> bool {
    components.iter().enumerate().all(|(i, c)| !components[..i].contains(c))
}
