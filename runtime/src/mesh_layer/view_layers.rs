//! A view's layers around its volume layer, as one node of its renderer: the mesh layer under
//! it (its renderer tree, drawn per target size in use), the overlay over it, the camera both
//! look at the meshes with, and the slice views' pictures the tree shows on their planes.

use super::pipelines::MeshPipelines;
use super::{LayerCamera, LayerContent, LayerNode, LayerViews, MeshInstance, MeshLayer, Overlay, PlanePicture};
use crate::error::RuntimeError;
use crate::filter_pass::{FilterAt, FilterPass};
use crate::gpu::Gpu;
use crate::node::{Buffer, Frame, PictureNode, Written};
use crate::region::Region;
use crate::resources::Resources;
use crate::textures::VolumeTexture;
use std::sync::Arc;

/// Mesh layers and overlays kept per view: one for previews and one for the full image.
const SIZES_KEPT: usize = 2;

/// What the layers draw with: the scene's meshes, their pipelines (none before the scene has
/// meshes or planes), the sampler of the planes' pictures, and the count of the meshes'
/// surface changes.
#[derive(Clone, Copy)]
pub(crate) struct MeshResources<'a> {
    pub pipelines: Option<&'a MeshPipelines>,
    pub meshes: &'a [MeshInstance],
    pub sampler: &'a wgpu::Sampler,
    pub generation: u64,
    /// The light volumes of the lights the view's volume casts shadows from, by light name
    /// (shadow groups following those lights take the volume's shadow).
    pub light_volumes: &'a [(String, Arc<VolumeTexture>)],
}

/// A view's mesh layer and overlay, and what they draw.
#[derive(Default)]
pub(crate) struct ViewLayers {
    /// The mesh layer's images, one per target size in use, the last used first.
    under: Vec<MeshLayer>,
    /// The overlay's depth buffers, likewise.
    over: Vec<Overlay>,
    /// How both look at the meshes; without it the layer is empty (depth 1, no colour) and
    /// nothing is drawn over the picture.
    camera: Option<LayerCamera>,
    tree: Vec<LayerNode>,
    /// The meshes drawn over the picture (indices into the scene's meshes).
    overlay: Vec<usize>,
    /// Patient space to the primary volume's normalized coordinates (where light volumes are
    /// read).
    world_to_volume: glam::Mat4,
    /// Slice views' pictures the tree shows on their planes, and how often they were rendered
    /// anew.
    planes: Vec<Option<PlanePicture>>,
    planes_generation: u64,
}

impl ViewLayers {
    /// How the layers look at the meshes, the tree the mesh layer draws and the meshes the
    /// overlay draws.
    pub(crate) fn set(&mut self, camera: LayerCamera, tree: Vec<LayerNode>, overlay: Vec<usize>) {
        self.camera = Some(camera);
        self.tree = tree;
        self.overlay = overlay;
    }

    /// Where the primary volume lies: patient space to its normalized coordinates.
    pub(crate) fn set_world_to_volume(&mut self, world_to_volume: glam::Mat4) {
        self.world_to_volume = world_to_volume;
    }

    /// The slice pictures the tree shows on their planes, just rendered: the layer is drawn
    /// again with them.
    pub(crate) fn set_planes(&mut self, planes: Vec<Option<PlanePicture>>) {
        self.planes = planes;
        self.planes_generation += 1;
    }

    pub(crate) fn planes(&self) -> &[Option<PlanePicture>] {
        &self.planes
    }

    /// Counts renders of the planes' pictures (part of what a progressive view's history is
    /// rendered from).
    pub(crate) fn planes_generation(&self) -> u64 {
        self.planes_generation
    }

    /// The mesh layer as last drawn.
    pub(crate) fn mesh_layer(&self) -> Option<&MeshLayer> {
        self.under.first()
    }

    /// The images of the mesh layer last drawn, as the volume layer binds them.
    pub(crate) fn views(&self) -> Option<LayerViews<'_>> {
        self.under.first().map(MeshLayer::views)
    }

    /// Records the mesh layer for a target of `size` pixels (drawn again only when what it shows
    /// changed); `peeled`, its translucent meshes peeled for the volume layer; `filters`, the
    /// passes of the tree's filters.
    pub(crate) fn encode_under(
        &mut self,
        gpu: &Gpu,
        (resources, filters): (MeshResources, TreeFilters<'_>),
        encoder: &mut wgpu::CommandEncoder,
        (size, peeled): ([u32; 2], bool),
    ) -> Result<(), RuntimeError> {
        let layer = for_size(&mut self.under, size, MeshLayer::size, || MeshLayer::new(gpu, size, peeled))?;
        let tree = match (&self.camera, resources.pipelines) {
            (Some(_), Some(_)) => &self.tree[..],
            _ => &[],
        };
        let camera = self.camera.unwrap_or(LayerCamera::Projection { world_to_clip: glam::Mat4::IDENTITY });
        let content = LayerContent {
            camera: &camera,
            tree,
            meshes: resources.meshes,
            planes: &self.planes,
            generation: resources.generation,
            planes_generation: self.planes_generation,
            light_volumes: resources.light_volumes,
            world_to_volume: self.world_to_volume,
            filters_key: filters.key(),
        };
        let TreeFilters { shared, passes } = filters;
        let mut run = |filter: usize, target: &wgpu::TextureView, part: LayerViews<'_>, encoder: &mut _| {
            let Some((_, pass)) = passes.iter_mut().find(|(at, _)| *at == FilterAt::Tree(filter)) else {
                return Ok(());
            };
            let size = target.texture().size();
            let region = Region::whole([size.width, size.height]);
            let frame = &mut Frame { gpu, resources: shared, encoder, target, region };
            pass.encode(frame, Written { mesh_layer: Some(part), planes_generation: 0 })
        };
        layer.encode(gpu, (resources.pipelines, resources.sampler), encoder, (&content, &mut run))
    }

    /// Records the overlay's meshes over `target` (after the volume layer's pass).
    pub(crate) fn encode_over(
        &mut self,
        gpu: &Gpu,
        resources: MeshResources,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
    ) -> Result<(), RuntimeError> {
        let (Some(camera), Some(pipelines)) = (&self.camera, resources.pipelines) else { return Ok(()) };
        let meshes: Vec<&MeshInstance> = self.overlay.iter().filter_map(|&i| resources.meshes.get(i)).collect();
        if meshes.is_empty() {
            return Ok(());
        }
        let size = target.texture().size();
        let size = [size.width, size.height];
        let overlay = for_size(&mut self.over, size, Overlay::size, || Overlay::new(gpu, size))?;
        overlay.encode(gpu, pipelines, encoder, target, camera, &meshes)
    }
}

