//! Lowering of one function body: expressions, statements and the emit discipline.

use rustc_hash::FxHashMap;

use naga::{Expression as E, Handle, MathFunction as Mf, Statement as S};

use super::emitter::{Emitter, is_pre_emitted};
use super::{
    BrickedFns, ModuleBuilder, PipelineEnv, ResourceVariant, UniformAccess, emitted_name, internal, naga_scalar,
    vector_size,
};
use crate::ast::{AssignOp, BinaryOp, UnaryOp};
use crate::diag::Diagnostic;
use crate::hir::{self, Access, Builtin, ExprKind, PlaceRoot, ScalarValue, StmtKind};
use crate::source::Span;
use crate::types::{Scalar, Type};

type R<T> = Result<T, Diagnostic>;
type Ex = Handle<naga::Expression>;

pub(super) fn lower_lib_fn(
    b: &mut ModuleBuilder,
    program: &hir::Program,
    lf: &hir::LibFn,
    variant: &ResourceVariant,
) -> R<naga::Function> {
    let mut func = naga::Function { name: Some(b.claim_function_name(&lf.name, lf.module)), ..Default::default() };
    let mut params = Vec::with_capacity(lf.params.len());
    let mut resources = variant.iter();
    for p in &lf.params {
        let name = emitted_name(&p.name);
        let arg = |func: &mut naga::Function, name: String, ty| {
            let index = func.arguments.len() as u32;
            func.arguments.push(naga::FunctionArgument { name: Some(name), ty, binding: None });
            func.expressions.append(E::FunctionArgument(index), p.span.into())
        };
        let bricked = if p.ty.is_resource() { resources.next().copied().flatten() } else { None };
        params.push(match p.ty {
            Type::Volume if let Some(fns) = bricked => ParamSlot::Bricked(fns),
            Type::Image => {
                let tex_ty = b.texture_type(naga::ImageDimension::D2);
                ParamSlot::Image(arg(&mut func, name, tex_ty))
            }
            Type::Volume | Type::Tf => {
                let dim = if p.ty == Type::Volume { naga::ImageDimension::D3 } else { naga::ImageDimension::D2 };
                let (tex_ty, samp_ty) = (b.texture_type(dim), b.sampler_type());
                let texture = arg(&mut func, name.clone(), tex_ty);
                let sampler = arg(&mut func, format!("{name}_sampler"), samp_ty);
                ParamSlot::Resource { texture, sampler }
            }
            t => {
                let ty = b.ty(t, p.span)?;
                ParamSlot::Plain(arg(&mut func, name, ty))
            }
        });
    }
    if lf.ret != Type::Void {
        func.result = Some(naga::FunctionResult { ty: b.ty(lf.ret, lf.span)?, binding: None });
    }
    let mut cx = FnCtx::new(b, program, func, &lf.locals, &lf.calls, Kind::Lib { ret: lf.ret });
    cx.params = params;
    let body = cx.block(&lf.body)?;
    if lf.ret != Type::Void && !block_returns(&lf.body) {
        return Err(internal(
            lf.span,
            format!("library function `{}` can end without returning a value (the checker reports E0401)", lf.name),
        ));
    }
    cx.func.body = body;
    Ok(cx.func)
}

pub(super) fn lower_pipeline_fn(
    b: &mut ModuleBuilder,
    program: &hir::Program,
    pf: &hir::PipelineFn,
    name: &str,
    env: &PipelineEnv,
) -> R<naga::Function> {
    if env.state_members.len() != pf.state.len() || env.uniforms.len() != pf.uniforms.len() {
        return Err(internal(pf.span, format!("the environment of pipeline function `{}` does not fit it", pf.name)));
    }
    let ptr_ty = b.function_pointer_type(env.state_type);
    let mut func = naga::Function { name: Some(b.claim_function_name(name, pf.module)), ..Default::default() };
    func.arguments.push(naga::FunctionArgument { name: Some("state".into()), ty: ptr_ty, binding: None });
    let state_ptr = func.expressions.append(E::FunctionArgument(0), pf.span.into());
    let kind = Kind::Pipeline { env, state_ptr, state: &pf.state, uniforms: &pf.uniforms };
    let mut cx = FnCtx::new(b, program, func, &pf.locals, &pf.calls, kind);
    cx.func.body = cx.block(&pf.body)?;
    Ok(cx.func)
}

/// Whether control never reaches the end of the block (WGSL's behaviour analysis, restricted to
/// what VRS has: a `for` loop may run zero times).
fn block_returns(b: &hir::Block) -> bool {
    b.stmts.iter().any(|s| match &s.kind {
        StmtKind::Return(_) => true,
        StmtKind::If { then, otherwise: Some(otherwise), .. } => block_returns(then) && block_returns(otherwise),
        StmtKind::Block(b) => block_returns(b),
        _ => false,
    })
}

/// The statements up to the first `return`, `break` or `continue`: the rest never runs (W0004),
/// and naga's WGSL front end rejects a function whose code goes on after its `return`.
fn reachable(stmts: &[hir::Stmt]) -> &[hir::Stmt] {
    let jump = stmts.iter().position(|s| matches!(s.kind, StmtKind::Return(_) | StmtKind::Break | StmtKind::Continue));
    jump.map_or(stmts, |i| &stmts[..=i])
}

enum Kind<'a> {
    Lib { ret: Type },
    Pipeline { env: &'a PipelineEnv, state_ptr: Ex, state: &'a [hir::StateDecl], uniforms: &'a [hir::UniformDecl] },
}

#[derive(Clone, Copy)]
enum LocalSlot {
    /// A `let`: the value.
    Value(Ex),
    /// A `var` or loop variable: the pointer to its local variable.
    Var(Ex),
}

