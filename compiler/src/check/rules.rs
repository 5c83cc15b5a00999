//! WGSL's typing rules for operators, built-ins and constructors, as pure functions over
//! [`Type`]s. The checker calls these; they know nothing of spans or names.
//!
//! `Type::Error` is accepted everywhere and propagates: an operand or argument of type `Error`
//! gives `Some(Type::Error)` / `Ok(..)`, never a message, so one mistake yields one diagnostic.

use crate::ast::{BinaryOp, UnaryOp};
use crate::hir::Builtin;
use crate::types::{Scalar, Type};

/// Result type of `lhs op rhs`, or `None` when WGSL rejects the operand types.
/// Operands of type `Type::Error` give `Some(Type::Error)`.
pub fn binary_result(op: BinaryOp, lhs: Type, rhs: Type) -> Option<Type> {
    use BinaryOp::*;
    if lhs.is_error() || rhs.is_error() {
        return Some(Type::Error);
    }
    match op {
        Add | Sub => arithmetic(lhs, rhs).or_else(|| same_matrix(lhs, rhs)),
        Mul => arithmetic(lhs, rhs).or_else(|| matrix_product(lhs, rhs)),
        Div | Rem => arithmetic(lhs, rhs),
        Lt | Le | Gt | Ge => comparison(lhs, rhs, Scalar::is_numeric),
        Eq | Ne => comparison(lhs, rhs, |_| true),
        And | Or => (lhs == Type::BOOL && rhs == Type::BOOL).then_some(Type::BOOL),
        // WGSL (and naga) define `&` and `|` on bool, but `^` on integers only.
        BitAnd | BitOr => same_scalar_or_vector(lhs, rhs, |s| s.is_integer() || s == Scalar::Bool),
        BitXor => same_scalar_or_vector(lhs, rhs, Scalar::is_integer),
        Shl | Shr => shift(lhs, rhs),
    }
}

/// The element scalar of a scalar or vector (not a matrix or resource).
fn element(ty: Type) -> Option<Scalar> {
    match ty {
        Type::Scalar(s) | Type::Vector { scalar: s, .. } => Some(s),
        _ => None,
    }
}

/// Whether `ty` is a scalar or vector whose element satisfies `pred`.
fn is_sv(ty: Type, pred: impl Fn(Scalar) -> bool) -> bool {
    element(ty).is_some_and(pred)
}

fn is_float(ty: Type) -> bool {
    is_sv(ty, |s| s == Scalar::F32)
}

fn is_numeric(ty: Type) -> bool {
    is_sv(ty, Scalar::is_numeric)
}

fn is_bool(ty: Type) -> bool {
    is_sv(ty, |s| s == Scalar::Bool)
}

fn is_float_vector(ty: Type) -> bool {
    matches!(ty, Type::Vector { scalar: Scalar::F32, .. })
}

/// `+ - * / %` on numeric scalars and vectors: equal types, or a vector mixed with a scalar of
/// its element type (either side).
fn arithmetic(lhs: Type, rhs: Type) -> Option<Type> {
    let (l, r) = (element(lhs)?, element(rhs)?);
    if l != r || !l.is_numeric() {
        return None;
    }
    match (lhs, rhs) {
        _ if lhs == rhs => Some(lhs),
        (Type::Vector { .. }, Type::Scalar(_)) => Some(lhs),
        (Type::Scalar(_), Type::Vector { .. }) => Some(rhs),
        _ => None,
    }
}

/// `mat + mat`, `mat - mat` of the same shape.
fn same_matrix(lhs: Type, rhs: Type) -> Option<Type> {
    (matches!(lhs, Type::Matrix { .. }) && lhs == rhs).then_some(lhs)
}

