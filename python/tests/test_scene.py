"""vrsc.Scene: volumes from numpy arrays and files, rendering, probes, uniforms, views."""

import os

import nibabel
import numpy as np
import pytest

import vrsc
from conftest import ROOT, TINT, ball

SIZE = (48, 40)


def test_from_array_renders_an_rgba8_image(sphere):
    scene = vrsc.Scene.from_array(sphere, spacing=(1.0, 1.0, 1.0))
    image = scene.render(size=(64, 64))
    assert isinstance(image, np.ndarray)
    assert image.shape == (64, 64, 4) and image.dtype == np.uint8
    assert image[32, 32, :3].max() > 0, "the ball is visible at the centre"
    assert image[0, 0, :3].max() == 0, "and not in the corner"
    other = scene.render(size=SIZE)
    assert other.shape == (40, 48, 4)
    assert scene.render().shape == (256, 256, 4), "without a size, the view's own"


@pytest.mark.parametrize(
    "dtype", ["u1", "i1", "u2", "i2", "u4", "i4", "f4", "f8", "i8", "u8", "f2", ">f4", ">i2", "bool"]
)
def test_any_numeric_dtype_renders(dtype):
    array = ball(16).astype(dtype) if dtype != "bool" else ball(16) > 30
    image = vrsc.Scene.from_array(array).render(size=(24, 24))
    assert image.shape == (24, 24, 4) and image[12, 12, :3].max() > 0, dtype


def test_c_and_fortran_order_are_the_same_volume(sphere):
    c = np.ascontiguousarray(sphere)
    f = np.asfortranarray(sphere)
    strided = np.ascontiguousarray(np.transpose(sphere, (2, 1, 0))).transpose(2, 1, 0)
    images = [vrsc.Scene.from_array(a, spacing=(1.0, 1.2, 0.8)).render(size=SIZE) for a in (c, f, strided)]
    assert np.array_equal(images[0], images[1])
    assert np.array_equal(images[0], images[2])
    flipped = vrsc.Scene.from_array(np.ascontiguousarray(sphere[::-1]), spacing=(1.0, 1.2, 0.8)).render(size=SIZE)
    assert not np.array_equal(images[0], flipped), "the picture depends on the axis order"


def test_an_array_renders_as_the_same_samples_written_as_nifti(sphere, tmp_path):
    affine = np.array([[0.9, 0.0, 0.0, -10.0], [0.0, 1.1, 0.0, 4.0], [0.0, 0.0, 1.3, 2.0], [0.0, 0.0, 0.0, 1.0]])
    path = tmp_path / "ball.nii"
    nibabel.save(nibabel.Nifti1Image(sphere, affine), str(path))
    from_array = vrsc.Scene.from_array(sphere, affine=affine, tf="hot_metal").render(size=SIZE)
    from_file = vrsc.Scene()
    from_file.add_volume("volume", path=path, tf="hot_metal")
    from_file.add_view("3d", size=[256, 256])
    assert np.array_equal(from_array, from_file.render(size=SIZE))
    # And as nibabel reads it back (its own array, Fortran-ordered over the file's memory map).
    loaded = np.asanyarray(nibabel.load(str(path)).dataobj)
    assert np.array_equal(from_array, vrsc.Scene.from_array(loaded, affine=affine, tf="hot_metal").render(size=SIZE))


@pytest.mark.parametrize(
    "array, message",
    [
        (np.zeros((4, 4)), "3D array"),
        (np.zeros((2, 3, 4, 5)), "3D array"),
        (np.zeros((0, 4, 4)), "empty array"),
        (np.zeros((4, 4, 4), dtype=complex), "numbers"),
        (np.array([[["a"]]]), "numbers"),
    ],
)
def test_wrong_shapes_and_dtypes_are_value_errors(array, message):
    with pytest.raises(ValueError, match=message):
        vrsc.Scene.from_array(array)


