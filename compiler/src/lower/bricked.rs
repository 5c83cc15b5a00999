//! Bricked volumes in a view module: the lookup `sample(v, p)` and `dims(v)` call for a volume
//! the runtime keeps in bricks. The lookup is WGSL (`stdlib/bricks.wgsl`, or a scene's own file
//! with the same interface: `[[volume]] lookup`), parsed by naga's front end and copied into
//! each module that needs it, once per bricked volume, its globals bound where the caller says
//! and its names prefixed by the volume's.

use std::sync::OnceLock;

use naga::{Expression as E, Handle, ResourceBinding};

use super::lookup_interface::{self, LookupError};
use super::{ModuleBuilder, emitted_name, internal};
use crate::diag::{Code, Diagnostic};
use crate::source::Span;

/// The lookup's source; `NAME` stands for the volume's uniform.
pub const BRICKS_WGSL: &str = include_str!("../../../stdlib/bricks.wgsl");

/// The placeholder in [`BRICKS_WGSL`]'s names.
const PLACEHOLDER: &str = "NAME";

/// Its globals in binding order: the pool, its sampler, the page table, the layout, the requests.
pub const BRICK_GLOBALS: usize = 5;

/// The functions a bricked volume's `sample` and `dims` call.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BrickedFns {
    /// The full lookup, `NAME_sample(p)`.
    pub sample: Handle<naga::Function>,
    pub dims: Handle<naga::Function>,
    /// The segment march, when the lookup has it.
    pub segment: Option<SegmentFns>,
}

/// The functions of a lookup's segment march (`stdlib/bricks.wgsl`): the composer opens a
/// segment before each sample it takes with the full lookup, reads the segment in the samples
/// after it, and takes a sample again where one read outside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SegmentFns {
    /// `NAME_segment_start()`.
    pub start: Handle<naga::Function>,
    /// `NAME_sample_in_segment(p) -> f32`: what a call of `sample` becomes in those samples.
    pub sample: Handle<naga::Function>,
    /// `NAME_segment_missed() -> bool`.
    pub missed: Handle<naga::Function>,
}

/// Where a bricked volume's lookup comes from.
#[derive(Clone, Copy, Debug)]
pub enum LookupSource<'a> {
    /// `stdlib/bricks.wgsl`.
    Standard,
    /// A scene's own lookup: the file's text and its first byte's global offset (the spans of
    /// its diagnostics).
    File { text: &'a str, base: u32 },
}

fn standard_template() -> Result<&'static naga::Module, Diagnostic> {
    static PARSED: OnceLock<Result<naga::Module, String>> = OnceLock::new();
    PARSED
        .get_or_init(|| parse_lookup(BRICKS_WGSL).map_err(|(_, e)| e))
        .as_ref()
        .map_err(|e| internal(Span::DUMMY, format!("stdlib/bricks.wgsl: {e}")))
}

/// Parses and validates a lookup and checks its interface: the five bindings of a bricked
/// volume and the two functions, as `stdlib/bricks.wgsl` has them.
fn parse_lookup(text: &str) -> Result<naga::Module, LookupError> {
    let module = naga::front::wgsl::parse_str(text).map_err(|e| {
        let span = e.labels().next().map_or(naga::Span::UNDEFINED, |(span, _)| span);
        (span, format!("the lookup does not parse: {}", e.message()))
    })?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .map_err(|e| {
            let span = e.spans().next().map_or(naga::Span::UNDEFINED, |(span, _)| *span);
            let mut message = format!("the lookup is not valid WGSL: {}", e.as_inner());
            let mut cause = std::error::Error::source(e.as_inner());
            while let Some(c) = cause {
                message.push_str(&format!(": {c}"));
                cause = c.source();
            }
            (span, message)
        })?;
    lookup_interface::check(&module)?;
    Ok(module)
}

/// A lookup error as a diagnostic: the user's (E0610, in their file) or a compiler bug.
fn lookup_diagnostic(source: LookupSource<'_>, at: Span, (span, message): LookupError) -> Diagnostic {
    match source {
        LookupSource::Standard => internal(at, format!("stdlib/bricks.wgsl: {message}")),
        LookupSource::File { base, .. } => {
            let span = span.to_range().map_or(at, |r| Span::new(base + r.start as u32, base + r.end as u32));
            Diagnostic::new(Code::BadLookup, span, message).with_label("in this brick lookup").with_note(
                "a lookup has the interface of stdlib/bricks.wgsl (see \"Bricked volumes\" in docs/reference.md)",
            )
        }
    }
}

