//! Composition: a scene file to validated WGSL + reflection for every view, against naga's WGSL
//! front end parsing and validating that same output, and against a composition cache hit.
//! Run: `cargo bench -p vrsc --bench compose`.
//!
//! Scene: `tests/fixtures/compose/bench_3vol_2lights_4clips` (three volumes, two lights, four
//! clip-plane instances; a raycast and a slice view, composed in parallel), and its raycast view
//! alone. Like the `vrsc` binary, the bench runs on mimalloc.

use criterion::{Criterion, criterion_main};

// The allocator the `vrsc` binary ships with (see cli/src/main.rs).
#[global_allocator]
static GLOBAL: vrsc_alloc::MiMalloc = vrsc_alloc::MiMalloc;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use vrsc::compose::build::build_scene;
use vrsc::compose::cache::CompositionCache;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/compose/bench_3vol_2lights_4clips/scene.toml")
}

fn naga_parse_validate(wgsl: &str) -> naga::valid::ModuleInfo {
    let module = naga::front::wgsl::parse_str(wgsl).expect("composed WGSL parses");
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .expect("composed WGSL validates")
}

fn composition(c: &mut Criterion) {
    let path = scene();
    let built = build_scene(&path, None).expect("bench scene readable");
    assert!(!built.diags.has_errors(), "bench scene composes");
    let wgsl: Vec<String> = built.views.iter().filter_map(|v| v.shader.as_ref()).map(|s| s.wgsl.clone()).collect();
    assert_eq!(wgsl.len(), 2);

    let mut group = c.benchmark_group("compose_3vol_2lights_4clips");
    group.bench_function("vrsc_compose_all_views", |b| b.iter(|| build_scene(black_box(&path), None).unwrap()));
    group.bench_function("vrsc_compose_raycast_view_only", |b| {
        b.iter(|| build_scene(black_box(&path), Some("3d")).unwrap())
    });
    group.bench_function("naga_parse_validate_same_wgsl", |b| {
        b.iter(|| {
            for w in &wgsl {
                black_box(naga_parse_validate(black_box(w)));
            }
        })
    });
    let mut cache = CompositionCache::new();
    cache.build(&path).unwrap();
    group.bench_function("vrsc_cache_hit", |b| b.iter(|| cache.build(black_box(&path)).unwrap()));
    group.finish();
}

/// The group `criterion_main!` runs; in a private module, since its generated function has no
/// documentation.
mod group {
    criterion::criterion_group!(benches, super::composition);
}
criterion_main!(group::benches);