/// The products involving a matrix: with f32, with a vector on either side, with a matrix.
fn matrix_product(lhs: Type, rhs: Type) -> Option<Type> {
    use Type::{Matrix, Vector};
    match (lhs, rhs) {
        (Matrix { .. }, Type::F32) => Some(lhs),
        (Type::F32, Matrix { .. }) => Some(rhs),
        (Matrix { cols, rows }, Vector { size, scalar: Scalar::F32 }) if size == cols => {
            Some(Type::vec(rows, Scalar::F32))
        }
        (Vector { size, scalar: Scalar::F32 }, Matrix { cols, rows }) if size == rows => {
            Some(Type::vec(cols, Scalar::F32))
        }
        (Matrix { cols: k, rows }, Matrix { cols, rows: k2 }) if k == k2 => Some(Matrix { cols, rows }),
        _ => None,
    }
}

/// Equal scalar or vector types whose element satisfies `pred`, giving bool of the same shape.
fn comparison(lhs: Type, rhs: Type, pred: impl Fn(Scalar) -> bool) -> Option<Type> {
    same_scalar_or_vector(lhs, rhs, pred).map(|t| t.with_scalar(Scalar::Bool))
}

/// Equal scalar or vector types whose element satisfies `pred`.
fn same_scalar_or_vector(lhs: Type, rhs: Type, pred: impl Fn(Scalar) -> bool) -> Option<Type> {
    (lhs == rhs && is_sv(lhs, pred)).then_some(lhs)
}

/// `e << n`, `e >> n`: an integer scalar or vector shifted by u32 of the same shape.
fn shift(lhs: Type, rhs: Type) -> Option<Type> {
    let shape_ok = rhs == lhs.with_scalar(Scalar::U32);
    (is_sv(lhs, Scalar::is_integer) && shape_ok).then_some(lhs)
}

/// Result type of `op operand`.
pub fn unary_result(op: UnaryOp, operand: Type) -> Option<Type> {
    if operand.is_error() {
        return Some(Type::Error);
    }
    // WGSL (and naga) negate scalars and vectors only, not matrices: write `m * -1.0`.
    let ok = match op {
        UnaryOp::Neg => is_sv(operand, |s| matches!(s, Scalar::I32 | Scalar::F32)),
        UnaryOp::Not => is_bool(operand),
    };
    ok.then_some(operand)
}

/// All built-ins with their names, e.g. for completion.
pub fn builtins() -> &'static [(Builtin, &'static str)] {
    Builtin::ALL
}

/// The built-in called `name`, if any.
pub fn builtin_by_name(name: &str) -> Option<Builtin> {
    Builtin::by_name(name)
}

/// The name a built-in is called by in VRS.
pub fn builtin_name(builtin: Builtin) -> &'static str {
    builtin.name()
}

/// How a built-in is called and what it accepts, for editors: (`clamp(e, low, high)`, "takes
/// three values of the same float or integer type"); the first is the bare name where the
/// arguments need no names (`abs`).
pub fn builtin_usage(builtin: Builtin) -> (&'static str, &'static str) {
    let sig = signature(builtin, &[]);
    (sig.usage.unwrap_or_else(|| builtin_name(builtin)), sig.accepts)
}

/// Result type of a built-in call, or a message explaining which overloads exist.
pub fn builtin_result(builtin: Builtin, args: &[Type]) -> Result<Type, String> {
    if args.iter().any(|t| t.is_error()) {
        return Ok(Type::Error);
    }
    let sig = signature(builtin, args);
    let usage = sig.usage.unwrap_or_else(|| builtin_name(builtin));
    sig.result.ok_or_else(|| format!("`{usage}` {}; found {}", sig.accepts, found(args)))
}

/// The outcome of matching a call against a built-in's overloads.
struct Signature {
    /// How the call is written in messages, when more than the bare name helps.
    usage: Option<&'static str>,
    /// What the built-in accepts, as a sentence fragment.
    accepts: &'static str,
    result: Option<Type>,
}

fn sig(accepts: &'static str, result: Option<Type>) -> Signature {
    Signature { usage: None, accepts, result }
}

