//! Bricked volumes in a view module: the lookup `sample(v, p)` and `dims(v)` call for a volume
//! the runtime keeps in bricks. The lookup is WGSL (`stdlib/bricks.wgsl`), parsed once by naga's
//! front end and copied into each module that needs it, once per bricked volume, its globals
//! bound where the caller says and its names prefixed by the volume's.

use std::sync::OnceLock;

use naga::{Expression as E, Handle, ResourceBinding};

use super::{ModuleBuilder, emitted_name, internal};
use crate::diag::Diagnostic;
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
    pub sample: Handle<naga::Function>,
    pub dims: Handle<naga::Function>,
}

fn template() -> Result<&'static naga::Module, Diagnostic> {
    static PARSED: OnceLock<Result<naga::Module, String>> = OnceLock::new();
    PARSED
        .get_or_init(|| naga::front::wgsl::parse_str(BRICKS_WGSL).map_err(|e| e.emit_to_string(BRICKS_WGSL)))
        .as_ref()
        .map_err(|e| internal(Span::DUMMY, format!("stdlib/bricks.wgsl does not parse: {e}")))
}

impl ModuleBuilder {
    /// Adds the lookup of bricked volume `name`: its five globals bound at `bindings` (pool,
    /// sampler, page table, layout, requests) and its two functions.
    pub fn add_bricked_volume(
        &mut self,
        name: &str,
        bindings: [ResourceBinding; BRICK_GLOBALS],
        span: Span,
    ) -> Result<BrickedFns, Diagnostic> {
        let template = template()?;
        let name = emitted_name(name);
        let rename = |n: &Option<String>| n.as_ref().map(|n| n.replacen(PLACEHOLDER, &name, 1));
        let types = self.copy_types(template);
        let bound = template.global_variables.iter().filter(|(_, g)| g.binding.is_some()).count();
        if bound != BRICK_GLOBALS {
            return Err(internal(span, "stdlib/bricks.wgsl must bind exactly the five globals of a bricked volume"));
        }
        let mut bindings = bindings.into_iter();
        let mut globals = Vec::with_capacity(template.global_variables.len());
        for (_, g) in template.global_variables.iter() {
            if g.init.is_some() {
                return Err(internal(span, "stdlib/bricks.wgsl's globals may not have initializers"));
            }
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
        for (_, f) in template.functions.iter() {
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
                remap_expression(expr, &types, &globals).map_err(|what| internal(span, what))?;
            }
            if let Some(n) = &copy.name {
                self.function_names.insert(n.clone());
            }
            // No VRS span: `vrsc explain` names the lookup's source by the function's name.
            functions.push(self.module.functions.append(copy, naga::Span::UNDEFINED));
        }
        match functions[..] {
            [sample, dims] => Ok(BrickedFns { sample, dims }),
            _ => Err(internal(span, "stdlib/bricks.wgsl must define exactly `NAME_sample` and `NAME_dims`")),
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

/// Points an expression copied from the template at the module's types and globals. The
/// template calls no function and has no constants, which this refuses.
fn remap_expression(
    expr: &mut E,
    types: &[Handle<naga::Type>],
    globals: &[Handle<naga::GlobalVariable>],
) -> Result<(), String> {
    match expr {
        E::Compose { ty, .. } | E::ZeroValue(ty) => *ty = types[ty.index()],
        E::GlobalVariable(g) => *g = globals[g.index()],
        E::Constant(_) | E::Override(_) | E::CallResult(_) => {
            return Err(format!("stdlib/bricks.wgsl may not use constants or calls ({expr:?})"));
        }
        _ => {}
    }
    Ok(())
}
