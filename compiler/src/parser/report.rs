//! Chumsky's errors as diagnostics: one per spot, worded in one place.

use super::{ParseError, span_of};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::lexer::Token;
use crate::source::Span;
use chumsky::error::{RichPattern, RichReason};
use rustc_hash::FxHashSet;

/// Most expected tokens listed in a message.
const MAX_EXPECTED: usize = 6;

/// error (a syntax error right after characters the lexer dropped, or at a token the lexer
/// already reported).
pub(super) fn report(errors: Vec<ParseError<'_>>, tokens: &[(Token, Span)], diags: &mut Diagnostics) {
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
