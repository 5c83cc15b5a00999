use super::depth::MAX_DEPTH;
use super::*;
use crate::ast::*;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::lexer::Token;
use crate::lexer::{IntSuffix, lex};
use chumsky::error::EmptyErr;

fn parse(src: &str) -> (Module, Vec<Diagnostic>) {
    let mut diags = Diagnostics::new();
    let lexed = lex(src, 0, &mut diags);
    let module = parse_module(&lexed, 0, src.len() as u32, &mut diags);
    (module, diags.iter().cloned().collect())
}

/// The tokens of `src` as the grammar takes them.
fn grammar_tokens(src: &str) -> Vec<(Token, SimpleSpan)> {
    let lexed = lex(src, 0, &mut Diagnostics::new());
    lexed.tokens.iter().map(|(t, s)| (t.clone(), SimpleSpan::from(s.start as usize..s.end as usize))).collect()
}

#[test]
fn the_fast_pass_builds_the_tree_the_reporting_pass_builds() {
    let snippets = [
        "const K: f32 = -(1.0 + 2.0) * 3.0;",
        "lib fn f(v: vec3<f32>, m: mat4x4f) -> f32 { var s = 0.0; for i in 0..3 { s += v[i]; } return s; }",
        "pipeline p before shading.lights[$] when active { state c: vec4f = vec4f(1.0); c = c.xyzw * 2.0; if c.x > 1.0 { return; } else if c.y < 0.0 { c.z = 0.0; } }",
        "remove shading.lights[key]; import \"a.vrs\"; import std::math;",
    ];
    let std = crate::stdlib::modules().map(|(_, src)| src);
    let broken = ["lib fn f( { }", "pipeline p after x { let a = ; }"];
    for src in snippets.into_iter().chain(std).chain(broken) {
        let tokens = grammar_tokens(src);
        let input = || tokens.as_slice().split_token_span(SimpleSpan::from(src.len()..src.len()));
        let fast = super::item::module::<_, EmptyErr>().parse(input());
        let full = super::item::module::<_, ParseError>().parse(input());
        let valid = !broken.contains(&src);
        assert_eq!((fast.has_errors(), full.has_errors()), (!valid, !valid), "validity of {src}");
        if valid {
            assert_eq!(format!("{:?}", fast.output()), format!("{:?}", full.output()), "the passes disagree on {src}");
        }
    }
}

/// Parses input that must have no diagnostics.
fn parse_ok(src: &str) -> Module {
    let (module, diags) = parse(src);
    assert!(diags.is_empty(), "unexpected diagnostics for {src:?}: {diags:#?}");
    module
}

fn line_of(src: &str, offset: u32) -> usize {
    src[..offset as usize].matches('\n').count() + 1
}

/// The lines and codes of the diagnostics.
fn errors(src: &str) -> Vec<(usize, Code)> {
    parse(src).1.iter().map(|d| (line_of(src, d.span.start), d.code)).collect()
}

/// S-expression form of an expression, for precedence tests.
fn show(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Int { value, suffix } => {
            let s = match suffix {
                Some(IntSuffix::I) => "i",
                Some(IntSuffix::U) => "u",
                None => "",
            };
            format!("{}{s}", value.map_or("?".to_string(), |v| v.to_string()))
        }
        ExprKind::Float { value, suffixed } => format!("{value:?}{}", if *suffixed { "f" } else { "" }),
        ExprKind::Bool(b) => b.to_string(),
        ExprKind::Name(n) => n.name.clone(),
        ExprKind::State(n) => format!("state.{}", n.name),
        ExprKind::Member { base, member } => format!("{}.{}", show(base), member.name),
        ExprKind::Index { base, index } => format!("{}[{}]", show(base), show(index)),
        ExprKind::Call { callee, generics, args } => {
            let g = if generics.is_empty() {
                String::new()
            } else {
                format!("<{}>", generics.iter().map(show_ty).collect::<Vec<_>>().join(", "))
            };
            format!("{}{g}({})", callee.name, args.iter().map(show).collect::<Vec<_>>().join(", "))
        }
        ExprKind::Unary { op, operand } => {
            format!("({} {})", if *op == UnaryOp::Neg { "-" } else { "!" }, show(operand))
        }
        ExprKind::Binary { op, lhs, rhs } => format!("({} {} {})", op.symbol(), show(lhs), show(rhs)),
        ExprKind::Error => "<error>".to_string(),
    }
}

