//! Shared set-up of the runtime's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use vrs_runtime::{AdapterChoice, Gpu};

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The software adapter (lavapipe), so images are the same on every machine. Never skips: a
/// machine without it fails with the command that installs it (`.ci/run` runs that command).
pub fn software_gpu() -> Gpu {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        let dir = std::env::temp_dir().join("vrs-xdg");
        let _ = std::fs::create_dir_all(&dir);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        // SAFETY: set before any other thread of this test reads the environment.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", dir) };
    }
    Gpu::headless(AdapterChoice::Software).unwrap_or_else(|e| {
        panic!(
            "rendering tests need the software Vulkan driver (lavapipe): {e}\n\
             install it with: apt-get install -y mesa-vulkan-drivers libvulkan1"
        )
    })
}
