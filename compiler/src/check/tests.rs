//! Unit tests of the checker: each rule on a small source, asserting the code and the line.

use super::check_program;
use crate::diag::{Code, Diagnostics};
use crate::hir::{self, ScalarValue};
use crate::loader::Loader;
use crate::source::SourceMap;
use crate::types::Type;

struct Checked {
    program: hir::Program,
    /// (code, line, message) of every diagnostic, in report order.
    diags: Vec<(Code, usize, String)>,
}

impl Checked {
    fn codes(&self) -> Vec<(Code, usize)> {
        self.diags.iter().map(|d| (d.0, d.1)).collect()
    }

    fn message(&self, code: Code) -> &str {
        self.diags.iter().find(|d| d.0 == code).map_or("", |d| d.2.as_str())
    }
}

/// Lexes, parses, loads and checks one module given as text.
fn check(src: &str) -> Checked {
    check_many(&[src])
}

/// Several root modules, checked together (module order = order given).
fn check_many(srcs: &[&str]) -> Checked {
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let graph = {
        let mut loader = Loader::new(&mut sources, &mut diags);
        for (i, src) in srcs.iter().enumerate() {
            loader.load_root_source(&format!("m{i}.vrs"), src.to_string(), None);
        }
        loader.finish()
    };
    let program = check_program(&graph, &sources, &mut diags);
    let diags = diags
        .iter()
        .map(|d| {
            let line = sources.position(d.span.start).map_or(0, |(_, p)| p.line);
            let mut text = d.message.clone();
            for n in &d.notes {
                text.push_str(" | ");
                text.push_str(n);
            }
            (d.code, line, text)
        })
        .collect();
    Checked { program, diags }
}

/// Asserts exactly these diagnostics (code and line), in any order.
#[track_caller]
fn expect(src: &str, want: &[(Code, usize)]) -> Checked {
    let c = check(src);
    let mut got = c.codes();
    got.sort();
    let mut want = want.to_vec();
    want.sort();
    assert_eq!(got, want, "diagnostics: {:#?}", c.diags);
    c
}

#[track_caller]
fn ok(src: &str) -> Checked {
    expect(src, &[])
}

// ---- literals ----

#[test]
fn literals_take_the_expected_type() {
    let c = ok(
        "lib fn f() -> f32 {\n let a: u32 = 7;\n let b: f32 = 3;\n let c = 2;\n var d: f32 = 0.0;\n d += 1;\n return b + f32(a) + f32(c) + d;\n}",
    );
    let f = &c.program.lib_fns[0];
    assert_eq!(f.locals.iter().map(|l| l.ty).collect::<Vec<_>>(), [Type::U32, Type::F32, Type::I32, Type::F32]);
}

#[test]
fn literal_adopts_other_operand_and_constructor_scalar() {
    ok(
        "lib fn f(x: f32, u: u32) -> vec3f {\n let a = x * 2;\n let b = 1 + x;\n let c = u + 1;\n let m = max(x, 0);\n return vec3f(1, 2, a + b + f32(c) + m);\n}",
    );
}

#[test]
fn float_literal_never_becomes_an_integer() {
    expect("lib fn f() -> i32 {\n let a: i32 = 1.5;\n return a;\n}", &[(Code::TypeMismatch, 2)]);
}

#[test]
fn integer_literal_out_of_range() {
    expect("lib fn f() -> i32 {\n let a: i32 = 3000000000;\n return a;\n}", &[(Code::LiteralOutOfRange, 2)]);
    expect("lib fn f() -> u32 {\n let a: u32 = -1;\n return a;\n}", &[(Code::LiteralOutOfRange, 2)]);
    ok("lib fn f() -> i32 {\n let a: i32 = -2147483648;\n let b = -2147483648i;\n return a - b;\n}");
    // Both `let`s are constants in the emitted WGSL, which rejects their overflowing sum.
    expect(
        "lib fn f() -> i32 {\n let a: i32 = -2147483648;\n let b = -2147483648i;\n return a + b;\n}",
        &[(Code::ConstEvalFailed, 4)],
    );
}

// ---- names and scopes ----

#[test]
fn duplicate_items_and_locals() {
    expect("const A: f32 = 1.0;\nconst A: f32 = 2.0;", &[(Code::Duplicate, 2)]);
    expect("lib fn f() {}\nlib fn f() {}", &[(Code::Duplicate, 2)]);
    expect("lib fn f() {\n let x = 1;\n let x = 2;\n}", &[(Code::Duplicate, 3)]);
    expect("lib fn f(x: f32) {\n let x = 1.0;\n}", &[(Code::Duplicate, 2)]);
    ok("lib fn f(x: f32) -> f32 {\n if x > 0.0 {\n let x = 2.0;\n return x;\n }\n return x;\n}");
}

