//! `vrsc view` in a real window under Xvfb on the software adapter: the picture appears, an
//! orbit dragged with the mouse changes it, dragging the ablation needle's marker in a slice
//! view moves its zone, E exports a view as `vrsc render` writes it, a scene saved with a
//! renamed uniform is refused with `vrsc build`'s diagnostic, and a path-traced view converges
//! while left alone (screenshots with ImageMagick's `import`, the mouse and keys with
//! `xdotool`; `.ci/run` installs all three).

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

/// Screenshots until two in a row agree in `region` (the picture has refined), up to `limit`.
fn settled(
    display: &str,
    path: &Path,
    limit: Duration,
    region: fn(&image::RgbaImage) -> image::RgbaImage,
) -> image::RgbaImage {
    let deadline = Instant::now() + limit;
    let mut last: Option<image::RgbaImage> = None;
    loop {
        std::thread::sleep(Duration::from_millis(1500));
        let shot = screenshot(display, path).expect("a screenshot of the Xvfb display");
        let view = region(&shot);
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
/// The window tests share the machine; the one that measures change over wall-clock time has it
/// alone (a neighbour's load in its first window made that window's change look small).
static MACHINE: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// A test's Xvfb and its share of the machine, both held until the test ends.
struct Xvfb {
    _process: Killed,
    _share: Share,
}

enum Share {
    Shared(#[allow(dead_code)] std::sync::RwLockReadGuard<'static, ()>),
    Alone(#[allow(dead_code)] std::sync::RwLockWriteGuard<'static, ()>),
}

fn start_xvfb() -> (Xvfb, String) {
    start_xvfb_sharing(false)
}

/// [`start_xvfb`] once no other window test runs, and none starts until this one ends.
fn start_xvfb_alone() -> (Xvfb, String) {
    start_xvfb_sharing(true)
}

fn start_xvfb_sharing(alone: bool) -> (Xvfb, String) {
    let share = if alone {
        Share::Alone(MACHINE.write().unwrap_or_else(|e| e.into_inner()))
    } else {
        Share::Shared(MACHINE.read().unwrap_or_else(|e| e.into_inner()))
    };
    let (process, display) = spawn_xvfb();
    (Xvfb { _process: process, _share: share }, display)
}

fn spawn_xvfb() -> (Killed, String) {
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

/// Whether the window tools are here; without them the test fails unless `VRS_NO_WINDOW_TEST`
/// asks to skip it.
fn window_tools() -> bool {
    let missing: Vec<&str> = ["Xvfb", "xdotool", "import"].into_iter().filter(|t| !have(t)).collect();
    if !missing.is_empty() {
        assert!(
            std::env::var_os("VRS_NO_WINDOW_TEST").is_some(),
            "the window test needs {missing:?} (bash .ci/run installs them: apt-get install xvfb xdotool imagemagick); \
             set VRS_NO_WINDOW_TEST=1 to run the other tests without them"
        );
        eprintln!("window test skipped on request: {missing:?} missing");
        return false;
    }
    true
}

/// `vrsc view SCENE --software` on `display`, printing into `log`.
fn start_viewer(scene: &Path, display: &str, runtime_dir: &Path, log: &Path) -> Killed {
    Killed(
        Command::new(env!("CARGO_BIN_EXE_vrsc"))
            .args(["view", &scene.display().to_string(), "--software"])
            .env("DISPLAY", display)
            .env("XDG_RUNTIME_DIR", runtime_dir)
            .env_remove("WAYLAND_DISPLAY")
            .stderr(std::fs::File::create(log).unwrap())
            .spawn()
            .expect("vrsc view starts"),
    )
}

/// Runs `xdotool` with `script` (words separated by single spaces) on `display`.
fn xdotool(display: &str, script: &str) {
    let status = Command::new("xdotool").args(script.split(' ')).env("DISPLAY", display).status().unwrap();
    assert!(status.success(), "xdotool drives the mouse");
}

#[test]
fn the_window_shows_the_scene_and_an_orbit_changes_the_picture() {
    if !window_tools() {
        return;
    }
    let (_xvfb, display) = start_xvfb();
    let scene: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "examples", "basic", "scene.toml"].iter().collect();
    let runtime_dir = tempfile::tempdir().unwrap();
    let log_path = runtime_dir.path().join("viewer.log");
    let mut viewer = start_viewer(&scene, &display, runtime_dir.path(), &log_path);
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let before = settled(&display, &shot, Duration::from_secs(90), first_view);
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
    xdotool(&display, &drag);
    let after = settled(&display, &shot, Duration::from_secs(90), first_view);
    still_running(&mut viewer, &log_path);
    let difference = mean_difference(&before, &after);
    assert!(difference > 1.0, "the orbit must change the picture (mean difference {difference:.3} of 255)");
    assert!(distinct_colours(&after) > 20, "the orbited view is blank");
}

/// The ablation example with only its axial view, needle A and zone A: one marker, one zone
/// fill, and no 3D view to render (a quicker test). Written into `dir` with the modules.
fn axial_ablation(dir: &Path) -> PathBuf {
    let example: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "examples", "ablation"].iter().collect();
    for entry in std::fs::read_dir(&example).unwrap().flatten() {
        if entry.path().extension().is_some_and(|e| e == "vrs") {
            std::fs::copy(entry.path(), dir.join(entry.file_name())).unwrap();
        }
    }
    let text = std::fs::read_to_string(example.join("scene.toml")).unwrap();
    // The tables of the scene, each from its header to the next.
    let mut tables: Vec<String> = Vec::new();
    for line in text.lines() {
        if line.starts_with('[') || tables.is_empty() {
            tables.push(String::new());
        }
        let table = tables.last_mut().unwrap();
        table.push_str(line);
        table.push('\n');
    }
    let dropped = ["[[view]]\nname = \"3d\"\n", "[[mesh]]\nname = \"needle_b\"\n"];
    for table in dropped {
        assert!(tables.iter().any(|t| t.starts_with(table)), "examples/ablation/scene.toml has no {table:?}");
    }
    tables.retain(|t| !dropped.iter().any(|d| t.starts_with(d)));
    let uniforms = tables.iter_mut().find(|t| t.starts_with("[uniforms]\n")).expect("a [uniforms] table");
    uniforms.insert_str("[uniforms]\n".len(), "zone_enabled_b = false\n");
    let path = dir.join("scene.toml");
    std::fs::write(&path, tables.concat()).unwrap();
    path
}

/// Whether a pixel is a mesh point's marker (the viewer's `MARKER`, (60, 255, 120)).
fn is_marker(p: &image::Rgba<u8>) -> bool {
    p[0].abs_diff(60) < 50 && p[1] > 200 && p[2].abs_diff(120) < 50
}

/// Whether a pixel is the ablation zone's fill: its colour (1.0, 0.75, 0.1) at 45% over the
/// slice, so orange to olive: red well above blue, green between.
fn is_fill(p: &image::Rgba<u8>) -> bool {
    let [r, g, b] = [p[0], p[1], p[2]].map(f32::from);
    r > 110.0 && b < 0.42 * r && g > 0.5 * r && g < 0.88 * r
}

/// The centroid and count of the pixels of `shot` that pass `test`, within `area` (x0, y0, x1,
/// y1), if any do.
fn centroid(shot: &image::RgbaImage, area: [u32; 4], test: fn(&image::Rgba<u8>) -> bool) -> Option<([f32; 2], usize)> {
    let [x0, y0, x1, y1] = area;
    let (mut sum, mut n) = ([0.0f64; 2], 0usize);
    for y in y0..y1.min(shot.height()) {
        for x in x0..x1.min(shot.width()) {
            if test(shot.get_pixel(x, y)) {
                sum = [sum[0] + x as f64, sum[1] + y as f64];
                n += 1;
            }
        }
    }
    (n > 0).then(|| ([(sum[0] / n as f64) as f32, (sum[1] / n as f64) as f32], n))
}

fn whole(shot: &image::RgbaImage) -> image::RgbaImage {
    shot.clone()
}

#[test]
fn dragging_the_needle_marker_in_the_axial_view_moves_the_ablation_zone() {
    if !window_tools() {
        return;
    }
    let scenes = tempfile::tempdir().unwrap();
    let scene = axial_ablation(scenes.path());
    let (_xvfb, display) = start_xvfb();
    let runtime_dir = tempfile::tempdir().unwrap();
    let log_path = runtime_dir.path().join("viewer.log");
    let mut viewer = start_viewer(&scene, &display, runtime_dir.path(), &log_path);
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let before = settled(&display, &shot, Duration::from_secs(90), whole);
    still_running(&mut viewer, &log_path);
    let everywhere = [0, 0, before.width(), before.height()];
    let printed = || std::fs::read_to_string(&log_path).unwrap_or_default();
    let (marker, ring) = centroid(&before, everywhere, is_marker)
        .unwrap_or_else(|| panic!("no marker of needle A's tip on the screen; the viewer printed:\n{}", printed()));
    assert!(ring > 20, "a marker is a ring: {ring} pixels");
    // Around the marker: the zone (a few centimetres at most) before and after the drag, and
    // nothing of the side panel.
    let [mx, my] = marker.map(|c| c.round() as u32);
    let area = [mx.saturating_sub(160), my.saturating_sub(160), mx + 160, my + 160];
    let (zone_before, filled) = centroid(&before, area, is_fill).expect("zone A's fill around the needle's marker");
    assert!(filled > 200, "zone A's fill is {filled} pixels");

    // Press on the marker, drag 40 pixels right and down in steps (paced, so that a loaded
    // machine's slow frames still see a drag), release.
    let drag = [32.0f32, 24.0];
    let mut script = format!("mousemove {mx} {my} mousedown 1 sleep 0.4");
    for step in 1..=4 {
        let at = [marker[0] + drag[0] * step as f32 / 4.0, marker[1] + drag[1] * step as f32 / 4.0];
        script += &format!(" mousemove {} {} sleep 0.4", at[0].round(), at[1].round());
    }
    script += " mouseup 1";
    xdotool(&display, &script);
    let after = settled(&display, &shot, Duration::from_secs(90), whole);
    still_running(&mut viewer, &log_path);
    let (moved_marker, _) = centroid(&after, everywhere, is_marker).expect("the marker after the drag");
    let (zone_after, filled_after) = centroid(&after, area, is_fill).expect("zone A's fill after the drag");
    let shift = |a: [f32; 2], b: [f32; 2]| [b[0] - a[0], b[1] - a[1]];
    let (marker_shift, zone_shift) = (shift(marker, moved_marker), shift(zone_before, zone_after));
    let report = format!(
        "marker {marker:?} -> {moved_marker:?}, zone fill {zone_before:?} ({filled} px) -> {zone_after:?} \
         ({filled_after} px), drag {drag:?}"
    );
    eprintln!("{report}");
    let off = |s: [f32; 2]| ((s[0] - drag[0]).powi(2) + (s[1] - drag[1]).powi(2)).sqrt();
    // The marker is under the cursor again (it follows the tip within a pixel or two)...
    assert!(off(marker_shift) < 4.0, "the marker follows the drag: {report}");
    // ...and the zone moved the same way (its cut by the slice changes a little as its centre
    // moves, so its outline is not just translated).
    let along = (zone_shift[0] * drag[0] + zone_shift[1] * drag[1]) / 40.0;
    assert!(along > 28.0 && off(zone_shift) < 12.0, "the zone's fill moves with the needle: {report}");
}

/// A viewer on `scene` in its own Xvfb, its first view settled: the display, the process, and
/// where it prints (the temporary folder holds the log and the screenshots).
struct Running {
    _xvfb: Xvfb,
    display: String,
    viewer: Killed,
    dir: tempfile::TempDir,
}

impl Running {
    fn settled(scene: &Path) -> Running {
        let (xvfb, display) = start_xvfb();
        let dir = tempfile::tempdir().unwrap();
        let viewer = start_viewer(scene, &display, dir.path(), &dir.path().join("viewer.log"));
        let mut running = Running { _xvfb: xvfb, display, viewer, dir };
        running.shot(first_view);
        running
    }

    /// The settled picture of `region` (see `settled`), the viewer still running.
    fn shot(&mut self, region: fn(&image::RgbaImage) -> image::RgbaImage) -> image::RgbaImage {
        let view = settled(&self.display, &self.dir.path().join("shot.png"), Duration::from_secs(90), region);
        still_running(&mut self.viewer, &self.dir.path().join("viewer.log"));
        view
    }

    /// What the viewer printed so far.
    fn printed(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("viewer.log")).unwrap_or_default()
    }
}

/// A viewer on a scene of `text`, written as `scene.toml` in a folder of its own (kept with
/// the viewer: exports land beside the scene), settled; `None` when the window tools are
/// missing and the test is skipped on request.
fn viewer_on(text: &str) -> Option<(tempfile::TempDir, PathBuf, Running)> {
    if !window_tools() {
        return None;
    }
    let scenes = tempfile::tempdir().unwrap();
    let scene = scenes.path().join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let viewer = Running::settled(&scene);
    Some((scenes, scene, viewer))
}

/// The basic example's scene text.
fn basic_example() -> String {
    let example: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "examples", "basic", "scene.toml"].iter().collect();
    std::fs::read_to_string(example).unwrap()
}

/// Waits up to a minute for `done`; whether it came.
fn within_a_minute(done: impl Fn() -> bool) -> bool {
    let deadline = Instant::now() + Duration::from_secs(60);
    while !done() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(300));
    }
    done()
}

