//! Remote Zarr stores through `vrsc render`: a store served over HTTP by a server on 127.0.0.1
//! renders the same picture as from disk (also through a server that fails every other
//! request, which the client retries); a server that stalls or fails gives a clear error in
//! bounded time, never a hang (as does `https://` to a server without TLS); unknown schemes are
//! refused at build.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use crate::support::loopback::{Mode, Server};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/zarr").canonicalize().expect("fixtures")
}

fn scene(path: &str) -> String {
    format!(
        r#"
[render]
compositing = "dvr"
jitter = 0.0

[[volume]]
name = "cells"
role = "primary"
path = "{path}"
window = [0.0, 4000.0]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = {{ azimuth = 30.0, elevation = 20.0, distance = 2.2 }}
"#
    )
}

/// `vrsc render` of a scene of the store at `path` into `dir/NAME/`, with a request timeout.
fn render(dir: &Path, name: &str, path: &str, timeout_s: f32) -> (Output, PathBuf) {
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(&file, scene(path)).expect("scene written");
    let out = dir.join(name);
    let output = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .arg("render")
        .arg(&file)
        .arg("--output")
        .arg(&out)
        .env("VRS_HTTP_TIMEOUT", timeout_s.to_string())
        .output()
        .expect("vrsc runs");
    (output, out)
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

#[test]
fn a_store_over_http_renders_as_from_disk() {
    let dir = tempfile::tempdir().expect("temp dir");
    let store = "v3_sharded_float32.zarr";
    let (local, local_out) = render(dir.path(), "local", &fixtures().join(store).display().to_string(), 5.0);
    assert!(local.status.success(), "{}", text(&local));
    let server = Server::start(fixtures(), Mode::Files);
    let (remote, remote_out) = render(dir.path(), "remote", &server.url(store), 5.0);
    assert!(remote.status.success(), "{}", text(&remote));
    assert!(server.requests.load(std::sync::atomic::Ordering::Relaxed) > 0, "the store was read over HTTP");
    let a = image::open(local_out.join("3d.png")).expect("local image").to_rgba8();
    let b = image::open(remote_out.join("3d.png")).expect("remote image").to_rgba8();
    assert!(a.pixels().any(|p| p.0[3] > 0), "the picture shows the store");
    assert_eq!(a.as_raw(), b.as_raw(), "the remote store renders as the local one");

    // A server that fails every other request: the client retries, the picture is the same.
    let flaky = Server::start(fixtures(), Mode::Flaky);
    let (retried, retried_out) = render(dir.path(), "flaky", &flaky.url(store), 5.0);
    assert!(retried.status.success(), "{}", text(&retried));
    let c = image::open(retried_out.join("3d.png")).expect("retried image").to_rgba8();
    assert_eq!(a.as_raw(), c.as_raw());
}

#[test]
fn a_stalling_or_failing_server_is_a_clear_error_in_bounded_time() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A stalled request is given up after its timeout and retries; a failing one says its status.
    for (mode, expect) in [(Mode::Stall, "retries"), (Mode::Fail(500), "500")] {
        let server = Server::start(fixtures(), mode);
        let started = Instant::now();
        let (output, _) = render(dir.path(), "bad", &server.url("v2_blosc.zarr"), 0.5);
        let took = started.elapsed();
        let said = text(&output);
        assert!(!output.status.success(), "{mode:?}: {said}");
        assert!(said.contains("v2_blosc.zarr") && said.to_lowercase().contains(expect), "{mode:?}: {said}");
        assert!(took < Duration::from_secs(60), "{mode:?} took {took:?}");
    }
    // Nothing listens on a port just released.
    let port = std::net::TcpListener::bind("127.0.0.1:0").expect("a port").local_addr().expect("addr").port();
    let (output, _) = render(dir.path(), "closed", &format!("http://127.0.0.1:{port}/store.zarr"), 0.5);
    assert!(!output.status.success() && text(&output).contains("store.zarr"), "{}", text(&output));
    // `https://` to a server that speaks plain HTTP: the client's TLS stack starts, the
    // handshake fails, and that is an error at the store's path (E0719, exit 1), not a panic (101).
    let server = Server::start(fixtures(), Mode::Files);
    let url = server.url("v2_blosc.zarr").replacen("http://", "https://", 1);
    let (output, _) = render(dir.path(), "tls", &url, 0.5);
    let said = text(&output);
    assert_eq!(output.status.code(), Some(1), "{said}");
    assert!(said.contains("E0719") && said.contains("v2_blosc.zarr") && !said.contains("panicked"), "{said}");
}

#[test]
fn unknown_schemes_are_refused_at_build() {
    let dir = tempfile::tempdir().expect("temp dir");
    for url in ["s3://bucket/cells.zarr", "gs://bucket/cells.zarr", "ftp://host/cells.zarr"] {
        let (output, _) = render(dir.path(), "scheme", url, 1.0);
        let said = text(&output);
        assert!(!output.status.success(), "{url}: {said}");
        assert!(said.contains("stores are not supported") && said.contains("E0718"), "{url}: {said}");
    }
}
