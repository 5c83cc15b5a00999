//! Lexer: source text to tokens with global spans (logos).
//!
//! Public face: [`lex`], which turns one file's text into a [`Lexed`] (its [`Token`]s with their
//! spans), and the token type with its literal payloads ([`IntLit`], [`IntSuffix`],
//! [`FloatLit`]). The parser, and the language server's grammar tests, read these.
//!
//! Lexing never stops: a bad character is reported and skipped. Doc comments (`///`) do not
//! become tokens; they are kept beside the stream, keyed by the start of the token they document,
//! so the grammar needs no rule for them. Brackets nested deeper than `MAX_NESTING` (128) are
//! reported and the over-deep run is replaced by one [`Token::Error`], which bounds the recursion
//! of every later pass.

use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::source::Span;
use logos::Logos;
use rustc_hash::FxHashMap;
use std::fmt;

/// Deepest bracket nesting accepted: far beyond hand-written code, far below a stack overflow.
pub(crate) const MAX_NESTING: usize = 128;

/// A token of VRS source (logos).
#[derive(Logos, Clone, Debug, PartialEq)]
#[logos(skip r"[ \t\r\n\f]+")]
pub enum Token {
    /// A name that is not a keyword: `[A-Za-z_$][A-Za-z0-9_$]*` (a `$` makes it a template
    /// name). Type names such as `f32` and `vec3f` are identifiers too.
    #[regex(r"[A-Za-z_$][A-Za-z0-9_$]*", |lex| lex.slice().to_string())]
    Ident(String),
    /// An integer literal: its value and suffix (`i`, `u` or none).
    #[regex(r"[0-9]+[iu]?", int_literal)]
    #[regex(r"0[xX][0-9a-fA-F]+[iu]?", int_literal)]
    Int(IntLit),
    /// `12..`: an integer directly followed by a range operator; split into `Int` + `DotDot`.
    #[regex(r"[0-9]+\.\.", |lex| int_value(lex.slice().trim_end_matches('.')))]
    IntDotDot(IntLit),
    /// A float literal: `1.`, `1.5`, `.5`, `1e3`, `2f`, with an optional exponent and `f` suffix.
    #[regex(r"[0-9]+\.[0-9]*([eE][+-]?[0-9]+)?f?", float_literal)]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?f?", float_literal)]
    #[regex(r"[0-9]+[eE][+-]?[0-9]+f?", float_literal)]
    #[regex(r"[0-9]+f", float_literal)]
    Float(FloatLit),
    /// An attribute such as `@ray`: the name after the `@`.
    #[regex(r"@[A-Za-z_][A-Za-z0-9_]*", |lex| lex.slice()[1..].to_string())]
    Attribute(String),
    /// A string literal (only `import "path";` uses one): its unescaped contents.
    #[regex(r#""([^"\\\n]|\\.)*""#, string_literal)]
    Str(String),

    /// `import`: starts an import item.
    #[token("import")]
    Import,
    /// `const`: starts a constant item.
    #[token("const")]
    Const,
    /// `lib`: starts a library function (`lib fn`).
    #[token("lib")]
    Lib,
    /// `fn`: follows `lib` in a library function.
    #[token("fn")]
    Fn,
    /// `pipeline`: starts a pipeline function.
    #[token("pipeline")]
    Pipeline,
    /// `state`: declares a state field in a pipeline function.
    #[token("state")]
    State,
    /// `uniform`: declares a uniform in a pipeline function.
    #[token("uniform")]
    Uniform,
    /// `use`: lists names a pipeline function reads (`use a, b;`).
    #[token("use")]
    Use,
    /// `remove`: starts a remove item.
    #[token("remove")]
    Remove,
    /// `before`: places a pipeline function just before the target step.
    #[token("before")]
    Before,
    /// `after`: places a pipeline function just after the target step.
    #[token("after")]
    After,
    /// `replace`: places a pipeline function instead of the target step.
    #[token("replace")]
    Replace,
    /// `in`: places a pipeline function into a step; also in `for i in a .. b` and a uniform's range.
    #[token("in")]
    In,
    /// `when`: first word of `when active`.
    #[token("when")]
    When,
    /// `active`: second word of `when active`.
    #[token("active")]
    Active,
    /// `let`: binds an immutable local.
    #[token("let")]
    Let,
    /// `var`: binds a mutable local.
    #[token("var")]
    Var,
    /// `if`: starts a conditional.
    #[token("if")]
    If,
    /// `else`: the alternative of an `if`.
    #[token("else")]
    Else,
    /// `for`: starts a counted loop.
    #[token("for")]
    For,
    /// `break`: leaves the innermost loop.
    #[token("break")]
    Break,
    /// `continue`: goes on with the next iteration.
    #[token("continue")]
    Continue,
    /// `return`: leaves the function.
    #[token("return")]
    Return,
    /// `true`: the boolean literal.
    #[token("true")]
    True,
    /// `false`: the boolean literal.
    #[token("false")]
    False,