fn sig_usage(usage: &'static str, accepts: &'static str, result: Option<Type>) -> Signature {
    Signature { usage: Some(usage), accepts, result }
}

const FLOAT_1: &str = "takes one f32 or float vector (vecNf)";
const FLOAT_2: &str = "takes two values of the same float type (f32 or vecNf)";
const NUMERIC_2: &str = "takes two values of the same float or integer type";

fn signature(builtin: Builtin, args: &[Type]) -> Signature {
    use Builtin::*;
    match builtin {
        Abs => sig("takes one float or integer scalar or vector", one(args, is_numeric)),
        Sign => sig(
            "takes one f32 or i32 scalar or vector",
            one(args, |t| is_sv(t, |s| matches!(s, Scalar::F32 | Scalar::I32))),
        ),
        Min | Max => sig(NUMERIC_2, same(args, 2, is_numeric)),
        Clamp => sig_usage(
            "clamp(e, low, high)",
            "takes three values of the same float or integer type",
            same(args, 3, is_numeric),
        ),
        Mix => sig_usage(
            "mix(a, b, t)",
            "takes three values of the same float type, or two float vectors of the same type and an f32",
            mix(args),
        ),
        Step => sig_usage("step(edge, x)", "takes two values of the same float type", same(args, 2, is_float)),
        Smoothstep => {
            sig_usage("smoothstep(low, high, x)", "takes three values of the same float type", same(args, 3, is_float))
        }
        Floor | Ceil | Fract | Round | Trunc | Sqrt | InverseSqrt | Exp | Exp2 | Log | Log2 | Sin | Cos | Tan
        | Asin | Acos | Atan => sig(FLOAT_1, one(args, is_float)),
        Pow | Atan2 => sig(FLOAT_2, same(args, 2, is_float)),
        Dot => sig("takes two vectors of the same type", dot(args)),
        Cross => sig("takes two vec3f", cross(args)),
        Length => sig(FLOAT_1, one(args, is_float).map(|_| Type::F32)),
        Distance => sig(FLOAT_2, same(args, 2, is_float).map(|_| Type::F32)),
        Normalize => sig("takes one float vector (vecNf)", one(args, is_float_vector)),
        Reflect => sig("takes two float vectors of the same type", same(args, 2, is_float_vector)),
        FaceForward => sig("takes three float vectors of the same type", same(args, 3, is_float_vector)),
        Transpose => sig("takes one matrix", transpose(args)),
        Determinant => sig("takes one square matrix (mat2x2f, mat3x3f or mat4x4f)", determinant(args)),
        Select => sig_usage(
            "select(f, t, cond)",
            "takes two values of the same scalar or vector type and a bool condition \
             (a vecN<bool> of the same size for vectors)",
            select(args),
        ),
        Any | All => sig("takes one bool or vecN<bool>", one(args, is_bool).map(|_| Type::BOOL)),
        Sample => sig_usage("sample(v, p)", "takes a volume and a vec3f position", sample(args)),
        Lookup => sig_usage(
            "lookup(t, x)",
            "takes a tf and an f32 (a 1D table), or a tf and a vec2f (a 2D table such as a \
             pre-integrated one)",
            lookup(args),
        ),
        Dims => sig_usage("dims(v)", "takes a volume or an image", dims(args)),
        Load => sig_usage("load(i, p)", "takes an image and a vec2i pixel", load(args)),
    }
}

/// One argument satisfying `pred`; the result has its type.
fn one(args: &[Type], pred: impl Fn(Type) -> bool) -> Option<Type> {
    match args {
        [a] if pred(*a) => Some(*a),
        _ => None,
    }
}

/// `count` arguments of one type satisfying `pred`; the result has that type.
fn same(args: &[Type], count: usize, pred: impl Fn(Type) -> bool) -> Option<Type> {
    let first = *args.first()?;
    let all_same = args.iter().all(|t| *t == first);
    (args.len() == count && all_same && pred(first)).then_some(first)
}

