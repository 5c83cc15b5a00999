//! The layers of a view around its volume layer (the composed compute pipeline): the mesh
//! layer under it, the view's meshes and slice views' pictures on their planes rasterized at
//! its camera into a depth image and a premultiplied colour image, which the volume layer reads
//! into `geometry_depth` and `geometry_color` (`BindingKind::GeometryDepth`, `GeometryColor`);
//! and the `Overlay` over the finished picture.
//!
//! Rules the mesh layer keeps (the reference's "Meshes and layers"): colour is premultiplied;
//! depth is the WebGPU window depth of the view's own projection (0 near, 1 far, cleared to 1),
//! so `std::meshes` turns it into a ray parameter with the same matrix (`geometry_inv_proj`);
//! opaque meshes write depth, translucent ones are blended over them (back faces, then front
//! faces, in scene order) without writing it, unless the volume layer blends them into its rays
//! in depth order: then they are peeled into layers (`peel`) and left out of the colour. The
//! layer draws a renderer tree (`tree`): an occlusion group's parts are drawn into images of
//! their own and combined into their parent's; a shadow group's meshes into a shadow map from
//! its light first (`shadow`), then lit by it. `ViewLayers` is a view's node of all this. A
//! slice view draws where each mesh crosses its plane, as opaque outlines on the plane
//! (`outline`), whatever the tree.

mod draws;
pub(crate) mod outline;
mod overlay;
mod peel;
pub(crate) mod pipelines;
mod shadow;
mod tree;
mod view_layers;

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh::Mesh;
use crate::textures::{Image2d, VolumeTexture};
use draws::LitBy;
pub(crate) use draws::PlanePicture;
use draws::{DrawBuffer, Pipelines, Target};
use glam::Mat4;
use outline::SliceFrame;
use overlay::Overlay;
use peel::PeeledLayers;
use pipelines::{COLOR_FORMAT, DEPTH_FORMAT, DEPTH_IMAGE_FORMAT, MeshPipelines};
use shadow::ShadowMap;
use std::sync::Arc;
use tree::{FilterStep, LayerPass, LayerPlan, PassTarget};
pub(crate) use tree::{LayerNode, ShadowLight, resolve_lights, set_hidden_opacity, visit};
pub(crate) use view_layers::{OverNode, UnderNode, ViewLayers};

/// A mesh on the GPU: interleaved positions and normals, and triangle indices.
pub(crate) struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl GpuMesh {
    pub(crate) fn upload(gpu: &Gpu, name: &str, mesh: &Mesh) -> Result<GpuMesh, RuntimeError> {
        let interleaved: Vec<f32> =
            mesh.positions.iter().zip(&mesh.normals).flat_map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]]).collect();
        let doing = format!("uploading mesh `{name}`");
        let buffer = |contents: &[u8], usage| draws::buffer(gpu, &doing, contents, usage);
        Ok(GpuMesh {
            vertices: buffer(bytemuck::cast_slice(&interleaved), wgpu::BufferUsages::VERTEX)?,
            indices: buffer(bytemuck::cast_slice(&mesh.indices), wgpu::BufferUsages::INDEX)?,
            index_count: mesh.indices.len() as u32,
        })
    }
}

/// A mesh as a scene shows it: its surface (kept on the CPU too, for slice outlines), its
/// colour, opacity and placement.
pub struct MeshInstance {
    /// The mesh's name in the scene.
    pub name: String,
    /// The surface, in the mesh's own coordinates (`model` places it).
    pub mesh: Arc<Mesh>,
    pub(crate) gpu: Arc<GpuMesh>,
    /// sRGB display colour.
    pub color: [f32; 3],
    /// 0 (invisible) to 1 (opaque).
    pub opacity: f32,
    /// The mesh's vertices to patient space (RAS mm).
    pub model: Mat4,
    /// The surface is closed and wound outward ([`Mesh::is_closed_outward`]): opaque, its back
    /// faces are culled.
    pub(crate) closed: bool,
}

