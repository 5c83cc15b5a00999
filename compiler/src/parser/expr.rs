//! Names, types and expressions.

use super::depth::{Dx, deepen_expr};
use super::recovery::skip_expr_group;
use super::{Extra, GrammarError, Rule, Tokens, emit, span_of};
use crate::ast::{BinaryOp, Expr, ExprKind, Ident, TypeExpr, UnaryOp};
use crate::diag::Diagnostic;
use crate::lexer::Token as T;
use crate::source::Span;
use crate::types::Type;
use chumsky::prelude::*;

/// Any name.
pub(super) fn ident<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> Rule<'t, I, Ident, Er> {
    select_ref! { T::Ident(name) = e => Ident { name: name.clone(), span: span_of(e.span()) } }
        .labelled("identifier")
        .boxed()
}

/// A name that is not a generic type name (`vec3`, `mat4x4`, ...).
fn plain_ident<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> Rule<'t, I, Ident, Er> {
    select_ref! {
        T::Ident(name) = e if !Type::is_generic_name(name) => Ident { name: name.clone(), span: span_of(e.span()) }
    }
    .labelled("identifier")
    .boxed()
}

/// A generic type name (`vec3`, `mat4x4`, ...).
fn generic_ident<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> Rule<'t, I, Ident, Er> {
    select_ref! {
        T::Ident(name) = e if Type::is_generic_name(name) => Ident { name: name.clone(), span: span_of(e.span()) }
    }
    .boxed()
}

/// Types: `name` or `name<T, ...>`, built by a loop (types nest at most four deep) so that no
/// input can make this part recurse.
pub(super) fn type_expr<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> Rule<'t, I, TypeExpr, Er> {
    let ident = ident();
    let mut ty = ident.clone().map(|name| TypeExpr { span: name.span, name, args: Vec::new() }).boxed();
    for _ in 0..3 {
        let args =
            ty.separated_by(just(T::Comma)).at_least(1).collect::<Vec<_>>().delimited_by(just(T::Lt), just(T::Gt));
        ty = ident
            .clone()
            .then(args.or_not())
            .map_with(|(name, args), e| TypeExpr { name, args: args.unwrap_or_default(), span: span_of(e.span()) })
            .boxed();
    }
    ty.labelled("type").boxed()
}

/// An expression with its depth: binary operators over unary ones over postfix ones over
/// primaries, which recurse into bracketed expressions.
pub(super) fn expression<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    ty: Rule<'t, I, TypeExpr, Er>,
) -> Rule<'t, I, Dx, Er> {
    recursive(|expr| binary(unary(postfix(primary(expr.clone(), ty), expr)))).boxed()
}

/// An expression without its depth.
pub(super) fn value<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
) -> impl Parser<'t, I, Expr, Extra<Er>> + Clone {
    expr.map(|d: Dx| d.expr)
}

/// The next token is `t`, which is left in place. Tokens that may continue an expression are
/// tested this way, with `select_ref!`, whose failure is not listed in messages: after `x` in
/// `let y = x z`, "expected `;`" says more than a list of every operator.
fn peek<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(t: T) -> impl Parser<'t, I, (), Extra<Er>> + Clone {
    select_ref! { tok if *tok == t => () }.rewind()
}

/// `(a, b, ...)`; a broken list is skipped to its `)`.
fn call_args<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: impl Parser<'t, I, Dx, Extra<Er>> + Clone + 't,
) -> Rule<'t, I, Vec<Dx>, Er> {
    expr.separated_by(just(T::Comma))
        .allow_trailing()
        .collect::<Vec<Dx>>()
        .delimited_by(just(T::LParen), just(T::RParen))
        .recover_with(via_parser(skip_expr_group(T::LParen).map(|span| vec![Dx::error(span)])))
        .boxed()
}

/// Literals (and a token the lexer already reported).
fn literal<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Dx, Extra<Er>> + Clone {
    select_ref! {
        T::Int(lit) => ExprKind::Int { value: lit.value, suffix: lit.suffix },
        T::Float(lit) => ExprKind::Float { value: lit.value, suffixed: lit.suffixed },
        T::True => ExprKind::Bool(true),
        T::False => ExprKind::Bool(false),
        // Already reported by the lexer.
        T::Error => ExprKind::Error,
    }
    .map_with(|kind, e| Dx::leaf(kind, span_of(e.span())))
}

