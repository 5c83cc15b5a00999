//! The syntax tree the parser builds. Nothing here is resolved or typed yet (see `hir` for the
//! checked form).
//!
//! Public face: the node types, from [`Module`] (one parsed file) down to [`Expr`], all plain data
//! with public fields, which the checker, the loader and the language server read. Every span is
//! a half-open range of global byte offsets (see [`crate::source`]); unless a field says
//! otherwise, a node's span runs from its first token to its last one, closing `;`, `}` or `)`
//! included, and leaves out the doc comment before it.

use crate::lexer::IntSuffix;
use crate::source::{FileId, Span};

/// A name as written, possibly with the template wildcard `$`.
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    /// The name exactly as written (`$` included in a template name).
    pub name: String,
    /// The name's token.
    pub span: Span,
}

impl Ident {
    /// Whether the name holds the template wildcard `$`.
    pub fn is_template(&self) -> bool {
        self.name.contains('$')
    }
}

/// One parsed file.
#[derive(Clone, Debug)]
pub struct Module {
    /// The file in the [`SourceMap`](crate::source::SourceMap) it was parsed from.
    pub file: FileId,
    /// Its items in source order; an item the parser could not make sense of is left out (its
    /// error is reported).
    pub items: Vec<Item>,
}

/// A top-level item with its doc comment and span.
#[derive(Clone, Debug)]
pub struct Item {
    /// Which item it is, with its parts.
    pub kind: ItemKind,
    /// The `///` doc comment before the item, lines joined with `\n`.
    pub doc: Option<String>,
    /// From the item's keyword (`import`, `const`, `lib`, `pipeline`, `remove`) to its closing
    /// `;` or `}`; the doc comment is not part of it.
    pub span: Span,
}

/// What an item is.
#[derive(Clone, Debug)]
pub enum ItemKind {
    /// `import "path.vrs";` or `import std::NAME;`.
    Import(Import),
    /// `const NAME: T = e;`.
    Const(ConstItem),
    /// `lib fn NAME(params) -> T { body }`: a function pipeline functions can call.
    LibFn(LibFn),
    /// `pipeline NAME PLACEMENT { ... }`: code placed into a pipeline step.
    Pipeline(PipelineFn),
    /// `remove STEP_PATH;`: takes the code of a step (or substep) out of the pipeline.
    Remove(Remove),
}

/// The target of an `import`: a file path or a standard module.
#[derive(Clone, Debug)]
pub enum Import {
    /// `import "path.vrs";`, relative to the importing file. The string is unescaped.
    Path {
        /// The path as written between the quotes, escapes resolved.
        path: String,
        /// The string literal, quotes included.
        span: Span,
    },
    /// `import std::shading;`
    Std {
        /// The segments after `std::` (`["shading"]`), each with its span.
        path: Vec<Ident>,
    },
}

/// `const NAME: T = e;` (the type may be left out).
#[derive(Clone, Debug)]
pub struct ConstItem {
    /// The constant's name.
    pub name: Ident,
    /// The type after `:`; `None` when left out (the checker infers it from the value).
    pub ty: Option<TypeExpr>,
    /// The expression after `=`.
    pub value: Expr,
}

/// `lib fn NAME(params) -> T { body }` (no return type means it returns nothing).
#[derive(Clone, Debug)]
pub struct LibFn {
    /// The function's name.
    pub name: Ident,
    /// The parameters in order.
    pub params: Vec<Param>,
    /// The type after `->`; `None` for a function that returns nothing.
    pub ret: Option<TypeExpr>,
    /// The body, braces included in its span.
    pub body: Block,
}

/// A parameter of a library function: `NAME: TYPE`.
#[derive(Clone, Debug)]
pub struct Param {
    /// The parameter's name.
    pub name: Ident,
    /// Its declared type.
    pub ty: TypeExpr,
    /// From the name to the end of the type (no comma).
    pub span: Span,
}

/// `pipeline NAME PLACEMENT { decls stmts }`
#[derive(Clone, Debug)]
pub struct PipelineFn {
    /// The pipeline function's name.
    pub name: Ident,
    /// Where it goes: `in`, `before`, `after` or `replace` a step or substep.
    pub placement: Placement,
    /// The `state`, `uniform` and `use` declarations at the top of the body, in order.
    pub decls: Vec<Decl>,
    /// The statements after the declarations. Its span is the whole `{ ... }`, declarations
    /// included.
    pub body: Block,
}

/// `remove STEP_PATH;` (optionally `when active`).
#[derive(Clone, Debug)]
pub struct Remove {
    /// The step or substep removed.
    pub target: StepPath,
    /// Whether `when active` follows the path.
    pub when_active: bool,
}

