//! Scenes ("Scenes" in `docs/language.md`, with `vrsc`'s own keys under "Scenes" in
//! `docs/reference.md`): what to compose and render, as TOML.
//!
//! The public face: [`parse_scene`] and [`parse_scene_text`], which give the typed [`Scene`]
//! (its tables [`Render`], [`Volume`], [`View`], [`Mesh`], [`ModuleRef`] and the `[uniforms]`
//! values, [`UniformSetting`]), the queries later passes ask of it (which modules a view
//! composes, what a uniform starts at), the defaults and limits the scene applies
//! ([`DEFAULT_VIEW_SIZE`], [`MAX_VIEW_SIZE`], [`DEFAULT_CAMERA`], ...), and small helpers the
//! runtime shares ([`is_zarr`], [`is_url`], [`is_view_name`]).
//!
//! The caller adds the scene file to the [`SourceMap`] and calls [`parse_scene`] with its id;
//! every diagnostic then points into that file, in the map's global offset space. Parsing has
//! two stages: serde (with `deny_unknown_fields` on every table) turns the TOML into raw tables
//! whose fields keep their byte ranges ([`toml::Spanned`]); validation then checks what serde
//! cannot (names, ranges, one primary volume, keys that need each other) and builds the typed
//! [`Scene`], in which every name and value a later pass may point at carries its [`Span`].
//!
//! Decisions beyond "Scenes" in `docs/language.md` (documented for users in `docs/reference.md`,
//! "Choices beyond the language guide", and `stdlib/README.md`):
//! - `render.shading = true` without `lights` means `lights = ["key"]`; `lights` is ignored
//!   (warning) when shading is off. `lights = []` with shading gives ambient light only.
//! - `compositing = "iso"` requires `iso_value` (an error, not a silent default).
//! - `render.step_size`, `max_samples`, `jitter`, `background` and `iso_value` are initial values
//!   of the uniforms of the same names; setting one both there and in `[uniforms]` is an error.
//! - A volume's `window = [lo, hi]` (or `level` and `width`) is in data units; `lo < hi`.
//! - A volume's `tf` is a preset name when it is an identifier (`grayscale`), else a file path.
//!   It defaults to `grayscale` (`labels` for a tag volume) and is ignored for a mask volume.
//! - A module path `std::NAME` names a standard module; any other path is a file relative to the
//!   scene file.
//! - Keys that have no effect where they are (a raycast view's `axis`, a slice view's `camera`)
//!   are warnings, not errors.
//! - Names of volumes, lights, instances and uniforms are identifiers and not VRS keywords; view
//!   names (which name output files, `3d` in the examples of `docs/language.md`) are
//!   `[A-Za-z0-9_-]+`.

use crate::ast::Ident;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::source::{FileId, SourceMap, Span};
use crate::suggest::did_you_mean;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The size of a view when `size` is not given.
pub const DEFAULT_VIEW_SIZE: [u32; 2] = [512, 512];
/// The largest width or height of a view in a scene: the 2D texture size every WebGPU device
/// holds (`maxTextureDimension2D`), so a scene `build` accepts fits any device's output image.
pub const MAX_VIEW_SIZE: u32 = 8192;
/// The light that `shading = true` gets when `lights` is not given.
pub const DEFAULT_LIGHT: &str = "key";
/// The transfer function preset of primary and additional volumes without `tf`.
pub const DEFAULT_TF: &str = "grayscale";
/// The transfer function preset of tag volumes without `tf`.
pub const DEFAULT_TAG_TF: &str = "labels";
/// The default of the `step_size` uniform (mm); `stdlib/raycast.vrs` and `stdlib/slice.vrs`
/// declare the same value. The runtime replaces it by half the primary volume's smallest voxel
/// spacing when the scene sets no step size.
pub const DEFAULT_STEP_SIZE: f32 = 0.5;
/// The most samples per ray a scene may ask for.
pub const MAX_SAMPLES_LIMIT: u32 = 1 << 16;
/// Camera defaults: looking at the volume's centre along -z from `distance` 2.5, 30° vertical
/// field of view.
pub const DEFAULT_CAMERA: Camera = Camera { azimuth: 0.0, elevation: 0.0, distance: 2.5, fov: 30.0 };
/// Slice position when `position` is not given: the middle of the volume.
pub const DEFAULT_SLICE_POSITION: f32 = 0.5;

/// Uniforms that `[render]` keys set; `[uniforms]` must not set them again.
const RENDER_UNIFORMS: &[&str] = &["iso_value", "step_size", "max_samples", "jitter", "background"];

mod errors;
mod image;
mod mesh;
mod mistake;
mod model;
mod raw;
#[cfg(test)]
mod tests;
mod tree;
mod validate;
mod view_render;

pub use image::Image;
pub use mesh::{Coordinates, DEFAULT_MESH_COLOR, Mesh, MeshSource, Point, SHAPES};
use mistake::*;
pub use model::*;
use raw::RawScene;
pub use tree::DEFAULT_HIDDEN_OPACITY;
use tree::ViewLists;
use validate::Cx;
pub use validate::is_view_name;
pub use view_render::Convention;

// ---------------------------------------------------------------------------------------------
// Entry points.

/// Parses and validates the scene file `file` of `sources`, reporting into `diags`; the scene
/// when it has no errors. Relative paths resolve against the directory of the file's `path` (or
/// of its name when it has no path).
pub fn parse_scene(sources: &SourceMap, file: FileId, diags: &mut Diagnostics) -> Option<Scene> {
    let f = sources.file(file);
    let from = f.path.clone().unwrap_or_else(|| PathBuf::from(&f.name));
    let dir = from.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_scene_text(&f.text, f.base, &dir, diags)
}

/// Parses and validates scene text whose first byte has global offset `base`, reporting into
/// `diags` (sorted by position); the scene when it has no errors. Relative paths resolve against
/// `dir`.
pub fn parse_scene_text(text: &str, base: u32, dir: &Path, diags: &mut Diagnostics) -> Option<Scene> {
    let mut cx = Cx { text, base, dir, errors: Vec::new(), warnings: Vec::new() };
    let raw: RawScene = match toml::from_str(text) {
        Ok(raw) => raw,
        Err(e) => {
            diags.push(cx.toml_error(&e));
            return None;
        }
    };
    let scene = cx.scene(raw);
    let valid = cx.errors.is_empty();
    let mut found = cx.errors;
    found.extend(cx.warnings);
    crate::diag::sort(&mut found);
    found.into_iter().for_each(|d| diags.push(d));
    valid.then_some(scene)
}
