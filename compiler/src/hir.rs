//! The checked program: names resolved, every expression typed, constants folded.
//!
//! The checker builds it from the AST; lowering (and the composer) consume it. Pipeline-function
//! names, state fields and uniforms keep their `$` here: a template is instantiated by the
//! composer, which substitutes names, never by re-checking.
//!
//! A function body never names another function by its [`LibFnId`]: a call names one of the
//! calling function's call sites (`calls`), and only that table holds ids. Bodies are therefore
//! the same in every program that holds the function (the standard library's are checked once
//! per process and shared, [`Arc`]), and renumbering a program's functions touches only the
//! tables.

use std::sync::Arc;

use crate::ast::{AssignOp, BinaryOp, PlacementKind, UnaryOp};
use crate::source::Span;
use crate::types::{Scalar, Type};

/// Index into [`Program::lib_fns`].
pub type LibFnId = usize;
/// Index into a function's `locals`.
pub type LocalId = usize;

/// Every checked function of the modules given to the checker (and of the modules they import).
#[derive(Clone, Debug, Default)]
pub struct Program {
    /// In dependency order: a function's callees come before it.
    pub lib_fns: Vec<LibFn>,
    /// In module order, then source order.
    pub pipelines: Vec<PipelineFn>,
    /// `remove` items, in the same order.
    pub removes: Vec<Remove>,
}

/// A checked library function.
#[derive(Clone, Debug)]
pub struct LibFn {
    /// The name it is declared and called by.
    pub name: String,
    /// Index of the module (in the loader's graph) that defines it.
    pub module: usize,
    /// Its `///` documentation, without the slashes (`None` when it has none).
    pub doc: Option<String>,
    /// Its parameters, in declaration order; [`ExprKind::Param`] indexes this list.
    pub params: Vec<Param>,
    /// `Type::Void` when it returns nothing.
    pub ret: Type,
    /// Every `let`, `var` and `for` variable of the body; [`LocalId`]s index this list.
    pub locals: Vec<Local>,
    /// The checked body (shared: the standard library's bodies are checked once per process).
    pub body: Arc<Block>,
    /// The callee of each call site of the body ([`ExprKind::CallLib::site`]).
    pub calls: Vec<LibFnId>,
    /// The whole `lib fn` item in the source.
    pub span: Span,
}

/// A parameter of a checked library function.
#[derive(Clone, Debug)]
pub struct Param {
    /// The parameter's name as declared.
    pub name: String,
    /// Its declared type (`volume` and `tf` included).
    pub ty: Type,
    /// The parameter's name in the source.
    pub span: Span,
}

/// A `let`, `var` or `for` variable.
#[derive(Clone, Debug)]
pub struct Local {
    /// The variable's name as declared (names may shadow: several locals can share one).
    pub name: String,
    /// Its declared type, or the type of its initialiser when none is declared.
    pub ty: Type,
    /// `var` and loop variables are mutable... loop variables only by the loop itself.
    pub mutable: bool,
    /// The variable's name in its declaration.
    pub span: Span,
}

/// A checked pipeline function: its placement, declarations and body.
#[derive(Clone, Debug)]
pub struct PipelineFn {
    /// The name as written, `$` kept in a template (the composer substitutes it per instance).
    pub name: String,
    /// Index of the module (in the loader's graph) that defines it.
    pub module: usize,
    /// Its `///` documentation, without the slashes (`None` when it has none).
    pub doc: Option<String>,
    /// Where in the pipeline it runs: its header's step path.
    pub placement: Placement,
    /// The declared state fields, in declaration order; `Expr::State` indexes this list.
    pub state: Vec<StateDecl>,
    /// The declared uniforms, in declaration order; `Expr::Uniform` indexes this list.
    pub uniforms: Vec<UniformDecl>,
    /// The declared library functions.
    pub uses: Vec<LibFnId>,
    /// Every `let`, `var` and `for` variable of the body; [`LocalId`]s index this list.
    pub locals: Vec<Local>,
    /// The checked body (shared: the standard library's bodies are checked once per process).
    pub body: Arc<Block>,
    /// The callee of each call site of the body ([`ExprKind::CallLib::site`]).
    pub calls: Vec<LibFnId>,
    /// The whole `pipeline` item in the source.
    pub span: Span,
}

