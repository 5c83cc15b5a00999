//! The reflection of a composed view: what a runtime needs to drive the shader without the
//! compiler — the uniform block layout with defaults, ranges and docs, every binding, the state
//! layout, the pipeline map, and hashes that tie it to its WGSL.
//!
//! This crate is the contract between `vrsc` and `vrs-runtime`: the compiler builds these values,
//! the runtime reads them, in process as typed values or from the `VIEW.json` that `vrsc build`
//! writes (serde, the same types both ways).
//!
//! Public API:
//! - [`Reflection`]: one view's reflection; [`Reflection::from_json`] reads `VIEW.json` (checking
//!   [`FORMAT_VERSION`]), [`Reflection::uniform`] and [`Reflection::declared_by`] look uniforms up.
//! - The uniforms: [`UniformBlock`] (the buffer's binding and size) and [`UniformInfo`] (each
//!   uniform's type, offset, default, range and doc).
//! - The bindings: [`BindingInfo`] with its [`BindingKind`]; [`BRICK_LAYOUT_BYTES`], the size of a
//!   bricked volume's layout uniform.
//! - For tools: the state layout ([`StateInfo`], [`FieldInfo`], [`Lifetime`]) and the pipeline
//!   map ([`StepInfo`], [`FunctionInfo`], [`FunctionStatus`]).
//! - [`content_hash`]: the hash written as `wgsl_hash`.

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Bumped whenever the JSON's shape changes incompatibly.
pub const FORMAT_VERSION: u32 = 1;

/// A view's reflection.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reflection {
    /// The JSON format this was written in ([`FORMAT_VERSION`]; checked by [`Reflection::from_json`]).
    pub format_version: u32,
    /// The scene's `[[view]]` name this shader renders.
    pub view: String,
    /// `raycast` or `slice`.
    pub kind: String,
    /// The compute entry point's WGSL function name (`main`).
    pub entry_point: String,
    /// The entry point's `@workgroup_size` (x, y, z): pixels one workgroup renders.
    pub workgroup_size: [u32; 3],
    /// xxh3-64 (hex) of the WGSL text: a runtime loading `.wgsl` + `.json` checks they belong
    /// together.
    pub wgsl_hash: String,
    /// xxh3-64 (hex) of everything that shapes the shader (the WGSL and its bindings). Uniform
    /// values do not enter it, so equal hashes mean a configuration change only needs new
    /// uniform values, not a new pipeline.
    pub structural_hash: String,
    /// Where the uniform buffer is bound and its size in bytes.
    pub uniform_block: UniformBlock,
    /// Every uniform the shader reads: block members first, then `volume` and `tf` resources.
    pub uniforms: Vec<UniformInfo>,
    /// Every resource binding of the shader, in binding order.
    pub bindings: Vec<BindingInfo>,
    /// The state layout and the pipeline map are for tools (inspectors, probes); a runtime
    /// needs neither, so JSON without them still loads.
    #[serde(default)]
    pub state: StateInfo,
    /// The pipeline map: each step with the functions placed in it, in execution order.
    #[serde(default)]
    pub pipeline: Vec<StepInfo>,
}

/// Where the uniform block is bound and how large it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct UniformBlock {
    /// Its `@group`.
    pub group: u32,
    /// Its `@binding` within the group.
    pub binding: u32,
    /// Bytes of the block, padded to WGSL's uniform layout rules (what the buffer must hold).
    pub size: u32,
}

/// One uniform: a member of the uniform block, or a `volume` / `tf` resource (no offset).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UniformInfo {
    /// The uniform's name as scenes and `[uniforms]` spell it (instantiated for templates).
    pub name: String,
    /// The VRS type: `f32`, `vec3f`, `mat4x4f`, `volume`, `tf`, ...
    #[serde(rename = "type")]
    pub ty: String,
    /// Byte offset in the uniform block; `None` for `volume` and `tf` (they are bindings).
    pub offset: Option<u32>,
    /// Bytes it takes in the uniform block; `None` for `volume` and `tf`.
    pub size: Option<u32>,
    /// A scalar as a JSON scalar, a vector as an array, a matrix as an array of columns.
    pub default: Option<Value>,
    /// The scene's initial value, when `[uniforms]` sets one.
    pub value: Option<Value>,
    /// `in LO .. HI` of the declaration.
    pub range: Option<[Value; 2]>,
    /// The declaration's doc comment.
    pub doc: Option<String>,
}

