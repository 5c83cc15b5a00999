//! Recovery scans: what a broken expression group, statement or item is skipped to.

use super::{Extra, GrammarError, ITEM_KEYWORDS, Tokens, span_of};
use crate::ast::Item;
use crate::diag::{Code, Diagnostic};
use crate::lexer::Token;
use crate::source::Span;
use chumsky::input::{Input, InputRef};
use chumsky::prelude::*;

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
fn skip_group<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    inp: &mut InputRef<'t, '_, I, Extra<Er>>,
    stops: &[Token],
) -> bool {
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
pub(super) fn skip_expr_group<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    open: Token,
) -> impl Parser<'t, I, Span, Extra<Er>> + Clone {
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
pub(super) fn skip_statement<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Span, Extra<Er>> + Clone
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
pub(super) fn skip_item<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>()
-> impl Parser<'t, I, Option<Item>, Extra<Er>> + Clone {
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