/// E over a view exports it beside the scene as `SCENE-VIEW.png`, at the scene's size: the very
/// pixels `vrsc render` writes for the same scene.
#[test]
fn e_over_a_view_exports_what_vrsc_render_writes() {
    let Some((scenes, scene, viewer)) = viewer_on(&basic_example()) else { return };
    // Over the first view (the 3D one), press E (with the keyboard's focus on the window: no
    // window manager gives it).
    xdotool(&viewer.display, "search --name vrsc windowfocus");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key e", 1000 / 6, 620 / 2));
    let exported = scenes.path().join("scene-3d.png");
    let written = within_a_minute(|| exported.exists());
    assert!(written, "no {} after E; the viewer printed:\n{}", exported.display(), viewer.printed());
    std::thread::sleep(Duration::from_millis(500));
    let out = scenes.path().join("rendered");
    let rendered = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["render", &scene.display().to_string(), "-o", &out.display().to_string(), "--software"])
        .env("XDG_RUNTIME_DIR", viewer.dir.path())
        .output()
        .unwrap();
    assert!(rendered.status.success(), "vrsc render: {}", String::from_utf8_lossy(&rendered.stderr));
    let (a, b) = (image::open(&exported).unwrap().to_rgba8(), image::open(out.join("3d.png")).unwrap().to_rgba8());
    assert_eq!(a.dimensions(), (256, 256), "the scene's size");
    let worst = a.pixels().zip(b.pixels()).flat_map(|(p, q)| (0..4).map(move |c| p[c].abs_diff(q[c]))).max();
    assert_eq!(worst, Some(0), "the export is `vrsc render`'s image");
}