def test_nans_are_value_errors(sphere):
    bad = sphere.copy()
    bad[3, 4, 5] = np.nan
    with pytest.raises(ValueError, match=r"NaN at index \(3, 4, 5\)"):
        vrsc.Scene.from_array(bad)
    bad[3, 4, 5] = np.inf
    with pytest.raises(ValueError, match="finite"):
        vrsc.Scene.from_array(bad.astype(np.float64))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"spacing": (1.0, 0.0, 1.0)}, "positive"),
        ({"spacing": (1.0, 1.0)}, "three numbers"),
        ({"affine": np.eye(3)}, "4 x 4"),
        ({"affine": np.zeros((4, 4)) + np.diag([0, 0, 0, 1])}, "singular"),
        ({"affine": np.ones((4, 4))}, "last row"),
        ({"spacing": (1, 1, 1), "affine": np.eye(4)}, "not both"),
        ({"spacing": (1e9, 1.0, 1.0)}, "voxel spacing"),
    ],
)
def test_bad_placements_are_refused(sphere, kwargs, message):
    with pytest.raises((ValueError, vrsc.SceneError), match=message):
        vrsc.Scene.from_array(sphere, **kwargs)


def test_transfer_functions_from_points_and_compositing(sphere):
    red = vrsc.Scene.from_array(sphere, tf=[[0, 1, 0, 0, 0], [100, 1, 0, 0, 1]]).render(size=SIZE)
    assert red[20, 24, 0] > 0 and red[20, 24, 1] == 0 and red[20, 24, 2] == 0
    grey = vrsc.Scene.from_array(sphere, tf=[[0, 0], [100, 1]]).render(size=SIZE)
    assert grey[20, 24, 0] == grey[20, 24, 1] == grey[20, 24, 2] > 0
    mip = vrsc.Scene.from_array(sphere, compositing="mip").render(size=SIZE)
    dvr = vrsc.Scene.from_array(sphere, compositing="dvr").render(size=SIZE)
    assert not np.array_equal(mip, dvr)
    with pytest.raises(ValueError, match="increasing"):
        vrsc.Scene.from_array(sphere, tf=[[100, 0], [0, 1]])
    with pytest.raises(vrsc.CompileError, match="compositing"):
        vrsc.Scene.from_array(sphere, compositing="sideways")


def test_a_path_traced_picture_is_the_mean_of_its_samples(sphere):
    scene = vrsc.Scene.from_array(sphere, tf=[[0, 0.2], [100, 1]], compositing="pathtrace")
    one = scene.render(size=SIZE, samples=1).astype(float)
    fresh = vrsc.Scene.from_array(sphere, tf=[[0, 0.2], [100, 1]], compositing="pathtrace")
    many = fresh.render(size=SIZE, samples=32).astype(float)
    # One sample per pixel is noise around the mean that 32 converge to: neighbours differ more.
    roughness = lambda image: np.abs(np.diff(image[..., :3], axis=1)).mean()
    assert roughness(one) > 2 * roughness(many) > 0
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="samples"):
            scene.render(size=SIZE, samples=bad)


def test_a_module_from_a_string_tints_the_picture(sphere):
    plain = vrsc.Scene.from_array(sphere).render(size=SIZE)
    scene = vrsc.Scene.from_array(sphere, modules=[TINT])
    tinted = scene.render(size=SIZE)
    r, g, b = (int(v) for v in tinted[20, 24, :3])
    assert r > g > b > 0, (r, g, b)
    assert plain[20, 24, 0] == plain[20, 24, 1], "the standard pipeline alone is grey"


def test_a_module_from_a_file_and_its_errors(sphere, tmp_path):
    module = tmp_path / "tint.vrs"
    module.write_text(TINT)
    scene = vrsc.Scene.from_array(sphere, modules=[module])
    assert scene.get_uniform("boost") == 1.0
    broken = tmp_path / "broken.vrs"
    broken.write_text(TINT.replace("tint * boost", "tint * bost"))
    with pytest.raises(vrsc.CompileError) as caught:
        vrsc.Scene.from_array(sphere, modules=[broken])
    assert caught.value.errors[0].file.endswith("broken.vrs") and caught.value.errors[0].line == 10


