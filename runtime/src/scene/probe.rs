//! Probes of a scene's views (see [`crate::probe`] and "Probes" in `docs/reference.md`): the
//! compiler composes a view's probe variant in process, the renderer keeps it (with its pipeline)
//! per view shader and field, renders its passes with the view's current uniforms, camera and
//! slice, and decodes them into an image.

use super::picture::ViewPicture;
use super::{SceneRenderer, SceneView, apply_view_uniforms};
use crate::error::RuntimeError;
use crate::filter_pass::FilterAt;
use crate::probe::{ComponentKind, ProbeFormat, ProbeValues};
use crate::shader::ViewShader;
use crate::view::ViewRenderer;
use std::collections::HashMap;
use vrsc::compose::build::ViewPass;
pub use vrsc::compose::probe::ProbeAt;
use vrsc::compose::probe::{self as cprobe, DeclaredField, ProbeLayout};
use vrsc::types::{Scalar, Type};

/// What to probe: a state field of the view, and where along the ray (`None`: a `@ray` field
/// at `ray.finish`, a sample field at accumulated opacity 0.5).
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeSpec {
    /// The state field's name.
    pub field: String,
    /// Where along the ray to read it (`None`: the field's default, above).
    pub at: Option<ProbeAt>,
}

impl ProbeSpec {
    /// A probe of `field` where its lifetime says.
    pub fn of(field: impl Into<String>) -> ProbeSpec {
        ProbeSpec { field: field.into(), at: None }
    }
}

/// A probe image and what it shows.
#[derive(Clone, Debug)]
pub struct ProbeImage {
    /// The view's name.
    pub view: String,
    /// The field's name, VRS type and lifetime (`true` for `@ray`).
    pub(crate) field: String,
    pub(crate) ty: String,
    pub(crate) ray: bool,
    pub(crate) pass: ViewPass,
    /// Where the value was read.
    pub(crate) at: ProbeAt,
    /// The coloured image (straight alpha; transparent where a pixel has no value).
    pub image: image::RgbaImage,
    /// The exact values behind it, for a value under the mouse and for tests.
    pub values: ProbeValues,
}

impl ProbeImage {
    /// Two lines for people: what the probe is, then how to read it (range and mapping).
    pub fn legend(&self) -> String {
        let (lifetime, at) = match self.pass {
            ViewPass::Filter => ("field of the filter pass", "at filter.finish".to_string()),
            ViewPass::TreeFilter(_) => ("field of a filter of the tree", "at filter.finish".to_string()),
            ViewPass::Ray if self.ray => ("@ray field", self.at.describe()),
            ViewPass::Ray => ("sample field", self.at.describe()),
        };
        format!("{}.{}: {} {lifetime} {at}\n{}", self.view, self.field, self.ty, self.values.legend())
    }
}

/// The probe variants a renderer has composed, by the structural hash of the view's shader and
/// the field: a view whose shader changes (a reload) gets new variants.
#[derive(Default)]
pub(super) struct ProbeCache {
    variants: HashMap<(String, String), Probe>,
}

/// A composed probe variant, ready to render.
struct Probe {
    layout: ProbeLayout,
    view: SceneView,
}

impl SceneRenderer {
    /// The state fields view `index` declares, each of which [`SceneRenderer::render_probe`]
    /// can show (except matrices), in pipeline order.
    pub fn probe_fields(&self, index: usize) -> Result<Vec<DeclaredField>, RuntimeError> {
        let name = &self.views.get(index).ok_or_else(|| no_view(index))?.name;
        let built = vrsc::compose::build::build_scene_keeping(&self.path, Some(name), vrsc::compose::build::Keep::Ir)
            .map_err(|error| RuntimeError::Io { path: self.path.clone(), error })?;
        let view = built.views.first().filter(|_| !built.diags.has_errors());
        let fields = view.filter(|v| v.ir.is_some()).map(cprobe::view_fields);
        fields.ok_or_else(|| compose_error(&built.diags, &built.sources))
    }