/// The running viewer validates a saved scene as `vrsc build` does: a `[uniforms]` value renamed
/// to a name no view reads is refused with the diagnostic `build` prints (E0702 and its
/// did-you-mean), over the last good picture.
#[test]
fn a_renamed_uniform_in_a_running_viewer_is_refused_as_build_refuses_it() {
    let text = basic_example() + "\n[uniforms]\nambient = 0.3\n";
    let Some((_scenes, scene, mut viewer)) = viewer_on(&text) else { return };
    let upper = viewer.shot(upper_first_view);
    std::fs::write(&scene, text.replace("ambient = 0.3", "ambeint = 0.3")).unwrap();
    within_a_minute(|| viewer.printed().contains("E0702"));
    still_running(&mut viewer.viewer, &viewer.dir.path().join("viewer.log"));
    // The diagnostics lie over the views' lower left: the views keep their size (a view made
    // smaller for a panel would show its picture smaller), so their upper part is unchanged.
    let kept = mean_difference(&upper, &viewer.shot(upper_first_view));
    assert!(kept < 0.5, "the view kept its size and picture (mean difference {kept:.3})");
    let build = Command::new(env!("CARGO_BIN_EXE_vrsc"))
        .args(["build", &scene.display().to_string(), "--color", "never", "-o"])
        .arg(viewer.dir.path().join("built"))
        .output()
        .unwrap();
    assert!(!build.status.success(), "build refuses the renamed uniform");
    let said = String::from_utf8_lossy(&build.stderr).into_owned() + &String::from_utf8_lossy(&build.stdout);
    let lines: Vec<&str> = said.lines().filter(|l| l.contains("E0702") || l.contains("did you mean")).collect();
    assert!(lines.iter().any(|l| l.contains("did you mean `ambient`")), "build said:\n{said}");
    let viewer_said = viewer.printed();
    for line in lines {
        assert!(viewer_said.contains(line.trim()), "the viewer did not say {line:?}; it printed:\n{viewer_said}");
    }
}

