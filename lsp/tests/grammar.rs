//! The TextMate grammar (`editors/vscode/syntaxes/vrs.tmLanguage.json`) against the compiler's
//! own lexer, on every `.vrs` file of the repository: every token the lexer produces gets exactly
//! one scope from the grammar, and no character outside whitespace is left unscoped.
//!
//! A small TextMate tokenizer runs the grammar: patterns tried at each position, the earliest
//! match winning (ties go to the first listed), `include`s of the repository, `match` rules with
//! `captures`, and `begin`/`end` rules across lines. Its regexes are fancy-regex, whose syntax
//! covers the subset of Oniguruma the grammar keeps to (classes, groups, `\b`, lookahead).

use fancy_regex::Regex;
use serde_json::Value;
use std::ops::Range;
use std::path::{Path, PathBuf};
use vrsc::lexer::Token;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// A compiled grammar rule.
enum Rule {
    Match { regex: Regex, name: Option<String>, captures: Vec<(usize, String)> },
    Block { begin: Regex, end: Regex, name: String },
}

/// Flattens the grammar's top-level patterns (following `include`s) into rules, in order.
fn rules(grammar: &Value) -> Vec<Rule> {
    let mut out = Vec::new();
    for pattern in grammar["patterns"].as_array().unwrap() {
        flatten(pattern, grammar, &mut out, 0);
    }
    out
}

fn flatten(pattern: &Value, grammar: &Value, out: &mut Vec<Rule>, depth: usize) {
    assert!(depth < 16, "include cycle");
    if let Some(include) = pattern["include"].as_str() {
        let key = include.strip_prefix('#').expect("only repository includes are used");
        let entry = &grammar["repository"][key];
        assert!(!entry.is_null(), "include of a missing repository entry `{key}`");
        for p in entry["patterns"].as_array().unwrap() {
            flatten(p, grammar, out, depth + 1);
        }
        return;
    }
    let name = pattern["name"].as_str().map(String::from);
    if let Some(regex) = pattern["match"].as_str() {
        let captures = pattern["captures"]
            .as_object()
            .map(|caps| {
                caps.iter().map(|(k, v)| (k.parse().unwrap(), v["name"].as_str().unwrap().to_string())).collect()
            })
            .unwrap_or_default();
        out.push(Rule::Match { regex: Regex::new(regex).unwrap(), name, captures });
    } else {
        let begin = Regex::new(pattern["begin"].as_str().unwrap()).unwrap();
        let end = Regex::new(pattern["end"].as_str().unwrap()).unwrap();
        out.push(Rule::Block { begin, end, name: name.expect("a begin/end rule has a name") });
    }
}

/// Scoped regions (byte ranges of the whole text) the grammar gives `text`.
fn tokenize(rules: &[Rule], text: &str) -> Vec<(Range<usize>, String)> {
    let mut regions = Vec::new();
    let mut open_block: Option<(&Regex, &str)> = None;
    let mut line_start = 0;
    for line in text.split_inclusive('\n') {
        let line = line.strip_suffix('\n').unwrap_or(line);
        let mut pos = 0;
        while pos < line.len() {
            if let Some((end, name)) = open_block {
                match end.find_from_pos(line, pos).unwrap() {
                    Some(m) => {
                        regions.push((line_start + pos..line_start + m.end(), name.to_string()));
                        pos = m.end();
                        open_block = None;
                    }
                    None => {
                        regions.push((line_start + pos..line_start + line.len(), name.to_string()));
                        pos = line.len();
                    }
                }
                continue;
            }
            // The earliest match from `pos`; a tie goes to the rule listed first.
            let mut best: Option<(usize, usize, &Rule)> = None;
            for rule in rules {
                let regex = match rule {
                    Rule::Match { regex, .. } => regex,
                    Rule::Block { begin, .. } => begin,
                };
                if let Some(m) = regex.find_from_pos(line, pos).unwrap()
                    && m.end() > m.start()
                    && best.is_none_or(|(start, _, _)| m.start() < start)
                {
                    best = Some((m.start(), m.end(), rule));
                }
            }
            let Some((start, end, rule)) = best else { break };
            match rule {
                Rule::Match { regex, name, captures } => {
                    let caps = regex.captures_from_pos(line, pos).unwrap().unwrap();
                    let mut covered = start;
                    let mut groups: Vec<(Range<usize>, &str)> = captures
                        .iter()
                        .filter_map(|(i, scope)| caps.get(*i).map(|g| (g.start()..g.end(), scope.as_str())))
                        .collect();
                    groups.sort_by_key(|(r, _)| r.start);
                    for (range, scope) in groups {
                        if range.start > covered
                            && let Some(name) = name
                        {
                            regions.push((line_start + covered..line_start + range.start, name.clone()));
                        }
                        regions.push((line_start + range.start..line_start + range.end, scope.to_string()));
                        covered = range.end;
                    }
                    if covered < end
                        && let Some(name) = name
                    {
                        regions.push((line_start + covered..line_start + end, name.clone()));
                    }
                }
                Rule::Block { end: end_regex, name, .. } => {
                    regions.push((line_start + start..line_start + end, name.clone()));
                    open_block = Some((end_regex, name));
                }
            }
            pos = end;
        }
        line_start += line.len() + 1;
    }
    regions
}