/// What a mesh layer draws: a tree of meshes, slice views' pictures on their planes and
/// occlusion groups, seen by a camera.
pub(crate) struct LayerContent<'a> {
    pub camera: &'a LayerCamera,
    pub tree: &'a [LayerNode],
    /// What the tree's meshes and planes index.
    pub meshes: &'a [MeshInstance],
    /// The planes' pictures, by place (none where a plane shows nothing).
    pub planes: &'a [Option<PlanePicture>],
    /// Counts changes of the meshes' surfaces and, apart, renders of the planes' pictures.
    pub generation: u64,
    pub planes_generation: u64,
    /// The light volumes of the lights the view's volume casts shadows from, by light name.
    pub light_volumes: &'a [(String, Arc<VolumeTexture>)],
    /// Patient space to the primary volume's normalized coordinates.
    pub world_to_volume: glam::Mat4,
    /// What the tree's filters filter with (their uniforms): a change draws the layer again.
    pub filters_key: u64,
}

/// Runs filter `filter` of the tree (its index among the scene's tree filters) in place over a
/// part's colour image (`target`), with the part's images as what it reads (`picture_depth`).
pub(crate) type RunFilter<'r> =
    dyn FnMut(usize, &wgpu::TextureView, LayerViews<'_>, &mut wgpu::CommandEncoder) -> Result<(), RuntimeError> + 'r;

impl LayerContent<'_> {
    /// The light volume of light `light`, if the view's volume casts shadows from it.
    fn light_volume(&self, light: &str) -> Option<&wgpu::TextureView> {
        self.light_volumes.iter().find(|(name, _)| name == light).map(|(_, texture)| &texture.view)
    }
}

/// How a view's mesh layer looks at the meshes.
#[derive(Clone, Copy, Debug)]
pub(crate) enum LayerCamera {
    /// A raycast view: its projection of patient space (RAS mm) to clip space.
    Projection { world_to_clip: Mat4 },
    /// A slice view: its plane; meshes show as outlines where they cross it.
    Slice(SliceFrame),
}

/// The clip-space depth of the slice plane in a slice view's mesh layer.
pub(crate) const SLICE_PLANE_DEPTH: f32 = 0.5;

/// The images a layer's pass draws into: premultiplied colour, the opaque surfaces' depth as
/// colour (what the volume layer and occlusion groups read) and the depth test's buffer.
struct LayerImages {
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    depth_buffer: wgpu::TextureView,
}

impl LayerImages {
    /// The images of a pass into the layer or (`part`) into a group's part, whose colour a filter
    /// of the tree may filter in place (it copies it, then writes it).
    fn new(gpu: &Gpu, size: [u32; 2], part: bool) -> Result<LayerImages, RuntimeError> {
        let what = if part { "group part" } else { "mesh layer" };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let doing = format!("creating a {}x{} {what}", size[0], size[1]);
        let image = |label, format, usage| Image2d { label, size, format, usage }.create(gpu, &doing);
        let depth_buffer = image("mesh depth buffer", DEPTH_FORMAT, usage)?;
        let depth = image("mesh depth", DEPTH_IMAGE_FORMAT, usage)?;
        let filtered = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC;
        let color = image("mesh colour", COLOR_FORMAT, if part { usage | filtered } else { usage })?;
        Ok(LayerImages {
            depth_buffer: depth_buffer.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color_view: color.create_view(&Default::default()),
            color,
        })
    }

    /// The colour and the depth, as a combination reads them.
    fn read(&self) -> (&wgpu::TextureView, &wgpu::TextureView) {
        (&self.color_view, &self.depth_view)
    }
}

/// One view's mesh layer: its images, its occlusion groups' and what they were drawn from.
pub struct MeshLayer {
    images: LayerImages,
    /// Per occlusion group of the tree, its context's and its focus's images.
    groups: Vec<[LayerImages; 2]>,
    /// Per shadow group of the tree, its shadow map.
    shadow_maps: Vec<ShadowMap>,
    /// The shadow groups that follow a light of the view, as last drawn: the light's name, the
    /// group's shadow map (an index into `shadow_maps`) and its patient space to clip space.
    followed: Vec<FollowedShadow>,
    /// The translucent surfaces peeled into layers, for a volume layer that reads them.
    peeled: Option<PeeledLayers>,
    /// The filters of the tree as last drawn, each with the group slot it filters.
    filters: Vec<FilterStep>,
    /// What the images hold, so tiles and unchanged frames draw nothing again.
    drawn: Option<u64>,
    buffer: DrawBuffer,
}

