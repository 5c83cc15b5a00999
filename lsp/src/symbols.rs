//! What the cursor is on: the syntax-tree node under a global offset, classified by what it
//! names (a state field, a uniform, a function, a step path, ...).
//!
//! This works on the syntax tree, which the parser builds even for a file with errors, so hover
//! and navigation keep working while the user types; types of locals come from the checked
//! program when the function checked.

use vrsc::ast::{self, DeclKind, ExprKind, Ident, Item, ItemKind, Module, StmtKind};
use vrsc::source::Span;

/// The item a symbol sits in.
#[derive(Clone, Copy, Debug)]
pub enum Owner<'a> {
    Pipeline(&'a ast::PipelineFn),
    Lib(&'a ast::LibFn),
    Other,
}

/// What a symbol names.
#[derive(Clone, Debug)]
pub enum Kind {
    /// `state.NAME`, or the name of a `state NAME: T` declaration.
    State,
    /// The name of a `uniform NAME: T` declaration.
    UniformDecl,
    /// A plain name in an expression: a uniform, constant, parameter or local.
    Name,
    /// A called name (library function, built-in or type constructor), an entry of `use`, or the
    /// name of a `lib fn`.
    Function,
    /// The name of a `const`.
    ConstDecl,
    /// A `let`, `var` or `for` variable, or a parameter, where it is declared.
    LocalDecl,
    /// The name of a pipeline function.
    PipelineName,
    /// A type name.
    Type,
    /// A step path: the whole path; `placement` says how it is used (`None` for `remove`).
    Step { path: ast::StepPath, placement: Option<ast::PlacementKind> },
    /// `std::NAME` in an import.
    StdModule,
    /// The string of `import "file.vrs";`.
    FileImport,
    /// A member or swizzle after a dot.
    Member,
}

/// The symbol under the cursor.
#[derive(Clone, Debug)]
pub struct Symbol<'a> {
    pub kind: Kind,
    pub name: String,
    pub span: Span,
    pub owner: Owner<'a>,
}

/// Whether `offset` touches `span` (its end counts: the cursor just after a word is on it).
fn touches(span: Span, offset: u32) -> bool {
    span.start <= offset && offset <= span.end
}

/// The symbol at global `offset` of `module`.
pub fn at(module: &Module, offset: u32) -> Option<Symbol<'_>> {
    module.items.iter().filter(|item| touches(item.span, offset)).find_map(|item| in_item(item, offset))
}

fn symbol<'a>(kind: Kind, id: &Ident, owner: Owner<'a>) -> Option<Symbol<'a>> {
    Some(Symbol { kind, name: id.name.clone(), span: id.span, owner })
}

fn in_item(item: &Item, offset: u32) -> Option<Symbol<'_>> {
    match &item.kind {
        ItemKind::Import(ast::Import::Std { path }) => {
            let first = path.first()?;
            let span = first.span.to(path.last()?.span);
            // The path leaves out the leading `std`.
            let name = format!("std::{}", path.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join("::"));
            touches(span, offset).then_some(Symbol { kind: Kind::StdModule, name, span, owner: Owner::Other })
        }
        ItemKind::Import(ast::Import::Path { path, span }) => touches(*span, offset).then(|| Symbol {
            kind: Kind::FileImport,
            name: path.clone(),
            span: *span,
            owner: Owner::Other,
        }),
        ItemKind::Const(c) => {
            if touches(c.name.span, offset) {
                return symbol(Kind::ConstDecl, &c.name, Owner::Other);
            }
            in_type(c.ty.as_ref(), offset, Owner::Other).or_else(|| in_expr(&c.value, offset, Owner::Other))
        }
        ItemKind::LibFn(f) => in_lib(f, offset),
        ItemKind::Pipeline(p) => in_pipeline(p, offset),
        ItemKind::Remove(r) => in_step(&r.target, None, offset),
    }
}

fn in_step(path: &ast::StepPath, placement: Option<ast::PlacementKind>, offset: u32) -> Option<Symbol<'static>> {
    touches(path.span, offset).then(|| Symbol {
        kind: Kind::Step { path: path.clone(), placement },
        name: path.step_name(),
        span: path.span,
        owner: Owner::Other,
    })
}

fn in_lib(f: &ast::LibFn, offset: u32) -> Option<Symbol<'_>> {
    let owner = Owner::Lib(f);
    if touches(f.name.span, offset) {
        return symbol(Kind::Function, &f.name, owner);
    }
    for param in &f.params {
        if touches(param.name.span, offset) {
            return symbol(Kind::LocalDecl, &param.name, owner);
        }
        if let Some(s) = in_type(Some(&param.ty), offset, owner) {
            return Some(s);
        }
    }
    in_type(f.ret.as_ref(), offset, owner).or_else(|| in_block(&f.body, offset, owner))
}

