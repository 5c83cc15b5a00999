"""The VTK contender: vtkGPUVolumeRayCastMapper in an offscreen EGL window (llvmpipe without a
GPU). Set up per case, then timed frame by frame: Render() and WaitForCompletion()."""

import os
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import vtk  # noqa: E402
from vtk.util import numpy_support  # noqa: E402

import peers_common as common  # noqa: E402

state = {}


def setup(case):
    volume, tf = common.load_prepared(case)
    scale, spacing, origin = common.world_box(case)
    image = vtk.vtkImageData()
    image.SetDimensions(*case["dims"])
    image.SetSpacing(*spacing)
    image.SetOrigin(*origin)
    scalars = numpy_support.numpy_to_vtk(volume.ravel(), deep=True, array_type=vtk.VTK_FLOAT)
    image.GetPointData().SetScalars(scalars)

    mapper = vtk.vtkGPUVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetSampleDistance(case["step"])  # world units: the largest side is 1, as in vrsc
    if case["mode"] == "mip":
        mapper.SetBlendModeToMaximumIntensity()
    else:
        mapper.SetBlendModeToComposite()

    color = vtk.vtkColorTransferFunction()
    opacity = vtk.vtkPiecewiseFunction()
    for i, (r, g, b, a) in enumerate(tf):
        x = (i + 0.5) / len(tf)  # vrsc's entries stand for their texel centres
        color.AddRGBPoint(x, r, g, b)
        opacity.AddPoint(x, a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(case["ref_step"])
    prop.SetInterpolationTypeToLinear()
    prop.SetShade(1 if case["mode"] == "dvr_shaded" else 0)
    prop.SetAmbient(0.3)
    prop.SetDiffuse(0.7)
    prop.SetSpecular(0.3)
    prop.SetSpecularPower(32.0)

    actor = vtk.vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    renderer = vtk.vtkRenderer()
    renderer.SetBackground(0, 0, 0)
    renderer.AddVolume(actor)
    camera = renderer.GetActiveCamera()
    camera.SetPosition(*common.eye_position(case["camera"]))
    camera.SetFocalPoint(0, 0, 0)
    camera.SetViewUp(0, 0, 1)
    camera.SetViewAngle(case["camera"]["fov"])
    renderer.ResetCameraClippingRange()

    window = state.get("window")
    if window is None:
        window = vtk.vtkRenderWindow()
        window.SetOffScreenRendering(1)
        state["window"] = window
    old = state.get("renderer")
    if old is not None:
        window.RemoveRenderer(old)
    window.AddRenderer(renderer)
    window.SetSize(*case["size"])
    state["renderer"] = renderer
    window.Render()
    window.WaitForCompletion()
    return {"ok": True, "gl": window.ReportCapabilities().split("OpenGL renderer string:")[-1].split("\n")[0].strip()}


def frame():
    window = state["window"]
    start = time.perf_counter()
    window.Render()
    window.WaitForCompletion()
    return (time.perf_counter() - start) * 1e3


def timed(request):
    if request.get("warmup", True):
        frame()
    return {"ms": [frame() for _ in range(request["frames"])]}


def image(request):
    window = state["window"]
    window.Render()
    window.WaitForCompletion()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.Update()
    data = grab.GetOutput()
    w, h, _ = data.GetDimensions()
    pixels = numpy_support.vtk_to_numpy(data.GetPointData().GetScalars()).reshape(h, w, -1)
    np.save(request["out"], pixels[::-1, :, :3].copy())  # VTK's rows run bottom to top
    return {"ok": True}


common.serve({"setup": setup, "time": timed, "image": image})