/// The upper half of the first view's region.
fn upper_first_view(shot: &image::RgbaImage) -> image::RgbaImage {
    let (w, h) = shot.dimensions();
    image::imageops::crop_imm(shot, 0, h / 8, w / 3, h * 3 / 8).to_image()
}

/// The second view's region (the right tile of two, left of the side panel).
fn second_view(shot: &image::RgbaImage) -> image::RgbaImage {
    let (w, h) = shot.dimensions();
    image::imageops::crop_imm(shot, w / 3, h / 8, w / 3, h * 3 / 4).to_image()
}

/// The head phantom under a grey ramp in two slice views, axial then coronal.
const HEAD_SLICES: &str = "[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\ntf = \"grayscale\"\n\n\
    [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.5\nsize = [256, 256]\n\n\
    [[view]]\nname = \"coronal\"\nkind = \"slice\"\naxis = \"coronal\"\nposition = 0.5\nsize = [256, 256]\n";

/// The crosshair: a click in the axial view, above its centre, moves the coronal view's plane
/// through the clicked point (further anterior), and the coronal picture changes.
#[test]
fn a_click_in_one_slice_view_moves_the_other_through_the_point() {
    let Some((_scenes, _scene, mut viewer)) = viewer_on(HEAD_SLICES) else { return };
    let before = viewer.shot(second_view);
    // A click (no drag) 70 points above the axial view's centre: anterior of the coronal plane.
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 click 1", 1000 / 6, 620 / 2 - 70));
    let after = viewer.shot(second_view);
    let difference = mean_difference(&before, &after);
    assert!(difference > 1.0, "the coronal view must move to the clicked point (mean difference {difference:.3})");
    assert!(distinct_colours(&after) > 20, "the moved coronal view is blank");
}