#[derive(Clone, Copy)]
enum ParamSlot {
    Plain(Ex),
    Resource {
        texture: Ex,
        sampler: Ex,
    },
    /// A bricked volume: no parameter, its lookup is called directly.
    Bricked(BrickedFns),
    /// An `image`: its texture (read with `textureLoad`, no sampler).
    Image(Ex),
}

/// A `volume` or `tf` argument as lowering reaches it.
#[derive(Clone, Copy)]
enum Resource {
    Texture { texture: Ex, sampler: Ex },
    Bricked(BrickedFns),
    Image(Ex),
}

struct FnCtx<'a> {
    b: &'a mut ModuleBuilder,
    program: &'a hir::Program,
    func: naga::Function,
    kind: Kind<'a>,
    locals: &'a [hir::Local],
    /// The callee of each call site of the body.
    calls: &'a [hir::LibFnId],
    slots: Vec<Option<LocalSlot>>,
    params: Vec<ParamSlot>,
    globals: FxHashMap<Handle<naga::GlobalVariable>, Ex>,
    emitter: Emitter,
    loop_depth: u32,
}

impl<'a> FnCtx<'a> {
    fn new(
        b: &'a mut ModuleBuilder,
        program: &'a hir::Program,
        func: naga::Function,
        locals: &'a [hir::Local],
        calls: &'a [hir::LibFnId],
        kind: Kind<'a>,
    ) -> Self {
        FnCtx {
            b,
            program,
            func,
            kind,
            locals,
            calls,
            slots: vec![None; locals.len()],
            params: Vec::new(),
            globals: FxHashMap::default(),
            emitter: Emitter::default(),
            loop_depth: 0,
        }
    }

    // ---- The emit discipline (see `emitter.rs`) ------------------------------------------

    fn append(&mut self, expr: naga::Expression, span: Span) -> Ex {
        self.emitter.append(&mut self.func.expressions, expr, span.into())
    }

    /// Pushes `Emit`s for every expression appended since the last flush.
    fn flush(&mut self, block: &mut naga::Block) {
        self.emitter.flush(&self.func.expressions, block);
    }

    fn push(&mut self, block: &mut naga::Block, stmt: naga::Statement, span: Span) {
        self.emitter.push(&self.func.expressions, block, stmt, span.into());
    }

    /// Names an expression for the WGSL writer (which then binds it with `let`), unless it is
    /// written inline anyway or already has a name.
    fn name(&mut self, h: Ex, name: &str) {
        let expr = &self.func.expressions[h];
        if !is_pre_emitted(expr) && !self.func.named_expressions.contains_key(&h) {
            self.func.named_expressions.insert(h, emitted_name(name));
        }
    }

    fn global(&mut self, gv: Handle<naga::GlobalVariable>, span: Span) -> Ex {
        if let Some(&h) = self.globals.get(&gv) {
            return h;
        }
        let h = self.append(E::GlobalVariable(gv), span);
        self.globals.insert(gv, h);
        h
    }

