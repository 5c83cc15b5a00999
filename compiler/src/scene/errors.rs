//! Error mapping: TOML's and serde's errors as scene diagnostics that name the table and key.

use super::raw::*;
use super::*;

impl Cx<'_> {
    /// The TOML or serde error as a diagnostic at its span.
    pub(super) fn toml_error(&self, e: &toml::de::Error) -> Diagnostic {
        let span = e.span().map_or(Span::new(self.base, self.base), |r| self.range(r));
        let raw = e.message().trim();
        let offset = e.span().map_or(0, |r| r.start);
        if let Some(rest) = raw.strip_prefix("unknown field `") {
            let key = rest.split('`').next().unwrap_or_default();
            let expected = backticked(rest.get(key.len() + 1..).unwrap_or_default());
            let context = self.keys_context(&expected, offset);
            let mut d = Diagnostic::new(Code::SceneUnknownKey, span, format!("unknown key `{key}` in {context}"))
                .with_label("unknown key");
            if let Some(s) = did_you_mean(key, expected.iter().map(String::as_str)) {
                d = d.with_help(format!("did you mean `{s}`?"));
            }
            if !expected.is_empty() {
                d = d.with_note(format!("expected one of {}", quote_list(&expected)));
            }
            return d;
        }
        if let Some(rest) = raw.strip_prefix("unknown variant `") {
            let value = rest.split('`').next().unwrap_or_default();
            let expected = backticked(rest.get(value.len() + 1..).unwrap_or_default());
            let suggestion = did_you_mean(value, expected.iter().map(String::as_str)).map(String::from);
            return SceneError::from(UnknownValue::Choice { value: value.to_string(), expected, suggestion }).at(span);
        }
        if let Some(rest) = raw.strip_prefix("missing field `") {
            let key = rest.split('`').next().unwrap_or_default();
            let context = self.table_context(offset, key);
            return SceneError::from(Missing::Key { key: key.to_string(), table: context }).at(span);
        }
        if raw.starts_with("data did not match any variant of untagged enum RawChild") {
            let (found, expected) = ("an entry that is neither".into(), "names and `{ filter = \"PATH\" }`".into());
            return SceneError::from(WrongType::Value { key: Some("children".into()), found, expected }).at(span);
        }
        if let Some((found, expected)) = serde_mismatch(raw) {
            let key = self.key_before(offset);
            return SceneError::from(WrongType::Value { key, found, expected }).at(span);
        }
        let (code, label) = (Code::SceneSyntax, "invalid TOML");
        let mut lines = raw.lines().map(str::trim).filter(|l| !l.is_empty());
        let mut message = lines.next().unwrap_or("invalid TOML").to_string();
        let key = e.span().and_then(|r| self.text.get(r)).unwrap_or_default();
        if message == "duplicate key" && !key.is_empty() {
            message = format!("duplicate key `{key}`");
        }
        let mut d = Diagnostic::new(code, span, message).with_label(label);
        for line in lines {
            d = d.with_note(line.to_string());
        }
        d
    }

    /// The key of the `key = value` pair whose value holds `offset`, when it is on the same line.
    pub(super) fn key_before(&self, offset: usize) -> Option<String> {
        let upto = self.text.get(..offset.min(self.text.len()))?;
        let line = &upto[upto.rfind('\n').map_or(0, |i| i + 1)..];
        let before_eq = line[..line.rfind('=')?].trim_end();
        let start =
            before_eq.rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-')).map_or(0, |i| i + 1);
        let key = &before_eq[start..];
        (!key.is_empty()).then(|| key.to_string())
    }

    /// Names the table whose key list is `expected`.
    pub(super) fn keys_context(&self, expected: &[String], offset: usize) -> String {
        let is = |keys: &[&str]| keys.len() == expected.len() && keys.iter().zip(expected).all(|(a, b)| a == b);
        if is(SCENE_KEYS) {
            "the scene's top level".into()
        } else if is(RENDER_KEYS) {
            "[render]".into()
        } else if is(VOLUME_KEYS) {
            "[[volume]]".into()
        } else if is(VIEW_KEYS) {
            "[[view]]".into()
        } else if is(super::mesh::MESH_KEYS) {
            "[[mesh]]".into()
        } else if is(GROUP_KEYS) {
            "[[group]]".into()
        } else if is(super::image::IMAGE_KEYS) {
            "[[image]]".into()
        } else if is(CAMERA_KEYS) {
            "the `camera` of a [[view]]".into()
        } else if is(MODULE_KEYS) {
            self.table_context(offset, "path")
        } else {
            self.header_before(offset).unwrap_or_else(|| "the scene".into())
        }
    }

    /// Names the table around `offset` for an error about `key`.
    pub(super) fn table_context(&self, offset: usize, key: &str) -> String {
        match self.header_before(offset) {
            Some(h) if h == "[[view]]" && (key == "path" || key == "instances") => "a module of a [[view]]".into(),
            Some(h) => h,
            None => "the scene's top level".into(),
        }
    }

    /// The last table header (`[render]`, `[[view]]`) that starts a line before `offset`.
    pub(super) fn header_before(&self, offset: usize) -> Option<String> {
        let upto = self.text.get(..offset.min(self.text.len()))?;
        // Headers cover the line they are on, so include the line holding `offset`.
        let line_end = self.text[upto.len()..].find('\n').map_or(self.text.len(), |i| upto.len() + i);
        self.text[..line_end].lines().rev().find_map(|line| {
            let l = line.trim();
            let (open, close) = if l.starts_with("[[") { ("[[", "]]") } else { ("[", "]") };
            let inner = l.strip_prefix(open)?.split(close).next()?.trim();
            let ok = !inner.is_empty()
                && inner.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | ' ' | '"'));
            let looks_like_number = inner.chars().next().is_some_and(|c| c.is_ascii_digit() || c == '-');
            (ok && !looks_like_number && l.contains(close)).then(|| format!("{open}{inner}{close}"))
        })
    }
}

/// Splits serde's "invalid type: FOUND, expected EXPECTED" (and "invalid value: ...",
/// "invalid length N, expected ...") into plain words: (found, expected).
fn serde_mismatch(message: &str) -> Option<(String, String)> {
    let (found, expected) = if let Some(rest) = message.strip_prefix("invalid type: ") {
        rest.split_once(", expected ")?
    } else if let Some(rest) = message.strip_prefix("invalid value: ") {
        rest.split_once(", expected ")?
    } else if let Some(rest) = message.strip_prefix("invalid length ") {
        let (n, expected) = rest.split_once(", expected ")?;
        let found = if n == "1" { "1 element".to_string() } else { format!("{n} elements") };
        return Some((found, plain_type(expected)));
    } else {
        return None;
    };
    let found = found.replace("map", "a table").replace("sequence", "an array");
    Some((found, plain_type(expected)))
}

/// Serde's and Rust's type words as a scene author reads them.
fn plain_type(expected: &str) -> String {
    match expected {
        "u32" => "a whole number, 0 or more".into(),
        "f32" | "f64" => "a number".into(),
        "a sequence" => "an array".into(),
        "a boolean" => "`true` or `false`".into(),
        other => other.replace("a sequence", "an array").replace("an array of length", "an array of"),
    }
}

/// The backticked words of a serde "expected one of `a`, `b`" tail.
fn backticked(s: &str) -> Vec<String> {
    s.split('`').skip(1).step_by(2).map(String::from).collect()
}

fn quote_list(items: &[String]) -> String {
    items.iter().map(|i| format!("`{i}`")).collect::<Vec<_>>().join(", ")
}