#[test]
fn unknown_type_suggests() {
    let c = expect("lib fn f(x: vec3d) {}", &[(Code::UnknownType, 1)]);
    assert!(c.message(Code::UnknownType).contains("`vec3f`"), "{:?}", c.diags);
    let c = expect("lib fn f(x: vec3) {}", &[(Code::UnknownType, 1)]);
    assert!(c.message(Code::UnknownType).contains("`vec3<f32>`"), "{:?}", c.diags);
    ok("lib fn f(x: vec3<f32>, m: mat3x3<f32>) -> vec3f {\n return m * x;\n}");
}

#[test]
fn unknown_name_in_lib_fn() {
    let c = expect("lib fn f(value: f32) -> f32 {\n return valeu;\n}", &[(Code::UnknownName, 2)]);
    assert!(c.message(Code::UnknownName).contains("`value`"), "{:?}", c.diags);
}

#[test]
fn lib_fn_cannot_see_uniforms() {
    let c = expect(
        "pipeline p in start {\n uniform gain: f32;\n state value: f32;\n state.value = gain;\n}\nlib fn f() -> f32 {\n return gain;\n}",
        &[(Code::UnknownName, 7)],
    );
    assert!(c.message(Code::UnknownName).contains("parameter"), "{:?}", c.diags);
}

#[test]
fn unknown_name_in_pipeline_offers_uniform() {
    let c = expect(
        "pipeline tint in start {\n state color: vec4f;\n state.color = state.color * tint_color;\n}",
        &[(Code::UndeclaredUniform, 3)],
    );
    assert!(c.message(Code::UndeclaredUniform).contains("`uniform tint_color: vec4f;`"), "{:?}", c.diags);
}

#[test]
fn unknown_function_suggests() {
    let c = expect("lib fn f(x: f32) -> f32 {\n return sqr(x);\n}", &[(Code::UnknownFunction, 2)]);
    assert!(c.message(Code::UnknownFunction).contains("sqrt"), "{:?}", c.diags);
}

