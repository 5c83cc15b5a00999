//! Meshes with volumes on lavapipe, against geometry: rays end at the first opaque surface (the
//! opacity along each ray is that of the path up to the surface), slice views outline where a
//! mesh crosses their plane, and a view reads the mesh layer at any image size.

use crate::common;

use glam::{Mat4, Vec3};
use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// 32^3 voxels of 1 mm, value 1000 everywhere: a homogeneous volume whose box is
/// [-0.5, 31.5]^3 mm (voxel centres at whole millimetres from 0).
fn homogeneous_volume(dir: &Path) {
    let values = vec![1000.0f32; 32 * 32 * 32];
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    common::write_nrrd(&dir.join("cube.nrrd"), "RAS", [32; 3], identity, [0.0; 3], &values);
    let tf = format!(
        r#"[{{"Name": "cube", "RGBPoints": [0, 1, 1, 1, 1000, 1, 1, 1], "Points": [0, {A}, 0.5, 0, 1000, {A}, 0.5, 0]}}]"#
    );
    std::fs::write(dir.join("cube.json"), tf).expect("tf written");
}

/// Opacity per millimetre: 13/255, which the 8-bit transfer-function table holds exactly.
const A: f64 = 13.0 / 255.0;

/// The box mesh: half inside the volume (x from 16 to 40 mm; the volume ends at 31.5).
const BOX_MIN: Vec3 = Vec3::new(16.0, 6.0, 6.0);
const BOX_MAX: Vec3 = Vec3::new(40.0, 25.0, 25.0);

const SCENE: &str = r#"
[render]
compositing = "dvr"
step_size = 0.25
jitter = 0.0
background = [0.0, 0.0, 0.0, 1.0]
empty_space_skipping = false

[[volume]]
name = "cube"
role = "primary"
path = "cube.nrrd"
window = [0.0, 1000.0]
tf = "cube.json"

[uniforms]
ref_step = 1.0

[[mesh]]
name = "block"
shape = "box"
min = [16.0, 6.0, 6.0]
max = [40.0, 25.0, 25.0]
color = [0.0, 0.0, 0.0]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 60.0, elevation = 25.0, distance = 2.2 }
"#;

fn open(dir: &Path, scene: &str) -> SceneRenderer {
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).expect("scene written");
    SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The ray parameters where `origin + t dir` enters and leaves the box `[lo, hi]`, if it meets it.
fn slab_hit(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let inv = dir.recip();
    let (a, b) = ((lo - origin) * inv, (hi - origin) * inv);
    let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
    (near <= far && far > 0.0).then_some((near.max(0.0), far))
}

/// The pixel's ray in patient space (origin on the near plane, unit direction).
fn pixel_ray(clip_to_world: Mat4, [x, y]: [f32; 2]) -> (Vec3, Vec3) {
    let ndc = |z| Vec3::new(x * 2.0 - 1.0, 1.0 - y * 2.0, z);
    let near = clip_to_world.project_point3(ndc(0.0));
    let far = clip_to_world.project_point3(ndc(1.0));
    (near, (far - near).normalize())
}

/// Where the ray meets no mesh, or meets it at the pixel's centre and its four neighbours alike
/// (pixels on the box's silhouette are left out: the rasterizer decides them by coverage).
fn path_in_volume(clip_to_world: Mat4, size: u32, px: u32, py: u32) -> Option<f32> {
    let at = |dx: f32, dy: f32| {
        let pixel = [(px as f32 + 0.5 + dx) / size as f32, (py as f32 + 0.5 + dy) / size as f32];
        let (o, d) = pixel_ray(clip_to_world, pixel);
        (o, d, slab_hit(o, d, BOX_MIN, BOX_MAX).map(|h| h.0))
    };
    let (o, d, hit) = at(0.0, 0.0);
    let neighbours = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
    if neighbours.iter().any(|&(dx, dy)| at(dx, dy).2.is_some() != hit.is_some()) {
        return None;
    }
    let (enter, leave) = slab_hit(o, d, Vec3::splat(-0.5), Vec3::splat(31.5)).unwrap_or((0.0, 0.0));
    let end = hit.map_or(leave, |h| h.min(leave));
    Some((end - enter).max(0.0))
}

