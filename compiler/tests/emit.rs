//! WGSL fixtures: every `tests/fixtures/emit/*.vrs` checks cleanly, lowers to WGSL that naga
//! validates, and that WGSL parses and validates again through naga's own WGSL front end.

mod common;

#[test]
fn emitted_wgsl_is_valid_and_stable() {
    for (name, path) in common::cases("emit") {
        let mut checked = common::check_fixture(&path);
        let errors: Vec<_> = checked.diags.iter().filter(|d| d.is_error()).cloned().collect();
        assert!(errors.is_empty(), "{name}: {}", vrsc::diag::render_plain(&errors, &checked.sources));
        let wgsl = checked.emit_standalone_wgsl().unwrap_or_else(|| {
            panic!("{name}: {}", vrsc::diag::render_plain(&checked.diags.sorted(), &checked.sources))
        });
        let module =
            naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&wgsl)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: re-parsed WGSL does not validate: {e:?}"));
        insta::assert_snapshot!(name, wgsl);
    }
}