fn in_pipeline(p: &ast::PipelineFn, offset: u32) -> Option<Symbol<'_>> {
    let owner = Owner::Pipeline(p);
    if touches(p.name.span, offset) {
        return symbol(Kind::PipelineName, &p.name, owner);
    }
    if let Some(s) = in_step(&p.placement.target, Some(p.placement.kind), offset) {
        return Some(s);
    }
    for decl in p.decls.iter().filter(|d| touches(d.span, offset)) {
        let found = match &decl.kind {
            DeclKind::State { name, ty, default, .. } => {
                if touches(name.span, offset) {
                    return symbol(Kind::State, name, owner);
                }
                in_type(Some(ty), offset, owner).or_else(|| default.as_ref().and_then(|e| in_expr(e, offset, owner)))
            }
            DeclKind::Uniform { name, ty, default, range } => {
                if touches(name.span, offset) {
                    return symbol(Kind::UniformDecl, name, owner);
                }
                let exprs = default.iter().chain(range.iter().flat_map(|(lo, hi)| [lo, hi]));
                in_type(Some(ty), offset, owner).or_else(|| exprs.into_iter().find_map(|e| in_expr(e, offset, owner)))
            }
            DeclKind::Use { names } => {
                names.iter().find(|n| touches(n.span, offset)).and_then(|n| symbol(Kind::Function, n, owner))
            }
        };
        if found.is_some() {
            return found;
        }
    }
    in_block(&p.body, offset, owner)
}

fn in_type<'a>(ty: Option<&ast::TypeExpr>, offset: u32, owner: Owner<'a>) -> Option<Symbol<'a>> {
    let ty = ty.filter(|t| touches(t.span, offset))?;
    ty.args
        .iter()
        .find_map(|arg| in_type(Some(arg), offset, owner))
        .or_else(|| touches(ty.name.span, offset).then(|| symbol(Kind::Type, &ty.name, owner)).flatten())
}

fn in_block<'a>(block: &'a ast::Block, offset: u32, owner: Owner<'a>) -> Option<Symbol<'a>> {
    if !touches(block.span, offset) {
        return None;
    }
    block.stmts.iter().filter(|s| touches(s.span, offset)).find_map(|s| in_stmt(s, offset, owner))
}

fn in_stmt<'a>(stmt: &'a ast::Stmt, offset: u32, owner: Owner<'a>) -> Option<Symbol<'a>> {
    match &stmt.kind {
        StmtKind::Let { name, ty, value, .. } => {
            if touches(name.span, offset) {
                return symbol(Kind::LocalDecl, name, owner);
            }
            in_type(ty.as_ref(), offset, owner).or_else(|| value.as_ref().and_then(|v| in_expr(v, offset, owner)))
        }
        StmtKind::Assign { target, value, .. } => {
            in_expr(target, offset, owner).or_else(|| in_expr(value, offset, owner))
        }
        StmtKind::If { cond, then, otherwise } => in_expr(cond, offset, owner)
            .or_else(|| in_block(then, offset, owner))
            .or_else(|| otherwise.as_ref().and_then(|b| in_block(b, offset, owner))),
        StmtKind::For { var, start, end, body } => {
            if touches(var.span, offset) {
                return symbol(Kind::LocalDecl, var, owner);
            }
            in_expr(start, offset, owner)
                .or_else(|| in_expr(end, offset, owner))
                .or_else(|| in_block(body, offset, owner))
        }
        StmtKind::Return(Some(e)) | StmtKind::Expr(e) => in_expr(e, offset, owner),
        StmtKind::Block(b) => in_block(b, offset, owner),
        StmtKind::Return(None) | StmtKind::Break | StmtKind::Continue | StmtKind::Error => None,
    }
}

fn in_expr<'a>(expr: &'a ast::Expr, offset: u32, owner: Owner<'a>) -> Option<Symbol<'a>> {
    if !touches(expr.span, offset) {
        return None;
    }
    match &expr.kind {
        ExprKind::Name(id) => symbol(Kind::Name, id, owner),
        ExprKind::State(id) => touches(id.span, offset).then(|| symbol(Kind::State, id, owner)).flatten(),
        ExprKind::Member { base, member } => {
            if touches(member.span, offset) {
                return symbol(Kind::Member, member, owner);
            }
            in_expr(base, offset, owner)
        }
        ExprKind::Index { base, index } => in_expr(base, offset, owner).or_else(|| in_expr(index, offset, owner)),
        ExprKind::Call { callee, generics, args } => {
            if touches(callee.span, offset) {
                let kind =
                    if vrsc::types::Type::from_name(&callee.name).is_some() { Kind::Type } else { Kind::Function };
                return symbol(kind, callee, owner);
            }
            generics
                .iter()
                .find_map(|g| in_type(Some(g), offset, owner))
                .or_else(|| args.iter().find_map(|a| in_expr(a, offset, owner)))
        }
        ExprKind::Unary { operand, .. } => in_expr(operand, offset, owner),
        ExprKind::Binary { lhs, rhs, .. } => in_expr(lhs, offset, owner).or_else(|| in_expr(rhs, offset, owner)),
        ExprKind::Int { .. } | ExprKind::Float { .. } | ExprKind::Bool(_) | ExprKind::Error => None,
    }
}