/// Window/level, per view: a right drag across the axial slice (the first view; a grey ramp
/// over the phantom) narrows its window, and its picture changes while the coronal one's does
/// not.
#[test]
fn a_right_drag_in_a_slice_view_changes_its_window() {
    let Some((_scenes, _scene, mut viewer)) = viewer_on(HEAD_SLICES) else { return };
    let (before, coronal_before) = (viewer.shot(first_view), viewer.shot(second_view));
    let (x, y) = (1000 / 6, 620 / 2);
    let drag = format!(
        "mousemove {x} {y} mousedown 3 sleep 0.4 mousemove {} {y} sleep 0.4 mousemove {} {} sleep 0.4 mouseup 3",
        x - 60,
        x - 120,
        y - 20
    );
    xdotool(&viewer.display, &drag);
    let (after, coronal_after) = (viewer.shot(first_view), viewer.shot(second_view));
    let difference = mean_difference(&before, &after);
    assert!(difference > 1.0, "window/level must change the slice (mean difference {difference:.3})");
    let other = mean_difference(&coronal_before, &coronal_after);
    assert!(other < 0.5, "the other view keeps its window (mean difference {other:.3})");
}

/// CT window presets, per view: over the axial slice, 4 (bone: W 1800 L 400) changes its
/// picture and not the coronal one's; 0 gives it the volume's window back.
#[test]
fn a_ct_window_key_sets_the_view_under_the_mouse() {
    let Some((_scenes, _scene, mut viewer)) = viewer_on(HEAD_SLICES) else { return };
    let (before, coronal_before) = (viewer.shot(first_view), viewer.shot(second_view));
    xdotool(&viewer.display, "search --name vrsc windowfocus");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key 4", 1000 / 6, 620 / 2));
    let (bone, coronal_after) = (viewer.shot(first_view), viewer.shot(second_view));
    let difference = mean_difference(&before, &bone);
    assert!(difference > 1.0, "the bone window must change the slice (mean difference {difference:.3})");
    let other = mean_difference(&coronal_before, &coronal_after);
    assert!(other < 0.5, "the other view keeps its window (mean difference {other:.3})");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key 0", 1000 / 6, 620 / 2 + 10));
    let back = viewer.shot(first_view);
    let restored = mean_difference(&before, &back);
    assert!(restored < 0.5, "0 gives the view the volume's window again (mean difference {restored:.3})");
}