/// `state.NAME`.
fn state_access<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Dx, Extra<Er>> + Clone {
    just(T::State)
        .ignore_then(just(T::Dot))
        .ignore_then(ident())
        .map_with(|name, e| Dx::leaf(ExprKind::State(name), span_of(e.span())))
}

/// A call node over its arguments.
fn call(callee: Ident, generics: Vec<TypeExpr>, args: Vec<Dx>, span: Span) -> (Dx, Option<Diagnostic>) {
    let inner = args.iter().map(|a| a.depth).max().unwrap_or(0);
    let args = args.into_iter().map(|a| a.expr).collect();
    deepen_expr(ExprKind::Call { callee, generics, args }, span, inner)
}

/// `vec3<f32>(x)`, `vec3(x)` or `vec3`: after a generic type name, `<` always opens template
/// arguments (never a comparison).
fn generic_call<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    ty: Rule<'t, I, TypeExpr, Er>,
    args: Rule<'t, I, Vec<Dx>, Er>,
) -> impl Parser<'t, I, Dx, Extra<Er>> + Clone {
    let generics =
        ty.separated_by(just(T::Comma)).at_least(1).collect::<Vec<_>>().delimited_by(just(T::Lt), just(T::Gt));
    let opt_args = peek(T::LParen).ignore_then(args.clone()).or_not();
    generic_ident()
        .then(choice((
            generics.then(args).map(|(g, a)| (g, Some(a))),
            peek(T::Lt).not().ignore_then(opt_args).map(|a| (Vec::new(), a)),
        )))
        .map_with(move |(callee, (generics, args)), e| match args {
            Some(args) => {
                let (out, d) = call(callee, generics, args, span_of(e.span()));
                emit(e, d);
                out
            }
            None => Dx::leaf(ExprKind::Name(callee.clone()), callee.span),
        })
}

/// `f(x)` or a name.
fn call_or_name<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    args: Rule<'t, I, Vec<Dx>, Er>,
) -> impl Parser<'t, I, Dx, Extra<Er>> + Clone {
    let opt_args = peek(T::LParen).ignore_then(args).or_not();
    plain_ident().then(opt_args).map_with(move |(callee, args), e| match args {
        Some(args) => {
            let (out, d) = call(callee, Vec::new(), args, span_of(e.span()));
            emit(e, d);
            out
        }
        None => Dx::leaf(ExprKind::Name(callee.clone()), callee.span),
    })
}

/// `(x)`; a broken one is skipped to its `)`.
fn paren<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: impl Parser<'t, I, Dx, Extra<Er>> + Clone + 't,
) -> impl Parser<'t, I, Dx, Extra<Er>> + Clone {
    expr.delimited_by(just(T::LParen), just(T::RParen))
        .map_with(|inner: Dx, e| {
            let expr = Expr { kind: inner.expr.kind, span: span_of(e.span()) };
            Dx { expr, depth: inner.depth }
        })
        .recover_with(via_parser(skip_expr_group(T::LParen).map(Dx::error)))
}

fn primary<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: impl Parser<'t, I, Dx, Extra<Er>> + Clone + 't,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> Rule<'t, I, Dx, Er> {
    let args = call_args(expr.clone());
    choice((literal(), state_access(), generic_call(ty, args.clone()), call_or_name(args), paren(expr)))
        .labelled("expression")
        .boxed()
}

/// A postfix operation: `.member` or `[index]`.
enum Post {
    Member(Ident),
    Index(Dx),
}

/// A primary followed by `.member` and `[index]` operations.
fn postfix<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    primary: Rule<'t, I, Dx, Er>,
    expr: impl Parser<'t, I, Dx, Extra<Er>> + Clone + 't,
) -> Rule<'t, I, Dx, Er> {
    let member = peek(T::Dot).ignore_then(just(T::Dot)).ignore_then(ident()).map(Post::Member);
    let index = peek(T::LBracket)
        .ignore_then(
            expr.delimited_by(just(T::LBracket), just(T::RBracket))
                .recover_with(via_parser(skip_expr_group(T::LBracket).map(Dx::error))),
        )
        .map(Post::Index);
    primary
        .foldl_with(choice((member, index)).repeated(), |base: Dx, post, e| {
            let span = span_of(e.span());
            let (out, d) = match post {
                Post::Member(member) => {
                    deepen_expr(ExprKind::Member { base: Box::new(base.expr), member }, span, base.depth)
                }
                Post::Index(index) => {
                    let inner = base.depth.max(index.depth);
                    let kind = ExprKind::Index { base: Box::new(base.expr), index: Box::new(index.expr) };
                    deepen_expr(kind, span, inner)
                }
            };
            emit(e, d);
            out
        })
        .boxed()
}

