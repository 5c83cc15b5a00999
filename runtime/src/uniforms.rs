//! A view's uniform block on the CPU, set by name and typed from the reflection: the bytes that
//! are uploaded to the view's uniform buffer.

use crate::reflection::{Reflection, UniformInfo};
use serde_json::Value as Json;
use std::fmt;

/// A uniform value. Vectors and matrices are flat lists of components (matrices column by
/// column), so one shape serves every VRS type.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `f32` components (a scalar, vector or matrix, column by column).
    Float(Vec<f32>),
    /// `i32` components.
    Int(Vec<i32>),
    /// `u32` components.
    Uint(Vec<u32>),
    /// `bool` components.
    Bool(Vec<bool>),
}

impl From<f32> for Value {
    fn from(v: f32) -> Value {
        Value::Float(vec![v])
    }
}
impl From<u32> for Value {
    fn from(v: u32) -> Value {
        Value::Uint(vec![v])
    }
}
impl From<i32> for Value {
    fn from(v: i32) -> Value {
        Value::Int(vec![v])
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Value {
        Value::Bool(vec![v])
    }
}
impl<const N: usize> From<[f32; N]> for Value {
    fn from(v: [f32; N]) -> Value {
        Value::Float(v.to_vec())
    }
}
impl From<glam::Vec3> for Value {
    fn from(v: glam::Vec3) -> Value {
        Value::Float(v.to_array().to_vec())
    }
}
impl From<glam::Vec4> for Value {
    fn from(v: glam::Vec4) -> Value {
        Value::Float(v.to_array().to_vec())
    }
}
impl From<glam::Mat3> for Value {
    fn from(m: glam::Mat3) -> Value {
        Value::Float(m.to_cols_array().to_vec())
    }
}
impl From<glam::Mat4> for Value {
    fn from(m: glam::Mat4) -> Value {
        Value::Float(m.to_cols_array().to_vec())
    }
}

/// The scalar kind and shape of a VRS type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Shape {
    kind: Kind,
    /// 1 for scalars and vectors, the column count for matrices.
    cols: u32,
    /// Components per column (vector size; 1 for scalars).
    rows: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Float,
    Int,
    Uint,
    Bool,
}

impl Shape {
    fn parse(ty: &str) -> Option<Shape> {
        let scalar = |kind| Some(Shape { kind, cols: 1, rows: 1 });
        match ty {
            "f32" => return scalar(Kind::Float),
            "i32" => return scalar(Kind::Int),
            "u32" => return scalar(Kind::Uint),
            "bool" => return scalar(Kind::Bool),
            _ => {}
        }
        if let Some(rest) = ty.strip_prefix("vec") {
            let rows = rest.get(..1)?.parse().ok()?;
            let kind = match rest.get(1..)? {
                "f" => Kind::Float,
                "i" => Kind::Int,
                "u" => Kind::Uint,
                "<bool>" => Kind::Bool,
                _ => return None,
            };
            return Some(Shape { kind, cols: 1, rows });
        }
        let rest = ty.strip_prefix("mat")?.strip_suffix('f')?;
        let (cols, rows) = rest.split_once('x')?;
        Some(Shape { kind: Kind::Float, cols: cols.parse().ok()?, rows: rows.parse().ok()? })
    }

    fn components(self) -> usize {
        (self.cols * self.rows) as usize
    }

    /// Byte distance between matrix columns in a uniform block (a column is a vector).
    fn column_stride(self) -> usize {
        if self.rows == 2 { 8 } else { 16 }
    }
}

/// Setting a uniform failed.
#[derive(Clone, Debug, PartialEq)]
pub enum UniformError {
    /// No uniform of that name in the view's shader.
    Unknown {
        /// The name asked for.
        name: String,
        /// The uniforms the shader has, for a suggestion.
        known: Vec<String>,
    },
    /// The value's type does not match the uniform's.
    WrongType {
        /// The uniform.
        name: String,
        /// Its WGSL type.
        expected: String,
        /// The value's type.
        got: String,
    },
    /// `volume` and `tf` uniforms are bound resources, not values.
    Resource {
        /// The uniform.
        name: String,
    },
}

impl fmt::Display for UniformError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UniformError::Unknown { name, known } => {
                write!(f, "the shader has no uniform `{name}`")?;
                if let Some(best) = closest(name, known) {
                    write!(f, "; did you mean `{best}`?")?;
                }
                Ok(())
            }
            UniformError::WrongType { name, expected, got } => {
                write!(f, "uniform `{name}` is a {expected}, not {got}")
            }
            UniformError::Resource { name } => {
                write!(f, "uniform `{name}` is a volume or transfer function: bind a texture instead of a value")
            }
        }
    }
}

impl std::error::Error for UniformError {}

fn closest<'a>(name: &str, known: &'a [String]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| (strsim::levenshtein(name, k), k))
        .filter(|(d, k)| *d <= 2.max(k.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k.as_str())
}

