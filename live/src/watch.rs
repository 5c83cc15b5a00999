//! Watching a scene's files: notify with a debouncer, so an editor's burst of writes on save is
//! one change.
//!
//! The folders holding the files are watched, not the files: editors that save by writing a new
//! file and renaming it over the old one (vim, many IDEs) replace the file's inode, which a
//! watch on the file itself would lose.

use notify::RecursiveMode;
use notify_debouncer_full::{DebounceEventResult, Debouncer, RecommendedCache, new_debouncer};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Reports changes of a set of files.
pub struct FileWatcher {
    debouncer: Debouncer<notify::RecommendedWatcher, RecommendedCache>,
    /// The files of interest, canonical where they exist.
    files: Arc<Mutex<BTreeSet<PathBuf>>>,
    folders: BTreeSet<PathBuf>,
    changes: Receiver<BTreeSet<PathBuf>>,
}

/// How long the debouncer waits for a burst of events to end.
pub const DEBOUNCE: Duration = Duration::from_millis(50);

impl FileWatcher {
    /// A watcher that calls `wake` from its own thread after each batch of changes (for an
    /// event loop that sleeps until something happens).
    pub fn new(wake: impl Fn() + Send + 'static) -> notify::Result<FileWatcher> {
        let files: Arc<Mutex<BTreeSet<PathBuf>>> = Arc::default();
        let (sender, changes) = channel();
        let watched = files.clone();
        let handler = move |result: DebounceEventResult| {
            let Ok(events) = result else { return };
            let files = watched.lock().map(|f| f.clone()).unwrap_or_default();
            let changed: BTreeSet<PathBuf> = events
                .iter()
                .filter(|e| !e.kind.is_access() && !e.kind.is_other())
                .flat_map(|e| e.paths.iter())
                .filter_map(|p| matching(&files, p))
                .collect();
            if !changed.is_empty() && sender.send(changed).is_ok() {
                wake();
            }
        };
        let debouncer = new_debouncer(DEBOUNCE, None, handler)?;
        Ok(FileWatcher { debouncer, files, folders: BTreeSet::new(), changes })
    }

    /// Watches exactly `files` from now on (their folders, filtered to them).
    pub fn watch(&mut self, files: &[PathBuf]) -> notify::Result<()> {
        let wanted: BTreeSet<PathBuf> = files.iter().map(|f| canonical(f)).collect();
        let folders: BTreeSet<PathBuf> = wanted.iter().filter_map(|f| f.parent().map(Path::to_path_buf)).collect();
        for gone in self.folders.difference(&folders) {
            let _ = self.debouncer.unwatch(gone);
        }
        for new in folders.difference(&self.folders) {
            self.debouncer.watch(new, RecursiveMode::NonRecursive)?;
        }
        self.folders = folders;
        if let Ok(mut current) = self.files.lock() {
            *current = wanted;
        }
        Ok(())
    }

    /// The files that changed since the last call, without waiting.
    pub fn changes(&self) -> Option<BTreeSet<PathBuf>> {
        let mut all: Option<BTreeSet<PathBuf>> = None;
        while let Ok(batch) = self.changes.try_recv() {
            all.get_or_insert_default().extend(batch);
        }
        all
    }

    /// Waits up to `timeout` for changes; then takes every change that has arrived.
    pub fn wait(&self, timeout: Duration) -> Option<BTreeSet<PathBuf>> {
        match self.changes.recv_timeout(timeout) {
            Ok(mut batch) => {
                batch.extend(self.changes().unwrap_or_default());
                Some(batch)
            }
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => None,
        }
    }
}

/// `path` canonical where it exists; a missing file keeps its folder canonical (it may be
/// created later).
fn canonical(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    match (path.parent(), path.file_name()) {
        (Some(parent), Some(name)) => parent.canonicalize().map_or_else(|_| path.to_path_buf(), |p| p.join(name)),
        _ => path.to_path_buf(),
    }
}

fn matching(files: &BTreeSet<PathBuf>, event_path: &Path) -> Option<PathBuf> {
    if files.contains(event_path) {
        return Some(event_path.to_path_buf());
    }
    let canonical = canonical(event_path);
    files.contains(&canonical).then_some(canonical)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    /// Waits for a change of `file` (other events may arrive first), up to five seconds.
    fn saw(watcher: &FileWatcher, file: &Path) -> bool {
        let deadline = Instant::now() + Duration::from_secs(5);
        let file = canonical(file);
        while Instant::now() < deadline {
            if watcher.wait(Duration::from_millis(100)).is_some_and(|c| c.contains(&file)) {
                return true;
            }
        }
        false
    }

    #[test]
    fn edits_of_watched_files_are_reported_and_others_are_not() {
        let dir = tempfile::tempdir().unwrap();
        let (scene, module, other) = (dir.path().join("s.toml"), dir.path().join("m.vrs"), dir.path().join("x.txt"));
        for f in [&scene, &module, &other] {
            std::fs::write(f, "a").unwrap();
        }
        let mut watcher = FileWatcher::new(|| {}).unwrap();
        watcher.watch(&[scene.clone(), module.clone()]).unwrap();
        std::fs::write(&other, "b").unwrap();
        std::fs::write(&module, "b").unwrap();
        assert!(saw(&watcher, &module), "an edit of a watched module must be reported");
        std::thread::sleep(DEBOUNCE * 4);
        let late = watcher.changes().unwrap_or_default();
        assert!(!late.contains(&canonical(&other)), "an unwatched file was reported: {late:?}");
    }

    #[test]
    fn a_save_that_replaces_the_file_by_renaming_is_seen() {
        let dir = tempfile::tempdir().unwrap();
        let module = dir.path().join("m.vrs");
        std::fs::write(&module, "a").unwrap();
        let mut watcher = FileWatcher::new(|| {}).unwrap();
        watcher.watch(std::slice::from_ref(&module)).unwrap();
        for round in 0..2 {
            let temp = dir.path().join(format!(".m.vrs.swp{round}"));
            std::fs::write(&temp, format!("b{round}")).unwrap();
            std::fs::rename(&temp, &module).unwrap();
            assert!(saw(&watcher, &module), "rename-over save {round} was missed");
        }
    }
}