/// How a pipeline function is placed relative to its target step or substep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlacementKind {
    /// `in`: runs as part of the target.
    In,
    /// `before`: runs just before the target.
    Before,
    /// `after`: runs just after the target.
    After,
    /// `replace`: runs instead of the target's own code.
    Replace,
}

/// `in|before|after|replace STEP[SUBSTEP] [when active]`.
#[derive(Clone, Debug)]
pub struct Placement {
    /// The keyword: `in`, `before`, `after` or `replace`.
    pub kind: PlacementKind,
    /// The step or substep it refers to.
    pub target: StepPath,
    /// Whether `when active` follows the path.
    pub when_active: bool,
    /// From the keyword to the end of the path, or of `when active` when present.
    pub span: Span,
}

/// `shading.lights`, `classification.additional[gm]`, `compositing`.
#[derive(Clone, Debug)]
pub struct StepPath {
    /// Dotted segments: `["shading", "lights"]`, or one for a group name alone.
    pub segments: Vec<Ident>,
    /// The substep in brackets.
    pub substep: Option<Ident>,
    /// From the first segment to the last one, or to the `]` of the substep.
    pub span: Span,
}

impl StepPath {
    /// The dotted step name without the substep: `shading.lights`.
    pub fn step_name(&self) -> String {
        self.segments.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(".")
    }
}

/// A declaration in the header of a pipeline function.
#[derive(Clone, Debug)]
pub struct Decl {
    /// Which declaration it is, with its parts.
    pub kind: DeclKind,
    /// The `///` doc comment before the declaration, lines joined with `\n`.
    pub doc: Option<String>,
    /// From its attribute (`@ray`) or keyword to its `;`.
    pub span: Span,
}

/// A declaration at the top of a pipeline function's body.
#[derive(Clone, Debug)]
pub enum DeclKind {
    /// `@ray? state NAME: T (= e)?;`
    State {
        /// Whether it is marked `@ray`: it lives for the whole ray instead of one sample.
        ray: bool,
        /// The field's name, as read through `state.NAME`.
        name: Ident,
        /// Its type.
        ty: TypeExpr,
        /// The initial value after `=`, if any.
        default: Option<Expr>,
    },
    /// `uniform NAME: T (= e)? (in lo .. hi)?;`
    Uniform {
        /// The uniform's name.
        name: Ident,
        /// Its type.
        ty: TypeExpr,
        /// The default value after `=`, if any.
        default: Option<Expr>,
        /// The bounds after `in`: `lo` and `hi` of `lo .. hi`.
        range: Option<(Expr, Expr)>,
    },
    /// `use a, b;`
    Use {
        /// The names listed, in order.
        names: Vec<Ident>,
    },
}

/// A type as written: `f32`, `vec3f`, `vec3<f32>`, `mat4x4<f32>`, `volume`.
#[derive(Clone, Debug, PartialEq)]
pub struct TypeExpr {
    /// The type's name: `vec3` in `vec3<f32>`, `vec3f` in `vec3f`.
    pub name: Ident,
    /// Template arguments: `vec3<f32>` has one.
    pub args: Vec<TypeExpr>,
    /// From the name to the closing `>` (the name alone without arguments).
    pub span: Span,
}

/// `{ statements }`.
#[derive(Clone, Debug)]
pub struct Block {
    /// The statements in order.
    pub stmts: Vec<Stmt>,
    /// From `{` to `}`, both included.
    pub span: Span,
}

/// A statement with its span.
#[derive(Clone, Debug)]
pub struct Stmt {
    /// Which statement it is, with its parts.
    pub kind: StmtKind,
    /// The whole statement, its `;` or closing `}` included.
    pub span: Span,
}

/// `=`, `+=`, `-=`, `*=`, `/=`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AssignOp {
    /// `=`: plain assignment.
    Assign,
    /// `+=`.
    Add,
    /// `-=`.
    Sub,
    /// `*=`.
    Mul,
    /// `/=`.
    Div,
}

