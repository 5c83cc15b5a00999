//! The body of a pipeline function: declarations (`state`, `uniform`, `use`, with an optional
//! attribute), then statements.

use super::depth::{Dx, St};
use super::expr::{ident, value};
use super::stmt::{check_closed, close, open};
use super::{Extra, GrammarError, Rule, Tokens, emit, span_of};
use crate::ast::{Block, Decl, DeclKind, Stmt, StmtKind, TypeExpr};
use crate::diag::{Code, Diagnostic};
use crate::lexer::Token as T;
use crate::source::Span;
use chumsky::prelude::*;

/// One entry of a pipeline function's body.
enum Entry {
    Decl(Decl),
    Stmt(St),
}

/// `{ declarations statements }`: the declarations, and the statements as a block. A
/// declaration after the first statement is E0106.
pub(super) fn body<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
    stmt: Rule<'t, I, St, Er>,
) -> impl Parser<'t, I, (Vec<Decl>, Block), Extra<Er>> + Clone {
    open().then(entry(expr, ty, stmt).repeated().collect::<Vec<Entry>>()).then(close()).map_with(
        move |((open, entries), missing), e| {
            emit(e, check_closed(open, missing));
            let (decls, stmts, late) = split_entries(entries);
            for d in late {
                e.emit(Er::diagnostic(d));
            }
            (decls, Block { stmts, span: span_of(e.span()) })
        },
    )
}

/// Declarations and statements apart, and an E0106 for each declaration after the first
/// statement.
fn split_entries(entries: Vec<Entry>) -> (Vec<Decl>, Vec<Stmt>, Vec<Diagnostic>) {
    let mut decls = Vec::new();
    let mut stmts = Vec::new();
    let mut late = Vec::new();
    let mut first_stmt: Option<Span> = None;
    for entry in entries {
        match entry {
            Entry::Decl(decl) => {
                if let Some(first) = first_stmt {
                    late.push(
                        Diagnostic::new(
                            Code::DeclarationAfterStatement,
                            decl.span,
                            "declaration after the first statement",
                        )
                        .with_label("declarations must come before the statements")
                        .with_secondary(first, "the first statement")
                        .with_help("move this declaration above the first statement"),
                    );
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
    (decls, stmts, late)
}

/// A declaration or a statement, with an optional attribute (`@ray`).
fn entry<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
    stmt: Rule<'t, I, St, Er>,
) -> impl Parser<'t, I, Entry, Extra<Er>> + Clone {
    let attribute = select_ref! { T::Attribute(name) = e => (name.clone(), span_of(e.span())) };
    attribute.or_not().then(choice((declaration(expr, ty).map(Ok), stmt.map(Err)))).map_with(|(attr, entry), e| {
        let span = span_of(e.span());
        let mut entry = match entry {
            Ok(kind) => Entry::Decl(Decl { kind, doc: None, span }),
            Err(st) => Entry::Stmt(st),
        };
        if let Some((name, at)) = attr {
            emit(e, apply_attribute(&mut entry, &name, at));
        }
        entry
    })
}

/// Marks a `state` declaration `@ray`; anything else with an attribute is an error (E0107 for
/// an unknown one), except a statement already broken.
fn apply_attribute(entry: &mut Entry, name: &str, at: Span) -> Option<Diagnostic> {
    if name != "ray" {
        return Some(
            Diagnostic::new(Code::UnknownAttribute, at, format!("unknown attribute `@{name}`"))
                .with_label("not a VRS attribute")
                .with_help("the only attribute is `@ray`, on `state` declarations"),
        );
    }
    if let Entry::Decl(Decl { kind: DeclKind::State { ray, .. }, .. }) = entry {
        *ray = true;
        return None;
    }
    if matches!(entry, Entry::Stmt(St { stmt: Some(Stmt { kind: StmtKind::Error, .. }), .. })) {
        return None;
    }
    Some(
        Diagnostic::new(Code::Syntax, at, "`@ray` applies only to `state` declarations")
            .with_label("not allowed here")
            .with_help("remove it, or declare a field: `@ray state NAME: TYPE;`"),
    )
}

fn declaration<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, DeclKind, Extra<Er>> + Clone {
    choice((state_decl(expr.clone(), ty.clone()), uniform_decl(expr, ty), use_decl())).labelled("declaration")
}

/// `state NAME: TYPE[ = DEFAULT];`
fn state_decl<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, DeclKind, Extra<Er>> + Clone {
    just(T::State)
        .ignore_then(ident())
        .then_ignore(just(T::Colon))
        .then(ty)
        .then(just(T::Eq).ignore_then(value(expr)).or_not())
        .then_ignore(just(T::Semi))
        .map(|((name, ty), default)| DeclKind::State { ray: false, name, ty, default })
}

/// `uniform NAME: TYPE[ = DEFAULT][ in LO..HI];`
fn uniform_decl<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, DeclKind, Extra<Er>> + Clone {
    let range = just(T::In).ignore_then(value(expr.clone())).then_ignore(just(T::DotDot)).then(value(expr.clone()));
    just(T::Uniform)
        .ignore_then(ident())
        .then_ignore(just(T::Colon))
        .then(ty)
        .then(just(T::Eq).ignore_then(value(expr)).or_not())
        .then(range.or_not())
        .then_ignore(just(T::Semi))
        .map(|(((name, ty), default), range)| DeclKind::Uniform { name, ty, default, range })
}

/// `use NAME, ...;`
fn use_decl<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, DeclKind, Extra<Er>> + Clone {
    just(T::Use)
        .ignore_then(ident().separated_by(just(T::Comma)).at_least(1).allow_trailing().collect::<Vec<_>>())
        .then_ignore(just(T::Semi))
        .map(|names| DeclKind::Use { names })
}
