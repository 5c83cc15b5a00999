//! Saving the user's uniform values into the scene file, keeping the file's comments, order
//! and layout (toml_edit): what the parameter panel's save action does.

use std::fmt;
use std::path::{Path, PathBuf};
use toml_edit::{Array, DocumentMut, Item, Table, Value as Toml};
use vrs_runtime::Value;

/// Uniforms that a scene sets through its `[render]` table rather than `[uniforms]`.
pub const RENDER_UNIFORMS: &[&str] = &["iso_value", "step_size", "jitter", "background", "max_samples"];

/// One uniform to save: its name, its VRS type (`f32`, `vec4f`, `mat3x3f`, ...) and value.
#[derive(Clone, Debug, PartialEq)]
pub struct SavedUniform {
    /// The key written under `[uniforms]` (or `[render]`).
    pub name: String,
    /// The VRS type, which decides how the value is written (a scalar or an array).
    pub ty: String,
    /// The value, as the runtime holds it.
    pub value: Value,
}

/// Why the scene file could not be saved (it is left as it was).
#[derive(Debug)]
pub enum SaveError {
    /// Reading the file, or writing and renaming its replacement, failed.
    Io {
        /// The scene file.
        path: PathBuf,
        /// What the file system said.
        error: std::io::Error,
    },
    /// The file is not valid TOML any more (the user is editing it): nothing is written.
    Parse {
        /// The scene file.
        path: PathBuf,
        /// The TOML parser's message.
        message: String,
    },
}

impl fmt::Display for SaveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SaveError::Io { path, error } => write!(f, "`{}`: cannot save: {error}", path.display()),
            SaveError::Parse { path, message } => {
                write!(f, "`{}` is not valid TOML now, so nothing was saved: {message}", path.display())
            }
        }
    }
}

impl std::error::Error for SaveError {}

/// Writes `uniforms` into the scene file at `path`: each replaces the value of its key in
/// `[uniforms]` (or `[render]`, for [`RENDER_UNIFORMS`]) or is added at the table's end; the
/// table is created when missing. Comments, key order and formatting of everything else stay.
/// The file is replaced atomically (a temporary file renamed over it).
pub fn save_uniforms(path: &Path, uniforms: &[SavedUniform]) -> Result<(), SaveError> {
    let io = |error| SaveError::Io { path: path.to_path_buf(), error };
    let text = std::fs::read_to_string(path).map_err(io)?;
    let updated =
        with_uniforms(&text, uniforms).map_err(|message| SaveError::Parse { path: path.to_path_buf(), message })?;
    let temporary = path.with_extension("toml.saving");
    std::fs::write(&temporary, updated).map_err(io)?;
    std::fs::rename(&temporary, path).map_err(io)
}

/// The scene text with `uniforms` written in (see [`save_uniforms`]).
pub fn with_uniforms(text: &str, uniforms: &[SavedUniform]) -> Result<String, String> {
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| e.to_string())?;
    for u in uniforms {
        let table = if RENDER_UNIFORMS.contains(&u.name.as_str()) { "render" } else { "uniforms" };
        let table = table_mut(&mut doc, table)?;
        let value = toml_value(&u.ty, &u.value);
        match table.get_mut(&u.name).and_then(Item::as_value_mut) {
            // Keep the comment after the value (and the spacing before it).
            Some(old) => {
                let decor = old.decor().clone();
                *old = value;
                *old.decor_mut() = decor;
            }
            None => {
                table.insert(&u.name, Item::Value(value));
            }
        }
    }
    Ok(doc.to_string())
}

/// Points the `tf` of the scene's `[[volume]]` named `volume` at `tf` (a preset name or a
/// colormap path as the scene writes it), keeping everything else of the file.
pub fn set_volume_tf(path: &Path, volume: &str, tf: &str) -> Result<(), SaveError> {
    let io = |error| SaveError::Io { path: path.to_path_buf(), error };
    let parse = |message: String| SaveError::Parse { path: path.to_path_buf(), message };
    let text = std::fs::read_to_string(path).map_err(io)?;
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| parse(e.to_string()))?;
    let volumes = doc.get_mut("volume").and_then(Item::as_array_of_tables_mut);
    let table = volumes
        .and_then(|v| v.iter_mut().find(|t| t.get("name").and_then(Item::as_str) == Some(volume)))
        .ok_or_else(|| parse(format!("it has no [[volume]] named `{volume}`")))?;
    match table.get_mut("tf").and_then(Item::as_value_mut) {
        Some(old) => {
            let decor = old.decor().clone();
            *old = Toml::from(tf);
            *old.decor_mut() = decor;
        }
        None => {
            table.insert("tf", toml_edit::value(tf));
        }
    }
    write_atomically(path, &doc.to_string())
}

fn write_atomically(path: &Path, text: &str) -> Result<(), SaveError> {
    let io = |error| SaveError::Io { path: path.to_path_buf(), error };
    let temporary = path.with_extension("toml.saving");
    std::fs::write(&temporary, text).map_err(io)?;
    std::fs::rename(&temporary, path).map_err(io)
}

