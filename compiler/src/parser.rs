//! Parser: the tokens of one file to its syntax tree (chumsky).
//!
//! Parsing never fails. Errors are reported and recovered from at three levels, so every
//! independent error in a file is reported once:
//!
//! - **expressions**: a broken parenthesised expression, argument list or index is skipped to its
//!   closing bracket (within the statement) and becomes [`ExprKind::Error`];
//! - **statements and declarations**: a broken one is skipped to the next `;` (inclusive) or past
//!   the next balanced `{ ... }`, and becomes [`StmtKind::Error`]; a block whose `}` is missing at
//!   the end of the file or before the next item keyword is closed there;
//! - **items**: a broken item is skipped to the next item keyword (`import const lib pipeline
//!   remove`); none of them can occur inside an item, so brackets need no balancing there.
//!
//! A file is parsed first with chumsky's `EmptyErr`, which records only that an error occurred and
//! takes about half the instructions; only a file with a syntax error is parsed again, with `Rich`
//! errors, to report. Chumsky's errors become E0104 diagnostics that say what was expected and
//! what was found; a syntax error right after characters the lexer dropped (E0101, E0102), or at a
//! [`Token::Error`], is not reported again.
//!
//! Nothing recurses without bound. Brackets are nested at most [`crate::lexer::MAX_NESTING`] deep
//! (the lexer sees to that) and the recursion through them is on a growable stack (chumsky's
//! `stacker`); unary operators and `else if` chains are parsed by loops, binary operators as a flat
//! list folded by precedence, and recovery scans are loops. Every tree the parser builds is at most
//! [`MAX_DEPTH`] expression levels and [`MAX_DEPTH`] statement levels deep (deeper input is E0105
//! and becomes an error node), which bounds the recursion of every later pass, dropping the tree
//! included.

use crate::ast::*;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::lexer::{Lexed, Token};
use crate::source::{FileId, Span};
use crate::types::Type;
use chumsky::error::{EmptyErr, Error, RichPattern, RichReason};
use chumsky::input::{BorrowInput, Input, InputRef, MapExtra, ValueInput};
use chumsky::label::LabelError;
use chumsky::prelude::*;
use chumsky::recursive::Indirect;
use rustc_hash::{FxHashMap, FxHashSet};

/// The deepest expression tree, and the deepest statement nesting (blocks and `else if` levels),
/// the parser builds. Deeper input is reported (E0105) and replaced by an error node.
pub const MAX_DEPTH: u32 = 256;

/// Depth of a node that replaced a too-deep subtree: enclosing nodes become errors as well,
/// without a second report.
const SATURATED: u32 = MAX_DEPTH + 1;

/// Most expected tokens listed in a message.
const MAX_EXPECTED: usize = 6;

/// Tokens that start an item: where item-level recovery resumes, and where an unclosed block ends.
const ITEM_KEYWORDS: [Token; 5] = [Token::Import, Token::Const, Token::Lib, Token::Pipeline, Token::Remove];

/// The error the grammar reports with; `Custom` carries a finished diagnostic (E0105, E0106,
/// E0107, ...).
type ParseError<'t> = Rich<'t, Token, SimpleSpan, Box<Diagnostic>>;
type Extra<Er> = extra::Err<Er>;

/// What the grammar needs of its error type. It runs with [`EmptyErr`] first, which tracks
/// nothing but whether an error occurred and is enough for a file without syntax errors, and
/// again with [`ParseError`] only to report the errors of a file that has some.
trait GrammarError<'t, I: Input<'t>>: Error<'t, I> + LabelError<'t, I, &'static str> + 't {
    /// An error that carries one of our finished diagnostics.
    fn diagnostic(d: Diagnostic) -> Self;
}

impl<'t, I> GrammarError<'t, I> for ParseError<'t>
where
    I: Input<'t, Token = Token, Span = SimpleSpan>,
{
    fn diagnostic(d: Diagnostic) -> Self {
        Rich::custom(SimpleSpan::from(d.span.start as usize..d.span.end as usize), Box::new(d))
    }
}

impl<'t, I: Input<'t>> GrammarError<'t, I> for EmptyErr {
    fn diagnostic(_: Diagnostic) -> Self {
        EmptyErr::default()
    }
}

/// Parses one file's tokens. Never fails: returns the tree with every independent error reported.
/// `eof` is the global offset of the end of the file (the span of "end of input").
pub fn parse_module(lexed: &Lexed, file: FileId, eof: u32, diags: &mut Diagnostics) -> Module {
    let tokens: Vec<(Token, SimpleSpan)> =
        lexed.tokens.iter().map(|(t, s)| (t.clone(), SimpleSpan::from(s.start as usize..s.end as usize))).collect();
    let eoi = SimpleSpan::from(eof as usize..eof as usize);
    let input = || tokens.as_slice().split_token_span(eoi);
    // The grammar and so the tree do not depend on the error type: a file without syntax errors
    // needs only the fast pass (it takes half the instructions of a reporting one).
    let fast = module_parser::<_, EmptyErr>().parse(input());
    let (items, errors) = if fast.has_errors() {
        module_parser::<_, ParseError>().parse(input()).into_output_errors()
    } else {
        (fast.into_output(), Vec::new())
    };
    let mut items = items.unwrap_or_default();
    attach_docs(&mut items, &lexed.docs);
    report(errors, &lexed.tokens, diags);
    Module { file, items }
}

fn span_of(s: SimpleSpan) -> Span {
    Span::new(s.start as u32, s.end as u32)
}

/// An expression with the depth of its tree.
#[derive(Clone)]
struct Dx {
    expr: Expr,
    depth: u32,
}

impl Dx {
    fn leaf(kind: ExprKind, span: Span) -> Dx {
        Dx { expr: Expr { kind, span }, depth: 1 }
    }

    fn error(span: Span) -> Dx {
        Dx::leaf(ExprKind::Error, span)
    }
}

/// A statement (`None` for an empty `;`) with its nesting depth.
#[derive(Clone)]
struct St {
    stmt: Option<Stmt>,
    depth: u32,
}

/// Builds a node over children at most `inner` deep, or an error node if it would be too deep.
fn deepen_expr(kind: ExprKind, span: Span, inner: u32) -> (Dx, Option<Diagnostic>) {
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
fn deepen_stmt(kind: StmtKind, span: Span, inner: u32) -> (St, Option<Diagnostic>) {
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

fn emit<'t, I, Er>(e: &mut MapExtra<'t, '_, I, Extra<Er>>, d: Option<Diagnostic>)
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    if let Some(d) = d {
        e.emit(Er::diagnostic(d));
    }
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

/// One entry of a pipeline function's body.
enum Entry {
    Decl(Decl),
    Stmt(St),
}

/// A postfix operation: `.member` or `[index]`.
enum Post {
    Member(Ident),
    Index(Dx),
}

/// Tokens that never occur inside parentheses or brackets: a recovery scan of a bracket group
/// gives up at them, so that it stays within one statement.
const EXPR_STOPS: [Token; 8] = [
    Token::Semi,
    Token::LBrace,
    Token::RBrace,
    Token::Import,
    Token::Const,
    Token::Lib,
    Token::Pipeline,
    Token::Remove,
];

fn closer_of(t: &Token) -> Option<Token> {
    match t {
        Token::LParen => Some(Token::RParen),
        Token::LBracket => Some(Token::RBracket),
        Token::LBrace => Some(Token::RBrace),
        _ => None,
    }
}

/// With the next token an opening bracket, consumes its balanced group (all bracket kinds
/// balanced, by a loop) and returns true. Otherwise (a mismatched closer, the end of input or a
/// token of `stops` inside) consumes nothing and returns false.
///
/// Recovery scans are written by hand rather than with chumsky combinators: a failed combinator
/// leaves an "expected" error at the furthest point it reached, which would then be reported in
/// place of the next real error.
fn skip_group<'t, I, Er>(inp: &mut InputRef<'t, '_, I, Extra<Er>>, stops: &[Token]) -> bool
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    let start = inp.save();
    let Some(first) = inp.next_ref().and_then(closer_of) else {
        inp.rewind(start);
        return false;
    };
    let mut expected = vec![first];
    while let Some(t) = inp.next_ref() {
        if stops.contains(t) {
            break;
        }
        if let Some(close) = closer_of(t) {
            expected.push(close);
        } else if matches!(t, Token::RParen | Token::RBracket | Token::RBrace) {
            if expected.last() != Some(t) {
                break;
            }
            expected.pop();
            if expected.is_empty() {
                return true;
            }
        }
    }
    inp.rewind(start);
    false
}

/// The error of a recovery scan that found nothing to skip. It is never reported: `via_parser`
/// puts the original error back when its recovery parser fails.
fn nothing_to_skip<'t, I: Input<'t>, Er: GrammarError<'t, I>>(span: SimpleSpan) -> Er {
    Er::diagnostic(Diagnostic::new(Code::Syntax, span_of(span), "nothing to skip"))
}