#[test]
fn imports_bring_lib_fns_and_consts() {
    let dir = std::env::temp_dir().join(format!("vrsc-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("a.vrs"), "const K: f32 = 2.0;\nlib fn twice(x: f32) -> f32 { return x * K; }\n").unwrap();
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let graph = {
        let mut loader = Loader::new(&mut sources, &mut diags);
        let src = "import \"a.vrs\";\nlib fn g(x: f32) -> f32 { return twice(x) + K; }\nlib fn twice(x: f32) -> f32 { return x; }\n";
        loader.load_root_source("main.vrs", src.to_string(), Some(&dir));
        loader.finish()
    };
    let program = check_program(&graph, &sources, &mut diags);
    let codes: Vec<(Code, usize)> =
        diags.iter().map(|d| (d.code, sources.position(d.span.start).map_or(0, |(_, p)| p.line))).collect();
    assert_eq!(codes, [(Code::Duplicate, 3)]);
    // The imported `twice` is kept (its module is fine); the clashing local one is not, nor is
    // `g`, which calls it (local names win).
    let kept: Vec<(&str, usize)> = program.lib_fns.iter().map(|f| (f.name.as_str(), f.module)).collect();
    assert_eq!(kept, [("twice", 1)]);
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- expressions ----

#[test]
fn operators_report_both_types() {
    let c = expect("lib fn f(a: f32, b: i32) -> f32 {\n return a + b;\n}", &[(Code::InvalidOperands, 2)]);
    let m = c.message(Code::InvalidOperands);
    assert!(m.contains("f32") && m.contains("i32"), "{m}");
}

#[test]
fn builtin_argument_count_and_overloads() {
    expect("lib fn f(x: f32) -> f32 {\n return clamp(x, 0.0);\n}", &[(Code::ArgumentCount, 2)]);
    expect("lib fn f(x: bool) -> f32 {\n return sqrt(x);\n}", &[(Code::NoOverload, 2)]);
    ok("lib fn f(x: vec3f, y: vec3f) -> f32 {\n return dot(x, y) + length(cross(x, y)) + clamp(x.x, 0, 1);\n}");
}

#[test]
fn lib_call_arguments() {
    expect(
        "lib fn add(a: f32, b: f32) -> f32 { return a + b; }\nlib fn f() -> f32 {\n return add(1.0);\n}",
        &[(Code::ArgumentCount, 3)],
    );
    expect(
        "lib fn add(a: f32, b: f32) -> f32 { return a + b; }\nlib fn f() -> f32 {\n return add(1.0, vec2f(1.0));\n}",
        &[(Code::TypeMismatch, 3)],
    );
    ok("lib fn add(a: f32, b: f32) -> f32 { return a + b; }\nlib fn f() -> f32 {\n return add(1, 2);\n}");
}

#[test]
fn constructors() {
    expect("lib fn f() -> vec3f {\n return vec3f(1.0, 2.0);\n}", &[(Code::InvalidConstructor, 2)]);
    ok("lib fn f(v: vec3i) -> vec4f {\n let a = vec3f(v);\n return vec4f(a, 1);\n}");
}

#[test]
fn swizzles() {
    let c = expect("lib fn f(v: vec3f) -> vec4f {\n return v.xyzw;\n}", &[(Code::InvalidMember, 2)]);
    assert_eq!(c.message(Code::InvalidMember), "`v.xyzw`: vec3f has no component `w`");
    expect("lib fn f(v: vec4f) -> vec2f {\n return v.xg;\n}", &[(Code::InvalidMember, 2)]);
    expect("lib fn f(m: mat3x3f) -> f32 {\n return m.x;\n}", &[(Code::InvalidMember, 2)]);
    expect("lib fn f(s: f32) -> f32 {\n return s.x;\n}", &[(Code::InvalidMember, 2)]);
    ok("lib fn f(v: vec4f) -> vec3f {\n return v.bgr + v.zyx + vec3f(v.a);\n}");
}

#[test]
fn indexing() {
    ok("lib fn f(v: vec3f, m: mat3x3f, i: u32) -> f32 {\n return v[0] + v[i] + m[2].y + m[1][1];\n}");
    expect("lib fn f(v: vec3f) -> f32 {\n return v[3];\n}", &[(Code::IndexOutOfBounds, 2)]);
    expect("lib fn f(v: vec3f) -> f32 {\n return v[1 + 2];\n}", &[(Code::IndexOutOfBounds, 2)]);
    expect("lib fn f(m: mat2x2f) -> vec2f {\n let i = 2u;\n return m[i];\n}", &[(Code::IndexOutOfBounds, 3)]);
    expect("lib fn f(v: vec3f) -> f32 {\n return v[1.0];\n}", &[(Code::InvalidIndex, 2)]);
    expect("lib fn f(s: f32) -> f32 {\n return s[0];\n}", &[(Code::InvalidIndex, 2)]);
}

#[test]
fn void_call_as_value() {
    expect("lib fn g() {}\nlib fn f() -> f32 {\n let x = g();\n return 1.0;\n}", &[(Code::TypeMismatch, 3)]);
}

#[test]
fn deep_expressions_are_cut_off() {
    let terms = vec!["x"; 100_000].join(" + ");
    let src = format!("lib fn f(x: f32) -> f32 {{\n return {terms};\n}}");
    // The parser itself may recurse; give the test a big stack like the CLI's main thread.
    let c =
        std::thread::Builder::new().stack_size(256 << 20).spawn(move || check(&src).codes()).unwrap().join().unwrap();
    assert_eq!(c.iter().filter(|d| d.0 == Code::TooDeep).count(), 1, "{c:?}");
}

#[test]
fn moderately_deep_expression_is_fine() {
    let terms = vec!["x"; 256].join(" + ");
    ok(&format!("lib fn f(x: f32) -> f32 {{\n return {terms};\n}}"));
}

// ---- statements ----

#[test]
fn let_and_params_are_immutable() {
    expect("lib fn f(x: f32) -> f32 {\n let y = x;\n y = 2.0;\n return y;\n}", &[(Code::NotAssignable, 3)]);
    expect("lib fn f(x: f32) -> f32 {\n x = 2.0;\n return x;\n}", &[(Code::NotAssignable, 2)]);
    expect("lib fn f() {\n for i in 0 .. 4 {\n i = 2;\n }\n}", &[(Code::NotAssignable, 3)]);
    ok("lib fn f(x: f32) -> f32 {\n var y = x;\n y = 2.0;\n y *= 3.0;\n return y;\n}");
}

#[test]
fn assignment_types() {
    expect("lib fn f() {\n var y: f32 = 0.0;\n y = vec2f(1.0);\n}", &[(Code::TypeMismatch, 3)]);
    expect("lib fn f() {\n var y: f32 = 0.0;\n y += 1u;\n}", &[(Code::InvalidOperands, 3)]);
    ok("lib fn f() {\n var v = vec3f(0.0);\n v *= 2.0;\n v.x = 1.0;\n v.zy = vec2f(1.0);\n v[1] = 3.0;\n}");
    expect("lib fn f() {\n var v = vec3f(0.0);\n v.xx = vec2f(1.0);\n}", &[(Code::NotAssignable, 3)]);
}

#[test]
fn conditions_and_ranges() {
    expect("lib fn f(x: f32) {\n if x {\n }\n}", &[(Code::ConditionNotBool, 2)]);
    expect("lib fn f(n: u32) {\n for i in 0i .. n {\n }\n}", &[(Code::RangeNotInteger, 2)]);
    expect("lib fn f() {\n for i in 0.0 .. 2.0 {\n }\n}", &[(Code::RangeNotInteger, 2)]);
    ok("lib fn f(n: u32) -> u32 {\n var s = 0u;\n for i in 0 .. n {\n s += i;\n }\n return s;\n}");
}

#[test]
fn break_outside_loop() {
    expect("lib fn f() {\n break;\n}", &[(Code::BreakOutsideLoop, 2)]);
    expect("pipeline p in start {\n continue;\n}", &[(Code::BreakOutsideLoop, 2)]);
}

#[test]
fn return_rules() {
    expect("pipeline p in start {\n state value: f32;\n return state.value;\n}", &[(Code::ReturnMismatch, 3)]);
    expect("lib fn f() -> f32 {\n return;\n}", &[(Code::ReturnMismatch, 2)]);
    expect("lib fn f() {\n return 1.0;\n}", &[(Code::ReturnMismatch, 2)]);
    expect("lib fn f() -> f32 {\n return vec2f(1.0);\n}", &[(Code::TypeMismatch, 2)]);
    ok("pipeline p in start {\n state value: f32;\n if state.value > 0.5 {\n return;\n }\n state.value = 1.0;\n}");
}

#[test]
fn missing_return() {
    expect("lib fn f(x: f32) -> f32 {\n if x > 0.0 {\n return 1.0;\n }\n}", &[(Code::MissingReturn, 1)]);
    expect("lib fn f(n: i32) -> f32 {\n for i in 0 .. n {\n return 1.0;\n }\n}", &[(Code::MissingReturn, 1)]);
    ok("lib fn f(x: f32) -> f32 {\n if x > 0.0 {\n return 1.0;\n } else {\n return 2.0;\n }\n}");
    ok("lib fn f(x: f32) -> f32 {\n {\n return x;\n }\n}");
}

#[test]
fn unreachable_code_warns() {
    let c = expect("lib fn f(x: f32) -> f32 {\n return x;\n let y = 1.0;\n}", &[(Code::UnreachableCode, 3)]);
    assert_eq!(c.program.lib_fns.len(), 1, "a warning does not drop the function");
    expect("lib fn f() {\n for i in 0 .. 3 {\n break;\n continue;\n }\n}", &[(Code::UnreachableCode, 4)]);
}

#[test]
fn expression_statement_must_be_a_call() {
    expect("lib fn g() {}\nlib fn f() {\n g();\n}", &[]);
}

// ---- library functions ----

#[test]
fn lib_reads_state() {
    expect("lib fn bad(x: f32) -> f32 {\n return x + state.value;\n}", &[(Code::ImpureLibrary, 2)]);
}

#[test]
fn resources_only_as_params_and_uniforms() {
    ok("lib fn g(v: volume, t: tf, p: vec3f) -> vec4f {\n return lookup(t, sample(v, p));\n}");
    expect("lib fn g(v: volume) -> volume {\n return v;\n}", &[(Code::ResourceMisuse, 1)]);
    expect("lib fn g(v: volume) {\n let w = v;\n}", &[(Code::ResourceMisuse, 2)]);
    expect("pipeline keep in start {\n state v: volume;\n}", &[(Code::ResourceMisuse, 2)]);
    expect(
        "pipeline p in start {\n uniform v: volume = 1.0;\n state value: f32;\n state.value = sample(v, vec3f(0.5));\n}",
        &[(Code::ResourceMisuse, 2)],
    );
}

#[test]
fn recursion_is_reported_once() {
    let c = expect(
        "lib fn even(n: i32) -> bool {\n if n == 0 { return true; }\n return odd(n - 1);\n}\nlib fn odd(n: i32) -> bool {\n if n == 0 { return false; }\n return even(n - 1);\n}\nlib fn ok(n: i32) -> i32 { return n; }",
        &[(Code::Recursion, 7)],
    );
    assert_eq!(c.program.lib_fns.iter().map(|f| f.name.as_str()).collect::<Vec<_>>(), ["ok"]);
    expect("lib fn f(n: i32) -> i32 {\n return f(n);\n}", &[(Code::Recursion, 2)]);
}

#[test]
fn lib_fns_are_in_callee_order_with_renumbered_call_sites() {
    let c = ok(
        "lib fn a(x: f32) -> f32 { return b(x) + c(x); }\nlib fn b(x: f32) -> f32 { return c(x); }\nlib fn c(x: f32) -> f32 { return x; }",
    );
    let names: Vec<&str> = c.program.lib_fns.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["c", "b", "a"]);
    let a = &c.program.lib_fns[2];
    assert_eq!(a.calls, [1, 0], "a calls b (now #1), then c (now #0)");
    assert_eq!(c.program.lib_fns[1].calls, [0]);
    let hir::StmtKind::Return(Some(e)) = &a.body.stmts[0].kind else { panic!() };
    let hir::ExprKind::Binary { lhs, rhs, .. } = &e.kind else { panic!() };
    assert!(matches!(lhs.kind, hir::ExprKind::CallLib { site: 0, .. }));
    assert!(matches!(rhs.kind, hir::ExprKind::CallLib { site: 1, .. }));
}

#[test]
fn callers_of_broken_functions_are_left_out() {
    let c = expect(
        "lib fn bad(x: f32) -> f32 {\n return x + nope;\n}\nlib fn user(x: f32) -> f32 { return bad(x); }\nlib fn fine(x: f32) -> f32 { return x; }",
        &[(Code::UnknownName, 2)],
    );
    assert_eq!(c.program.lib_fns.iter().map(|f| f.name.as_str()).collect::<Vec<_>>(), ["fine"]);
}

// ---- pipeline functions ----

#[test]
fn undeclared_state_offers_declaration() {
    let c = expect(
        "pipeline shade in shading.tone {\n state color: vec4f;\n let n = normalize(state.gradient);\n state.color = vec4f(n, 1.0);\n}",
        &[(Code::UndeclaredState, 3)],
    );
    assert!(c.message(Code::UndeclaredState).contains("`state gradient: vec3f;`"), "{:?}", c.diags);
    let c = expect("pipeline p in ray.finish {\n state.accum = vec4f(0.0);\n}", &[(Code::UndeclaredState, 2)]);
    assert!(c.message(Code::UndeclaredState).contains("`@ray state accum: vec4f;`"), "{:?}", c.diags);
}

#[test]
fn undeclared_and_unknown_library() {
    let c = expect(
        "lib fn brighten(c: vec4f) -> vec4f { return c * 1.5; }\npipeline glow in shading.tone {\n state color: vec4f;\n state.color = brighten(state.color);\n}",
        &[(Code::UndeclaredLibrary, 4)],
    );
    assert!(c.message(Code::UndeclaredLibrary).contains("`use brighten;`"), "{:?}", c.diags);
    expect(
        "pipeline p in start {\n use nothing;\n state value: f32;\n state.value = 1.0;\n}",
        &[(Code::UnknownLibrary, 2)],
    );
    // A lib fn calling another needs no `use`.
    ok("lib fn a(x: f32) -> f32 { return x; }\nlib fn b(x: f32) -> f32 { return a(x); }");
}

#[test]
fn unused_declarations_warn() {
    expect(
        "lib fn helper(x: f32) -> f32 { return x; }\npipeline p in start {\n state value: f32;\n state other: f32;\n uniform u: f32;\n use helper;\n state.value = 1.0;\n}",
        &[(Code::UnusedState, 4), (Code::UnusedUniform, 5), (Code::UnusedUse, 6)],
    );
}

#[test]
fn state_read_and_written_are_recorded() {
    let c = ok(
        "pipeline p in start {\n state a: f32;\n state b: f32;\n state c: vec4f;\n state.b = state.a;\n state.c.a += 1.0;\n}",
    );
    let s = &c.program.pipelines[0].state;
    assert_eq!((s[0].read, s[0].written), (true, false));
    assert_eq!((s[1].read, s[1].written), (false, true));
    assert_eq!((s[2].read, s[2].written), (true, true));
}

#[test]
fn uniforms_defaults_and_ranges() {
    let c = ok(
        "pipeline p in start {\n uniform clip: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;\n uniform n: i32 = 3 in 0 .. 10;\n state value: f32;\n state.value = clip.x + f32(n);\n}",
    );
    let u = &c.program.pipelines[0].uniforms;
    assert_eq!(u[0].default.as_ref().unwrap().components[3], ScalarValue::F32(-0.5));
    let (lo, hi) = u[0].range.as_ref().unwrap();
    assert_eq!(
        (lo.ty, lo.components.len(), hi.components[2]),
        (Type::vec(4, crate::types::Scalar::F32), 4, ScalarValue::F32(1.0))
    );
    assert_eq!(u[1].range.as_ref().unwrap().1.components, [ScalarValue::I32(10)]);
    expect(
        "pipeline p in start {\n state value: f32 = vec2f(1.0);\n state.value = 1.0;\n}",
        &[(Code::TypeMismatch, 2)],
    );
    expect(
        "pipeline p in start {\n uniform g: f32;\n state value: f32 = g;\n state.value = g;\n}",
        &[(Code::UnknownName, 3)],
    );
    // Built-ins of constants are constant expressions, as in WGSL.
    ok("pipeline p in start {\n state value: f32 = sqrt(2.0);\n state.value = 1.0;\n}");
}

#[test]
fn consts_any_order_and_cycles() {
    let c = ok("const B: f32 = A * 2.0;\nconst A: f32 = 1.5;\nlib fn f() -> f32 { return B; }");
    let hir::StmtKind::Return(Some(e)) = &c.program.lib_fns[0].body.stmts[0].kind else { panic!() };
    assert!(matches!(&e.kind, hir::ExprKind::Const(v) if v.components == [ScalarValue::F32(3.0)]));
    expect("const A: f32 = B;\nconst B: f32 = A;", &[(Code::NotConstant, 2)]);
    expect("const A: i32 = 2147483647 + 1;", &[(Code::ConstEvalFailed, 1)]);
    expect("const A: i32 = 1 / 0;", &[(Code::DivisionByZero, 1)]);
    expect("const A: volume = 1;", &[(Code::ResourceMisuse, 1)]);
}

#[test]
fn declaration_conflicts_across_functions() {
    let both = "pipeline a in start {\n state w: f32 = 0.0;\n state.w = 1.0;\n}\npipeline b in end {\n";
    expect(&format!("{both} state w: vec2f;\n state.w = vec2f(1.0);\n}}"), &[(Code::StateConflict, 6)]);
    expect(&format!("{both} state w: f32 = 1.0;\n state.w = 2.0;\n}}"), &[(Code::DefaultConflict, 6)]);
    expect(&format!("{both} @ray state w: f32;\n state.w = 2.0;\n}}"), &[(Code::StateConflict, 6)]);
    ok(&format!("{both} state w: f32 = 0.0;\n state.w = 2.0;\n}}"));
    let u = "pipeline a in start {\n uniform g: f32 = 1.0;\n state value: f32;\n state.value = g;\n}\npipeline b in end {\n";
    expect(
        &format!("{u} uniform g: i32;\n state value: f32;\n state.value = f32(g);\n}}"),
        &[(Code::UniformConflict, 7)],
    );
    expect(
        &format!("{u} uniform g: f32 = 2.0;\n state value: f32;\n state.value = g;\n}}"),
        &[(Code::DefaultConflict, 7)],
    );
}

#[test]
fn conflicts_across_modules_point_at_the_later_module() {
    let a = "pipeline a in start {\n state w: f32;\n state.w = 1.0;\n}";
    let b = "\n\npipeline b in end {\n state w: i32;\n state.w = 1;\n}";
    let c = check_many(&[a, b]);
    assert_eq!(c.codes(), [(Code::StateConflict, 4)]);
    assert_eq!(c.program.pipelines.len(), 1);
}

#[test]
fn placements() {
    let c = ok(
        "pipeline a before compositing {\n state value: f32;\n state.value = 1.0;\n}\npipeline b after compositing {\n state value: f32;\n state.value = 1.0;\n}\nremove shading.tone;\nremove classification.additional[$];",
    );
    use crate::steps::Step;
    assert_eq!(c.program.pipelines[0].placement.step, Step::CompositingPrimaryColor);
    assert_eq!(c.program.pipelines[1].placement.step, Step::CompositingAdditional);
    assert_eq!(c.program.removes[1].substep.as_deref(), Some("$"));
    let c = expect(
        "pipeline p after shadingg.lights {\n state value: f32;\n state.value = 1.0;\n}",
        &[(Code::UnknownStep, 1)],
    );
    assert!(c.message(Code::UnknownStep).contains("shading.lights"), "{:?}", c.diags);
    expect("pipeline p in compositing {\n state value: f32;\n state.value = 1.0;\n}", &[(Code::GroupNotAllowed, 1)]);
    expect("\nremove shading;", &[(Code::GroupNotAllowed, 2)]);
}

#[test]
fn template_names_are_kept() {
    let c = ok(
        "lib fn d(p: vec4f, q: vec3f) -> f32 { return dot(p.xyz, q) + p.w; }\npipeline clip_$ after classification.additional[$] when active {\n uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;\n state pos: vec3f;\n state color_$: vec4f;\n use d;\n if d(clip_plane_$, state.pos) < 0.0 {\n state.color_$ = vec4f(0.0);\n }\n}",
    );
    let p = &c.program.pipelines[0];
    assert_eq!((p.name.as_str(), p.placement.substep.as_deref()), ("clip_$", Some("$")));
    assert_eq!(p.uses, [0]);
}

#[test]
fn duplicate_declarations_in_a_header() {
    expect("pipeline p in start {\n state v: f32;\n state v: f32;\n state.v = 1.0;\n}", &[(Code::Duplicate, 3)]);
    expect(
        "pipeline p in start {\n uniform u: f32;\n uniform u: f32;\n state v: f32;\n state.v = u;\n}",
        &[(Code::Duplicate, 3)],
    );
    // Two pipeline functions of one name clash only in one step: the composer decides.
    let c = ok(
        "pipeline p in start {\n uniform u: f32;\n state v: f32;\n state.v = u;\n}\npipeline p in end {\n uniform u: f32;\n state v: f32;\n state.v = u;\n}",
    );
    assert_eq!(c.program.pipelines.len(), 2);
}

#[test]
fn failed_pipelines_are_left_out() {
    let c = expect(
        "pipeline good in start {\n state value: f32;\n state.value = 1.0;\n}\npipeline bad in start {\n state value: f32;\n state.value = nope;\n}",
        &[(Code::UndeclaredUniform, 7)],
    );
    assert_eq!(c.program.pipelines.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["good"]);
}

#[test]
fn names_after_a_dropped_statement_are_not_reported_again() {
    let c = check("lib fn two(x: f32) -> f32 {\n let y = (x * 2.0;\n return y;\n}");
    assert_eq!(c.codes(), [(Code::Syntax, 2)]);
    assert!(c.program.lib_fns.is_empty());
}

#[test]
fn long_chains_of_constants_do_not_overflow() {
    // Each constant refers to the next one, so evaluating the first nests through all of them.
    let src: String = (0..2000).map(|i| format!("const C{i}: f32 = C{}  + 1.0;\n", i + 1)).collect::<String>()
        + "const C2000: f32 = 0.0;\n";
    let c = check(&src);
    assert_eq!(c.codes().iter().filter(|d| d.0 == Code::TooDeep).count(), 1, "{:?}", c.codes());
    // In source order they are fine.
    let src: String = "const C0: f32 = 0.0;\n".to_string()
        + &(1..2000).map(|i| format!("const C{i}: f32 = C{} + 1.0;\n", i - 1)).collect::<String>();
    ok(&src);
}

#[test]
fn a_missing_declaration_is_reported_once() {
    expect(
        "lib fn g(x: f32) -> f32 { return x; }\npipeline p in start {\n state value: f32;\n state.value = g(tint) + g(tint);\n state.q = state.q + tint;\n}",
        &[(Code::UndeclaredLibrary, 4), (Code::UndeclaredUniform, 4), (Code::UndeclaredState, 5)],
    );
}

#[test]
fn the_standard_library_checks_cleanly_once() {
    assert!(super::std_cache::std_checked().is_some(), "the standard library must check without a diagnostic");
}

/// The functions copied from the standard library checked once are exactly those checking the
/// graph in full gives, whatever else the graph holds and in whatever order it loads them.
#[test]
fn reused_standard_modules_equal_checking_them_again() {
    let user = "import std::shading;\nlib fn twice(x: f32) -> f32 { return 2.0 * x; }\n\
                pipeline bright in shading.tone { state color: vec4f = vec4f(0.0); \
                @ray state ray_dir: vec3f = vec3f(0.0, 0.0, 1.0); use twice, surface_normal; \
                let n = surface_normal(vec3f(twice(0.5)), -state.ray_dir); \
                state.color = vec4f(state.color.rgb * n.x, state.color.a); }";
    for name in crate::stdlib::names() {
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let graph = {
            let mut loader = Loader::new(&mut sources, &mut diags);
            loader.load_root_source("user.vrs", user.to_string(), None);
            loader.load_root_std(name).expect("a standard module");
            loader.finish()
        };
        assert!(diags.is_empty(), "std::{name}: {:?}", diags.iter().map(|d| &d.message).collect::<Vec<_>>());
        let reused = super::check_graph(&graph, &sources, &mut diags, super::std_cache::std_checked());
        let again = super::check_graph(&graph, &sources, &mut diags, None);
        assert_eq!(format!("{reused:?}"), format!("{again:?}"), "std::{name}");
        assert!(diags.is_empty(), "std::{name}: {:?}", diags.iter().map(|d| &d.message).collect::<Vec<_>>());
    }
}

#[test]
fn shader_creation_rules_in_bodies() {
    let lib = |body: &str| format!("lib fn f(x: i32, u: u32, y: f32, v: vec2i) -> f32 {{\n {body}\n return y;\n}}");
    expect(&lib("let a = x / 0;"), &[(Code::DivisionByZero, 2)]);
    expect(&lib("let a = x % 0;"), &[(Code::DivisionByZero, 2)]);
    expect(&lib("let a = v / vec2i(x, 0);"), &[(Code::DivisionByZero, 2)]);
    expect(&lib("let z = 0;\n let a = x / z;"), &[(Code::DivisionByZero, 3)]);
    expect(&lib("var a = x;\n a /= 0;"), &[(Code::DivisionByZero, 3)]);
    expect(&lib("let a = u << 40u;"), &[(Code::ShiftTooLarge, 2)]);
    expect(&lib("let a = v >> vec2u(1u, 32u);"), &[(Code::ShiftTooLarge, 2)]);
    expect(&lib("let a = 1e999999;"), &[(Code::LiteralOutOfRange, 2)]);
    expect(&lib("let a = -1e999999;"), &[(Code::LiteralOutOfRange, 2)]);
    expect(&lib("let a = y * (3e38 * 10.0);"), &[(Code::ConstEvalFailed, 2)]);
    expect(&lib("let a = x + (2147483647 + 1);"), &[(Code::ConstEvalFailed, 2)]);
    expect(&lib("let a = y / (1.0 / 0.0);"), &[(Code::DivisionByZero, 2)]);
    expect(&lib("let a = y + sqrt(-1.0);"), &[(Code::MathDomain, 2)]);
    expect(&lib("let a = clamp(y, 1.0, 0.0);"), &[(Code::MathDomain, 2)]);
    expect(&lib("let a = y + exp(100.0);"), &[(Code::ConstEvalFailed, 2)]);
    // Known only at run time: WGSL allows these.
    ok(&lib("let a = y / 0.0;\n let b = x / (x - x);\n let c = u << (u + 40u);"));
    ok(&lib("let a = clamp(y, 0.0, 1.0) + sqrt(2.0);\n let b = x / 2;"));
}

#[test]
fn folded_constants_reach_the_hir() {
    let checked = ok("lib fn f() -> f32 {\n return 2.0 * 3.0 + sqrt(4.0);\n}");
    let body = &checked.program.lib_fns[0].body;
    let hir::StmtKind::Return(Some(e)) = &body.stmts[0].kind else { panic!("a return: {body:?}") };
    assert!(matches!(&e.kind, hir::ExprKind::Const(v) if v.components == [ScalarValue::F32(8.0)]), "{e:?}");
}

#[test]
fn a_var_needs_a_type_or_a_value() {
    let c = expect("lib fn f() -> f32 {\n    var x;\n    x = 1.0;\n    return x;\n}\n", &[(Code::Syntax, 2)]);
    assert!(c.message(Code::Syntax).contains("needs a type or a value"));
    ok("lib fn f() -> f32 {\n    var x: f32;\n    var y = 2.0;\n    x = y;\n    return x;\n}\n");
}