/// The table `name`, created (after everything else) when the file has none.
fn table_mut<'d>(doc: &'d mut DocumentMut, name: &str) -> Result<&'d mut Table, String> {
    let item = doc.entry(name).or_insert_with(|| Item::Table(Table::new()));
    if let Some(inline) = item.as_inline_table() {
        *item = Item::Table(inline.clone().into_table());
    }
    item.as_table_mut().ok_or_else(|| format!("`{name}` is not a table"))
}

/// A value as the scene writes it: a scalar, a vector as an array, a matrix as an array of
/// columns.
fn toml_value(ty: &str, value: &Value) -> Toml {
    let scalars: Vec<Toml> = match value {
        Value::Float(v) => v.iter().map(|&x| Toml::from(shortest(x))).collect(),
        Value::Int(v) => v.iter().map(|&x| Toml::from(i64::from(x))).collect(),
        Value::Uint(v) => v.iter().map(|&x| Toml::from(i64::from(x))).collect(),
        Value::Bool(v) => v.iter().map(|&x| Toml::from(x)).collect(),
    };
    if let Some(rows) = matrix_rows(ty) {
        let columns = scalars.chunks(rows).map(|c| Toml::Array(c.iter().cloned().collect::<Array>()));
        return Toml::Array(columns.collect());
    }
    match <[Toml; 1]>::try_from(scalars) {
        Ok([one]) if !ty.starts_with("vec") => one,
        Ok(one) => Toml::Array(one.into_iter().collect()),
        Err(many) => Toml::Array(many.into_iter().collect()),
    }
}

/// The rows of a matrix type `matCxRf`.
fn matrix_rows(ty: &str) -> Option<usize> {
    let shape = ty.strip_prefix("mat")?;
    shape.as_bytes().get(2).filter(|_| shape.as_bytes().get(1) == Some(&b'x')).map(|r| (r - b'0') as usize)
}

/// An f32 as the f64 with the same shortest decimal form (0.1f32 is written `0.1`).
fn shortest(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn saved(name: &str, ty: &str, value: Value) -> SavedUniform {
        SavedUniform { name: name.into(), ty: ty.into(), value }
    }

    const SCENE: &str = "# the scene\n[render]\njitter = 1.0 # keep the noise\n\n[uniforms]\n# the plane of the grey matter\nclip_plane_gm = [1.0, 0.0, 0.0, -0.5]  # x = 0.5\n\n[[view]]\nname = \"3d\"\n";

    #[test]
    fn a_saved_value_replaces_the_old_one_and_keeps_the_comments() {
        let plane = saved("clip_plane_gm", "vec4f", Value::Float(vec![0.0, 1.0, 0.0, -0.25]));
        let out = with_uniforms(SCENE, &[plane, saved("jitter", "f32", Value::Float(vec![0.5]))]).unwrap();
        assert!(out.contains("clip_plane_gm = [0.0, 1.0, 0.0, -0.25]  # x = 0.5\n"), "{out}");
        assert!(out.contains("# the plane of the grey matter\n"), "{out}");
        assert!(out.contains("jitter = 0.5 # keep the noise\n"), "{out}");
        assert!(out.starts_with("# the scene\n[render]"), "{out}");
        assert!(out.ends_with("[[view]]\nname = \"3d\"\n"), "{out}");
    }

    #[test]
    fn new_uniforms_and_tables_are_added() {
        let m = saved("warp", "mat2x2f", Value::Float(vec![1.0, 0.0, 0.5, 1.0]));
        let out =
            with_uniforms("[[view]]\nname = \"a\"\n", &[m, saved("show", "bool", Value::Bool(vec![true]))]).unwrap();
        let doc: toml::Table = out.parse().unwrap();
        assert_eq!(doc["uniforms"]["warp"].to_string(), "[[1.0, 0.0], [0.5, 1.0]]");
        assert_eq!(doc["uniforms"]["show"].as_bool(), Some(true));
        let ints = with_uniforms("", &[saved("count", "vec2u", Value::Uint(vec![3, 4]))]).unwrap();
        assert!(ints.contains("count = [3, 4]"), "{ints}");
        let one = with_uniforms("", &[saved("v", "vec1f", Value::Float(vec![0.1]))]).unwrap();
        assert!(one.contains("v = [0.1]"), "{one}");
    }

    #[test]
    fn a_volume_tf_is_pointed_at_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        let scene = "[[volume]]\nname = \"t1\"\ntf = \"grayscale\" # first try\n\n[[volume]]\nname = \"gm\"\n";
        std::fs::write(&path, scene).unwrap();
        set_volume_tf(&path, "t1", "t1_tf.json").unwrap();
        set_volume_tf(&path, "gm", "gm_tf.json").unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("tf = \"t1_tf.json\" # first try\n"), "{text}");
        assert!(text.contains("name = \"gm\"\ntf = \"gm_tf.json\""), "{text}");
        assert!(set_volume_tf(&path, "nope", "x.json").is_err());
    }

    #[test]
    fn broken_toml_is_not_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, "[uniforms\n").unwrap();
        let err = save_uniforms(&path, &[saved("x", "f32", Value::Float(vec![1.0]))]).unwrap_err();
        assert!(err.to_string().contains("nothing was saved"), "{err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "[uniforms\n");
    }
}
