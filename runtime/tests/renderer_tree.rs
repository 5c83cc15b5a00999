//! Renderer trees on lavapipe: an occlusion group's hidden children show through the first
//! child as the reference's rule says, against the pictures of each child alone; a shadow
//! group's shadow falls where its light's rays meet the shadowing mesh.

use crate::common;

use glam::{Mat4, Vec3};
use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// A transparent volume (32^3 voxels of 1 mm; the transfer function is clear everywhere), so a
/// view's picture is its mesh layer's colour over the black background; the scenes below follow.
const TRANSPARENT_VOLUME: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0
background = [0.0, 0.0, 0.0, 1.0]

[[volume]]
name = "cube"
role = "primary"
path = "cube.nrrd"
window = [0.0, 1000.0]
tf = "clear.json"
"#;

/// A box of tissue with a vessel inside, in an occlusion group.
const SCENE: &str = r#"
[[mesh]]
name = "tissue"
shape = "box"
min = [8.0, 6.0, 6.0]
max = [26.0, 25.0, 25.0]
color = [0.0, 0.3, 1.0]

[[mesh]]
name = "vessel"
shape = "sphere"
centre = [17.0, 15.5, 15.5]
radius = 6.0
color = [1.0, 0.2, 0.0]

[[group]]
name = "liver"
kind = "occlusion"
children = ["tissue", "vessel"]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 60.0, elevation = 25.0, distance = 2.2 }
"#;

/// The scene of `TRANSPARENT_VOLUME` and `scene`, its view's picture `picture`, written into
/// `dir` with its volume and opened.
fn open(dir: &Path, scene: &str, picture: &str) -> SceneRenderer {
    let text = scene.replace("size = [64, 64]", &format!("size = [64, 64]\npicture = {picture}"));
    common::open_with_clear_cube(dir, &format!("{TRANSPARENT_VOLUME}{text}"))
}

fn render(dir: &Path, scene: &str, picture: &str) -> image::RgbaImage {
    open(dir, scene, picture).render_all().expect("render").remove(0).1
}