/// With a heavy 3D view beside a cheap slice (the ablation example), the slice shows its full
/// picture long before the 3D view (in under a quarter of its time) instead of refining beside
/// it: the viewer renders one piece at a time, cheap views' first
/// (`vrs_live::ViewFrames::step_views`), and says when each view is complete; a save (a
/// reload) starts the count again.
#[test]
fn the_cheap_slice_settles_before_the_heavy_3d_view() {
    if !window_tools() {
        return;
    }
    let scenes = tempfile::tempdir().unwrap();
    let example: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "examples", "ablation"].iter().collect();
    for entry in std::fs::read_dir(&example).unwrap().flatten() {
        if entry.path().is_file() {
            std::fs::copy(entry.path(), scenes.path().join(entry.file_name())).unwrap();
        }
    }
    let scene = scenes.path().join("scene.toml");
    let viewer = Running::settled(&scene);
    let full_after = |view: &str, nth: usize| -> Option<f64> {
        let printed = viewer.printed();
        let prefix = format!("view `{view}`: full ");
        let line = printed.lines().filter(|l| l.starts_with(&prefix)).nth(nth)?;
        line.split(" picture ").nth(1)?.split(" ms").next()?.parse().ok()
    };
    let both = |nth: usize| full_after("axial", nth).is_some() && full_after("3d", nth).is_some();
    assert!(within_a_minute(|| both(0)), "both views complete; the viewer printed:\n{}", viewer.printed());
    // Measured when written: 513 against 5368 ms (the two views side by side, 350 pixels wide);
    // with a piece of work in flight per view, as before, 3819 against 4823 ms.
    let (axial, heavy) = (full_after("axial", 0).unwrap(), full_after("3d", 0).unwrap());
    assert!(4.0 * axial < heavy, "the slice ({axial} ms) completes long before the 3D view ({heavy} ms)");
    // A save reloads the scene: both views start again, the slice first again.
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text + "\n# saved again\n").unwrap();
    assert!(within_a_minute(|| both(1)), "both views complete after the save:\n{}", viewer.printed());
    let (axial, heavy) = (full_after("axial", 1).unwrap(), full_after("3d", 1).unwrap());
    assert!(
        4.0 * axial < heavy,
        "after the save, the slice ({axial} ms) completes long before the 3D view ({heavy} ms)"
    );
}

/// The head phantom in two 3D views of one size, seen from different sides.
const TWO_CAMERAS: &str = "[render]\njitter = 0.0\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\ntf = \"ct_bone\"\n\n\
    [[view]]\nname = \"front\"\nkind = \"raycast\"\nsize = [256, 256]\ncamera = { azimuth = 0.0, elevation = 10.0, distance = 2.5 }\n\n\
    [[view]]\nname = \"side\"\nkind = \"raycast\"\nsize = [256, 256]\ncamera = { azimuth = 90.0, elevation = 10.0, distance = 2.5 }\n";

/// Linked 3D cameras: unlinked, orbiting the first view leaves the second alone; after L, an
/// orbit of the first view gives the second its camera, so the two (same volume, same size)
/// export the same picture (E over each view: `vrsc render`'s pixels at the scene's size).
#[test]
fn linked_3d_cameras_follow_the_view_that_moves() {
    let Some((scenes, _scene, mut viewer)) = viewer_on(TWO_CAMERAS) else { return };
    xdotool(&viewer.display, "search --name vrsc windowfocus");
    // Over each view (the left and the right tile), E writes SCENE-VIEW.png.
    let over = [(1000 / 6, 620 / 2), (1000 / 2, 620 / 2)];
    let export = |viewer: &Running, view: usize, name: &str| -> image::RgbaImage {
        let path = scenes.path().join(format!("scene-{name}.png"));
        let _ = std::fs::remove_file(&path);
        let (x, y) = over[view];
        xdotool(&viewer.display, &format!("mousemove {x} {y} sleep 0.3 key e"));
        assert!(within_a_minute(|| path.exists()), "no {} after E:\n{}", path.display(), viewer.printed());
        std::thread::sleep(Duration::from_millis(500));
        image::open(&path).unwrap().to_rgba8()
    };
    let orbit = |viewer: &Running, dx: i32| {
        let (x, y) = over[0];
        let drag = format!("mousemove {x} {y} mousedown 1 sleep 0.3 mousemove {} {y} sleep 0.3 mouseup 1", x + dx);
        xdotool(&viewer.display, &drag);
    };
    let side_before = export(&viewer, 1, "side");
    orbit(&viewer, 40);
    viewer.shot(first_view);
    let (front, side) = (export(&viewer, 0, "front"), export(&viewer, 1, "side"));
    assert_eq!(mean_difference(&side_before, &side), 0.0, "unlinked, the second view stays");
    assert!(mean_difference(&front, &side) > 2.0, "the views show different sides");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key l sleep 0.3", over[0].0, over[0].1));
    orbit(&viewer, 30);
    viewer.shot(second_view);
    let (front, side) = (export(&viewer, 0, "front"), export(&viewer, 1, "side"));
    let same = mean_difference(&front, &side);
    assert!(same < 0.01, "linked, the second view has the first one's camera (mean difference {same:.3})");
    assert!(mean_difference(&side_before, &side) > 2.0, "the second view moved");
}