fn mix(args: &[Type]) -> Option<Type> {
    match args {
        [a, b, Type::F32] if a == b && is_float_vector(*a) => Some(*a),
        _ => same(args, 3, is_float),
    }
}

fn dot(args: &[Type]) -> Option<Type> {
    match args {
        [a @ Type::Vector { scalar, .. }, b] if a == b && scalar.is_numeric() => Some(Type::Scalar(*scalar)),
        _ => None,
    }
}

fn cross(args: &[Type]) -> Option<Type> {
    let v3 = Type::vec(3, Scalar::F32);
    (args == [v3, v3]).then_some(v3)
}

fn transpose(args: &[Type]) -> Option<Type> {
    match args {
        [Type::Matrix { cols, rows }] => Some(Type::Matrix { cols: *rows, rows: *cols }),
        _ => None,
    }
}

fn determinant(args: &[Type]) -> Option<Type> {
    match args {
        [Type::Matrix { cols, rows }] if cols == rows => Some(Type::F32),
        _ => None,
    }
}

fn select(args: &[Type]) -> Option<Type> {
    match args {
        [f, t, Type::BOOL] if f == t && element(*f).is_some() => Some(*f),
        [f @ Type::Vector { size, .. }, t, Type::Vector { size: n, scalar: Scalar::Bool }] if f == t && size == n => {
            Some(*f)
        }
        _ => None,
    }
}

fn sample(args: &[Type]) -> Option<Type> {
    (args == [Type::Volume, Type::vec(3, Scalar::F32)]).then_some(Type::F32)
}

/// `lookup(t, x)` reads a 1D table at `x`; `lookup(t, xy)` a 2D one at `xy` (a `tf` is a 2D
/// texture: a 1D table is one row, which reads the same at every y).
fn lookup(args: &[Type]) -> Option<Type> {
    let coordinate_ok = matches!(args, [Type::Tf, Type::F32]) || args == [Type::Tf, Type::vec(2, Scalar::F32)];
    coordinate_ok.then_some(Type::vec(4, Scalar::F32))
}

fn dims(args: &[Type]) -> Option<Type> {
    match args {
        [Type::Volume] => Some(Type::vec(3, Scalar::U32)),
        [Type::Image] => Some(Type::vec(2, Scalar::U32)),
        _ => None,
    }
}

fn load(args: &[Type]) -> Option<Type> {
    (args == [Type::Image, Type::vec(2, Scalar::I32)]).then_some(Type::vec(4, Scalar::F32))
}

/// The argument types for a message: `f32`, `vec3f and vec4f`, `f32, i32, f32`.
fn found(args: &[Type]) -> String {
    let names: Vec<String> = args.iter().map(Type::to_string).collect();
    match names.as_slice() {
        [] => "no arguments".to_string(),
        [a, b] => format!("{a} and {b}"),
        _ => names.join(", "),
    }
}

/// How a type constructor `T(args)` is lowered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConstructorKind {
    /// Builds `T` from components (or zero-initialises it with no arguments).
    Construct,
    /// Converts one value of the same shape: `f32(i)`, `vec3f(v3i)`.
    Convert,
}

/// Checks a type constructor call, or explains which arguments `target` accepts.
pub fn constructor(target: Type, args: &[Type]) -> Result<ConstructorKind, String> {
    use ConstructorKind::*;
    if target.is_error() || args.iter().any(|t| t.is_error()) {
        return Ok(Construct);
    }
    let kind = match target {
        Type::Volume | Type::Tf | Type::Image => {
            return Err(format!(
                "`{target}` values cannot be constructed; they exist only as uniforms and \
                 library-function parameters"
            ));
        }
        Type::Void | Type::Error => return Err(format!("`{target}` cannot be constructed")),
        _ if args.is_empty() => Some(Construct),
        Type::Scalar(_) => scalar_constructor(args),
        Type::Vector { size, scalar } => vector_constructor(size, scalar, args),
        Type::Matrix { cols, rows } => matrix_constructor(target, cols, rows, args),
    };
    kind.ok_or_else(|| format!("{}; found {}", constructor_accepts(target), found(args)))
}

