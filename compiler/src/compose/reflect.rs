//! Reflection: what a runtime needs to drive a composed shader without the compiler — the
//! uniform block layout with defaults, ranges and docs, every binding, the state layout, the
//! pipeline map, and hashes that tie the JSON to its WGSL.

use super::ir::Composition;
use super::view::ViewModule;
use crate::hir::{self, ConstValue, ScalarValue};
use crate::scene::{Scene, UniformValue, View};
use crate::source::{SourceMap, Span};
use serde_json::Value;
pub use vrs_reflection::{
    FORMAT_VERSION, FieldInfo, FunctionInfo, FunctionStatus, Lifetime, Reflection, StateInfo, StepInfo, UniformBlock,
    UniformInfo, content_hash,
};

/// xxh3-64 (hex) of the WGSL and the bindings' JSON, joined by a newline.
fn structural_hash(wgsl: &str, bindings_json: &str) -> String {
    let mut hasher = xxhash_rust::xxh3::Xxh3::new();
    hasher.update(wgsl.as_bytes());
    hasher.update(b"\n");
    hasher.update(bindings_json.as_bytes());
    format!("{:016x}", hasher.digest())
}

pub fn reflect(
    scene: &Scene,
    view: &View,
    program: &hir::Program,
    comp: &Composition,
    vm: &ViewModule,
    wgsl: &str,
    sources: &SourceMap,
) -> Reflection {
    let values = scene.view_uniform_values(view);
    let member = |name: &str| {
        let emitted = crate::lower::emitted_name(name);
        vm.uniform_layout.members.iter().find(|m| m.name == emitted)
    };
    let plain = vm.uniforms.iter().map(|u| (u, member(&u.name)));
    let resources = comp.uniforms.iter().filter(|u| u.ty.is_resource()).map(|u| (u, None));
    let uniforms = plain
        .chain(resources)
        .map(|(u, m)| UniformInfo {
            name: u.name.clone(),
            ty: u.ty.to_string(),
            offset: m.map(|m| m.offset),
            size: m.map(|m| m.size),
            default: u.default.as_ref().map(const_json),
            value: values.get(&u.name).map(UniformValue::to_json),
            range: u.range.as_ref().map(|(lo, hi)| [const_json(lo), const_json(hi)]),
            doc: u.doc.clone(),
        })
        .collect();
    let fields = comp
        .fields
        .iter()
        .zip(&vm.state_layout.members)
        .map(|(f, m)| FieldInfo {
            name: f.name.clone(),
            ty: f.ty.to_string(),
            lifetime: if f.ray { Lifetime::Ray } else { Lifetime::Sample },
            offset: m.offset,
            size: m.size,
            default: const_json(&f.default),
        })
        .collect();
    let pipeline = pipeline_info(comp, program, sources);
    let bindings_json = serde_json::to_string(&vm.bindings).unwrap_or_default();
    Reflection {
        format_version: FORMAT_VERSION,
        view: view.name.name.clone(),
        kind: format!("{:?}", view.kind.value).to_lowercase(),
        entry_point: "main".into(),
        workgroup_size: super::entry::WORKGROUP_SIZE,
        wgsl_hash: content_hash(wgsl),
        structural_hash: structural_hash(wgsl, &bindings_json),
        uniform_block: UniformBlock { group: 0, binding: 0, size: vm.uniform_layout.size },
        uniforms,
        bindings: vm.bindings.clone(),
        state: StateInfo { size: vm.state_layout.size, fields },
        pipeline,
    }
}

/// The pipeline map: every step's running functions with their origin and declarations, and
/// the functions that do not run.
fn pipeline_info(comp: &Composition, program: &hir::Program, sources: &SourceMap) -> Vec<StepInfo> {
    let function = |pipeline: usize, name: &str, instance: &Option<String>, status| {
        let span = program.pipelines.get(pipeline).map_or(Span::DUMMY, |p| p.span);
        let (file, line, column) = match sources.position(span.start) {
            Some((id, p)) => (sources.file(id).name.clone(), p.line, p.column),
            None => (String::from("?"), 0, 0),
        };
        let local = sources.locate(span).map_or([0, 0], |(_, r)| [r.start as u32, r.end as u32]);
        FunctionInfo {
            name: name.to_string(),
            instance: instance.clone(),
            file,
            line,
            column,
            span: local,
            status,
            uniforms: Vec::new(),
            fields: Vec::new(),
        }
    };
    let subst = |names: &mut dyn Iterator<Item = &String>, instance: &Option<String>| -> Vec<String> {
        names.map(|n| super::instantiate::subst(n, instance.as_deref())).collect()
    };
    comp.steps
        .iter()
        .map(|s| StepInfo {
            step: s.step.name().to_string(),
            functions: s
                .functions
                .iter()
                .map(|f| FunctionInfo {
                    uniforms: f.uniforms.iter().map(|&i| comp.uniforms[i].name.clone()).collect(),
                    fields: f.state.iter().flatten().map(|&i| comp.fields[i].name.clone()).collect(),
                    ..function(f.pipeline, &f.name, &f.instance, FunctionStatus::Active)
                })
                .collect(),
            not_placed: comp
                .not_placed
                .iter()
                .filter(|n| n.step == s.step)
                .map(|n| {
                    let status = if n.removed { FunctionStatus::Removed } else { FunctionStatus::LeftOut };
                    let p = program.pipelines.get(n.pipeline);
                    FunctionInfo {
                        uniforms: p
                            .map(|p| subst(&mut p.uniforms.iter().map(|u| &u.name), &n.instance))
                            .unwrap_or_default(),
                        fields: p.map(|p| subst(&mut p.state.iter().map(|f| &f.name), &n.instance)).unwrap_or_default(),
                        ..function(n.pipeline, &n.name, &n.instance, status)
                    }
                })
                .collect(),
        })
        .collect()
}

fn scalar_json(v: ScalarValue) -> Value {
    match v {
        ScalarValue::Bool(b) => Value::Bool(b),
        ScalarValue::I32(i) => i.into(),
        ScalarValue::U32(u) => u.into(),
        ScalarValue::F32(f) => serde_json::Number::from_f64(f as f64).map_or(Value::Null, Value::Number),
    }
}

/// A scalar as a JSON scalar, a vector as an array, a matrix as an array of columns.
pub fn const_json(c: &ConstValue) -> Value {
    match c.ty {
        crate::types::Type::Vector { .. } => Value::Array(c.components.iter().map(|&v| scalar_json(v)).collect()),
        crate::types::Type::Matrix { rows, .. } => Value::Array(
            c.components
                .chunks(rows as usize)
                .map(|col| Value::Array(col.iter().map(|&v| scalar_json(v)).collect()))
                .collect(),
        ),
        _ => c.components.first().map_or(Value::Null, |&v| scalar_json(v)),
    }
}
