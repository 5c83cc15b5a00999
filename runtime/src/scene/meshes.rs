//! The scene's meshes (`[[mesh]]`): files loaded and shapes made when the scene's mesh tables
//! change, shapes made again when a uniform they follow changes (the ablation needle follows
//! its zone's centre), and each view's mesh-layer camera with the matching
//! `geometry_inv_proj`.

use super::{SceneRenderer, SceneView, VolumeGrid};
use crate::error::RuntimeError;
use crate::geometry::{self, ShaderPlane};
use crate::mesh::{self, Mesh, isosurface, shapes};
use crate::mesh_layer::outline::SliceFrame;
use crate::mesh_layer::{
    GpuMesh, LayerCamera, MeshInstance, PlanePicture, SLICE_PLANE_DEPTH, pipelines::MeshPipelines,
};
use crate::uniforms::Value;
use crate::volume::Volume;
use glam::{Mat4, Vec3, Vec4};
use std::sync::Arc;
use vrsc::scene::{self as vscene, MeshSource, Node, Point, Scene, VolumeSource};

/// How far from a slice plane (mm) its mesh layer's depth range reaches on either side.
const SLICE_DEPTH_REACH: f32 = 1000.0;

/// The scene's mesh tables as they were last made, and the uniform values their shapes were
/// made with.
#[derive(Default)]
pub(super) struct SceneMeshes {
    tables: Vec<vscene::Mesh>,
    /// Per mesh, the values of the points it follows.
    followed: Vec<Vec<[f32; 3]>>,
    /// The scene's directory, which file paths were resolved against (part of the key).
    key: String,
}

impl SceneRenderer {
    /// Loads every mesh of `scene` when its mesh tables changed (a file's errors are errors
    /// here; `build` reports them first, at the table).
    pub(super) fn load_meshes(&mut self, scene: &Scene) -> Result<(), RuntimeError> {
        let key = format!("{:?}", scene.meshes);
        let planes = scene.views.iter().any(|v| !scene.leaves_under(v).1.is_empty());
        if key == self.tree.meshes.key
            && self.resources.meshes.len() == scene.meshes.len()
            && (!planes || self.resources.mesh_pipelines.is_some())
        {
            return Ok(());
        }
        let mut instances = Vec::with_capacity(scene.meshes.len());
        let mut followed = Vec::with_capacity(scene.meshes.len());
        for table in &scene.meshes {
            let points = self.followed_values(table);
            let surface = mesh_surface(table, &points, &|name| self.volume_on_cpu(scene, name))?;
            instances.push(self.instance(table, surface)?);
            followed.push(points);
        }
        let planes = scene.views.iter().any(|v| !scene.leaves_under(v).1.is_empty());
        if (!instances.is_empty() || planes) && self.resources.mesh_pipelines.is_none() {
            self.resources.mesh_pipelines = Some(MeshPipelines::new(&self.gpu)?);
        }
        self.resources.meshes = instances;
        self.resources.meshes_changed();
        self.tree.meshes = SceneMeshes { tables: scene.meshes.clone(), followed, key };
        Ok(())
    }

    /// Makes again each shape whose followed uniforms changed since it was made, keeping its
    /// colour, opacity and placement as they are now.
    pub(super) fn update_followed_meshes(&mut self) -> Result<(), RuntimeError> {
        for i in 0..self.tree.meshes.tables.len() {
            let table = &self.tree.meshes.tables[i];
            if table.followed_uniforms().is_empty() {
                continue;
            }
            let points = self.followed_values(table);
            if points == self.tree.meshes.followed[i] {
                continue;
            }
            let surface = mesh_surface(table, &points, &|_| Err(no_surface_volume()))?;
            // A new surface in the style it is drawn with now (the user may have changed it).
            let mut instance = self.instance(table, surface)?;
            let now = &self.resources.meshes[i];
            (instance.color, instance.opacity, instance.model) = (now.color, now.opacity, now.model);
            self.resources.meshes[i] = instance;
            self.tree.meshes.followed[i] = points;
            self.resources.meshes_changed();
        }
        Ok(())
    }

    /// The current values of the uniforms `table` follows (from the first view that reads
    /// each), in the order of [`vscene::Mesh::followed_uniforms`].
    fn followed_values(&self, table: &vscene::Mesh) -> Vec<[f32; 3]> {
        table.followed_uniforms().iter().map(|u| self.uniform_vec3(&u.value).unwrap_or([0.0; 3])).collect()
    }

