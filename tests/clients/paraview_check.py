# ParaView draws Wake's output: run by CTest under Xvfb (tests/CMakeLists.txt),
#   tests/clients/with_xvfb.sh pvpython paraview_check.py RUN_DIR SCENE PICTURE.png
# Opens RUN_DIR/SCENE.xdmf with ParaView's own reader and checks, at several times, the
# blocks (fluid, each body, the surface), the fluid's cell and point counts and arrays
# against Wake's numbers (RUN_DIR/surface/surface.json); then renders the default
# representation of the fluid alone (the particles, as 2-pixel points) and checks that it
# covers a plausible share of the pixels, and
# writes PICTURE (the fluid coloured by speed, the bodies and the water surface). Exit 0
# = pass.
import json
import os
import sys

from paraview import servermanager
from paraview.simple import (ColorBy, ExtractCellsByType, GetActiveViewOrCreate, GetDisplayProperties,
                             Hide, OpenDataFile, Render, ResetCamera, SaveScreenshot, Show)
from vtkmodules.vtkIOImage import vtkPNGReader


def fail(message):
    print("paraview_check: FAIL: " + message, flush=True)
    sys.exit(1)


def leaves(data):
    """The datasets of a composite's leaves, in document order: the XDMF's temporal
    collections (fluid, the bodies by name, surface; ParaView's Xdmf3 readers do not keep
    their names)."""
    out = []
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


def covered(png, background):
    """Share of the pixels of `png` that differ from the background colour."""
    reader = vtkPNGReader()
    reader.SetFileName(png)
    reader.Update()
    image = reader.GetOutput()
    scalars = image.GetPointData().GetScalars()
    n = image.GetNumberOfPoints()
    comps = scalars.GetNumberOfComponents()
    differ = 0
    for i in range(n):
        px = [scalars.GetComponent(i, c) for c in range(3)]
        if max(abs(px[c] - background[c]) for c in range(3)) > 24:
            differ += 1
    return differ / float(n)


if len(sys.argv) != 4:
    fail("usage: pvpython paraview_check.py RUN_DIR SCENE PICTURE.png")
run_dir, scene, picture = sys.argv[1:]
manifest = json.load(open(os.path.join(run_dir, "surface", "surface.json")))
frames = manifest["frames"]
reader = OpenDataFile(os.path.join(run_dir, scene + ".xdmf"))
times = list(reader.TimestepValues)
if len(times) != len(frames):
    fail("%d time steps in ParaView, %d frames in surface.json" % (len(times), len(frames)))
expected_bodies = len(frames[0]["bodies"]) + len(manifest["static_bodies"])
for k in sorted({0, len(frames) // 2, len(frames) - 1}):
    entry = frames[k]
    if abs(times[k] - entry["time"]) > 1e-9:
        fail("time step %d is t = %g, surface.json says %g" % (k, times[k], entry["time"]))
    reader.UpdatePipeline(times[k])
    parts = leaves(servermanager.Fetch(reader))
    if len(parts) != 2 + expected_bodies:
        fail("t = %g: %d blocks, expected fluid, %d bodies and surface"
             % (times[k], len(parts), expected_bodies))
    fluid, surface = parts[0], parts[-1]
    names = sorted([b["name"] for b in entry["bodies"]] + [b["name"] for b in manifest["static_bodies"]])
    named = dict(zip(["body_" + n for n in names], parts[1:-1]))
    n = entry["particles"]
    if fluid.GetNumberOfPoints() != n or fluid.GetNumberOfCells() < 1:
        fail("t = %g: fluid has %d points, %d cells; Wake wrote %d particles"
             % (times[k], fluid.GetNumberOfPoints(), fluid.GetNumberOfCells(), n))
    drawn = sum(fluid.GetCell(c).GetNumberOfPoints() for c in range(fluid.GetNumberOfCells()))
    if drawn != n:
        fail("t = %g: the fluid's cells hold %d points of %d" % (times[k], drawn, n))
    arrays = {fluid.GetPointData().GetArrayName(i) for i in range(fluid.GetPointData().GetNumberOfArrays())}
    if not {"velocity", "density", "pressure", "id"} <= arrays:
        fail("t = %g: fluid arrays %s" % (times[k], sorted(arrays)))
    rho = fluid.GetPointData().GetArray("density").GetRange()
    # Every particle has a density (free spray may be far below rest), none is compressed
    # anywhere near twice the rest density (1000 kg/m^3 in the scenes checked here).
    if not (0 < rho[0] <= rho[1] < 2000):
        fail("t = %g: density range %s" % (times[k], rho))
    if surface.GetNumberOfCells() != entry["fluid"]["triangles"] or \
       surface.GetNumberOfPoints() != entry["fluid"]["vertices"]:
        fail("t = %g: surface %d points %d cells; Wake wrote %d vertices %d triangles"
             % (times[k], surface.GetNumberOfPoints(), surface.GetNumberOfCells(),
                entry["fluid"]["vertices"], entry["fluid"]["triangles"]))
    for body in entry["bodies"]:
        part = named.get("body_" + body["name"])
        if part is None or part.GetNumberOfCells() != body["triangles"]:
            fail("t = %g: body %s has %d cells, Wake wrote %d triangles"
                 % (times[k], body["name"], part.GetNumberOfCells() if part else -1,
                    body["triangles"]))
    print("paraview_check: t = %g: fluid %d particles (%d cells), %d bodies, surface %d triangles"
          % (times[k], n, fluid.GetNumberOfCells(), len(parts) - 2, surface.GetNumberOfCells()))

# The default representation of the fluid alone must show: a plausible share of pixels.
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [640, 360]
view.Background = [1.0, 1.0, 1.0]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
view.OrientationAxesVisibility = 0
view.ViewTime = times[-1]
fluid_only = ExtractCellsByType(Input=reader)
fluid_only.CellTypes = ["Polyvertex"]
Show(fluid_only, view)
ResetCamera(view)
Render(view)
probe = picture + ".fluid.png"
SaveScreenshot(probe, view, ImageResolution=[640, 360])
share = covered(probe, (255, 255, 255))
os.remove(probe)
# ParaView's default representation draws each particle (a vertex of the Polyvertex cell)
# as a point of 2 x 2 pixels: at least half of them must show (the rest may hide behind
# one another), and the fluid must not fill the picture.
n = frames[-1]["particles"]
print("paraview_check: the fluid covers %.2f %% of the picture (%d particles)" % (100 * share, n))
if not (0.5 * n / (640.0 * 360.0) < share < 0.9):
    fail("the fluid covers %.2f %% of the picture, %d particles" % (100 * share, n))
Hide(fluid_only, view)

# The picture: the bodies and the water surface see-through, the particles coloured by
# speed on top.
everything = Show(reader, view)
everything.Opacity = 0.3
particles = Show(fluid_only, view)
ColorBy(particles, ("POINTS", "velocity", "Magnitude"))
particles.PointSize = 4
particles.SetScalarBarVisibility(view, False)
ResetCamera(view)
camera = view.GetActiveCamera()
camera.Elevation(30)
camera.Azimuth(-30)
ResetCamera(view)
Render(view)
SaveScreenshot(picture, view, ImageResolution=[640, 360])
if not os.path.isfile(picture):
    fail("no picture written")
print("paraview_check: PASS", flush=True)