    /// `(`: opens arguments, parameters or a parenthesized expression.
    #[token("(")]
    LParen,
    /// `)`: closes what `(` opened.
    #[token(")")]
    RParen,
    /// `{`: opens a block or body.
    #[token("{")]
    LBrace,
    /// `}`: closes what `{` opened.
    #[token("}")]
    RBrace,
    /// `[`: opens an index or a substep.
    #[token("[")]
    LBracket,
    /// `]`: closes what `[` opened.
    #[token("]")]
    RBracket,
    /// `,`: separates arguments, parameters and names.
    #[token(",")]
    Comma,
    /// `;`: ends a statement, declaration or item.
    #[token(";")]
    Semi,
    /// `:`: precedes a type.
    #[token(":")]
    Colon,
    /// `::`: separates the segments of `std::NAME`.
    #[token("::")]
    ColonColon,
    /// `.`: member access, or separates the segments of a step path.
    #[token(".")]
    Dot,
    /// `..`: the range operator (`a .. b`).
    #[token("..")]
    DotDot,
    /// `->`: precedes a function's return type.
    #[token("->")]
    Arrow,
    /// `=`: assignment or initializer.
    #[token("=")]
    Eq,
    /// `+=`: compound assignment.
    #[token("+=")]
    PlusEq,
    /// `-=`: compound assignment.
    #[token("-=")]
    MinusEq,
    /// `*=`: compound assignment.
    #[token("*=")]
    StarEq,
    /// `/=`: compound assignment.
    #[token("/=")]
    SlashEq,
    /// `+`: addition.
    #[token("+")]
    Plus,
    /// `-`: subtraction or negation.
    #[token("-")]
    Minus,
    /// `*`: multiplication.
    #[token("*")]
    Star,
    /// `/`: division.
    #[token("/")]
    Slash,
    /// `%`: remainder.
    #[token("%")]
    Percent,
    /// `<<`: shift left.
    #[token("<<")]
    Shl,
    /// `>>`: shift right.
    #[token(">>")]
    Shr,
    /// `<`: less than, or opens template arguments.
    #[token("<")]
    Lt,
    /// `<=`: less than or equal.
    #[token("<=")]
    Le,
    /// `>`: greater than, or closes template arguments.
    #[token(">")]
    Gt,
    /// `>=`: greater than or equal.
    #[token(">=")]
    Ge,
    /// `==`: equality.
    #[token("==")]
    EqEq,
    /// `!=`: inequality.
    #[token("!=")]
    Ne,
    /// `&`: bitwise and.
    #[token("&")]
    Amp,
    /// `^`: bitwise exclusive or.
    #[token("^")]
    Caret,
    /// `|`: bitwise or.
    #[token("|")]
    Pipe,
    /// `&&`: logical and.
    #[token("&&")]
    AndAnd,
    /// `||`: logical or.
    #[token("||")]
    OrOr,
    /// `!`: logical not.
    #[token("!")]
    Bang,

    /// A `///` line: the text after the slashes. [`lex`] keeps it beside the tokens (for the parser to
    /// attach to the item after it), never in the token stream.
    #[regex(r"///[^\n]*", |lex| lex.slice()[3..].to_string(), allow_greedy = true)]
    DocComment(String),
    /// A `//` or `/* */` comment. Logos skips them, so the stream never holds one.
    #[regex(r"//[^\n]*", logos::skip, allow_greedy = true)]
    #[token("/*", block_comment)]
    Comment,

    /// Stands for input that was already reported (a run of over-deep brackets): the parser
    /// accepts it as an expression without a second diagnostic.
    Error,
}

/// Suffix of a number literal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntSuffix {
    /// `i`: the literal is an `i32`.
    I,
    /// `u`: the literal is a `u32`.
    U,
}

/// An integer literal: its value and suffix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntLit {
    /// `None` when the digits do not fit in 64 bits (reported as E0103).
    pub value: Option<u64>,
    /// `i`, `u`, or `None` without a suffix.
    pub suffix: Option<IntSuffix>,
}