/// A box half inside a homogeneous volume: each pixel's brightness (white volume, black box,
/// black background) is the opacity of the volume along its ray up to the box's surface,
/// 1 - (1 - A)^L for a path of L mm. Samples 0.25 mm apart place the end of the path to within
/// a step, and the colour is 8-bit: the tolerance is (1 - A)^-0.25 - 1 of the transmittance plus
/// 1.5/255.
#[test]
fn rays_end_at_an_opaque_box_with_the_opacity_of_their_path() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let mut scene = open(dir.path(), SCENE);
    let image = scene.render_all().expect("render").remove(0).1;
    let (dims, grid_to_world) = scene.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let camera = scene.views()[0].camera.expect("a raycast view");
    let clip_to_world = to_world * camera.inv_view_proj(to_world, 1.0);
    let (mut checked, mut behind_box, mut worst) = (0, 0, 0.0f64);
    for (px, py, pixel) in image.enumerate_pixels() {
        let Some(path) = path_in_volume(clip_to_world, 64, px, py) else { continue };
        let want = 1.0 - (1.0 - A).powf(f64::from(path));
        let got = f64::from(pixel[0]) / 255.0;
        let tolerance = (1.0 - want) * ((1.0 - A).powf(-0.25) - 1.0) + 1.5 / 255.0;
        worst = worst.max((got - want).abs());
        assert!(
            (got - want).abs() <= tolerance,
            "pixel ({px}, {py}): brightness {got:.4}, the opacity of {path:.2} mm is {want:.4}"
        );
        checked += 1;
        let (o, d) = pixel_ray(clip_to_world, [(px as f32 + 0.5) / 64.0, (py as f32 + 0.5) / 64.0]);
        behind_box += usize::from(slab_hit(o, d, BOX_MIN, BOX_MAX).is_some());
    }
    assert!(checked > 2000, "most pixels are checked ({checked})");
    assert!(behind_box > 300, "many rays end at the box ({behind_box})");
    eprintln!("{checked} pixels, {behind_box} ending at the box; largest difference {worst:.4}");
}

/// The same scene without the mesh: the whole chord shows (the box made the difference).
#[test]
fn without_the_mesh_the_whole_chord_shows() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let with = open(dir.path(), SCENE).render_all().expect("render").remove(0).1;
    let without_scene = SCENE.replace("size = [64, 64]", "size = [64, 64]\nmeshes = []");
    let without = open(dir.path(), &without_scene).render_all().expect("render").remove(0).1;
    let darker = with.pixels().zip(without.pixels()).filter(|(a, b)| a[0].saturating_add(8) < b[0]).count();
    assert!(darker > 300, "the box hides the volume behind its surface ({darker} pixels darker)");
}

/// An axial slice through a needle perpendicular to it: the needle's colour rings the point
/// where it crosses (its radius away), and the slice shows elsewhere.
#[test]
fn a_slice_outlines_where_a_needle_crosses_it() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let scene_text = SCENE.replace(
        "shape = \"box\"\nmin = [16.0, 6.0, 6.0]\nmax = [40.0, 25.0, 25.0]\ncolor = [0.0, 0.0, 0.0]",
        "shape = \"needle\"\ntip = [10.0, 20.0, 4.0]\ndirection = [0.0, 0.0, 1.0]\nlength = 60.0\nradius = 3.0\ncolor = [1.0, 0.0, 0.0]",
    ) + "\n[[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.5\nsize = [128, 128]\n";
    let mut scene = open(dir.path(), &scene_text);
    let image = scene.render_all().expect("render").remove(1).1;
    let ([cx, cy], off) = scene.slice_geometry(1).expect("a slice view").world_to_pixel(Vec3::new(10.0, 20.0, 15.5));
    assert!(off.abs() < 1e-3, "the point lies on the plane ({off} mm off)");
    let px_per_mm = 128.0 / 32.0;
    let (cx, cy) = (cx * 128.0, cy * 128.0);
    let red = |p: &image::Rgba<u8>| p[0] > 200 && p[1] < 60 && p[2] < 60;
    let mut ring = 0;
    for (x, y, p) in image.enumerate_pixels() {
        let r = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)).sqrt() / px_per_mm;
        if red(p) {
            assert!((r - 3.0).abs() < 0.75, "red pixel ({x}, {y}) {r:.2} mm from the needle's axis");
            ring += 1;
        } else if !(2.0..=4.0).contains(&r) {
            assert!(p[0] > 30 && p[0] == p[1], "the slice shows at ({x}, {y}): {p:?}");
        }
    }
    assert!(ring > 40, "the ring is drawn ({ring} pixels)");
}