/// The images of a mesh layer that a volume layer binds.
#[derive(Clone, Copy)]
pub(crate) struct LayerViews<'a> {
    /// The opaque surfaces' depth (`r32float`) and the colour.
    pub depth: &'a wgpu::TextureView,
    pub color: &'a wgpu::TextureView,
    /// The translucent layers' depths and colours (`texture_2d_array`), where peeled.
    pub translucent: Option<(&'a wgpu::TextureView, &'a wgpu::TextureView)>,
    shadow_maps: &'a [ShadowMap],
    followed: &'a [FollowedShadow],
}

/// A shadow group that follows a light of the view (`light = "NAME"`), as last drawn.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FollowedShadow {
    /// The light's name.
    pub light: String,
    /// Its shadow map, among the layer's.
    map: usize,
    /// Patient space to the shadow map's clip space.
    pub light_to_clip: glam::Mat4,
}

impl<'a> LayerViews<'a> {
    /// The depth image of the shadow map of the first shadow group that follows light `light`
    /// (`std::mesh_shadow`'s `mesh_shadow_map_NAME`).
    pub(crate) fn shadow_map(&self, light: &str) -> Option<&'a wgpu::TextureView> {
        let followed = self.followed.iter().find(|f| f.light == light)?;
        self.shadow_maps.get(followed.map).map(|m| &m.depth)
    }

    /// The shadow groups that follow lights of the view, first of each light first.
    pub(crate) fn followed(&self) -> &'a [FollowedShadow] {
        self.followed
    }
}

impl MeshLayer {
    /// An empty layer (depth 1, no colour) of `size` pixels; with `peeled`, its translucent
    /// meshes are peeled into layers rather than blended into its colour.
    pub(crate) fn new(gpu: &Gpu, size: [u32; 2], peeled: bool) -> Result<MeshLayer, RuntimeError> {
        Ok(MeshLayer {
            images: LayerImages::new(gpu, size, false)?,
            groups: Vec::new(),
            shadow_maps: Vec::new(),
            followed: Vec::new(),
            peeled: if peeled { Some(PeeledLayers::new(gpu, size)?) } else { None },
            filters: Vec::new(),
            drawn: None,
            buffer: DrawBuffer::default(),
        })
    }

    /// Width and height of the layer's images in pixels (the view's image size).
    pub fn size(&self) -> [u32; 2] {
        [self.images.color.width(), self.images.color.height()]
    }