/// A float literal: its value and whether it has the `f` suffix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloatLit {
    /// The value of the digits and exponent.
    pub value: f64,
    /// `true` for an explicit `f` suffix.
    pub suffixed: bool,
}

fn int_value(text: &str) -> IntLit {
    let (digits, suffix) = match text.as_bytes().last() {
        // Neither letter is a hex digit, so a trailing one is always a suffix.
        Some(b'i') => (&text[..text.len() - 1], Some(IntSuffix::I)),
        Some(b'u') => (&text[..text.len() - 1], Some(IntSuffix::U)),
        _ => (text, None),
    };
    let value = match digits.strip_prefix("0x").or_else(|| digits.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => digits.parse::<u64>().ok(),
    };
    IntLit { value, suffix }
}

fn int_literal(lex: &mut logos::Lexer<Token>) -> IntLit {
    int_value(lex.slice())
}

fn float_literal(lex: &mut logos::Lexer<Token>) -> FloatLit {
    let text = lex.slice();
    let suffixed = text.ends_with('f');
    let digits = text.trim_end_matches('f');
    // The regexes only admit valid float syntax, which `f64::from_str` accepts.
    FloatLit { value: digits.parse().unwrap_or(f64::NAN), suffixed }
}

/// The contents of a string literal without its quotes, with `\"`, `\\`, `\n`, `\t` and `\0`
/// unescaped; any other escape is kept as written (so a Windows path survives).
fn string_literal(lex: &mut logos::Lexer<Token>) -> String {
    let text = lex.slice();
    let inner = text.get(1..text.len().saturating_sub(1)).unwrap_or("");
    let mut out = String::with_capacity(inner.len());
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some('0') => out.push('\0'),
            Some('"') => out.push('"'),
            Some('\\') => out.push('\\'),
            Some(other) => {
                out.push('\\');
                out.push(other);
            }
            None => out.push('\\'),
        }
    }
    out
}

/// Skips a block comment; an unterminated one is an error token spanning to the end of input.
fn block_comment(lex: &mut logos::Lexer<Token>) -> logos::FilterResult<(), ()> {
    match lex.remainder().find("*/") {
        Some(end) => {
            lex.bump(end + 2);
            logos::FilterResult::Skip
        }
        None => {
            lex.bump(lex.remainder().len());
            logos::FilterResult::Error(())
        }
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match self {
            Token::Ident(name) => return write!(f, "identifier `{name}`"),
            Token::Int(_) | Token::IntDotDot(_) => "integer literal",
            Token::Float(_) => "float literal",
            Token::Attribute(name) => return write!(f, "`@{name}`"),
            Token::Str(_) => "string literal",
            Token::DocComment(_) => "doc comment",
            Token::Comment => "comment",
            Token::Error => "invalid input",
            other => return write!(f, "`{}`", other.keyword_or_punct()),
        };
        f.write_str(text)
    }
}

impl Token {
    fn keyword_or_punct(&self) -> &'static str {
        use Token::*;
        match self {
            Import => "import",
            Const => "const",
            Lib => "lib",
            Fn => "fn",
            Pipeline => "pipeline",
            State => "state",
            Uniform => "uniform",
            Use => "use",
            Remove => "remove",
            Before => "before",
            After => "after",
            Replace => "replace",
            In => "in",
            When => "when",
            Active => "active",
            Let => "let",
            Var => "var",
            If => "if",
            Else => "else",
            For => "for",
            Break => "break",
            Continue => "continue",
            Return => "return",
            True => "true",
            False => "false",
            LParen => "(",
            RParen => ")",
            LBrace => "{",
            RBrace => "}",
            LBracket => "[",
            RBracket => "]",
            Comma => ",",
            Semi => ";",
            Colon => ":",
            ColonColon => "::",
            Dot => ".",
            DotDot => "..",
            Arrow => "->",
            Eq => "=",
            PlusEq => "+=",
            MinusEq => "-=",
            StarEq => "*=",
            SlashEq => "/=",
            Plus => "+",
            Minus => "-",
            Star => "*",
            Slash => "/",
            Percent => "%",
            Shl => "<<",
            Shr => ">>",
            Lt => "<",
            Le => "<=",
            Gt => ">",
            Ge => ">=",
            EqEq => "==",
            Ne => "!=",
            Amp => "&",
            Caret => "^",
            Pipe => "|",
            AndAnd => "&&",
            OrOr => "||",
            Bang => "!",
            Ident(_) | Int(_) | IntDotDot(_) | Float(_) | Attribute(_) | Str(_) | DocComment(_) | Comment | Error => {
                "?"
            }
        }
    }
}

