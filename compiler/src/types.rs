//! VRS types: WGSL's plain types plus the two resource types `volume` and `tf`.
//!
//! Public face: [`Type`] and its [`Scalar`]s, with their names as written (`Type::from_name`,
//! `Display`) and the questions the checker asks of them; the runtime and the language server
//! use them to describe uniforms and name types.

use std::fmt;

/// A VRS scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Scalar {
    /// `bool`.
    Bool,
    /// `i32`: 32-bit signed integer.
    I32,
    /// `u32`: 32-bit unsigned integer.
    U32,
    /// `f32`: 32-bit float.
    F32,
}

impl Scalar {
    /// The type's name as written (`f32`).
    pub fn name(self) -> &'static str {
        match self {
            Scalar::Bool => "bool",
            Scalar::I32 => "i32",
            Scalar::U32 => "u32",
            Scalar::F32 => "f32",
        }
    }

    /// The letter of WGSL's short vector aliases (`vec3f`, `vec2i`, `vec4u`).
    fn alias_letter(self) -> Option<char> {
        match self {
            Scalar::Bool => None,
            Scalar::I32 => Some('i'),
            Scalar::U32 => Some('u'),
            Scalar::F32 => Some('f'),
        }
    }

    /// `i32` or `u32`.
    pub(crate) fn is_integer(self) -> bool {
        matches!(self, Scalar::I32 | Scalar::U32)
    }

    /// Not `bool`.
    pub(crate) fn is_numeric(self) -> bool {
        self != Scalar::Bool
    }
}

/// A VRS type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Type {
    /// A single `bool`, `i32`, `u32` or `f32`.
    Scalar(Scalar),
    /// `vecN<T>` (also written `vec3f` and the like).
    Vector {
        /// The component count: 2, 3 or 4.
        size: u8,
        /// The component type.
        scalar: Scalar,
    },
    /// `matCxR<f32>`; always f32.
    Matrix {
        /// The column count: 2, 3 or 4.
        cols: u8,
        /// The row count: 2, 3 or 4.
        rows: u8,
    },
    /// A scalar 3D texture with its sampler.
    Volume,
    /// A transfer function: a 1D RGBA lookup texture with its sampler.
    Tf,
    /// A 2D image of the picture (a filter's input buffer), read texel by texel with `load`.
    Image,
    /// The result of a call that returns nothing.
    Void,
    /// The type of an expression that already produced an error: accepted everywhere, so one
    /// mistake yields one diagnostic.
    Error,
}

impl Type {
    /// The scalar type `bool`.
    pub const BOOL: Type = Type::Scalar(Scalar::Bool);
    /// The scalar type `i32`.
    pub const I32: Type = Type::Scalar(Scalar::I32);
    /// The scalar type `u32`.
    pub const U32: Type = Type::Scalar(Scalar::U32);
    /// The scalar type `f32`.
    pub const F32: Type = Type::Scalar(Scalar::F32);

    /// `vecN<scalar>`.
    pub(crate) fn vec(size: u8, scalar: Scalar) -> Type {
        Type::Vector { size, scalar }
    }

    /// Parses a type name without template arguments: `f32`, `vec3f`, `mat4x4f`, `volume`.
    pub fn from_name(name: &str) -> Option<Type> {
        let scalar = |s: &str| match s {
            "f" => Some(Scalar::F32),
            "i" => Some(Scalar::I32),
            "u" => Some(Scalar::U32),
            _ => None,
        };
        Some(match name {
            "bool" => Type::BOOL,
            "i32" => Type::I32,
            "u32" => Type::U32,
            "f32" => Type::F32,
            "volume" => Type::Volume,
            "tf" => Type::Tf,
            "image" => Type::Image,
            _ => {
                if let Some(rest) = name.strip_prefix("vec") {
                    let (n, s) = rest.split_at_checked(1)?;
                    Type::vec(vector_size(n)?, scalar(s)?)
                } else if let Some(rest) = name.strip_prefix("mat") {
                    let bytes = rest.as_bytes();
                    if bytes.len() != 4 || bytes[1] != b'x' || bytes[3] != b'f' {
                        return None;
                    }
                    Type::Matrix { cols: vector_size(&rest[0..1])?, rows: vector_size(&rest[2..3])? }
                } else {
                    return None;
                }
            }
        })
    }