/// Recovery for a bracketed part of an expression: skips the balanced group at `open` within the
/// statement.
fn skip_expr_group<'t, I, Er>(open: Token) -> impl Parser<'t, I, Span, Extra<Er>> + Clone
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    custom(move |inp: &mut InputRef<'t, '_, I, Extra<Er>>| {
        let before = inp.cursor();
        if inp.peek_ref() == Some(&open) && skip_group(inp, &EXPR_STOPS) {
            Ok(span_of(inp.span_since(&before)))
        } else {
            Err(nothing_to_skip(inp.span_since(&before)))
        }
    })
}

/// Recovery for a statement or declaration: skips to the next `;` (inclusive) or past the next
/// balanced `{ ... }`, stopping before a `}` or an item keyword. Consumes at least one token.
fn skip_statement<'t, I, Er>() -> impl Parser<'t, I, Span, Extra<Er>> + Clone
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    custom(|inp: &mut InputRef<'t, '_, I, Extra<Er>>| {
        let before = inp.cursor();
        let mut consumed = false;
        while let Some(t) = inp.peek_ref() {
            match t {
                Token::Semi => {
                    inp.skip();
                    consumed = true;
                    break;
                }
                Token::RBrace => break,
                t if ITEM_KEYWORDS.contains(t) => break,
                Token::LBrace => {
                    consumed |= skip_group(inp, &ITEM_KEYWORDS);
                    break;
                }
                Token::LParen | Token::LBracket => {
                    if !skip_group(inp, &EXPR_STOPS) {
                        inp.skip();
                    }
                    consumed = true;
                }
                _ => {
                    inp.skip();
                    consumed = true;
                }
            }
        }
        let span = inp.span_since(&before);
        if consumed { Ok(span_of(span)) } else { Err(nothing_to_skip(span)) }
    })
}

/// Recovery for an item: skips its first token and everything up to the next item keyword.
fn skip_item<'t, I, Er>() -> impl Parser<'t, I, Option<Item>, Extra<Er>> + Clone
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    custom(|inp: &mut InputRef<'t, '_, I, Extra<Er>>| {
        let before = inp.cursor();
        if inp.next_ref().is_none() {
            return Err(nothing_to_skip(inp.span_since(&before)));
        }
        while inp.peek_ref().is_some_and(|t| !ITEM_KEYWORDS.contains(t)) {
            inp.skip();
        }
        Ok(None)
    })
}