fn show_ty(t: &TypeExpr) -> String {
    if t.args.is_empty() {
        t.name.name.clone()
    } else {
        format!("{}<{}>", t.name.name, t.args.iter().map(show_ty).collect::<Vec<_>>().join(", "))
    }
}

/// The statements of `lib fn f() { BODY }`.
fn body(src_body: &str) -> Vec<Stmt> {
    let src = format!("lib fn f() {{ {src_body} }}");
    let module = parse_ok(&src);
    match module.items.into_iter().next().map(|i| i.kind) {
        Some(ItemKind::LibFn(f)) => f.body.stmts,
        other => panic!("not a lib fn: {other:?}"),
    }
}

/// One expression, parsed as `let v = EXPR;`.
fn expr(text: &str) -> String {
    match body(&format!("let v = {text};")).into_iter().next().map(|s| s.kind) {
        Some(StmtKind::Let { value: Some(value), .. }) => show(&value),
        other => panic!("not a let: {other:?}"),
    }
}

fn pipeline(src: &str) -> PipelineFn {
    match parse_ok(src).items.into_iter().next().map(|i| i.kind) {
        Some(ItemKind::Pipeline(p)) => p,
        other => panic!("not a pipeline: {other:?}"),
    }
}

fn path_text(p: &StepPath) -> String {
    match &p.substep {
        Some(s) => format!("{}[{}]", p.step_name(), s.name),
        None => p.step_name(),
    }
}

// ---- Items ----

#[test]
fn imports() {
    let src = "import \"lib/geom.vrs\";\nimport std::shading;\nimport \"a\\\"b\\\\c\";";
    let m = parse_ok(src);
    assert_eq!(m.items.len(), 3);
    match &m.items[0].kind {
        ItemKind::Import(Import::Path { path, span }) => {
            assert_eq!(path, "lib/geom.vrs");
            assert_eq!(&src[span.start as usize..span.end as usize], "\"lib/geom.vrs\"");
        }
        other => panic!("{other:?}"),
    }
    match &m.items[1].kind {
        ItemKind::Import(Import::Std { path }) => {
            assert_eq!(path.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["shading"]);
        }
        other => panic!("{other:?}"),
    }
    match &m.items[2].kind {
        ItemKind::Import(Import::Path { path, .. }) => assert_eq!(path, "a\"b\\c"),
        other => panic!("{other:?}"),
    }
    assert_eq!(errors("import foo::bar;"), vec![(1, Code::Syntax)]);
    assert_eq!(errors("import std;"), vec![(1, Code::Syntax)]);
}