impl ModuleBuilder {
    /// Adds the lookup of bricked volume `name` from `source`: its five globals bound at
    /// `bindings` (pool, sampler, page table, layout, requests) and its two functions. `span`
    /// (the volume's uniform) is where errors of the standard lookup are reported.
    pub fn add_bricked_volume(
        &mut self,
        name: &str,
        bindings: [ResourceBinding; BRICK_GLOBALS],
        span: Span,
        source: LookupSource<'_>,
    ) -> Result<BrickedFns, Diagnostic> {
        let parsed;
        let template = match source {
            LookupSource::Standard => standard_template()?,
            LookupSource::File { text, .. } => {
                parsed = parse_lookup(text).map_err(|e| lookup_diagnostic(source, span, e))?;
                &parsed
            }
        };
        let name = emitted_name(name);
        let rename = |n: &Option<String>| n.as_ref().map(|n| n.replacen(PLACEHOLDER, &name, 1));
        let types = self.copy_types(template);
        let mut bindings = bindings.into_iter();
        let mut globals = Vec::with_capacity(template.global_variables.len());
        for (_, g) in template.global_variables.iter() {
            let var = naga::GlobalVariable {
                name: rename(&g.name),
                space: g.space,
                // Resources take the caller's bindings in order; private variables have none.
                binding: g.binding.as_ref().and_then(|_| bindings.next()),
                ty: types[g.ty.index()],
                init: None,
                memory_decorations: g.memory_decorations,
            };
            globals.push(self.module.global_variables.append(var, span.into()));
        }
        let mut functions = Vec::new();
        for (handle, f) in template.functions.iter() {
            let mut copy = f.clone();
            copy.name = rename(&f.name);
            for arg in &mut copy.arguments {
                arg.ty = types[arg.ty.index()];
            }
            if let Some(result) = &mut copy.result {
                result.ty = types[result.ty.index()];
            }
            for (_, local) in copy.local_variables.iter_mut() {
                local.ty = types[local.ty.index()];
            }
            for (_, expr) in copy.expressions.iter_mut() {
                remap_expression(expr, &types, &globals)
                    .map_err(|what| lookup_diagnostic(source, span, (template.functions.get_span(handle), what)))?;
            }
            if let Some(n) = &copy.name {
                self.function_names.insert(n.clone());
            }
            // The standard lookup has no span (`vrsc explain` names it by the function's name);
            // a scene's own has its place in its file.
            let at = match source {
                LookupSource::Standard => naga::Span::UNDEFINED,
                LookupSource::File { base, .. } => template
                    .functions
                    .get_span(handle)
                    .to_range()
                    .map_or(naga::Span::UNDEFINED, |r| naga::Span::new(base + r.start as u32, base + r.end as u32)),
            };
            functions.push(self.module.functions.append(copy, at));
        }
        // The interface check found these, in this order.
        match functions[..] {
            [sample, dims] => Ok(BrickedFns { sample, dims, segment: None }),
            [sample, dims, start, in_segment, missed] => {
                Ok(BrickedFns { sample, dims, segment: Some(SegmentFns { start, sample: in_segment, missed }) })
            }
            _ => {
                Err(lookup_diagnostic(source, span, (naga::Span::UNDEFINED, "no `NAME_sample` and `NAME_dims`".into())))
            }
        }
    }

    /// Copies every type of `from` into the module; the new handles, by `from`'s index.
    fn copy_types(&mut self, from: &naga::Module) -> Vec<Handle<naga::Type>> {
        let mut map: Vec<Handle<naga::Type>> = Vec::with_capacity(from.types.len());
        for (_, ty) in from.types.iter() {
            let mut inner = ty.inner.clone();
            match &mut inner {
                naga::TypeInner::Pointer { base, .. }
                | naga::TypeInner::Array { base, .. }
                | naga::TypeInner::BindingArray { base, .. } => *base = map[base.index()],
                naga::TypeInner::Struct { members, .. } => {
                    for m in members {
                        m.ty = map[m.ty.index()];
                    }
                }
                _ => {}
            }
            map.push(self.module.types.insert(naga::Type { name: ty.name.clone(), inner }, naga::Span::UNDEFINED));
        }
        map
    }
}

/// Points an expression copied from the template at the module's types and globals. A lookup
/// calls no function and uses no module-scope constant, which this refuses.
fn remap_expression(
    expr: &mut E,
    types: &[Handle<naga::Type>],
    globals: &[Handle<naga::GlobalVariable>],
) -> Result<(), String> {
    match expr {
        E::Compose { ty, .. } | E::ZeroValue(ty) => *ty = types[ty.index()],
        E::GlobalVariable(g) => *g = globals[g.index()],
        E::Constant(_) | E::Override(_) | E::CallResult(_) => {
            return Err(
                "a lookup may not use module-scope constants or overrides, nor call its own functions: write them inline"
                    .to_string(),
            );
        }
        _ => {}
    }
    Ok(())
}