/// The occlusion group against its children alone: where the vessel (wholly inside the
/// tissue) shows, the group's picture is `k vessel + (1 - k) tissue` per channel (both opaque:
/// the rule `k F + (1 - k F.a) C`), elsewhere the tissue's; `k` is the group's hidden opacity.
/// Colours pass through 8-bit images twice, so the tolerance is 3/255.
fn assert_occlusion(dir: &Path, scene: &str, k: f32) {
    let tissue = render(dir, scene, r#"["tissue", "volume"]"#);
    let vessel = render(dir, scene, r#"["vessel", "volume"]"#);
    let group = render(dir, scene, r#"["liver", "volume"]"#);
    let (mut hidden, mut worst) = (0, 0.0f32);
    for ((c, f), got) in tissue.pixels().zip(vessel.pixels()).zip(group.pixels()) {
        let covered = f[0] > 0 || f[1] > 0 || f[2] > 0;
        hidden += usize::from(covered);
        for ch in 0..3 {
            let want = if covered { k * f32::from(f[ch]) + (1.0 - k) * f32::from(c[ch]) } else { f32::from(c[ch]) };
            let off = (f32::from(got[ch]) - want).abs();
            worst = worst.max(off);
            assert!(off <= 3.0, "channel {ch}: {got:?}, want {want} from tissue {c:?} and vessel {f:?} (k = {k})");
        }
    }
    assert!(hidden > 150, "the vessel covers many pixels ({hidden})");
    assert!(tissue != group, "the vessel shows through the tissue");
    eprintln!("k = {k}: {hidden} pixels show the hidden vessel; largest difference {worst}/255");
}

#[test]
fn an_occlusion_group_shows_what_its_first_child_hides_semi_transparently() {
    let dir = tempfile::tempdir().expect("a folder");
    assert_occlusion(dir.path(), SCENE, vrsc::scene::DEFAULT_HIDDEN_OPACITY);
    let thin = SCENE.replace("kind = \"occlusion\"", "kind = \"occlusion\"\nopacity = 0.25");
    assert_occlusion(dir.path(), &thin, 0.25);
}

#[test]
fn an_occlusion_group_with_show_visible_shows_the_hidden_children_whole() {
    let dir = tempfile::tempdir().expect("a folder");
    let visible = SCENE.replace("kind = \"occlusion\"", "kind = \"occlusion\"\nshow = \"visible\"");
    assert_occlusion(dir.path(), &visible, 1.0);
}

/// A depth group is the same picture as its children listed in the view.
#[test]
fn a_depth_group_draws_as_its_children_would() {
    let dir = tempfile::tempdir().expect("a folder");
    let depth = SCENE.replace("kind = \"occlusion\"", "kind = \"depth\"");
    let listed = render(dir.path(), &depth, r#"["tissue", "vessel", "volume"]"#);
    let grouped = render(dir.path(), &depth, r#"["liver", "volume"]"#);
    assert!(listed == grouped, "a depth group draws its children as the view would");
    let tissue = render(dir.path(), &depth, r#"["tissue", "volume"]"#);
    assert!(listed == tissue, "the vessel inside the tissue is hidden");
    // Translucent meshes in a depth group are peeled into the rays' depth order, as listed
    // ones are; an occlusion group blends its own.
    let peels =
        |scene: &str| open(dir.path(), scene, r#"["liver", "volume"]"#).views()[0].renderer.reads_translucent_layers();
    assert!(peels(&depth), "a depth group's meshes are peeled");
    assert!(!peels(SCENE), "an occlusion group's are blended in its parts");
}

/// A white floor under a ball, in a shadow group lit from `LIGHT`, seen from above.
const SHADOW_SCENE: &str = r#"
[[mesh]]
name = "floor"
shape = "box"
min = [-30.0, -30.0, 0.0]
max = [62.0, 62.0, 2.0]
color = [1.0, 1.0, 1.0]

[[mesh]]
name = "ball"
shape = "sphere"
centre = [15.5, 15.5, 14.0]
radius = 5.0
color = [1.0, 0.0, 0.0]

[[group]]
name = "lit"
kind = "shadow"
light = [1.0, 0.0, 2.0]
children = ["floor", "ball"]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 0.0, elevation = 70.0, distance = 2.2 }
"#;

const LIGHT: Vec3 = Vec3::new(1.0, 0.0, 2.0);
const BALL: (Vec3, f32) = (Vec3::new(15.5, 15.5, 14.0), 5.0);

/// Where the ray `origin + t dir` meets the sphere `(centre, radius)` in front of its origin.
fn meets_ball(origin: Vec3, dir: Vec3) -> bool {
    let (disc, b) = sphere_discriminant(origin, dir, BALL);
    disc > 0.0 && -b + disc.sqrt() > 0.0
}

/// For the ray `origin + t dir` (`dir` a unit vector) and the sphere `(centre, radius)`: the
/// discriminant of the intersection (positive: the line crosses the sphere; mm^2) and the ray's
/// projection `b` on the way to the centre (the crossings lie at `t = -b +- sqrt(disc)`).
fn sphere_discriminant(origin: Vec3, dir: Vec3, (centre, radius): (Vec3, f32)) -> (f32, f32) {
    let to = origin - centre;
    let b = to.dot(dir);
    (b * b - (to.length_squared() - radius * radius), b)
}

/// What the pixel at `[x, y]` (in [0, 1]^2) shows: `None` for the ball or nothing, else whether
/// the floor's top there lies in the ball's shadow.
fn floor_in_shadow(clip_to_world: Mat4, [x, y]: [f32; 2]) -> Option<bool> {
    let ndc = |z| Vec3::new(x * 2.0 - 1.0, 1.0 - y * 2.0, z);
    let near = clip_to_world.project_point3(ndc(0.0));
    let dir = (clip_to_world.project_point3(ndc(1.0)) - near).normalize();
    if meets_ball(near, dir) || dir.z >= 0.0 {
        return None;
    }
    let floor = near + dir * ((2.0 - near.z) / dir.z);
    Some(meets_ball(floor, LIGHT.normalize()))
}

/// The floor's top in the ball's shadow has the ambient light alone (0.3 of its white); the
/// rest of it the light's Lambert term too (0.3 + 0.7 n.l, n.l = 2/sqrt(5)). Pixels whose
/// neighbours 1.5 pixels away fall otherwise are left out (the shadow's soft edge, the ball's
/// outline); the tolerance is 4/255.
#[test]
fn a_shadow_group_casts_the_balls_shadow_where_its_light_says() {
    let dir = tempfile::tempdir().expect("a folder");
    let mut renderer = open(dir.path(), SHADOW_SCENE, r#"["lit", "volume"]"#);
    let image = renderer.render_all().expect("render").remove(0).1;
    let (dims, grid_to_world) = renderer.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let camera = renderer.views()[0].camera.expect("a raycast view");
    let clip_to_world = to_world * camera.inv_view_proj(to_world, 1.0);
    let lit = 255.0 * (0.3 + 0.7 * 2.0 / 5.0f32.sqrt());
    let (mut shadowed, mut bright) = (0, 0);
    for (px, py, pixel) in image.enumerate_pixels() {
        let at = |dx: f32, dy: f32| {
            floor_in_shadow(clip_to_world, [(px as f32 + 0.5 + dx) / 64.0, (py as f32 + 0.5 + dy) / 64.0])
        };
        let here = at(0.0, 0.0);
        if here.is_none() || [(1.5, 0.0), (-1.5, 0.0), (0.0, 1.5), (0.0, -1.5)].iter().any(|&(x, y)| at(x, y) != here) {
            continue;
        }
        let in_shadow = here == Some(true);
        let want = if in_shadow { 255.0 * 0.3 } else { lit };
        let got = f32::from(pixel[1]);
        assert!((got - want).abs() <= 4.0, "pixel ({px}, {py}) {pixel:?}: in shadow {in_shadow}, want {want:.1}");
        if in_shadow { shadowed += 1 } else { bright += 1 }
    }
    assert!(shadowed > 30 && bright > 300, "{shadowed} pixels in the shadow, {bright} lit");
    eprintln!("{shadowed} floor pixels in the ball's shadow, {bright} lit, each as computed");
}

/// An occlusion group's opacity changed while shown (a viewer's panel) gives the picture of the
/// scene written with it.
#[test]
fn an_occlusion_groups_opacity_changes_live() {
    let dir = tempfile::tempdir().expect("a folder");
    let thin = SCENE.replace("kind = \"occlusion\"", "kind = \"occlusion\"\nopacity = 0.25");
    let written = render(dir.path(), &thin, r#"["liver", "volume"]"#);
    let mut scene = open(dir.path(), SCENE, r#"["liver", "volume"]"#);
    assert_eq!(scene.occlusion_groups(), [("liver".to_string(), 0.5)]);
    let before = scene.render_all().expect("render").remove(0).1;
    scene.set_group_opacity("liver", 0.25).expect("the group's opacity");
    assert_eq!(scene.occlusion_groups(), [("liver".to_string(), 0.25)]);
    let after = scene.render_all().expect("render").remove(0).1;
    assert!(after == written && after != before, "the picture of the scene written with opacity 0.25");
    assert!(scene.set_group_opacity("kidney", 0.5).is_err(), "no such group");
    assert!(scene.set_group_opacity("liver", f32::NAN).is_err(), "not a number");
}

/// A shadow group whose `light` names a light follows its `light_dir_NAME` as the view has it,
/// changed live too: the pictures of the same group with that direction written out.
#[test]
fn a_shadow_group_follows_its_named_lights_direction() {
    let dir = tempfile::tempdir().expect("a folder");
    let lit_view = |light: &str| {
        SHADOW_SCENE
            .replace("light = [1.0, 0.0, 2.0]", &format!("light = {light}"))
            .replace("camera = {", "render = { shading = true, lights = [\"key\"] }\ncamera = {")
            + "\n[uniforms]\nlight_dir_key = [1.0, 0.0, 2.0]\n"
    };
    let picture = r#"["lit", "volume"]"#;
    let mut named = open(dir.path(), &lit_view("\"key\""), picture);
    let first = named.render_all().expect("render").remove(0).1;
    assert!(first == render(dir.path(), &lit_view("[1.0, 0.0, 2.0]"), picture), "the light's direction");
    named.set_uniform("light_dir_key", [-1.0f32, 0.0, 2.0]).expect("the light's uniform");
    let moved = named.render_all().expect("render").remove(0).1;
    assert!(moved != first, "the shadow moves with the light");
    assert!(moved == render(dir.path(), &lit_view("[-1.0, 0.0, 2.0]"), picture), "its new direction");
}

/// A vessel partly outside the tissue (through its face towards the camera): where the vessel is
/// in front (the depth combination shows it), the group shows it as it is; where the tissue
/// hides it, `k vessel + (1 - k) tissue`. Pixels the depth combination shows as neither alone
/// (the outline where the vessel enters the tissue) are left out.
#[test]
fn an_occlusion_group_leaves_what_lies_in_front_of_its_first_child_as_it_is() {
    let dir = tempfile::tempdir().expect("a folder");
    let scene = SCENE.replace("centre = [17.0, 15.5, 15.5]", "centre = [23.0, 15.5, 15.5]");
    let k = vrsc::scene::DEFAULT_HIDDEN_OPACITY;
    let [tissue, vessel, depth, group] = [
        r#"["tissue", "volume"]"#,
        r#"["vessel", "volume"]"#,
        r#"["tissue", "vessel", "volume"]"#,
        r#"["liver", "volume"]"#,
    ]
    .map(|picture| render(dir.path(), &scene, picture));
    let (mut in_front, mut hidden) = (0, 0);
    for (x, y, got) in group.enumerate_pixels() {
        let (c, f, d) = (tissue.get_pixel(x, y), vessel.get_pixel(x, y), depth.get_pixel(x, y));
        if f[0] == 0 && f[1] == 0 && f[2] == 0 {
            continue;
        }
        let want: [f32; 3] = if d == f {
            in_front += 1;
            [0, 1, 2].map(|ch| f32::from(f[ch]))
        } else if d == c {
            hidden += 1;
            [0, 1, 2].map(|ch| k * f32::from(f[ch]) + (1.0 - k) * f32::from(c[ch]))
        } else {
            continue;
        };
        for ch in 0..3 {
            assert!((f32::from(got[ch]) - want[ch]).abs() <= 3.0, "({x}, {y}): {got:?}, want {want:?}");
        }
    }
    assert!(in_front > 50 && hidden > 50, "{in_front} pixels in front, {hidden} hidden");
    eprintln!("{in_front} vessel pixels in front of the tissue, {hidden} behind it, each as the rule says");
}

/// A slab of tissue (the volume: opaque white below z = 8.5 mm) under the ball and a post beside
/// it (which makes the group's shadow map asymmetric), shaded by the light `key` from [1, 0, 2],
/// which a shadow group around them follows.
const SLAB_SCENE: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0
shading = true
lights = ["key"]
background = [0.0, 0.0, 0.0, 1.0]
empty_space_skipping = false

[[volume]]
name = "slab"
role = "primary"
path = "slab.nrrd"
window = [0.0, 1000.0]
tf = "opaque.json"

[uniforms]
light_dir_key = [1.0, 0.0, 2.0]

[[mesh]]
name = "ball"
shape = "sphere"
centre = [15.5, 15.5, 14.0]
radius = 5.0
color = [1.0, 0.0, 0.0]

[[mesh]]
name = "post"
shape = "box"
min = [22.0, 20.0, 11.0]
max = [26.0, 24.0, 16.0]
color = [0.0, 1.0, 0.0]

[[group]]
name = "lit"
kind = "shadow"
light = "key"
children = ["ball", "post"]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 0.0, elevation = 70.0, distance = 2.2 }
"#;

/// The meshes of a shadow group that follows a light of the view shadow the volume's shading of
/// that light (`std::mesh_shadow`): against the same view without the group, a pixel of the
/// slab is darker exactly where the ray from its surface point (the `pos` probe at opacity 0.5)
/// towards the light meets the ball or the post, and unchanged elsewhere. Pixels whose neighbours fall
/// otherwise (the shadow's edge) and the ball's own pixels are left out.
#[test]
fn a_shadow_groups_meshes_shadow_the_volume_from_the_light_it_follows() {
    let dir = tempfile::tempdir().expect("a folder");
    let slab = |_x: usize, z: usize| z < 9;
    let open_with = |picture: &str| {
        let text = SLAB_SCENE.replace("size = [64, 64]", &format!("size = [64, 64]\npicture = {picture}"));
        open_tissue(dir.path(), ("slab.nrrd", &slab), &text)
    };
    let mut plain = open_with(r#"["ball", "post", "volume"]"#);
    let before = plain.render_all().expect("render").remove(0).1;
    let probe = plain.render_probe(0, &vrs_runtime::ProbeSpec::of("pos")).expect("the pos probe");
    let (dims, grid_to_world) = plain.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let after = open_with(r#"["lit", "volume"]"#).render_all().expect("render").remove(0).1;
    let in_shadow = |x: i64, y: i64| -> Option<bool> {
        let (x, y) = (u32::try_from(x).ok()?, u32::try_from(y).ok()?);
        let p = probe.values.at(x, y)?;
        let surface = to_world.transform_point3(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
        Some(meets_ball(surface, LIGHT.normalize()) || meets_post(surface, LIGHT.normalize()))
    };
    let (mut shadowed, mut lit) = (0, 0);
    for (x, y, pixel) in after.enumerate_pixels() {
        let (xi, yi) = (i64::from(x), i64::from(y));
        let here = in_shadow(xi, yi);
        if here.is_none()
            || [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|(dx, dy)| in_shadow(xi + dx, yi + dy) != here)
        {
            continue;
        }
        let (got, was) = (i32::from(pixel[1]), i32::from(before.get_pixel(x, y)[1]));
        if here == Some(true) {
            assert!(was - got > 40, "({x}, {y}) lies in the shadow: {got} against {was} without it");
            shadowed += 1;
        } else {
            assert!((got - was).abs() <= 1, "({x}, {y}) lies in the light: {got} against {was}");
            lit += 1;
        }
    }
    assert!(shadowed > 20 && lit > 300, "{shadowed} slab pixels in the shadow, {lit} lit");
}

/// Whether the ray `origin + t dir` (t > 0) meets the post of `SLAB_SCENE` (a slab test).
fn meets_post(origin: Vec3, dir: Vec3) -> bool {
    let (lo, hi) = (Vec3::new(22.0, 20.0, 11.0), Vec3::new(26.0, 24.0, 16.0));
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for axis in 0..3 {
        let (a, b) = ((lo[axis] - origin[axis]) / dir[axis], (hi[axis] - origin[axis]) / dir[axis]);
        near = near.max(a.min(b));
        far = far.min(a.max(b));
    }
    near <= far
}

/// Writes the volume `file` (32^3 voxels of 1 mm: opaque white tissue where `inside(x, z)`,
/// nothing elsewhere, through the transfer function `opaque.json`) and `scene` into `dir`, and
/// opens the scene.
fn open_tissue(dir: &Path, (file, inside): (&str, &dyn Fn(usize, usize) -> bool), scene: &str) -> SceneRenderer {
    let side = 32usize;
    let values: Vec<f32> =
        (0..side * side * side).map(|i| if inside(i % side, i / (side * side)) { 1000.0 } else { 0.0 }).collect();
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    common::write_nrrd(&dir.join(file), "RAS", [32; 3], identity, [0.0; 3], &values);
    let tf = r#"[{"Name": "opaque", "RGBPoints": [0, 1, 1, 1, 1000, 1, 1, 1], "Points": [0, 0, 0.5, 0, 499, 0, 0.5, 0, 500, 1, 0.5, 0, 1000, 1, 0.5, 0]}]"#;
    std::fs::write(dir.join("opaque.json"), tf).expect("tf written");
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).expect("scene written");
    SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"))
}

/// An opaque shelf of tissue (the volume: x < 15.5 mm, 19.5 mm < z < 23.5 mm) over a floor in a
/// shadow group that follows the light `key`, straight above; the view's volume casts shadows
/// from light volumes (`shadows = "volume"`, which the test replaces by the other modes).
const SHELF_SCENE: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0
shading = true
lights = ["key"]
shadows = "volume"
background = [0.0, 0.0, 0.0, 1.0]

[[volume]]
name = "shelf"
role = "primary"
path = "shelf.nrrd"
window = [0.0, 1000.0]
tf = "opaque.json"

[uniforms]
light_dir_key = [0.0, 0.0, 1.0]

[[mesh]]
name = "floor"
shape = "box"
min = [0.0, 0.0, 2.0]
max = [31.0, 31.0, 4.0]
color = [1.0, 1.0, 1.0]

[[group]]
name = "lit"
kind = "shadow"
light = "key"
children = ["floor"]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
picture = ["lit", "volume"]
camera = { azimuth = 0.0, elevation = 12.0, distance = 2.2 }
"#;

/// The volume shadows the meshes of a shadow group that follows a light it is shaded with,
/// whatever its own `shadows` (from light volumes, rays, or none on itself): the floor's top (lit straight from above: 0.3 + 0.7 of its white) is dark
/// (0.3) under the shelf and lit beside it, within 8/255 (the light volume is read
/// trilinearly); pixels within 2 mm of the shelf's edge, and those the shelf covers, are left
/// out.
#[test]
fn the_volume_shadows_a_shadow_groups_meshes_from_the_light_it_follows() {
    for shadows in ["volume", "rays", "off"] {
        let scene = SHELF_SCENE.replace(r#"shadows = "volume""#, &format!("shadows = {shadows:?}"));
        let (dark, lit) = shelf_shadow_on_floor(&scene);
        assert!(dark > 50 && lit > 50, "shadows = {shadows:?}: {dark} floor pixels under the shelf, {lit} beside it");
        eprintln!("shadows = {shadows:?}: {dark} floor pixels in the shelf's shadow, {lit} lit, each as computed");
    }
}

/// Renders the shelf `scene` and checks each floor pixel away from the shadow's edge; the
/// numbers of pixels checked in the shadow and beside it.
fn shelf_shadow_on_floor(scene: &str) -> (usize, usize) {
    let dir = tempfile::tempdir().expect("a folder");
    let shelf = |x: usize, z: usize| x < 16 && (20..24).contains(&z);
    let mut renderer = open_tissue(dir.path(), ("shelf.nrrd", &shelf), scene);
    let image = renderer.render_all().expect("render").remove(0).1;
    let (dims, grid_to_world) = renderer.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let camera = renderer.views()[0].camera.expect("a raycast view");
    let clip_to_world = to_world * camera.inv_view_proj(to_world, 1.0);
    let (mut dark, mut lit) = (0, 0);
    for (px, py, pixel) in image.enumerate_pixels() {
        let ndc = |z| Vec3::new((px as f32 + 0.5) / 32.0 - 1.0, 1.0 - (py as f32 + 0.5) / 32.0, z);
        let near = clip_to_world.project_point3(ndc(0.0));
        let dir = (clip_to_world.project_point3(ndc(1.0)) - near).normalize();
        if dir.z >= 0.0 {
            continue;
        }
        let floor = near + dir * ((4.0 - near.z) / dir.z);
        let on_floor = (0.5..30.5).contains(&floor.x) && (0.5..30.5).contains(&floor.y);
        // The ray must pass under the shelf, not through it.
        let through_shelf = (0..200).any(|i| {
            let p = near + (floor - near) * (i as f32 / 200.0);
            p.x < 15.5 && (19.5..23.5).contains(&p.z) && (-0.5..31.5).contains(&p.y)
        });
        if !on_floor || through_shelf || (floor.x - 15.5).abs() < 2.0 {
            continue;
        }
        let under = floor.x < 15.5;
        let want = if under { 255.0 * 0.3 } else { 255.0 };
        let got = f32::from(pixel[1]);
        assert!((got - want).abs() <= 8.0, "pixel ({px}, {py}) {pixel:?} at {floor}: under the shelf {under}");
        if under { dark += 1 } else { lit += 1 }
    }
    (dark, lit)
}

/// An image leaf: a picture of 4 x 2 cells of 8 x 8 pixels each (the sixth cell transparent)
/// upright at y = 16 behind a grey ball, seen from the front (the default camera, from +y).
const IMAGE_SCENE: &str = r#"
[[image]]
name = "plan"
path = "plan.png"
origin = [4.0, 16.0, 22.0]
right = [24.0, 0.0, 0.0]
down = [0.0, 0.0, -12.0]

[[mesh]]
name = "ball"
shape = "sphere"
centre = [10.0, 22.0, 19.0]
radius = 2.5
color = [0.5, 0.5, 0.5]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { distance = 2.0 }
"#;

/// The cells' colours, row by row; the sixth is transparent.
const CELLS: [[u8; 4]; 8] = [
    [255, 0, 0, 255],
    [0, 255, 0, 255],
    [0, 0, 255, 255],
    [255, 255, 255, 255],
    [255, 255, 0, 255],
    [0, 0, 0, 0],
    [255, 0, 255, 255],
    [0, 255, 255, 255],
];

/// Each pixel whose ray meets the image's rectangle first, at least 1.5 texels inside a cell,
/// shows the cell's colour (the background where the cell is transparent) within 2/255; where
/// it meets the ball first it shows the grey ball (depth combines the two); where it misses
/// both by a margin, the black background.
#[test]
fn an_image_leaf_shows_its_pixels_on_its_rectangle_by_depth() {
    let dir = tempfile::tempdir().expect("a folder");
    let png = image::RgbaImage::from_fn(32, 16, |x, y| image::Rgba(CELLS[(y / 8 * 4 + x / 8) as usize]));
    png.save(dir.path().join("plan.png")).expect("the picture written");
    let mut renderer = open(dir.path(), IMAGE_SCENE, r#"["plan", "ball", "volume"]"#);
    let picture = renderer.render_all().expect("render").remove(0).1;
    let (dims, grid_to_world) = renderer.primary_grid().expect("a primary volume");
    let to_world = vrs_runtime::geometry::volume_to_world(dims, grid_to_world);
    let camera = renderer.views()[0].camera.expect("a raycast view");
    let clip_to_world = to_world * camera.inv_view_proj(to_world, 1.0);
    let (origin, right, down) = (Vec3::new(4.0, 16.0, 22.0), Vec3::new(24.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -12.0));
    let (mut on_cells, mut on_ball, mut off) = (0, 0, 0);
    for (px, py, pixel) in picture.enumerate_pixels() {
        let ndc = |z| Vec3::new((px as f32 + 0.5) / 32.0 - 1.0, 1.0 - (py as f32 + 0.5) / 32.0, z);
        let near = clip_to_world.project_point3(ndc(0.0));
        let dir = (clip_to_world.project_point3(ndc(1.0)) - near).normalize();
        let (ball, _) = sphere_discriminant(near, dir, (Vec3::new(10.0, 22.0, 19.0), 2.5));
        if ball > 0.4 {
            assert!(pixel[0] > 20 && pixel[0].abs_diff(pixel[1]) <= 3 && pixel[1].abs_diff(pixel[2]) <= 3, "{pixel:?}");
            on_ball += 1;
            continue;
        }
        let hit = near + dir * ((16.0 - near.y) / dir.y);
        let (u, v) =
            ((hit - origin).dot(right) / right.length_squared(), (hit - origin).dot(down) / down.length_squared());
        let [tx, ty] = [u * 32.0, v * 16.0];
        let inside = |t: f32, cells: f32| t > 0.0 && t < cells * 8.0 && (t % 8.0 - 4.0).abs() < 2.5;
        if ball < -0.4 && inside(tx, 4.0) && inside(ty, 2.0) {
            let cell = CELLS[(ty / 8.0) as usize * 4 + (tx / 8.0) as usize];
            let want = if cell[3] == 0 { [0, 0, 0] } else { [cell[0], cell[1], cell[2]] };
            for c in 0..3 {
                assert!(pixel[c].abs_diff(want[c]) <= 2, "pixel ({px}, {py}) {pixel:?}, cell {cell:?}");
            }
            on_cells += 1;
        } else if ball < -0.4 && (!(-0.1..=1.1).contains(&u) || !(-0.1..=1.1).contains(&v)) {
            assert!(pixel[0] <= 2 && pixel[1] <= 2 && pixel[2] <= 2, "pixel ({px}, {py}) {pixel:?} off the image");
            off += 1;
        }
    }
    assert!(on_cells > 200 && on_ball > 20 && off > 200, "{on_cells} on cells, {on_ball} on the ball, {off} off");
    eprintln!("{on_cells} pixels on the image's cells, {on_ball} on the ball in front, {off} off both, as computed");
}