/// Shift+E exports the whole window as it is on screen, beside the scene as
/// `SCENE-window.png`: the window's pixels (the screen of Xvfb shows the window at its top-left
/// corner, so the screenshot's overlap with it must agree).
#[test]
fn shift_e_exports_the_window_as_shown() {
    let Some((scenes, _scene, mut viewer)) = viewer_on(&basic_example()) else { return };
    viewer.shot(second_view);
    xdotool(&viewer.display, "search --name vrsc windowfocus");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key shift+e", 1000 / 6, 620 / 2));
    let exported = scenes.path().join("scene-window.png");
    assert!(within_a_minute(|| exported.exists()), "no {} after Shift+E:\n{}", exported.display(), viewer.printed());
    std::thread::sleep(Duration::from_millis(500));
    let window = image::open(&exported).unwrap().to_rgba8();
    if let Ok(keep) = std::env::var("VRS_KEEP_WINDOW_EXPORT") {
        std::fs::copy(&exported, keep).unwrap();
    }
    let shot = screenshot(&viewer.display, &viewer.dir.path().join("now.png")).expect("a screenshot");
    let (w, h) = (window.width().min(shot.width()), window.height().min(shot.height()));
    assert!(w >= 900 && h >= 560, "the export is the window ({}x{})", window.width(), window.height());
    let overlap = |img: &image::RgbaImage| image::imageops::crop_imm(img, 0, 0, w, h).to_image();
    let difference = mean_difference(&overlap(&window), &overlap(&shot));
    // The caption's last-action text and the cost figures may differ between the two moments.
    assert!(difference < 2.0, "the export shows what the screen shows (mean difference {difference:.3})");
    assert!(distinct_colours(&window) > 50, "the export holds the window's pictures");
}

/// F1 opens the keys window over the views and F1 again closes it: the screen shows it, then
/// shows what it showed before.
#[test]
fn f1_shows_and_hides_the_keys() {
    let Some((_scenes, _scene, mut viewer)) = viewer_on(HEAD_SLICES) else { return };
    let before = viewer.shot(whole);
    xdotool(&viewer.display, "search --name vrsc windowfocus");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 key F1", 1000 / 6, 620 / 2));
    let open = viewer.shot(whole);
    let shown = mean_difference(&before, &open);
    assert!(shown > 2.0, "the keys window must appear (mean difference {shown:.3})");
    xdotool(&viewer.display, "key F1");
    let closed = viewer.shot(whole);
    let gone = mean_difference(&before, &closed);
    assert!(gone < 0.5, "F1 again must close it (mean difference {gone:.3})");
}

/// A small ball (radius 16 of 64 voxels, `ball.nrrd` beside the scene) in two slice views: the
/// corners of each slice are empty, so what changes there is the text the view paints.
const BALL_SLICES: &str = "[[volume]]\nname = \"ball\"\nrole = \"primary\"\npath = \"ball.nrrd\"\ntf = \"grayscale\"\n\n\
    [[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.5\nsize = [256, 256]\n\n\
    [[view]]\nname = \"coronal\"\nkind = \"slice\"\naxis = \"coronal\"\nposition = 0.5\nsize = [256, 256]\n";

