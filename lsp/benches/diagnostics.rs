//! Diagnostics latency after a change: from a `didChange` with the whole text to the
//! `publishDiagnostics` it causes, through the server loop over an in-memory connection.
//! Run: `cargo bench -p vrsc-lsp --bench diagnostics`.
//!
//! Inputs: `examples/ablation/applicator.vrs` in a copy of its folder, so every change also
//! composes the two views of the scene that lists it; and a generated module of 3000 functions
//! (the one `compiler/benches/frontend.rs` compiles) with no scene.

use criterion::{Criterion, criterion_main};
use lsp_server::{Connection, Message, Notification, Request, RequestId};
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;
use std::time::Duration;

// The allocator the `vrsc` binary ships with (see cli/src/main.rs).
#[global_allocator]
static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;

/// 1500 library functions and 1500 pipeline functions that call them.
fn large_module() -> String {
    let mut src = String::new();
    for i in 0..1500 {
        let _ = write!(
            src,
            "/// Helper {i}.\nlib fn helper_{i}(p: vec3f, k: f32) -> vec3f {{\n    var acc = p;\n    for j in 0 .. 4 {{\n        \
             if f32(j) > k {{ break; }}\n        acc = acc * 0.5 + vec3f(f32(j) * {i}.0);\n    }}\n    \
             return normalize(acc + vec3f(k, 1.0, 2.0));\n}}\n\n\
             pipeline step_{i} in shading.tone {{\n    uniform gain_{i}: f32 = 1.5 in 0.0 .. 4.0;\n    \
             state color: vec4f = vec4f(0.0);\n    state pos: vec3f;\n    use helper_{i};\n    \
             let n = helper_{i}(state.pos, gain_{i});\n    if dot(n, vec3f(0.0, 0.0, 1.0)) > 0.5 {{\n        \
             state.color = vec4f(state.color.rgb * gain_{i}, state.color.a);\n    }}\n}}\n\n"
        );
    }
    src
}

/// A server on a thread and the client's end of its connection.
struct Session {
    client: Connection,
    server: Option<std::thread::JoinHandle<Result<(), lsp_server::ProtocolError>>>,
    uri: String,
    version: i32,
}

impl Session {
    fn start(root: &Path, file: &Path, text: &str) -> Session {
        let (server_side, client) = Connection::memory();
        let server = std::thread::spawn(move || vrsc_lsp::serve(&server_side));
        let root_uri = vrsc_lsp::uri::from_path(root).unwrap().as_str().to_string();
        let uri = vrsc_lsp::uri::from_path(file).unwrap().as_str().to_string();
        let session = Session { client, server: Some(server), uri, version: 1 };
        let params = json!({ "capabilities": {}, "workspaceFolders": [{ "uri": root_uri, "name": "bench" }] });
        session.send(Message::Request(Request::new(RequestId::from(1), "initialize".into(), params)));
        session.wait(|m| matches!(m, Message::Response(_)));
        session.notify("initialized", json!({}));
        let doc = json!({ "textDocument": { "uri": session.uri, "languageId": "vrs", "version": 1, "text": text } });
        session.notify("textDocument/didOpen", doc);
        session.wait_diagnostics();
        session
    }

    fn send(&self, message: Message) {
        self.client.sender.send(message).unwrap();
    }

    fn notify(&self, method: &str, params: Value) {
        self.send(Message::Notification(Notification::new(method.into(), params)));
    }

    fn wait(&self, pick: impl Fn(&Message) -> bool) -> Message {
        loop {
            let message = self.client.receiver.recv_timeout(Duration::from_secs(60)).expect("the server answers");
            if pick(&message) {
                return message;
            }
        }
    }

    /// Waits for the diagnostics of the document and returns how many there are.
    fn wait_diagnostics(&self) -> usize {
        let message =
            self.wait(|m| matches!(m, Message::Notification(n) if n.method == "textDocument/publishDiagnostics"));
        let Message::Notification(n) = message else { unreachable!() };
        n.params["diagnostics"].as_array().map_or(0, Vec::len)
    }

    /// Sends `text` as the document's new content and waits for its diagnostics.
    fn change(&mut self, text: &str) -> usize {
        self.version += 1;
        let params = json!({
            "textDocument": { "uri": self.uri, "version": self.version },
            "contentChanges": [{ "text": text }]
        });
        self.notify("textDocument/didChange", params);
        self.wait_diagnostics()
    }

    fn stop(mut self) {
        self.send(Message::Request(Request::new(RequestId::from(2), "shutdown".into(), Value::Null)));
        self.wait(|m| matches!(m, Message::Response(r) if r.id == RequestId::from(2)));
        self.notify("exit", Value::Null);
        self.server.take().unwrap().join().unwrap().unwrap();
    }
}

/// Alternates between two versions of a text (a trailing comment added and removed), as typing
/// does, and measures change to diagnostics.
fn bench_changes(c: &mut Criterion, name: &str, root: &Path, file: &Path, text: &str) {
    let mut session = Session::start(root, file, text);
    let edited = format!("{text}\n// typed\n");
    let expected = session.change(text);
    let mut group = c.benchmark_group("diagnostics_after_change");
    group.sample_size(20).measurement_time(Duration::from_secs(10));
    let mut flip = false;
    group.bench_function(name, |b| {
        b.iter(|| {
            flip = !flip;
            let found = session.change(if flip { &edited } else { text });
            assert_eq!(found, expected, "the edit changes no diagnostic");
        })
    });
    group.finish();
    session.stop();
}

fn benches(c: &mut Criterion) {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/ablation");
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().canonicalize().unwrap();
    for entry in std::fs::read_dir(&examples).unwrap().flatten() {
        if entry.path().is_file() {
            std::fs::copy(entry.path(), root.join(entry.file_name())).unwrap();
        }
    }
    let applicator = root.join("applicator.vrs");
    let text = std::fs::read_to_string(&applicator).unwrap();
    bench_changes(c, "ablation_applicator_with_scene", &root, &applicator, &text);

    let large_dir = tempfile::tempdir().unwrap();
    let large_root = large_dir.path().canonicalize().unwrap();
    let large = large_root.join("large.vrs");
    let src = large_module();
    std::fs::write(&large, &src).unwrap();
    bench_changes(c, "module_3000_functions", &large_root, &large, &src);
}

/// The group `criterion_main!` runs; in a private module, since its generated function has no
/// documentation.
mod group {
    criterion::criterion_group!(lsp, super::benches);
}
criterion_main!(group::lsp);