    /// The images the volume layer binds.
    pub(crate) fn views(&self) -> LayerViews<'_> {
        LayerViews {
            depth: &self.images.depth_view,
            color: &self.images.color_view,
            translucent: self.peeled.as_ref().map(PeeledLayers::views),
            shadow_maps: &self.shadow_maps,
            followed: &self.followed,
        }
    }

    /// Records the drawing of `content` into the layer's images, unless they already hold
    /// exactly that picture (the tiles of one frame draw it once). `sampler` reads the pictures;
    /// `filter` runs the tree's filters.
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        (pipelines, sampler): (Option<&MeshPipelines>, &wgpu::Sampler),
        encoder: &mut wgpu::CommandEncoder,
        (content, filter): (&LayerContent, &mut RunFilter<'_>),
    ) -> Result<(), RuntimeError> {
        let key = layer_key(content, self.size());
        if self.drawn == Some(key) {
            return Ok(());
        }
        let plan = match content.camera {
            LayerCamera::Projection { .. } => LayerPlan::of(content.tree),
            // A slice view outlines every mesh on its plane, whatever its group.
            LayerCamera::Slice(_) => LayerPlan::of_meshes(tree::meshes(content.tree)),
        };
        let planned = match pipelines {
            Some(pipelines) => {
                self.make_images(gpu, &plan)?;
                self.draws(gpu, (pipelines, sampler), content, &plan)?
            }
            None => PlannedDraws::default(),
        };
        self.followed = followed_shadows(&plan, &planned.shadow_clips);
        let bind_group = self.buffer.bind(gpu, pipelines, &planned.draws)?;
        let recorded = pipelines.zip(bind_group.as_ref());
        if let Some(recorded) = recorded {
            self.encode_shadow_maps(gpu, recorded, encoder, &planned)?;
        }
        self.encode_passes(gpu, (recorded, encoder), (&plan, &planned), filter)?;
        self.filters = if recorded.is_some() { plan.filters.clone() } else { Vec::new() };
        if let (Some(peeled), Some((pipelines, bind_group))) = (&mut self.peeled, recorded) {
            let first = planned.peeled_from;
            let translucent = (bind_group, &planned.draws[first..], first);
            peeled.encode(gpu, pipelines, encoder, &self.images.depth_view, translucent)?;
        }
        self.drawn = Some(key);
        Ok(())
    }

    /// The colour image of the part that filter `filter` of the tree (its index among the
    /// scene's tree filters) filtered when the layer was last drawn, as the filter left it
    /// (nothing draws into it after the filter); none where it ran no such filter.
    pub(crate) fn filtered_part(&self, filter: usize) -> Option<&wgpu::Texture> {
        let step = self.filters.iter().find(|step| step.filter == filter)?;
        self.groups.get(step.group).map(|[context, _]| &context.color)
    }

    /// The images `plan` draws into besides the layer's own: its occlusion groups' parts and its
    /// shadow maps (kept once made).
    fn make_images(&mut self, gpu: &Gpu, plan: &LayerPlan) -> Result<(), RuntimeError> {
        while self.groups.len() < plan.groups {
            let part = || LayerImages::new(gpu, self.size(), true);
            self.groups.push([part()?, part()?]);
        }
        while self.shadow_maps.len() < plan.shadows.len() {
            self.shadow_maps.push(ShadowMap::new(gpu)?);
        }
        Ok(())
    }

    /// Records each shadow map's pass: its group's meshes seen from its light.
    fn encode_shadow_maps(
        &self,
        gpu: &Gpu,
        (pipelines, bind_group): (&MeshPipelines, &wgpu::BindGroup),
        encoder: &mut wgpu::CommandEncoder,
        planned: &PlannedDraws,
    ) -> Result<(), RuntimeError> {
        for (map, range) in self.shadow_maps.iter().zip(&planned.shadow_ranges) {
            gpu.capture("drawing a shadow map", || {
                let depth = Some(depth_attachment(&map.depth));
                let mut render = encoder.begin_render_pass(&pass_descriptor("shadow map", &[], depth));
                let casters = (&planned.draws[range.clone()], range.start);
                draws::record(&mut render, Pipelines::One(&pipelines.shadow_caster), bind_group, casters);
            })?;
        }
        Ok(())
    }

    /// Records the passes of `plan`, each into its images (cleared) with its draws, each
    /// filter right after the pass that drew what it filters.
    fn encode_passes(
        &self,
        gpu: &Gpu,
        (recorded, encoder): (Option<(&MeshPipelines, &wgpu::BindGroup)>, &mut wgpu::CommandEncoder),
        (plan, planned): (&LayerPlan, &PlannedDraws),
        filter: &mut RunFilter<'_>,
    ) -> Result<(), RuntimeError> {
        for (i, pass) in plan.passes.iter().enumerate() {
            let images = match pass.target {
                PassTarget::Layer => &self.images,
                PassTarget::Context(g) => &self.groups[g][0],
                PassTarget::Focus(g) => &self.groups[g][1],
            };
            let range = planned.ranges.get(i).cloned().unwrap_or(0..0);
            gpu.capture("drawing a mesh layer", || {
                let targets = [
                    Some(attachment(&images.color_view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT))),
                    Some(attachment(&images.depth_view, wgpu::LoadOp::Clear(wgpu::Color::WHITE))),
                ];
                let depth = Some(depth_attachment(&images.depth_buffer));
                let mut render = encoder.begin_render_pass(&pass_descriptor("mesh layer", &targets, depth));
                if let Some((pipelines, bind_group)) = recorded {
                    let by_pass = Pipelines::ByPass(&pipelines.layer, pipelines);
                    draws::record(&mut render, by_pass, bind_group, (&planned.draws[range.clone()], range.start));
                }
            })?;
            for step in plan.filters.iter().filter(|s| s.after == i) {
                self.encode_filter(step, encoder, filter)?;
            }
        }
        Ok(())
    }

    /// Runs `step`'s filter over the context of its group slot, in place.
    fn encode_filter(
        &self,
        step: &FilterStep,
        encoder: &mut wgpu::CommandEncoder,
        filter: &mut RunFilter<'_>,
    ) -> Result<(), RuntimeError> {
        let part = &self.groups[step.group][0];
        let views = LayerViews {
            depth: &part.depth_view,
            color: &part.color_view,
            translucent: None,
            shadow_maps: &[],
            followed: &[],
        };
        filter(step.filter, &part.color_view, views, encoder)
    }

    /// The draws of `plan`: its shadow maps' casters; then, per pass, its occlusion groups'
    /// combinations, its planes and its meshes; last, the translucent meshes the layer's own
    /// pass leaves to peeling.
    fn draws(
        &self,
        gpu: &Gpu,
        (pipelines, sampler): (&MeshPipelines, &wgpu::Sampler),
        content: &LayerContent,
        plan: &LayerPlan,
    ) -> Result<PlannedDraws, RuntimeError> {
        let mut planned = PlannedDraws::default();
        let mut lights = Vec::with_capacity(plan.shadows.len());
        for (cast, map) in plan.shadows.iter().zip(&self.shadow_maps) {
            let meshes: Vec<&MeshInstance> = cast.meshes.iter().filter_map(|&i| content.meshes.get(i)).collect();
            let towards =
                glam::Vec3::from(cast.light).try_normalize().unwrap_or_else(|| towards_viewer(content.camera));
            let light_to_clip = shadow::light_to_clip(towards, &meshes);
            let start = planned.draws.len();
            planned.draws.extend(draws::caster_draws(light_to_clip, &meshes));
            planned.shadow_ranges.push(start..planned.draws.len());
            planned.shadow_clips.push(light_to_clip);
            let light_volume = cast.follows.as_deref().and_then(|light| content.light_volume(light));
            let map = map.bind(gpu, pipelines, light_volume, sampler)?;
            lights.push(LitBy { light_to_clip, towards, world_to_volume: content.world_to_volume, map });
        }
        let mut peeled = Vec::new();
        for pass in &plan.passes {
            let start = planned.draws.len();
            for &(group, hidden_opacity) in &pass.combines {
                let [context, focus] = &self.groups[group];
                let parts = [context.read(), focus.read()];
                planned.draws.push(draws::combine_draw(gpu, pipelines, hidden_opacity, parts)?);
            }
            if let LayerCamera::Projection { world_to_clip } = content.camera {
                let planes: Vec<PlanePicture> =
                    pass.planes.iter().filter_map(|&i| content.planes.get(i)?.clone()).collect();
                planned.draws.extend(draws::plane_draws(gpu, pipelines, sampler, *world_to_clip, &planes)?);
            }
            for (shadow, meshes) in by_light(pass, content.meshes) {
                let Some(light) = shadow.and_then(|s| lights.get(s)) else {
                    // Peeled (a raycast view): the layer's own translucent meshes are drawn
                    // only by the peeling passes, after the others; a group's are blended into
                    // its part.
                    let peels = self.peeled.is_some()
                        && pass.target == PassTarget::Layer
                        && matches!(content.camera, LayerCamera::Projection { .. });
                    let (drawn, translucent): (Vec<&MeshInstance>, Vec<&MeshInstance>) =
                        meshes.into_iter().partition(|m| !peels || m.opacity >= 1.0);
                    planned.draws.extend(draws::frame_draws(gpu, content.camera, &drawn, self.size(), Target::Layer)?);
                    peeled.extend(translucent);
                    continue;
                };
                let lit = draws::frame_draws(gpu, content.camera, &meshes, self.size(), Target::Layer)?;
                planned.draws.extend(draws::shadowed(lit, light));
            }
            planned.ranges.push(start..planned.draws.len());
        }
        planned.peeled_from = planned.draws.len();
        if let (LayerCamera::Projection { world_to_clip }, Some(_)) = (content.camera, &self.peeled) {
            planned.draws.extend(draws::peel_draws(*world_to_clip, &peeled));
        }
        Ok(planned)
    }
}