/// A checked step path.
#[derive(Clone, Debug)]
pub struct Placement {
    /// `in`, `before`, `after` or `replace`.
    pub kind: PlacementKind,
    /// A known step, resolved from a group name for `before`/`after` (see `steps`).
    pub step: crate::steps::Step,
    /// The substep name, possibly with `$`.
    pub substep: Option<String>,
    /// `when active`: the function is left out, silently, unless its target exists and holds a
    /// function (an instance with no such additional volume places nothing).
    pub when_active: bool,
    /// The step path of the header in the source.
    pub span: Span,
}

/// A checked `remove`: the step, and the substep for `remove S[x]`.
#[derive(Clone, Debug)]
pub struct Remove {
    /// Index of the module (in the loader's graph) that holds it.
    pub module: usize,
    /// The step removed from (the whole step when `substep` is `None`).
    pub step: crate::steps::Step,
    /// The substep removed, possibly with `$`.
    pub substep: Option<String>,
    /// `when active`: a missing target is no error; there is simply nothing to remove.
    pub when_active: bool,
    /// The whole `remove` item in the source.
    pub span: Span,
}

/// A `state` declaration of a pipeline function, with whether the body reads and writes it.
#[derive(Clone, Debug)]
pub struct StateDecl {
    /// The field's name, possibly with `$`.
    pub name: String,
    /// The field's declared type.
    pub ty: Type,
    /// `@ray`: lives for the whole ray instead of one sample.
    pub ray: bool,
    /// The folded `= value` of the declaration, if it has one.
    pub default: Option<ConstValue>,
    /// Whether the body reads `state.name`.
    pub read: bool,
    /// Whether the body writes `state.name` (assigns it or a component of it).
    pub written: bool,
    /// The first `state.name` of the body that reads it (for data-flow warnings).
    pub first_read: Option<Span>,
    /// The `state` declaration in the source.
    pub span: Span,
}

/// A `uniform` declaration of a pipeline function.
#[derive(Clone, Debug)]
pub struct UniformDecl {
    /// The uniform's name, possibly with `$`.
    pub name: String,
    /// The uniform's declared type (`volume` and `tf` included).
    pub ty: Type,
    /// The folded `= value` of the declaration, if it has one.
    pub default: Option<ConstValue>,
    /// Slider bounds, per component for vectors and matrices.
    pub range: Option<(ConstValue, ConstValue)>,
    /// Its `///` documentation, without the slashes (shown next to its slider).
    pub doc: Option<String>,
    /// The `uniform` declaration in the source.
    pub span: Span,
}

/// A compile-time value: a scalar, vector or matrix, components flattened column-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstValue {
    /// The value's type (a scalar, vector or matrix type).
    pub ty: Type,
    /// One entry for a scalar, one per component of a vector, columns one after another for a
    /// matrix.
    pub components: Vec<ScalarValue>,
}

impl ConstValue {
    /// The value as an index, when it is one integer (`i32` or `u32`); whether it is in range is
    /// the caller's question.
    pub(crate) fn as_index(&self) -> Option<i64> {
        match self.components.as_slice() {
            [ScalarValue::I32(i)] => Some(i64::from(*i)),
            [ScalarValue::U32(u)] => Some(i64::from(*u)),
            _ => None,
        }
    }
}

/// One component of a constant value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScalarValue {
    /// A `bool` component.
    Bool(bool),
    /// An `i32` component.
    I32(i32),
    /// A `u32` component.
    U32(u32),
    /// An `f32` component.
    F32(f32),
}

impl ScalarValue {
    /// The scalar type of the component.
    pub fn scalar(self) -> Scalar {
        match self {
            ScalarValue::Bool(_) => Scalar::Bool,
            ScalarValue::I32(_) => Scalar::I32,
            ScalarValue::U32(_) => Scalar::U32,
            ScalarValue::F32(_) => Scalar::F32,
        }
    }
}

