//! The runtime's own passes (light volumes, the luminance reduction, mesh layers) declare their
//! bindings once, as a [`PassBindings`] beside their WGSL, and this module makes everything from
//! that one declaration: the bind-group layouts, the pipeline layout, the compute pipeline and
//! each bind group (its entries numbered from the declaration, in its order). wgpu's layout
//! derived from the shader (`layout: None`) is never used, as for the views' shaders
//! (`crate::bindings`): the declaration is the one source, and a unit test checks each inline
//! shader against it with naga (the bindings it declares, and what each is).

use crate::gpu::Gpu;

/// One binding of a group: its number, the stages that see it and what it is.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slot {
    pub binding: u32,
    pub visibility: wgpu::ShaderStages,
    pub ty: wgpu::BindingType,
}

impl Slot {
    /// A binding seen by compute shaders.
    pub(crate) const fn compute(binding: u32, ty: wgpu::BindingType) -> Slot {
        Slot { binding, visibility: wgpu::ShaderStages::COMPUTE, ty }
    }
}

/// The declared bindings of a pass's shader: group `i` is `groups[i]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PassBindings {
    pub label: &'static str,
    pub groups: &'static [&'static [Slot]],
}

/// The usual binding types, for declarations.
pub(crate) mod ty {
    /// A uniform buffer (`var<uniform>`).
    pub(crate) const UNIFORM: wgpu::BindingType = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    /// A read-write storage buffer (`var<storage, read_write>`).
    pub(crate) const STORAGE_READ_WRITE: wgpu::BindingType = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only: false },
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    /// A filtering sampler.
    pub(crate) const SAMPLER: wgpu::BindingType = wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering);

    /// A sampled float texture of `view_dimension`.
    pub(crate) const fn texture(view_dimension: wgpu::TextureViewDimension, filterable: bool) -> wgpu::BindingType {
        wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension,
            multisampled: false,
        }
    }

    /// A write-only storage texture.
    pub(crate) const fn storage_texture(
        format: wgpu::TextureFormat,
        view_dimension: wgpu::TextureViewDimension,
    ) -> wgpu::BindingType {
        wgpu::BindingType::StorageTexture { access: wgpu::StorageTextureAccess::WriteOnly, format, view_dimension }
    }
}

/// The bind-group layouts of a declaration, one per group.
pub(crate) struct PassLayout {
    pub label: &'static str,
    declared: PassBindings,
    pub groups: Vec<wgpu::BindGroupLayout>,
}

impl PassLayout {
    /// The declaration's bind-group layouts (wgpu's errors go to the caller's capture).
    pub(crate) fn new(gpu: &Gpu, declared: PassBindings) -> PassLayout {
        let groups = declared
            .groups
            .iter()
            .map(|slots| {
                let entries: Vec<wgpu::BindGroupLayoutEntry> = slots
                    .iter()
                    .map(|s| wgpu::BindGroupLayoutEntry {
                        binding: s.binding,
                        visibility: s.visibility,
                        ty: s.ty,
                        count: None,
                    })
                    .collect();
                gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(declared.label),
                    entries: &entries,
                })
            })
            .collect();
        PassLayout { label: declared.label, declared, groups }
    }

    /// The pipeline layout of the first `count` groups (a pipeline that reads only those).
    pub(crate) fn pipeline_layout(&self, gpu: &Gpu, count: usize) -> wgpu::PipelineLayout {
        let groups: Vec<Option<&wgpu::BindGroupLayout>> = self.groups.iter().take(count).map(Some).collect();
        gpu.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(self.label),
            bind_group_layouts: &groups,
            immediate_size: 0,
        })
    }

    /// The pipeline layout of the groups `groups` (a pipeline that reads only those; the
    /// others are left unbound).
    pub(crate) fn pipeline_layout_of(&self, gpu: &Gpu, groups: &[usize]) -> wgpu::PipelineLayout {
        let count = groups.iter().max().map_or(0, |g| g + 1);
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> =
            (0..count).map(|g| groups.contains(&g).then(|| &self.groups[g])).collect();
        gpu.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(self.label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        })
    }

    /// A bind group of group `group`: `resources` in the declaration's order, each numbered as
    /// declared. Too few or too many resources are wgpu validation errors (the caller's capture
    /// reports them).
    pub(crate) fn bind_group(&self, gpu: &Gpu, group: usize, resources: &[wgpu::BindingResource]) -> wgpu::BindGroup {
        let slots = self.declared.groups.get(group).copied().unwrap_or(&[]);
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .iter()
            .enumerate()
            .map(|(i, resource)| wgpu::BindGroupEntry {
                binding: slots.get(i).map_or(u32::MAX, |s| s.binding),
                resource: resource.clone(),
            })
            .collect();
        let layout = &self.groups[group.min(self.groups.len().saturating_sub(1))];
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(self.label), layout, entries: &entries })
    }
}