/// The unit direction towards the viewer at the middle of the picture (a headlight's).
fn towards_viewer(camera: &LayerCamera) -> glam::Vec3 {
    let to_world = match camera {
        LayerCamera::Projection { world_to_clip } => world_to_clip.inverse(),
        LayerCamera::Slice(frame) => frame.image_to_world,
    };
    let (near, far) = (to_world.project_point3(glam::Vec3::ZERO), to_world.project_point3(glam::Vec3::Z));
    (near - far).try_normalize().unwrap_or(glam::Vec3::Z)
}

/// A pass's meshes by the light that lights them (a shadow group's, or none: the headlight), in
/// the order the lights first appear.
fn by_light<'a>(pass: &LayerPass, meshes: &'a [MeshInstance]) -> Vec<(Option<usize>, Vec<&'a MeshInstance>)> {
    let mut out: Vec<(Option<usize>, Vec<&MeshInstance>)> = Vec::new();
    for lit in &pass.meshes {
        let Some(mesh) = meshes.get(lit.mesh) else { continue };
        match out.iter_mut().find(|(shadow, _)| *shadow == lit.shadow) {
            Some((_, list)) => list.push(mesh),
            None => out.push((lit.shadow, vec![mesh])),
        }
    }
    out
}

/// A layer's draws, and which belong to which shadow map and which pass (in the plan's order);
/// those from `peeled_from` on are the peeling passes'.
#[derive(Default)]
struct PlannedDraws {
    draws: Vec<draws::Draw>,
    shadow_ranges: Vec<std::ops::Range<usize>>,
    /// Per shadow map, its patient space to clip space.
    shadow_clips: Vec<glam::Mat4>,
    ranges: Vec<std::ops::Range<usize>>,
    peeled_from: usize,
}

