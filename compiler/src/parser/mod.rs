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

mod recovery;
mod report;

use recovery::{skip_expr_group, skip_item, skip_statement};
use report::report;

/// The deepest expression tree, and the deepest statement nesting (blocks and `else if` levels),
/// the parser builds. Deeper input is reported (E0105) and replaced by an error node.
pub const MAX_DEPTH: u32 = 256;

/// Depth of a node that replaced a too-deep subtree: enclosing nodes become errors as well,
/// without a second report.
const SATURATED: u32 = MAX_DEPTH + 1;

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

#[cfg(test)]
mod tests;
