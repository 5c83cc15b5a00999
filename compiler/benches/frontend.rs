//! Front end + lowering + WGSL writing, against naga's own WGSL front end parsing and
//! validating the WGSL we emit. Run: `cargo bench -p vrsc --bench frontend`.
//!
//! Inputs: a generated module of 3000 functions (library and pipeline functions), a pipeline
//! function whose body is 5000 statements long (the front end must stay linear in the length of
//! a body), and a clip-plane template: the `clip` function of the first example of
//! `docs/language.md` ("A first look"), made a template as in "Instances (`$`)".

use criterion::{Criterion, Throughput, criterion_main};

// The allocator the `vrsc` binary ships with (see cli/src/main.rs).
#[global_allocator]
static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;
use std::fmt::Write;
use std::hint::black_box;

/// 1500 library functions and 1500 pipeline functions that call them.
fn large_module() -> String {
    let mut src = String::new();
    for i in 0..1500 {
        let _ = write!(
            src,
            "/// Helper {i}.\nlib fn helper_{i}(p: vec3f, k: f32) -> vec3f {{\n    var acc = p;\n    for j in 0 .. 4 {{\n        \
             if f32(j) > k {{ break; }}\n        acc = acc * 0.5 + vec3f(f32(j) * {i}.0);\n    }}\n    \
             return normalize(acc + vec3f(k, 1.0, 2.0));\n}}\n\n\
             pipeline step_{i} in shading.tone {{\n    uniform gain_{i}: f32 = 1.5 in 0.0 .. 4.0;\n    \
             state color: vec4f = vec4f(0.0);\n    state pos: vec3f;\n    use helper_{i};\n    \
             let n = helper_{i}(state.pos, gain_{i});\n    if dot(n, vec3f(0.0, 0.0, 1.0)) > 0.5 {{\n        \
             state.color = vec4f(state.color.rgb * gain_{i}, state.color.a);\n    }}\n}}\n\n"
        );
    }
    src
}

/// One pipeline function of 5000 statements, each a call, an index and a swizzle.
fn long_body() -> String {
    let stmt = "    state.color = vec4f(state.color.rgb * 0.5 + f(x, y)[1], 1.0);\n";
    format!(
        "lib fn f(a: f32, b: f32) -> vec3f {{\n    return vec3f(a, b, 1.0);\n}}\n\n\
         pipeline long_body in shading.tone {{\n    uniform x: f32 = 1.0 in 0.0 .. 4.0;\n    \
         uniform y: f32 = 2.0 in 0.0 .. 4.0;\n    state color: vec4f = vec4f(0.0);\n    use f;\n\n{}}}\n",
        stmt.repeat(5_000)
    )
}

const CLIP_PLANE: &str = r#"
lib fn plane_distance(plane: vec4f, p: vec3f) -> f32 {
    return dot(plane.xyz, p) + plane.w;
}

/// Clip one additional volume against a plane.
pipeline clip_$ after classification.additional[$] when active {
    uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;
    state pos: vec3f;
    state color_$: vec4f;
    use plane_distance;

    if plane_distance(clip_plane_$, state.pos) < 0.0 {
        state.color_$ = vec4f(0.0);
    }
}
"#;

/// Our whole pipeline: source text to validated WGSL text.
fn vrsc_compile(src: &str) -> String {
    let mut checked = vrsc::driver::check_source("bench.vrs", src, None);
    checked.emit_standalone_wgsl().expect("benchmark input compiles")
}

/// naga's front end on the same WGSL: parse and validate.
fn naga_parse_validate(wgsl: &str) -> naga::valid::ModuleInfo {
    let module = naga::front::wgsl::parse_str(wgsl).expect("emitted WGSL parses");
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .expect("emitted WGSL validates")
}

fn bench_input(c: &mut Criterion, name: &str, src: &str) {
    let wgsl = vrsc_compile(src);
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Bytes(src.len() as u64));
    group.bench_function("vrsc_check_lower_wgsl", |b| b.iter(|| vrsc_compile(black_box(src))));
    group.throughput(Throughput::Bytes(wgsl.len() as u64));
    group.bench_function("naga_wgsl_parse_validate", |b| b.iter(|| naga_parse_validate(black_box(&wgsl))));
    group.finish();
    eprintln!("{name}: {} KB of VRS, {} KB of WGSL emitted", src.len() / 1024, wgsl.len() / 1024);
}

fn benches(c: &mut Criterion) {
    bench_input(c, "module_3000_functions", &large_module());
    bench_input(c, "pipeline_5000_statements", &long_body());
    bench_input(c, "clip_plane_template", CLIP_PLANE);
}

/// The group `criterion_main!` runs; in a private module, since its generated function has no
/// documentation.
mod group {
    criterion::criterion_group! {
        name = frontend;
        config = criterion::Criterion::default().sample_size(20);
        targets = super::benches
    }
}
criterion_main!(group::frontend);
