//! Statements and blocks.

use super::depth::{Dx, St, deepen_stmt};
use super::expr::{ident, value};
use super::recovery::skip_statement;
use super::{Extra, GrammarError, ITEM_KEYWORDS, Rule, Tokens, emit, span_of};
use crate::ast::{AssignOp, Block, ExprKind, Ident, Stmt, StmtKind, TypeExpr};
use crate::diag::{Code, Diagnostic};
use crate::lexer::Token as T;
use crate::source::Span;
use chumsky::prelude::*;

/// A statement as its kind and the depth of what it holds (0 for none).
type Nested = (StmtKind, u32);

/// Where a block's `}` was missing: the token found instead (`None`: the end of input).
pub(super) type Missing = Option<(Option<T>, SimpleSpan)>;

/// The statement rule and the block rule built on it.
pub(super) struct Statements<'t, I: Tokens<'t>, Er: GrammarError<'t, I>> {
    pub(super) stmt: Rule<'t, I, St, Er>,
    pub(super) block: Rule<'t, I, (Block, u32), Er>,
}

/// Statements over `expr`; a broken one is skipped to the next `;` or past its `{ ... }`.
pub(super) fn statements<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> Statements<'t, I, Er> {
    // `recursive` hands the rule a weak handle to itself, so the grammar is no reference cycle
    // (a `Recursive::declare` rule that holds itself is never freed). The block rule outside
    // holds the rule strongly.
    let stmt = recursive(|stmt| {
        let block = block(stmt);
        let stmt_inner = choice((
            let_stmt(expr.clone(), ty.clone()),
            var_stmt(expr.clone(), ty),
            if_stmt(expr.clone(), block.clone()),
            for_stmt(expr.clone(), block.clone()),
            just(T::Return)
                .ignore_then(value(expr.clone()).or_not())
                .then_ignore(just(T::Semi))
                .map(|e| (StmtKind::Return(e), 0)),
            just(T::Break).then(just(T::Semi)).to((StmtKind::Break, 0)),
            just(T::Continue).then(just(T::Semi)).to((StmtKind::Continue, 0)),
            block.map(|(b, depth)| (StmtKind::Block(b), depth)),
            expr_stmt(expr),
            // A run of over-deep brackets the lexer already reported, standing alone.
            just(T::Error).then(just(T::Semi).or_not()).to((StmtKind::Error, 0)),
        ))
        .map_with(|(kind, inner), e| {
            let (st, d) = deepen_stmt(kind, span_of(e.span()), inner);
            emit(e, d);
            st
        })
        .or(just(T::Semi).to(St { stmt: None, depth: 0 }))
        .labelled("statement");
        // What a broken statement or declaration is skipped to.
        let stmt_skip = skip_statement().map(|span| St { stmt: Some(Stmt { kind: StmtKind::Error, span }), depth: 1 });
        stmt_inner.recover_with(via_parser(stmt_skip)).boxed()
    })
    .boxed();
    let block = block(stmt.clone());
    Statements { stmt, block }
}

/// `{`, with its span.
pub(super) fn open<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Span, Extra<Er>> + Clone {
    just(T::LBrace).map_with(|_, e| span_of(e.span()))
}

/// `}`. When the `}` is missing at the end of the file or before an item keyword, the block ends
/// there (so the next item still parses) and [`check_closed`] reports it.
pub(super) fn close<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> Rule<'t, I, Missing, Er> {
    choice((
        just(T::RBrace).to(None),
        choice((
            end().map_with(|_, e| Some((None, e.span()))),
            one_of(ITEM_KEYWORDS).map_with(|t, e| Some((Some(t), e.span()))),
        ))
        .rewind(),
    ))
    .boxed()
}

/// The error for a block opened at `open` whose `}` is missing.
pub(super) fn check_closed(open: Span, missing: Missing) -> Option<Diagnostic> {
    missing.map(|(found, at)| {
        let found = found.map_or_else(|| "end of input".to_string(), |t| t.to_string());
        Diagnostic::new(Code::Syntax, span_of(at), format!("expected `}}`, found {found}"))
            .with_label("the block is not closed before this")
            .with_secondary(open, "this `{` is never closed")
            .with_help("add the missing `}`")
    })
}

/// `{ statements }`, with the depth of its deepest statement.
fn block<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    stmt: impl Parser<'t, I, St, Extra<Er>> + Clone + 't,
) -> Rule<'t, I, (Block, u32), Er> {
    open()
        .then(stmt.repeated().collect::<Vec<St>>())
        .then(close())
        .map_with(move |((open, sts), missing), e| {
            emit(e, check_closed(open, missing));
            let depth = sts.iter().map(|s| s.depth).max().unwrap_or(0);
            let stmts = sts.into_iter().filter_map(|s| s.stmt).collect();
            (Block { stmts, span: span_of(e.span()) }, depth)
        })
        .boxed()
}

