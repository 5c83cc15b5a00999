"""vrsc.check and vrsc.compose: diagnostics as objects, CompileError naming the line."""

import os

import pytest

import vrsc
from conftest import ROOT, TINT

BROKEN = """pipeline p after classification.primary {
    state color: vec4f;
    state.color = vec4f(not_declared);
}
"""


def test_a_clean_module_checks_without_error():
    assert [d for d in vrsc.check(TINT) if d.is_error] == []


def test_a_compile_error_is_raised_with_its_line():
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.check(BROKEN)
    text = str(caught.value)
    assert "line 3" in text and "<string>:3:25" in text, text
    assert "unknown name `not_declared`" in text
    [d] = caught.value.errors
    assert (d.code, d.severity, d.file, d.line, d.column) == ("E0502", "error", "<string>", 3, 25)
    assert d.message == "unknown name `not_declared`"
    assert d.help and "uniform not_declared" in d.help
    assert "3 │" in str(d), "str() is the CLI's rendering with the source line"
    assert isinstance(caught.value, vrsc.VrscError)


def test_a_syntax_error_names_its_line():
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.check("pipeline p after classification.primary {\n    let x = ;\n}\n")
    assert caught.value.errors[0].line == 2


def test_files_are_checked_by_path_with_their_imports(tmp_path):
    lib = tmp_path / "lib.vrs"
    lib.write_text("lib fn half(x: f32) -> f32 {\n    return x * 0.5;\n}\n")
    main = tmp_path / "main.vrs"
    main.write_text(
        'import "lib.vrs";\npipeline p after classification.primary {\n    state color: vec4f;\n'
        "    use half;\n    state.color = vec4f(half(state.color.a));\n}\n"
    )
    assert [d for d in vrsc.check(main) if d.is_error] == []
    assert [d for d in vrsc.check(str(main)) if d.is_error] == []
    main.write_text(main.read_text().replace("half(state", "halve(state"))
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.check(main)
    assert caught.value.errors[0].file.endswith("main.vrs") and caught.value.errors[0].line == 5


def test_a_missing_file_is_file_not_found():
    with pytest.raises(FileNotFoundError):
        vrsc.check("no/such/module.vrs")


def test_warnings_come_back_as_diagnostics():
    # A uniform declared and never read is fine; a state field written and never read warns
    # only in composition, so check a composed scene for warnings' shape instead.
    diags = vrsc.compose(os.path.join(ROOT, "examples", "basic", "scene.toml"))
    assert all(isinstance(d, vrsc.Diagnostic) and not d.is_error for d in diags)


def test_a_scene_with_errors_raises_compile_error(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[[volume]]\nname = "v"\nrole = "primary"\nphantom = "head"\n\n[[module]]\npath = "bad.vrs"\n\n'
        '[[view]]\nname = "3d"\nkind = "raycast"\n'
    )
    (tmp_path / "bad.vrs").write_text(BROKEN)
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.compose(scene)
    [d] = caught.value.errors
    assert d.file.endswith("bad.vrs") and d.line == 3
    with pytest.raises(vrsc.CompileError):
        vrsc.Scene.load(scene)


def test_an_unknown_scene_key_is_an_error_at_its_line(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text('[[volume]]\nname = "v"\nrole = "primary"\nphantom = "head"\ncolour = 1\n')
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.compose(scene)
    assert any(d.line == 5 for d in caught.value.errors)
