//! Parser: the tokens of one file to its syntax tree (chumsky).
//!
//! The grammar is one small function per construct: [`expr`] (names, types, expressions),
//! [`stmt`] (statements and blocks), [`decl`] (the declarations and body of a pipeline
//! function), [`item`] (items and the module); [`recovery`] holds the scans that skip broken
//! input and [`report`] the wording of syntax errors. Every grammar function takes its tokens as
//! a [`Tokens`] input and its error type as a [`GrammarError`].
//!
//! Parsing never fails. Errors are reported and recovered from at three levels, so every
//! independent error in a file is reported once:
//!
//! - **expressions**: a broken parenthesised expression, argument list or index is skipped to its
//!   closing bracket (within the statement) and becomes [`ExprKind::Error`](crate::ast::ExprKind::Error);
//! - **statements and declarations**: a broken one is skipped to the next `;` (inclusive) or past
//!   the next balanced `{ ... }`, and becomes [`StmtKind::Error`](crate::ast::StmtKind::Error); a block whose `}` is missing at
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
//! [`depth::MAX_DEPTH`] expression levels and as many statement levels deep (deeper input is E0105
//! and becomes an error node), which bounds the recursion of every later pass, dropping the tree
//! included.

use crate::ast::{Item, ItemKind, Module};
use crate::diag::{Diagnostic, Diagnostics};
use crate::lexer::{Lexed, Token};
use crate::source::{FileId, Span};
use chumsky::error::{EmptyErr, Error};
use chumsky::input::{BorrowInput, Input, MapExtra, ValueInput};
use chumsky::label::LabelError;
use chumsky::prelude::*;
use rustc_hash::FxHashMap;

mod decl;
mod depth;
mod expr;
mod item;
mod recovery;
mod report;
mod stmt;
#[cfg(test)]
mod tests;

/// Tokens that start an item: where item-level recovery resumes, and where an unclosed block ends.
const ITEM_KEYWORDS: [Token; 5] = [Token::Import, Token::Const, Token::Lib, Token::Pipeline, Token::Remove];

/// The error the grammar reports with; `Custom` carries a finished diagnostic (E0105, E0106,
/// E0107, ...).
type ParseError<'t> = Rich<'t, Token, SimpleSpan, Box<Diagnostic>>;
type Extra<Er> = extra::Err<Er>;

/// A grammar rule behind a pointer: the rules that are cloned into many others, and the
/// recursive ones.
type Rule<'t, I, O, Er> = Boxed<'t, 't, I, O, Extra<Er>>;

/// The input every grammar function reads: our tokens with chumsky's spans, borrowed. The one
/// spelling of the bound.
trait Tokens<'t>: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t> {}

impl<'t, I: ValueInput<'t, Token = Token, Span = SimpleSpan> + BorrowInput<'t>> Tokens<'t> for I {}

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
    let fast = item::module::<_, EmptyErr>().parse(input());
    let (items, errors) = if fast.has_errors() {
        item::module::<_, ParseError>().parse(input()).into_output_errors()
    } else {
        (fast.into_output(), Vec::new())
    };
    let mut items = items.unwrap_or_default();
    attach_docs(&mut items, &lexed.docs);
    report::report(errors, &lexed.tokens, diags);
    Module { file, items }
}

fn span_of(s: SimpleSpan) -> Span {
    Span::new(s.start as u32, s.end as u32)
}

/// Reports `d`, if any, from inside a rule.
fn emit<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(e: &mut MapExtra<'t, '_, I, Extra<Er>>, d: Option<Diagnostic>) {
    if let Some(d) = d {
        e.emit(Er::diagnostic(d));
    }
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
