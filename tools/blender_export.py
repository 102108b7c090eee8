#!/usr/bin/env python3
"""Export a Blender scene for radiosity: the OBJ, its MTL and the camera
sidecar `<scene>.camera` together (issue 30).

Inside Blender (any 4.2 or later):
    blender --background scene.blend --python tools/blender_export.py -- out/scene.obj
With Blender as a Python module (`pip install bpy`):
    python tools/blender_export.py [--blend scene.blend] out/scene.obj
From a script:
    import blender_export; blender_export.export_scene("out/scene.obj")

then
    formfactor out/scene.obj --ke radiance -o scene.ff
    solve scene.ff -o scene.rad
    render scene.rad -o scene.exr      # the sidecar gives camera and size

What it writes:
  - scene.obj / scene.mtl: Blender's own OBJ exporter (bpy.ops.wm.obj_export)
    with the settings scenes/README.md recommends: default axes (forward -Z,
    up Y: the OBJ is Y-up), materials, normals (they only check the
    winding), no UVs, modifiers applied as they render, quads kept.
    Emission is written as Ke = emission colour x strength: the emitted
    radiance, so give formfactor `--ke radiance`.
  - scene.camera: the scene's active camera, converted the way the OBJ is:
    Blender's (x, y, z), Z up, becomes the OBJ's (x, z, -y), Y up. The
    lines: eye (the camera's position), look_at (a point one unit ahead
    along its view), up (its local +Y), fov_y (the vertical field of view
    from focal length, sensor size and sensor fit at the render's aspect
    ratio, as Blender's own projection matrix has it), width and height
    (the render resolution times its percentage), which render uses when
    --width and --height are not given.

It refuses (exit 1, saying why) a scene without a camera or with a camera
render cannot imitate (orthographic, panoramic), and warns of what does
not carry over: lens shift (render centres the view), non-square pixels,
lamp objects (only emissive surfaces light a radiosity scene), materials
without a Principled BSDF, base colours of 1 (formfactor --clamp-rho 0.99)
and a scene with nothing emissive.

tools/make_blender_reference.py exported tests/data/blender/diffuse_room.*
(and two more cameras) with this module and rendered the room's Cycles
reference; tests/blender_export_camera.py checks those cameras against the
closed form of the conversion, tests/blender_cycles.py the picture.
"""
import math
import os
import sys

import bpy
from mathutils import Vector


# A direction's components below this (float32 rounding of a rotation
# matrix) are 0.
DIRECTION_SNAP = 1e-6


def to_obj(v):
    """Blender's Z-up world coordinates -> the exported OBJ's Y-up ones
    (the exporter's defaults, forward -Z, up Y)."""
    return (v[0], v[2], -v[1])