fn vrs_files() -> Vec<PathBuf> {
    let root = repo_root();
    let mut files = Vec::new();
    for dir in ["stdlib", "examples", "tests/fixtures"] {
        collect(&root.join(dir), &mut files);
    }
    files.sort();
    files
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e == "vrs") {
            out.push(path);
        }
    }
}

/// The problems the grammar has with `text`, as readable lines.
fn problems(rules: &[Rule], text: &str) -> Vec<String> {
    let regions = tokenize(rules, text);
    let mut diags = vrsc::diag::Diagnostics::new();
    let lexed = vrsc::lexer::lex(text, 0, &mut diags);
    let mut out = Vec::new();
    for (token, span) in &lexed.tokens {
        // The lexer's stand-in for a run of over-deep brackets (E0105) covers many tokens of the
        // text, which the grammar scopes one by one.
        if *token == Token::Error {
            continue;
        }
        let (start, end) = (span.start as usize, span.end as usize);
        let overlapping: Vec<&(Range<usize>, String)> =
            regions.iter().filter(|(r, _)| r.start < end && start < r.end).collect();
        match overlapping.as_slice() {
            [(_, scope)] if scope.starts_with("invalid.") => {
                out.push(format!("token {token} `{}` at {start} is scoped {scope}", &text[start..end]))
            }
            [(r, _)] if r.start <= start && end <= r.end => {}
            [] => out.push(format!("token {token} `{}` at {start} has no scope", &text[start..end])),
            many => out.push(format!(
                "token {token} `{}` at {start} is split across scopes {:?}",
                &text[start..end],
                many.iter().map(|(r, s)| (&text[r.clone()], s)).collect::<Vec<_>>()
            )),
        }
    }
    let mut scoped = vec![false; text.len()];
    for (r, _) in &regions {
        scoped[r.clone()].iter_mut().for_each(|b| *b = true);
    }
    for (i, c) in text.char_indices() {
        if !c.is_whitespace() && !scoped[i] {
            out.push(format!("character `{c}` at {i} is left unscoped"));
        }
    }
    // What the grammar calls illegal is exactly what the lexer rejects (E0101).
    let rejected: Vec<Range<usize>> = diags
        .iter()
        .filter(|d| d.code == vrsc::diag::Code::InvalidCharacter)
        .map(|d| d.span.start as usize..d.span.end as usize)
        .collect();
    for (r, scope) in regions.iter().filter(|(_, s)| s.starts_with("invalid.")) {
        if !rejected.iter().any(|bad| bad.start <= r.start && r.end <= bad.end) {
            out.push(format!("`{}` at {} is scoped {scope} but the lexer accepts it", &text[r.clone()], r.start));
        }
    }
    out
}

fn grammar() -> Vec<Rule> {
    let path = repo_root().join("editors/vscode/syntaxes/vrs.tmLanguage.json");
    let grammar: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(grammar["scopeName"], "source.vrs");
    rules(&grammar)
}

#[test]
fn every_token_of_every_vrs_file_gets_one_scope() {
    let rules = grammar();
    let files = vrs_files();
    assert!(files.len() > 20, "expected the repository's .vrs files, found {}", files.len());
    let mut failures = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for problem in problems(&rules, &text) {
            failures.push(format!("{}: {problem}", file.display()));
        }
    }
    assert!(failures.is_empty(), "{} problems:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn scopes_of_a_pipeline_function() {
    let rules = grammar();
    let text = "/// Doc.\npipeline glow_$ after shading.lights[key] when active {\n    @ray state accum: vec4f = vec4f(0.0);\n    uniform k: f32 = 0x2Au in 0 .. 1.5e2f;\n    for i in 0..3 { state.accum += clamp(k, 0.0, 1.0) * f(\"x\"); } /* end */\n}\n";
    let regions = tokenize(&rules, text);
    let scope_of = |needle: &str| {
        let at = text.find(needle).unwrap();
        regions.iter().find(|(r, _)| r.start == at).map(|(_, s)| s.as_str()).unwrap_or("(none)")
    };
    let shown: Vec<String> = [
        "/// Doc.",
        "pipeline",
        "glow_$",
        "after",
        "shading.lights",
        "key",
        "when",
        "active",
        "@ray",
        "state accum",
        "accum:",
        "vec4f =",
        "0.0)",
        "0x2Au",
        "0 ..",
        "..",
        "1.5e2f",
        "0..3",
        "3 {",
        "state.accum",
        ".accum",
        "+=",
        "clamp",
        "f(\"",
        "\"x\"",
        "/* end */",
    ]
    .iter()
    .map(|needle| format!("{needle:<16} {}", scope_of(needle)))
    .collect();
    insta::assert_snapshot!(shown.join("\n"));
    assert!(problems(&rules, text).is_empty(), "{:?}", problems(&rules, text));
}