fn module_parser<'t, I, Er>() -> impl Parser<'t, I, Vec<Item>, Extra<Er>>
where
    I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>,
    Er: GrammarError<'t, I>,
{
    use Token as T;

    let ident = select_ref! { T::Ident(name) = e => Ident { name: name.clone(), span: span_of(e.span()) } }
        .labelled("identifier")
        .boxed();
    // A name that is not a generic type name (`vec3`, `mat4x4`, ...).
    let plain_ident = select_ref! {
        T::Ident(name) = e if !Type::is_generic_name(name) => Ident { name: name.clone(), span: span_of(e.span()) }
    }
    .labelled("identifier")
    .boxed();
    let generic_ident = select_ref! {
        T::Ident(name) = e if Type::is_generic_name(name) => Ident { name: name.clone(), span: span_of(e.span()) }
    }
    .boxed();

    // Types: `name` or `name<T, ...>`, built by a loop (types nest at most four deep) so that no
    // input can make this part recurse.
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
    let ty = ty.labelled("type").boxed();

    let expr = recursive(|expr| {
        let args = expr
            .clone()
            .separated_by(just(T::Comma))
            .allow_trailing()
            .collect::<Vec<Dx>>()
            .delimited_by(just(T::LParen), just(T::RParen))
            .recover_with(via_parser(skip_expr_group(T::LParen).map(|span| vec![Dx::error(span)])))
            .boxed();
        // Tokens that may continue an expression are tested with `select_ref!`, whose failure is
        // not listed in messages: after `x` in `let y = x z`, "expected `;`" says more than a list
        // of every operator.
        let peek = |t: Token| select_ref! { tok if *tok == t => () }.rewind();
        let opt_args = peek(T::LParen).ignore_then(args.clone()).or_not();

        let literal = select_ref! {
            T::Int(lit) => ExprKind::Int { value: lit.value, suffix: lit.suffix },
            T::Float(lit) => ExprKind::Float { value: lit.value, suffixed: lit.suffixed },
            T::True => ExprKind::Bool(true),
            T::False => ExprKind::Bool(false),
            // Already reported by the lexer.
            T::Error => ExprKind::Error,
        }
        .map_with(|kind, e| Dx::leaf(kind, span_of(e.span())));

        let state = just(T::State)
            .ignore_then(just(T::Dot))
            .ignore_then(ident.clone())
            .map_with(|name, e| Dx::leaf(ExprKind::State(name), span_of(e.span())));

        let call = |callee: Ident, generics: Vec<TypeExpr>, args: Vec<Dx>, span: Span| {
            let inner = args.iter().map(|a| a.depth).max().unwrap_or(0);
            let args = args.into_iter().map(|a| a.expr).collect();
            deepen_expr(ExprKind::Call { callee, generics, args }, span, inner)
        };

        // `vec3<f32>(x)`, `vec3(x)` or `vec3`: after a generic type name, `<` always opens
        // template arguments (never a comparison).
        let generics = ty
            .clone()
            .separated_by(just(T::Comma))
            .at_least(1)
            .collect::<Vec<_>>()
            .delimited_by(just(T::Lt), just(T::Gt));
        let generic_call = generic_ident
            .then(choice((
                generics.then(args.clone()).map(|(g, a)| (g, Some(a))),
                peek(T::Lt).not().ignore_then(opt_args.clone()).map(|a| (Vec::new(), a)),
            )))
            .map_with(move |(callee, (generics, args)), e| match args {
                Some(args) => {
                    let (out, d) = call(callee, generics, args, span_of(e.span()));
                    emit(e, d);
                    out
                }
                None => Dx::leaf(ExprKind::Name(callee.clone()), callee.span),
            });

        let call_or_name = plain_ident.clone().then(opt_args).map_with(move |(callee, args), e| match args {
            Some(args) => {
                let (out, d) = call(callee, Vec::new(), args, span_of(e.span()));
                emit(e, d);
                out
            }
            None => Dx::leaf(ExprKind::Name(callee.clone()), callee.span),
        });

        let paren = expr
            .clone()
            .delimited_by(just(T::LParen), just(T::RParen))
            .map_with(|inner: Dx, e| {
                let expr = Expr { kind: inner.expr.kind, span: span_of(e.span()) };
                Dx { expr, depth: inner.depth }
            })
            .recover_with(via_parser(skip_expr_group(T::LParen).map(Dx::error)));

        let primary = choice((literal, state, generic_call, call_or_name, paren)).labelled("expression").boxed();

        let member = peek(T::Dot).ignore_then(just(T::Dot)).ignore_then(ident.clone()).map(Post::Member);
        let index = peek(T::LBracket)
            .ignore_then(
                expr.clone()
                    .delimited_by(just(T::LBracket), just(T::RBracket))
                    .recover_with(via_parser(skip_expr_group(T::LBracket).map(Dx::error))),
            )
            .map(Post::Index);
        let postfix = primary
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
            .boxed();

        // Prefix operators by a loop, not by recursion: `- - - - x` cannot exhaust the stack.
        let prefix_op = select_ref! {
            T::Minus = e => (UnaryOp::Neg, span_of(e.span())),
            T::Bang = e => (UnaryOp::Not, span_of(e.span())),
        };
        let unary = prefix_op
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
            .boxed();

        // Binary operators: a flat list folded by precedence (no recursion, one token test per
        // operand).
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
    })
    .boxed();
    let value = expr.clone().map(|d: Dx| d.expr);

    // ---- Statements ----

    // `{` ... `}`. When the `}` is missing at the end of the file or before an item keyword, that is
    // reported and the block ends there (so the next item still parses).
    let open = just(T::LBrace).map_with(|_, e| span_of(e.span()));
    let close = choice((
        just(T::RBrace).to(None),
        choice((
            end().map_with(|_, e| Some((None, e.span()))),
            one_of(ITEM_KEYWORDS).map_with(|t, e| Some((Some(t), e.span()))),
        ))
        .rewind(),
    ))
    .boxed();
    let check_closed = |open: Span, missing: Option<(Option<Token>, SimpleSpan)>| {
        missing.map(|(found, at)| {
            let found = found.map_or_else(|| "end of input".to_string(), |t| t.to_string());
            Diagnostic::new(Code::Syntax, span_of(at), format!("expected `}}`, found {found}"))
                .with_label("the block is not closed before this")
                .with_secondary(open, "this `{` is never closed")
                .with_help("add the missing `}`")
        })
    };

    // What a broken statement or declaration is skipped to.
    let stmt_skip = skip_statement().map(|span| St { stmt: Some(Stmt { kind: StmtKind::Error, span }), depth: 1 });

    let mut stmt = Recursive::<Indirect<'t, 't, I, St, Extra<Er>>>::declare();

    let block = open
        .clone()
        .then(stmt.clone().repeated().collect::<Vec<St>>())
        .then(close.clone())
        .map_with(move |((open, sts), missing), e| {
            emit(e, check_closed(open, missing));
            let depth = sts.iter().map(|s| s.depth).max().unwrap_or(0);
            let stmts = sts.into_iter().filter_map(|s| s.stmt).collect();
            (Block { stmts, span: span_of(e.span()) }, depth)
        })
        .boxed();

    let annotation = just(T::Colon).ignore_then(ty.clone()).or_not();
    let let_stmt = just(T::Let)
        .ignore_then(ident.clone())
        .then(annotation.clone())
        .then_ignore(just(T::Eq))
        .then(value.clone())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| (StmtKind::Let { mutable: false, name, ty, value: Some(value) }, 0));
    let var_stmt = just(T::Var)
        .ignore_then(ident.clone())
        .then(annotation.clone())
        .then(just(T::Eq).ignore_then(value.clone()).or_not())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| (StmtKind::Let { mutable: true, name, ty, value }, 0));

    // `if c {} else if c {} ... else {}` is parsed by a loop and folded from the right.
    let if_head = just(T::If)
        .ignore_then(value.clone())
        .then(block.clone())
        .map_with(|(cond, then), e| (cond, then, span_of(e.span())));
    let if_stmt = if_head
        .clone()
        .then(just(T::Else).ignore_then(if_head).repeated().collect::<Vec<_>>())
        .then(just(T::Else).ignore_then(block.clone()).or_not())
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
        });

    let for_stmt = just(T::For)
        .ignore_then(ident.clone())
        .then_ignore(just(T::In))
        .then(value.clone())
        .then_ignore(just(T::DotDot))
        .then(value.clone())
        .then(block.clone())
        .map(|(((var, start), end), (body, depth))| (StmtKind::For { var, start, end, body }, depth));

    let return_stmt = just(T::Return)
        .ignore_then(value.clone().or_not())
        .then_ignore(just(T::Semi))
        .map(|e| (StmtKind::Return(e), 0));
    let break_stmt = just(T::Break).then(just(T::Semi)).to((StmtKind::Break, 0));
    let continue_stmt = just(T::Continue).then(just(T::Semi)).to((StmtKind::Continue, 0));
    let block_stmt = block.clone().map(|(b, depth)| (StmtKind::Block(b), depth));

    let assign_op = select_ref! {
        T::Eq => AssignOp::Assign,
        T::PlusEq => AssignOp::Add,
        T::MinusEq => AssignOp::Sub,
        T::StarEq => AssignOp::Mul,
        T::SlashEq => AssignOp::Div,
    };
    let expr_stmt = value.clone().then(assign_op.then(value.clone()).or_not()).then_ignore(just(T::Semi)).map_with(
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
    );
    // A run of over-deep brackets the lexer already reported, standing alone.
    let error_stmt = just(T::Error).then(just(T::Semi).or_not()).to((StmtKind::Error, 0));

    let stmt_inner = choice((
        let_stmt,
        var_stmt,
        if_stmt,
        for_stmt,
        return_stmt,
        break_stmt,
        continue_stmt,
        block_stmt,
        expr_stmt,
        error_stmt,
    ))
    .map_with(|(kind, inner), e| {
        let (st, d) = deepen_stmt(kind, span_of(e.span()), inner);
        emit(e, d);
        st
    })
    .or(just(T::Semi).to(St { stmt: None, depth: 0 }))
    .labelled("statement");
    stmt.define(stmt_inner.recover_with(via_parser(stmt_skip)).boxed());

    // ---- Pipeline functions ----

    let state_decl = just(T::State)
        .ignore_then(ident.clone())
        .then_ignore(just(T::Colon))
        .then(ty.clone())
        .then(just(T::Eq).ignore_then(value.clone()).or_not())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), default)| DeclKind::State { ray: false, name, ty, default });
    let uniform_decl = just(T::Uniform)
        .ignore_then(ident.clone())
        .then_ignore(just(T::Colon))
        .then(ty.clone())
        .then(just(T::Eq).ignore_then(value.clone()).or_not())
        .then(just(T::In).ignore_then(value.clone()).then_ignore(just(T::DotDot)).then(value.clone()).or_not())
        .then_ignore(just(T::Semi))
        .map(|(((name, ty), default), range)| DeclKind::Uniform { name, ty, default, range });
    let use_decl = just(T::Use)
        .ignore_then(ident.clone().separated_by(just(T::Comma)).at_least(1).allow_trailing().collect::<Vec<_>>())
        .then_ignore(just(T::Semi))
        .map(|names| DeclKind::Use { names });
    let decl = choice((state_decl, uniform_decl, use_decl)).labelled("declaration");

    let attribute = select_ref! { T::Attribute(name) = e => (name.clone(), span_of(e.span())) };
    let entry = attribute.or_not().then(choice((decl.map(Ok), stmt.clone().map(Err)))).map_with(|(attr, entry), e| {
        let span = span_of(e.span());
        let mut entry = match entry {
            Ok(kind) => Entry::Decl(Decl { kind, doc: None, span }),
            Err(st) => Entry::Stmt(st),
        };
        if let Some((name, at)) = attr {
            if name != "ray" {
                e.emit(Er::diagnostic(
                    Diagnostic::new(Code::UnknownAttribute, at, format!("unknown attribute `@{name}`"))
                        .with_label("not a VRS attribute")
                        .with_help("the only attribute is `@ray`, on `state` declarations"),
                ));
            } else if let Entry::Decl(Decl { kind: DeclKind::State { ray, .. }, .. }) = &mut entry {
                *ray = true;
            } else if !matches!(&entry, Entry::Stmt(St { stmt: Some(Stmt { kind: StmtKind::Error, .. }), .. })) {
                e.emit(Er::diagnostic(
                    Diagnostic::new(Code::Syntax, at, "`@ray` applies only to `state` declarations")
                        .with_label("not allowed here")
                        .with_help("remove it, or declare a field: `@ray state NAME: TYPE;`"),
                ));
            }
        }
        entry
    });
    let body = open.then(entry.repeated().collect::<Vec<Entry>>()).then(close).map_with(
        move |((open, entries), missing), e| {
            emit(e, check_closed(open, missing));
            let mut decls = Vec::new();
            let mut stmts = Vec::new();
            let mut first_stmt: Option<Span> = None;
            for entry in entries {
                match entry {
                    Entry::Decl(decl) => {
                        if let Some(first) = first_stmt {
                            e.emit(Er::diagnostic(
                                Diagnostic::new(
                                    Code::DeclarationAfterStatement,
                                    decl.span,
                                    "declaration after the first statement",
                                )
                                .with_label("declarations must come before the statements")
                                .with_secondary(first, "the first statement")
                                .with_help("move this declaration above the first statement"),
                            ));
                        }
                        decls.push(decl);
                    }
                    Entry::Stmt(St { stmt: Some(stmt), .. }) => {
                        if first_stmt.is_none() && !matches!(stmt.kind, StmtKind::Error) {
                            first_stmt = Some(stmt.span);
                        }
                        stmts.push(stmt);
                    }
                    Entry::Stmt(St { stmt: None, .. }) => {}
                }
            }
            (decls, Block { stmts, span: span_of(e.span()) })
        },
    );

    // `shading.lights`, `classification.additional[$]`
    let step_path = ident
        .clone()
        .separated_by(just(T::Dot))
        .at_least(1)
        .collect::<Vec<_>>()
        .then(ident.clone().delimited_by(just(T::LBracket), just(T::RBracket)).or_not())
        .map_with(|(segments, substep), e| StepPath { segments, substep, span: span_of(e.span()) });
    let when_active = just(T::When).then(just(T::Active)).or_not().map(|w| w.is_some());
    let placement = choice((
        just(T::In).to(PlacementKind::In),
        just(T::Before).to(PlacementKind::Before),
        just(T::After).to(PlacementKind::After),
        just(T::Replace).to(PlacementKind::Replace),
    ))
    .then(step_path.clone())
    .then(when_active.clone())
    .map_with(|((kind, target), when_active), e| Placement { kind, target, when_active, span: span_of(e.span()) });

    // ---- Items ----

    let string = select_ref! { T::Str(path) = e => Import::Path { path: path.clone(), span: span_of(e.span()) } }
        .labelled("string literal");
    let std_path = select_ref! { T::Ident(name) if name == "std" => () }
        .labelled("`std`")
        .ignore_then(just(T::ColonColon).ignore_then(ident.clone()).repeated().at_least(1).collect::<Vec<_>>())
        .map(|path| Import::Std { path });
    let import =
        just(T::Import).ignore_then(choice((string, std_path))).then_ignore(just(T::Semi)).map(ItemKind::Import);

    let const_item = just(T::Const)
        .ignore_then(ident.clone())
        .then(annotation)
        .then_ignore(just(T::Eq))
        .then(value.clone())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| ItemKind::Const(ConstItem { name, ty, value }));

    let param = ident.clone().then_ignore(just(T::Colon)).then(ty.clone()).map_with(|(name, ty), e| Param {
        name,
        ty,
        span: span_of(e.span()),
    });
    let lib_fn = just(T::Lib)
        .ignore_then(just(T::Fn))
        .ignore_then(ident.clone())
        .then(
            param
                .separated_by(just(T::Comma))
                .allow_trailing()
                .collect::<Vec<_>>()
                .delimited_by(just(T::LParen), just(T::RParen)),
        )
        .then(just(T::Arrow).ignore_then(ty.clone()).or_not())
        .then(block)
        .map(|(((name, params), ret), (body, _))| ItemKind::LibFn(LibFn { name, params, ret, body }));

    let pipeline = just(T::Pipeline)
        .ignore_then(ident.clone())
        .then(placement)
        .then(body)
        .map(|((name, placement), (decls, body))| ItemKind::Pipeline(PipelineFn { name, placement, decls, body }));

    let remove = just(T::Remove)
        .ignore_then(step_path)
        .then(when_active)
        .then_ignore(just(T::Semi))
        .map(|(target, when_active)| ItemKind::Remove(Remove { target, when_active }));

    // A broken item is skipped up to the next item keyword outside brackets.
    let item = choice((import, const_item, lib_fn, pipeline, remove))
        .map_with(|kind, e| Some(Item { kind, doc: None, span: span_of(e.span()) }))
        .recover_with(via_parser(skip_item()));

    item.repeated().collect::<Vec<Option<Item>>>().map(|items| items.into_iter().flatten().collect())
}

