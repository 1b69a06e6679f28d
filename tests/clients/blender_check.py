# Blender opens Wake's surfaces: run headless by CTest (tests/CMakeLists.txt),
#   blender -b --factory-startup --python blender_check.py -- SURFACE_DIR FRAME [PICTURE.png]
# Imports frame FRAME's water mesh (PLY), a moving body's mesh (PLY), the static bodies and
# the water's level set (.vdb, as a volume), and checks vertex and face counts and bounds
# against Wake's own numbers in SURFACE_DIR/surface.json. With PICTURE, renders the frame
# (Cycles, a few samples) with scripts/blender_import.py's water material. Exit 0 = pass.
import json
import os
import sys

import bpy


def fail(message):
    print("blender_check: FAIL: " + message, flush=True)
    sys.exit(1)


def bounds(obj):
    """World bounds of a mesh object's vertices."""
    xs = [obj.matrix_world @ v.co for v in obj.data.vertices]
    lo = [min(p[i] for p in xs) for i in range(3)]
    hi = [max(p[i] for p in xs) for i in range(3)]
    return lo, hi


def check_mesh(obj, entry, what):
    mesh = obj.data
    if len(mesh.vertices) != entry["vertices"]:
        fail("%s: %d vertices in Blender, %d in surface.json" % (what, len(mesh.vertices), entry["vertices"]))
    if len(mesh.polygons) != entry["triangles"]:
        fail("%s: %d faces in Blender, %d in surface.json" % (what, len(mesh.polygons), entry["triangles"]))
    lo, hi = bounds(obj)
    for i in range(3):
        if abs(lo[i] - entry["min"][i]) > 1e-5 or abs(hi[i] - entry["max"][i]) > 1e-5:
            fail("%s: bounds %s..%s differ from %s..%s" % (what, lo, hi, entry["min"], entry["max"]))
    print("blender_check: %s: %d vertices, %d faces, bounds match" % (what, len(mesh.vertices), len(mesh.polygons)))


def import_ply(path):
    before = set(bpy.data.objects)
    bpy.ops.import_mesh.ply(filepath=path)
    new = [o for o in bpy.data.objects if o not in before]
    if len(new) != 1:
        fail("importing %s made %d objects" % (path, len(new)))
    return new[0]


argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) < 2:
    fail("usage: blender -b --python blender_check.py -- SURFACE_DIR FRAME [PICTURE.png]")
folder, frame = argv[0], int(argv[1])
picture = argv[2] if len(argv) > 2 else None
manifest = json.load(open(os.path.join(folder, "surface.json")))
entry = manifest["frames"][frame]

for obj in list(bpy.data.objects):  # an empty scene
    bpy.data.objects.remove(obj, do_unlink=True)

water = import_ply(os.path.join(folder, entry["fluid"]["file"]))
check_mesh(water, entry["fluid"], "water")
if not entry["bodies"]:
    fail("frame %d has no moving body to check" % frame)
for body in entry["bodies"]:
    check_mesh(import_ply(os.path.join(folder, body["file"])), body, "body " + body["name"])
for body in manifest["static_bodies"]:
    check_mesh(import_ply(os.path.join(folder, body["file"])), body, "static body " + body["name"])

# The level set as a volume: its grid "fluid" loads and its bounds hold the water mesh.
bpy.ops.object.volume_import(filepath=os.path.join(folder, entry["fluid"]["vdb"]))
volume = bpy.context.active_object
if volume is None or volume.type != "VOLUME":
    fail("the .vdb did not import as a volume")
volume.data.grids.load()
names = [g.name for g in volume.data.grids]
if "fluid" not in names:
    fail("the .vdb's grids are %s, not 'fluid'" % names)
depsgraph = bpy.context.evaluated_depsgraph_get()
box = [volume.evaluated_get(depsgraph).matrix_world @ __import__("mathutils").Vector(c)
       for c in volume.evaluated_get(depsgraph).bound_box]
vlo = [min(c[i] for c in box) for i in range(3)]
vhi = [max(c[i] for c in box) for i in range(3)]
voxel = manifest["particle_radius"] * manifest["settings"]["voxel_factor"]
for i in range(3):
    if vlo[i] > entry["fluid"]["min"][i] + voxel or vhi[i] < entry["fluid"]["max"][i] - voxel:
        fail("the volume's bounds %s..%s do not hold the water mesh %s..%s"
             % (vlo, vhi, entry["fluid"]["min"], entry["fluid"]["max"]))
print("blender_check: volume: grid 'fluid', bounds hold the water mesh")

if picture:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
    import blender_import
    volume.hide_render = True
    for obj in bpy.data.objects:
        if obj.type == "MESH":
            obj.parent = blender_import.wake_axes()
    blender_import.apply_water(water, blender_import.water_material("blue"))
    blender_import.frame_camera_and_light(manifest, entry)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 48
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.filepath = picture
    bpy.ops.render.render(write_still=True)
    if not os.path.isfile(picture):
        fail("no picture written")
    print("blender_check: picture " + picture)
print("blender_check: PASS", flush=True)