/// Checked statements: a function body or a `{ ... }` of an `if`, `for` or block statement.
#[derive(Clone, Debug)]
pub struct Block {
    /// The statements, in source order (unreachable ones included: the checker only warns about
    /// them).
    pub stmts: Vec<Stmt>,
    /// From the `{` to the `}`.
    pub span: Span,
}

/// A checked statement with its span.
#[derive(Clone, Debug)]
pub struct Stmt {
    /// What the statement is.
    pub kind: StmtKind,
    /// The whole statement in the source.
    pub span: Span,
}

/// What a checked statement is.
#[derive(Clone, Debug)]
pub enum StmtKind {
    /// Initialises a local; `None` for `var x: T;` (zero value).
    Let {
        /// The variable it declares.
        local: LocalId,
        /// Its initialiser, of the local's type.
        value: Option<Expr>,
    },
    /// `place op= value`; for compound ops the value has the place's type (or a scalar that
    /// WGSL's vector-scalar rules accept).
    Assign {
        /// What is assigned to.
        place: Place,
        /// `=`, or the compound operator (`+=`, ...).
        op: AssignOp,
        /// The assigned value (the right-hand operand of a compound assignment).
        value: Expr,
    },
    /// `if cond { then } else { otherwise }`; an `else if` is an `otherwise` block holding one
    /// `If`.
    If {
        /// The condition, a `bool`.
        cond: Expr,
        /// Runs when the condition holds.
        then: Block,
        /// Runs otherwise, when there is an `else`.
        otherwise: Option<Block>,
    },
    /// `for var in start .. end` over i32 or u32.
    For {
        /// The loop variable (immutable to the body).
        var: LocalId,
        /// The first value of the variable.
        start: Expr,
        /// The bound the variable stays below (exclusive), of the variable's type.
        end: Expr,
        /// Runs once per value.
        body: Block,
    },
    /// `break`: leaves the innermost `for`.
    Break,
    /// `continue`: goes on with the next value of the innermost `for`.
    Continue,
    /// `return`, with the function's result unless it returns nothing.
    Return(Option<Expr>),
    /// A call whose value (if any) is dropped.
    Expr(Expr),
    /// A nested `{ ... }`: its locals end with it.
    Block(Block),
}

/// Something assignable: a local or state field, then component/swizzle/index accesses.
#[derive(Clone, Debug)]
pub struct Place {
    /// The variable or state field the place starts from.
    pub root: PlaceRoot,
    /// The accesses below the root, outermost first (`v.x` is `[Component(0)]`); empty for the
    /// whole root.
    pub path: Vec<Access>,
    /// The type of the whole place.
    pub ty: Type,
    /// The place as written (left of the `=`).
    pub span: Span,
}

/// What an assignment or a reference starts from: a local or a state field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaceRoot {
    /// A variable of the function.
    Local(LocalId),
    /// Index into the pipeline function's `state`.
    State(usize),
}

/// One step of an access path below a place root.
#[derive(Clone, Debug)]
pub enum Access {
    /// `.x`, `.g`: one vector component.
    Component(u8),
    /// `.xz`: several distinct components, in order (only at the end of a path).
    Swizzle(Vec<u8>),
    /// `[i]` of a vector or matrix column.
    Index(Box<Expr>),
}

/// A checked expression with its type and span.
#[derive(Clone, Debug)]
pub struct Expr {
    /// What the expression is.
    pub kind: ExprKind,
    /// Its type; `Type::Error` for an expression the checker rejected (never in a function that
    /// reaches the [`Program`]).
    pub ty: Type,
    /// The expression in the source.
    pub span: Span,
}

impl Expr {
    /// The value of a constant integer index, if the expression is one.
    pub(crate) fn const_index(&self) -> Option<i64> {
        match &self.kind {
            ExprKind::Const(v) => v.as_index(),
            _ => None,
        }
    }
}