/// The tokens of one file, its doc comments, and the lexical errors found.
#[derive(Debug, Default)]
pub struct Lexed {
    /// The tokens in source order with their global spans; comments and doc comments are not
    /// among them.
    pub tokens: Vec<(Token, Span)>,
    /// Doc comment text (lines joined with `\n`), keyed by the start of the token it precedes.
    pub(crate) docs: FxHashMap<u32, String>,
}

/// `[A-Za-z_][A-Za-z0-9_]*`: a name the scene gives that becomes part of an identifier (an
/// instance, a volume, a light, a uniform). Unlike the lexer's identifiers, no `$`.
pub(crate) fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether `word` is a VRS keyword: the lexer reads it whole as one token that is not an
/// identifier (so the keyword list is the token definitions).
pub(crate) fn is_keyword(word: &str) -> bool {
    let mut tokens = Token::lexer(word);
    let first = tokens.next();
    let whole = tokens.span() == (0..word.len());
    whole
        && tokens.next().is_none()
        && word.chars().all(|c| c.is_ascii_alphabetic())
        && matches!(first, Some(Ok(t)) if !matches!(t, Token::Ident(_)))
}

/// Lexes `text`, whose first byte has global offset `base`.
pub fn lex(text: &str, base: u32, diags: &mut Diagnostics) -> Lexed {
    let mut out = Lexed::default();
    let mut pending_doc: Vec<String> = Vec::new();
    let mut bad_run: Option<Span> = None;
    let mut lexer = Token::lexer(text);
    while let Some(result) = lexer.next() {
        let r = lexer.span();
        let span = Span::new(base + r.start as u32, base + r.end as u32);
        let token = match result {
            Ok(t) => t,
            Err(()) if lexer.slice().starts_with("/*") => {
                let head = Span::new(span.start, span.start + 2);
                diags.push(
                    Diagnostic::new(Code::UnterminatedComment, head, "unterminated block comment")
                        .with_label("this comment is never closed")
                        .with_help("close it with `*/`"),
                );
                continue;
            }
            Err(()) => {
                bad_run = Some(match bad_run {
                    Some(run) if run.end == span.start => run.to(span),
                    Some(run) => {
                        report_bad_characters(text, base, run, diags);
                        span
                    }
                    None => span,
                });
                continue;
            }
        };
        if let Some(run) = bad_run.take() {
            report_bad_characters(text, base, run, diags);
        }
        match token {
            Token::DocComment(line) => pending_doc.push(line.strip_prefix(' ').unwrap_or(&line).to_string()),
            Token::IntDotDot(lit) => {
                let dots = Span::new(span.end - 2, span.end);
                out.tokens.push((Token::Int(lit), Span::new(span.start, span.end - 2)));
                out.tokens.push((Token::DotDot, dots));
            }
            token => {
                if !pending_doc.is_empty() {
                    out.docs.insert(span.start, pending_doc.join("\n"));
                    pending_doc.clear();
                }
                out.tokens.push((token, span));
            }
        }
    }
    if let Some(run) = bad_run {
        report_bad_characters(text, base, run, diags);
    }
    report_bad_literals(&out.tokens, diags);
    out.tokens = bound_nesting(std::mem::take(&mut out.tokens), diags);
    out
}

fn report_bad_characters(text: &str, base: u32, run: Span, diags: &mut Diagnostics) {
    let shown = text.get((run.start - base) as usize..(run.end - base) as usize).unwrap_or("?");
    let plural = if shown.chars().count() > 1 { "s" } else { "" };
    diags.push(
        Diagnostic::new(Code::InvalidCharacter, run, format!("invalid character{plural} `{shown}`"))
            .with_label("not part of VRS"),
    );
}

fn report_bad_literals(tokens: &[(Token, Span)], diags: &mut Diagnostics) {
    for (token, span) in tokens {
        if let Token::Int(IntLit { value: None, .. }) = token {
            diags.push(
                Diagnostic::new(Code::InvalidLiteral, *span, "integer literal too large")
                    .with_label("does not fit in 64 bits"),
            );
        }
    }
}

