//! The reflection JSON that `vrsc build` writes beside each view's WGSL, read without the
//! compiler: what the runtime needs to bind resources and fill the uniform block.

use serde::Deserialize;
use serde_json::Value;

/// The reflection format this runtime reads (`format_version` in the JSON).
pub const FORMAT_VERSION: u32 = 1;

/// A view's reflection.
#[derive(Clone, Debug, Deserialize)]
pub struct Reflection {
    pub format_version: u32,
    pub view: String,
    /// `raycast` or `slice`.
    pub kind: String,
    pub entry_point: String,
    pub workgroup_size: [u32; 3],
    /// xxh3-64 (hex) of the WGSL text.
    pub wgsl_hash: String,
    /// xxh3-64 (hex) of everything that shapes the pipeline: equal hashes, same pipeline.
    pub structural_hash: String,
    pub uniform_block: UniformBlock,
    pub uniforms: Vec<UniformInfo>,
    pub bindings: Vec<BindingInfo>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct UniformBlock {
    pub group: u32,
    pub binding: u32,
    pub size: u32,
}

/// One uniform: a member of the uniform block, or a `volume` / `tf` resource (no offset).
#[derive(Clone, Debug, Deserialize)]
pub struct UniformInfo {
    pub name: String,
    /// The VRS type: `f32`, `vec3f`, `mat4x4f`, `volume`, `tf`, ...
    #[serde(rename = "type")]
    pub ty: String,
    pub offset: Option<u32>,
    pub size: Option<u32>,
    pub default: Option<Value>,
    /// The scene's initial value, when it sets one.
    pub value: Option<Value>,
    pub range: Option<[Value; 2]>,
    pub doc: Option<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BindingKind {
    UniformBlock,
    OutputImage,
    VolumeTexture,
    VolumeSampler,
    TfTexture,
    TfSampler,
}

#[derive(Clone, Debug, Deserialize)]
pub struct BindingInfo {
    /// The uniform's name for resources (`volume`, `tf_gm`); `uniforms` / `output` otherwise.
    pub name: String,
    pub group: u32,
    pub binding: u32,
    pub kind: BindingKind,
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

    pub fn uniform(&self, name: &str) -> Option<&UniformInfo> {
        self.uniforms.iter().find(|u| u.name == name)
    }
}

/// xxh3-64 of `text` as 16 hex digits: the hash `vrsc` writes as `wgsl_hash`.
pub fn content_hash(text: &str) -> String {
    format!("{:016x}", xxhash_rust::xxh3::xxh3_64(text.as_bytes()))
}