/// Prefix operators by a loop, not by recursion: `- - - - x` cannot exhaust the stack.
fn unary<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(postfix: Rule<'t, I, Dx, Er>) -> Rule<'t, I, Dx, Er> {
    let prefix_op = select_ref! {
        T::Minus = e => (UnaryOp::Neg, span_of(e.span())),
        T::Bang = e => (UnaryOp::Not, span_of(e.span())),
    };
    prefix_op
        .repeated()
        .collect::<Vec<_>>()
        .then(postfix)
        .map_with(|(ops, operand), e| {
            let end = span_of(e.span()).end;
            let mut out = operand;
            for (op, at) in ops.into_iter().rev() {
                let (next, d) = deepen_expr(
                    ExprKind::Unary { op, operand: Box::new(out.expr) },
                    Span::new(at.start, end),
                    out.depth,
                );
                emit(e, d);
                out = next;
            }
            out
        })
        .boxed()
}

/// Binary operators: a flat list folded by precedence (no recursion, one token test per
/// operand).
fn binary<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(unary: Rule<'t, I, Dx, Er>) -> Rule<'t, I, Dx, Er> {
    let binary_op = select_ref! {
        T::Star => BinaryOp::Mul,
        T::Slash => BinaryOp::Div,
        T::Percent => BinaryOp::Rem,
        T::Plus => BinaryOp::Add,
        T::Minus => BinaryOp::Sub,
        T::Shl => BinaryOp::Shl,
        T::Shr => BinaryOp::Shr,
        T::Lt => BinaryOp::Lt,
        T::Le => BinaryOp::Le,
        T::Gt => BinaryOp::Gt,
        T::Ge => BinaryOp::Ge,
        T::EqEq => BinaryOp::Eq,
        T::Ne => BinaryOp::Ne,
        T::Amp => BinaryOp::BitAnd,
        T::Caret => BinaryOp::BitXor,
        T::Pipe => BinaryOp::BitOr,
        T::AndAnd => BinaryOp::And,
        T::OrOr => BinaryOp::Or,
    };
    unary
        .clone()
        .then(binary_op.then(unary).repeated().collect::<Vec<_>>())
        .map_with(|(first, rest), e| {
            let (out, diags) = fold_binary(first, rest);
            for d in diags {
                e.emit(Er::diagnostic(d));
            }
            out
        })
        .boxed()
}

/// Binding power of a binary operator (WGSL's precedence; all are left-associative).
fn precedence(op: BinaryOp) -> u8 {
    use BinaryOp::*;
    match op {
        Mul | Div | Rem => 10,
        Add | Sub => 9,
        Shl | Shr => 8,
        Lt | Le | Gt | Ge => 7,
        Eq | Ne => 6,
        BitAnd => 5,
        BitXor => 4,
        BitOr => 3,
        And => 2,
        Or => 1,
    }
}

/// Folds `first (op operand)*` into a tree by precedence (shunting-yard, in linear time and
/// constant stack).
fn fold_binary(first: Dx, rest: Vec<(BinaryOp, Dx)>) -> (Dx, Vec<Diagnostic>) {
    fn reduce(operands: &mut Vec<Dx>, ops: &mut Vec<BinaryOp>, diags: &mut Vec<Diagnostic>) {
        let (Some(op), Some(rhs), Some(lhs)) = (ops.pop(), operands.pop(), operands.pop()) else { return };
        let span = lhs.expr.span.to(rhs.expr.span);
        let inner = lhs.depth.max(rhs.depth);
        let kind = ExprKind::Binary { op, lhs: Box::new(lhs.expr), rhs: Box::new(rhs.expr) };
        let (out, d) = deepen_expr(kind, span, inner);
        diags.extend(d);
        operands.push(out);
    }
    let mut diags = Vec::new();
    if rest.is_empty() {
        return (first, diags);
    }
    let mut operands = vec![first];
    let mut ops: Vec<BinaryOp> = Vec::new();
    for (op, operand) in rest {
        while ops.last().is_some_and(|top| precedence(*top) >= precedence(op)) {
            reduce(&mut operands, &mut ops, &mut diags);
        }
        ops.push(op);
        operands.push(operand);
    }
    while !ops.is_empty() {
        reduce(&mut operands, &mut ops, &mut diags);
    }
    let out = operands.pop().unwrap_or_else(|| Dx::error(Span::DUMMY));
    (out, diags)
}