/// The shadow groups of `plan` that follow a light, with the clip spaces their maps were drawn in.
fn followed_shadows(plan: &LayerPlan, clips: &[glam::Mat4]) -> Vec<FollowedShadow> {
    let casts = plan.shadows.iter().zip(clips).enumerate();
    casts
        .filter_map(|(map, (cast, &light_to_clip))| {
            Some(FollowedShadow { light: cast.follows.clone()?, map, light_to_clip })
        })
        .collect()
}

/// A colour attachment loaded as `load` says and kept.
fn attachment(view: &wgpu::TextureView, load: wgpu::LoadOp<wgpu::Color>) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
    }
}

/// A render pass `label` into `color_attachments` and `depth_stencil_attachment`.
fn pass_descriptor<'a>(
    label: &'a str,
    color_attachments: &'a [Option<wgpu::RenderPassColorAttachment<'a>>],
    depth_stencil_attachment: Option<wgpu::RenderPassDepthStencilAttachment<'a>>,
) -> wgpu::RenderPassDescriptor<'a> {
    wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments,
        depth_stencil_attachment,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    }
}

/// A depth buffer cleared to 1 (the far plane).
fn depth_attachment(view: &wgpu::TextureView) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
        stencil_ops: None,
    }
}

/// What a frame is drawn from: the camera, the tree, each mesh's placement and look, the
/// image's size, and the generations (changes of the meshes' surfaces, renders of the planes'
/// pictures). Equal keys, equal pictures.
fn layer_key(content: &LayerContent, size: [u32; 2]) -> u64 {
    let mut floats: Vec<f32> = match content.camera {
        LayerCamera::Projection { world_to_clip } => world_to_clip.to_cols_array().to_vec(),
        LayerCamera::Slice(frame) => frame.image_to_world.to_cols_array().to_vec(),
    };
    let meshes: Vec<&MeshInstance> =
        tree::meshes(content.tree).into_iter().filter_map(|i| content.meshes.get(i)).collect();
    for m in &meshes {
        floats.extend(m.model.to_cols_array());
        floats.extend(m.color);
        floats.push(m.opacity);
    }
    let mut bytes: Vec<u8> = bytemuck::cast_slice(&floats).to_vec();
    bytes.extend([content.generation, content.planes_generation].iter().flat_map(|g| g.to_le_bytes()));
    bytes.extend(bytemuck::cast_slice(&size));
    bytes.push(matches!(content.camera, LayerCamera::Slice(_)) as u8);
    bytes.extend(meshes.iter().flat_map(|m| Arc::as_ptr(&m.gpu).addr().to_le_bytes()));
    bytes.extend(format!("{:?}", content.tree).bytes());
    // A light volume made again (its light, the volume or its transfer function changed) is a
    // new texture.
    bytes.extend(content.light_volumes.iter().flat_map(|(_, t)| Arc::as_ptr(t).addr().to_le_bytes()));
    bytes.extend(bytemuck::cast_slice(&content.world_to_volume.to_cols_array()));
    bytes.extend(content.filters_key.to_le_bytes());
    xxhash_rust::xxh3::xxh3_64(&bytes)
}