    /// The samples of scene volume `name`, read again on the CPU (the textures hold no copy), for
    /// a surface extracted from it.
    fn volume_on_cpu(&self, scene: &Scene, name: &str) -> Result<Volume, RuntimeError> {
        let v = scene.volumes.iter().find(|v| v.name.name == name).ok_or_else(no_surface_volume)?;
        let invalid = |e: String| RuntimeError::Invalid(format!("volume `{name}`: {e}"));
        let phantom =
            |p: &str| crate::volume::phantom(p, self.options.phantom_size).map_err(|e| invalid(e.to_string()));
        // A bricked volume: the finest level that fits in memory as one piece.
        if let Some(bricked) = self.resources.bricked.get(&v.binding()) {
            return super::bricked::standin(bricked.source().as_ref());
        }
        match (&v.source, &v.fallback) {
            (VolumeSource::File(file), Some(fallback)) if !file.resolved.exists() => phantom(&fallback.value),
            (VolumeSource::File(file), _) => {
                crate::volume::load(&file.resolved, &mut |_, _| {}).map_err(|e| invalid(e.to_string()))
            }
            (VolumeSource::Phantom(p), _) => phantom(&p.value),
            (VolumeSource::Url(u), _) => Err(invalid(format!("the remote store `{}` is read in bricks", u.value))),
        }
    }

    fn uniform_vec3(&self, name: &str) -> Option<[f32; 3]> {
        let view = self.views.iter().find(|v| v.renderer.has_uniform(name))?;
        match view.renderer.uniforms().get(name)? {
            Value::Float(v) if v.len() == 3 => Some([v[0], v[1], v[2]]),
            _ => None,
        }
    }

    fn instance(&self, table: &vscene::Mesh, surface: Mesh) -> Result<MeshInstance, RuntimeError> {
        let name = &table.name.name;
        let gpu = GpuMesh::upload(&self.gpu, name, &surface)?;
        let model = table.transform.as_ref().map_or(Mat4::IDENTITY, |t| Mat4::from_cols_array_2d(&t.value));
        let closed = surface.is_closed_outward();
        Ok(MeshInstance {
            closed,
            name: name.clone(),
            mesh: Arc::new(surface),
            gpu: Arc::new(gpu),
            color: table.color,
            opacity: table.opacity,
            model,
        })
    }

    /// Sets a mesh's colour, opacity or placement (the panel's controls); its surface stays.
    pub fn set_mesh_style(
        &mut self,
        name: &str,
        color: [f32; 3],
        opacity: f32,
        model: Mat4,
    ) -> Result<(), RuntimeError> {
        let mesh = self
            .resources
            .meshes
            .iter_mut()
            .find(|m| m.name == name)
            .ok_or_else(|| RuntimeError::Invalid(format!("the scene has no mesh `{name}`")))?;
        mesh.color = color;
        mesh.opacity = opacity.clamp(0.0, 1.0);
        mesh.model = model;
        self.resources.content_changed();
        Ok(())
    }

    /// The scene's meshes as they are drawn now.
    pub fn meshes(&self) -> &[MeshInstance] {
        &self.resources.meshes
    }
}

fn no_surface_volume() -> RuntimeError {
    RuntimeError::Invalid("a surface's volume is not in the scene".into())
}

/// The surface of a mesh table: its file loaded (within `mesh::Limits::default`), its shape
/// made with `points` the values of the uniforms it follows (in the order of
/// [`vscene::Mesh::followed_uniforms`]; zero where missing), or the surface of the volume
/// `volume(NAME)` gives at its level.
pub fn mesh_surface(
    table: &vscene::Mesh,
    points: &[[f32; 3]],
    volume: &dyn Fn(&str) -> Result<Volume, RuntimeError>,
) -> Result<Mesh, RuntimeError> {
    let mut followed = points.iter();
    let mut point = |p: &Point| -> Vec3 {
        match p {
            Point::Value(v) => Vec3::from(*v),
            Point::Uniform(_) => Vec3::from(followed.next().copied().unwrap_or([0.0; 3])),
        }
    };
    let name = &table.name.name;
    let made = match &table.source {
        MeshSource::File { file, coordinates } => {
            let coordinates = match coordinates {
                vscene::Coordinates::Ras => mesh::Coordinates::Ras,
                vscene::Coordinates::Lps => mesh::Coordinates::Lps,
            };
            mesh::load_with(&file.resolved, coordinates, &mesh::Limits::default())
        }
        MeshSource::Needle { tip, direction, length, radius } => {
            let (tip, direction) = (point(tip), point(direction));
            shapes::needle(tip, direction, *length, *radius, NEEDLE_SEGMENTS)
        }
        MeshSource::Cylinder { base, tip, radius } => {
            let (base, tip) = (point(base), point(tip));
            shapes::cylinder(base, tip, *radius, NEEDLE_SEGMENTS)
        }
        MeshSource::Sphere { centre, radius } => shapes::sphere(point(centre), *radius, 32, 64),
        MeshSource::Surface { volume: name, level } => {
            isosurface::extract(&volume(&name.value)?, *level, &mesh::Limits::default())
        }
        MeshSource::Box { min, max } => {
            let (min, max) = (point(min), point(max));
            shapes::cuboid(min, max)
        }
    };
    made.map_err(|e| RuntimeError::Invalid(format!("mesh `{name}`: {e}")))
}