/// What a checked expression is.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// A literal or a folded constant.
    Const(ConstValue),
    /// Reads a `let`, `var` or loop variable of the function.
    Local(LocalId),
    /// Reads a parameter: index into the library function's `params`.
    Param(usize),
    /// Index into the pipeline function's `uniforms`.
    Uniform(usize),
    /// Index into the pipeline function's `state`.
    State(usize),
    /// A call of a library function (the callee is found through the call site).
    CallLib {
        /// Index into the calling function's `calls`.
        site: usize,
        /// The arguments, one per parameter, of the parameters' types.
        args: Vec<Expr>,
    },
    /// A call of a built-in function.
    CallBuiltin {
        /// Which built-in.
        builtin: Builtin,
        /// The arguments, as many as [`Builtin::arity`].
        args: Vec<Expr>,
    },
    /// A type constructor: `vec4f(rgb, 1.0)`, `vec3f(0.5)` (splat), `mat3x3f(...)`, `f32()`.
    /// The constructed type is the expression's type.
    Construct {
        /// The arguments: none (zero value), one (splat) or pieces filling the components.
        args: Vec<Expr>,
    },
    /// `f32(i)`, `vec3f(v_int)`: a conversion of a value of the same shape.
    Convert {
        /// The converted value; the target type is the expression's type.
        arg: Box<Expr>,
    },
    /// `-x`, `!b`.
    Unary {
        /// The operator.
        op: UnaryOp,
        /// Its operand.
        operand: Box<Expr>,
    },
    /// Operand types follow WGSL: equal types, or vector-scalar mixing, or matrix products.
    Binary {
        /// The operator.
        op: BinaryOp,
        /// The left operand.
        lhs: Box<Expr>,
        /// The right operand.
        rhs: Box<Expr>,
    },
    /// `.xyz`: components of a vector (one component gives a scalar).
    Swizzle {
        /// The vector.
        base: Box<Expr>,
        /// The components taken, in order (`x`/`r` is 0).
        components: Vec<u8>,
    },
    /// `v[i]`, `m[i]`.
    Index {
        /// The vector or matrix indexed.
        base: Box<Expr>,
        /// The index, an `i32` or `u32`.
        index: Box<Expr>,
    },
}