/// Writes `ball.nrrd` into `dir`: 64^3 int16 voxels of 1 mm, 1000 within 16 voxels of the
/// centre, 0 elsewhere.
fn write_ball(dir: &Path) {
    let n = 64u32;
    let mut bytes = format!(
        "NRRD0004\ntype: short\ndimension: 3\nsizes: {n} {n} {n}\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\
         space origin: (0,0,0)\nendian: little\nencoding: raw\n\n"
    )
    .into_bytes();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let d = [i, j, k].map(|c| c as f32 - 31.5);
                let inside = d.iter().map(|c| c * c).sum::<f32>() < 16.0 * 16.0;
                bytes.extend(if inside { 1000i16 } else { 0 }.to_le_bytes());
            }
        }
    }
    std::fs::write(dir.join("ball.nrrd"), bytes).unwrap();
}

/// The lower right corner of the first slice view's image, where its position is written
/// (`z 44.0 mm · slice 45 of 64`: the line's right part, with the numbers): the two square
/// views of the default window lie at y 143-501, the first at x 10-368.
fn first_slice_corner(shot: &image::RgbaImage) -> image::RgbaImage {
    image::imageops::crop_imm(shot, 250, 478, 114, 20).to_image()
}

/// The slice's position is written in its corner (`z 12.5 mm · slice 76 of 189`): scrolling
/// the axial view moves the slice, and the text there changes.
#[test]
fn the_slice_position_in_the_corner_follows_the_wheel() {
    if !window_tools() {
        return;
    }
    let scenes = tempfile::tempdir().unwrap();
    write_ball(scenes.path());
    let scene = scenes.path().join("scene.toml");
    std::fs::write(&scene, BALL_SLICES).unwrap();
    let mut viewer = Running::settled(&scene);
    let before = viewer.shot(first_slice_corner);
    assert!(distinct_colours(&before) > 1, "text in the corner");
    xdotool(&viewer.display, &format!("mousemove {} {} sleep 0.3 click --repeat 6 4", 1000 / 6, 620 / 2));
    let after = viewer.shot(first_slice_corner);
    let changed = mean_difference(&before, &after);
    assert!(changed > 1.0, "the position text changes with the slice (mean difference {changed:.3})");
}

/// The head phantom path-traced in one small 3D view.
const PATH_TRACED: &str = "[render]\ncompositing = \"pathtrace\"\nshading = true\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\nphantom = \"head\"\ntf = \"ct_bone\"\n\n\
    [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [160, 160]\ncamera = { azimuth = 30.0, elevation = 15.0, distance = 2.2 }\n";

/// A path-traced view keeps refining while it is left alone, with no input: after its first
/// full picture its frames keep changing the picture, by less and less as their mean converges
/// (each frame moves a mean of N frames by about 1/N of its noise).
#[test]
fn a_path_traced_view_converges_while_left_alone() {
    if !window_tools() {
        return;
    }
    let scenes = tempfile::tempdir().unwrap();
    let scene = scenes.path().join("scene.toml");
    std::fs::write(&scene, PATH_TRACED).unwrap();
    let (_xvfb, display) = start_xvfb_alone();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("viewer.log");
    let mut viewer = start_viewer(&scene, &display, dir.path(), &log);
    let printed = || std::fs::read_to_string(&log).unwrap_or_default();
    let shown = within_a_minute(|| printed().lines().any(|l| l.starts_with("view `3d`: full ")));
    assert!(shown, "the first full picture; the viewer printed:\n{}", printed());
    let path = dir.path().join("shot.png");
    let shot = |wait: u64| {
        std::thread::sleep(Duration::from_secs(wait));
        first_view(&screenshot(&display, &path).expect("a screenshot"))
    };
    let (a, b) = (shot(0), shot(2));
    let (c, d) = (shot(6), shot(2));
    still_running(&mut viewer, &log);
    let (early, late) = (mean_difference(&a, &b), mean_difference(&c, &d));
    eprintln!("change over two seconds: {early:.3}/255 after the first full picture, {late:.3}/255 eight seconds on");
    assert!(distinct_colours(&d) > 20, "the head shows");
    assert!(early > 0.2, "the picture refines without input: {early:.3}");
    assert!(late < 0.5 * early, "the refinement converges: {early:.3} then {late:.3}");
}
