# Loads a Wake run's surfaces (`wake surface DIR` or `wake run --surface`) into Blender as
# an animation: one water mesh and the moving bodies' meshes per frame, shown only at
# their frame, the static bodies once, a water material, a camera and a sun.
#
#   blender --python scripts/blender_import.py -- DIR/surface [--material clear|blue|NAME]
#           [--fps N] [--frames A:B] [--render OUT_PREFIX [--samples N]]
#
# --material: "clear" (default: glass-like water), "blue" (tinted water), or the name of a
#   material already in the .blend file you opened (blender my.blend --python ...).
# --fps: Blender's frame rate (default: the run's frame rate from surface.json).
# --frames A:B: only Wake frames A..B (inclusive).
# --render OUT_PREFIX: render the animation with Cycles (960 x 540, --samples N, default
#   64) to OUT_PREFIX####.png (add -b before --python for no window).
# Blender frame 1 is the first Wake frame loaded. Started without a .blend file, the
# start-up scene's cube, camera and light are removed first. Needs Blender 3.x (Debian 12:
# blender).
import json
import os
import sys

import bpy
from mathutils import Vector


def water_material(name="clear"):
    """A water material: "clear", "blue", or an existing material of that name."""
    if name not in ("clear", "blue"):
        if name not in bpy.data.materials:
            raise SystemExit("blender_import: no material named %r in this file" % name)
        return bpy.data.materials[name]
    mat = bpy.data.materials.new("wake_water_" + name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        bsdf = nodes.new("ShaderNodeBsdfPrincipled")
        output = next((n for n in nodes if n.type == "OUTPUT_MATERIAL"), None) or \
            nodes.new("ShaderNodeOutputMaterial")
        mat.node_tree.links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    colour = (0.8, 0.9, 1.0, 1.0) if name == "clear" else (0.2, 0.45, 0.8, 1.0)
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Roughness"].default_value = 0.02
    bsdf.inputs["IOR"].default_value = 1.33
    bsdf.inputs["Transmission"].default_value = 1.0 if name == "clear" else 0.6
    return mat


def apply_water(obj, mat):
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    for poly in obj.data.polygons:
        poly.use_smooth = True


def wake_axes():
    """The empty every imported object hangs from: Wake's +y (up) is Blender's +z."""
    if "wake_axes" in bpy.data.objects:
        return bpy.data.objects["wake_axes"]
    axes = bpy.data.objects.new("wake_axes", None)
    axes.rotation_euler = (1.5707963267948966, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(axes)
    return axes


def to_blender(v):
    """A point in Wake's frame (y up) in Blender's (z up)."""
    return Vector((v[0], -v[2], v[1]))


def import_ply(path, collection):
    before = set(bpy.data.objects)
    bpy.ops.import_mesh.ply(filepath=path)
    (obj,) = [o for o in bpy.data.objects if o not in before]
    for c in obj.users_collection:
        c.objects.unlink(obj)
    collection.objects.link(obj)
    obj.parent = wake_axes()
    return obj


def show_only_at(obj, frame):
    """Visible (viewport and render) at Blender frame `frame` only."""
    for f, hidden in ((frame - 1, True), (frame, False), (frame + 1, True)):
        if f < 0:
            continue
        obj.hide_viewport = hidden
        obj.hide_render = hidden
        obj.keyframe_insert("hide_viewport", frame=f)
        obj.keyframe_insert("hide_render", frame=f)
    for curve in obj.animation_data.action.fcurves:
        for key in curve.keyframe_points:
            key.interpolation = "CONSTANT"


def frame_camera_and_light(manifest, entry):
    """A camera looking at the scene's bounds (Wake's numbers of `entry` and the static
    bodies) from the front-left and above, and a sun."""
    lo = Vector((1e30, 1e30, 1e30))
    hi = -lo
    for m in [entry["fluid"]] + entry["bodies"] + manifest["static_bodies"]:
        if m.get("min") is None:
            continue
        lo = Vector(map(min, lo, m["min"]))
        hi = Vector(map(max, hi, m["max"]))
    centre, size = to_blender((lo + hi) / 2), (hi - lo).length
    cam_data = bpy.data.cameras.new("wake_camera")
    cam = bpy.data.objects.new("wake_camera", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    cam_data.lens = 35.0
    cam.location = centre + Vector((-0.3 * size, -0.75 * size, 1.25 * size))
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (centre - cam.location).to_track_quat("-Z", "Y")
    bpy.context.scene.camera = cam
    sun = bpy.data.objects.new("wake_sun", bpy.data.lights.new("wake_sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (-0.9, 0.3, 0.4)
    bpy.context.scene.collection.objects.link(sun)
    world = bpy.context.scene.world or bpy.data.worlds.new("wake_world")
    bpy.context.scene.world = world
    world.use_nodes = True
    for node in world.node_tree.nodes:
        if node.type == "BACKGROUND":
            node.inputs["Color"].default_value = (0.55, 0.65, 0.8, 1.0)


def load(folder, material="clear", fps=None, first=0, last=None):
    manifest = json.load(open(os.path.join(folder, "surface.json")))
    if not bpy.data.filepath:  # Blender's start-up scene: its cube would hide the run
        for name in ("Cube", "Camera", "Light"):
            if name in bpy.data.objects:
                bpy.data.objects.remove(bpy.data.objects[name], do_unlink=True)
    frames = manifest["frames"][first:None if last is None else last + 1]
    if not frames:
        raise SystemExit("blender_import: no frames to load in " + folder)
    mat = water_material(material)
    root = bpy.data.collections.new("wake_" + (manifest.get("scene") or "run"))
    bpy.context.scene.collection.children.link(root)
    for body in manifest["static_bodies"]:
        import_ply(os.path.join(folder, body["file"]), root).name = body["name"]
    for n, entry in enumerate(frames, start=1):
        water = import_ply(os.path.join(folder, entry["fluid"]["file"]), root)
        water.name = "water_%06d" % entry["frame"]
        apply_water(water, mat)
        show_only_at(water, n)
        for body in entry["bodies"]:
            obj = import_ply(os.path.join(folder, body["file"]), root)
            obj.name = "%s_%06d" % (body["name"], entry["frame"])
            show_only_at(obj, n)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, len(frames)
    if fps is None and len(manifest["frames"]) > 1:
        fps = round(1.0 / (manifest["frames"][1]["time"] - manifest["frames"][0]["time"]))
    scene.render.fps = int(fps or 25)
    frame_camera_and_light(manifest, frames[0])
    return manifest


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not args or args[0].startswith("-"):
        raise SystemExit(__doc__ if __doc__ else "usage: blender --python blender_import.py -- DIR/surface")
    folder, options = args[0], dict(zip(args[1::2], args[2::2]))
    first, last = 0, None
    if "--frames" in options:
        a, _, b = options["--frames"].partition(":")
        first, last = int(a), int(b or a)
    load(folder, options.get("--material", "clear"),
         float(options["--fps"]) if "--fps" in options else None, first, last)
    if "--render" in options:
        bpy.context.scene.render.engine = "CYCLES"
        bpy.context.scene.cycles.use_denoising = False  # Debian's Blender has no denoiser
        bpy.context.scene.cycles.samples = int(options.get("--samples", 64))
        bpy.context.scene.render.resolution_x = 960
        bpy.context.scene.render.resolution_y = 540
        bpy.context.scene.render.filepath = options["--render"]
        bpy.ops.render.render(animation=True)