/// The item of `list` (the last used first) made for `size`, moved to the front; made by `make`
/// when there is none, the least recently used dropped past [`SIZES_KEPT`].
fn for_size<T>(
    list: &mut Vec<T>,
    size: [u32; 2],
    size_of: fn(&T) -> [u32; 2],
    make: impl FnOnce() -> Result<T, RuntimeError>,
) -> Result<&mut T, RuntimeError> {
    match list.iter().position(|item| size_of(item) == size) {
        Some(i) => list[..=i].rotate_right(1),
        None => {
            list.insert(0, make()?);
            list.truncate(SIZES_KEPT);
        }
    }
    Ok(&mut list[0])
}

impl<'a> MeshResources<'a> {
    /// What a view's layers draw with, of the scene's resources, with the light volumes of the
    /// lights its volume casts shadows from.
    pub(crate) fn of(resources: &'a Resources, light_volumes: &'a [(String, Arc<VolumeTexture>)]) -> Self {
        MeshResources {
            pipelines: resources.mesh_pipelines.as_ref(),
            meshes: &resources.meshes,
            sampler: &resources.sampler,
            generation: resources.mesh_generation(),
            light_volumes,
        }
    }
}

/// A view's filter passes (those of its tree run in the mesh layer), and the scene's resources
/// they bind.
pub(crate) struct TreeFilters<'a> {
    pub shared: &'a Resources,
    pub passes: &'a mut [(FilterAt, FilterPass)],
}

impl TreeFilters<'_> {
    /// What the passes filter with now (their uniform values): the layer is drawn again when
    /// it changes.
    fn key(&self) -> u64 {
        let tree = self.passes.iter().filter_map(|(at, p)| match at {
            FilterAt::Tree(f) => Some((f, p)),
            FilterAt::Picture => None,
        });
        let bytes: Vec<u8> =
            tree.flat_map(|(f, p)| f.to_le_bytes().into_iter().chain(p.uniforms().bytes().iter().copied())).collect();
        xxhash_rust::xxh3::xxh3_64(&bytes)
    }
}

/// The mesh layer under a view's volume, as a node of its picture: it writes the layer's depth
/// and colour, its shadow maps and, `peeled`, its translucent layers; its tree's filters run
/// inside it.
pub(crate) struct UnderNode<'a> {
    pub layers: &'a mut ViewLayers,
    pub peeled: bool,
    /// The light volumes of the lights the view's volume casts shadows from.
    pub light_volumes: &'a [(String, Arc<VolumeTexture>)],
    /// The view's filter passes (those of its tree run here).
    pub filters: &'a mut [(FilterAt, FilterPass)],
}

impl PictureNode for UnderNode<'_> {
    fn reads(&self) -> Vec<Buffer> {
        Vec::new()
    }

    fn writes(&self) -> Vec<Buffer> {
        let mut writes = vec![Buffer::MeshLayer, Buffer::ShadowMaps];
        if self.peeled {
            writes.push(Buffer::TranslucentLayers);
        }
        writes
    }

    fn encode(&mut self, frame: &mut Frame<'_, '_>, _: Written<'_>) -> Result<(), RuntimeError> {
        let size = frame.target.texture().size();
        let resources = MeshResources::of(frame.resources, self.light_volumes);
        let filters = TreeFilters { shared: frame.resources, passes: self.filters };
        let size = [size.width, size.height];
        self.layers.encode_under(frame.gpu, (resources, filters), frame.encoder, (size, self.peeled))
    }
}

/// The overlay of a view, as a node of its picture: meshes drawn over the picture.
pub(crate) struct OverNode<'a>(pub &'a mut ViewLayers);

impl PictureNode for OverNode<'_> {
    fn reads(&self) -> Vec<Buffer> {
        vec![Buffer::Picture]
    }

    fn writes(&self) -> Vec<Buffer> {
        vec![Buffer::Picture]
    }

    fn encode(&mut self, frame: &mut Frame<'_, '_>, _: Written<'_>) -> Result<(), RuntimeError> {
        let resources = MeshResources::of(frame.resources, &[]);
        self.0.encode_over(frame.gpu, resources, frame.encoder, frame.target)
    }
}
