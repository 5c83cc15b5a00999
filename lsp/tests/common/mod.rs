//! A test client: the server on a thread over an in-memory connection, driven by LSP messages.

use lsp_server::{Connection, Message, Notification, Request, RequestId};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

pub struct Client {
    connection: Connection,
    server: Option<std::thread::JoinHandle<Result<(), lsp_server::ProtocolError>>>,
    next_id: i32,
    /// Text replaced in snapshots: (text, placeholder).
    redactions: Vec<(String, String)>,
    /// Notifications received while waiting for a response.
    pub notifications: Vec<Notification>,
}

pub fn uri_of(path: &Path) -> String {
    vrsc_lsp::uri::from_path(path).unwrap().as_str().to_string()
}

/// A copy of `examples/ablation` in a fresh folder (the tests edit files and scenes there).
pub fn ablation_copy() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().canonicalize().unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ablation");
    for entry in std::fs::read_dir(source).unwrap().flatten() {
        if entry.path().is_file() {
            std::fs::copy(entry.path(), root.join(entry.file_name())).unwrap();
        }
    }
    (dir, root)
}

impl Client {
    /// Starts a server and initializes it with `root` as the workspace folder.
    pub fn start(root: &Path) -> (Client, Value) {
        let (server_side, client_side) = Connection::memory();
        let server = std::thread::spawn(move || vrsc_lsp::serve(&server_side));
        let mut redactions = vec![(uri_of(root), "file://$ROOT".to_string())];
        if let Some(std) = vrsc_lsp::stdlib_files::folder() {
            redactions.push((uri_of(std), "file://$STDLIB".to_string()));
        }
        let mut client =
            Client { connection: client_side, server: Some(server), next_id: 0, redactions, notifications: Vec::new() };
        let root_uri = uri_of(root);
        let result = client.request(
            "initialize",
            json!({ "capabilities": {}, "rootUri": root_uri, "workspaceFolders": [{ "uri": root_uri, "name": "ws" }] }),
        );
        client.notify("initialized", json!({}));
        (client, result)
    }

    pub fn notify(&mut self, method: &str, params: Value) {
        self.connection.sender.send(Message::Notification(Notification::new(method.to_string(), params))).unwrap();
    }

    pub fn request(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = RequestId::from(self.next_id);
        self.connection.sender.send(Message::Request(Request::new(id.clone(), method.to_string(), params))).unwrap();
        loop {
            match self.connection.receiver.recv_timeout(Duration::from_secs(60)).expect("no answer from the server") {
                Message::Response(r) if r.id == id => {
                    return r.response_result.unwrap_or_else(|e| panic!("{method} failed: {e:?}"));
                }
                Message::Notification(n) => self.notifications.push(n),
                other => panic!("unexpected message {other:?}"),
            }
        }
    }

    /// The next `publishDiagnostics` for `uri` (earlier ones for other documents are kept).
    pub fn diagnostics(&mut self, uri: &str) -> Value {
        if let Some(i) = self.notifications.iter().position(|n| is_diagnostics_for(n, uri)) {
            return self.notifications.remove(i).params;
        }
        loop {
            match self.connection.receiver.recv_timeout(Duration::from_secs(60)).expect("no diagnostics") {
                Message::Notification(n) if is_diagnostics_for(&n, uri) => return n.params,
                Message::Notification(n) => self.notifications.push(n),
                other => panic!("unexpected message {other:?}"),
            }
        }
    }

    pub fn open(&mut self, uri: &str, text: &str) {
        self.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": uri, "languageId": "vrs", "version": 1, "text": text } }),
        );
    }

    pub fn change(&mut self, uri: &str, version: i32, text: &str) {
        self.notify(
            "textDocument/didChange",
            json!({ "textDocument": { "uri": uri, "version": version }, "contentChanges": [{ "text": text }] }),
        );
    }

    /// A request at the position of the first `needle` in `text` (plus `offset` characters).
    pub fn at(&mut self, method: &str, uri: &str, text: &str, needle: &str, offset: usize) -> Value {
        let position = position_of(text, needle, offset);
        let mut params = json!({ "textDocument": { "uri": uri }, "position": position });
        if method == "textDocument/references" {
            params["context"] = json!({ "includeDeclaration": true });
        }
        self.request(method, params)
    }

    /// `value` as pretty JSON with the test's folders replaced by placeholders.
    /// `value` as pretty JSON with object keys sorted (whatever order serde_json keeps: a
    /// dependency turns on its `preserve_order`), redacted.
    pub fn show(&self, value: &Value) -> String {
        let mut text = serde_json::to_string_pretty(&sorted(value)).unwrap();
        for (from, to) in &self.redactions {
            text = text.replace(from, to);
        }
        text
    }

    /// Shuts the server down; it must end without error.
    pub fn shutdown(mut self) {
        let result = self.request("shutdown", Value::Null);
        assert_eq!(result, Value::Null);
        self.notify("exit", Value::Null);
        let server = self.server.take().unwrap();
        server.join().unwrap().unwrap();
    }
}

fn is_diagnostics_for(n: &Notification, uri: &str) -> bool {
    n.method == "textDocument/publishDiagnostics" && n.params["uri"] == uri
}

/// The LSP position (UTF-16 columns; the test texts are ASCII) of `needle` plus `offset`.
pub fn position_of(text: &str, needle: &str, offset: usize) -> Value {
    let at = text.find(needle).unwrap_or_else(|| panic!("`{needle}` not in the text")) + offset;
    let line = text[..at].matches('\n').count();
    let column = at - text[..at].rfind('\n').map_or(0, |i| i + 1);
    json!({ "line": line, "character": column })
}

/// `value` with the keys of every object in sorted order.
fn sorted(value: &Value) -> Value {
    match value {
        Value::Object(map) => {
            let mut entries: Vec<(&String, &Value)> = map.iter().collect();
            entries.sort_by(|a, b| a.0.cmp(b.0));
            Value::Object(entries.into_iter().map(|(k, v)| (k.clone(), sorted(v))).collect())
        }
        Value::Array(items) => Value::Array(items.iter().map(sorted).collect()),
        other => other.clone(),
    }
}
