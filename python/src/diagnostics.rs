//! Diagnostics as Python objects: what `--message-format json` prints, as attributes, and the
//! CLI's text as `str()`.

use pyo3::prelude::*;
use vrsc::diag::{Diagnostic, Severity, render_plain};
use vrsc::source::SourceMap;

/// One diagnostic of the checker or the composer.
#[pyclass(name = "Diagnostic", module = "vrsc", frozen, get_all)]
#[derive(Clone)]
pub struct PyDiagnostic {
    /// `E0201`, `W0005`, ...
    pub code: String,
    /// `"error"` or `"warning"`.
    pub severity: String,
    pub message: String,
    /// The file (as the compiler names it; `<string>` for source text), empty when the
    /// diagnostic has no place.
    pub file: String,
    /// 1-based; 0 when the diagnostic has no place.
    pub line: usize,
    pub column: usize,
    pub end_line: usize,
    pub end_column: usize,
    /// The labels, secondary places (`file:line:column: text`) and notes, as in JSON.
    pub notes: Vec<String>,
    /// The `help:` notes, joined by newlines; `None` without any.
    pub help: Option<String>,
    /// The text the CLI prints for it.
    pub text: String,
}

#[pymethods]
impl PyDiagnostic {
    fn __str__(&self) -> String {
        self.text.clone()
    }

    fn __repr__(&self) -> String {
        format!("<Diagnostic {} {}:{}:{}: {}>", self.code, self.file, self.line, self.column, self.message)
    }

    /// Whether it is an error (else a warning).
    #[getter]
    fn is_error(&self) -> bool {
        self.severity == "error"
    }
}

impl PyDiagnostic {
    pub fn new(d: &Diagnostic, sources: &SourceMap) -> PyDiagnostic {
        let json = d.to_json(sources);
        let help: Vec<&str> = d.notes.iter().filter_map(|n| n.strip_prefix("help: ")).collect();
        PyDiagnostic {
            code: json.code.to_string(),
            severity: match d.severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            }
            .to_string(),
            message: d.message.clone(),
            file: json.file.clone(),
            line: json.line,
            column: json.column,
            end_line: json.end_line,
            end_column: json.end_column,
            notes: json.notes.clone(),
            help: (!help.is_empty()).then(|| help.join("\n")),
            text: render_plain(std::slice::from_ref(d), sources),
        }
    }

    /// `file:line:column` (or the file alone without a line).
    fn place(&self) -> String {
        match (self.file.as_str(), self.line) {
            ("", _) => String::from("(no place)"),
            (file, 0) => file.to_string(),
            (file, line) => format!("{file}:{line}:{}", self.column),
        }
    }
}

/// The diagnostics of a pass in the CLI's order.
pub fn collect(diags: &vrsc::diag::Diagnostics, sources: &SourceMap) -> Vec<PyDiagnostic> {
    diags.sorted().iter().map(|d| PyDiagnostic::new(d, sources)).collect()
}

/// The warnings when there is no error, else a `vrsc.CompileError` carrying every diagnostic.
/// Its text starts with one line per error naming its place (`file:line:column`, and the line
/// in words), then the CLI's rendering of all of them.
pub fn warnings_or_error(py: Python<'_>, list: Vec<PyDiagnostic>) -> PyResult<Vec<PyDiagnostic>> {
    if !list.iter().any(|d| d.is_error()) {
        return Ok(list);
    }
    let mut text = String::new();
    for d in list.iter().filter(|d| d.is_error()) {
        let line = if d.line > 0 { format!(" (line {})", d.line) } else { String::new() };
        text.push_str(&format!("{}{line}: error[{}]: {}\n", d.place(), d.code, d.message));
    }
    text.push('\n');
    for d in &list {
        text.push_str(&d.text);
    }
    let objects: Vec<Py<PyDiagnostic>> = list.into_iter().map(|d| Py::new(py, d)).collect::<PyResult<_>>()?;
    Err(crate::errors::raise(py, "CompileError", (text.trim_end().to_string(), objects)))
}