def render_size(scene):
    """The render's picture size in pixels: resolution x percentage."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * scale)), max(1, int(r.resolution_y * scale))


def camera_lines(scene, camera=None, warn=print):
    """The sidecar's text for `camera` (default: the scene's active one)."""
    cam = camera or scene.camera
    if cam is None or cam.type != "CAMERA":
        raise ValueError("the scene has no camera: add one (Add > Camera) and make it active (Ctrl Numpad 0)")
    data = cam.data
    if data.type != "PERSP":
        raise ValueError(f"camera '{cam.name}' is {data.type.lower()}: render has a pinhole (perspective) camera only")
    width, height = render_size(scene)
    r = scene.render
    if r.pixel_aspect_x != r.pixel_aspect_y:
        warn(f"warning: pixel aspect {r.pixel_aspect_x}:{r.pixel_aspect_y} is not square; render's pixels are")
    if data.shift_x or data.shift_y:
        warn(f"warning: camera '{cam.name}' has lens shift ({data.shift_x}, {data.shift_y}); render's view is "
             "centred, so the picture is framed differently")
    # Blender's own projection at this size: sensor fit (AUTO, HORIZONTAL,
    # VERTICAL), sensor size and focal length, without re-deriving them.
    depsgraph = bpy.context.evaluated_depsgraph_get()
    proj = cam.calc_matrix_camera(depsgraph, x=width, y=height,
                                  scale_x=r.pixel_aspect_x, scale_y=r.pixel_aspect_y)
    fov_y = math.degrees(2.0 * math.atan(1.0 / proj[1][1]))
    m = cam.matrix_world

    def direction(v):
        # Blender's matrices are float32: cos(90 degrees) is 4e-8 there.
        # Snapping that to 0 keeps a level camera's up exactly +y.
        v = (m.to_3x3() @ Vector(v)).normalized()
        return Vector([c if abs(c) > DIRECTION_SNAP else 0.0 for c in v]).normalized()

    eye = m.translation
    forward = direction((0.0, 0.0, -1.0))  # a camera looks along its local -Z, its local +Y up
    up = direction((0.0, 1.0, 0.0))
    look_at = eye + forward

    def fmt(v):  # float32 values: 7 significant digits hold them
        return " ".join(f"{c:.7g}" if c != 0 else "0" for c in to_obj(v))

    return (f"# camera '{cam.name}' of {bpy.data.filepath or 'an unsaved scene'}, written by "
            "tools/blender_export.py\n"
            "# Blender's (x, y, z) Z-up as the OBJ's (x, z, -y) Y-up\n"
            f"eye {fmt(eye)}\n"
            f"look_at {fmt(look_at)}\n"
            f"up {fmt(up)}\n"
            f"fov_y {fov_y:.7g}\n"
            f"width {width}\n"
            f"height {height}\n")


def check_scene(scene, warn=print):
    """Warnings for what does not carry over into a radiosity scene."""
    lamps = [o.name for o in scene.objects if o.type == "LIGHT"]
    if lamps:
        warn(f"warning: lamp objects are not exported ({', '.join(lamps)}): only emissive surfaces light a "
             "radiosity scene; give a mesh an Emission colour and strength instead")
    emissive = False
    for mat in bpy.data.materials:
        if not mat.users:
            continue
        nodes = mat.node_tree.nodes if mat.node_tree else []
        bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is None:
            warn(f"warning: material '{mat.name}' has no Principled BSDF: the exporter writes its viewport "
                 "colour as Kd and no Ke")
            continue
        base = bsdf.inputs["Base Color"].default_value
        if max(base[:3]) >= 1.0:
            warn(f"warning: material '{mat.name}' has base colour {tuple(round(c, 3) for c in base[:3])}: "
                 "reflectance 1 is refused; give formfactor --clamp-rho 0.99 or darken it")
        strength = bsdf.inputs["Emission Strength"].default_value
        colour = bsdf.inputs["Emission Color"].default_value
        if strength > 0 and max(colour[:3]) > 0:
            emissive = True
    if not emissive:
        warn("warning: no material emits (Emission Strength > 0): the radiosity image will be black")


def export_scene(obj_path, scene=None, camera=None, warn=print):
    """Writes obj_path, its .mtl and its .camera; returns the camera's path."""
    scene = scene or bpy.context.scene
    check_scene(scene, warn)
    text = camera_lines(scene, camera, warn)  # before writing anything: a scene without a camera fails here
    obj_path = os.path.abspath(obj_path)
    os.makedirs(os.path.dirname(obj_path), exist_ok=True)
    bpy.ops.wm.obj_export(filepath=obj_path, export_selected_objects=False, forward_axis="NEGATIVE_Z",
                          up_axis="Y", global_scale=1.0, apply_modifiers=True, export_eval_mode="DAG_EVAL_RENDER",
                          export_uv=False, export_normals=True, export_materials=True,
                          export_triangulated_mesh=False, export_curves_as_nurbs=False)
    camera_path = os.path.splitext(obj_path)[0] + ".camera"
    with open(camera_path, "w", encoding="ascii") as f:
        f.write(text)
    return camera_path


def main(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else argv[1:]
    blend = None
    if len(args) >= 2 and args[0] == "--blend":
        blend, args = args[1], args[2:]
    if len(args) != 1 or args[0].startswith("-"):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    if blend:
        bpy.ops.wm.open_mainfile(filepath=blend)
    try:
        camera_path = export_scene(args[0], warn=lambda m: print(m, file=sys.stderr))
    except ValueError as e:
        print(f"blender_export: {e}", file=sys.stderr)
        return 1
    obj = os.path.abspath(args[0])
    stem = os.path.splitext(os.path.basename(obj))[0]
    print(f"wrote {obj}, its .mtl and {camera_path}\nnext:\n"
          f"  formfactor {obj} --ke radiance -o {stem}.ff\n"
          f"  solve {stem}.ff -o {stem}.rad\n"
          f"  render {stem}.rad -o {stem}.exr")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