/// What a binding holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BindingKind {
    /// The uniform buffer ([`UniformBlock`]) holding every non-resource uniform.
    UniformBlock,
    /// `texture_storage_2d<rgba8unorm, write>`: the picture the view renders.
    OutputImage,
    /// `vec4<u32>` uniform: the pixels `x0, y0, x1, y1` (end exclusive) that a dispatch renders.
    Region,
    /// `texture_3d<f32>`: a `volume` uniform's samples, normalized by its window.
    VolumeTexture,
    /// The (filtering) `sampler` a `volume` or brick pool is read through.
    VolumeSampler,
    /// `texture_2d<f32>` of height 1: a `tf` uniform's RGBA table.
    TfTexture,
    /// The (filtering) `sampler` a `tf` table is read through.
    TfSampler,
    /// `texture_storage_2d<r32float, write>`, as large as the output image: each pixel's
    /// `metered_luminance`, which the runtime reduces on the GPU for automatic exposure.
    LuminanceImage,
    /// `texture_2d<f32>` (`r32float`, not filterable): the depth of the view's mesh layer (0 near
    /// .. 1 far, 1 where no opaque mesh is), which the entry point loads into `geometry_depth`.
    GeometryDepth,
    /// `texture_2d<f32>` (`rgba8unorm`): the colour of the view's mesh layer, premultiplied,
    /// which the entry point loads into `geometry_color`.
    GeometryColor,
    /// `texture_2d_array<f32>` (`r32float`, not filterable), one layer per translucent layer of
    /// the view's mesh layer (nearest first): its depth (1 where the layer holds nothing), which
    /// the entry point loads into `translucent_depth_N`.
    TranslucentDepth,
    /// `texture_2d_array<f32>` (`rgba8unorm`), one layer per translucent layer: its colour,
    /// premultiplied, which the entry point loads into `translucent_color_N`.
    TranslucentColor,
    /// `texture_3d<f32>` (`r16float`): the brick pool of a bricked volume (named like the
    /// volume's uniform), sampled through its page table; its sampler is a `VolumeSampler`.
    BrickPool,
    /// `array<u32>` storage buffer (read-only): a bricked volume's page table, one word per
    /// brick of every level (level after level): missing, resident (the pool slot) or constant
    /// (the value).
    PageTable,
    /// Uniform buffer `BrickLayout` ([`BRICK_LAYOUT_BYTES`]): a bricked volume's grid, levels,
    /// pool and the view's eye (what the lookup needs to pick a level and find a brick).
    BrickLayout,
    /// `array<u32>` storage buffer (read-write), one word per page-table word: the bricks rays
    /// used, and those they needed and did not find resident (the feedback the runtime loads bricks from).
    BrickRequests,
    /// `array<vec4f>` storage buffer (read-write), two elements per pixel of the target, row
    /// after row: the pixel's mean `accum` over the frames since the view last changed, and
    /// their number in the next element's first component. The entry point loads them into
    /// `history` and `history_samples` before ray setup and stores them after ray finish; the
    /// runtime clears the buffer whenever the picture changes (a progressive view: the path
    /// tracer).
    History,
    /// `texture_2d<f32>` (`rgba8unorm`), as large as the output image: a filter pass's input,
    /// the view's picture before its filters (premultiplied), read by the `image` uniform
    /// `picture`. (A filter's `picture_depth` is a [`BindingKind::GeometryDepth`].)
    Picture,
    /// `texture_2d<f32>` (unfilterable: a depth image): the shadow map of the shadow group
    /// following light NAME, read by the image uniform `mesh_shadow_map_NAME`
    /// (`std::mesh_shadow`): depth from the light, 0 nearest.
    MeshShadowMap,
}

/// Bytes of the `BrickLayout` uniform the runtime writes for a bricked volume (five `vec4f`,
/// `stdlib/bricks.wgsl`): a lookup's layout struct may be no larger.
pub const BRICK_LAYOUT_BYTES: u64 = 80;

/// One `@group(g) @binding(n)` of the view's shader.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BindingInfo {
    /// The uniform's name for resources (`volume`, `tf_gm`); `uniforms`, `output` or `region`
    /// otherwise.
    pub name: String,
    /// Its `@group`.
    pub group: u32,
    /// Its `@binding` within the group.
    pub binding: u32,
    /// What the runtime must bind there.
    pub kind: BindingKind,
}

/// The layout of the view's `State` struct.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateInfo {
    /// Bytes of one `State` value (WGSL layout).
    pub size: u32,
    /// Its fields, in member order.
    pub fields: Vec<FieldInfo>,
}