/// Replaces each bracket run nested deeper than [`MAX_NESTING`] by one [`Token::Error`].
fn bound_nesting(tokens: Vec<(Token, Span)>, diags: &mut Diagnostics) -> Vec<(Token, Span)> {
    let mut out = Vec::with_capacity(tokens.len());
    let mut depth = 0usize;
    // Start of the run being dropped, while inside one.
    let mut dropping: Option<Span> = None;
    for (token, span) in tokens {
        let opens = matches!(token, Token::LParen | Token::LBracket | Token::LBrace);
        let closes = matches!(token, Token::RParen | Token::RBracket | Token::RBrace);
        if opens {
            depth += 1;
            if depth > MAX_NESTING && dropping.is_none() {
                diags.push(
                    Diagnostic::new(Code::TooDeep, span, format!("brackets nested more than {MAX_NESTING} deep"))
                        .with_label("this bracket is too deep")
                        .with_help("split the expression with `let` bindings, or the code into functions"),
                );
                dropping = Some(span);
            }
        }
        if closes {
            depth = depth.saturating_sub(1);
        }
        match dropping {
            Some(start) if closes && depth == MAX_NESTING => {
                out.push((Token::Error, start.to(span)));
                dropping = None;
            }
            Some(_) => {}
            None => out.push((token, span)),
        }
    }
    if let Some(start) = dropping {
        out.push((Token::Error, start));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<Token> {
        let mut d = Diagnostics::new();
        lex(src, 0, &mut d).tokens.into_iter().map(|(t, _)| t).collect()
    }

    #[test]
    fn literals_with_suffixes() {
        let int = |v, s| Token::Int(IntLit { value: Some(v), suffix: s });
        assert_eq!(
            kinds("42 0x2A 7u 3i 0x2Au"),
            vec![
                int(42, None),
                int(42, None),
                int(7, Some(IntSuffix::U)),
                int(3, Some(IntSuffix::I)),
                int(42, Some(IntSuffix::U))
            ]
        );
        let float = |v, s| Token::Float(FloatLit { value: v, suffixed: s });
        assert_eq!(
            kinds("1.0 .5 1e-3 2.5e2f 1f 3."),
            vec![
                float(1.0, false),
                float(0.5, false),
                float(1e-3, false),
                float(250.0, true),
                float(1.0, true),
                float(3.0, false)
            ]
        );
    }

    #[test]
    fn ranges_split_from_integers() {
        let int = |v| Token::Int(IntLit { value: Some(v), suffix: None });
        assert_eq!(kinds("0..n"), vec![int(0), Token::DotDot, Token::Ident("n".into())]);
    }

    #[test]
    fn identifiers_may_hold_the_wildcard() {
        assert_eq!(
            kinds("clip_$ $ plane_$_a"),
            vec![Token::Ident("clip_$".into()), Token::Ident("$".into()), Token::Ident("plane_$_a".into())]
        );
    }

    #[test]
    fn doc_comments_attach_to_the_next_token() {
        let mut d = Diagnostics::new();
        let lexed = lex("/// one\n/// two\nlib // not doc\n", 10, &mut d);
        assert_eq!(lexed.tokens.len(), 1);
        assert_eq!(lexed.docs.get(&(10 + 16)).map(String::as_str), Some("one\ntwo"));
    }

    #[test]
    fn bad_characters_and_unterminated_comments_are_reported() {
        let mut d = Diagnostics::new();
        let lexed = lex("a ## b /* never", 0, &mut d);
        assert_eq!(lexed.tokens.len(), 2);
        let codes: Vec<_> = d.iter().map(|d| d.code).collect();
        assert_eq!(codes, vec![Code::InvalidCharacter, Code::UnterminatedComment]);
    }

    #[test]
    fn deep_nesting_is_bounded() {
        let src = format!("{}x{}", "(".repeat(5000), ")".repeat(5000));
        let mut d = Diagnostics::new();
        let lexed = lex(&src, 0, &mut d);
        assert_eq!(d.iter().filter(|d| d.code == Code::TooDeep).count(), 1);
        assert_eq!(lexed.tokens.len(), 2 * MAX_NESTING + 1);
        assert_eq!(lexed.tokens[MAX_NESTING].0, Token::Error);
    }

    #[test]
    fn keywords_are_the_keyword_tokens() {
        for word in ["import", "pipeline", "when", "active", "true", "false", "continue"] {
            assert!(is_keyword(word), "{word}");
        }
        for word in ["state_x", "imports", "vec3", "", "if ", "x", "@ray", "1"] {
            assert!(!is_keyword(word), "{word}");
        }
        assert!(is_identifier("gm_2") && !is_identifier("2gm") && !is_identifier("a$") && !is_identifier(""));
    }
}