/// Sides of a needle's or cylinder's shaft.
const NEEDLE_SEGMENTS: u32 = 48;

/// The mesh layer's camera of a view and the `geometry_inv_proj` that turns its depth back into
/// normalized volume coordinates.
pub(super) fn layer_camera(view: &SceneView, primary: &VolumeGrid) -> Option<(LayerCamera, Mat4)> {
    let to_world = geometry::volume_to_world(primary.dims, primary.grid_to_world);
    let [w, h] = view.renderer.size();
    let aspect = w as f32 / h.max(1) as f32;
    if let Some(camera) = view.camera {
        let inv_view_proj = camera.mesh_inv_view_proj(to_world, aspect);
        let world_to_clip = (to_world * inv_view_proj).inverse();
        return Some((LayerCamera::Projection { world_to_clip }, inv_view_proj));
    }
    let (plane, _) = view.slice?;
    let plane = ShaderPlane::new(plane.oriented(view.convention), to_world, aspect);
    // (x, y, s mm along the normal) to normalized volume coordinates, then to patient space.
    let image_to_volume =
        Mat4::from_cols(plane.u.extend(0.0), plane.v.extend(0.0), plane.normal.extend(0.0), plane.origin.extend(1.0));
    let image_to_world = to_world * image_to_volume;
    let frame = SliceFrame { image_to_world, world_to_image: image_to_world.inverse() };
    // Clip (ndc x, ndc y, depth) to image (x, y, s): depth SLICE_PLANE_DEPTH is the plane.
    let clip_to_image = Mat4::from_cols(
        Vec4::new(0.5, 0.0, 0.0, 0.0),
        Vec4::new(0.0, -0.5, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 2.0 * SLICE_DEPTH_REACH, 0.0),
        Vec4::new(0.5, 0.5, -2.0 * SLICE_DEPTH_REACH * SLICE_PLANE_DEPTH, 1.0),
    );
    Some((LayerCamera::Slice(frame), image_to_volume * clip_to_image))
}

/// A slice view's image frame (image `x, y` in [0, 1]^2, y down, and mm along the normal, to
/// patient space) and its matrix to normalized volume coordinates.
fn slice_frame(view: &SceneView, primary: &VolumeGrid) -> Option<(SliceFrame, Mat4)> {
    let (plane, _) = view.slice?;
    let to_world = geometry::volume_to_world(primary.dims, primary.grid_to_world);
    let [w, h] = view.renderer.size();
    let plane = ShaderPlane::new(plane.oriented(view.convention), to_world, w as f32 / h.max(1) as f32);
    let image_to_volume =
        Mat4::from_cols(plane.u.extend(0.0), plane.v.extend(0.0), plane.normal.extend(0.0), plane.origin.extend(1.0));
    let image_to_world = to_world * image_to_volume;
    Some((SliceFrame { image_to_world, world_to_image: image_to_world.inverse() }, image_to_volume))
}

/// A point of a mesh that follows a uniform: what a viewer lets the user drag.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshHandle {
    /// The name of the mesh in the scene.
    pub mesh: String,
    /// The `vec3f` uniform the point follows (patient space, mm).
    pub uniform: String,
    /// Its value now.
    pub point: Vec3,
}

impl SceneRenderer {
    /// Every point of a mesh that follows a uniform (a needle's tip and direction, a sphere's
    /// centre), with the uniform's value now: the first of a mesh is its tip or centre.
    pub fn mesh_handles(&self) -> Vec<MeshHandle> {
        let mut out = Vec::new();
        for table in &self.tree.meshes.tables {
            for u in table.followed_uniforms() {
                if let Some(p) = self.uniform_vec3(&u.value) {
                    out.push(MeshHandle { mesh: table.name.name.clone(), uniform: u.value.clone(), point: p.into() });
                }
            }
        }
        out
    }

    /// Where slice view `index`'s image lies in patient space as the view shows it now (its
    /// plane, position, convention and size); `None` for a raycast view or a scene without a
    /// primary volume.
    pub fn slice_geometry(&self, index: usize) -> Option<SliceGeometry> {
        let view = self.views.get(index)?;
        let (frame, _) = slice_frame(view, self.grids.first()?)?;
        let (plane, _) = view.slice?;
        Some(SliceGeometry { frame, edge_labels: plane.oriented(view.convention).edge_labels() })
    }
}

