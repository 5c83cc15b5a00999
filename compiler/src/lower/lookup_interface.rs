//! The interface a brick lookup must have, `stdlib/bricks.wgsl`'s: what the runtime binds for a
//! bricked volume and what `sample(v, p)` and `dims(v)` call. A scene's own lookup is checked
//! against it before it is copied into a view's module, so a mistake is an error in the user's
//! file rather than a refused pipeline.

use naga::{AddressSpace, ImageClass, ImageDimension, ScalarKind, StorageAccess, TypeInner, VectorSize};

use vrs_reflection::BRICK_LAYOUT_BYTES;

/// What is wrong with a lookup, and where in its text.
pub(super) type LookupError = (naga::Span, String);

/// The resources a lookup binds, in declaration order.
const RESOURCES: [&str; 5] = [
    "`var NAME: texture_3d<f32>` (the brick pool)",
    "`var NAME_sampler: sampler` (filtering)",
    "`var<storage, read> NAME_pages: array<u32>` (the page table)",
    "`var<uniform> NAME_layout: BrickLayout` (the layout the runtime writes)",
    "`var<storage, read_write> NAME_requests: array<u32>` (the requests)",
];

/// The lookup's functions: `NAME_sample(p: vec3f) -> f32` and `NAME_dims() -> vec3u`, then,
/// optionally, the three of a segment march (see `stdlib/bricks.wgsl`).
pub const SAMPLE: &str = "NAME_sample";
pub const DIMS: &str = "NAME_dims";
pub const SEGMENT_START: &str = "NAME_segment_start";
pub const SAMPLE_IN_SEGMENT: &str = "NAME_sample_in_segment";
pub const SEGMENT_MISSED: &str = "NAME_segment_missed";

/// The functions a lookup defines, in order: the two it must have, then the three it may have.
const FUNCTIONS: [(&str, &str); 5] = [
    (SAMPLE, "fn NAME_sample(p: vec3f) -> f32"),
    (DIMS, "fn NAME_dims() -> vec3u"),
    (SEGMENT_START, "fn NAME_segment_start()"),
    (SAMPLE_IN_SEGMENT, "fn NAME_sample_in_segment(p: vec3f) -> f32"),
    (SEGMENT_MISSED, "fn NAME_segment_missed() -> bool"),
];

/// Checks `module` (parsed and valid) against the interface.
pub fn check(module: &naga::Module) -> Result<(), LookupError> {
    if let Some(entry) = module.entry_points.first() {
        return Err((naga::Span::UNDEFINED, format!("a lookup has no entry points, and `{}` is one", entry.name)));
    }
    let mut resources = 0;
    for (handle, global) in module.global_variables.iter() {
        let span = module.global_variables.get_span(handle);
        let name = global.name.as_deref().unwrap_or_default();
        match global.space {
            AddressSpace::Private if global.init.is_some() => {
                return Err((span, format!("private variable `{name}` may not have an initializer")));
            }
            AddressSpace::Private => continue,
            AddressSpace::Handle | AddressSpace::Uniform | AddressSpace::Storage { .. } => {}
            _ => return Err((span, format!("`{name}`: a lookup's variables are its five resources or private"))),
        }
        let Some(wanted) = RESOURCES.get(resources) else {
            return Err((span, format!("`{name}` is a sixth resource; a lookup binds five: {}", RESOURCES.join(", "))));
        };
        if !resource_fits(module, resources, global) {
            return Err((span, format!("resource {} of the lookup must be {wanted}", resources + 1)));
        }
        resources += 1;
    }
    if let Some(missing) = RESOURCES.get(resources) {
        return Err((
            naga::Span::UNDEFINED,
            format!("the lookup binds {resources} resources; the next must be {missing}"),
        ));
    }
    check_functions(module)
}

/// Whether `global` is what resource `index` must be.
fn resource_fits(module: &naga::Module, index: usize, global: &naga::GlobalVariable) -> bool {
    let inner = &module.types[global.ty].inner;
    let u32_array = || match inner {
        TypeInner::Array { base, size: naga::ArraySize::Dynamic, .. } => {
            matches!(module.types[*base].inner, TypeInner::Scalar(s) if s == naga::Scalar::U32)
        }
        _ => false,
    };
    match (index, global.space) {
        (0, AddressSpace::Handle) => matches!(
            inner,
            TypeInner::Image {
                dim: ImageDimension::D3,
                arrayed: false,
                class: ImageClass::Sampled { kind: ScalarKind::Float, multi: false }
            }
        ),
        (1, AddressSpace::Handle) => matches!(inner, TypeInner::Sampler { comparison: false }),
        (2, AddressSpace::Storage { access }) => access == StorageAccess::LOAD && u32_array(),
        (3, AddressSpace::Uniform) => {
            matches!(inner, TypeInner::Struct { span, .. } if u64::from(*span) <= BRICK_LAYOUT_BYTES)
        }
        (4, AddressSpace::Storage { access }) => access == StorageAccess::LOAD | StorageAccess::STORE && u32_array(),
        _ => false,
    }
}