/// `: TYPE`, optional.
pub(super) fn annotation<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, Option<TypeExpr>, Extra<Er>> + Clone {
    just(T::Colon).ignore_then(ty).or_not()
}

/// `NAME: TYPE`, the annotation optional.
fn binding<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, (Ident, Option<TypeExpr>), Extra<Er>> + Clone {
    ident().then(annotation(ty))
}

/// `let NAME[: TYPE] = VALUE;`
fn let_stmt<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, Nested, Extra<Er>> + Clone {
    just(T::Let)
        .ignore_then(binding(ty))
        .then_ignore(just(T::Eq))
        .then(value(expr))
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| (StmtKind::Let { mutable: false, name, ty, value: Some(value) }, 0))
}

/// `var NAME[: TYPE][ = VALUE];`
fn var_stmt<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, Nested, Extra<Er>> + Clone {
    just(T::Var)
        .ignore_then(binding(ty))
        .then(just(T::Eq).ignore_then(value(expr)).or_not())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| (StmtKind::Let { mutable: true, name, ty, value }, 0))
}

/// `if c {} else if c {} ... else {}`, parsed by a loop and folded from the right.
fn if_stmt<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    block: Rule<'t, I, (Block, u32), Er>,
) -> impl Parser<'t, I, Nested, Extra<Er>> + Clone {
    let if_head = just(T::If)
        .ignore_then(value(expr))
        .then(block.clone())
        .map_with(|(cond, then), e| (cond, then, span_of(e.span())));
    if_head
        .clone()
        .then(just(T::Else).ignore_then(if_head).repeated().collect::<Vec<_>>())
        .then(just(T::Else).ignore_then(block).or_not())
        .map_with(|(((cond, then, _), else_ifs), last), e| {
            let end = span_of(e.span()).end;
            let mut otherwise = last;
            for (cond, (then, then_depth), head) in else_ifs.into_iter().rev() {
                let span = Span::new(head.start, end);
                let inner = then_depth.max(otherwise.as_ref().map_or(0, |(_, d)| *d));
                let kind = StmtKind::If { cond, then, otherwise: otherwise.map(|(b, _)| b) };
                let (st, d) = deepen_stmt(kind, span, inner);
                emit(e, d);
                otherwise = Some((Block { stmts: st.stmt.into_iter().collect(), span }, st.depth));
            }
            let (then, then_depth) = then;
            let inner = then_depth.max(otherwise.as_ref().map_or(0, |(_, d)| *d));
            (StmtKind::If { cond, then, otherwise: otherwise.map(|(b, _)| b) }, inner)
        })
}

/// `for NAME in START..END { ... }`
fn for_stmt<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    block: Rule<'t, I, (Block, u32), Er>,
) -> impl Parser<'t, I, Nested, Extra<Er>> + Clone {
    just(T::For)
        .ignore_then(ident())
        .then_ignore(just(T::In))
        .then(value(expr.clone()))
        .then_ignore(just(T::DotDot))
        .then(value(expr))
        .then(block)
        .map(|(((var, start), end), (body, depth))| (StmtKind::For { var, start, end, body }, depth))
}

/// `TARGET OP= VALUE;` or `CALL;`
fn expr_stmt<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
) -> impl Parser<'t, I, Nested, Extra<Er>> + Clone {
    let assign_op = select_ref! {
        T::Eq => AssignOp::Assign,
        T::PlusEq => AssignOp::Add,
        T::MinusEq => AssignOp::Sub,
        T::StarEq => AssignOp::Mul,
        T::SlashEq => AssignOp::Div,
    };
    value(expr.clone()).then(assign_op.then(value(expr)).or_not()).then_ignore(just(T::Semi)).map_with(
        |(target, rest), e| match rest {
            Some((op, value)) => (StmtKind::Assign { target, op, value }, 0),
            None => {
                if !matches!(target.kind, ExprKind::Call { .. } | ExprKind::Error) {
                    e.emit(Er::diagnostic(
                        Diagnostic::new(Code::Syntax, target.span, "only a call can be used as a statement")
                            .with_label("this value is computed and never used")
                            .with_help("assign it (`let v = ...;`, `x = ...;`) or remove it"),
                    ));
                }
                (StmtKind::Expr(target), 0)
            }
        },
    )
}