/// Fills the `doc` of items and declarations from the doc comments the lexer kept.
fn attach_docs(items: &mut [Item], docs: &FxHashMap<u32, String>) {
    if docs.is_empty() {
        return;
    }
    for item in items {
        item.doc = docs.get(&item.span.start).cloned();
        if let ItemKind::Pipeline(p) = &mut item.kind {
            for decl in &mut p.decls {
                decl.doc = docs.get(&decl.span.start).cloned();
            }
        }
    }
}

/// Turns chumsky's errors into diagnostics: one per spot, and none that only repeats a lexical
/// error (a syntax error right after characters the lexer dropped, or at a token the lexer
/// already reported).
fn report(errors: Vec<ParseError<'_>>, tokens: &[(Token, Span)], diags: &mut Diagnostics) {
    let dropped: Vec<Span> = diags
        .iter()
        .filter(|d| matches!(d.code, Code::InvalidCharacter | Code::UnterminatedComment))
        .map(|d| d.span)
        .collect();
    // Whether lexed-away input lies between the token before `at` and `at`.
    let after_dropped = |at: u32| {
        let index = tokens.partition_point(|(_, s)| s.start < at);
        let Some(prev) = index.checked_sub(1).and_then(|i| tokens.get(i)) else { return false };
        dropped.iter().any(|d| d.start >= prev.1.end && d.start < at)
    };
    let mut syntax_at: FxHashSet<u32> = FxHashSet::default();
    let mut others: Vec<Diagnostic> = Vec::new();
    for err in errors {
        let Some(d) = to_diagnostic(err) else { continue };
        if d.code == Code::Syntax {
            if !syntax_at.insert(d.span.start) || after_dropped(d.span.start) {
                continue;
            }
        } else if others.contains(&d) {
            continue;
        } else {
            others.push(d.clone());
        }
        diags.push(d);
    }
}

/// `None` for an error at a token that stands for input the lexer already reported.
fn to_diagnostic(err: ParseError<'_>) -> Option<Diagnostic> {
    let span = span_of(*err.span());
    match err.into_reason() {
        RichReason::Custom(d) => Some(*d),
        RichReason::ExpectedFound { expected, found } => {
            let found = found.as_deref();
            if found == Some(&Token::Error) {
                return None;
            }
            let found_text = found.map_or_else(|| "end of input".to_string(), Token::to_string);
            let list = expected_list(&expected);
            let (message, label) = match list.len() {
                0 => (format!("unexpected {found_text}"), "unexpected here".to_string()),
                n if n <= MAX_EXPECTED => {
                    let list = join_or(&list);
                    (format!("expected {list}, found {found_text}"), format!("expected {list}"))
                }
                _ => {
                    let shown = list[..MAX_EXPECTED].join(", ");
                    (format!("unexpected {found_text}"), format!("expected one of {shown}, ..."))
                }
            };
            Some(Diagnostic::new(Code::Syntax, span, message).with_label(label))
        }
    }
}

fn expected_list(expected: &[RichPattern<'_, Token>]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for p in expected {
        let text = match p {
            RichPattern::Token(t) => t.to_string(),
            RichPattern::Label(l) => l.to_string(),
            RichPattern::Identifier(i) => format!("`{i}`"),
            RichPattern::Any => "a token".to_string(),
            RichPattern::EndOfInput => "end of input".to_string(),
            _ => continue,
        };
        if !out.contains(&text) {
            out.push(text);
        }
    }
    out
}

