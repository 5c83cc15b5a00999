//! `vrsc lsp` end to end: the real binary over its standard input and output, with the
//! protocol's `Content-Length` framing. (The server's features are tested in depth over an
//! in-memory connection in `lsp/tests/protocol.rs`.)

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};

fn send(stdin: &mut impl Write, message: &Value) {
    let body = message.to_string();
    write!(stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
    stdin.flush().unwrap();
}

/// The next message the server writes.
fn receive(stdout: &mut impl BufRead) -> Value {
    let mut length = None;
    loop {
        let mut line = String::new();
        assert!(stdout.read_line(&mut line).unwrap() > 0, "the server closed its output");
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some(n) = line.strip_prefix("Content-Length: ") {
            length = Some(n.parse::<usize>().unwrap());
        }
    }
    let mut body = vec![0; length.expect("a Content-Length header")];
    stdout.read_exact(&mut body).unwrap();
    serde_json::from_slice(&body).unwrap()
}

/// Messages until the one `pick` accepts.
fn receive_until(stdout: &mut impl BufRead, pick: impl Fn(&Value) -> bool) -> Value {
    loop {
        let message = receive(stdout);
        if pick(&message) {
            return message;
        }
    }
}

#[test]
fn the_binary_serves_diagnostics_and_hover_then_exits_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().canonicalize().unwrap();
    let uri = format!("file://{}/glow.vrs", root.display());
    let mut server = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .arg("lsp")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = server.stdin.take().unwrap();
    let mut stdout = BufReader::new(server.stdout.take().unwrap());
    let root_uri = format!("file://{}", root.display());
    send(
        &mut stdin,
        &json!({ "jsonrpc": "2.0", "id": 1, "method": "initialize", "params": { "capabilities": {}, "rootUri": root_uri } }),
    );
    let init = receive_until(&mut stdout, |m| m["id"] == 1);
    assert_eq!(init["result"]["serverInfo"]["name"], "vrsc");
    send(&mut stdin, &json!({ "jsonrpc": "2.0", "method": "initialized", "params": {} }));
    let text = "pipeline glow after shading.lights {\n    state color: vec4f;\n    state.color = state.color * state.gradient.x;\n}\n";
    send(
        &mut stdin,
        &json!({ "jsonrpc": "2.0", "method": "textDocument/didOpen", "params": {
            "textDocument": { "uri": uri, "languageId": "vrs", "version": 1, "text": text } } }),
    );
    let published = receive_until(&mut stdout, |m| m["method"] == "textDocument/publishDiagnostics");
    let codes: Vec<&str> =
        published["params"]["diagnostics"].as_array().unwrap().iter().map(|d| d["code"].as_str().unwrap()).collect();
    assert_eq!(codes, ["E0501"], "{published}");
    send(
        &mut stdin,
        &json!({ "jsonrpc": "2.0", "id": 2, "method": "textDocument/hover", "params": {
            "textDocument": { "uri": uri }, "position": { "line": 1, "character": 12 } } }),
    );
    let hover = receive_until(&mut stdout, |m| m["id"] == 2);
    let value = hover["result"]["contents"]["value"].as_str().unwrap();
    assert!(value.starts_with("```vrs\nstate color: vec4f\n```"), "{value}");
    send(&mut stdin, &json!({ "jsonrpc": "2.0", "id": 3, "method": "shutdown", "params": null }));
    assert_eq!(receive_until(&mut stdout, |m| m["id"] == 3)["result"], Value::Null);
    send(&mut stdin, &json!({ "jsonrpc": "2.0", "method": "exit", "params": null }));
    drop(stdin);
    assert!(server.wait().unwrap().success());
}
