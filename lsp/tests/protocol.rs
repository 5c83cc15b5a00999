//! The server driven through its protocol over an in-memory connection: initialize, open,
//! change, hover, completion, definition, references, code actions, shutdown and exit, with
//! snapshot answers. The module under test is a copy of `examples/ablation` (so scene context
//! is real), with the test's folders redacted in the snapshots.

mod common;

use common::{Client, ablation_copy, uri_of};
use serde_json::{Value, json};

/// `label  detail` per completion item, the answer's order.
fn labels(items: &Value) -> String {
    items
        .as_array()
        .unwrap()
        .iter()
        .map(|i| format!("{:<28} {}", i["label"].as_str().unwrap(), i["detail"].as_str().unwrap_or("")))
        .collect::<Vec<_>>()
        .join("\n")
}

fn hover_text(answer: &Value) -> String {
    answer["contents"]["value"].as_str().unwrap_or("(no hover)").to_string()
}

#[test]
fn initialize_announces_the_capabilities() {
    let (_dir, root) = ablation_copy();
    let (client, result) = Client::start(&root);
    insta::assert_snapshot!(client.show(&result));
    client.shutdown();
}

#[test]
fn diagnostics_follow_every_change() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let uri = uri_of(&root.join("glow.vrs"));
    let broken = "pipeline glow after shading.lights {\n    state color: vec4f;\n    state.color = state.color * brighten(state.gradient);\n}\n";
    client.open(&uri, broken);
    let answer = client.diagnostics(&uri);
    insta::assert_snapshot!("broken", client.show(&answer));
    let fixed =
        "pipeline glow after shading.lights {\n    state color: vec4f;\n    state.color = state.color * 2.0;\n}\n";
    client.change(&uri, 2, fixed);
    let answer = client.diagnostics(&uri);
    assert_eq!(answer["diagnostics"], json!([]), "{}", client.show(&answer));
    client.shutdown();
}

#[test]
fn a_scene_that_lists_the_module_adds_its_composition_errors() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let path = root.join("compose_3d.vrs");
    let uri = uri_of(&path);
    let text = std::fs::read_to_string(&path).unwrap();
    client.open(&uri, &text);
    let clean = client.diagnostics(&uri);
    assert_eq!(clean["diagnostics"], json!([]), "{}", client.show(&clean));
    // Only composing the scene can tell that the standard pipeline has no such substep.
    let moved = text.replace("after compositing.alpha", "after compositing.alpha[no_such_function]");
    client.change(&uri, 2, &moved);
    let answer = client.diagnostics(&uri);
    insta::assert_snapshot!(client.show(&answer));
    client.shutdown();
}

/// A module the scene lists among a view's `filters` gets the errors of composing the view's
/// filter pass: an image that no picture has.
#[test]
fn a_scene_that_lists_the_module_as_a_filter_adds_its_filter_pass_errors() {
    let (_dir, root) = ablation_copy();
    let scene = root.join("scene.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    let listed =
        text.replacen("[[view]]\nname = \"3d\"", "[[view]]\nname = \"3d\"\nfilters = [{ path = \"dim.vrs\" }]", 1);
    assert_ne!(listed, text, "the example's 3d view");
    std::fs::write(&scene, listed).unwrap();
    let path = root.join("dim.vrs");
    let module = "pipeline dim in filter.apply {\n    uniform pictures: image;\n    state texel: vec2i;\n    state color: vec4f;\n    state.color = 0.5 * load(pictures, state.texel);\n}\n";
    std::fs::write(&path, module).unwrap();
    let (mut client, _) = Client::start(&root);
    let uri = uri_of(&path);
    client.open(&uri, module);
    let answer = client.diagnostics(&uri);
    let shown = client.show(&answer);
    assert!(shown.contains("E0608") && shown.contains("`pictures`"), "{shown}");
    client.shutdown();
}

#[test]
fn hover_tells_types_lifetimes_defaults_docs_and_step_meanings() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let path = root.join("applicator.vrs");
    let uri = uri_of(&path);
    let text = std::fs::read_to_string(&path).unwrap();
    client.open(&uri, &text);
    let mut shown = Vec::new();
    for (what, needle, offset) in [
        ("a state field used", "state.ray_dir", 7),
        ("a state field declared", "@ray state t_next", 12),
        ("a uniform used", "zone_enabled_$ {", 2),
        ("a library function called", "ellipsoid_depth(p", 3),
        ("a local", "let p", 4),
        ("a step path", "before start", 8),
        ("a type", "vec2f =", 1),
    ] {
        let answer = client.at("textDocument/hover", &uri, &text, needle, offset);
        shown.push(format!("## {what} (`{needle}`)\n{}", hover_text(&answer)));
    }
    let std_user = "import std::shading;\n\n/// Brightens the colour.\npipeline glow after shading.lights[key] {\n    state color: vec4f;\n    state.color = clamp(state.color, vec4f(0.0), vec4f(1.0));\n}\n";
    let glow = uri_of(&root.join("glow.vrs"));
    client.open(&glow, std_user);
    for (what, needle, offset) in
        [("a standard module", "std::shading", 6), ("a substep", "lights[key]", 8), ("a built-in", "clamp", 1)]
    {
        let answer = client.at("textDocument/hover", &glow, std_user, needle, offset);
        shown.push(format!("## {what} (`{needle}`)\n{}", hover_text(&answer)));
    }
    insta::assert_snapshot!(shown.join("\n\n"));
    client.shutdown();
}

