//! The raw serde tables of a scene file: what `deny_unknown_fields` checks, with byte ranges.

use super::*;

// ---------------------------------------------------------------------------------------------
// Raw serde tables.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) render: Option<Spanned<RawRender>>,
    #[serde(default, rename = "volume")]
    pub(super) volumes: Vec<Spanned<RawVolume>>,
    #[serde(default, rename = "module")]
    pub(super) modules: Vec<Spanned<RawModule>>,
    #[serde(default)]
    pub(super) uniforms: BTreeMap<Spanned<String>, Spanned<UniformValue>>,
    #[serde(default, rename = "view")]
    pub(super) views: Vec<Spanned<RawView>>,
    #[serde(default, rename = "mesh")]
    pub(super) meshes: Vec<Spanned<super::mesh::RawMesh>>,
    #[serde(default, rename = "group")]
    pub(super) groups: Vec<Spanned<RawGroup>>,
    #[serde(default, rename = "image")]
    pub(super) images: Vec<Spanned<super::image::RawImage>>,
}
pub(super) const SCENE_KEYS: &[&str] = &["render", "volume", "module", "uniforms", "view", "mesh", "group", "image"];

#[derive(Deserialize, Default, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    pub(super) compositing: Option<Spanned<Compositing>>,
    pub(super) iso_value: Option<Spanned<f32>>,
    pub(super) shading: Option<Spanned<bool>>,
    pub(super) lights: Option<Spanned<Vec<Spanned<String>>>>,
    pub(super) boundary: Option<Spanned<bool>>,
    pub(super) tone: Option<Spanned<bool>>,
    pub(super) empty_space_skipping: Option<Spanned<bool>>,
    pub(super) step_size: Option<Spanned<f32>>,
    pub(super) max_samples: Option<Spanned<u32>>,
    pub(super) jitter: Option<Spanned<f32>>,
    pub(super) background: Option<Spanned<[f32; 4]>>,
    pub(super) tone_mapping: Option<Spanned<ToneMapping>>,
    pub(super) exposure: Option<Spanned<f32>>,
    pub(super) auto_exposure: Option<Spanned<bool>>,
    pub(super) white_point: Option<Spanned<f32>>,
    pub(super) preintegration: Option<Spanned<Preintegration>>,
    pub(super) shadows: Option<Spanned<Shadows>>,
    pub(super) ambient_occlusion: Option<Spanned<bool>>,
    pub(super) memory: Option<Spanned<String>>,
    pub(super) host_memory: Option<Spanned<String>>,
}
pub(super) const RENDER_KEYS: &[&str] = &[
    "compositing",
    "iso_value",
    "shading",
    "lights",
    "boundary",
    "tone",
    "empty_space_skipping",
    "step_size",
    "max_samples",
    "jitter",
    "background",
    "tone_mapping",
    "exposure",
    "auto_exposure",
    "white_point",
    "preintegration",
    "shadows",
    "ambient_occlusion",
    "memory",
    "host_memory",
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawVolume {
    pub(super) name: Spanned<String>,
    pub(super) role: Spanned<Role>,
    pub(super) path: Option<Spanned<String>>,
    pub(super) phantom: Option<Spanned<String>>,
    pub(super) fallback: Option<Spanned<String>>,
    pub(super) tf: Option<Spanned<RawTf>>,
    pub(super) window: Option<Spanned<[f32; 2]>>,
    pub(super) level: Option<Spanned<f32>>,
    pub(super) width: Option<Spanned<f32>>,
    pub(super) bricks: Option<Spanned<bool>>,
    pub(super) lookup: Option<Spanned<String>>,
    pub(super) labels: Option<Spanned<bool>>,
    pub(super) multiscale: Option<Spanned<RawEntry>>,
    pub(super) channel: Option<Spanned<RawChannels>>,
    pub(super) time: Option<Spanned<i64>>,
}
pub(super) const VOLUME_KEYS: &[&str] = &[
    "name",
    "role",
    "path",
    "phantom",
    "fallback",
    "tf",
    "window",
    "level",
    "width",
    "bricks",
    "lookup",
    "labels",
    "multiscale",
    "channel",
    "time",
];

/// A volume's `tf`: one, or one per channel of `channel = [...]`.
#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum RawTf {
    One(String),
    Many(Vec<String>),
}

/// `channel`: one channel, or a list of them (one volume each).
#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum RawChannels {
    One(RawEntry),
    Many(Vec<RawEntry>),
}

/// An entry of a store's list, by index or by name.
#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum RawEntry {
    Index(i64),
    Name(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawModule {
    pub(super) path: Spanned<String>,
    pub(super) instances: Option<Spanned<Vec<Spanned<String>>>>,
}
pub(super) const MODULE_KEYS: &[&str] = &["path", "instances"];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawView {
    pub(super) name: Spanned<String>,
    pub(super) kind: Option<Spanned<ViewKind>>,
    pub(super) size: Option<Spanned<[u32; 2]>>,
    pub(super) camera: Option<Spanned<RawCamera>>,
    pub(super) axis: Option<Spanned<Axis>>,
    pub(super) position: Option<Spanned<f32>>,
    pub(super) slab: Option<Spanned<f32>>,
    pub(super) convention: Option<Spanned<Convention>>,
    pub(super) render: Option<Spanned<RawRender>>,
    #[serde(default)]
    pub(super) modules: Vec<Spanned<RawModule>>,
    #[serde(default)]
    pub(super) filters: Vec<Spanned<RawModule>>,
    pub(super) meshes: Option<Spanned<Vec<Spanned<String>>>>,
    pub(super) overlay: Option<Spanned<Vec<Spanned<String>>>>,
    pub(super) planes: Option<Spanned<Vec<Spanned<String>>>>,
    pub(super) picture: Option<Spanned<Vec<Spanned<String>>>>,
}
pub(super) const VIEW_KEYS: &[&str] = &[
    "name",
    "kind",
    "size",
    "camera",
    "axis",
    "position",
    "slab",
    "convention",
    "render",
    "modules",
    "filters",
    "meshes",
    "overlay",
    "planes",
    "picture",
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGroup {
    pub(super) name: Spanned<String>,
    pub(super) kind: Option<Spanned<GroupKindName>>,
    pub(super) children: Spanned<Vec<Spanned<RawChild>>>,
    pub(super) show: Option<Spanned<Show>>,
    pub(super) opacity: Option<Spanned<f32>>,
    pub(super) light: Option<Spanned<RawLight>>,
}

/// A group's child: a node's name, or a filter over the children before it.
#[derive(Deserialize, Clone)]
#[serde(untagged)]
pub(super) enum RawChild {
    Name(String),
    Filter(RawFilterChild),
}

/// `{ filter = "PATH", instances = [...] }` among a group's children (without spans of its
/// own: an untagged enum cannot hold them; the entry's span stands for its values).
#[derive(Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFilterChild {
    pub(super) filter: String,
    pub(super) instances: Option<Vec<String>>,
}

/// A shadow group's `light`: a direction, or a light's name.
#[derive(Deserialize, Clone)]
#[serde(untagged)]
pub(super) enum RawLight {
    Towards([f32; 3]),
    Name(String),
}
pub(super) const GROUP_KEYS: &[&str] = &["name", "kind", "children", "show", "opacity", "light"];
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    pub(super) azimuth: Option<Spanned<f32>>,
    pub(super) elevation: Option<Spanned<f32>>,
    pub(super) distance: Option<Spanned<f32>>,
    pub(super) fov: Option<Spanned<f32>>,
}
pub(super) const CAMERA_KEYS: &[&str] = &["azimuth", "elevation", "distance", "fov"];