/// Tiles and previews render into targets of other sizes: the mesh layer follows the target.
#[test]
fn a_smaller_target_reads_a_mesh_layer_of_its_own_size() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let mut scene = open(dir.path(), SCENE);
    let full = scene.render_all().expect("render").remove(0).1;
    let gpu = scene.gpu().clone();
    let target = vrs_runtime::view::create_output(&gpu, [32, 32]).expect("a target");
    let view = target.create_view(&Default::default());
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    scene.encode_view_into(0, &mut encoder, &view, vrs_runtime::Region::whole([32, 32])).expect("encoded");
    gpu.queue.submit([encoder.finish()]);
    gpu.wait();
    let layer = scene.views()[0].renderer.mesh_layer().expect("the view reads a mesh layer");
    assert_eq!(layer.size(), [32, 32]);
    assert_eq!(full.dimensions(), (64, 64));
}

/// An overlay draws its meshes over the finished picture: a red pin inside the volume shows at
/// full colour over it, and dimmed by the volume in front of it when it is in the mesh layer
/// instead.
#[test]
fn an_overlay_shows_a_mesh_over_the_volume_in_front_of_it() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let pin = "\n[[mesh]]\nname = \"pin\"\nshape = \"needle\"\ntip = [12.0, 14.0, 16.0]\ndirection = [0.0, 0.0, 1.0]\nlength = 10.0\nradius = 2.0\ncolor = [1.0, 0.0, 0.0]\n";
    let with = |lists: &str| {
        let text = SCENE
            .replace("[[view]]", &format!("{pin}\n[[view]]"))
            .replace("size = [64, 64]", &format!("size = [64, 64]\n{lists}"));
        open(dir.path(), &text).render_all().expect("render").remove(0).1
    };
    let reddest =
        |image: &image::RgbaImage| image.pixels().map(|p| i32::from(p[0]) - i32::from(p[1])).max().unwrap_or(0);
    let over = with("meshes = [\"block\"]\noverlay = [\"pin\"]");
    let under = with("meshes = [\"block\", \"pin\"]");
    assert!(reddest(&over) > 200, "the overlay shows the pin at full colour ({})", reddest(&over));
    assert!(
        reddest(&under) < reddest(&over) - 40,
        "under the volume the pin is dimmed ({} vs {})",
        reddest(&under),
        reddest(&over)
    );
}

/// A slice view on its plane in the 3D view: the rays that meet the plane end there and show the
/// slice's picture (nearly white: the slice stands for a thick slab of the white volume), so
/// the plane's pixels are brighter than the volume's chord behind them; the other pixels stay.
#[test]
fn a_slice_view_shows_on_its_plane_in_the_3d_view() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let axial = "\n[[view]]\nname = \"axial\"\nkind = \"slice\"\naxis = \"axial\"\nposition = 0.5\nsize = [64, 64]\nmeshes = []\nrender = { background = [0.0, 0.0, 0.0, 0.0] }\n";
    let without = format!("{}{axial}", SCENE.replace("size = [64, 64]", "size = [64, 64]\nmeshes = []"));
    let with = without.replace("meshes = []", "meshes = []\nplanes = [\"axial\"]");
    let plain = open(dir.path(), &without).render_all().expect("render").remove(0).1;
    let mut scene = open(dir.path(), &with);
    let shown = scene.render_all().expect("render").remove(0).1;
    assert!(scene.views()[0].renderer.reads_mesh_layer(), "the plane makes a mesh layer");
    let brighter = shown.pixels().zip(plain.pixels()).filter(|(a, b)| a[0] > b[0].saturating_add(20)).count();
    let darker = shown.pixels().zip(plain.pixels()).filter(|(a, b)| a[0].saturating_add(2) < b[0]).count();
    assert!(brighter > 500, "the plane shows ({brighter} pixels brighter)");
    assert_eq!(darker, 0, "nothing gets darker: the slice is the volume's brightest");
}