/// The bytes of one view's uniform block and where each uniform lives in it.
#[derive(Clone, Debug)]
pub struct UniformBlock {
    bytes: Vec<u8>,
    members: Vec<Member>,
    dirty: bool,
}

#[derive(Clone, Debug)]
struct Member {
    name: String,
    ty: String,
    shape: Option<Shape>,
    offset: usize,
}

impl UniformBlock {
    /// A block with every uniform at its reflected default (then the scene's value, if any).
    pub(crate) fn new(reflection: &Reflection) -> UniformBlock {
        let size = reflection.uniform_block.size.max(16) as usize;
        let members = reflection
            .uniforms
            .iter()
            .map(|u| Member {
                name: u.name.clone(),
                ty: u.ty.clone(),
                shape: Shape::parse(&u.ty),
                offset: u.offset.unwrap_or(0) as usize,
            })
            .collect();
        let mut block = UniformBlock { bytes: vec![0; size], members, dirty: true };
        for u in &reflection.uniforms {
            block.set_initial(u);
        }
        block
    }

    fn set_initial(&mut self, u: &UniformInfo) {
        for json in [&u.default, &u.value].into_iter().flatten() {
            if let Some(value) = self.value_from_json(&u.name, json) {
                let _ = self.set(&u.name, value);
            }
        }
    }

    /// A JSON value (as reflection and scenes write them) as a value of uniform `name`'s type.
    pub fn value_from_json(&self, name: &str, json: &Json) -> Option<Value> {
        let shape = self.members.iter().find(|m| m.name == name)?.shape?;
        let flat: Vec<&Json> = match json {
            Json::Array(items) => {
                items.iter().flat_map(|i| i.as_array().map_or(vec![i], |col| col.iter().collect())).collect()
            }
            scalar => vec![scalar],
        };
        Some(match shape.kind {
            Kind::Float => Value::Float(flat.iter().map(|v| v.as_f64().map(|f| f as f32)).collect::<Option<_>>()?),
            Kind::Int => Value::Int(flat.iter().map(|v| v.as_i64().map(|i| i as i32)).collect::<Option<_>>()?),
            Kind::Uint => Value::Uint(flat.iter().map(|v| v.as_u64().map(|u| u as u32)).collect::<Option<_>>()?),
            Kind::Bool => Value::Bool(flat.iter().map(|v| v.as_bool()).collect::<Option<_>>()?),
        })
    }

    /// Sets uniform `name`; the value's kind and component count must match its type.
    pub(crate) fn set(&mut self, name: &str, value: impl Into<Value>) -> Result<(), UniformError> {
        let value = value.into();
        let Some(member) = self.members.iter().find(|m| m.name == name) else {
            let known = self.members.iter().map(|m| m.name.clone()).collect();
            return Err(UniformError::Unknown { name: name.to_string(), known });
        };
        let Some(shape) = member.shape else { return Err(UniformError::Resource { name: name.to_string() }) };
        let (kind, count) = match &value {
            Value::Float(v) => (Kind::Float, v.len()),
            Value::Int(v) => (Kind::Int, v.len()),
            Value::Uint(v) => (Kind::Uint, v.len()),
            Value::Bool(v) => (Kind::Bool, v.len()),
        };
        if kind != shape.kind || count != shape.components() {
            return Err(UniformError::WrongType {
                name: name.to_string(),
                expected: member.ty.clone(),
                got: describe(kind, count),
            });
        }
        let words: Vec<[u8; 4]> = match value {
            Value::Float(v) => v.iter().map(|x| x.to_le_bytes()).collect(),
            Value::Int(v) => v.iter().map(|x| x.to_le_bytes()).collect(),
            Value::Uint(v) => v.iter().map(|x| x.to_le_bytes()).collect(),
            // Booleans live in the block as u32 (WGSL has no host-shareable bool).
            Value::Bool(v) => v.iter().map(|&x| u32::from(x).to_le_bytes()).collect(),
        };
        let offset = member.offset;
        for (i, word) in words.iter().enumerate() {
            let (col, row) = (i / shape.rows as usize, i % shape.rows as usize);
            let at = offset + col * shape.column_stride() + row * 4;
            if let Some(slot) = self.bytes.get_mut(at..at + 4) {
                slot.copy_from_slice(word);
            }
        }
        self.dirty = true;
        Ok(())
    }

