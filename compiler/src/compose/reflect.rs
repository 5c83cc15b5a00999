//! Reflection: what a runtime needs to drive a composed shader without the compiler — the
//! uniform block layout with defaults, ranges and docs, every binding, the state layout, the
//! pipeline map, and hashes that tie the JSON to its WGSL.

use super::place::Composition;
use super::view::{BindingInfo, ViewModule};
use crate::hir::{self, ConstValue, ScalarValue};
use crate::scene::{Scene, UniformValue, View};
use crate::source::SourceMap;
use serde::Serialize;
use serde_json::Value;

/// Bumped whenever the JSON's shape changes incompatibly.
pub const FORMAT_VERSION: u32 = 1;

#[derive(Clone, Debug, Serialize)]
pub struct Reflection {
    pub format_version: u32,
    pub view: String,
    pub kind: String,
    pub entry_point: String,
    pub workgroup_size: [u32; 3],
    /// xxh3-64 (hex) of the WGSL text: a runtime loading `.wgsl` + `.json` checks they belong
    /// together.
    pub wgsl_hash: String,
    /// xxh3-64 (hex) of everything that shapes the shader (the WGSL and its bindings). Uniform
    /// values do not enter it, so equal hashes mean a configuration change only needs new
    /// uniform values, not a new pipeline.
    pub structural_hash: String,
    pub uniform_block: UniformBlock,
    pub uniforms: Vec<UniformInfo>,
    pub bindings: Vec<BindingInfo>,
    pub state: StateInfo,
    pub pipeline: Vec<StepInfo>,
}

#[derive(Clone, Debug, Serialize)]
pub struct UniformBlock {
    pub group: u32,
    pub binding: u32,
    pub size: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct UniformInfo {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    /// Byte offset in the uniform block; `None` for `volume` and `tf` (they are bindings).
    pub offset: Option<u32>,
    pub size: Option<u32>,
    pub default: Option<Value>,
    /// The scene's initial value, when `[uniforms]` sets one.
    pub value: Option<Value>,
    pub range: Option<[Value; 2]>,
    pub doc: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct StateInfo {
    pub size: u32,
    pub fields: Vec<FieldInfo>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FieldInfo {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    pub lifetime: &'static str,
    pub offset: u32,
    pub size: u32,
    pub default: Value,
}

#[derive(Clone, Debug, Serialize)]
pub struct StepInfo {
    pub step: &'static str,
    pub functions: Vec<FunctionInfo>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FunctionInfo {
    pub name: String,
    pub instance: Option<String>,
    pub file: String,
    pub line: usize,
    pub column: usize,
    /// Byte range in the file.
    pub span: [u32; 2],
}

/// xxh3-64 of `text`, as 16 hex digits.
pub fn content_hash(text: &str) -> String {
    format!("{:016x}", xxhash_rust::xxh3::xxh3_64(text.as_bytes()))
}

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
    let values = scene.uniform_values();
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
            value: values.get(&u.name).map(uniform_json),
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
            lifetime: if f.ray { "ray" } else { "sample" },
            offset: m.offset,
            size: m.size,
            default: const_json(&f.default),
        })
        .collect();
    let map = comp.pipeline_map(program, sources);
    let pipeline = comp
        .steps
        .iter()
        .map(|s| StepInfo {
            step: s.step.name(),
            functions: map
                .iter()
                .filter(|e| e.step == s.step)
                .map(|e| {
                    let local = sources.locate(e.span).map_or([0, 0], |(_, r)| [r.start as u32, r.end as u32]);
                    FunctionInfo {
                        name: e.name.clone(),
                        instance: e.instance.clone(),
                        file: e.file.clone(),
                        line: e.line,
                        column: e.column,
                        span: local,
                    }
                })
                .collect(),
        })
        .collect();
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

fn uniform_json(v: &UniformValue) -> Value {
    match v {
        UniformValue::Bool(b) => Value::Bool(*b),
        UniformValue::Int(i) => (*i).into(),
        UniformValue::Float(f) => serde_json::Number::from_f64(*f).map_or(Value::Null, Value::Number),
        UniformValue::Array(items) => Value::Array(items.iter().map(uniform_json).collect()),
    }
}