/// Where a slice view's image lies in patient space ([`SceneRenderer::slice_geometry`]): what
/// a viewer maps the mouse through and labels the image's edges with. Image coordinates are
/// in [0, 1]^2, y down; patient space is RAS, mm.
#[derive(Clone, Copy, Debug)]
pub struct SliceGeometry {
    frame: SliceFrame,
    edge_labels: [&'static str; 4],
}

impl SliceGeometry {
    /// The patient-space point under `pixel`.
    pub fn pixel_to_world(&self, pixel: [f32; 2]) -> Vec3 {
        self.frame.image_to_world.transform_point3(Vec3::new(pixel[0], pixel[1], 0.0))
    }

    /// Where `point` shows in the image, and its distance from the plane (mm).
    pub fn world_to_pixel(&self, point: Vec3) -> ([f32; 2], f32) {
        let p = self.frame.world_to_image.transform_point3(point);
        ([p.x, p.y], p.z)
    }

    /// The patient directions at the image's edges, `[left, right, top, bottom]` (see
    /// `SlicePlane::edge_labels`).
    pub fn edge_labels(&self) -> [&'static str; 4] {
        self.edge_labels
    }
}

impl SceneRenderer {
    /// [`SceneRenderer::encode_planes`] in a submission of its own (before a view that renders
    /// with its own encoder); nothing for a view without planes.
    pub(super) fn render_planes(&mut self, index: usize) -> Result<(), RuntimeError> {
        if self.views.get(index).is_none_or(|v| v.picture.planes.is_empty()) {
            return Ok(());
        }
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.encode_planes(index, &mut encoder)?;
        self.gpu.capture("rendering the slice views shown on planes", || self.gpu.queue.submit([encoder.finish()]))?;
        Ok(())
    }

    /// Renders the slice views that view `index` shows on their planes (each into its own
    /// output, recorded into `encoder` before the view) and hands their pictures, and the
    /// images it shows, to its mesh layer. A view that shows images only takes them once.
    pub(super) fn encode_planes(
        &mut self,
        index: usize,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(), RuntimeError> {
        let Some(view) = self.views.get(index).filter(|v| !v.picture.planes.is_empty()) else {
            return Ok(());
        };
        let planes = view.picture.planes.clone();
        let images_only = planes.iter().all(|p| matches!(p, Node::Image(_)));
        if images_only && view.picture.images_shown == self.tree.images.generation {
            return Ok(());
        }
        let mut pictures = Vec::with_capacity(planes.len());
        // One entry per plane, in order: the mesh layer's tree finds them by place.
        for p in planes {
            let picture = match p {
                Node::Image(i) => self.tree.images.pictures.get(i).cloned(),
                Node::Plane(v) => self.encode_slice_picture(v, encoder)?,
                Node::Mesh(_) | Node::Group(_) | Node::Filter(_) => None,
            };
            pictures.push(picture);
        }
        let view = &mut self.views[index];
        view.renderer.set_planes(pictures);
        view.picture.images_shown = if images_only { self.tree.images.generation } else { 0 };
        Ok(())
    }

    /// Renders slice view `index` (into its own output, recorded into `encoder`) and gives its
    /// picture on its plane; none where there is no such view or no primary volume.
    fn encode_slice_picture(
        &mut self,
        index: usize,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<Option<PlanePicture>, RuntimeError> {
        let (Some(view), Some(primary)) = (self.views.get_mut(index), self.grids.first()) else {
            return Ok(None);
        };
        super::apply_view_uniforms(view, &self.grids)?;
        view.renderer.encode(&self.gpu, &self.resources, encoder)?;
        Ok(plane_picture(view, primary))
    }
}

/// A slice view's picture and the part of its plane inside the primary volume's box, in patient
/// space, with each corner's place in the picture.
fn plane_picture(view: &SceneView, primary: &VolumeGrid) -> Option<PlanePicture> {
    let (plane, _) = view.slice?;
    let (frame, _) = slice_frame(view, primary)?;
    let to_world = geometry::volume_to_world(primary.dims, primary.grid_to_world);
    let box_to_world = geometry::PatientBox::of(to_world).to_world();
    let plane = plane.oriented(view.convention);
    let corners = [plane.origin, plane.origin + plane.u, plane.origin + plane.u + plane.v, plane.origin + plane.v]
        .map(|c| box_to_world.transform_point3(c));
    let uv = corners.map(|c| frame.world_to_image.transform_point3(c).truncate());
    Some(PlanePicture { picture: view.renderer.output().create_view(&Default::default()), corners, uv })
}
