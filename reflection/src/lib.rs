//! The reflection of a composed view: what a runtime needs to drive the shader without the
//! compiler — the uniform block layout with defaults, ranges and docs, every binding, the state
//! layout, the pipeline map, and hashes that tie it to its WGSL.
//!
//! This crate is the contract between `vrsc` and `vrs-runtime`: the compiler builds these values,
//! the runtime reads them, in process as typed values or from the `VIEW.json` that `vrsc build`
//! writes (serde, the same types both ways).

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Bumped whenever the JSON's shape changes incompatibly.
pub const FORMAT_VERSION: u32 = 1;

/// A view's reflection.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reflection {
    pub format_version: u32,
    pub view: String,
    /// `raycast` or `slice`.
    pub kind: String,
    pub entry_point: String,
    pub workgroup_size: [u32; 3],
    /// xxh3-64 (hex) of the WGSL text: a runtime loading `.wgsl` + `.json` checks they belong
    /// together.
    pub wgsl_hash: String,
    /// xxh3-64 (hex) of everything that shapes the shader (the WGSL and its bindings). Uniform
    /// values do not enter it, so equal hashes mean a configuration change only needs new
    /// uniform values, not a new pipeline.
    pub structural_hash: String,
    pub uniform_block: UniformBlock,
    pub uniforms: Vec<UniformInfo>,
    pub bindings: Vec<BindingInfo>,
    /// The state layout and the pipeline map are for tools (inspectors, probes); a runtime
    /// needs neither, so JSON without them still loads.
    #[serde(default)]
    pub state: StateInfo,
    #[serde(default)]
    pub pipeline: Vec<StepInfo>,
}

/// Where the uniform block is bound and how large it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct UniformBlock {
    pub group: u32,
    pub binding: u32,
    pub size: u32,
}

/// One uniform: a member of the uniform block, or a `volume` / `tf` resource (no offset).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UniformInfo {
    pub name: String,
    /// The VRS type: `f32`, `vec3f`, `mat4x4f`, `volume`, `tf`, ...
    #[serde(rename = "type")]
    pub ty: String,
    /// Byte offset in the uniform block; `None` for `volume` and `tf` (they are bindings).
    pub offset: Option<u32>,
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
    UniformBlock,
    OutputImage,
    /// `vec4<u32>` uniform: the pixels `x0, y0, x1, y1` (end exclusive) that a dispatch renders.
    Region,
    VolumeTexture,
    VolumeSampler,
    TfTexture,
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
    pub group: u32,
    pub binding: u32,
    pub kind: BindingKind,
}

/// The layout of the view's `State` struct.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateInfo {
    pub size: u32,
    pub fields: Vec<FieldInfo>,
}

/// Whether a state field lives for the whole ray or is reset at every sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Lifetime {
    Ray,
    Sample,
}

/// One state field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldInfo {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    pub lifetime: Lifetime,
    pub offset: u32,
    pub size: u32,
    pub default: Value,
}

/// One step of the pipeline and the functions placed in it, in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepInfo {
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
    pub name: String,
    pub instance: Option<String>,
    pub file: String,
    pub line: usize,
    pub column: usize,
    /// Byte range in the file.
    pub span: [u32; 2],
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