    /// Renders a probe of view `index`: the field's value per pixel, as its view shows it now
    /// (uniforms, camera, slice), coloured as [`crate::probe`] says. The first probe of a field
    /// composes the view's probe variant from the scene file (a few milliseconds, plus a
    /// pipeline); later ones only render. An unknown field is an error with the closest name.
    pub fn render_probe(&mut self, index: usize, spec: &ProbeSpec) -> Result<ProbeImage, RuntimeError> {
        let view = self.views.get(index).ok_or_else(|| no_view(index))?;
        let key = (view.renderer.shader().reflection.structural_hash.clone(), spec.field.clone());
        let size = view.renderer.size();
        if self.probes.variants.get(&key).is_none_or(|p| p.view.renderer.size() != size) {
            let probe = self.compose_probe(index, &spec.field)?;
            self.probes.variants.insert(key.clone(), probe);
        }
        // The slice views the view shows on planes, as they are now.
        self.render_planes(index)?;
        let (view, probe) = match (self.views.get(index), self.probes.variants.get_mut(&key)) {
            (Some(view), Some(probe)) => (view, probe),
            _ => return Err(no_view(index)),
        };
        let field = &probe.layout.field;
        let at = spec.at.unwrap_or(default_at(field));
        check_at(&probe.layout, at)?;
        let r = &mut probe.view.renderer;
        for u in view.renderer.reflections().flat_map(|r| r.uniforms.iter()) {
            if r.has_uniform(&u.name)
                && let Some(value) = view.renderer.uniform(&u.name)
            {
                r.set_uniform(&u.name, value)?;
            }
        }
        // A probe of the filter pass reads its field at `filter.finish`: it has no mode.
        if r.has_uniform(cprobe::MODE_UNIFORM) {
            r.set_uniform(cprobe::MODE_UNIFORM, at.mode())?;
        }
        match at {
            ProbeAt::Opacity(a) => r.set_uniform(cprobe::THRESHOLD_UNIFORM, a)?,
            ProbeAt::Sample(n) => r.set_uniform(cprobe::SAMPLE_UNIFORM, n)?,
            ProbeAt::Finish => {}
        }
        probe.view.camera = view.camera;
        probe.view.slice = view.slice;
        probe.view.convention = view.convention;
        apply_view_uniforms(&mut probe.view, &self.grids)?;
        probe.view.renderer.set_planes(view.renderer.planes().to_vec());
        let mut passes = Vec::with_capacity(probe.layout.passes as usize);
        for pass in 0..probe.layout.passes {
            let r = &mut probe.view.renderer;
            r.set_uniform(cprobe::PASS_UNIFORM, pass)?;
            // A filter of the tree writes into its group's part, which is read right after it.
            passes.push(match field.pass {
                ViewPass::TreeFilter(f) => r.render_filtered_part(&self.gpu, &self.resources, f)?,
                ViewPass::Ray | ViewPass::Filter => r.render(&self.gpu, &self.resources)?,
            });
        }
        let values = ProbeValues::decode(format(&probe.layout)?, &passes).map_err(RuntimeError::Invalid)?;
        Ok(ProbeImage {
            view: view.name.clone(),
            field: field.name.clone(),
            ty: field.ty.to_string(),
            ray: field.ray,
            pass: field.pass,
            at,
            image: values.to_image(),
            values,
        })
    }

