//! The one source of a view's bindings: its reflection (`reflection.bindings`, built by the
//! compiler in the same pass that declares them in the shader) gives both the bind-group
//! layout the pipeline is made with and the bind group each dispatch uses, so the two cannot
//! drift apart. wgpu's layout derived from the shader would list only the bindings the entry
//! point reaches, which is not what the reflection promises (an additional volume that MIP
//! samples but never composites is declared, and bound, all the same).

use crate::error::RuntimeError;
use crate::mesh_layer::LayerViews;
use crate::reflection::{BindingInfo, BindingKind, Reflection};
use crate::resources::Resources;
use std::collections::HashMap;
use vrsc::compose::MESH_SHADOW_MAP_PREFIX;

/// What a binding of each kind is in the layout.
fn binding_type(kind: BindingKind) -> wgpu::BindingType {
    let texture = |view_dimension| wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: true },
        view_dimension,
        multisampled: false,
    };
    match kind {
        BindingKind::UniformBlock | BindingKind::Region => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        BindingKind::OutputImage => wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::Rgba8Unorm,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        BindingKind::LuminanceImage => wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::R32Float,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        BindingKind::GeometryDepth | BindingKind::GeometryColor | BindingKind::Picture | BindingKind::MeshShadowMap => {
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            }
        }
        BindingKind::TranslucentDepth | BindingKind::TranslucentColor => wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        BindingKind::VolumeTexture | BindingKind::BrickPool => texture(wgpu::TextureViewDimension::D3),
        BindingKind::PageTable => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        BindingKind::BrickLayout => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        BindingKind::BrickRequests | BindingKind::History => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        BindingKind::TfTexture => texture(wgpu::TextureViewDimension::D2),
        BindingKind::VolumeSampler | BindingKind::TfSampler => {
            wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)
        }
    }
}

/// The bindings of group `group`, in binding order.
fn in_group(reflection: &Reflection, group: u32) -> impl Iterator<Item = &BindingInfo> {
    reflection.bindings.iter().filter(move |b| b.group == group)
}

/// The groups the reflection uses, 0 to the highest (wgpu numbers pipeline layouts' groups by
/// position, so a gap is an empty group).
pub(crate) fn group_count(reflection: &Reflection) -> u32 {
    reflection.bindings.iter().map(|b| b.group + 1).max().unwrap_or(0)
}

/// The layout of group `group` of a view, from its reflection.
pub(crate) fn layout_entries(reflection: &Reflection, group: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    in_group(reflection, group)
        .map(|b| wgpu::BindGroupLayoutEntry {
            binding: b.binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: binding_type(b.kind),
            count: None,
        })
        .collect()
}

/// What one dispatch binds besides the shared resources.
pub(crate) struct DispatchResources<'a> {
    pub uniforms: &'a wgpu::Buffer,
    pub region: &'a wgpu::Buffer,
    pub output: &'a wgpu::TextureView,
    /// The luminance image of a view that meters (`crate::metering`).
    pub luminance: Option<&'a wgpu::TextureView>,
    /// The images of the view's mesh layer (`crate::mesh_layer`).
    pub mesh_layer: Option<LayerViews<'a>>,
    /// The view's own transfer-function tables, bound in place of the scene's of the same name.
    pub tfs: &'a std::collections::HashMap<String, crate::textures::TfTexture>,
    /// The view's `BrickLayout` buffer of each bricked volume it reads, by binding name.
    pub brick_layouts: &'a std::collections::HashMap<String, wgpu::Buffer>,
    /// The pixels' history of a progressive view (`crate::history`), for the target.
    pub history: Option<&'a wgpu::Buffer>,
    /// The picture a filter pass reads (`crate::filter_pass`).
    pub picture: Option<&'a wgpu::TextureView>,
}

/// The brick pools a dispatch binds, by binding name, as they are now (a pool grows between
/// frames).
pub(crate) type BrickPools = HashMap<String, wgpu::TextureView>;

/// The pools of the bricked volumes `reflection` binds.
pub(crate) fn brick_pools(reflection: &Reflection, shared: &Resources) -> BrickPools {
    let pools = reflection.bindings.iter().filter(|b| b.kind == BindingKind::BrickPool);
    pools.filter_map(|b| Some((b.name.clone(), shared.bricked.get(&b.name)?.pool_view()))).collect()
}