/// What a statement is.
#[derive(Clone, Debug)]
pub enum StmtKind {
    /// `let x (: T)? = e;` (`mutable: false`) or `var x (: T)? (= e)?;` (`mutable: true`).
    Let {
        /// `true` for `var`, `false` for `let`.
        mutable: bool,
        /// The name bound.
        name: Ident,
        /// The type after `:`; `None` when left out (inferred from the value).
        ty: Option<TypeExpr>,
        /// The initial value after `=`; only a `var` may leave it out.
        value: Option<Expr>,
    },
    /// `target op e;`: the target is a name, `state.f`, or field/swizzle/index access on one.
    Assign {
        /// What is assigned to (left of the operator).
        target: Expr,
        /// `=` or a compound operator.
        op: AssignOp,
        /// The right-hand side.
        value: Expr,
    },
    /// `if c { } else ...`: an `else if` is an `else` block holding one `If` statement.
    If {
        /// The condition.
        cond: Expr,
        /// The block run when it holds.
        then: Block,
        /// The `else` block, if any.
        otherwise: Option<Block>,
    },
    /// `for i in a .. b { }`
    For {
        /// The loop variable.
        var: Ident,
        /// The first value (`a`, included).
        start: Expr,
        /// The bound (`b`, excluded).
        end: Expr,
        /// The loop body.
        body: Block,
    },
    /// `break;`
    Break,
    /// `continue;`
    Continue,
    /// `return;` or `return e;`.
    Return(Option<Expr>),
    /// A call as a statement.
    Expr(Expr),
    /// A nested `{ }` block.
    Block(Block),
    /// What the parser skipped while recovering from a reported error.
    Error,
}

/// `-` and `!`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    /// `-x`: arithmetic negation.
    Neg,
    /// `!x`: logical not.
    Not,
}

/// The binary operators, WGSL's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    /// `*`.
    Mul,
    /// `/`.
    Div,
    /// `%`: remainder.
    Rem,
    /// `+`.
    Add,
    /// `-`.
    Sub,
    /// `<<`: shift left.
    Shl,
    /// `>>`: shift right.
    Shr,
    /// `<`.
    Lt,
    /// `<=`.
    Le,
    /// `>`.
    Gt,
    /// `>=`.
    Ge,
    /// `==`.
    Eq,
    /// `!=`.
    Ne,
    /// `&`: bitwise (or non-short-circuit boolean) and.
    BitAnd,
    /// `^`: bitwise exclusive or.
    BitXor,
    /// `|`: bitwise (or non-short-circuit boolean) or.
    BitOr,
    /// `&&`: short-circuit logical and.
    And,
    /// `||`: short-circuit logical or.
    Or,
}

impl BinaryOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        use BinaryOp::*;
        match self {
            Mul => "*",
            Div => "/",
            Rem => "%",
            Add => "+",
            Sub => "-",
            Shl => "<<",
            Shr => ">>",
            Lt => "<",
            Le => "<=",
            Gt => ">",
            Ge => ">=",
            Eq => "==",
            Ne => "!=",
            BitAnd => "&",
            BitXor => "^",
            BitOr => "|",
            And => "&&",
            Or => "||",
        }
    }
}

/// An expression with its span.
#[derive(Clone, Debug)]
pub struct Expr {
    /// Which expression it is, with its parts.
    pub kind: ExprKind,
    /// The whole expression; a parenthesized one includes its parentheses.
    pub span: Span,
}

/// What an expression is.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// An integer literal; `None` when it did not fit in 64 bits (already reported).
    Int {
        /// The value of the digits; `None` when it does not fit in 64 bits.
        value: Option<u64>,
        /// `i`, `u`, or none (the type then comes from context).
        suffix: Option<IntSuffix>,
    },
    /// A float literal; `suffixed` for an explicit `f`.
    Float {
        /// The literal's value.
        value: f64,
        /// Whether it ends in `f`.
        suffixed: bool,
    },
    /// `true` or `false`.
    Bool(bool),
    /// A plain name: local, parameter, constant or uniform.
    Name(Ident),
    /// `state.field`
    State(Ident),
    /// `base.member`: a swizzle or vector component.
    Member {
        /// The expression before the `.`.
        base: Box<Expr>,
        /// The name after the `.` (`xyz`, `x`).
        member: Ident,
    },
    /// `base[index]`
    Index {
        /// The expression indexed.
        base: Box<Expr>,
        /// The expression in brackets.
        index: Box<Expr>,
    },
    /// A call or type constructor: `f(a)`, `vec3f(x)`, `vec3<f32>(x)`.
    Call {
        /// The function or type name called.
        callee: Ident,
        /// Template arguments between `<` and `>` (`f32` in `vec3<f32>(x)`); usually empty.
        generics: Vec<TypeExpr>,
        /// The arguments in order.
        args: Vec<Expr>,
    },
    /// `-x` or `!x`.
    Unary {
        /// The operator.
        op: UnaryOp,
        /// The expression it applies to.
        operand: Box<Expr>,
    },
    /// `a OP b`, grouped by WGSL's precedence.
    Binary {
        /// The operator.
        op: BinaryOp,
        /// The left operand.
        lhs: Box<Expr>,
        /// The right operand.
        rhs: Box<Expr>,
    },
    /// Input the parser or lexer already reported; checks skip it silently.
    Error,
}