    /// Composes the probe variant of view `index` for `field` and makes its renderer.
    fn compose_probe(&mut self, index: usize, field: &str) -> Result<Probe, RuntimeError> {
        let view = self.views.get(index).ok_or_else(|| no_view(index))?;
        let built = cprobe::build_probe(&self.path, &view.name, field)
            .map_err(|error| RuntimeError::Io { path: self.path.clone(), error })?;
        let Some(variant) = built.variant else { return Err(compose_error(&built.diags, &built.sources)) };
        let shader = ViewShader::new(variant.shader.wgsl, variant.shader.reflection, &self.path)?;
        let mut renderer = ViewRenderer::new(&self.gpu, &mut self.pipelines, shader, view.renderer.size())?;
        let filter = variant.filter.map(|f| ViewShader::new(f.wgsl, f.reflection, &self.path)).transpose()?;
        // The tree's filters as the view has them (what the probe reads of the mesh layer is
        // what the view's volume layer reads), the probed pass replaced by its variant; the
        // view's own pass only where it is probed.
        let probed = match variant.layout.field.pass {
            ViewPass::TreeFilter(f) => FilterAt::Tree(f),
            ViewPass::Ray | ViewPass::Filter => FilterAt::Picture,
        };
        let mut filters = view.renderer.filter_shaders();
        filters.retain(|(at, _)| *at != FilterAt::Picture && *at != probed);
        filters.extend(filter.map(|shader| (probed, shader)));
        renderer.set_filters(&self.gpu, &mut self.pipelines, filters)?;
        let view = SceneView {
            name: view.name.clone(),
            renderer,
            camera: view.camera,
            slice: view.slice,
            convention: view.convention,
            // The planes' pictures are the view's own, which the probe reads as they are.
            picture: ViewPicture { planes: Vec::new(), ..view.picture.clone() },
        };
        Ok(Probe { layout: variant.layout, view })
    }
}

/// Where a probe reads `field` unless told: a field of the filter pass at `filter.finish`
/// ([`ProbeAt::Finish`]), else as [`ProbeAt::default_for`] its lifetime says.
fn default_at(field: &cprobe::DeclaredField) -> ProbeAt {
    match field.pass {
        ViewPass::Filter | ViewPass::TreeFilter(_) => ProbeAt::Finish,
        ViewPass::Ray => ProbeAt::default_for(field.ray),
    }
}

/// Whether the probe can read its field `at` that place.
fn check_at(layout: &ProbeLayout, at: ProbeAt) -> Result<(), RuntimeError> {
    let field = &layout.field.name;
    if layout.field.pass != ViewPass::Ray {
        return match at {
            ProbeAt::Finish => Ok(()),
            _ => Err(RuntimeError::Invalid(format!(
                "`{field}` is a field of a filter pass of view `{}`, which runs once per pixel: \
                 it is read at filter.finish, not at a sample",
                layout.view
            ))),
        };
    }
    match at {
        ProbeAt::Finish if !layout.field.ray => Err(RuntimeError::Invalid(format!(
            "`{field}` is a sample field: it has a value at a sample, not at ray.finish \
             (probe it at an opacity threshold or a sample index)"
        ))),
        ProbeAt::Opacity(_) if !layout.opacity => Err(RuntimeError::Invalid(format!(
            "view `{}` has no `@ray accum: vec4f` to take an opacity threshold from; probe `{field}` at a sample index",
            layout.view
        ))),
        ProbeAt::Opacity(a) if !a.is_finite() => {
            Err(RuntimeError::Invalid(format!("the opacity threshold must be a number, not {a}")))
        }
        _ => Ok(()),
    }
}

/// The decoder's view of a probe layout.
fn format(layout: &ProbeLayout) -> Result<ProbeFormat, RuntimeError> {
    let kind = match layout.field.ty.scalar() {
        Some(Scalar::F32) => ComponentKind::Float,
        Some(Scalar::I32) => ComponentKind::Int,
        Some(Scalar::U32) => ComponentKind::Uint,
        Some(Scalar::Bool) => ComponentKind::Bool,
        None => return Err(RuntimeError::Invalid(format!("a probe cannot show a `{}`", layout.field.ty))),
    };
    let format = ProbeFormat { kind, components: layout.words };
    if matches!(layout.field.ty, Type::Matrix { .. }) || format.passes() != layout.passes {
        return Err(RuntimeError::Invalid(format!("a probe cannot show a `{}`", layout.field.ty)));
    }
    Ok(format)
}

fn no_view(index: usize) -> RuntimeError {
    RuntimeError::Invalid(format!("the scene has no view {index}"))
}

fn compose_error(diags: &vrsc::diag::Diagnostics, sources: &vrsc::source::SourceMap) -> RuntimeError {
    RuntimeError::Compose { rendered: vrsc::diag::render_plain(&diags.sorted(), sources) }
}
