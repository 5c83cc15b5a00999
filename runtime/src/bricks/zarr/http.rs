//! Stores served over HTTP(S): `object_store`'s HTTP client (connection and request timeouts,
//! retries with exponential backoff on failures and timeouts) read through `zarrs`'
//! synchronous storage interface (`zarrs_object_store` and zarrs' async-to-sync adapter), on a
//! small Tokio runtime of its own. The loader threads each block on their own requests, so
//! bricks load in parallel.
//!
//! Timeouts: 10 s to connect, 30 s for a request, retried 3 times within 60 s; the environment
//! variable `VRS_HTTP_TIMEOUT` (seconds) scales all three down or up for slow links and tests.

use std::sync::{Arc, OnceLock};
use std::time::Duration;

use object_store::http::HttpBuilder;
use object_store::{BackoffConfig, ClientOptions, RetryConfig};
use zarrs::storage::storage_adapter::async_to_sync::{AsyncToSyncBlockOn, AsyncToSyncStorageAdapter};
use zarrs_object_store::AsyncObjectStore;

use super::dataset::Store;

/// Blocks on a future on the shared runtime (from a loader or the calling thread, never from
/// a runtime thread).
struct BlockOn(tokio::runtime::Handle);

impl AsyncToSyncBlockOn for BlockOn {
    fn block_on<F: core::future::Future>(&self, future: F) -> F::Output {
        self.0.block_on(future)
    }
}

/// The process's runtime for HTTP stores: two I/O threads, made on first use.
fn runtime() -> Result<&'static tokio::runtime::Runtime, String> {
    static RUNTIME: OnceLock<Result<tokio::runtime::Runtime, String>> = OnceLock::new();
    RUNTIME
        .get_or_init(|| {
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .thread_name("vrs-http")
                .enable_all()
                .build()
                .map_err(|e| format!("cannot start the HTTP client: {e}"))
        })
        .as_ref()
        .map_err(Clone::clone)
}

/// The request timeout in seconds (`VRS_HTTP_TIMEOUT`, else 30).
fn timeout() -> Duration {
    let seconds = std::env::var("VRS_HTTP_TIMEOUT").ok().and_then(|v| v.parse::<f64>().ok());
    Duration::from_secs_f64(seconds.filter(|s| s.is_finite() && *s > 0.0).unwrap_or(30.0).min(3600.0))
}

/// Makes ring the process's TLS provider, unless one is installed already (by the
/// application, or an earlier store): the HTTP client's rustls is built without one.
fn install_tls_provider() {
    if rustls::crypto::CryptoProvider::get_default().is_none() {
        // An error means another thread installed one meanwhile, which serves as well.
        let _ = rustls::crypto::ring::default_provider().install_default();
    }
}

/// The store at `url` (`http://` or `https://`).
pub(super) fn open(url: &str) -> Result<Arc<Store>, String> {
    check_scheme(url)?;
    install_tls_provider();
    let request = timeout();
    let options = ClientOptions::new()
        .with_allow_http(true)
        .with_timeout(request)
        .with_connect_timeout(request.mul_f64(1.0 / 3.0));
    let retry = RetryConfig {
        backoff: BackoffConfig {
            init_backoff: Duration::from_millis(100),
            max_backoff: Duration::from_secs(2),
            base: 2.0,
        },
        max_retries: 3,
        retry_timeout: request * 2,
    };
    let store = HttpBuilder::new()
        .with_url(url.trim_end_matches('/'))
        .with_client_options(options)
        .with_retry(retry)
        .build()
        .map_err(|e| format!("{url}: {e}"))?;
    let runtime = runtime()?;
    let adapter =
        AsyncToSyncStorageAdapter::new(Arc::new(AsyncObjectStore::new(store)), BlockOn(runtime.handle().clone()));
    Ok(Arc::new(adapter))
}

/// Only `http://` and `https://` URLs name remote stores here.
fn check_scheme(url: &str) -> Result<(), String> {
    let scheme = url.split_once("://").map(|(s, _)| s.to_ascii_lowercase());
    match scheme.as_deref() {
        Some("http" | "https") => Ok(()),
        Some(other) => Err(format!(
            "`{other}://` stores are not supported; a remote store is read over `https://` or `http://` (an S3 bucket by its HTTPS address)"
        )),
        None => Err(format!("`{url}` is not a URL")),
    }
}
