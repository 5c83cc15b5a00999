//! A file server on 127.0.0.1 for the remote-store tests: GET (whole files and single byte
//! ranges), HEAD, keep-alive; or a server that stalls or fails. It listens on the loopback
//! address only, on a port the system picks, and stops by itself when dropped or after two
//! minutes, whichever comes first.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How the server answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Serves the folder's files.
    Files,
    /// Reads each request and never answers.
    Stall,
    /// Answers every request with this status.
    Fail(u16),
    /// Answers every other request with 503 and serves the rest.
    Flaky,
}

/// The longest a server runs.
const LIFETIME: Duration = Duration::from_secs(120);

pub struct Server {
    pub addr: SocketAddr,
    /// Requests answered or stalled so far.
    pub requests: Arc<AtomicUsize>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Starts serving `root` as `mode` says.
    pub fn start(root: PathBuf, mode: Mode) -> Server {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a loopback port");
        listener.set_nonblocking(true).expect("non-blocking accept");
        let addr = listener.local_addr().expect("its address");
        let stop = Arc::new(AtomicBool::new(false));
        let requests = Arc::new(AtomicUsize::new(0));
        let (stop2, requests2) = (stop.clone(), requests.clone());
        let thread = std::thread::spawn(move || {
            let started = Instant::now();
            while !stop2.load(Ordering::Relaxed) && started.elapsed() < LIFETIME {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let (root, stop, requests) = (root.clone(), stop2.clone(), requests2.clone());
                        std::thread::spawn(move || serve(stream, &root, mode, &stop, &requests));
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
            stop2.store(true, Ordering::Relaxed);
        });
        Server { addr, requests, stop, thread: Some(thread) }
    }

    /// The URL of `path` under the served folder.
    pub fn url(&self, path: &str) -> String {
        format!("http://{}/{path}", self.addr)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Answers the requests of one connection until it closes or the server stops.
fn serve(stream: TcpStream, root: &std::path::Path, mode: Mode, stop: &AtomicBool, requests: &AtomicUsize) {
    let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
    let mut writer = match stream.try_clone() {
        Ok(w) => w,
        Err(_) => return,
    };
    let mut reader = BufReader::new(stream);
    while !stop.load(Ordering::Relaxed) {
        let Some((method, path, range)) = read_request(&mut reader, stop) else { return };
        let n = requests.fetch_add(1, Ordering::Relaxed);
        let answer = match mode {
            Mode::Stall => {
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(20));
                }
                return;
            }
            Mode::Fail(status) => respond(status, b"failing on purpose", None),
            Mode::Flaky if n.is_multiple_of(2) => respond(503, b"busy", None),
            Mode::Files | Mode::Flaky => file_answer(root, &path, range),
        };
        let (head, body) = answer;
        let body = if method == "HEAD" { Vec::new() } else { body };
        if writer.write_all(head.as_bytes()).and_then(|()| writer.write_all(&body)).is_err() {
            return;
        }
    }
}

/// A request: its method, path and byte range (first and last byte).
type Request = (String, String, Option<(u64, u64)>);

/// The next request; `None` when the connection ends.
fn read_request(reader: &mut BufReader<TcpStream>, stop: &AtomicBool) -> Option<Request> {
    let mut head = Vec::new();
    loop {
        let mut line = String::new();
        match reader.read_line(&mut line) {
            Ok(0) => return None,
            Ok(_) if line == "\r\n" && !head.is_empty() => break,
            Ok(_) => head.push(line),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                if stop.load(Ordering::Relaxed) {
                    return None;
                }
            }
            Err(_) => return None,
        }
    }
    let mut first = head[0].split_whitespace();
    let (method, path) = (first.next()?.to_string(), first.next()?.to_string());
    let mut range = None;
    let mut length = 0u64;
    for line in &head[1..] {
        let (name, value) = line.split_once(':')?;
        let value = value.trim();
        match name.to_ascii_lowercase().as_str() {
            "range" => {
                let (a, b) = value.strip_prefix("bytes=")?.split_once('-')?;
                range = Some((a.parse().ok()?, b.parse().unwrap_or(u64::MAX)));
            }
            "content-length" => length = value.parse().ok()?,
            _ => {}
        }
    }
    // Requests here have no body; skip one if sent.
    std::io::copy(&mut reader.by_ref().take(length), &mut std::io::sink()).ok()?;
    Some((method, path, range))
}

fn file_answer(root: &std::path::Path, path: &str, range: Option<(u64, u64)>) -> (String, Vec<u8>) {
    let relative = path.trim_start_matches('/');
    if relative.split('/').any(|p| p == "..") {
        return respond(403, b"", None);
    }
    let Ok(bytes) = std::fs::read(root.join(relative)) else { return respond(404, b"not found", None) };
    match range {
        None => respond(200, &bytes, None),
        Some((a, b)) => {
            let end = b.min(bytes.len() as u64 - 1);
            if a > end || bytes.is_empty() {
                return respond(416, b"", None);
            }
            let part = &bytes[a as usize..=end as usize];
            respond(206, part, Some(format!("bytes {a}-{end}/{}", bytes.len())))
        }
    }
}

fn respond(status: u16, body: &[u8], content_range: Option<String>) -> (String, Vec<u8>) {
    let reason = match status {
        200 => "OK",
        206 => "Partial Content",
        404 => "Not Found",
        503 => "Service Unavailable",
        _ => "Error",
    };
    let mut head = format!(
        "HTTP/1.1 {status} {reason}\r\nContent-Length: {}\r\nLast-Modified: Thu, 03 Dec 2026 10:00:00 GMT\r\nETag: \"{}\"\r\nAccept-Ranges: bytes\r\n",
        body.len(),
        body.len()
    );
    if let Some(r) = content_range {
        head.push_str(&format!("Content-Range: {r}\r\n"));
    }
    head.push_str("\r\n");
    (head, body.to_vec())
}
