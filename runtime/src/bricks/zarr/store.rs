//! Where a store's bytes come from: a directory, or an HTTP(S) server (`http.rs`), behind one
//! readable-storage interface; its metadata documents read through it; and, for a directory, the
//! chunk files of an array listed once (what lets a sparse store skip its empty parts unread).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde_json::Value;
use zarrs::filesystem::FilesystemStore;
use zarrs::storage::StoreKey;

use super::dataset::{Dataset, Store};

/// Metadata documents larger than this are refused rather than read.
const MAX_METADATA_BYTES: u64 = 16 << 20;

/// The most chunk files of a level that are listed once (a set of their keys); a level with
/// more looks each chunk up.
const MAX_LISTED_CHUNKS: u64 = 1 << 21;

/// Where a Zarr store is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StoreLocation {
    /// A directory on this machine.
    Path(PathBuf),
    /// An `http://` or `https://` URL of the store's root.
    Url(String),
}

impl StoreLocation {
    /// The store's name for messages: the directory's or the URL's last part.
    pub(crate) fn name(&self) -> String {
        match self {
            StoreLocation::Path(p) => {
                p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
            }
            StoreLocation::Url(u) => u.trim_end_matches('/').rsplit('/').next().unwrap_or(u).to_string(),
        }
    }
}

impl std::fmt::Display for StoreLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StoreLocation::Path(p) => write!(f, "{}", p.display()),
            StoreLocation::Url(u) => f.write_str(u),
        }
    }
}

/// An opened store: its storage and, for a directory, the directory (which can be listed).
pub(super) struct Opened {
    pub(super) store: Arc<Store>,
    pub(super) dir: Option<PathBuf>,
}

/// Opens the store at `location`.
pub(super) fn open(location: &StoreLocation) -> Result<Opened, String> {
    match location {
        StoreLocation::Path(path) => {
            if !path.is_dir() {
                return Err(format!("{} is not a directory (a Zarr store is one)", path.display()));
            }
            let store = FilesystemStore::new(path).map_err(|e| e.to_string())?;
            Ok(Opened { store: Arc::new(store), dir: Some(path.clone()) })
        }
        StoreLocation::Url(url) => Ok(Opened { store: super::http::open(url)?, dir: None }),
    }
}

/// A JSON document of the store, `None` when the store has no such key.
pub(super) fn read_json(store: &Store, key: &str) -> Result<Option<Value>, String> {
    let store_key = StoreKey::new(key).map_err(|e| format!("{key}: {e}"))?;
    if let Some(len) = store.size_key(&store_key).map_err(|e| format!("{key}: {e}"))?
        && len > MAX_METADATA_BYTES
    {
        return Err(format!("{key}: {len} bytes is too large for metadata"));
    }
    let Some(bytes) = store.get(&store_key).map_err(|e| format!("{key}: {e}"))? else { return Ok(None) };
    if bytes.len() as u64 > MAX_METADATA_BYTES {
        return Err(format!("{key}: {} bytes is too large for metadata", bytes.len()));
    }
    serde_json::from_slice(&bytes).map(Some).map_err(|e| format!("{key}: not valid JSON: {e}"))
}

/// What the store's root is.
pub(super) enum Root {
    /// An array, with its Zarr v3 `dimension_names` (empty for v2 or when absent).
    Array(Vec<Option<String>>),
    /// A group, with its attributes.
    Group(Value),
}

/// Reads the root metadata (v3 `zarr.json`, v2 `.zarray` / `.zgroup` + `.zattrs`).
pub(super) fn root_node(store: &Store) -> Result<Root, String> {
    if let Some(meta) = read_json(store, "zarr.json")? {
        return match meta.get("node_type").and_then(Value::as_str) {
            Some("array") => {
                let names = meta.get("dimension_names").and_then(Value::as_array);
                let names = names.map(|n| n.iter().map(|v| v.as_str().map(str::to_string)).collect());
                Ok(Root::Array(names.unwrap_or_default()))
            }
            Some("group") => Ok(Root::Group(meta.get("attributes").cloned().unwrap_or(Value::Null))),
            other => Err(format!("zarr.json: `node_type` is {other:?}, not \"array\" or \"group\"")),
        };
    }
    if read_json(store, ".zarray")?.is_some() {
        return Ok(Root::Array(Vec::new()));
    }
    if read_json(store, ".zgroup")?.is_some() {
        return Ok(Root::Group(read_json(store, ".zattrs")?.unwrap_or(Value::Null)));
    }
    Err("not a Zarr store: it has no zarr.json, .zarray or .zgroup".into())
}

/// The chunks an array of a directory store has on disk.
pub(super) struct Listing {
    pub(super) keys: HashSet<String>,
    /// Their indices (all axes).
    pub(super) indices: Vec<Vec<u64>>,
}

/// The chunk files of `dataset` in the directory store at `root`: the array's directory walked,
/// giving up (`None`) past [`MAX_LISTED_CHUNKS`] files so that memory stays bounded whatever
/// the store holds.
pub(super) fn list_chunks(root: &Path, dataset: &Dataset) -> Option<Listing> {
    let grid = dataset.array.chunk_grid_shape();
    let prefix = if dataset.path == "/" { String::new() } else { format!("{}/", dataset.path) };
    let mut keys = Vec::new();
    walk(&root.join(&prefix), &prefix, &mut keys)?;
    let mut listing = Listing { keys: HashSet::new(), indices: Vec::new() };
    for key in keys {
        // Files that are not chunks (metadata) fail the round trip through the key encoding.
        let rest = &key[prefix.len()..];
        let rest = rest.strip_prefix("c/").or_else(|| rest.strip_prefix("c.")).unwrap_or(rest);
        let index: Option<Vec<u64>> = rest.split(['/', '.']).map(|p| p.parse().ok()).collect();
        let Some(index) = index.filter(|i| i.len() == grid.len() && i.iter().zip(grid).all(|(v, n)| v < n)) else {
            continue;
        };
        if dataset.array.chunk_key(&index).as_str() == key {
            listing.keys.insert(key);
            listing.indices.push(index);
        }
    }
    Some(listing)
}

/// Appends the store keys (`prefix` + path, `/`-separated) of the files under `dir`; `None`
/// past [`MAX_LISTED_CHUNKS`] of them or when a directory cannot be read.
fn walk(dir: &Path, prefix: &str, keys: &mut Vec<String>) -> Option<()> {
    for entry in std::fs::read_dir(dir).ok()? {
        let entry = entry.ok()?;
        let name = entry.file_name().into_string().ok()?;
        let kind = entry.file_type().ok()?;
        if kind.is_dir() {
            walk(&entry.path(), &format!("{prefix}{name}/"), keys)?;
        } else {
            if keys.len() as u64 >= MAX_LISTED_CHUNKS {
                return None;
            }
            keys.push(format!("{prefix}{name}"));
        }
    }
    Some(())
}