/// Whether the pixel's ray meets the box: `Some(true)` where it does at the pixel's centre and
/// its four neighbours, `Some(false)` where none of them does, `None` on the silhouette.
fn meets_box(clip_to_world: Mat4, size: u32, px: u32, py: u32) -> Option<bool> {
    let at = |dx: f32, dy: f32| {
        let pixel = [(px as f32 + 0.5 + dx) / size as f32, (py as f32 + 0.5 + dy) / size as f32];
        let (o, d) = pixel_ray(clip_to_world, pixel);
        slab_hit(o, d, BOX_MIN, BOX_MAX).is_some()
    };
    let centre = at(0.0, 0.0);
    let neighbours = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
    neighbours.iter().all(|&(dx, dy)| at(dx, dy) == centre).then_some(centre)
}

/// How far a pixel the fade must leave alone may move, per channel in 1/255: the same shader
/// but for a branch not taken, on the same device (one step of rounding allowed).
const UNCHANGED: u8 = 1;

/// A user's pipeline function reads the mesh layer: it fades the volume within 4 mm in front of
/// the box (`t_geometry - t`, in mm through `dt_mm / dt`), so the pixels whose rays end at the
/// box get darker and no other pixel changes: every pixel whose ray misses the box (off its
/// silhouette) stays within [`UNCHANGED`] of the plain picture in every channel.
#[test]
fn a_user_function_fades_the_volume_near_the_surface() {
    let dir = tempfile::tempdir().expect("a folder");
    homogeneous_volume(dir.path());
    let fade = "/// Hides the volume within `fade_mm` in front of the first opaque mesh.\n\
        pipeline fade_near_mesh after compositing.primary_color {\n    \
        uniform fade_mm: f32 = 4.0 in 0.0 .. 50.0;\n    @ray state t_geometry: f32 = 1e30;\n    \
        @ray state dt: f32;\n    @ray state dt_mm: f32;\n    state t: f32;\n    state src: vec4f;\n\n    \
        let mm = (state.t_geometry - state.t) * state.dt_mm / max(state.dt, 1e-9);\n    \
        if mm < fade_mm {\n        state.src.a = 0.0;\n    }\n}\n";
    std::fs::write(dir.path().join("fade.vrs"), fade).expect("module written");
    let plain = open(dir.path(), SCENE).render_all().expect("render").remove(0).1;
    let faded_scene = format!("{SCENE}\n[[module]]\npath = \"fade.vrs\"\n");
    let mut faded_renderer = open(dir.path(), &faded_scene);
    let faded = faded_renderer.render_all().expect("render").remove(0).1;
    let darker = faded.pixels().zip(plain.pixels()).filter(|(a, b)| a[0].saturating_add(4) < b[0]).count();
    let brighter = faded.pixels().zip(plain.pixels()).filter(|(a, b)| a[0] > b[0].saturating_add(1)).count();
    assert!(darker > 300, "the volume in front of the box fades ({darker} pixels darker)");
    assert_eq!(brighter, 0, "nothing gets brighter");
    let (dims, grid_to_world) = faded_renderer.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let camera = faded_renderer.views()[0].camera.expect("a raycast view");
    let clip_to_world = to_world * camera.inv_view_proj(to_world, 1.0);
    let mut away = 0;
    for (px, py, f) in faded.enumerate_pixels() {
        if meets_box(clip_to_world, 64, px, py) != Some(false) {
            continue;
        }
        let p = plain.get_pixel(px, py);
        let moved = (0..4).map(|c| f[c].abs_diff(p[c])).max().unwrap_or(0);
        assert!(moved <= UNCHANGED, "pixel ({px}, {py}) misses the box but changed: {p:?} -> {f:?}");
        away += 1;
    }
    assert!(away > 1000, "most pixels miss the box ({away} checked)");
}