#[test]
fn completion_offers_fields_steps_substeps_and_names() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let uri = uri_of(&root.join("glow.vrs"));
    let mut shown = Vec::new();
    let cases = [
        (
            "after `state.`",
            "pipeline glow after shading.lights {\n    state color: vec4f;\n    state.gr\n}\n",
            "state.gr",
            8,
        ),
        ("a step path", "pipeline glow after shading.\n", "shading.", 8),
        ("a substep", "pipeline glow after shading.lights[\n", "[", 1),
        ("a `use` list", "import \"ellipsoid.vrs\";\npipeline glow in start {\n    use \n}\n", "use ", 4),
    ];
    for (version, (what, text, needle, offset)) in cases.into_iter().enumerate() {
        if version == 0 {
            client.open(&uri, text);
        } else {
            client.change(&uri, version as i32 + 1, text);
        }
        let answer = client.at("textDocument/completion", &uri, text, needle, offset);
        shown.push(format!("## {what}\n{}", labels(&answer)));
    }
    insta::assert_snapshot!(shown.join("\n\n"));
    // In a body: declared uniforms and library functions, built-ins with their signatures.
    let body = "import \"ellipsoid.vrs\";\npipeline glow in start {\n    uniform gain: f32 = 1.0;\n    use ellipsoid_depth;\n    let x = \n}\n";
    client.change(&uri, 9, body);
    let answer = client.at("textDocument/completion", &uri, body, "let x = ", 8);
    let text = labels(&answer);
    for expected in [
        "gain",
        "uniform gain: f32",
        "ellipsoid_depth",
        "lib fn ellipsoid_depth(p: vec3f",
        "clamp(e, low, high)",
        "smoothstep(low, high, x)",
        "sample(v, p)",
        "abs(x)",
    ] {
        assert!(text.contains(expected), "`{expected}` missing from\n{text}");
    }
    // Choosing a field the function has not declared also adds its declaration.
    let field = "pipeline glow after shading.lights {\n    state color: vec4f;\n    state.gr\n}\n";
    client.change(&uri, 10, field);
    let answer = client.at("textDocument/completion", &uri, field, "state.gr", 8);
    let gradient = answer.as_array().unwrap().iter().find(|i| i["label"] == "gradient").expect("gradient offered");
    insta::assert_snapshot!(
        "gradient_item",
        client.show(&json!({ "detail": gradient["detail"], "additionalTextEdits": gradient["additionalTextEdits"] }))
    );
    client.shutdown();
}

#[test]
fn definitions_lead_into_imports_and_the_standard_library() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let path = root.join("applicator.vrs");
    let uri = uri_of(&path);
    let text = std::fs::read_to_string(&path).unwrap();
    client.open(&uri, &text);
    let mut shown = Vec::new();
    for (what, needle, offset) in [
        ("a library function of an import", "ellipsoid_depth(p", 3),
        ("a state field with defaults in the standard library", "state.ray_dir", 7),
        ("a uniform", "zone_enabled_$ {", 2),
        ("a step path", "before start", 8),
        ("an imported file", "\"ellipsoid.vrs\"", 2),
    ] {
        let answer = client.at("textDocument/definition", &uri, &text, needle, offset);
        shown.push(format!("## {what}\n{}", client.show(&answer)));
    }
    insta::assert_snapshot!(shown.join("\n\n"));
    // The standard library's cached copy is its embedded text.
    let answer = client.at("textDocument/definition", &uri, &text, "state.ray_dir", 7);
    let target = vrsc_lsp::uri::to_path(&answer[0]["uri"].as_str().unwrap().parse().unwrap()).unwrap();
    let name = target.file_stem().unwrap().to_str().unwrap();
    let embedded = vrsc::stdlib::modules().find(|(n, _)| *n == name).unwrap().1;
    assert_eq!(std::fs::read_to_string(&target).unwrap(), embedded);
    client.shutdown();
}

