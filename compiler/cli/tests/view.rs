//! `vrsc view` in a real window under Xvfb on the software adapter: the picture appears, and an
//! orbit dragged with the mouse changes it (screenshots with ImageMagick's `import`, the drag
//! with `xdotool`; `.ci/run` installs all three).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn have(tool: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn screenshot(display: &str, path: &Path) -> Option<image::RgbaImage> {
    let ok = Command::new("import")
        .args(["-display", display, "-window", "root", &path.display().to_string()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return None;
    }
    Some(image::open(path).ok()?.to_rgba8())
}

/// The region of the first view (the left tile of two, left of the side panel), below the
/// toolbar.
fn first_view(shot: &image::RgbaImage) -> image::RgbaImage {
    let (w, h) = shot.dimensions();
    image::imageops::crop_imm(shot, 0, h / 8, w / 3, h * 3 / 4).to_image()
}

fn distinct_colours(img: &image::RgbaImage) -> usize {
    let mut seen: Vec<[u8; 3]> = img.pixels().map(|p| [p[0] & 0xf0, p[1] & 0xf0, p[2] & 0xf0]).collect();
    seen.sort_unstable();
    seen.dedup();
    seen.len()
}

fn mean_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let total: u64 =
        a.pixels().zip(b.pixels()).map(|(p, q)| (0..3).map(|c| p[c].abs_diff(q[c]) as u64).sum::<u64>()).sum();
    total as f64 / (a.width() * a.height() * 3).max(1) as f64
}

/// Screenshots until two in a row agree (the picture has refined), up to `limit`.
fn settled(display: &str, path: &Path, limit: Duration) -> image::RgbaImage {
    let deadline = Instant::now() + limit;
    let mut last: Option<image::RgbaImage> = None;
    loop {
        std::thread::sleep(Duration::from_millis(1500));
        let shot = screenshot(display, path).expect("a screenshot of the Xvfb display");
        let view = first_view(&shot);
        let stable = last.as_ref().is_some_and(|l| mean_difference(l, &view) < 0.05);
        if (stable && distinct_colours(&view) > 20) || Instant::now() > deadline {
            return view;
        }
        last = Some(view);
    }
}

/// Starts Xvfb on a display it picks itself (`-displayfd`), so that no other server's display is
/// taken and the viewer starts only once the server accepts connections: Xvfb writes the number
/// when it is ready, which on a fresh machine (font caches to build) can take seconds.
fn start_xvfb() -> (Killed, String) {
    use std::io::BufRead;
    let mut child = Command::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "1000x620x24", "-nolisten", "tcp"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb starts");
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).expect("Xvfb reports its display");
    let number = line.trim();
    assert!(!number.is_empty(), "Xvfb exited before it reported a display");
    (Killed(child), format!(":{number}"))
}

/// Fails with what the viewer printed when it is no longer running.
fn still_running(viewer: &mut Killed, log: &Path) {
    if let Ok(Some(status)) = viewer.0.try_wait() {
        panic!("vrsc view exited ({status}); it printed:\n{}", std::fs::read_to_string(log).unwrap_or_default());
    }
}

#[test]
fn the_window_shows_the_scene_and_an_orbit_changes_the_picture() {
    let missing: Vec<&str> = ["Xvfb", "xdotool", "import"].into_iter().filter(|t| !have(t)).collect();
    if !missing.is_empty() {
        assert!(
            std::env::var_os("VRS_NO_WINDOW_TEST").is_some(),
            "the window test needs {missing:?} (bash .ci/run installs them: apt-get install xvfb xdotool imagemagick); \
             set VRS_NO_WINDOW_TEST=1 to run the other tests without them"
        );
        eprintln!("window test skipped on request: {missing:?} missing");
        return;
    }
    let (_xvfb, display) = start_xvfb();
    let scene: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "examples", "basic", "scene.toml"].iter().collect();
    let runtime_dir = tempfile::tempdir().unwrap();
    let log_path = runtime_dir.path().join("viewer.log");
    let mut viewer = Killed(
        Command::new(env!("CARGO_BIN_EXE_vrsc"))
            .args(["view", &scene.display().to_string(), "--software"])
            .env("DISPLAY", &display)
            .env("XDG_RUNTIME_DIR", runtime_dir.path())
            .env_remove("WAYLAND_DISPLAY")
            .stderr(std::fs::File::create(&log_path).unwrap())
            .spawn()
            .expect("vrsc view starts"),
    );
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let before = settled(&display, &shot, Duration::from_secs(90));
    still_running(&mut viewer, &log_path);
    assert!(
        distinct_colours(&before) > 20,
        "the first view is blank: {} colours ({} on the whole screen); the viewer printed:\n{}",
        distinct_colours(&before),
        screenshot(&display, &shot).map_or(0, |s| distinct_colours(&s)),
        std::fs::read_to_string(&log_path).unwrap_or_default()
    );

    // Orbit: a left-button drag across the first view.
    let (w, h) = (1000, 620);
    let (x, y) = (w / 6, h / 2);
    // Paced, so that a loaded machine's slow frames still see a drag and not a click.
    let drag = format!(
        "mousemove {x} {y} mousedown 1 sleep 0.4 mousemove {} {y} sleep 0.4 mousemove {} {y} sleep 0.4 \
         mousemove {} {y} sleep 0.4 mouseup 1",
        x + 40,
        x + 90,
        x + 140
    );
    let status = Command::new("xdotool").args(drag.split(' ')).env("DISPLAY", &display).status().unwrap();
    assert!(status.success(), "xdotool drives the mouse");
    let after = settled(&display, &shot, Duration::from_secs(90));
    still_running(&mut viewer, &log_path);
    let difference = mean_difference(&before, &after);
    assert!(difference > 1.0, "the orbit must change the picture (mean difference {difference:.3} of 255)");
    assert!(distinct_colours(&after) > 20, "the orbited view is blank");
}