#[test]
fn consts() {
    let m = parse_ok("const PI: f32 = 3.5;\nconst N = 2 * 3;\nconst V: vec3<f32> = vec3<f32>(1.0);");
    let consts: Vec<&ConstItem> = m
        .items
        .iter()
        .map(|i| match &i.kind {
            ItemKind::Const(c) => c,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(consts[0].name.name, "PI");
    assert_eq!(consts[0].ty.as_ref().map(show_ty).as_deref(), Some("f32"));
    assert_eq!(show(&consts[0].value), "3.5");
    assert!(consts[1].ty.is_none());
    assert_eq!(show(&consts[1].value), "(* 2 3)");
    assert_eq!(consts[2].ty.as_ref().map(show_ty).as_deref(), Some("vec3<f32>"));
    assert_eq!(show(&consts[2].value), "vec3<f32>(1.0)");
}

#[test]
fn lib_functions() {
    let src = "/// Doc line one.\n/// Two.\nlib fn add(a: f32, b: vec3<f32>,) -> f32 { return a; }\nlib fn none() {}";
    let m = parse_ok(src);
    let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
    assert_eq!(m.items[0].doc.as_deref(), Some("Doc line one.\nTwo."));
    assert_eq!(f.name.name, "add");
    assert_eq!(f.params.len(), 2);
    assert_eq!(f.params[1].name.name, "b");
    assert_eq!(show_ty(&f.params[1].ty), "vec3<f32>");
    assert_eq!(&src[f.params[0].span.start as usize..f.params[0].span.end as usize], "a: f32");
    assert_eq!(f.ret.as_ref().map(show_ty).as_deref(), Some("f32"));
    assert_eq!(f.body.stmts.len(), 1);
    let item_text = &src[m.items[0].span.start as usize..m.items[0].span.end as usize];
    assert!(item_text.starts_with("lib fn add") && item_text.ends_with('}'));
    let ItemKind::LibFn(g) = &m.items[1].kind else { panic!() };
    assert!(g.params.is_empty() && g.ret.is_none() && g.body.stmts.is_empty());
    assert_eq!(m.items[1].doc, None);
}

#[test]
fn placements() {
    let cases = [
        ("in start", PlacementKind::In, "start", false),
        ("before shading.lights", PlacementKind::Before, "shading.lights", false),
        ("after classification.additional[$]", PlacementKind::After, "classification.additional[$]", false),
        (
            "replace compositing.primary_color[dvr] when active",
            PlacementKind::Replace,
            "compositing.primary_color[dvr]",
            true,
        ),
        ("after compositing when active", PlacementKind::After, "compositing", true),
        ("before ray.setup[gm]", PlacementKind::Before, "ray.setup[gm]", false),
        ("in sampling.additional when active", PlacementKind::In, "sampling.additional", true),
    ];
    for (text, kind, path, active) in cases {
        let src = format!("pipeline p_$ {text} {{}}");
        let p = pipeline(&src);
        assert_eq!(p.name.name, "p_$");
        assert_eq!(p.placement.kind, kind, "{text}");
        assert_eq!(path_text(&p.placement.target), path, "{text}");
        assert_eq!(p.placement.when_active, active, "{text}");
        assert_eq!(&src[p.placement.span.start as usize..p.placement.span.end as usize], text);
    }
}

#[test]
fn removes() {
    let m = parse_ok("remove shading.tone;\nremove classification.additional[gm] when active;\nremove start;");
    let removes: Vec<&Remove> = m
        .items
        .iter()
        .map(|i| match &i.kind {
            ItemKind::Remove(r) => r,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(path_text(&removes[0].target), "shading.tone");
    assert!(!removes[0].when_active);
    assert_eq!(path_text(&removes[1].target), "classification.additional[gm]");
    assert_eq!(removes[1].target.substep.as_ref().map(|s| s.name.as_str()), Some("gm"));
    assert!(removes[1].when_active);
    assert_eq!(removes[2].target.segments.len(), 1);
    assert_eq!(errors("remove shading.tone when;"), vec![(1, Code::Syntax)]);
}

#[test]
fn declarations_with_docs() {
    let src = "pipeline clip_$ after classification.additional[$] when active {
/// The clip plane.
/// (normal, offset)
uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;
uniform strength: f32;
state pos: vec3f;
/// Ray accumulator.
@ray state hits: u32 = 0u;
use plane_distance, other,;
state.pos = state.pos;
}";
    let p = pipeline(src);
    assert_eq!(p.decls.len(), 5);
    assert_eq!(p.decls[0].doc.as_deref(), Some("The clip plane.\n(normal, offset)"));
    match &p.decls[0].kind {
        DeclKind::Uniform { name, ty, default, range } => {
            assert_eq!(name.name, "clip_plane_$");
            assert_eq!(show_ty(ty), "vec4f");
            assert_eq!(default.as_ref().map(show).as_deref(), Some("vec4f(1.0, 0.0, 0.0, (- 0.5))"));
            let (lo, hi) = range.as_ref().expect("range");
            assert_eq!((show(lo), show(hi)), ("(- 1.0)".to_string(), "1.0".to_string()));
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(&p.decls[1].kind, DeclKind::Uniform { default: None, range: None, .. }));
    assert_eq!(p.decls[1].doc, None);
    assert!(matches!(&p.decls[2].kind, DeclKind::State { ray: false, default: None, .. }));
    match &p.decls[3].kind {
        DeclKind::State { ray, name, default, .. } => {
            assert!(*ray);
            assert_eq!(name.name, "hits");
            assert_eq!(default.as_ref().map(show).as_deref(), Some("0u"));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(p.decls[3].doc.as_deref(), Some("Ray accumulator."));
    assert!(src[p.decls[3].span.start as usize..].starts_with("@ray state hits"));
    match &p.decls[4].kind {
        DeclKind::Use { names } => {
            assert_eq!(names.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(), ["plane_distance", "other"])
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(p.body.stmts.len(), 1);
}

#[test]
fn declaration_after_statement_is_e0106() {
    let src = "pipeline p in start {\n    state a: f32;\n    state.a = 1.0;\n    uniform u: f32;\n    use f;\n}";
    let (m, diags) = parse(src);
    let codes: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
    assert_eq!(codes, vec![(4, Code::DeclarationAfterStatement), (5, Code::DeclarationAfterStatement)]);
    let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
    assert_eq!(p.decls.len(), 3, "still recorded");
    assert_eq!(p.body.stmts.len(), 1);
    assert_eq!(diags[0].secondary.len(), 1);
}

#[test]
fn attributes() {
    let src = "pipeline p in start {\n    @foo state a: f32;\n    @ray uniform u: f32;\n    @ray state b: f32;\n}";
    let (m, diags) = parse(src);
    let codes: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
    assert_eq!(codes, vec![(2, Code::UnknownAttribute), (3, Code::Syntax)]);
    assert!(diags[0].message.contains("@foo"));
    let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
    assert_eq!(p.decls.len(), 3);
    assert!(matches!(p.decls[0].kind, DeclKind::State { ray: false, .. }));
    assert!(matches!(p.decls[2].kind, DeclKind::State { ray: true, .. }));
}

// ---- Statements ----

#[test]
fn statements() {
    let stmts = body(
        "let a = 1; let b: f32 = 2.0; var c: i32; var d = 3;
         c = 1; c += 1; c -= 1; c *= 2; c /= 2; state.color.a = 0.0; v[0].x = 1.0;
         f(a, b,); { let e = 1; } ; return; return a + 1; break; continue;",
    );
    let kinds: Vec<String> = stmts
        .iter()
        .map(|s| match &s.kind {
            StmtKind::Let { mutable, name, ty, value } => format!(
                "{} {}{}{}",
                if *mutable { "var" } else { "let" },
                name.name,
                ty.as_ref().map(|t| format!(": {}", show_ty(t))).unwrap_or_default(),
                value.as_ref().map(|v| format!(" = {}", show(v))).unwrap_or_default()
            ),
            StmtKind::Assign { target, op, value } => format!("{} {op:?} {}", show(target), show(value)),
            StmtKind::Expr(e) => format!("expr {}", show(e)),
            StmtKind::Block(b) => format!("block {}", b.stmts.len()),
            StmtKind::Return(e) => format!("return {}", e.as_ref().map(show).unwrap_or_default()),
            StmtKind::Break => "break".into(),
            StmtKind::Continue => "continue".into(),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "let a = 1",
            "let b: f32 = 2.0",
            "var c: i32",
            "var d = 3",
            "c Assign 1",
            "c Add 1",
            "c Sub 1",
            "c Mul 2",
            "c Div 2",
            "state.color.a Assign 0.0",
            "v[0].x Assign 1.0",
            "expr f(a, b)",
            "block 1",
            "return ",
            "return (+ a 1)",
            "break",
            "continue",
        ]
    );
}

#[test]
fn if_else_chains() {
    let src = "lib fn f() { if a { x(); } else if (b) { y(); } else if c { } else { z(); } if d {} }";
    let m = parse_ok(src);
    let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
    assert_eq!(f.body.stmts.len(), 2);
    let StmtKind::If { cond, then, otherwise } = &f.body.stmts[0].kind else { panic!() };
    assert_eq!(show(cond), "a");
    assert_eq!(then.stmts.len(), 1);
    let otherwise = otherwise.as_ref().expect("else if");
    assert_eq!(otherwise.stmts.len(), 1);
    let elif = &otherwise.stmts[0];
    assert!(src[elif.span.start as usize..elif.span.end as usize].starts_with("if (b)"));
    assert!(src[elif.span.start as usize..elif.span.end as usize].ends_with("z(); }"));
    let StmtKind::If { cond, otherwise, .. } = &elif.kind else { panic!() };
    assert_eq!(show(cond), "b");
    let StmtKind::If { cond, otherwise, .. } = &otherwise.as_ref().expect("else if").stmts[0].kind else { panic!() };
    assert_eq!(show(cond), "c");
    assert_eq!(otherwise.as_ref().expect("else").stmts.len(), 1);
    let StmtKind::If { otherwise: None, .. } = &f.body.stmts[1].kind else { panic!() };
}

#[test]
fn for_loops() {
    let stmts = body("for i in 0..n { continue; } for j in a + 1 .. 2u { }");
    let StmtKind::For { var, start, end, body } = &stmts[0].kind else { panic!() };
    assert_eq!((var.name.as_str(), show(start), show(end)), ("i", "0".to_string(), "n".to_string()));
    assert_eq!(body.stmts.len(), 1);
    let StmtKind::For { start, end, .. } = &stmts[1].kind else { panic!() };
    assert_eq!((show(start), show(end)), ("(+ a 1)".to_string(), "2u".to_string()));
}

#[test]
fn non_call_expression_statement_is_an_error() {
    assert_eq!(errors("lib fn f() { x + 1; }"), vec![(1, Code::Syntax)]);
    assert_eq!(errors("lib fn f() { f(x); }"), vec![]);
}

// ---- Expressions ----

#[test]
fn precedence() {
    assert_eq!(expr("a + b * c"), "(+ a (* b c))");
    assert_eq!(expr("a * b + c"), "(+ (* a b) c)");
    assert_eq!(expr("a - b - c"), "(- (- a b) c)");
    assert_eq!(expr("a < b == c"), "(== (< a b) c)");
    assert_eq!(expr("a < b < c"), "(< (< a b) c)");
    assert_eq!(expr("-a.x"), "(- a.x)");
    assert_eq!(expr("!f(x)[0]"), "(! f(x)[0])");
    assert_eq!(expr("- -a * b"), "(* (- (- a)) b)");
    assert_eq!(
        expr("a || b && c | d ^ e & f == g < h << i + j * k"),
        "(|| a (&& b (| c (^ d (& e (== f (< g (<< h (+ i (* j k))))))))))"
    );
    assert_eq!(expr("a * b % c / d"), "(/ (% (* a b) c) d)");
    assert_eq!(expr("(a + b) * c"), "(* (+ a b) c)");
    assert_eq!(expr("a >> 1u != b"), "(!= (>> a 1u) b)");
    assert_eq!(expr("state.color.rgb * 2.0"), "(* state.color.rgb 2.0)");
    assert_eq!(expr("m[0][1] + v.xyz.x"), "(+ m[0][1] v.xyz.x)");
    assert_eq!(expr("true && !false"), "(&& true (! false))");
    assert_eq!(expr("0x2Au + 7i + 1e-3 + .5 + 2.5e2f"), "(+ (+ (+ (+ 42u 7i) 0.001) 0.5) 250.0f)");
}

#[test]
fn generic_constructors_and_comparisons() {
    assert_eq!(expr("vec3<f32>(1.0, 2.0, x)"), "vec3<f32>(1.0, 2.0, x)");
    assert_eq!(expr("mat4x4<f32>(a)"), "mat4x4<f32>(a)");
    assert_eq!(expr("vec3(1.0)"), "vec3(1.0)");
    assert_eq!(expr("vec4f(c, 1.0)"), "vec4f(c, 1.0)");
    assert_eq!(expr("a < b > (c)"), "(> (< a b) c)");
    assert_eq!(expr("a<b"), "(< a b)");
    assert_eq!(expr("vec3<f32>(x).y < 1.0"), "(< vec3<f32>(x).y 1.0)");
    assert_eq!(errors("lib fn f() { let v = vec3<f32>; }"), vec![(1, Code::Syntax)]);
}

#[test]
fn spans() {
    let src = "lib fn f() { let v = -(a + b).x * g(1, 2); }";
    let stmts = body("let v = -(a + b).x * g(1, 2);");
    let StmtKind::Let { value: Some(value), .. } = &stmts[0].kind else { panic!() };
    let text = |e: &Expr| {
        let offset = "lib fn f() { ".len() as u32;
        src[(e.span.start - offset + 13) as usize..(e.span.end - offset + 13) as usize].to_string()
    };
    assert_eq!(text(value), "-(a + b).x * g(1, 2)");
    let ExprKind::Binary { lhs, rhs, .. } = &value.kind else { panic!() };
    assert_eq!(text(lhs), "-(a + b).x");
    assert_eq!(text(rhs), "g(1, 2)");
    let ExprKind::Unary { operand, .. } = &lhs.kind else { panic!() };
    assert_eq!(text(operand), "(a + b).x");
    let ExprKind::Member { base, .. } = &operand.kind else { panic!() };
    assert_eq!(text(base), "(a + b)");
}

// ---- Recovery ----

#[test]
fn recovery_reports_each_independent_error() {
    let src = "lib fn one(x: f32) -> f32 {
return x +;
}

lib fn two(x: f32) -> f32 {
let y = (x * 2.0;
return y;
}
";
    let (m, diags) = parse(src);
    let lines: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.code)).collect();
    assert_eq!(lines, vec![(2, Code::Syntax), (6, Code::Syntax)], "{diags:#?}");
    assert_eq!(diags[0].message, "expected expression, found `;`");
    assert_eq!(diags[1].message, "expected `)`, found `;`");
    assert_eq!(m.items.len(), 2);
    let ItemKind::LibFn(two) = &m.items[1].kind else { panic!() };
    assert!(matches!(two.body.stmts[0].kind, StmtKind::Error));
    assert!(matches!(two.body.stmts[1].kind, StmtKind::Return(Some(_))));
}

#[test]
fn readable_messages() {
    let (_, diags) = parse("lib fn f() { let x = 1 }");
    assert_eq!(diags.len(), 1);
    assert_eq!(diags[0].message, "expected `;`, found `}`");
    let (_, diags) = parse("lib fn f() { let x = a b; }");
    assert_eq!(diags[0].message, "expected `;`, found identifier `b`");
    let (_, diags) = parse("lib fn f() { g(a b); }");
    assert_eq!(diags[0].message, "expected `,` or `)`, found identifier `b`");
    let (_, diags) = parse("foo");
    assert_eq!(diags[0].message, "expected `import`, `const`, `lib`, `pipeline` or `remove`, found identifier `foo`");
}

#[test]
fn recovery_at_item_level() {
    let src = "pipeline p inn start { state.x = 1.0; }\nconst A = ;\nlib fn g() { return 1; }\n} }\nremove start;";
    let (m, diags) = parse(src);
    let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
    assert_eq!(lines, vec![1, 2, 4], "{diags:#?}");
    let kinds: Vec<_> = m
        .items
        .iter()
        .map(|i| match i.kind {
            ItemKind::LibFn(_) => "lib",
            ItemKind::Remove(_) => "remove",
            _ => "other",
        })
        .collect();
    assert_eq!(kinds, ["lib", "remove"]);
}

#[test]
fn statement_recovery_skips_to_semicolon_or_block() {
    let src = "lib fn f() {\n  let = 1;\n  if x + { y(); }\n  z();\n  w(;\n}\n";
    let (m, diags) = parse(src);
    let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
    assert_eq!(lines, vec![2, 3, 5], "{diags:#?}");
    let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
    let kinds: Vec<_> = f.body.stmts.iter().map(|s| matches!(s.kind, StmtKind::Error)).collect();
    assert_eq!(kinds, [true, true, false, true]);
}

#[test]
fn unclosed_block_at_end_of_file() {
    let (m, diags) = parse("lib fn f() {\n  if x {\n    let a = 1;\n");
    assert_eq!(diags.len(), 1, "{diags:#?}");
    assert!(diags[0].message.contains("found end of input"));
    assert_eq!(m.items.len(), 1);
    let (_, diags) = parse("pipeline p in start {");
    assert_eq!(diags.len(), 1);
    let (_, diags) = parse("{");
    assert_eq!(diags.len(), 1);
}

#[test]
fn unclosed_block_before_next_item() {
    let src = "lib fn f() {\n  let a = 1;\nlib fn g() { return; }\n";
    let (m, diags) = parse(src);
    let lines: Vec<_> = diags.iter().map(|d| line_of(src, d.span.start)).collect();
    assert_eq!(lines, vec![3]);
    assert_eq!(m.items.len(), 2);
}

#[test]
fn recovery_scans_leave_no_stale_errors() {
    // Recovering from line 2 scans the unbalanced `(` as far as the `}`; that scan must not
    // stand in for the real error on line 3.
    let src = "lib fn f() {\n  let a = (1 +;\n  let b = 2 3;\n}\nlib fn g() { let c = 1 2; }";
    let (_, diags) = parse(src);
    let found: Vec<_> = diags.iter().map(|d| (line_of(src, d.span.start), d.message.as_str())).collect();
    assert_eq!(
        found,
        [
            (2, "expected expression, found `;`"),
            (3, "expected `;`, found integer literal"),
            (5, "expected `;`, found integer literal")
        ]
    );
}

#[test]
fn unclosed_block_points_at_its_brace() {
    let src = "pipeline p in start {\n  state x: f32;\nlib fn g() {}";
    let (m, diags) = parse(src);
    assert_eq!(diags.len(), 1);
    assert_eq!(diags[0].message, "expected `}`, found `lib`");
    assert_eq!(&src[diags[0].span.start as usize..diags[0].span.end as usize], "lib");
    assert_eq!(diags[0].secondary.first().map(|(s, _)| s.start), Some(20));
    assert_eq!(m.items.len(), 2);
}

#[test]
fn lexer_errors_are_not_reported_again() {
    let deep = format!("lib fn f() {{ let a = {}1{}; }}", "(".repeat(300), ")".repeat(300));
    let (m, diags) = parse(&deep);
    assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
    assert_eq!(m.items.len(), 1);
    let deep_block = format!("lib fn f() {{ {} {} }}", "{".repeat(300), "}".repeat(300));
    let (_, diags) = parse(&deep_block);
    assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
}

#[test]
fn no_syntax_error_after_dropped_characters() {
    assert_eq!(errors("lib fn f(x: f32) -> f32 {\n    return x # 2.0;\n}"), vec![(2, Code::InvalidCharacter)]);
    assert_eq!(errors("lib fn f() {\n  let a = 1; /* never closed\n}"), vec![(2, Code::UnterminatedComment)]);
    assert_eq!(errors("lib fn f() { let a = 1 }#"), vec![(1, Code::InvalidCharacter), (1, Code::Syntax)]);
}

#[test]
fn spans_are_global_offsets() {
    let src = "remove start;\nlib fn f() { let a = ; }";
    let mut diags = Diagnostics::new();
    let lexed = lex(src, 1000, &mut diags);
    let m = parse_module(&lexed, 3, 1000 + src.len() as u32, &mut diags);
    assert_eq!(m.file, 3);
    assert_eq!((m.items[0].span.start, m.items[0].span.end), (1000, 1013));
    let d: Vec<_> = diags.iter().map(|d| d.span.start).collect();
    assert_eq!(d, vec![1000 + src.find("; }").unwrap_or(0) as u32]);
    let (_, diags) = {
        let src = "lib fn f() {";
        let mut diags = Diagnostics::new();
        let lexed = lex(src, 500, &mut diags);
        (parse_module(&lexed, 0, 500 + src.len() as u32, &mut diags), diags)
    };
    assert_eq!(diags.iter().map(|d| d.span.start).collect::<Vec<_>>(), vec![512]);
}

#[test]
fn garbage_never_panics() {
    let pieces = [
        "(", ")", "{", "}", "[", "]", ";", ",", ".", "..", "$", "state", "uniform", "use", "@ray", "@x", "let", "var",
        "for", "in", "if", "else", "return", "break", "fn", "lib", "pipeline", "remove", "replace", "when", "active",
        "0", "1.0", "vec3", "<", ">", "f32", "+", "-", "!", "=", "+=", "import", "::", "->", ":", "\"s\"", "const",
        "x", "after", "before",
    ];
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for _ in 0..400 {
        let mut src = String::new();
        for _ in 0..60 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            src.push_str(pieces[(seed % pieces.len() as u64) as usize]);
            src.push(' ');
        }
        let _ = parse(&src);
    }
}

// ---- Depth ----

/// Runs `f` on a thread with the default 2 MiB test stack.
fn on_small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new().stack_size(2 << 20).spawn(f).expect("spawn").join().expect("no overflow");
}

#[test]
fn long_unary_runs_do_not_overflow() {
    on_small_stack(|| {
        let src = format!("lib fn f() -> f32 {{ return {}x; }}", "- ".repeat(20_000));
        let (m, diags) = parse(&src);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
        assert_eq!(m.items.len(), 1);
        let src = format!("lib fn f() -> f32 {{ return {}x; }}", "-".repeat(MAX_DEPTH as usize - 1));
        let (_, diags) = parse(&src);
        assert!(diags.is_empty(), "{diags:?}");
    });
}

#[test]
fn long_operator_chains_do_not_overflow() {
    on_small_stack(|| {
        let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", "+a".repeat(100_000));
        let (m, diags) = parse(&src);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
        let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
        assert!(matches!(f.body.stmts[0].kind, StmtKind::Return(Some(Expr { kind: ExprKind::Error, .. }))));
        let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", "+a".repeat(MAX_DEPTH as usize - 1));
        let (_, diags) = parse(&src);
        assert!(diags.is_empty(), "{diags:?}");
        let src = format!("lib fn f(a: f32) -> f32 {{ return a{}; }}", ".x".repeat(50_000));
        let (_, diags) = parse(&src);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
    });
}

#[test]
fn long_else_if_chains_do_not_overflow() {
    on_small_stack(|| {
        let src = format!("lib fn f() {{ if a {{ }}{} g(); }}", " else if a { }".repeat(50_000));
        let (m, diags) = parse(&src);
        assert_eq!(diags.iter().map(|d| d.code).collect::<Vec<_>>(), vec![Code::TooDeep]);
        let ItemKind::LibFn(f) = &m.items[0].kind else { panic!() };
        assert_eq!(f.body.stmts.len(), 2);
        let src = format!("lib fn f() {{ if a {{ }}{} }}", " else if a { }".repeat(100));
        parse_ok(&src);
    });
}

#[test]
fn deep_brackets_do_not_overflow() {
    on_small_stack(|| {
        let src = format!("lib fn f() {{ let a = {}1{}; }}", "f(".repeat(127), ")".repeat(127));
        parse_ok(&src);
        let src = format!("lib fn f() {{ {} {} }}", "if a {".repeat(120), "}".repeat(120));
        parse_ok(&src);
    });
}

/// A long body parses whole (how long it takes is `benches/frontend.rs`'s
/// `pipeline_5000_statements`).
#[test]
fn long_bodies_parse() {
    let stmt = "state.color = vec4f(state.color.rgb * 0.5 + f(x, y)[1], 1.0);\n";
    let src = format!("pipeline p in start {{\n{}}}", stmt.repeat(5_000));
    let (m, diags) = parse(&src);
    assert!(diags.is_empty());
    let ItemKind::Pipeline(p) = &m.items[0].kind else { panic!() };
    assert_eq!(p.body.stmts.len(), 5_000);
}

// ---- Conformance cases ----

fn vrs_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            vrs_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "vrs") {
            out.push(path);
        }
    }
}

#[test]
fn conformance_cases_parse() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dirs = [root.join("../../shared/conformance/cases"), root.join("../tests/fixtures")];
    let mut files = Vec::new();
    for dir in &dirs {
        vrs_files(dir, &mut files);
    }
    if files.is_empty() {
        eprintln!("no conformance cases found next to the repository; skipped");
        return;
    }
    for path in files {
        let text = std::fs::read_to_string(&path).expect("readable");
        let (_, diags) = parse(&text);
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let in_ok_folder = path.ancestors().any(|a| {
            a.file_name().is_some_and(|n| n.to_string_lossy().starts_with("ok_"))
                && a.parent().is_some_and(|p| p.ends_with("cases"))
        });
        if name.starts_with("ok_") || in_ok_folder {
            assert!(diags.is_empty(), "{}: {diags:#?}", path.display());
        }
    }
}