    /// The current value of uniform `name`; `None` for an unknown name or a resource.
    pub fn get(&self, name: &str) -> Option<Value> {
        let member = self.members.iter().find(|m| m.name == name)?;
        let shape = member.shape?;
        let words = (0..shape.components()).map(|i| {
            let (col, row) = (i / shape.rows as usize, i % shape.rows as usize);
            let at = member.offset + col * shape.column_stride() + row * 4;
            self.bytes.get(at..at + 4).and_then(|b| b.try_into().ok()).unwrap_or([0; 4])
        });
        Some(match shape.kind {
            Kind::Float => Value::Float(words.map(f32::from_le_bytes).collect()),
            Kind::Int => Value::Int(words.map(i32::from_le_bytes).collect()),
            Kind::Uint => Value::Uint(words.map(u32::from_le_bytes).collect()),
            Kind::Bool => Value::Bool(words.map(|w| u32::from_le_bytes(w) != 0).collect()),
        })
    }

    /// Whether uniform `name` exists (as a value in the block).
    pub(crate) fn has(&self, name: &str) -> bool {
        self.members.iter().any(|m| m.name == name && m.shape.is_some())
    }

    pub(crate) fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The bytes, if they changed since the last call (so unchanged blocks are not uploaded).
    pub(crate) fn take_changes(&mut self) -> Option<&[u8]> {
        std::mem::take(&mut self.dirty).then_some(&self.bytes[..])
    }
}

fn describe(kind: Kind, count: usize) -> String {
    let scalar = match kind {
        Kind::Float => "f32",
        Kind::Int => "i32",
        Kind::Uint => "u32",
        Kind::Bool => "bool",
    };
    if count == 1 { format!("a {scalar}") } else { format!("{count} {scalar} values") }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reflection() -> Reflection {
        let json = r#"{"format_version":1,"view":"v","kind":"raycast","entry_point":"main",
            "workgroup_size":[8,8,1],"wgsl_hash":"0","structural_hash":"0",
            "uniform_block":{"group":0,"binding":0,"size":144},
            "uniforms":[
              {"name":"m","type":"mat4x4f","offset":0,"size":64,"default":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]],"value":null,"range":null,"doc":null},
              {"name":"c","type":"vec3f","offset":64,"size":12,"default":[0.5,0.5,0.5],"value":[1,2,3],"range":null,"doc":null},
              {"name":"k","type":"f32","offset":76,"size":4,"default":0.25,"value":null,"range":null,"doc":null},
              {"name":"n","type":"mat3x3f","offset":80,"size":48,"default":null,"value":null,"range":null,"doc":null},
              {"name":"flag","type":"bool","offset":128,"size":4,"default":true,"value":null,"range":null,"doc":null},
              {"name":"volume","type":"volume","offset":null,"size":null,"default":null,"value":null,"range":null,"doc":null}],
            "bindings":[]}"#;
        Reflection::from_json(json).unwrap()
    }

    fn f32_at(block: &UniformBlock, at: usize) -> f32 {
        f32::from_le_bytes(block.bytes()[at..at + 4].try_into().unwrap())
    }

    #[test]
    fn get_reads_back_what_set_wrote() {
        let mut block = UniformBlock::new(&reflection());
        let n: Vec<f32> = (0..9).map(|i| i as f32).collect();
        block.set("n", Value::Float(n.clone())).unwrap();
        assert_eq!(block.get("n"), Some(Value::Float(n)));
        assert_eq!(block.get("c"), Some(Value::Float(vec![1.0, 2.0, 3.0])));
        assert_eq!(block.get("flag"), Some(Value::Bool(vec![true])));
        assert_eq!(block.get("volume"), None);
        assert_eq!(block.get("nope"), None);
    }

    #[test]
    fn defaults_then_scene_values_fill_the_block() {
        let block = UniformBlock::new(&reflection());
        assert_eq!(f32_at(&block, 0), 1.0);
        assert_eq!(f32_at(&block, 20), 1.0);
        assert_eq!((f32_at(&block, 64), f32_at(&block, 72)), (1.0, 3.0), "the scene's value wins");
        assert_eq!(f32_at(&block, 76), 0.25);
    }

    #[test]
    fn set_checks_names_and_types() {
        let mut block = UniformBlock::new(&reflection());
        block.set("k", 2.0).unwrap();
        assert_eq!(f32_at(&block, 76), 2.0);
        let err = block.set("kk", 1.0).unwrap_err();
        assert_eq!(err.to_string(), "the shader has no uniform `kk`; did you mean `k`?");
        let err = block.set("c", 1.0).unwrap_err();
        assert_eq!(err.to_string(), "uniform `c` is a vec3f, not a f32");
        assert!(matches!(block.set("volume", 1.0), Err(UniformError::Resource { .. })));
        assert!(matches!(block.set("k", 1u32), Err(UniformError::WrongType { .. })));
    }

    #[test]
    fn mat3_columns_are_padded_to_16_bytes() {
        let mut block = UniformBlock::new(&reflection());
        block.set("n", Value::Float((1..=9).map(|i| i as f32).collect())).unwrap();
        assert_eq!(f32_at(&block, 80 + 16), 4.0);
        assert_eq!(f32_at(&block, 80 + 32 + 8), 9.0);
    }
}
