//! Nodes with the depth of their tree: what bounds every tree the parser builds.

use crate::ast::{Expr, ExprKind, Stmt, StmtKind};
use crate::diag::{Code, Diagnostic};
use crate::source::Span;

/// The deepest expression tree, and the deepest statement nesting (blocks and `else if` levels),
/// the parser builds. Deeper input is reported (E0105) and replaced by an error node.
pub const MAX_DEPTH: u32 = 256;

/// Depth of a node that replaced a too-deep subtree: enclosing nodes become errors as well,
/// without a second report.
const SATURATED: u32 = MAX_DEPTH + 1;

/// An expression with the depth of its tree.
#[derive(Clone)]
pub(super) struct Dx {
    pub(super) expr: Expr,
    pub(super) depth: u32,
}

impl Dx {
    pub(super) fn leaf(kind: ExprKind, span: Span) -> Dx {
        Dx { expr: Expr { kind, span }, depth: 1 }
    }

    pub(super) fn error(span: Span) -> Dx {
        Dx::leaf(ExprKind::Error, span)
    }
}

/// A statement (`None` for an empty `;`) with its nesting depth.
#[derive(Clone)]
pub(super) struct St {
    pub(super) stmt: Option<Stmt>,
    pub(super) depth: u32,
}

/// Builds a node over children at most `inner` deep, or an error node if it would be too deep.
pub(super) fn deepen_expr(kind: ExprKind, span: Span, inner: u32) -> (Dx, Option<Diagnostic>) {
    if inner >= SATURATED {
        return (Dx { expr: Expr { kind: ExprKind::Error, span }, depth: SATURATED }, None);
    }
    if inner + 1 > MAX_DEPTH {
        let d = Diagnostic::new(Code::TooDeep, span, format!("expression nested more than {MAX_DEPTH} levels deep"))
            .with_label("this expression is too deep")
            .with_help("split it with `let` bindings");
        return (Dx { expr: Expr { kind: ExprKind::Error, span }, depth: SATURATED }, Some(d));
    }
    (Dx { expr: Expr { kind, span }, depth: inner + 1 }, None)
}

/// [`deepen_expr`] for statements.
pub(super) fn deepen_stmt(kind: StmtKind, span: Span, inner: u32) -> (St, Option<Diagnostic>) {
    let error = |depth| St { stmt: Some(Stmt { kind: StmtKind::Error, span }), depth };
    if inner >= SATURATED {
        return (error(SATURATED), None);
    }
    if inner + 1 > MAX_DEPTH {
        let d = Diagnostic::new(Code::TooDeep, span, format!("statements nested more than {MAX_DEPTH} levels deep"))
            .with_label("this statement is too deep")
            .with_help("move the inner part into a library function, or flatten the `else if` chain");
        return (error(SATURATED), Some(d));
    }
    (St { stmt: Some(Stmt { kind, span }), depth: inner + 1 }, None)
}