/// Whether a state field lives for the whole ray or is reset at every sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Lifetime {
    /// `@ray state`: keeps its value from sample to sample along a ray.
    Ray,
    /// Plain `state`: back to its default at the start of every sample.
    Sample,
}

/// One state field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldInfo {
    /// The field's name (instantiated for templates).
    pub name: String,
    /// Its VRS type (`f32`, `vec4f`, ...).
    #[serde(rename = "type")]
    pub ty: String,
    /// Whether it lasts the whole ray or one sample.
    pub lifetime: Lifetime,
    /// Byte offset in the `State` struct.
    pub offset: u32,
    /// Bytes it takes in the `State` struct.
    pub size: u32,
    /// Its initial value, as JSON like a uniform's default.
    pub default: Value,
}

/// One step of the pipeline and the functions placed in it, in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepInfo {
    /// The step's name (`sampling`, `compositing.alpha`, ...).
    pub step: String,
    /// The functions that run, in execution order (all [`FunctionStatus::Active`]).
    pub functions: Vec<FunctionInfo>,
    /// Functions placed into this step that do not run: removed or replaced by a later
    /// module, or left out because their `when active` target was not there.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_placed: Vec<FunctionInfo>,
}

/// Whether a pipeline function of the view's modules runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FunctionStatus {
    /// Placed and run.
    #[default]
    Active,
    /// Placed, then taken out by a later `remove` or `replace`.
    Removed,
    /// Never placed: its placement says `when active` and its target was not in the pipeline.
    LeftOut,
}

/// A placed pipeline function and where its source is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FunctionInfo {
    /// The pipeline function's name as declared.
    pub name: String,
    /// The template instance it belongs to (`$` substituted by this), if any.
    pub instance: Option<String>,
    /// The source file it is declared in, as the compiler named it (`?` when unknown).
    pub file: String,
    /// 1-based line of its declaration (0 when unknown).
    pub line: usize,
    /// 1-based column, in characters, of its declaration (0 when unknown).
    pub column: usize,
    /// Byte range in the file.
    pub span: [u32; 2],
    /// Whether it runs, and if not why.
    #[serde(default)]
    pub status: FunctionStatus,
    /// The uniforms it declares (instantiated names), in declaration order.
    #[serde(default)]
    pub uniforms: Vec<String>,
    /// The state fields it declares (instantiated names), in declaration order.
    #[serde(default)]
    pub fields: Vec<String>,
}

impl Reflection {
    /// Parses reflection JSON and checks its format version.
    pub fn from_json(text: &str) -> Result<Reflection, String> {
        let value: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
        let version = value.get("format_version").and_then(Value::as_u64);
        if version != Some(u64::from(FORMAT_VERSION)) {
            let found = version.map_or("none".to_string(), |v| v.to_string());
            return Err(format!(
                "reflection format version {found}, this runtime reads version {FORMAT_VERSION}: \
                 rebuild the scene with a matching vrsc"
            ));
        }
        serde_json::from_value(value).map_err(|e| format!("malformed reflection: {e}"))
    }

    /// The uniform called `name`, if the shader reads it.
    pub fn uniform(&self, name: &str) -> Option<&UniformInfo> {
        self.uniforms.iter().find(|u| u.name == name)
    }

    /// The running functions that declare uniform `name`, in pipeline order.
    pub fn declared_by<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a FunctionInfo> + 'a {
        self.pipeline.iter().flat_map(|s| &s.functions).filter(move |f| f.uniforms.iter().any(|u| u == name))
    }
}

/// xxh3-64 of `text` as 16 hex digits: the hash written as `wgsl_hash`.
pub fn content_hash(text: &str) -> String {
    format!("{:016x}", xxhash_rust::xxh3::xxh3_64(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wrong_format_version_is_refused_with_advice() {
        let err = Reflection::from_json(r#"{"format_version": 99}"#).unwrap_err();
        assert!(err.contains("version 99") && err.contains("rebuild"), "{err}");
        assert!(Reflection::from_json("{}").unwrap_err().contains("version none"));
    }

    #[test]
    fn lifetimes_are_written_as_the_spec_names_them() {
        assert_eq!(serde_json::to_string(&Lifetime::Ray).unwrap(), "\"ray\"");
        assert_eq!(serde_json::from_str::<Lifetime>("\"sample\"").unwrap(), Lifetime::Sample);
    }
}