/// The ray parameters where `origin + t dir` (unit `dir`) meets the sphere, if it does.
fn sphere_hit(origin: Vec3, dir: Vec3, centre: Vec3, radius: f32) -> Option<(f32, f32)> {
    let to = origin - centre;
    let b = to.dot(dir);
    let disc = b * b - (to.length_squared() - radius * radius);
    (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
}

/// [`SCENE`] at `size` pixels looking along an axis (so that a ball fits between the box and the
/// near plane, which touches the sphere around the box), with the homogeneous volume written
/// into `dir`; the scene's text with its box, the picture of the volume alone and the view's
/// clip space to patient space.
fn along_an_axis(dir: &Path, size: u32) -> (String, image::RgbaImage, Mat4) {
    homogeneous_volume(dir);
    let sized = format!("size = [{size}, {size}]");
    let scene = SCENE
        .replace("azimuth = 60.0, elevation = 25.0", "azimuth = 0.0, elevation = 0.0")
        .replace("size = [64, 64]", &sized);
    let mut alone = open(dir, &scene.replace(&sized, &format!("{sized}\nmeshes = []")));
    let volume = alone.render_all().expect("render").remove(0).1;
    let (dims, grid_to_world) = alone.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let clip_to_world = to_world * alone.views()[0].camera.expect("a raycast view").inv_view_proj(to_world, 1.0);
    (scene, volume, clip_to_world)
}

/// `scene` with its box replaced by a sphere of `centre`, `radius`, `color` and `opacity`.
fn with_ball(scene: &str, centre: Vec3, radius: f32, opacity: f32) -> String {
    let ball = format!(
        "shape = \"sphere\"\ncentre = [{}, {}, {}]\nradius = {radius}\ncolor = [1.0, 0.0, 0.0]\nopacity = {opacity:?}",
        centre.x, centre.y, centre.z
    );
    scene.replace("shape = \"box\"\nmin = [16.0, 6.0, 6.0]\nmax = [40.0, 25.0, 25.0]\ncolor = [0.0, 0.0, 0.0]", &ball)
}

/// A translucent red ball between the camera and the homogeneous volume (no volume around it):
/// the volume behind it shows through both of its surfaces, so the green channel (the white
/// volume's alone: the ball is red) is the volume's without the ball times (1 - opacity)^2.
/// Blending the volume over the mesh layer (the order before meshes were peeled) leaves the
/// green channel as it is without the ball. The ball's colour is 8-bit (0.5 is 128/255), so the
/// tolerance is 2/255 plus 1% of the green. A ball made translucent while shown gives the same.
#[test]
fn a_translucent_mesh_in_front_of_the_volume_veils_it() {
    let dir = tempfile::tempdir().expect("a folder");
    let (scene, volume, clip_to_world) = along_an_axis(dir.path(), 128);
    // On the way from the volume's centre to the camera, just clear of the volume's box.
    let (_, forward) = pixel_ray(clip_to_world, [0.5, 0.5]);
    let (middle, radius) = (Vec3::splat(15.5), 5.0);
    let (_, exit) = slab_hit(middle, -forward, Vec3::splat(-0.5), Vec3::splat(31.5)).expect("inside the box");
    let centre = middle - forward * (exit + radius + 0.5);
    let scene_text = with_ball(&scene, centre, radius, 0.5);
    let veiled = open(dir.path(), &scene_text).render_all().expect("render").remove(0).1;
    let transmitted = (1.0 - 128.0 / 255.0f64).powi(2);
    let (mut checked, mut worst) = (0, 0.0f64);
    for (px, py, pixel) in veiled.enumerate_pixels() {
        let at = |dx: f32, dy: f32| {
            let (o, d) = pixel_ray(clip_to_world, [(px as f32 + 0.5 + dx) / 128.0, (py as f32 + 0.5 + dy) / 128.0]);
            sphere_hit(o, d, centre, radius).is_some()
        };
        // Well inside the ball's outline, where the volume behind it shows.
        let behind = f64::from(volume.get_pixel(px, py)[1]) / 255.0;
        if !at(0.0, 0.0) || [(1.5, 0.0), (-1.5, 0.0), (0.0, 1.5), (0.0, -1.5)].iter().any(|&(x, y)| !at(x, y)) {
            continue;
        }
        let want = behind * transmitted;
        let got = f64::from(pixel[1]) / 255.0;
        worst = worst.max((got - want).abs());
        assert!(
            (got - want).abs() <= 2.0 / 255.0 + 0.01 * behind,
            "pixel ({px}, {py}): green {got:.4}, the volume's {behind:.4} through the ball is {want:.4}"
        );
        assert!(pixel[0] > pixel[1], "pixel ({px}, {py}): the ball's red shows: {pixel:?}");
        checked += usize::from(behind > 0.3);
    }
    assert!(checked > 100, "many pixels show the volume through the ball ({checked})");
    eprintln!("{checked} pixels through the ball; largest difference {worst:.4}");
    // Made translucent while shown (a viewer's panel), without composing again: the same.
    let mut opaque = open(dir.path(), &scene_text.replace("opacity = 0.5", "opacity = 1.0"));
    let model = opaque.meshes()[0].model;
    opaque.set_mesh_style("block", [1.0, 0.0, 0.0], 0.5, model).expect("the mesh's style");
    assert!(opaque.render_all().expect("render").remove(0).1 == veiled, "made translucent in the panel");
}

/// An opaque ball between the camera and the volume, reaching further from the volume's centre
/// than the volume's own sphere (a needle's handle does): drawn whole, so no pixel inside its
/// outline shows the volume (green) through it. With the volume's planes for the mesh layer too,
/// its front was cut away at the near plane and the volume showed through the hole.
#[test]
fn a_mesh_beyond_the_volumes_reach_is_drawn_whole() {
    let dir = tempfile::tempdir().expect("a folder");
    let (scene, _, clip_to_world) = along_an_axis(dir.path(), 64);
    let (_, forward) = pixel_ray(clip_to_world, [0.5, 0.5]);
    // The box's sphere has a radius of 27.7 mm; the ball's front lies 16 + 1 + 16 = 33 mm out.
    let (middle, radius) = (Vec3::splat(15.5), 8.0);
    let centre = middle - forward * (16.0 + 1.0 + radius);
    let text = with_ball(&scene, centre, radius, 1.0);
    let image = open(dir.path(), &text).render_all().expect("render").remove(0).1;
    let mut inside = 0;
    for (px, py, pixel) in image.enumerate_pixels() {
        let covered = [(0.0, 0.0), (1.5, 0.0), (-1.5, 0.0), (0.0, 1.5), (0.0, -1.5)].iter().all(|&(dx, dy)| {
            let (o, d) = pixel_ray(clip_to_world, [(px as f32 + 0.5 + dx) / 64.0, (py as f32 + 0.5 + dy) / 64.0]);
            sphere_hit(o, d, centre, radius).is_some()
        });
        if covered {
            assert!(pixel[1] == 0 && pixel[0] > 60, "pixel ({px}, {py}) inside the ball shows {pixel:?}");
            inside += 1;
        }
    }
    assert!(inside > 200, "the ball covers many pixels ({inside})");
}

/// The green of a ray (the white volume's share; the translucent surfaces are red) through the
/// homogeneous volume over ray parameters `volume` (mm) and translucent surfaces of opacity
/// `alpha` at `surfaces`, composited front to back: a stretch of volume `len` mm long adds
/// `T (1 - (1 - A)^len)` and leaves `T (1 - A)^len`, a surface leaves `T (1 - alpha)`.
fn composite_green((v0, v1): (f32, f32), surfaces: &[f32], alpha: f64) -> f64 {
    let (mut at, mut transmitted, mut green) = (v0, 1.0f64, 0.0f64);
    let mut stretch = |from: f32, to: f32, transmitted: &mut f64| {
        let kept = (1.0 - A).powf(f64::from(to - from));
        green += *transmitted * (1.0 - kept);
        *transmitted *= kept;
    };
    let mut sorted = surfaces.to_vec();
    sorted.sort_by(f32::total_cmp);
    for s in sorted {
        if s > at && at < v1 {
            stretch(at, s.min(v1), &mut transmitted);
            at = s.min(v1);
        }
        transmitted *= 1.0 - alpha;
    }
    if at < v1 {
        stretch(at, v1, &mut transmitted);
    }
    green
}

/// A translucent red ball (opacity 0.5) in front of, inside and behind the homogeneous volume:
/// each pixel's green is the front-to-back composite of the volume's stretches and the ball's
/// two surfaces along its ray ([`composite_green`]). Samples 0.25 mm apart place each of the
/// three boundaries on a ray (the volume's entry and the two surfaces) to within a step, each
/// a step's opacity `1 - (1 - A)^0.25` at most, and the colours are 8-bit: the tolerance is
/// three steps' opacity plus 2/255 (measured: 0.011 at most). Blending the volume over the mesh
/// layer, as before meshes were peeled, fails at once: green 0.82 where the composite is 0.20
/// (the ball in front).
#[test]
fn a_translucent_ball_in_front_of_inside_and_behind_the_volume_composites_in_depth_order() {
    let dir = tempfile::tempdir().expect("a folder");
    let (scene, _, clip_to_world) = along_an_axis(dir.path(), 96);
    let (_, forward) = pixel_ray(clip_to_world, [0.5, 0.5]);
    let middle = Vec3::splat(15.5);
    let step = 1.0 - (1.0 - A).powf(0.25);
    let tolerance = 3.0 * step + 2.0 / 255.0;
    // (where, centre, radius): just clear of the box on either side, and around the centre.
    let places = [
        ("in front", middle - forward * (16.0 + 5.5), 5.0),
        ("inside", middle + Vec3::new(2.0, -1.0, 1.5), 8.0),
        ("behind", middle + forward * (16.0 + 5.5), 5.0),
    ];
    for (place, centre, radius) in places {
        let text = with_ball(&scene, centre, radius, 0.5);
        let image = open(dir.path(), &text).render_all().expect("render").remove(0).1;
        let (mut checked, mut worst) = (0, 0.0f64);
        for (px, py, pixel) in image.enumerate_pixels() {
            let ray = |dx: f32, dy: f32| {
                pixel_ray(clip_to_world, [(px as f32 + 0.5 + dx) / 96.0, (py as f32 + 0.5 + dy) / 96.0])
            };
            // Pixels on the ball's or the box's outline are left out (coverage decides them).
            let (o, d) = ray(0.0, 0.0);
            let hits = |(o, d): (Vec3, Vec3)| {
                (
                    sphere_hit(o, d, centre, radius).is_some(),
                    slab_hit(o, d, Vec3::splat(-0.5), Vec3::splat(31.5)).is_some(),
                )
            };
            let here = hits((o, d));
            if [(1.5, 0.0), (-1.5, 0.0), (0.0, 1.5), (0.0, -1.5)].iter().any(|&(x, y)| hits(ray(x, y)) != here) {
                continue;
            }
            let volume = slab_hit(o, d, Vec3::splat(-0.5), Vec3::splat(31.5)).unwrap_or((0.0, 0.0));
            let surfaces: Vec<f32> = sphere_hit(o, d, centre, radius).map_or(Vec::new(), |(a, b)| vec![a, b]);
            let want = composite_green(volume, &surfaces, 128.0 / 255.0);
            let got = f64::from(pixel[1]) / 255.0;
            worst = worst.max((got - want).abs());
            assert!(
                (got - want).abs() <= tolerance,
                "{place}, pixel ({px}, {py}): green {got:.4}, the composite along its ray {want:.4}"
            );
            checked += usize::from(!surfaces.is_empty() && here.1);
        }
        assert!(checked > 100, "{place}: many pixels see the volume and the ball ({checked})");
        eprintln!("{place}: {checked} pixels through both; largest difference {worst:.4} (tolerance {tolerance:.4})");
    }
}