def test_uniforms_are_typed_by_their_declarations(sphere):
    scene = vrsc.Scene.from_array(sphere, modules=[TINT])
    info = scene.uniforms["tint"]
    assert info["type"] == "vec3f" and info["range"] == ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    assert scene.uniforms["steps"]["type"] == "i32" and scene.uniforms["enabled"]["value"] is True
    before = scene.render(size=SIZE)
    scene.set_uniform("tint", np.array([0.0, 1.0, 0.0]))
    assert scene.get_uniform("tint") == [0.0, 1.0, 0.0]
    after = scene.render(size=SIZE)
    assert after[20, 24, 0] == 0 and after[20, 24, 1] > 0 and not np.array_equal(before, after)
    scene["boost"] = 2  # an int sets an f32
    assert scene["boost"] == 2.0
    scene["steps"] = 3
    assert scene["steps"] == 3
    scene["enabled"] = False
    assert scene["enabled"] is False
    assert np.array_equal(scene.render(size=SIZE), vrsc.Scene.from_array(sphere).render(size=SIZE))
    for name, value in [("tint", 1.0), ("tint", [1.0, 2.0]), ("boost", True), ("steps", 1.5), ("enabled", 1)]:
        with pytest.raises(TypeError, match=f"uniform `{name}` is a"):
            scene.set_uniform(name, value)
    with pytest.raises(TypeError, match="takes numbers"):
        scene.set_uniform("boost", "loud")
    with pytest.raises(ValueError, match="finite"):
        scene.set_uniform("boost", float("nan"))
    with pytest.raises(KeyError, match="did you mean `boost`"):
        scene.set_uniform("bost", 1.0)
    with pytest.raises(vrsc.SceneError):
        scene.get_uniform("nothing")
    with pytest.raises(vrsc.SceneError, match="set by the renderer"):
        scene.set_uniform("inv_view_proj", np.eye(4))


def test_uniforms_set_in_python_survive_a_change_of_the_scene(sphere):
    scene = vrsc.Scene.from_array(sphere, modules=[TINT])
    scene["boost"] = 3.0
    scene.add_view("small", size=[32, 32])
    assert scene.views == ["3d", "small"]
    assert scene["boost"] == 3.0


def test_probes_are_float_arrays(sphere):
    scene = vrsc.Scene.from_array(sphere)
    value = scene.render(size=SIZE, probe="value")
    assert value.dtype == np.float32 and value.shape == (40, 48)
    assert np.isnan(value[0, 0]), "no value where the rays miss the ball"
    assert 0.0 < np.nanmax(value) <= 1.0, "normalized values"
    accum = scene.render(size=SIZE, probe="accum")
    assert accum.dtype == np.float32 and accum.shape == (40, 48, 4)
    first = scene.render(size=SIZE, probe="value", probe_sample=0)
    assert first.shape == (40, 48)
    assert "value" in scene.probe_legend("value", size=SIZE)
    with pytest.raises(KeyError, match="did you mean `value`"):
        scene.render(size=SIZE, probe="valeu")


def test_views_cameras_and_unknown_views(sphere):
    scene = vrsc.Scene.from_array(sphere)
    scene.add_view("axial", kind="slice", axis="z", position=0.5, size=[40, 40])
    front = scene.render("3d", size=SIZE)
    assert scene.render("axial").shape == (40, 40, 4)
    with pytest.raises(KeyError, match="no view `3D`; did you mean `3d`"):
        scene.render("3D")
    with pytest.raises(vrsc.SceneError):
        scene.render("3D")
    assert scene.camera()["distance"] > 0
    scene.set_camera(azimuth=90.0)
    assert scene.camera()["azimuth"] == 90.0
    assert not np.array_equal(front, scene.render("3d", size=SIZE)), "the asymmetric ball turned"
    with pytest.raises(ValueError):
        scene.set_camera(distance=-1.0)
    with pytest.raises(vrsc.SceneError, match="slice view"):
        scene.camera("axial")


def test_a_scene_file_loads_and_renders():
    scene = vrsc.Scene.load(os.path.join(ROOT, "examples", "basic", "scene.toml"))
    assert scene.views == ["3d", "axial"]
    image = scene.render("axial", size=(32, 32))
    assert image.shape == (32, 32, 4) and image[:, :, :3].max() > 0
    with pytest.raises(vrsc.SceneError, match="editing the file"):
        scene.add_view("other")
    with pytest.raises(FileNotFoundError):
        vrsc.Scene.load("no/such/scene.toml")


def test_explain_and_pipeline_name_the_module_lines(sphere):
    scene = vrsc.Scene.from_array(sphere, modules=[TINT])
    text = scene.explain()
    assert "fn tint" in text and "module_1.vrs:3" in text, text[:2000]
    assert "tint" in scene.pipeline()