fn scalar_constructor(args: &[Type]) -> Option<ConstructorKind> {
    match args {
        [Type::Scalar(_)] => Some(ConstructorKind::Convert),
        _ => None,
    }
}

fn vector_constructor(size: u8, scalar: Scalar, args: &[Type]) -> Option<ConstructorKind> {
    use ConstructorKind::*;
    match args {
        [Type::Scalar(s)] if *s == scalar => Some(Construct),
        [Type::Vector { size: n, .. }] if *n == size => Some(Convert),
        [_] => None,
        _ => {
            let matching = args.iter().all(|t| element(*t) == Some(scalar));
            let total: usize = args.iter().map(|t| t.components()).sum();
            (matching && total == size as usize).then_some(Construct)
        }
    }
}

fn matrix_constructor(target: Type, cols: u8, rows: u8, args: &[Type]) -> Option<ConstructorKind> {
    let column = Type::vec(rows, Scalar::F32);
    let all = |ty: Type| args.iter().all(|t| *t == ty);
    match args.len() {
        1 if all(target) => Some(ConstructorKind::Convert),
        n if n == cols as usize && all(column) => Some(ConstructorKind::Construct),
        n if n == cols as usize * rows as usize && all(Type::F32) => Some(ConstructorKind::Construct),
        _ => None,
    }
}