/// Declares [`Builtin`] from one table of variants, VRS names and argument counts, so that the
/// enum, its list, its names and its arities cannot drift apart.
macro_rules! builtins {
    ($($(#[$doc:meta])* $variant:ident = $name:literal / $arity:literal,)*) => {
        /// The built-in functions (`docs/language.md`, "Built-in functions"): WGSL's, with their
        /// overloads, and three for resources.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Builtin {
            $($(#[$doc])* $variant,)*
        }

        impl Builtin {
            /// Every built-in with the name it is called by in VRS, in declaration order.
            pub const ALL: &[(Builtin, &str)] = &[$((Builtin::$variant, $name),)*];

            /// The name the built-in is called by in VRS.
            pub fn name(self) -> &'static str {
                match self {
                    $(Builtin::$variant => $name,)*
                }
            }

            /// How many arguments the built-in takes (WGSL's overloads of each have one count).
            pub fn arity(self) -> usize {
                match self {
                    $(Builtin::$variant => $arity,)*
                }
            }

            /// The built-in called `name`, if any.
            pub fn by_name(name: &str) -> Option<Builtin> {
                match name {
                    $($name => Some(Builtin::$variant),)*
                    _ => None,
                }
            }
        }
    };
}

builtins! {
    /// `abs(x)`: the absolute value, per component.
    Abs = "abs" / 1,
    /// `min(a, b)`: the smaller value, per component.
    Min = "min" / 2,
    /// `max(a, b)`: the larger value, per component.
    Max = "max" / 2,
    /// `clamp(x, lo, hi)`: `x` limited to `lo ..= hi`, per component.
    Clamp = "clamp" / 3,
    /// `mix(a, b, t)`: linear interpolation, `a * (1 - t) + b * t`.
    Mix = "mix" / 3,
    /// `step(edge, x)`: 1.0 where `x >= edge`, else 0.0.
    Step = "step" / 2,
    /// `smoothstep(lo, hi, x)`: a smooth Hermite step from 0.0 at `lo` to 1.0 at `hi`.
    Smoothstep = "smoothstep" / 3,
    /// `sign(x)`: -1, 0 or 1 by the sign of `x`, per component.
    Sign = "sign" / 1,
    /// `floor(x)`: rounds down to a whole number.
    Floor = "floor" / 1,
    /// `ceil(x)`: rounds up to a whole number.
    Ceil = "ceil" / 1,
    /// `fract(x)`: `x - floor(x)`, the fractional part.
    Fract = "fract" / 1,
    /// `round(x)`: the nearest whole number, halves to even.
    Round = "round" / 1,
    /// `trunc(x)`: rounds towards zero.
    Trunc = "trunc" / 1,
    /// `sqrt(x)`: the square root.
    Sqrt = "sqrt" / 1,
    /// `inverseSqrt(x)`: `1 / sqrt(x)`.
    InverseSqrt = "inverseSqrt" / 1,
    /// `pow(x, y)`: `x` to the power `y`.
    Pow = "pow" / 2,
    /// `exp(x)`: e to the power `x`.
    Exp = "exp" / 1,
    /// `exp2(x)`: 2 to the power `x`.
    Exp2 = "exp2" / 1,
    /// `log(x)`: the natural logarithm.
    Log = "log" / 1,
    /// `log2(x)`: the base-2 logarithm.
    Log2 = "log2" / 1,
    /// `sin(x)`: the sine of an angle in radians.
    Sin = "sin" / 1,
    /// `cos(x)`: the cosine of an angle in radians.
    Cos = "cos" / 1,
    /// `tan(x)`: the tangent of an angle in radians.
    Tan = "tan" / 1,
    /// `asin(x)`: the arc sine, in radians.
    Asin = "asin" / 1,
    /// `acos(x)`: the arc cosine, in radians.
    Acos = "acos" / 1,
    /// `atan(x)`: the arc tangent, in radians.
    Atan = "atan" / 1,
    /// `atan2(y, x)`: the angle of the point `(x, y)`, in radians.
    Atan2 = "atan2" / 2,
    /// `dot(a, b)`: the dot product of two vectors.
    Dot = "dot" / 2,
    /// `cross(a, b)`: the cross product of two `vec3`s.
    Cross = "cross" / 2,
    /// `length(v)`: the Euclidean length of a vector.
    Length = "length" / 1,
    /// `distance(a, b)`: `length(a - b)`.
    Distance = "distance" / 2,
    /// `normalize(v)`: the vector scaled to length 1.
    Normalize = "normalize" / 1,
    /// `reflect(i, n)`: the direction `i` reflected at the surface of normal `n`.
    Reflect = "reflect" / 2,
    /// `faceForward(n, i, r)`: `n` when `dot(r, i) < 0`, else `-n`.
    FaceForward = "faceForward" / 3,
    /// `transpose(m)`: the transposed matrix.
    Transpose = "transpose" / 1,
    /// `determinant(m)`: the determinant of a square matrix.
    Determinant = "determinant" / 1,
    /// `select(f, t, cond)`: `t` where `cond` holds, else `f` (per component for a vector `cond`).
    Select = "select" / 3,
    /// `any(b)`: whether any component of a boolean vector holds.
    Any = "any" / 1,
    /// `all(b)`: whether every component of a boolean vector holds.
    All = "all" / 1,
    /// `sample(v: volume, p: vec3f) -> f32`
    Sample = "sample" / 2,
    /// `lookup(t: tf, x: f32) -> vec4f`
    Lookup = "lookup" / 2,
    /// `dims(v: volume) -> vec3u`, `dims(i: image) -> vec2u`
    Dims = "dims" / 1,
    /// `load(i: image, p: vec2i) -> vec4f`: the texel at pixel `p`, clamped to the image's edge
    Load = "load" / 2,
}

/// A constant as VRS source: `1.0`, `vec3f(0.5, 0.5, 0.5)`.
pub(crate) fn show_const(v: &ConstValue) -> String {
    let parts: Vec<String> = v
        .components
        .iter()
        .map(|c| match c {
            ScalarValue::Bool(b) => b.to_string(),
            ScalarValue::I32(i) => i.to_string(),
            ScalarValue::U32(u) => format!("{u}u"),
            ScalarValue::F32(x) => format!("{x:?}"),
        })
        .collect();
    match v.ty {
        Type::Scalar(_) => parts.join(", "),
        _ => format!("{}({})", v.ty, parts.join(", ")),
    }
}