def test_an_array_written_in_place_is_uploaded_again_on_update(sphere):
    scene = vrsc.Scene.from_array(sphere, tf=[[0, 0], [100, 1]])
    before = scene.render(size=SIZE)
    sphere[sphere.shape[0] // 2 :] = 0
    assert np.array_equal(before, scene.render(size=SIZE)), "the texture is the scene's until told"
    scene.update()
    assert not np.array_equal(before, scene.render(size=SIZE))
    scene.set_volume("volume", ball())
    assert np.array_equal(before, scene.render(size=SIZE))


def test_repr_png_is_a_png(sphere):
    png = vrsc.Scene.from_array(sphere, size=(32, 32))._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError):
        vrsc.encode_png(np.zeros((4, 4, 3), dtype=np.uint8))


def test_described_scenes_are_scene_files(sphere):
    scene = vrsc.Scene()
    scene.add_volume("ct", phantom="head", tf="ct_bone")
    scene.add_volume("ball", sphere, role="additional", tf=[[0, 0], [100, 1]])
    scene.set_render(compositing="dvr", shading=True, lights=["key"])
    scene.add_view("3d", size=[32, 32], camera={"azimuth": 30.0, "elevation": 10.0, "distance": 2.5})
    assert scene.render().shape == (32, 32, 4)
    assert "[[volume]]" in scene.toml() and 'phantom = "head"' in scene.toml()
    with pytest.raises(TypeError, match="unknown keys"):
        scene.add_view("x", colour="red")


def test_an_occlusion_groups_opacity_is_set_from_python():
    scene = vrsc.Scene.load(os.path.join(ROOT, "examples", "liver", "scene.toml"))
    assert scene.occlusion_groups == {"liver_and_applicators": pytest.approx(0.45)}
    before = scene.render("occlusion", size=(96, 96))
    assert scene.pipeline("occlusion").startswith("picture: liver_and_applicators (occlusion 0.45)")
    scene.set_group_opacity("liver_and_applicators", 1.0)
    assert scene.occlusion_groups == {"liver_and_applicators": 1.0}
    after = scene.render("occlusion", size=(96, 96))
    assert not np.array_equal(before, after), "the applicators show whole through the organs"
    with pytest.raises(KeyError, match="no occlusion group `liver`"):
        scene.set_group_opacity("liver", 0.5)
    with pytest.raises(ValueError):
        scene.set_group_opacity("liver_and_applicators", 2.0)


def test_a_views_filter_pass_shows_in_its_map_uniforms_and_picture():
    scene = vrsc.Scene.load(os.path.join(ROOT, "examples", "liver", "scene.toml"))
    assert "filters:\nfilter.setup\n" in scene.pipeline("outlined")
    info = scene.uniforms["edge_threshold"]
    assert info["type"] == "f32" and info["views"] == ["outlined", "organs_outlined"], info
    before = scene.render("outlined", size=(96, 96))
    scene["filter_mix"] = 0.0
    assert scene["filter_mix"] == 0.0
    plain = scene.render("outlined", size=(96, 96))
    assert np.array_equal(plain, scene.render("hidden", size=(96, 96))), "no filters: the view `hidden`"
    assert not np.array_equal(before, plain)
    assert "// ===== the filter pass of view `outlined`" in scene.explain("outlined")


def test_filters_in_a_group_show_in_the_map_and_filter_the_group_only():
    scene = vrsc.Scene.load(os.path.join(ROOT, "examples", "liver", "scene.toml"))
    pipeline = scene.pipeline("organs_outlined")
    assert pipeline.startswith("picture: organs_outlined (depth) [organs, filter std::ssao, filter std::edges]")
    assert "organs_outlined-2.filters:\nfilter.setup\n" in pipeline
    assert "(the filter `organs_outlined-3` of its tree)" in scene.explain("organs_outlined")
    lined = scene.render("organs_outlined", size=(96, 96))
    scene["filter_mix"] = 0.0
    assert np.array_equal(scene.render("organs_outlined", size=(96, 96)), scene.render("hidden", size=(96, 96)))
    assert not np.array_equal(lined, scene.render("hidden", size=(96, 96)))