    /// Parses a generic type: `vec3<f32>`, `mat4x4<f32>`.
    pub(crate) fn from_generic(name: &str, arg: Type) -> Option<Type> {
        let Type::Scalar(scalar) = arg else { return None };
        if let Some(n) = name.strip_prefix("vec") {
            return Some(Type::vec(vector_size(n)?, scalar));
        }
        let rest = name.strip_prefix("mat")?;
        let bytes = rest.as_bytes();
        if bytes.len() != 3 || bytes[1] != b'x' || scalar != Scalar::F32 {
            return None;
        }
        Some(Type::Matrix { cols: vector_size(&rest[0..1])?, rows: vector_size(&rest[2..3])? })
    }

    /// Whether `name` is a generic type constructor that takes a template argument.
    pub(crate) fn is_generic_name(name: &str) -> bool {
        matches!(name, "vec2" | "vec3" | "vec4")
            || (name.len() == 6 && name.starts_with("mat") && Type::from_generic(name, Type::F32).is_some())
    }

    /// The element scalar of a scalar, vector or matrix.
    pub fn scalar(self) -> Option<Scalar> {
        match self {
            Type::Scalar(s) | Type::Vector { scalar: s, .. } => Some(s),
            Type::Matrix { .. } => Some(Scalar::F32),
            _ => None,
        }
    }

    /// Number of scalar components (1 for a scalar; cols*rows for a matrix).
    pub fn components(self) -> usize {
        match self {
            Type::Scalar(_) => 1,
            Type::Vector { size, .. } => size as usize,
            Type::Matrix { cols, rows } => cols as usize * rows as usize,
            _ => 0,
        }
    }

    /// A `volume`, `tf` or `image`: allowed only as uniforms and library-function parameters.
    pub(crate) fn is_resource(self) -> bool {
        matches!(self, Type::Volume | Type::Tf | Type::Image)
    }

    /// Values that can live in state, locals, constants and be returned.
    pub(crate) fn is_plain(self) -> bool {
        matches!(self, Type::Scalar(_) | Type::Vector { .. } | Type::Matrix { .. } | Type::Error)
    }

    /// Whether this is the type of an already reported mistake.
    pub fn is_error(self) -> bool {
        self == Type::Error
    }

    /// The same shape with another scalar: `vec3f` with `Bool` gives `vec3<bool>`.
    pub(crate) fn with_scalar(self, scalar: Scalar) -> Type {
        match self {
            Type::Vector { size, .. } => Type::vec(size, scalar),
            _ => Type::Scalar(scalar),
        }
    }
}

fn vector_size(digit: &str) -> Option<u8> {
    match digit {
        "2" => Some(2),
        "3" => Some(3),
        "4" => Some(4),
        _ => None,
    }
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Type::Scalar(s) => f.write_str(s.name()),
            Type::Vector { size, scalar } => match scalar.alias_letter() {
                Some(letter) => write!(f, "vec{size}{letter}"),
                None => write!(f, "vec{size}<bool>"),
            },
            Type::Matrix { cols, rows } => write!(f, "mat{cols}x{rows}f"),
            Type::Volume => f.write_str("volume"),
            Type::Tf => f.write_str("tf"),
            Type::Image => f.write_str("image"),
            Type::Void => f.write_str("()"),
            Type::Error => f.write_str("{error}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for name in ["bool", "i32", "u32", "f32", "vec2f", "vec3i", "vec4u", "mat3x3f", "mat4x2f", "volume", "tf"] {
            assert_eq!(Type::from_name(name).map(|t| t.to_string()), Some(name.to_string()));
        }
        assert_eq!(Type::from_generic("vec3", Type::F32), Some(Type::vec(3, Scalar::F32)));
        assert_eq!(Type::from_generic("mat2x3", Type::F32), Some(Type::Matrix { cols: 2, rows: 3 }));
        assert_eq!(Type::from_name("vec5f"), None);
        assert_eq!(Type::from_name("mat3x3i"), None);
    }
}