/// The entries of group `group` for one dispatch: the same bindings, in the same order, as
/// [`layout_entries`]. A volume or transfer function the view reads but the scene did not load
/// is an error naming it.
pub(crate) fn group_entries<'a>(
    reflection: &'a Reflection,
    group: u32,
    (shared, pools): (&'a Resources, &'a BrickPools),
    own: &DispatchResources<'a>,
) -> Result<Vec<wgpu::BindGroupEntry<'a>>, RuntimeError> {
    let missing = |what: &str, name: &str| {
        RuntimeError::Invalid(format!("view `{}` reads {what} `{name}`, but none is bound", reflection.view))
    };
    in_group(reflection, group)
        .map(|b| {
            let bricked = || shared.bricked.get(&b.name).ok_or_else(|| missing("bricked volume", &b.name));
            let resource = match b.kind {
                BindingKind::UniformBlock => own.uniforms.as_entire_binding(),
                BindingKind::OutputImage => wgpu::BindingResource::TextureView(own.output),
                BindingKind::Region => own.region.as_entire_binding(),
                BindingKind::LuminanceImage => wgpu::BindingResource::TextureView(
                    own.luminance.ok_or_else(|| missing("a luminance image", "luminance_image"))?,
                ),
                BindingKind::GeometryDepth => wgpu::BindingResource::TextureView(
                    own.mesh_layer.ok_or_else(|| missing("a mesh layer", "geometry_depth"))?.depth,
                ),
                BindingKind::GeometryColor => wgpu::BindingResource::TextureView(
                    own.mesh_layer.ok_or_else(|| missing("a mesh layer", "geometry_color"))?.color,
                ),
                BindingKind::TranslucentDepth => wgpu::BindingResource::TextureView(
                    own.mesh_layer.and_then(|l| l.translucent).ok_or_else(|| missing("translucent layers", &b.name))?.0,
                ),
                BindingKind::TranslucentColor => wgpu::BindingResource::TextureView(
                    own.mesh_layer.and_then(|l| l.translucent).ok_or_else(|| missing("translucent layers", &b.name))?.1,
                ),
                BindingKind::VolumeTexture => wgpu::BindingResource::TextureView(
                    &shared.volumes.get(&b.name).ok_or_else(|| missing("volume", &b.name))?.view,
                ),
                BindingKind::TfTexture => wgpu::BindingResource::TextureView(match own.tfs.get(&b.name) {
                    Some(own) => &own.view,
                    None => &shared.tfs.get(&b.name).ok_or_else(|| missing("transfer function", &b.name))?.view,
                }),
                BindingKind::VolumeSampler | BindingKind::TfSampler => wgpu::BindingResource::Sampler(&shared.sampler),
                BindingKind::BrickPool => wgpu::BindingResource::TextureView(
                    pools.get(&b.name).ok_or_else(|| missing("bricked volume", &b.name))?,
                ),
                BindingKind::PageTable => bricked()?.pages.as_entire_binding(),
                BindingKind::BrickRequests => bricked()?.requests.as_entire_binding(),
                BindingKind::MeshShadowMap => {
                    let light = b.name.strip_prefix(MESH_SHADOW_MAP_PREFIX).unwrap_or_default();
                    let map = own.mesh_layer.and_then(|l| l.shadow_map(light));
                    wgpu::BindingResource::TextureView(map.ok_or_else(|| missing("a shadow group's map", &b.name))?)
                }
                BindingKind::Picture => {
                    wgpu::BindingResource::TextureView(own.picture.ok_or_else(|| missing("a picture", &b.name))?)
                }
                BindingKind::History => own.history.ok_or_else(|| missing("a history", "history"))?.as_entire_binding(),
                BindingKind::BrickLayout => {
                    own.brick_layouts.get(&b.name).ok_or_else(|| missing("brick layout", &b.name))?.as_entire_binding()
                }
            };
            Ok(wgpu::BindGroupEntry { binding: b.binding, resource })
        })
        .collect()
}