#[test]
fn references_of_a_state_field_span_the_scene_and_the_standard_library() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let path = root.join("compose_3d.vrs");
    let uri = uri_of(&path);
    let text = std::fs::read_to_string(&path).unwrap();
    client.open(&uri, &text);
    let answer = client.at("textDocument/references", &uri, &text, "state.zone_$", 7);
    insta::assert_snapshot!(client.show(&answer));
    client.shutdown();
}

#[test]
fn code_actions_add_the_missing_declarations() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let uri = uri_of(&root.join("glow.vrs"));
    let text = "lib fn brighten(c: vec4f) -> vec4f {\n    return c * 2.0;\n}\n\npipeline glow after shading.lights {\n    state color: vec4f;\n\n    state.color = brighten(state.color) * gain + vec4f(state.gradient, 0.0);\n}\n";
    client.open(&uri, text);
    let diagnostics = client.diagnostics(&uri);
    let line = text.lines().position(|l| l.contains("brighten(state")).unwrap();
    let answer = client.request(
        "textDocument/codeAction",
        json!({
            "textDocument": { "uri": uri },
            "range": { "start": { "line": line, "character": 0 }, "end": { "line": line, "character": 80 } },
            "context": { "diagnostics": diagnostics["diagnostics"] }
        }),
    );
    let titles: Vec<String> =
        answer.as_array().unwrap().iter().map(|a| a["title"].as_str().unwrap().to_string()).collect();
    let edits: Vec<String> =
        answer.as_array().unwrap().iter().map(|a| client.show(&a["edit"]["changes"][&uri])).collect();
    insta::assert_snapshot!(format!("{}\n\n{}", titles.join("\n"), edits.join("\n")));
    // Applying every fix leaves no error.
    let mut fixed = text.to_string();
    for a in answer.as_array().unwrap().iter().rev() {
        let edit = &a["edit"]["changes"][&uri][0];
        let line = edit["range"]["start"]["line"].as_u64().unwrap() as usize;
        let column = edit["range"]["start"]["character"].as_u64().unwrap() as usize;
        let offset = fixed.split_inclusive('\n').take(line).map(str::len).sum::<usize>() + column;
        fixed.insert_str(offset, edit["newText"].as_str().unwrap());
    }
    client.change(&uri, 2, &fixed);
    let after = client.diagnostics(&uri);
    let errors: Vec<&Value> = after["diagnostics"].as_array().unwrap().iter().filter(|d| d["severity"] == 1).collect();
    assert!(errors.is_empty(), "{fixed}\n{}", client.show(&after));
    client.shutdown();
}

#[test]
fn a_change_to_an_imported_module_checks_its_importers_again() {
    let (_dir, root) = ablation_copy();
    let (mut client, _) = Client::start(&root);
    let applicator = uri_of(&root.join("applicator.vrs"));
    let applicator_text = std::fs::read_to_string(root.join("applicator.vrs")).unwrap();
    client.open(&applicator, &applicator_text);
    assert_eq!(client.diagnostics(&applicator)["diagnostics"], json!([]));
    let ellipsoid = uri_of(&root.join("ellipsoid.vrs"));
    let ellipsoid_text = std::fs::read_to_string(root.join("ellipsoid.vrs")).unwrap();
    client.open(&ellipsoid, &ellipsoid_text);
    assert_eq!(client.diagnostics(&ellipsoid)["diagnostics"], json!([]));
    // Renaming the function in the unsaved buffer breaks the module that imports it.
    client.change(&ellipsoid, 2, &ellipsoid_text.replace("fn ellipsoid_depth", "fn ellipsoid_depth2"));
    let codes = |answer: &Value| -> Vec<String> {
        answer["diagnostics"].as_array().unwrap().iter().map(|d| d["code"].as_str().unwrap().to_string()).collect()
    };
    let broken = client.diagnostics(&applicator);
    assert_eq!(codes(&broken), ["E0509", "E0205"], "{}", client.show(&broken));
    // Closing the buffer brings back the file on disk, and the closed document's diagnostics go.
    client.notify("textDocument/didClose", json!({ "textDocument": { "uri": ellipsoid } }));
    assert_eq!(client.diagnostics(&ellipsoid)["diagnostics"], json!([]));
    assert_eq!(client.diagnostics(&applicator)["diagnostics"], json!([]));
    client.shutdown();
}