/// `a`, `a or b`, `a, b or c`.
fn join_or(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lexer::{IntSuffix, lex};

    fn parse(src: &str) -> (Module, Vec<Diagnostic>) {
        let mut diags = Diagnostics::new();
        let lexed = lex(src, 0, &mut diags);
        let module = parse_module(&lexed, 0, src.len() as u32, &mut diags);
        (module, diags.iter().cloned().collect())
    }

    /// The tokens of `src` as the grammar takes them.
    fn grammar_tokens(src: &str) -> Vec<(Token, SimpleSpan)> {
        let lexed = lex(src, 0, &mut Diagnostics::new());
        lexed.tokens.iter().map(|(t, s)| (t.clone(), SimpleSpan::from(s.start as usize..s.end as usize))).collect()
    }

    #[test]
    fn the_fast_pass_builds_the_tree_the_reporting_pass_builds() {
        let snippets = [
            "const K: f32 = -(1.0 + 2.0) * 3.0;",
            "lib fn f(v: vec3<f32>, m: mat4x4f) -> f32 { var s = 0.0; for i in 0..3 { s += v[i]; } return s; }",
            "pipeline p before shading.lights[$] when active { state c: vec4f = vec4f(1.0); c = c.xyzw * 2.0; if c.x > 1.0 { return; } else if c.y < 0.0 { c.z = 0.0; } }",
            "remove shading.lights[key]; import \"a.vrs\"; import std::math;",
        ];
        let std = crate::stdlib::modules().map(|(_, src)| src);
        let broken = ["lib fn f( { }", "pipeline p after x { let a = ; }"];
        for src in snippets.into_iter().chain(std).chain(broken) {
            let tokens = grammar_tokens(src);
            let input = || tokens.as_slice().split_token_span(SimpleSpan::from(src.len()..src.len()));
            let fast = module_parser::<_, EmptyErr>().parse(input());
            let full = module_parser::<_, ParseError>().parse(input());
            let valid = !broken.contains(&src);
            assert_eq!((fast.has_errors(), full.has_errors()), (!valid, !valid), "validity of {src}");
            if valid {
                assert_eq!(
                    format!("{:?}", fast.output()),
                    format!("{:?}", full.output()),
                    "the passes disagree on {src}"
                );
            }
        }
    }

    /// Parses input that must have no diagnostics.
    fn parse_ok(src: &str) -> Module {
        let (module, diags) = parse(src);
        assert!(diags.is_empty(), "unexpected diagnostics for {src:?}: {diags:#?}");
        module
    }

    fn line_of(src: &str, offset: u32) -> usize {
        src[..offset as usize].matches('\n').count() + 1
    }

    /// The lines and codes of the diagnostics.
    fn errors(src: &str) -> Vec<(usize, Code)> {
        parse(src).1.iter().map(|d| (line_of(src, d.span.start), d.code)).collect()
    }

    /// S-expression form of an expression, for precedence tests.
    fn show(e: &Expr) -> String {
        match &e.kind {
            ExprKind::Int { value, suffix } => {
                let s = match suffix {
                    Some(IntSuffix::I) => "i",
                    Some(IntSuffix::U) => "u",
                    None => "",
                };
                format!("{}{s}", value.map_or("?".to_string(), |v| v.to_string()))
            }
            ExprKind::Float { value, suffixed } => format!("{value:?}{}", if *suffixed { "f" } else { "" }),
            ExprKind::Bool(b) => b.to_string(),
            ExprKind::Name(n) => n.name.clone(),
            ExprKind::State(n) => format!("state.{}", n.name),
            ExprKind::Member { base, member } => format!("{}.{}", show(base), member.name),
            ExprKind::Index { base, index } => format!("{}[{}]", show(base), show(index)),
            ExprKind::Call { callee, generics, args } => {
                let g = if generics.is_empty() {
                    String::new()
                } else {
                    format!("<{}>", generics.iter().map(show_ty).collect::<Vec<_>>().join(", "))
                };
                format!("{}{g}({})", callee.name, args.iter().map(show).collect::<Vec<_>>().join(", "))
            }
            ExprKind::Unary { op, operand } => {
                format!("({} {})", if *op == UnaryOp::Neg { "-" } else { "!" }, show(operand))
            }
            ExprKind::Binary { op, lhs, rhs } => format!("({} {} {})", op.symbol(), show(lhs), show(rhs)),
            ExprKind::Error => "<error>".to_string(),
        }
    }

    fn show_ty(t: &TypeExpr) -> String {
        if t.args.is_empty() {
            t.name.name.clone()
        } else {
            format!("{}<{}>", t.name.name, t.args.iter().map(show_ty).collect::<Vec<_>>().join(", "))
        }
    }

    /// The statements of `lib fn f() { BODY }`.
    fn body(src_body: &str) -> Vec<Stmt> {
        let src = format!("lib fn f() {{ {src_body} }}");
        let module = parse_ok(&src);
        match module.items.into_iter().next().map(|i| i.kind) {
            Some(ItemKind::LibFn(f)) => f.body.stmts,
            other => panic!("not a lib fn: {other:?}"),
        }
    }

    /// One expression, parsed as `let v = EXPR;`.
    fn expr(text: &str) -> String {
        match body(&format!("let v = {text};")).into_iter().next().map(|s| s.kind) {
            Some(StmtKind::Let { value: Some(value), .. }) => show(&value),
            other => panic!("not a let: {other:?}"),
        }
    }

    fn pipeline(src: &str) -> PipelineFn {
        match parse_ok(src).items.into_iter().next().map(|i| i.kind) {
            Some(ItemKind::Pipeline(p)) => p,
            other => panic!("not a pipeline: {other:?}"),
        }
    }

    fn path_text(p: &StepPath) -> String {
        match &p.substep {
            Some(s) => format!("{}[{}]", p.step_name(), s.name),
            None => p.step_name(),
        }
    }

    // ---- Items ----

    #[test]
    fn imports() {
        let src = "import \"lib/geom.vrs\";\nimport std::shading;\nimport \"a\\\"b\\\\c\";";
        let m = parse_ok(src);
        assert_eq!(m.items.len(), 3);
        match &m.items[0].kind {
            ItemKind::Import(Import::Path { path, span }) => {
                assert_eq!(path, "lib/geom.vrs");
                assert_eq!(&src[span.start as usize..span.end as usize], "\"lib/geom.vrs\"");
            }
            other => panic!("{other:?}"),
        }
        match &m.items[1].kind {
            ItemKind::Import(Import::Std { path }) => {
                assert_eq!(path.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["shading"]);
            }
            other => panic!("{other:?}"),
        }
        match &m.items[2].kind {
            ItemKind::Import(Import::Path { path, .. }) => assert_eq!(path, "a\"b\\c"),
            other => panic!("{other:?}"),
        }
        assert_eq!(errors("import foo::bar;"), vec![(1, Code::Syntax)]);
        assert_eq!(errors("import std;"), vec![(1, Code::Syntax)]);
    }

    #[test]
    fn consts() {
        let m = parse_ok("const PI: f32 = 3.5;\nconst N = 2 * 3;\nconst V: vec3<f32> = vec3<f32>(1.0);");
        let consts: Vec<&ConstItem> = m
            .items
            .iter()
            .map(|i| match &i.kind {
                ItemKind::Const(c) => c,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(consts[0].name.name, "PI");
        assert_eq!(consts[0].ty.as_ref().map(show_ty).as_deref(), Some("f32"));
        assert_eq!(show(&consts[0].value), "3.5");
        assert!(consts[1].ty.is_none());
        assert_eq!(show(&consts[1].value), "(* 2 3)");
        assert_eq!(consts[2].ty.as_ref().map(show_ty).as_deref(), Some("vec3<f32>"));
        assert_eq!(show(&consts[2].value), "vec3<f32>(1.0)");
    }

    #[test]
    fn lib_functions() {
        let src =
            "/// Doc line one.\n/// Two.\nlib fn add(a: f32, b: vec3<f32>,) -> f32 { return a; }\nlib fn none() {}";
        let m = parse_ok(src);
        let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
        assert_eq!(m.items[0].doc.as_deref(), Some("Doc line one.\nTwo."));
        assert_eq!(f.name.name, "add");
        assert_eq!(f.params.len(), 2);
        assert_eq!(f.params[1].name.name, "b");
        assert_eq!(show_ty(&f.params[1].ty), "vec3<f32>");
        assert_eq!(&src[f.params[0].span.start as usize..f.params[0].span.end as usize], "a: f32");
        assert_eq!(f.ret.as_ref().map(show_ty).as_deref(), Some("f32"));
        assert_eq!(f.body.stmts.len(), 1);
        let item_text = &src[m.items[0].span.start as usize..m.items[0].span.end as usize];
        assert!(item_text.starts_with("lib fn add") && item_text.ends_with('}'));
        let ItemKind::LibFn(g) = &m.items[1].kind else { panic!() };
        assert!(g.params.is_empty() && g.ret.is_none() && g.body.stmts.is_empty());
        assert_eq!(m.items[1].doc, None);
    }

    #[test]
    fn placements() {
        let cases = [
            ("in start", PlacementKind::In, "start", false),
            ("before shading.lights", PlacementKind::Before, "shading.lights", false),
            ("after classification.additional[$]", PlacementKind::After, "classification.additional[$]", false),
            (
                "replace compositing.primary_color[dvr] when active",
                PlacementKind::Replace,
                "compositing.primary_color[dvr]",
                true,
            ),
            ("after compositing when active", PlacementKind::After, "compositing", true),
            ("before ray.setup[gm]", PlacementKind::Before, "ray.setup[gm]", false),
            ("in sampling.additional when active", PlacementKind::In, "sampling.additional", true),
        ];
        for (text, kind, path, active) in cases {
            let src = format!("pipeline p_$ {text} {{}}");
            let p = pipeline(&src);
            assert_eq!(p.name.name, "p_$");
            assert_eq!(p.placement.kind, kind, "{text}");
            assert_eq!(path_text(&p.placement.target), path, "{text}");
            assert_eq!(p.placement.when_active, active, "{text}");
            assert_eq!(&src[p.placement.span.start as usize..p.placement.span.end as usize], text);
        }
    }

    #[test]
    fn removes() {
        let m = parse_ok("remove shading.tone;\nremove classification.additional[gm] when active;\nremove start;");
        let removes: Vec<&Remove> = m
            .items
            .iter()
            .map(|i| match &i.kind {
                ItemKind::Remove(r) => r,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(path_text(&removes[0].target), "shading.tone");
        assert!(!removes[0].when_active);
        assert_eq!(path_text(&removes[1].target), "classification.additional[gm]");
        assert_eq!(removes[1].target.substep.as_ref().map(|s| s.name.as_str()), Some("gm"));
        assert!(removes[1].when_active);
        assert_eq!(removes[2].target.segments.len(), 1);
        assert_eq!(errors("remove shading.tone when;"), vec![(1, Code::Syntax)]);
    }

    #[test]
    fn declarations_with_docs() {
        let src = "pipeline clip_$ after classification.additional[$] when active {
    /// The clip plane.
    /// (normal, offset)
    uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;
    uniform strength: f32;
    state pos: vec3f;
    /// Ray accumulator.
    @ray state hits: u32 = 0u;
    use plane_distance, other,;
    state.pos = state.pos;
}";
        let p = pipeline(src);
        assert_eq!(p.decls.len(), 5);
        assert_eq!(p.decls[0].doc.as_deref(), Some("The clip plane.\n(normal, offset)"));
        match &p.decls[0].kind {
            DeclKind::Uniform { name, ty, default, range } => {
                assert_eq!(name.name, "clip_plane_$");
                assert_eq!(show_ty(ty), "vec4f");
                assert_eq!(default.as_ref().map(show).as_deref(), Some("vec4f(1.0, 0.0, 0.0, (- 0.5))"));
                let (lo, hi) = range.as_ref().expect("range");
                assert_eq!((show(lo), show(hi)), ("(- 1.0)".to_string(), "1.0".to_string()));
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(&p.decls[1].kind, DeclKind::Uniform { default: None, range: None, .. }));
        assert_eq!(p.decls[1].doc, None);
        assert!(matches!(&p.decls[2].kind, DeclKind::State { ray: false, default: None, .. }));
        match &p.decls[3].kind {
            DeclKind::State { ray, name, default, .. } => {
                assert!(*ray);
                assert_eq!(name.name, "hits");
                assert_eq!(default.as_ref().map(show).as_deref(), Some("0u"));
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(p.decls[3].doc.as_deref(), Some("Ray accumulator."));
        assert!(src[p.decls[3].span.start as usize..].starts_with("@ray state hits"));
        match &p.decls[4].kind {
            DeclKind::Use { names } => {
                assert_eq!(names.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(), ["plane_distance", "other"])
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(p.body.stmts.len(), 1);
    }

    #[test]
    fn declaration_after_statement_is_e0106() {
        let src = "pipeline p in start {\n    state a: f32;\n    state.a = 1.0;\n    uniform u: f32;\n    use f;\n}";
        let (m, diags) = parse(src);
        let codes: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
        assert_eq!(codes, vec![(4, Code::DeclarationAfterStatement), (5, Code::DeclarationAfterStatement)]);
        let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
        assert_eq!(p.decls.len(), 3, "still recorded");
        assert_eq!(p.body.stmts.len(), 1);
        assert_eq!(diags[0].secondary.len(), 1);
    }

    #[test]
    fn attributes() {
        let src = "pipeline p in start {\n    @foo state a: f32;\n    @ray uniform u: f32;\n    @ray state b: f32;\n}";
        let (m, diags) = parse(src);
        let codes: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
        assert_eq!(codes, vec![(2, Code::UnknownAttribute), (3, Code::Syntax)]);
        assert!(diags[0].message.contains("@foo"));
        let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
        assert_eq!(p.decls.len(), 3);
        assert!(matches!(p.decls[0].kind, DeclKind::State { ray: false, .. }));
        assert!(matches!(p.decls[2].kind, DeclKind::State { ray: true, .. }));
    }

    // ---- Statements ----

    #[test]
    fn statements() {
        let stmts = body(
            "let a = 1; let b: f32 = 2.0; var c: i32; var d = 3;
             c = 1; c += 1; c -= 1; c *= 2; c /= 2; state.color.a = 0.0; v[0].x = 1.0;
             f(a, b,); { let e = 1; } ; return; return a + 1; break; continue;",
        );
        let kinds: Vec<String> = stmts
            .iter()
            .map(|s| match &s.kind {
                StmtKind::Let { mutable, name, ty, value } => format!(
                    "{} {}{}{}",
                    if *mutable { "var" } else { "let" },
                    name.name,
                    ty.as_ref().map(|t| format!(": {}", show_ty(t))).unwrap_or_default(),
                    value.as_ref().map(|v| format!(" = {}", show(v))).unwrap_or_default()
                ),
                StmtKind::Assign { target, op, value } => format!("{} {op:?} {}", show(target), show(value)),
                StmtKind::Expr(e) => format!("expr {}", show(e)),
                StmtKind::Block(b) => format!("block {}", b.stmts.len()),
                StmtKind::Return(e) => format!("return {}", e.as_ref().map(show).unwrap_or_default()),
                StmtKind::Break => "break".into(),
                StmtKind::Continue => "continue".into(),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(
            kinds,
            [
                "let a = 1",
                "let b: f32 = 2.0",
                "var c: i32",
                "var d = 3",
                "c Assign 1",
                "c Add 1",
                "c Sub 1",
                "c Mul 2",
                "c Div 2",
                "state.color.a Assign 0.0",
                "v[0].x Assign 1.0",
                "expr f(a, b)",
                "block 1",
                "return ",
                "return (+ a 1)",
                "break",
                "continue",
            ]
        );
    }

    #[test]
    fn if_else_chains() {
        let src = "lib fn f() { if a { x(); } else if (b) { y(); } else if c { } else { z(); } if d {} }";
        let m = parse_ok(src);
        let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
        assert_eq!(f.body.stmts.len(), 2);
        let StmtKind::If { cond, then, otherwise } = &f.body.stmts[0].kind else { panic!() };
        assert_eq!(show(cond), "a");
        assert_eq!(then.stmts.len(), 1);
        let otherwise = otherwise.as_ref().expect("else if");
        assert_eq!(otherwise.stmts.len(), 1);
        let elif = &otherwise.stmts[0];
        assert!(src[elif.span.start as usize..elif.span.end as usize].starts_with("if (b)"));
        assert!(src[elif.span.start as usize..elif.span.end as usize].ends_with("z(); }"));
        let StmtKind::If { cond, otherwise, .. } = &elif.kind else { panic!() };
        assert_eq!(show(cond), "b");
        let StmtKind::If { cond, otherwise, .. } = &otherwise.as_ref().expect("else if").stmts[0].kind else {
            panic!()
        };
        assert_eq!(show(cond), "c");
        assert_eq!(otherwise.as_ref().expect("else").stmts.len(), 1);
        let StmtKind::If { otherwise: None, .. } = &f.body.stmts[1].kind else { panic!() };
    }

    #[test]
    fn for_loops() {
        let stmts = body("for i in 0..n { continue; } for j in a + 1 .. 2u { }");
        let StmtKind::For { var, start, end, body } = &stmts[0].kind else { panic!() };
        assert_eq!((var.name.as_str(), show(start), show(end)), ("i", "0".to_string(), "n".to_string()));
        assert_eq!(body.stmts.len(), 1);
        let StmtKind::For { start, end, .. } = &stmts[1].kind else { panic!() };
        assert_eq!((show(start), show(end)), ("(+ a 1)".to_string(), "2u".to_string()));
    }

    #[test]
    fn non_call_expression_statement_is_an_error() {
        assert_eq!(errors("lib fn f() { x + 1; }"), vec![(1, Code::Syntax)]);
        assert_eq!(errors("lib fn f() { f(x); }"), vec![]);
    }

    // ---- Expressions ----

    #[test]
    fn precedence() {
        assert_eq!(expr("a + b * c"), "(+ a (* b c))");
        assert_eq!(expr("a * b + c"), "(+ (* a b) c)");
        assert_eq!(expr("a - b - c"), "(- (- a b) c)");
        assert_eq!(expr("a < b == c"), "(== (< a b) c)");
        assert_eq!(expr("a < b < c"), "(< (< a b) c)");
        assert_eq!(expr("-a.x"), "(- a.x)");
        assert_eq!(expr("!f(x)[0]"), "(! f(x)[0])");
        assert_eq!(expr("- -a * b"), "(* (- (- a)) b)");
        assert_eq!(
            expr("a || b && c | d ^ e & f == g < h << i + j * k"),
            "(|| a (&& b (| c (^ d (& e (== f (< g (<< h (+ i (* j k))))))))))"
        );
        assert_eq!(expr("a * b % c / d"), "(/ (% (* a b) c) d)");
        assert_eq!(expr("(a + b) * c"), "(* (+ a b) c)");
        assert_eq!(expr("a >> 1u != b"), "(!= (>> a 1u) b)");
        assert_eq!(expr("state.color.rgb * 2.0"), "(* state.color.rgb 2.0)");
        assert_eq!(expr("m[0][1] + v.xyz.x"), "(+ m[0][1] v.xyz.x)");
        assert_eq!(expr("true && !false"), "(&& true (! false))");
        assert_eq!(expr("0x2Au + 7i + 1e-3 + .5 + 2.5e2f"), "(+ (+ (+ (+ 42u 7i) 0.001) 0.5) 250.0f)");
    }

    #[test]
    fn generic_constructors_and_comparisons() {
        assert_eq!(expr("vec3<f32>(1.0, 2.0, x)"), "vec3<f32>(1.0, 2.0, x)");
        assert_eq!(expr("mat4x4<f32>(a)"), "mat4x4<f32>(a)");
        assert_eq!(expr("vec3(1.0)"), "vec3(1.0)");
        assert_eq!(expr("vec4f(c, 1.0)"), "vec4f(c, 1.0)");
        assert_eq!(expr("a < b > (c)"), "(> (< a b) c)");
        assert_eq!(expr("a<b"), "(< a b)");
        assert_eq!(expr("vec3<f32>(x).y < 1.0"), "(< vec3<f32>(x).y 1.0)");
        assert_eq!(errors("lib fn f() { let v = vec3<f32>; }"), vec![(1, Code::Syntax)]);
    }

    #[test]
    fn spans() {
        let src = "lib fn f() { let v = -(a + b).x * g(1, 2); }";
        let stmts = body("let v = -(a + b).x * g(1, 2);");
        let StmtKind::Let { value: Some(value), .. } = &stmts[0].kind else { panic!() };
        let text = |e: &Expr| {
            let offset = "lib fn f() { ".len() as u32;
            src[(e.span.start - offset + 13) as usize..(e.span.end - offset + 13) as usize].to_string()
        };
        assert_eq!(text(value), "-(a + b).x * g(1, 2)");
        let ExprKind::Binary { lhs, rhs, .. } = &value.kind else { panic!() };
        assert_eq!(text(lhs), "-(a + b).x");
        assert_eq!(text(rhs), "g(1, 2)");
        let ExprKind::Unary { operand, .. } = &lhs.kind else { panic!() };
        assert_eq!(text(operand), "(a + b).x");
        let ExprKind::Member { base, .. } = &operand.kind else { panic!() };
        assert_eq!(text(base), "(a + b)");
    }

    // ---- Recovery ----

    #[test]
    fn recovery_reports_each_independent_error() {
        let src = "lib fn one(x: f32) -> f32 {
    return x +;
}

lib fn two(x: f32) -> f32 {
    let y = (x * 2.0;
    return y;
}
";
        let (m, diags) = parse(src);
        let lines: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
        assert_eq!(lines, vec![(2, Code::Syntax), (6, Code::Syntax)], "{diags:#?}");
        assert_eq!(diags[0].message, "expected expression, found `;`");
        assert_eq!(diags[1].message, "expected `)`, found `;`");
        assert_eq!(m.items.len(), 2);
        let ItemKind::LibFn(two) = &m.items[1].kind else { panic!() };
        assert!(matches!(two.body.stmts[0].kind, StmtKind::Error));
        assert!(matches!(two.body.stmts[1].kind, StmtKind::Return(Some(_))));
    }

    #[test]
    fn readable_messages() {
        let (_, diags) = parse("lib fn f() { let x = 1 }");
        assert_eq!(diags.len(), 1);
        assert_eq!(diags[0].message, "expected `;`, found `}`");
        let (_, diags) = parse("lib fn f() { let x = a b; }");
        assert_eq!(diags[0].message, "expected `;`, found identifier `b`");
        let (_, diags) = parse("lib fn f() { g(a b); }");
        assert_eq!(diags[0].message, "expected `,` or `)`, found identifier `b`");
        let (_, diags) = parse("foo");
        assert_eq!(
            diags[0].message,
            "expected `import`, `const`, `lib`, `pipeline` or `remove`, found identifier `foo`"
        );
    }

    #[test]
    fn recovery_at_item_level() {
        let src = "pipeline p inn start { state.x = 1.0; }\nconst A = ;\nlib fn g() { return 1; }\n} }\nremove start;";
        let (m, diags) = parse(src);
        let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
        assert_eq!(lines, vec![1, 2, 4], "{diags:#?}");
        let kinds: Vec<_> = m
            .items
            .iter()
            .map(|i| match i.kind {
                ItemKind::LibFn(_) => "lib",
                ItemKind::Remove(_) => "remove",
                _ => "other",
            })
            .collect();
        assert_eq!(kinds, ["lib", "remove"]);
    }

    #[test]
    fn statement_recovery_skips_to_semicolon_or_block() {
        let src = "lib fn f() {\n  let = 1;\n  if x + { y(); }\n  z();\n  w(;\n}\n";
        let (m, diags) = parse(src);
        let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
        assert_eq!(lines, vec![2, 3, 5], "{diags:#?}");
        let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
        let kinds: Vec<_> = f.body.stmts.iter().map(|s| matches!(s.kind, StmtKind::Error)).collect();
        assert_eq!(kinds, [true, true, false, true]);
    }

    #[test]
    fn unclosed_block_at_end_of_file() {
        let (m, diags) = parse("lib fn f() {\n  if x {\n    let a = 1;\n");
        assert_eq!(diags.len(), 1, "{diags:#?}");
        assert!(diags[0].message.contains("found end of input"));
        assert_eq!(m.items.len(), 1);
        let (_, diags) = parse("pipeline p in start {");
        assert_eq!(diags.len(), 1);
        let (_, diags) = parse("{");
        assert_eq!(diags.len(), 1);
    }

    #[test]
    fn unclosed_block_before_next_item() {
        let src = "lib fn f() {\n  let a = 1;\nlib fn g() { return; }\n";
        let (m, diags) = parse(src);
        let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
        assert_eq!(lines, vec![3]);
        assert_eq!(m.items.len(), 2);
    }

    #[test]
    fn recovery_scans_leave_no_stale_errors() {
        // Recovering from line 2 scans the unbalanced `(` as far as the `}`; that scan must not
        // stand in for the real error on line 3.
        let src = "lib fn f() {\n  let a = (1 +;\n  let b = 2 3;\n}\nlib fn g() { let c = 1 2; }";
        let (_, diags) = parse(src);
        let found: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.message.as_str())).collect();
        assert_eq!(
            found,
            [
                (2, "expected expression, found `;`"),
                (3, "expected `;`, found integer literal"),
                (5, "expected `;`, found integer literal")
            ]
        );
    }

    #[test]
    fn unclosed_block_points_at_its_brace() {
        let src = "pipeline p in start {\n  state x: f32;\nlib fn g() {}";
        let (m, diags) = parse(src);
        assert_eq!(diags.len(), 1);
        assert_eq!(diags[0].message, "expected `}`, found `lib`");
        assert_eq!(&src[diags[0].span.start as usize..diags[0].span.end as usize], "lib");
        assert_eq!(diags[0].secondary.first().map(|(s, _)| s.start), Some(20));
        assert_eq!(m.items.len(), 2);
    }

    #[test]
    fn lexer_errors_are_not_reported_again() {
        let deep = format!("lib fn f() {{ let a = {}1{}; }}", "(".repeat(300), ")".repeat(300));
        let (m, diags) = parse(&deep);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
        assert_eq!(m.items.len(), 1);
        let deep_block = format!("lib fn f() {{ {} {} }}", "{".repeat(300), "}".repeat(300));
        let (_, diags) = parse(&deep_block);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
    }

    #[test]
    fn no_syntax_error_after_dropped_characters() {
        assert_eq!(errors("lib fn f(x: f32) -> f32 {\n    return x # 2.0;\n}"), vec![(2, Code::InvalidCharacter)]);
        assert_eq!(errors("lib fn f() {\n  let a = 1; /* never closed\n}"), vec![(2, Code::UnterminatedComment)]);
        assert_eq!(errors("lib fn f() { let a = 1 }#"), vec![(1, Code::InvalidCharacter), (1, Code::Syntax)]);
    }

    #[test]
    fn spans_are_global_offsets() {
        let src = "remove start;\nlib fn f() { let a = ; }";
        let mut diags = Diagnostics::new();
        let lexed = lex(src, 1000, &mut diags);
        let m = parse_module(&lexed, 3, 1000 + src.len() as u32, &mut diags);
        assert_eq!(m.file, 3);
        assert_eq!((m.items[0].span.start, m.items[0].span.end), (1000, 1013));
        let d: Vec<_> = diags.iter().map(|d| d.span.start).collect();
        assert_eq!(d, vec![1000 + src.find("; }").unwrap_or(0) as u32]);
        let (_, diags) = {
            let src = "lib fn f() {";
            let mut diags = Diagnostics::new();
            let lexed = lex(src, 500, &mut diags);
            (parse_module(&lexed, 0, 500 + src.len() as u32, &mut diags), diags)
        };
        assert_eq!(diags.iter().map(|d| d.span.start).collect::<Vec<_>>(), vec![512]);
    }

    #[test]
    fn garbage_never_panics() {
        let pieces = [
            "(", ")", "{", "}", "[", "]", ";", ",", ".", "..", "$", "state", "uniform", "use", "@ray", "@x", "let",
            "var", "for", "in", "if", "else", "return", "break", "fn", "lib", "pipeline", "remove", "replace", "when",
            "active", "0", "1.0", "vec3", "<", ">", "f32", "+", "-", "!", "=", "+=", "import", "::", "->", ":",
            "\"s\"", "const", "x", "after", "before",
        ];
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..400 {
            let mut src = String::new();
            for _ in 0..60 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                src.push_str(pieces[(seed % pieces.len() as u64) as usize]);
                src.push(' ');
            }
            let _ = parse(&src);
        }
    }

    // ---- Depth ----

    /// Runs `f` on a thread with the default 2 MiB test stack.
    fn on_small_stack(f: impl FnOnce() + Send + 'static) {
        std::thread::Builder::new().stack_size(2 << 20).spawn(f).expect("spawn").join().expect("no overflow");
    }

    #[test]
    fn long_unary_runs_do_not_overflow() {
        on_small_stack(|| {
            let src = format!("lib fn f() -> f32 {{ return {}x; }}", "- ".repeat(20_000));
            let (m, diags) = parse(&src);
            assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
            assert_eq!(m.items.len(), 1);
            let src = format!("lib fn f() -> f32 {{ return {}x; }}", "-".repeat(MAX_DEPTH as usize - 1));
            let (_, diags) = parse(&src);
            assert!(diags.is_empty(), "{diags:?}");
        });
    }

    #[test]
    fn long_operator_chains_do_not_overflow() {
        on_small_stack(|| {
            let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", "+a".repeat(100_000));
            let (m, diags) = parse(&src);
            assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
            let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
            assert!(matches!(f.body.stmts[0].kind, StmtKind::Return(Some(Expr { kind: ExprKind::Error, .. }))));
            let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", "+a".repeat(MAX_DEPTH as usize - 1));
            let (_, diags) = parse(&src);
            assert!(diags.is_empty(), "{diags:?}");
            let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", ".x".repeat(50_000));
            let (_, diags) = parse(&src);
            assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
        });
    }

    #[test]
    fn long_else_if_chains_do_not_overflow() {
        on_small_stack(|| {
            let src = format!("lib fn f() {{ if a {{ }}{} g(); }}", " else if a { }".repeat(50_000));
            let (m, diags) = parse(&src);
            assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
            let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
            assert_eq!(f.body.stmts.len(), 2);
            let src = format!("lib fn f() {{ if a {{ }}{} }}", " else if a { }".repeat(100));
            parse_ok(&src);
        });
    }

    #[test]
    fn deep_brackets_do_not_overflow() {
        on_small_stack(|| {
            let src = format!("lib fn f() {{ let a = {}1{}; }}", "f(".repeat(127), ")".repeat(127));
            parse_ok(&src);
            let src = format!("lib fn f() {{ {} {} }}", "if a {".repeat(120), "}".repeat(120));
            parse_ok(&src);
        });
    }

    #[test]
    fn long_inputs_parse_in_linear_time() {
        let stmt = "state.color = vec4f(state.color.rgb * 0.5 + f(x, y)[1], 1.0);\n";
        let src = format!("pipeline p in start {{\n{}}}", stmt.repeat(5_000));
        let start = std::time::Instant::now();
        let (m, diags) = parse(&src);
        assert!(diags.is_empty());
        let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
        assert_eq!(p.body.stmts.len(), 5_000);
        assert!(start.elapsed().as_secs() < 10, "took {:?}", start.elapsed());
    }

    // ---- Conformance cases ----

    fn vrs_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                vrs_files(&path, out);
            } else if path.extension().is_some_and(|e| e == "vrs") {
                out.push(path);
            }
        }
    }

    #[test]
    fn conformance_cases_parse() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let dirs = [root.join("../../shared/conformance/cases"), root.join("../tests/fixtures")];
        let mut files = Vec::new();
        for dir in &dirs {
            vrs_files(dir, &mut files);
        }
        if files.is_empty() {
            eprintln!("no conformance cases found next to the repository; skipped");
            return;
        }
        for path in files {
            let text = std::fs::read_to_string(&path).expect("readable");
            let (_, diags) = parse(&text);
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let in_ok_folder = path.ancestors().any(|a| {
                a.file_name().is_some_and(|n| n.to_string_lossy().starts_with("ok_"))
                    && a.parent().is_some_and(|p| p.ends_with("cases"))
            });
            if name.starts_with("ok_") || in_ok_folder {
                assert!(diags.is_empty(), "{}: {diags:#?}", path.display());
            }
        }
    }
}