    fn local(&self, id: hir::LocalId, span: Span) -> R<&'a hir::Local> {
        self.locals.get(id).ok_or_else(|| internal(span, format!("local #{id} does not exist")))
    }

    // ---- Statements ----------------------------------------------------------------------

    fn block(&mut self, b: &hir::Block) -> R<naga::Block> {
        let mut out = naga::Block::new();
        for s in reachable(&b.stmts) {
            self.stmt(s, &mut out)?;
        }
        self.flush(&mut out);
        Ok(out)
    }

    fn stmt(&mut self, s: &hir::Stmt, block: &mut naga::Block) -> R<()> {
        let span = s.span;
        match &s.kind {
            StmtKind::Let { local, value } => {
                let l = self.local(*local, span)?;
                let slot = if l.mutable {
                    let v = match value {
                        Some(v) => Some(self.expr(v, block)?),
                        None => None,
                    };
                    LocalSlot::Var(self.declare_var(l, v, block, span)?)
                } else {
                    let Some(v) = value else {
                        return Err(internal(span, format!("`let {}` without a value", l.name)));
                    };
                    let h = self.expr(v, block)?;
                    self.name(h, &l.name);
                    LocalSlot::Value(h)
                };
                self.slots[*local] = Some(slot);
            }
            StmtKind::Assign { place, op, value } => self.assign(place, *op, value, span, block)?,
            StmtKind::If { cond, then, otherwise } => {
                let condition = self.expr(cond, block)?;
                self.flush(block);
                let accept = self.block(then)?;
                let reject = match otherwise {
                    Some(b) => self.block(b)?,
                    None => naga::Block::new(),
                };
                self.push(block, S::If { condition, accept, reject }, span);
            }
            StmtKind::For { var, start, end, body } => self.for_loop(*var, start, end, body, span, block)?,
            StmtKind::Break | StmtKind::Continue => {
                if self.loop_depth == 0 {
                    return Err(internal(span, "`break` or `continue` outside a loop"));
                }
                let stmt = if matches!(s.kind, StmtKind::Break) { S::Break } else { S::Continue };
                self.push(block, stmt, span);
            }
            StmtKind::Return(value) => {
                let value = match (value, &self.kind) {
                    (Some(v), Kind::Lib { ret }) if *ret != Type::Void => Some(self.expr(v, block)?),
                    (None, Kind::Pipeline { .. }) | (None, Kind::Lib { ret: Type::Void }) => None,
                    _ => return Err(internal(span, "a `return` that does not fit the function's return type")),
                };
                self.push(block, S::Return { value }, span);
            }
            StmtKind::Expr(e) => {
                match &e.kind {
                    ExprKind::CallLib { site, args } => {
                        self.call_lib(*site, args, e.span, block)?;
                    }
                    // Anything else is pure: lower it for its checks; the writer drops it.
                    _ => {
                        self.expr(e, block)?;
                    }
                }
            }
            StmtKind::Block(b) => {
                self.flush(block);
                let inner = self.block(b)?;
                self.push(block, S::Block(inner), span);
            }
        }
        Ok(())
    }

    /// Declares the local variable of a `var` or loop variable, initialised with `value` (or its
    /// zero value). A literal initialiser outside loops becomes the variable's `init`; anything
    /// else is stored where the declaration stands, so a `var` in a loop body starts afresh.
    fn declare_var(&mut self, l: &hir::Local, value: Option<Ex>, block: &mut naga::Block, span: Span) -> R<Ex> {
        let ty = self.b.ty(l.ty, l.span)?;
        let constant = |h: Ex| matches!(self.func.expressions[h], E::Literal(_) | E::ZeroValue(_));
        let init = value.filter(|&h| self.loop_depth == 0 && constant(h));
        let var = naga::LocalVariable { name: Some(emitted_name(&l.name)), ty, init };
        let lv = self.func.local_variables.append(var, l.span.into());
        let ptr = self.append(E::LocalVariable(lv), l.span);
        match (value, init) {
            (Some(v), None) => self.push(block, S::Store { pointer: ptr, value: v }, span),
            (None, _) if self.loop_depth > 0 => {
                let zero = self.append(E::ZeroValue(ty), span);
                self.push(block, S::Store { pointer: ptr, value: zero }, span);
            }
            _ => {}
        }
        Ok(ptr)
    }

    fn for_loop(
        &mut self,
        var: hir::LocalId,
        start: &hir::Expr,
        end: &hir::Expr,
        body: &hir::Block,
        span: Span,
        block: &mut naga::Block,
    ) -> R<()> {
        let l = self.local(var, span)?;
        let one = match l.ty {
            Type::Scalar(Scalar::I32) => naga::Literal::I32(1),
            Type::Scalar(Scalar::U32) => naga::Literal::U32(1),
            t => return Err(internal(span, format!("a `for` variable of type `{t}`"))),
        };
        let start = self.expr(start, block)?;
        let end = self.expr(end, block)?;
        self.name(end, &format!("{}_end", l.name));
        let ptr = self.declare_var(l, Some(start), block, span)?;
        self.slots[var] = Some(LocalSlot::Var(ptr));
        self.flush(block);

        let mut body_block = naga::Block::new();
        let i = self.append(E::Load { pointer: ptr }, l.span);
        let done = self.append(E::Binary { op: naga::BinaryOperator::GreaterEqual, left: i, right: end }, span);
        let mut brk = naga::Block::new();
        brk.push(S::Break, span.into());
        self.push(&mut body_block, S::If { condition: done, accept: brk, reject: naga::Block::new() }, span);
        self.loop_depth += 1;
        let result = reachable(&body.stmts).iter().try_for_each(|s| self.stmt(s, &mut body_block));
        self.loop_depth -= 1;
        result?;
        self.flush(&mut body_block);

        let mut continuing = naga::Block::new();
        let i = self.append(E::Load { pointer: ptr }, l.span);
        let one = self.append(E::Literal(one), span);
        let next = self.append(E::Binary { op: naga::BinaryOperator::Add, left: i, right: one }, span);
        self.push(&mut continuing, S::Store { pointer: ptr, value: next }, span);
        self.push(block, S::Loop { body: body_block, continuing, break_if: None }, span);
        Ok(())
    }

    fn assign(
        &mut self,
        place: &hir::Place,
        op: AssignOp,
        value: &hir::Expr,
        span: Span,
        block: &mut naga::Block,
    ) -> R<()> {
        let (mut ptr, mut ty) = match place.root {
            PlaceRoot::Local(id) => {
                let l = self.local(id, place.span)?;
                match self.slots[id] {
                    Some(LocalSlot::Var(p)) => (p, l.ty),
                    _ => return Err(internal(place.span, format!("assignment to `{}`, which is not a `var`", l.name))),
                }
            }
            PlaceRoot::State(i) => {
                let Kind::Pipeline { env, state_ptr, state, .. } = self.kind else {
                    return Err(internal(place.span, "`state` in a library function"));
                };
                let decl =
                    state.get(i).ok_or_else(|| internal(place.span, format!("state field #{i} does not exist")))?;
                match env.state_members[i] {
                    Some(m) => (self.append(E::AccessIndex { base: state_ptr, index: m }, place.span), decl.ty),
                    // The field is left out of the struct: the write is dropped (values are pure).
                    None => return Ok(()),
                }
            }
        };
        let mut swizzle = None;
        for (k, access) in place.path.iter().enumerate() {
            match access {
                Access::Component(c) => {
                    ptr = self.append(E::AccessIndex { base: ptr, index: u32::from(*c) }, place.span);
                    ty = element_type(ty).ok_or_else(|| internal(place.span, format!("a component of `{ty}`")))?;
                }
                Access::Index(index) => {
                    ptr = self.index(ptr, index, place.span, block)?;
                    ty = element_type(ty).ok_or_else(|| internal(place.span, format!("an index into `{ty}`")))?;
                }
                Access::Swizzle(components) if k + 1 == place.path.len() => swizzle = Some(components),
                Access::Swizzle(_) => return Err(internal(place.span, "a swizzle in the middle of a place")),
            }
        }
        let v = self.expr(value, block)?;
        let new = match swizzle {
            None if op == AssignOp::Assign => v,
            None => {
                let old = self.append(E::Load { pointer: ptr }, place.span);
                self.binary(binary_op(op), (old, ty), (v, value.ty), span)
            }
            Some(components) => {
                let Type::Vector { size, scalar } = ty else {
                    return Err(internal(place.span, format!("a swizzle of `{ty}`")));
                };
                let old = self.append(E::Load { pointer: ptr }, place.span);
                let part = match op {
                    AssignOp::Assign => v,
                    _ => {
                        let old_part = self.swizzle(old, components, place.span)?;
                        let part_ty = if components.len() == 1 {
                            Type::Scalar(scalar)
                        } else {
                            Type::vec(components.len() as u8, scalar)
                        };
                        self.binary(binary_op(op), (old_part, part_ty), (v, value.ty), span)
                    }
                };
                let mut parts = Vec::with_capacity(size as usize);
                for j in 0..size {
                    parts.push(match components.iter().position(|&c| c == j) {
                        Some(_) if components.len() == 1 => part,
                        Some(pos) => self.append(E::AccessIndex { base: part, index: pos as u32 }, span),
                        None => self.append(E::AccessIndex { base: old, index: u32::from(j) }, place.span),
                    });
                }
                let vty = self.b.ty(ty, place.span)?;
                self.append(E::Compose { ty: vty, components: parts }, span)
            }
        };
        self.push(block, S::Store { pointer: ptr, value: new }, span);
        Ok(())
    }

    // ---- Expressions ---------------------------------------------------------------------

    /// The value of an expression.
    fn expr(&mut self, e: &hir::Expr, block: &mut naga::Block) -> R<Ex> {
        let span = e.span;
        if let Some(ptr) = self.reference(e, block)? {
            return Ok(self.append(E::Load { pointer: ptr }, span));
        }
        Ok(match &e.kind {
            ExprKind::Const(c) => self.constant(c, span)?,
            ExprKind::Local(id) => match self.slots.get(*id).copied().flatten() {
                Some(LocalSlot::Value(h)) => h,
                Some(LocalSlot::Var(p)) => self.append(E::Load { pointer: p }, span),
                None => return Err(internal(span, format!("local #{id} used before its declaration"))),
            },
            ExprKind::Param(i) => match self.params.get(*i) {
                Some(ParamSlot::Plain(h)) => *h,
                Some(ParamSlot::Resource { .. } | ParamSlot::Bricked(_) | ParamSlot::Image(_)) => {
                    return Err(internal(span, "a `volume`, `tf` or `image` parameter used as a value"));
                }
                None => return Err(internal(span, format!("parameter #{i} does not exist"))),
            },
            ExprKind::Uniform(i) => {
                let (access, decl) = self.uniform(*i, span)?;
                let UniformAccess::Member { block: gv, index } = access else {
                    return Err(internal(span, format!("the resource uniform `{}` used as a value", decl.name)));
                };
                let base = self.global(gv, span);
                let ptr = self.append(E::AccessIndex { base, index }, span);
                let v = self.append(E::Load { pointer: ptr }, span);
                // Only bool uniforms get here (see `reference`): stored as u32.
                self.convert(v, Scalar::Bool, span)
            }
            ExprKind::State(_) => return Err(internal(span, "`state` read outside a pipeline function")),
            ExprKind::CallLib { site, args } => match self.call_lib(*site, args, span, block)? {
                Some(h) => h,
                None => return Err(internal(span, "the result of a call that returns nothing used as a value")),
            },
            ExprKind::CallBuiltin { builtin, args } => self.builtin(*builtin, args, span, block)?,
            ExprKind::Construct { args } => self.construct(e.ty, args, span, block)?,
            ExprKind::Convert { arg } => {
                let v = self.expr(arg, block)?;
                match e.ty.scalar() {
                    _ if arg.ty == e.ty => v,
                    Some(s) => self.convert(v, s, span),
                    None => return Err(internal(span, format!("a conversion to `{}`", e.ty))),
                }
            }
            ExprKind::Unary { op, operand } => {
                let v = self.expr(operand, block)?;
                let op = match op {
                    UnaryOp::Neg => naga::UnaryOperator::Negate,
                    UnaryOp::Not if operand.ty.scalar() == Some(Scalar::Bool) => naga::UnaryOperator::LogicalNot,
                    UnaryOp::Not => naga::UnaryOperator::BitwiseNot,
                };
                self.append(E::Unary { op, expr: v }, span)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let l = self.expr(lhs, block)?;
                let r = self.expr(rhs, block)?;
                self.binary(*op, (l, lhs.ty), (r, rhs.ty), span)
            }
            ExprKind::Swizzle { base, components } => {
                let v = self.expr(base, block)?;
                self.swizzle(v, components, span)?
            }
            ExprKind::Index { base, index } => {
                let v = self.expr(base, block)?;
                match (const_index(index), base.ty) {
                    (Some(k), _) => self.append(E::AccessIndex { base: v, index: k }, span),
                    // naga indexes a matrix dynamically only behind a pointer: spill it.
                    (None, Type::Matrix { .. }) => {
                        let ty = self.b.ty(base.ty, span)?;
                        let var = naga::LocalVariable { name: None, ty, init: None };
                        let lv = self.func.local_variables.append(var, span.into());
                        let ptr = self.append(E::LocalVariable(lv), span);
                        self.push(block, S::Store { pointer: ptr, value: v }, span);
                        let i = self.expr(index, block)?;
                        let column = self.append(E::Access { base: ptr, index: i }, span);
                        self.append(E::Load { pointer: column }, span)
                    }
                    (None, _) => {
                        let i = self.expr(index, block)?;
                        self.append(E::Access { base: v, index: i }, span)
                    }
                }
            }
        })
    }

    /// A pointer to what the expression reads, when it reads memory: a `var`, a state field, a
    /// uniform block member, or a component / index of one. `None` (having appended nothing)
    /// for anything else.
    fn reference(&mut self, e: &hir::Expr, block: &mut naga::Block) -> R<Option<Ex>> {
        let span = e.span;
        Ok(match &e.kind {
            ExprKind::Local(id) => match self.slots.get(*id).copied().flatten() {
                Some(LocalSlot::Var(p)) => Some(p),
                _ => None,
            },
            ExprKind::State(i) => {
                let Kind::Pipeline { env, state_ptr, state, .. } = self.kind else {
                    return Err(internal(span, "`state` in a library function"));
                };
                let decl = state.get(*i).ok_or_else(|| internal(span, format!("state field #{i} does not exist")))?;
                let Some(m) = env.state_members[*i] else {
                    return Err(internal(span, format!("state field `{}` is read but was left out", decl.name)));
                };
                Some(self.append(E::AccessIndex { base: state_ptr, index: m }, span))
            }
            ExprKind::Uniform(i) => match self.uniform(*i, span)? {
                (UniformAccess::Member { block: gv, index }, decl) if decl.ty.scalar() != Some(Scalar::Bool) => {
                    let base = self.global(gv, span);
                    Some(self.append(E::AccessIndex { base, index }, span))
                }
                _ => None,
            },
            ExprKind::Index { base, index } => match self.reference(base, block)? {
                Some(p) => Some(self.index(p, index, span, block)?),
                None => None,
            },
            ExprKind::Swizzle { base, components } if components.len() == 1 => self
                .reference(base, block)?
                .map(|p| self.append(E::AccessIndex { base: p, index: u32::from(components[0]) }, span)),
            _ => None,
        })
    }

    /// `base[index]` on a pointer.
    fn index(&mut self, base: Ex, index: &hir::Expr, span: Span, block: &mut naga::Block) -> R<Ex> {
        Ok(match const_index(index) {
            Some(k) => self.append(E::AccessIndex { base, index: k }, span),
            None => {
                let i = self.expr(index, block)?;
                self.append(E::Access { base, index: i }, span)
            }
        })
    }

    fn uniform(&self, i: usize, span: Span) -> R<(UniformAccess, &'a hir::UniformDecl)> {
        let Kind::Pipeline { env, uniforms, .. } = self.kind else {
            return Err(internal(span, "a uniform in a library function"));
        };
        match (env.uniforms.get(i), uniforms.get(i)) {
            (Some(access), Some(decl)) => Ok((*access, decl)),
            _ => Err(internal(span, format!("uniform #{i} does not exist"))),
        }
    }

    fn constant(&mut self, c: &hir::ConstValue, span: Span) -> R<Ex> {
        if c.components.len() != c.ty.components() || c.components.is_empty() {
            return Err(internal(
                span,
                format!("a constant of type `{}` with {} components", c.ty, c.components.len()),
            ));
        }
        let literal = |v: ScalarValue| {
            E::Literal(match v {
                ScalarValue::Bool(b) => naga::Literal::Bool(b),
                ScalarValue::I32(i) => naga::Literal::I32(i),
                ScalarValue::U32(u) => naga::Literal::U32(u),
                ScalarValue::F32(f) => naga::Literal::F32(f),
            })
        };
        Ok(match c.ty {
            Type::Scalar(_) => self.append(literal(c.components[0]), span),
            Type::Vector { size, .. } if c.components.iter().all(|&v| v == c.components[0]) => {
                let value = self.append(literal(c.components[0]), span);
                let size = vector_size(size).ok_or_else(|| internal(span, "a vector of odd size"))?;
                self.append(E::Splat { size, value }, span)
            }
            Type::Vector { .. } => {
                let ty = self.b.ty(c.ty, span)?;
                let components = c.components.iter().map(|&v| self.append(literal(v), span)).collect();
                self.append(E::Compose { ty, components }, span)
            }
            Type::Matrix { rows, .. } => {
                let ty = self.b.ty(c.ty, span)?;
                let column_ty = self.b.ty(Type::vec(rows, Scalar::F32), span)?;
                let mut columns = Vec::new();
                for column in c.components.chunks(rows as usize) {
                    let components = column.iter().map(|&v| self.append(literal(v), span)).collect();
                    columns.push(self.append(E::Compose { ty: column_ty, components }, span));
                }
                self.append(E::Compose { ty, components: columns }, span)
            }
            t => return Err(internal(span, format!("a constant of type `{t}`"))),
        })
    }

    fn convert(&mut self, v: Ex, to: Scalar, span: Span) -> Ex {
        let s = naga_scalar(to);
        self.append(E::As { expr: v, kind: s.kind, convert: Some(s.width) }, span)
    }

    fn splat(&mut self, v: Ex, size: u8, span: Span) -> R<Ex> {
        let size = vector_size(size).ok_or_else(|| internal(span, "a vector of odd size"))?;
        Ok(self.append(E::Splat { size, value: v }, span))
    }

    /// A binary operation with WGSL's vector-scalar mixing (naga mixes only in `*`).
    fn binary(&mut self, op: BinaryOp, (mut l, lt): (Ex, Type), (mut r, rt): (Ex, Type), span: Span) -> Ex {
        use naga::BinaryOperator as Bo;
        if op != BinaryOp::Mul {
            match (lt, rt) {
                (Type::Vector { size, .. }, Type::Scalar(_)) => r = self.splat(r, size, span).unwrap_or(r),
                (Type::Scalar(_), Type::Vector { size, .. }) => l = self.splat(l, size, span).unwrap_or(l),
                _ => {}
            }
        }
        let op = match op {
            BinaryOp::Mul => Bo::Multiply,
            BinaryOp::Div => Bo::Divide,
            BinaryOp::Rem => Bo::Modulo,
            BinaryOp::Add => Bo::Add,
            BinaryOp::Sub => Bo::Subtract,
            BinaryOp::Shl => Bo::ShiftLeft,
            BinaryOp::Shr => Bo::ShiftRight,
            BinaryOp::Lt => Bo::Less,
            BinaryOp::Le => Bo::LessEqual,
            BinaryOp::Gt => Bo::Greater,
            BinaryOp::Ge => Bo::GreaterEqual,
            BinaryOp::Eq => Bo::Equal,
            BinaryOp::Ne => Bo::NotEqual,
            BinaryOp::BitAnd => Bo::And,
            BinaryOp::BitXor => Bo::ExclusiveOr,
            BinaryOp::BitOr => Bo::InclusiveOr,
            BinaryOp::And => Bo::LogicalAnd,
            BinaryOp::Or => Bo::LogicalOr,
        };
        self.append(E::Binary { op, left: l, right: r }, span)
    }

    fn swizzle(&mut self, v: Ex, components: &[u8], span: Span) -> R<Ex> {
        let pattern_of = |c: u8| match c {
            0 => Ok(naga::SwizzleComponent::X),
            1 => Ok(naga::SwizzleComponent::Y),
            2 => Ok(naga::SwizzleComponent::Z),
            3 => Ok(naga::SwizzleComponent::W),
            _ => Err(internal(span, format!("swizzle component {c}"))),
        };
        if let [c] = components {
            pattern_of(*c)?;
            return Ok(self.append(E::AccessIndex { base: v, index: u32::from(*c) }, span));
        }
        let size = u8::try_from(components.len())
            .ok()
            .and_then(vector_size)
            .ok_or_else(|| internal(span, "a swizzle of odd size"))?;
        let mut pattern = [naga::SwizzleComponent::X; 4];
        for (slot, &c) in pattern.iter_mut().zip(components) {
            *slot = pattern_of(c)?;
        }
        Ok(self.append(E::Swizzle { size, vector: v, pattern }, span))
    }

    fn construct(&mut self, ty: Type, args: &[hir::Expr], span: Span, block: &mut naga::Block) -> R<Ex> {
        let nty = self.b.ty(ty, span)?;
        if args.is_empty() {
            return Ok(self.append(E::ZeroValue(nty), span));
        }
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            values.push(self.expr(a, block)?);
        }
        Ok(match (ty, args) {
            (_, [a]) if a.ty == ty => values[0],
            (Type::Scalar(s), [_]) => self.convert(values[0], s, span),
            (Type::Vector { size, scalar }, [a]) if matches!(a.ty, Type::Scalar(_)) => {
                let v = if a.ty == Type::Scalar(scalar) { values[0] } else { self.convert(values[0], scalar, span) };
                self.splat(v, size, span)?
            }
            (Type::Vector { size, scalar }, [a]) if matches!(a.ty, Type::Vector { size: n, .. } if n == size) => {
                self.convert(values[0], scalar, span)
            }
            (Type::Matrix { cols, rows }, _)
                if args.len() == cols as usize * rows as usize
                    && args.iter().all(|a| matches!(a.ty, Type::Scalar(_))) =>
            {
                let column_ty = self.b.ty(Type::vec(rows, Scalar::F32), span)?;
                let columns = values
                    .chunks(rows as usize)
                    .map(|c| self.append(E::Compose { ty: column_ty, components: c.to_vec() }, span))
                    .collect();
                self.append(E::Compose { ty: nty, components: columns }, span)
            }
            _ => self.append(E::Compose { ty: nty, components: values }, span),
        })
    }

    fn call_lib(&mut self, site: usize, args: &[hir::Expr], span: Span, block: &mut naga::Block) -> R<Option<Ex>> {
        let Some(&id) = self.calls.get(site) else {
            return Err(internal(span, format!("call site #{site} is not in the function's table")));
        };
        let Some(callee) = self.program.lib_fns.get(id) else {
            return Err(internal(span, format!("library function #{id} does not exist")));
        };
        if callee.params.len() != args.len() {
            return Err(internal(span, format!("a call of `{}` with {} arguments", callee.name, args.len())));
        }
        // The callee first (its variant from the bricked volumes passed), then the arguments:
        // functions are emitted callees first, in the order calls reach them.
        let mut variant = ResourceVariant::new();
        for (p, a) in callee.params.iter().zip(args) {
            if p.ty.is_resource() {
                variant.push(self.bricked(a)?);
            }
        }
        let function = self.b.lower_lib_fn(self.program, id, &variant)?;
        let mut arguments = Vec::with_capacity(args.len());
        for (p, a) in callee.params.iter().zip(args) {
            if !p.ty.is_resource() {
                arguments.push(self.expr(a, block)?);
            } else {
                match self.resource(a)? {
                    Resource::Texture { texture, sampler } => arguments.extend([texture, sampler]),
                    Resource::Image(texture) => arguments.push(texture),
                    Resource::Bricked(_) => {}
                }
            }
        }
        let result = (callee.ret != Type::Void).then(|| self.append(E::CallResult(function), span));
        self.push(block, S::Call { function, arguments, result }, span);
        Ok(result)
    }

    /// A `volume` or `tf` argument: a parameter or a uniform.
    fn resource(&mut self, e: &hir::Expr) -> R<Resource> {
        match e.kind {
            ExprKind::Param(i) => match self.params.get(i) {
                Some(ParamSlot::Resource { texture, sampler }) => {
                    return Ok(Resource::Texture { texture: *texture, sampler: *sampler });
                }
                Some(ParamSlot::Bricked(fns)) => return Ok(Resource::Bricked(*fns)),
                Some(ParamSlot::Image(texture)) => return Ok(Resource::Image(*texture)),
                _ => {}
            },
            ExprKind::Uniform(i) => match self.uniform(i, e.span)?.0 {
                UniformAccess::Volume { texture, sampler } | UniformAccess::Tf { texture, sampler } => {
                    let texture = self.global(texture, e.span);
                    let sampler = self.global(sampler, e.span);
                    return Ok(Resource::Texture { texture, sampler });
                }
                UniformAccess::Bricked(fns) => return Ok(Resource::Bricked(fns)),
                UniformAccess::Image { texture } => return Ok(Resource::Image(self.global(texture, e.span))),
                UniformAccess::Member { .. } => {}
            },
            _ => {}
        }
        Err(internal(e.span, "expected a `volume`, `tf` or `image` parameter or uniform"))
    }

    /// The bricked volume a `volume` argument is, if it is one (nothing is appended).
    fn bricked(&self, e: &hir::Expr) -> R<Option<BrickedFns>> {
        Ok(match e.kind {
            ExprKind::Param(i) => match self.params.get(i) {
                Some(ParamSlot::Bricked(fns)) => Some(*fns),
                _ => None,
            },
            ExprKind::Uniform(i) => match self.uniform(i, e.span)?.0 {
                UniformAccess::Bricked(fns) => Some(fns),
                _ => None,
            },
            _ => None,
        })
    }

    /// The texture and sampler of a `tf` (never bricked).
    fn texture(&mut self, e: &hir::Expr) -> R<(Ex, Ex)> {
        match self.resource(e)? {
            Resource::Texture { texture, sampler } => Ok((texture, sampler)),
            Resource::Bricked(_) => Err(internal(e.span, "a bricked volume where a texture was expected")),
            Resource::Image(_) => Err(internal(e.span, "an image where a texture and sampler were expected")),
        }
    }

    /// `f(args)` for a function of the module that returns a value.
    fn call_value(
        &mut self,
        function: Handle<naga::Function>,
        arguments: Vec<Ex>,
        span: Span,
        block: &mut naga::Block,
    ) -> Ex {
        let result = self.append(E::CallResult(function), span);
        self.push(block, S::Call { function, arguments, result: Some(result) }, span);
        result
    }

    /// A built-in call: WGSL's math function of the same name, or one of the built-ins that
    /// lower to other expressions (`select`, `any`/`all`, and the resource built-ins).
    fn builtin(&mut self, builtin: Builtin, args: &[hir::Expr], span: Span, block: &mut naga::Block) -> R<Ex> {
        use Builtin as B;
        if args.len() != builtin.arity() {
            return Err(internal(span, format!("`{builtin:?}` with {} arguments", args.len())));
        }
        if let Some(fun) = math_function(builtin) {
            return self.math(fun, args, span, block);
        }
        Ok(match builtin {
            // WGSL: select(f, t, cond).
            B::Select => {
                let reject = self.expr(&args[0], block)?;
                let accept = self.expr(&args[1], block)?;
                let condition = self.expr(&args[2], block)?;
                self.append(E::Select { condition, accept, reject }, span)
            }
            B::Any | B::All => {
                let argument = self.expr(&args[0], block)?;
                if matches!(args[0].ty, Type::Scalar(_)) {
                    // `any(b)` and `all(b)` of a scalar are `b`.
                    argument
                } else {
                    let fun =
                        if builtin == B::Any { naga::RelationalFunction::Any } else { naga::RelationalFunction::All };
                    self.append(E::Relational { fun, argument }, span)
                }
            }
            B::Sample => self.sample_volume(&args[0], &args[1], span, block)?,
            B::Lookup => self.lookup(&args[0], &args[1], span, block)?,
            B::Dims => match self.resource(&args[0])? {
                Resource::Texture { texture: image, .. } | Resource::Image(image) => {
                    self.append(E::ImageQuery { image, query: naga::ImageQuery::Size { level: None } }, span)
                }
                Resource::Bricked(fns) => self.call_value(fns.dims, Vec::new(), span, block),
            },
            B::Load => self.load_texel(&args[0], &args[1], span, block)?,
            _ => return Err(internal(span, format!("built-in `{builtin:?}` is not lowered"))),
        })
    }

    /// A call of WGSL math function `fun` with the built-in's arguments.
    fn math(&mut self, fun: Mf, args: &[hir::Expr], span: Span, block: &mut naga::Block) -> R<Ex> {
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            values.push(self.expr(a, block)?);
        }
        // WGSL's overloads of these take one type T for all (the first two, for `mix`)
        // arguments; accept a scalar among vectors by splatting it.
        let same_type = match fun {
            Mf::Min | Mf::Max | Mf::Clamp | Mf::Step | Mf::SmoothStep | Mf::Pow | Mf::Atan2 => args.len(),
            Mf::Mix => 2,
            _ => 0,
        };
        let widest = args[..same_type]
            .iter()
            .filter_map(|a| match a.ty {
                Type::Vector { size, .. } => Some(size),
                _ => None,
            })
            .max();
        if let Some(size) = widest {
            for (v, a) in values.iter_mut().zip(args).take(same_type) {
                if matches!(a.ty, Type::Scalar(_)) {
                    *v = self.splat(*v, size, span)?;
                }
            }
        }
        Ok(self.append(
            E::Math { fun, arg: values[0], arg1: values.get(1).copied(), arg2: values.get(2).copied(), arg3: None },
            span,
        ))
    }

    /// `sample(v, p)`: the first component of the texel, or the bricked volume's lookup.
    fn sample_volume(&mut self, volume: &hir::Expr, p: &hir::Expr, span: Span, block: &mut naga::Block) -> R<Ex> {
        let volume = self.resource(volume)?;
        let coordinate = self.expr(p, block)?;
        Ok(match volume {
            Resource::Texture { texture, sampler } => {
                let texel = self.sample(texture, sampler, coordinate, span);
                self.append(E::AccessIndex { base: texel, index: 0 }, span)
            }
            Resource::Bricked(fns) => self.call_value(fns.sample, vec![coordinate], span, block),
            Resource::Image(_) => return Err(internal(span, "`sample` of an image")),
        })
    }

    /// `lookup(t, x)`: the transfer function's texel at `x` (a scalar `x` is read at
    /// `vec2(x, 0.5)`).
    fn lookup(&mut self, tf: &hir::Expr, x: &hir::Expr, span: Span, block: &mut naga::Block) -> R<Ex> {
        let (image, sampler) = self.texture(tf)?;
        let value = self.expr(x, block)?;
        let two_d = Type::vec(2, Scalar::F32);
        let coordinate = if x.ty == two_d {
            value
        } else {
            let half = self.append(E::Literal(naga::Literal::F32(0.5)), span);
            let ty = self.b.ty(two_d, span)?;
            self.append(E::Compose { ty, components: vec![value, half] }, span)
        };
        Ok(self.sample(image, sampler, coordinate, span))
    }

    /// `load(i, p)`: `textureLoad(i, clamp(p, 0, dims(i) - 1), 0)`. The clamp makes a
    /// neighbourhood read at the image's edge repeat the edge (WGSL leaves an out-of-range
    /// load undefined).
    fn load_texel(&mut self, image: &hir::Expr, p: &hir::Expr, span: Span, block: &mut naga::Block) -> R<Ex> {
        let Resource::Image(image) = self.resource(image)? else {
            return Err(internal(span, "`load` of a resource that is not an image"));
        };
        let pixel = self.expr(p, block)?;
        let size = self.append(E::ImageQuery { image, query: naga::ImageQuery::Size { level: None } }, span);
        let size = self.append(E::As { expr: size, kind: naga::ScalarKind::Sint, convert: Some(4) }, span);
        let one = self.append(E::Literal(naga::Literal::I32(1)), span);
        let one = self.splat(one, 2, span)?;
        let last = self.append(E::Binary { op: naga::BinaryOperator::Subtract, left: size, right: one }, span);
        let zero = self.append(E::Literal(naga::Literal::I32(0)), span);
        let zero = self.splat(zero, 2, span)?;
        let coordinate =
            self.append(E::Math { fun: Mf::Clamp, arg: pixel, arg1: Some(zero), arg2: Some(last), arg3: None }, span);
        let level = self.append(E::Literal(naga::Literal::I32(0)), span);
        Ok(self.append(E::ImageLoad { image, coordinate, array_index: None, sample: None, level: Some(level) }, span))
    }

    /// `textureSampleLevel(image, sampler, coordinate, 0.0)`.
    fn sample(&mut self, image: Ex, sampler: Ex, coordinate: Ex, span: Span) -> Ex {
        self.append(
            E::ImageSample {
                image,
                sampler,
                gather: None,
                coordinate,
                array_index: None,
                offset: None,
                level: naga::SampleLevel::Zero,
                depth_ref: None,
                clamp_to_edge: false,
            },
            span,
        )
    }
}