/// `NAME_sample(vec3f) -> f32` then `NAME_dims() -> vec3u`, and either nothing more or the
/// three segment functions.
fn check_functions(module: &naga::Module) -> Result<(), LookupError> {
    let functions: Vec<_> = module.functions.iter().collect();
    if functions.len() != 2 && functions.len() != FUNCTIONS.len() {
        let span = functions.get(2).map_or(naga::Span::UNDEFINED, |(h, _)| module.functions.get_span(*h));
        return Err((
            span,
            format!(
                "a lookup defines `{}` then `{}`, and may add `{}`, `{}` and `{}` (write helpers inline); it defines {} functions",
                FUNCTIONS[0].1,
                FUNCTIONS[1].1,
                FUNCTIONS[2].1,
                FUNCTIONS[3].1,
                FUNCTIONS[4].1,
                functions.len()
            ),
        ));
    }
    for ((handle, function), (name, signature)) in functions.into_iter().zip(FUNCTIONS) {
        if function.name.as_deref() != Some(name) || !signature_fits(module, function, name) {
            return Err((module.functions.get_span(handle), format!("this function must be `{signature}`")));
        }
    }
    Ok(())
}

/// Whether `function`'s arguments and result are those of the interface's function `name`.
fn signature_fits(module: &naga::Module, function: &naga::Function, name: &str) -> bool {
    let ty = |h: naga::Handle<naga::Type>| &module.types[h].inner;
    let vec3 = |h, scalar| matches!(ty(h), TypeInner::Vector { size: VectorSize::Tri, scalar: s } if *s == scalar);
    let scalar = |h, scalar| matches!(ty(h), TypeInner::Scalar(s) if *s == scalar);
    let result = function.result.as_ref().map(|r| r.ty);
    let arguments: Vec<_> = function.arguments.iter().map(|a| a.ty).collect();
    match name {
        SAMPLE | SAMPLE_IN_SEGMENT => {
            matches!(arguments[..], [p] if vec3(p, naga::Scalar::F32))
                && result.is_some_and(|r| scalar(r, naga::Scalar::F32))
        }
        DIMS => arguments.is_empty() && result.is_some_and(|r| vec3(r, naga::Scalar::U32)),
        SEGMENT_START => arguments.is_empty() && result.is_none(),
        _ => arguments.is_empty() && result.is_some_and(|r| scalar(r, naga::Scalar::BOOL)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lower::bricked::BRICKS_WGSL;

    fn error_of(text: &str) -> String {
        let module = naga::front::wgsl::parse_str(text).expect("parses");
        check(&module).expect_err("refused").1
    }

    #[test]
    fn the_standard_lookup_has_the_interface() {
        check(&naga::front::wgsl::parse_str(BRICKS_WGSL).expect("parses")).expect("fits");
    }

    #[test]
    fn a_lookup_may_leave_out_the_segment_march() {
        let text = BRICKS_WGSL;
        let two = &text[..text.find("// Opens a segment").expect("the segment functions")];
        check(&naga::front::wgsl::parse_str(two).expect("parses")).expect("fits");
    }

    #[test]
    fn lookups_without_the_interface_are_refused_saying_what_is_wanted() {
        let swapped = BRICKS_WGSL.replace("var<storage, read> NAME_pages", "var<storage, read_write> NAME_pages");
        assert!(error_of(&swapped).contains("resource 3 of the lookup must be `var<storage, read> NAME_pages"));
        let renamed = BRICKS_WGSL.replace("fn NAME_dims()", "fn NAME_size()").replace("NAME_dims", "NAME_size");
        assert!(error_of(&renamed).contains("must be `fn NAME_dims() -> vec3u`"), "{}", error_of(&renamed));
        let helper = format!("{BRICKS_WGSL}\nfn NAME_helper() -> f32 {{ return 1.0; }}\n");
        assert!(error_of(&helper).contains("it defines 6 functions"), "{}", error_of(&helper));
        let renamed = BRICKS_WGSL.replace("NAME_segment_missed", "NAME_segment_left");
        assert!(error_of(&renamed).contains("must be `fn NAME_segment_missed() -> bool`"));
        let initialized = BRICKS_WGSL.replace(
            "@group(0) @binding(0) var NAME:",
            "var<private> NAME_count: u32 = 1u;\n@group(0) @binding(0) var NAME:",
        );
        assert!(error_of(&initialized).contains("may not have an initializer"));
        let big = BRICKS_WGSL.replace("    table: vec4f,\n}", "    table: vec4f,\n    more: vec4f,\n}");
        assert!(error_of(&big).contains("resource 4"));
    }
}
