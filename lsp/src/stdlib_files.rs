//! The standard library's sources on disk, for "go to definition" into them.
//!
//! The compiler embeds `stdlib/*.vrs`, so an installed `vrsc` has no source tree to point at.
//! The server writes the embedded texts once into a cache folder named after the compiler's
//! version and a hash of the texts (`$XDG_CACHE_HOME/vrsc/stdlib-VERSION-HASH/NAME.vrs`, else
//! `~/.cache/...`, else the system's temporary folder) and points editors there. The files are
//! only ever read by the editor: the server itself always uses the embedded texts.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The folder holding `NAME.vrs` for every standard module, written on first use; `None` when
/// no folder could be written.
pub fn folder() -> Option<&'static Path> {
    static FOLDER: OnceLock<Option<PathBuf>> = OnceLock::new();
    FOLDER.get_or_init(write_folder).as_deref()
}

/// The file of standard module `name` (`shading` for `std::shading`).
pub fn path_of(name: &str) -> Option<PathBuf> {
    vrsc::stdlib::index(name)?;
    Some(folder()?.join(format!("{name}.vrs")))
}

/// The standard module whose cached file is `path`, if it is one.
pub fn module_of(path: &Path) -> Option<&'static str> {
    let folder = folder()?;
    let name = path.strip_prefix(folder).ok()?.to_str()?.strip_suffix(".vrs")?;
    vrsc::stdlib::names().find(|n| *n == name)
}

fn write_folder() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|home| PathBuf::from(home).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    let folder = base.join("vrsc").join(format!("stdlib-{}-{:016x}", env!("CARGO_PKG_VERSION"), texts_hash()));
    std::fs::create_dir_all(&folder).ok()?;
    for (name, text) in vrsc::stdlib::modules() {
        let path = folder.join(format!("{name}.vrs"));
        // Another server may have written it already; the folder's name fixes the contents.
        if std::fs::read_to_string(&path).is_ok_and(|t| t == text) {
            continue;
        }
        std::fs::write(&path, text).ok()?;
    }
    Some(folder)
}

/// FNV-1a over every module's name and text: a new standard library gets a new folder.
fn texts_hash() -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for (name, text) in vrsc::stdlib::modules() {
        for byte in name.bytes().chain([0]).chain(text.bytes()).chain([0]) {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}