/// Every use of state field `name` in `module`, in source order: `state.NAME` in bodies and
/// the names of its declarations (`true` beside a declaration).
pub fn state_uses(module: &Module, name: &str) -> Vec<(Span, bool)> {
    let mut out = Vec::new();
    for item in &module.items {
        let ItemKind::Pipeline(p) = &item.kind else { continue };
        let mut uses = Vec::new();
        for decl in &p.decls {
            if let DeclKind::State { name: n, .. } = &decl.kind
                && n.name == name
            {
                out.push((n.span, true));
            }
        }
        block_state_uses(&p.body, name, &mut uses);
        out.extend(uses.into_iter().map(|span| (span, false)));
    }
    out
}

fn block_state_uses(block: &ast::Block, name: &str, out: &mut Vec<Span>) {
    for stmt in &block.stmts {
        match &stmt.kind {
            StmtKind::Let { value, .. } => value.iter().for_each(|v| expr_state_uses(v, name, out)),
            StmtKind::Assign { target, value, .. } => {
                expr_state_uses(target, name, out);
                expr_state_uses(value, name, out);
            }
            StmtKind::If { cond, then, otherwise } => {
                expr_state_uses(cond, name, out);
                block_state_uses(then, name, out);
                otherwise.iter().for_each(|b| block_state_uses(b, name, out));
            }
            StmtKind::For { start, end, body, .. } => {
                expr_state_uses(start, name, out);
                expr_state_uses(end, name, out);
                block_state_uses(body, name, out);
            }
            StmtKind::Return(Some(e)) | StmtKind::Expr(e) => expr_state_uses(e, name, out),
            StmtKind::Block(b) => block_state_uses(b, name, out),
            StmtKind::Return(None) | StmtKind::Break | StmtKind::Continue | StmtKind::Error => {}
        }
    }
}

fn expr_state_uses(expr: &ast::Expr, name: &str, out: &mut Vec<Span>) {
    match &expr.kind {
        ExprKind::State(id) if id.name == name => out.push(id.span),
        ExprKind::Member { base, .. } | ExprKind::Unary { operand: base, .. } => expr_state_uses(base, name, out),
        ExprKind::Index { base, index } => {
            expr_state_uses(base, name, out);
            expr_state_uses(index, name, out);
        }
        ExprKind::Binary { lhs, rhs, .. } => {
            expr_state_uses(lhs, name, out);
            expr_state_uses(rhs, name, out);
        }
        ExprKind::Call { args, .. } => args.iter().for_each(|a| expr_state_uses(a, name, out)),
        _ => {}
    }
}

/// The pipeline function of `module` whose item covers `offset`.
pub fn pipeline_at(module: &Module, offset: u32) -> Option<&ast::PipelineFn> {
    module.items.iter().find_map(|item| match &item.kind {
        ItemKind::Pipeline(p) if touches(item.span, offset) => Some(p),
        _ => None,
    })
}

/// The library function of `module` whose item covers `offset`.
pub fn lib_at(module: &Module, offset: u32) -> Option<&ast::LibFn> {
    module.items.iter().find_map(|item| match &item.kind {
        ItemKind::LibFn(f) if touches(item.span, offset) => Some(f),
        _ => None,
    })
}

/// How a local name was introduced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocalKind {
    Let,
    Var,
    Loop,
    Param,
}

/// A local variable or parameter where it is declared.
pub struct LocalSite<'a> {
    pub name: &'a Ident,
    pub ty: Option<&'a ast::TypeExpr>,
    pub value: Option<&'a ast::Expr>,
    pub kind: LocalKind,
}

/// Every parameter and local of a function, in source order.
pub fn locals<'a>(owner: Owner<'a>) -> Vec<LocalSite<'a>> {
    let mut out = Vec::new();
    match owner {
        Owner::Pipeline(p) => block_locals(&p.body, &mut out),
        Owner::Lib(f) => {
            for param in &f.params {
                out.push(LocalSite { name: &param.name, ty: Some(&param.ty), value: None, kind: LocalKind::Param });
            }
            block_locals(&f.body, &mut out);
        }
        Owner::Other => {}
    }
    out
}

fn block_locals<'a>(block: &'a ast::Block, out: &mut Vec<LocalSite<'a>>) {
    for stmt in &block.stmts {
        match &stmt.kind {
            StmtKind::Let { mutable, name, ty, value } => {
                let kind = if *mutable { LocalKind::Var } else { LocalKind::Let };
                out.push(LocalSite { name, ty: ty.as_ref(), value: value.as_ref(), kind });
            }
            StmtKind::If { then, otherwise, .. } => {
                block_locals(then, out);
                otherwise.iter().for_each(|b| block_locals(b, out));
            }
            StmtKind::For { var, body, .. } => {
                out.push(LocalSite { name: var, ty: None, value: None, kind: LocalKind::Loop });
                block_locals(body, out);
            }
            StmtKind::Block(b) => block_locals(b, out),
            _ => {}
        }
    }
}