/// The WGSL math function a built-in is, if it is one: one arm per built-in, a table that reads
/// best whole.
fn math_function(builtin: Builtin) -> Option<Mf> {
    use Builtin as B;
    Some(match builtin {
        B::Abs => Mf::Abs,
        B::Min => Mf::Min,
        B::Max => Mf::Max,
        B::Clamp => Mf::Clamp,
        B::Mix => Mf::Mix,
        B::Step => Mf::Step,
        B::Smoothstep => Mf::SmoothStep,
        B::Sign => Mf::Sign,
        B::Floor => Mf::Floor,
        B::Ceil => Mf::Ceil,
        B::Fract => Mf::Fract,
        B::Round => Mf::Round,
        B::Trunc => Mf::Trunc,
        B::Sqrt => Mf::Sqrt,
        B::InverseSqrt => Mf::InverseSqrt,
        B::Pow => Mf::Pow,
        B::Exp => Mf::Exp,
        B::Exp2 => Mf::Exp2,
        B::Log => Mf::Log,
        B::Log2 => Mf::Log2,
        B::Sin => Mf::Sin,
        B::Cos => Mf::Cos,
        B::Tan => Mf::Tan,
        B::Asin => Mf::Asin,
        B::Acos => Mf::Acos,
        B::Atan => Mf::Atan,
        B::Atan2 => Mf::Atan2,
        B::Dot => Mf::Dot,
        B::Cross => Mf::Cross,
        B::Length => Mf::Length,
        B::Distance => Mf::Distance,
        B::Normalize => Mf::Normalize,
        B::Reflect => Mf::Reflect,
        B::FaceForward => Mf::FaceForward,
        B::Transpose => Mf::Transpose,
        B::Determinant => Mf::Determinant,
        B::Select | B::Any | B::All | B::Sample | B::Lookup | B::Dims | B::Load => return None,
    })
}

/// The element a component access or index of `t` yields.
fn element_type(t: Type) -> Option<Type> {
    match t {
        Type::Vector { scalar, .. } => Some(Type::Scalar(scalar)),
        Type::Matrix { rows, .. } => Some(Type::vec(rows, Scalar::F32)),
        _ => None,
    }
}

/// A non-negative constant index.
fn const_index(e: &hir::Expr) -> Option<u32> {
    e.const_index().and_then(|i| u32::try_from(i).ok())
}

fn binary_op(op: AssignOp) -> BinaryOp {
    match op {
        AssignOp::Assign | AssignOp::Add => BinaryOp::Add,
        AssignOp::Sub => BinaryOp::Sub,
        AssignOp::Mul => BinaryOp::Mul,
        AssignOp::Div => BinaryOp::Div,
    }
}