/// A compute pass of the runtime: its pipeline, made with the declaration's layout.
pub(crate) struct ComputePass {
    pub layout: PassLayout,
    pub pipeline: wgpu::ComputePipeline,
}

impl ComputePass {
    /// Compiles `wgsl` with the declared layout (entry point `main`); wgpu's errors go to the
    /// caller's capture.
    pub(crate) fn new(gpu: &Gpu, declared: PassBindings, wgsl: &str) -> ComputePass {
        let layout = PassLayout::new(gpu, declared);
        let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(declared.label),
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        });
        let pipeline_layout = layout.pipeline_layout(gpu, declared.groups.len());
        let pipeline = gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(declared.label),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        ComputePass { layout, pipeline }
    }

    /// Records one dispatch of `workgroups` with `bind_groups` (group `i` the `i`-th).
    pub(crate) fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_groups: &[&wgpu::BindGroup],
        workgroups: [u32; 3],
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.layout.label),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        for (i, group) in bind_groups.iter().enumerate() {
            pass.set_bind_group(i as u32, *group, &[]);
        }
        let [x, y, z] = workgroups;
        pass.dispatch_workgroups(x, y, z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use naga::{AddressSpace, ImageClass, ImageDimension, ScalarKind, StorageAccess, TypeInner};

    /// Every inline shader of the runtime's own passes, with its declarations (the mesh layer's
    /// pipelines bind two sets of groups).
    fn shaders() -> [(&'static str, &'static str, &'static [PassBindings]); 3] {
        use crate::mesh_layer::pipelines as mesh;
        [
            ("light volume", crate::light_volume::SHADER, &[crate::light_volume::BINDINGS]),
            ("metering", crate::metering::SHADER, &[crate::metering::BINDINGS]),
            ("mesh layer", mesh::SHADER, &[mesh::BINDINGS, mesh::SHADOW_BINDINGS]),
        ]
    }

    /// What a binding is, as far as the layout and the shader must agree.
    fn of_layout(ty: &wgpu::BindingType) -> String {
        match ty {
            wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, .. } => "uniform".into(),
            wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, .. } => {
                format!("storage read_only={read_only}")
            }
            wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison) => "comparison sampler".into(),
            wgpu::BindingType::Sampler(_) => "sampler".into(),
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Depth,
                view_dimension,
                multisampled,
            } => {
                format!("depth texture {view_dimension:?} multisampled={multisampled}")
            }
            wgpu::BindingType::Texture { view_dimension, multisampled, .. } => {
                format!("texture {view_dimension:?} multisampled={multisampled}")
            }
            wgpu::BindingType::StorageTexture { format, view_dimension, access } => {
                format!("storage texture {format:?} {view_dimension:?} {access:?}")
            }
            other => format!("{other:?}"),
        }
    }

    fn dimension(dim: ImageDimension, arrayed: bool) -> wgpu::TextureViewDimension {
        match (dim, arrayed) {
            (ImageDimension::D1, _) => wgpu::TextureViewDimension::D1,
            (ImageDimension::D2, false) => wgpu::TextureViewDimension::D2,
            (ImageDimension::D2, true) => wgpu::TextureViewDimension::D2Array,
            (ImageDimension::D3, _) => wgpu::TextureViewDimension::D3,
            (ImageDimension::Cube, false) => wgpu::TextureViewDimension::Cube,
            (ImageDimension::Cube, true) => wgpu::TextureViewDimension::CubeArray,
        }
    }

    fn storage_format(format: naga::StorageFormat) -> wgpu::TextureFormat {
        match format {
            naga::StorageFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            naga::StorageFormat::R32Float => wgpu::TextureFormat::R32Float,
            naga::StorageFormat::Rgba8Unorm => wgpu::TextureFormat::Rgba8Unorm,
            other => panic!("a storage format the runtime's passes do not use: {other:?}"),
        }
    }

    /// What a global of the shader is, in the terms of [`of_layout`].
    fn of_shader(module: &naga::Module, var: &naga::GlobalVariable) -> String {
        match (var.space, &module.types[var.ty].inner) {
            (AddressSpace::Uniform, _) => "uniform".into(),
            (AddressSpace::Storage { access }, _) => {
                format!("storage read_only={}", !access.contains(StorageAccess::STORE))
            }
            (_, TypeInner::Sampler { comparison: true }) => "comparison sampler".into(),
            (_, TypeInner::Sampler { comparison: false }) => "sampler".into(),
            (_, TypeInner::Image { dim, arrayed, class: ImageClass::Sampled { kind, multi } }) => {
                assert_eq!(*kind, ScalarKind::Float, "the runtime's passes sample float textures");
                format!("texture {:?} multisampled={multi}", dimension(*dim, *arrayed))
            }
            (_, TypeInner::Image { dim, arrayed, class: ImageClass::Depth { multi } }) => {
                format!("depth texture {:?} multisampled={multi}", dimension(*dim, *arrayed))
            }
            (_, TypeInner::Image { dim, arrayed, class: ImageClass::Storage { format, access } }) => {
                let access = match (access.contains(StorageAccess::LOAD), access.contains(StorageAccess::STORE)) {
                    (true, true) => wgpu::StorageTextureAccess::ReadWrite,
                    (true, false) => wgpu::StorageTextureAccess::ReadOnly,
                    _ => wgpu::StorageTextureAccess::WriteOnly,
                };
                format!("storage texture {:?} {:?} {access:?}", storage_format(*format), dimension(*dim, *arrayed))
            }
            (space, inner) => format!("{space:?} {inner:?}"),
        }
    }

    /// Each inline shader parses and validates, and its bindings are the declared ones: the
    /// same (group, binding) pairs, each of the same kind (uniform or storage buffer and its
    /// access, sampler, texture and its dimension, storage texture and its format).
    #[test]
    fn inline_shaders_validate_and_bind_what_their_passes_declare() {
        for (name, wgsl, declared) in shaders() {
            let report = check(wgsl, declared);
            assert!(report.is_empty(), "{name}:\n{}", report.join("\n"));
        }
    }

    /// The check finds a binding the shader has and the declaration lacks, and one of another
    /// kind (the test above can fail).
    #[test]
    fn the_check_finds_a_shader_that_differs_from_its_declaration() {
        let wgsl = "@group(0) @binding(0) var<uniform> a: vec4<f32>;\n\
                    @group(0) @binding(1) var<storage, read_write> b: array<u32>;\n\
                    @compute @workgroup_size(1) fn main() { b[0] = u32(a.x); }\n";
        const MISSING: PassBindings = PassBindings { label: "t", groups: &[&[Slot::compute(0, ty::UNIFORM)]] };
        const OTHER_KIND: PassBindings =
            PassBindings { label: "t", groups: &[&[Slot::compute(0, ty::UNIFORM), Slot::compute(1, ty::SAMPLER)]] };
        const RIGHT: PassBindings = PassBindings {
            label: "t",
            groups: &[&[Slot::compute(0, ty::UNIFORM), Slot::compute(1, ty::STORAGE_READ_WRITE)]],
        };
        let (missing, other_kind, right) = (&[MISSING], &[OTHER_KIND], &[RIGHT]);
        assert_eq!(check(wgsl, missing).len(), 1, "{:?}", check(wgsl, missing));
        assert_eq!(check(wgsl, other_kind).len(), 1, "{:?}", check(wgsl, other_kind));
        assert!(check(wgsl, right).is_empty(), "{:?}", check(wgsl, right));
        // Two declarations of one shader: what either declares is declared.
        assert!(check(wgsl, &[MISSING, RIGHT]).is_empty(), "{:?}", check(wgsl, &[MISSING, RIGHT]));
    }

    /// What differs between `wgsl` and `declared`, a line each (empty: they agree).
    fn check(wgsl: &str, declarations: &[PassBindings]) -> Vec<String> {
        let module = naga::front::wgsl::parse_str(wgsl).unwrap_or_else(|e| panic!("{}", e.emit_to_string(wgsl)));
        let mut validator = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), Default::default());
        if let Err(e) = validator.validate(&module) {
            return vec![format!("does not validate: {}", e.emit_to_string(wgsl))];
        }
        let in_shader: std::collections::BTreeMap<(u32, u32), String> = module
            .global_variables
            .iter()
            .filter_map(|(_, var)| var.binding.as_ref().map(|b| ((b.group, b.binding), of_shader(&module, var))))
            .collect();
        let mut report = Vec::new();
        let mut declared = std::collections::BTreeSet::new();
        for (group, slots) in declarations.iter().flat_map(|d| d.groups.iter().enumerate()) {
            for slot in *slots {
                let key = (group as u32, slot.binding);
                let want = of_layout(&slot.ty);
                declared.insert(key);
                match in_shader.get(&key) {
                    None => report.push(format!("{key:?}: declared ({want}), not in the shader")),
                    Some(got) if *got != want => report.push(format!("{key:?}: declared {want}, the shader has {got}")),
                    Some(_) => {}
                }
            }
        }
        let undeclared = in_shader.into_iter().filter(|(key, _)| !declared.contains(key));
        report.extend(undeclared.map(|(key, got)| format!("{key:?}: {got} in the shader, not declared")));
        report
    }
}