/// What a constructor of `target` accepts, for messages.
fn constructor_accepts(target: Type) -> String {
    match target {
        Type::Scalar(_) => {
            format!("`{target}(e)` converts one scalar (bool, i32, u32 or f32), and `{target}()` is zero")
        }
        Type::Vector { size, scalar } => format!(
            "`{target}` takes nothing (zero), one {s} (splat), one {size}-component vector \
             (conversion), or {s} scalars and vectors with {size} components in total",
            s = scalar.name(),
        ),
        Type::Matrix { cols, rows } => format!(
            "`{target}` takes nothing (zero), one {target}, {cols} vec{rows}f columns or {n} f32 values",
            n = cols as usize * rows as usize,
        ),
        _ => format!("`{target}` cannot be constructed"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use BinaryOp::*;

    fn t(name: &str) -> Type {
        Type::from_name(name).unwrap_or(Type::Void)
    }

    fn vb(n: u8) -> Type {
        Type::vec(n, Scalar::Bool)
    }

    #[test]
    fn binary_table() {
        // (op, lhs, rhs, expected result or "" for rejected)
        let table: &[(BinaryOp, &str, &str, &str)] = &[
            (Add, "f32", "f32", "f32"),
            (Add, "i32", "i32", "i32"),
            (Sub, "u32", "u32", "u32"),
            (Add, "i32", "f32", ""),
            (Add, "u32", "i32", ""),
            (Add, "vec3f", "vec3f", "vec3f"),
            (Add, "vec3f", "vec4f", ""),
            (Add, "vec3f", "vec3i", ""),
            (Mul, "vec3f", "f32", "vec3f"),
            (Mul, "f32", "vec3f", "vec3f"),
            (Div, "vec2i", "i32", "vec2i"),
            (Rem, "u32", "vec4u", "vec4u"),
            (Mul, "vec3f", "i32", ""),
            (Add, "bool", "bool", ""),
            (Add, "mat3x3f", "mat3x3f", "mat3x3f"),
            (Sub, "mat2x3f", "mat2x3f", "mat2x3f"),
            (Add, "mat2x3f", "mat3x2f", ""),
            (Add, "mat3x3f", "f32", ""),
            (Mul, "mat3x3f", "f32", "mat3x3f"),
            (Mul, "f32", "mat4x2f", "mat4x2f"),
            (Mul, "mat3x3i", "f32", ""),
            (Mul, "mat4x4f", "vec4f", "vec4f"),
            (Mul, "mat2x3f", "vec2f", "vec3f"),
            (Mul, "mat2x3f", "vec3f", ""),
            (Mul, "vec3f", "mat2x3f", "vec2f"),
            (Mul, "vec2f", "mat2x3f", ""),
            (Mul, "mat2x3f", "mat4x2f", "mat4x3f"),
            (Mul, "mat2x3f", "mat2x3f", ""),
            (Mul, "mat3x3f", "vec3i", ""),
            (Div, "mat3x3f", "f32", ""),
            (Rem, "mat2x2f", "mat2x2f", ""),
            (Lt, "f32", "f32", "bool"),
            (Ge, "vec3i", "vec3i", "vec3<bool>"),
            (Lt, "vec3f", "f32", ""),
            (Lt, "bool", "bool", ""),
            (Eq, "bool", "bool", "bool"),
            (Ne, "vec2u", "vec2u", "vec2<bool>"),
            (Eq, "mat2x2f", "mat2x2f", ""),
            (And, "bool", "bool", "bool"),
            (Or, "bool", "i32", ""),
            (BitAnd, "u32", "u32", "u32"),
            (BitOr, "vec3i", "vec3i", "vec3i"),
            (BitXor, "i32", "i32", "i32"),
            (BitAnd, "f32", "f32", ""),
            (BitAnd, "vec3i", "i32", ""),
            (BitXor, "bool", "bool", ""),
            (Shl, "i32", "u32", "i32"),
            (Shr, "u32", "u32", "u32"),
            (Shl, "vec3i", "vec3u", "vec3i"),
            (Shl, "i32", "i32", ""),
            (Shl, "vec3i", "u32", ""),
            (Shl, "vec3i", "vec2u", ""),
            (Shl, "f32", "u32", ""),
            (Add, "volume", "volume", ""),
        ];
        for &(op, l, r, want) in table {
            let want = match want {
                "" => None,
                "vec3<bool>" => Some(vb(3)),
                "vec2<bool>" => Some(vb(2)),
                name => Some(t(name)),
            };
            assert_eq!(binary_result(op, t(l), t(r)), want, "{l} {} {r}", op.symbol());
        }
        assert_eq!(binary_result(BitOr, vb(2), vb(2)), Some(vb(2)));
        assert_eq!(binary_result(And, vb(2), vb(2)), None);
    }

    #[test]
    fn errors_propagate() {
        assert_eq!(binary_result(Add, Type::Error, Type::F32), Some(Type::Error));
        assert_eq!(binary_result(Shl, Type::I32, Type::Error), Some(Type::Error));
        assert_eq!(unary_result(UnaryOp::Neg, Type::Error), Some(Type::Error));
        assert_eq!(builtin_result(Builtin::Dot, &[Type::Error]), Ok(Type::Error));
        assert_eq!(constructor(t("vec4f"), &[Type::Error]), Ok(ConstructorKind::Construct));
    }

    #[test]
    fn unary() {
        assert_eq!(unary_result(UnaryOp::Neg, t("i32")), Some(t("i32")));
        assert_eq!(unary_result(UnaryOp::Neg, t("vec3f")), Some(t("vec3f")));
        assert_eq!(unary_result(UnaryOp::Neg, t("u32")), None);
        assert_eq!(unary_result(UnaryOp::Neg, t("bool")), None);
        assert_eq!(unary_result(UnaryOp::Neg, t("mat2x2f")), None);
        assert_eq!(unary_result(UnaryOp::Not, vb(4)), Some(vb(4)));
        assert_eq!(unary_result(UnaryOp::Not, t("i32")), None);
    }

    #[test]
    fn builtin_names_round_trip() {
        for &(b, name) in Builtin::ALL {
            assert_eq!(builtin_by_name(name), Some(b));
            assert_eq!(builtin_name(b), name);
        }
        assert_eq!(Builtin::ALL.len(), 43);
        assert_eq!(builtin_by_name("inversesqrt"), None);
    }

    fn call(name: &str, args: &[&str]) -> Result<Type, String> {
        let builtin = builtin_by_name(name).ok_or("no such builtin")?;
        let args: Vec<Type> = args.iter().map(|a| if *a == "vec3<bool>" { vb(3) } else { t(a) }).collect();
        builtin_result(builtin, &args)
    }

    #[test]
    fn builtins_accepted() {
        let table: &[(&str, &[&str], &str)] = &[
            ("abs", &["u32"], "u32"),
            ("abs", &["vec3i"], "vec3i"),
            ("sign", &["vec2f"], "vec2f"),
            ("min", &["u32", "u32"], "u32"),
            ("max", &["vec3f", "vec3f"], "vec3f"),
            ("clamp", &["i32", "i32", "i32"], "i32"),
            ("mix", &["vec3f", "vec3f", "vec3f"], "vec3f"),
            ("mix", &["vec3f", "vec3f", "f32"], "vec3f"),
            ("mix", &["f32", "f32", "f32"], "f32"),
            ("step", &["f32", "f32"], "f32"),
            ("smoothstep", &["vec2f", "vec2f", "vec2f"], "vec2f"),
            ("inverseSqrt", &["vec4f"], "vec4f"),
            ("atan", &["f32"], "f32"),
            ("pow", &["vec3f", "vec3f"], "vec3f"),
            ("atan2", &["f32", "f32"], "f32"),
            ("dot", &["vec3f", "vec3f"], "f32"),
            ("dot", &["vec2i", "vec2i"], "i32"),
            ("cross", &["vec3f", "vec3f"], "vec3f"),
            ("length", &["vec3f"], "f32"),
            ("distance", &["vec2f", "vec2f"], "f32"),
            ("normalize", &["vec3f"], "vec3f"),
            ("reflect", &["vec3f", "vec3f"], "vec3f"),
            ("faceForward", &["vec3f", "vec3f", "vec3f"], "vec3f"),
            ("transpose", &["mat2x3f"], "mat3x2f"),
            ("determinant", &["mat3x3f"], "f32"),
            ("select", &["f32", "f32", "bool"], "f32"),
            ("select", &["vec3i", "vec3i", "bool"], "vec3i"),
            ("select", &["vec3f", "vec3f", "vec3<bool>"], "vec3f"),
            ("any", &["vec3<bool>"], "bool"),
            ("all", &["bool"], "bool"),
            ("sample", &["volume", "vec3f"], "f32"),
            ("lookup", &["tf", "f32"], "vec4f"),
            ("lookup", &["tf", "vec2f"], "vec4f"),
            ("dims", &["volume"], "vec3u"),
        ];
        for &(name, args, want) in table {
            assert_eq!(call(name, args), Ok(t(want)), "{name}{args:?}");
        }
    }

    #[test]
    fn builtins_rejected() {
        let table: &[(&str, &[&str])] = &[
            ("abs", &["bool"]),
            ("abs", &["f32", "f32"]),
            ("sign", &["u32"]),
            ("min", &["f32", "i32"]),
            ("max", &["mat2x2f", "mat2x2f"]),
            ("clamp", &["f32", "i32", "f32"]),
            ("mix", &["f32", "f32", "vec3f"]),
            ("mix", &["vec3i", "vec3i", "vec3i"]),
            ("step", &["i32", "i32"]),
            ("smoothstep", &["f32", "f32"]),
            ("sqrt", &["i32"]),
            ("sin", &[]),
            ("pow", &["f32", "vec2f"]),
            ("dot", &["vec3f", "vec4f"]),
            ("dot", &["f32", "f32"]),
            ("dot", &["vec3<bool>", "vec3<bool>"]),
            ("cross", &["vec4f", "vec4f"]),
            ("length", &["i32"]),
            ("distance", &["vec3f", "vec2f"]),
            ("normalize", &["f32"]),
            ("reflect", &["f32", "f32"]),
            ("faceForward", &["vec3f", "vec3f"]),
            ("transpose", &["vec3f"]),
            ("determinant", &["mat2x3f"]),
            ("select", &["f32", "i32", "bool"]),
            ("select", &["vec2f", "vec2f", "vec3<bool>"]),
            ("select", &["f32", "f32", "vec3<bool>"]),
            ("select", &["volume", "volume", "bool"]),
            ("any", &["vec3f"]),
            ("sample", &["tf", "vec3f"]),
            ("lookup", &["tf", "vec3f"]),
            ("lookup", &["tf", "vec2i"]),
            ("dims", &["tf"]),
        ];
        for &(name, args) in table {
            let result = call(name, args);
            assert!(matches!(&result, Err(m) if m.contains(name)), "{name}{args:?}: {result:?}");
        }
    }

    #[test]
    fn builtin_messages() {
        assert_eq!(
            call("dot", &["vec3f", "vec4f"]),
            Err("`dot` takes two vectors of the same type; found vec3f and vec4f".to_string())
        );
        assert_eq!(
            call("clamp", &["f32", "i32", "f32"]),
            Err("`clamp(e, low, high)` takes three values of the same float or integer type; found f32, i32, f32"
                .to_string())
        );
        assert!(matches!(call("sin", &[]), Err(m) if m.ends_with("found no arguments")));
    }

    fn ctor(target: &str, args: &[&str]) -> Result<ConstructorKind, String> {
        let args: Vec<Type> = args.iter().map(|a| t(a)).collect();
        constructor(t(target), &args)
    }

    #[test]
    fn constructors() {
        use ConstructorKind::*;
        let ok: &[(&str, &[&str], ConstructorKind)] = &[
            ("f32", &[], Construct),
            ("mat3x3f", &[], Construct),
            ("f32", &["i32"], Convert),
            ("u32", &["bool"], Convert),
            ("i32", &["i32"], Convert),
            ("vec3f", &["f32"], Construct),
            ("vec3f", &["vec3i"], Convert),
            ("vec3f", &["vec3f"], Convert),
            ("vec4f", &["vec3f", "f32"], Construct),
            ("vec4f", &["vec2f", "vec2f"], Construct),
            ("vec4f", &["f32", "vec2f", "f32"], Construct),
            ("vec2u", &["u32", "u32"], Construct),
            ("mat3x3f", &["vec3f", "vec3f", "vec3f"], Construct),
            ("mat3x3f", &["f32"; 9], Construct),
            ("mat2x3f", &["vec3f", "vec3f"], Construct),
            ("mat2x2f", &["mat2x2f"], Convert),
        ];
        for &(target, args, want) in ok {
            assert_eq!(ctor(target, args), Ok(want), "{target}{args:?}");
        }
        let rejected: &[(&str, &[&str])] = &[
            ("f32", &["vec2f"]),
            ("f32", &["f32", "f32"]),
            ("vec4f", &["vec2f"]),
            ("vec3f", &["i32"]),
            ("vec4f", &["vec3f", "i32"]),
            ("vec3f", &["vec2f", "vec2f"]),
            ("vec2f", &["mat2x2f"]),
            ("mat3x3f", &["vec3f", "vec3f"]),
            ("mat3x3f", &["f32"; 8]),
            ("mat2x2f", &["vec2f", "f32", "f32"]),
            ("mat2x2f", &["mat3x3f"]),
            ("volume", &[]),
            ("tf", &["tf"]),
        ];
        for &(target, args) in rejected {
            let result = ctor(target, args);
            assert!(matches!(&result, Err(m) if m.contains(target)), "{target}{args:?}: {result:?}");
        }
    }
}
