#!/usr/bin/env python3
"""Build the diffuse room of issue 30 in Blender, export it with
tools/blender_export.py and render it with Cycles: the reference that
tests/blender_cycles.py compares render's picture with.

    /work/bpyenv/bin/python tools/make_blender_reference.py [OUT_DIR] [SAMPLES] [--cameras-only]

OUT_DIR defaults to tests/data/blender, SAMPLES to 1024 (the stored
reference used 512; about 2.5 minutes on two cores). Needs the `bpy`
module (Blender 4.2 or later as a Python module); the test suite does not:
it reads what this writes, which is committed:
    diffuse_room.obj / .mtl / .camera   blender_export.export_scene's output
    diffuse_room_cycles.exr             Cycles' picture, one part, half
                                        float, ZIP: R, G, B (linear
                                        radiance) and `object` (each pixel's
                                        object pass index, INDEX below, 0 =
                                        none); Blender's multilayer EXR
                                        turned into it by oiiotool
    startup.camera                      the camera of Blender's factory
                                        startup scene (1920 x 1080, 50 mm)
    level_portrait.camera               a level camera (rotation 90 0 0)
                                        at 1080 x 1920, 35 mm: sensor fit
                                        AUTO fits the height
(tests/blender_export_camera.py checks the three .camera files against
the closed form of the conversion.)

The room (Blender axes, Z up, metres): x in [-2, 2], y in [-2, 2], z in
[0, 3]; six walls as separate objects facing into the room (floor and walls
Kd 0.7 grey, left wall red, right wall green, ceiling 0.75 grey) with a
1 x 1 m hole in the ceiling, centred at (0, 0.5), filled by the light (Kd 0, emission colour
(1, 0.85, 0.7) x strength 10: Ke 10 8.5 7, the emitted radiance), flush
with it so that the light's back side, which Cycles also lights, faces out
of the closed room; a 0.9 m box (no bottom) on the floor, turned 25
degrees. The camera stands inside at (0, -1.85, 1.4), 20 mm lens on a
36 mm sensor, turned 10 degrees left and 8 up, at 160 x 120 pixels: it
sees the light, four walls, the floor and the box.

Cycles renders diffuse light only, as radiosity does: the export's
Principled BSDFs are replaced by Diffuse BSDFs of the same colour (roughness
0: Lambert) plus an Emission shader of the same colour and strength; 64
diffuse bounces, no glossy, transmission or volume bounces, no light
clamping, black world, box pixel filter of 1 pixel (render's supersampling
is a box), no denoising, Standard view transform, exposure 0 (the EXR holds
scene-linear radiance either way).
"""
import math
import os
import subprocess
import sys

import bpy
import bmesh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_export  # noqa: E402

X0, X1, Y0, Y1, Z0, Z1 = -2.0, 2.0, -2.0, 2.0, 0.0, 3.0
LIGHT_HALF = 0.5
LIGHT_Y = 0.5  # the light's centre (x = 0)
EMISSION = (1.0, 0.85, 0.7)
STRENGTH = 10.0
WIDTH, HEIGHT = 160, 120

# Pass indices: the test's masks.
INDEX = {"Floor": 1, "Ceiling": 2, "Light": 3, "BackWall": 4, "FrontWall": 5, "LeftWall": 6, "RightWall": 7,
         "Box": 8}


def material(name, colour, emission=None, strength=0.0):
    m = bpy.data.materials.new(name)
    if hasattr(m, "use_nodes") and not m.use_nodes:
        try:
            m.use_nodes = True  # always on from 5.0, needed before
        except Exception:
            pass
    bsdf = m.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    if emission:
        bsdf.inputs["Emission Color"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = strength
    return m


def mesh_object(name, quads, mat):
    """An object from quads given as 4 corners each, wound so that the
    normal (right-hand rule) points where the face is seen from."""
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    verts = {}
    for q in quads:
        vs = []
        for p in q:
            key = tuple(round(c, 9) for c in p)
            if key not in verts:
                verts[key] = bm.verts.new(key)
            vs.append(verts[key])
        bm.faces.new(vs)
    bm.to_mesh(me)
    bm.free()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    me.materials.append(mat)
    obj.pass_index = INDEX[name]
    return obj


def build_room():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    grey = material("Grey", (0.7, 0.7, 0.7))
    ceiling = material("Ceiling", (0.75, 0.75, 0.75))
    red = material("Red", (0.65, 0.1, 0.08))
    green = material("Green", (0.15, 0.5, 0.12))
    light = material("Light", (0.0, 0.0, 0.0), EMISSION, STRENGTH)
    yellow = material("Box", (0.7, 0.6, 0.3))
    # Room faces point into the room.
    mesh_object("Floor", [[(X0, Y0, Z0), (X1, Y0, Z0), (X1, Y1, Z0), (X0, Y1, Z0)]], grey)
    h, ly = LIGHT_HALF, LIGHT_Y
    ring = [[(X0, Y0, Z1), (X0, Y1, Z1), (-h, ly + h, Z1), (-h, ly - h, Z1)],
            [(X0, Y1, Z1), (X1, Y1, Z1), (h, ly + h, Z1), (-h, ly + h, Z1)],
            [(X1, Y1, Z1), (X1, Y0, Z1), (h, ly - h, Z1), (h, ly + h, Z1)],
            [(X1, Y0, Z1), (X0, Y0, Z1), (-h, ly - h, Z1), (h, ly - h, Z1)]]
    mesh_object("Ceiling", ring, ceiling)
    mesh_object("Light", [[(-h, ly - h, Z1), (-h, ly + h, Z1), (h, ly + h, Z1), (h, ly - h, Z1)]], light)
    mesh_object("BackWall", [[(X0, Y1, Z0), (X1, Y1, Z0), (X1, Y1, Z1), (X0, Y1, Z1)]], grey)
    mesh_object("FrontWall", [[(X1, Y0, Z0), (X0, Y0, Z0), (X0, Y0, Z1), (X1, Y0, Z1)]], grey)
    mesh_object("LeftWall", [[(X0, Y0, Z0), (X0, Y1, Z0), (X0, Y1, Z1), (X0, Y0, Z1)]], red)
    mesh_object("RightWall", [[(X1, Y1, Z0), (X1, Y0, Z0), (X1, Y0, Z1), (X1, Y1, Z1)]], green)
    # The box: four sides and a top, facing out, turned about its centre.
    s, cx, cy, turn = 0.45, 0.5, 0.6, math.radians(25)

    def corner(dx, dy, z):
        c, n = math.cos(turn), math.sin(turn)
        return (cx + c * dx - n * dy, cy + n * dx + c * dy, z)

    t = 2 * s
    b = [corner(-s, -s, 0), corner(s, -s, 0), corner(s, s, 0), corner(-s, s, 0)]
    u = [corner(-s, -s, t), corner(s, -s, t), corner(s, s, t), corner(-s, s, t)]
    sides = [[b[k], b[(k + 1) % 4], u[(k + 1) % 4], u[k]] for k in range(4)]
    mesh_object("Box", sides + [u], yellow)
    # The camera, inside, looking towards +y (the back wall).
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 20.0
    cam_data.sensor_width = 36.0
    cam_data.sensor_fit = "AUTO"
    cam = bpy.data.objects.new("Camera", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    cam.location = (0.0, -1.85, 1.4)
    cam.rotation_euler = (math.radians(98), 0.0, math.radians(10))
    scene = bpy.context.scene
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    return scene


def diffuse_only(scene):
    """Principled -> Diffuse (+ Emission) with the same values, for Cycles."""
    for mat in bpy.data.materials:
        nt = mat.node_tree
        bsdf = nt.nodes.get("Principled BSDF")
        out = nt.nodes.get("Material Output")
        colour = tuple(bsdf.inputs["Base Color"].default_value)
        emission = tuple(bsdf.inputs["Emission Color"].default_value)
        strength = bsdf.inputs["Emission Strength"].default_value
        diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = colour
        diffuse.inputs["Roughness"].default_value = 0.0
        shader = diffuse.outputs["BSDF"]
        if strength > 0:
            em = nt.nodes.new("ShaderNodeEmission")
            em.inputs["Color"].default_value = emission
            em.inputs["Strength"].default_value = strength
            add = nt.nodes.new("ShaderNodeAddShader")
            nt.links.new(diffuse.outputs["BSDF"], add.inputs[0])
            nt.links.new(em.outputs["Emission"], add.inputs[1])
            shader = add.outputs["Shader"]
        nt.links.new(shader, out.inputs["Surface"])
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if hasattr(world, "use_nodes"):
        try:
            world.use_nodes = False
        except Exception:
            pass
    scene.world = world


def render_cycles(scene, path, samples):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 64
    c.diffuse_bounces = 64
    c.glossy_bounces = 0
    c.transmission_bounces = 0
    c.volume_bounces = 0
    c.transparent_max_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.caustics_reflective = False
    c.caustics_refractive = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.seed = 1
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.view_layers[0].use_pass_object_index = True
    s = scene.render.image_settings
    if hasattr(s, "media_type"):  # Blender 5.0 and later
        s.media_type = "MULTI_LAYER_IMAGE"
    s.file_format = "OPEN_EXR_MULTILAYER"
    s.color_depth = "16"
    s.exr_codec = "ZIP"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def write_cameras(out_dir):
    """The cameras of two more scenes, sidecars only."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    with open(os.path.join(out_dir, "startup.camera"), "w") as f:
        f.write(blender_export.camera_lines(scene))
    cam = scene.camera
    cam.location = (1.0, -8.0, 1.5)
    cam.rotation_euler = (math.radians(90), 0.0, 0.0)
    cam.data.lens = 35.0
    scene.render.resolution_x, scene.render.resolution_y = 1080, 1920
    with open(os.path.join(out_dir, "level_portrait.camera"), "w") as f:
        f.write(blender_export.camera_lines(scene))


def main(argv):
    here = os.path.dirname(os.path.abspath(__file__))
    cameras_only = "--cameras-only" in argv
    args = [a for a in argv[1:] if not a.startswith("--")]
    out_dir = args[0] if args else os.path.join(here, "..", "tests", "data", "blender")
    samples = int(args[1]) if len(args) > 1 else 1024
    write_cameras(out_dir)
    if cameras_only:
        return 0
    scene = build_room()
    camera = blender_export.export_scene(os.path.join(out_dir, "diffuse_room.obj"))
    print("wrote", camera)
    diffuse_only(scene)
    full = os.path.abspath(os.path.join(out_dir, "diffuse_room_cycles_full.exr"))
    render_cycles(scene, full, samples)
    # One part, the channels the test reads (exrread.py reads one part).
    subprocess.run(["oiiotool", full, "--subimage", "0", "--ch",
                    "R=ViewLayer.Combined.R,G=ViewLayer.Combined.G,B=ViewLayer.Combined.B", full, "--subimage", "1",
                    "--ch", "object=ViewLayer.Object Index.X", "--chappend", "-d", "half", "--compression", "zip",
                    "--attrib", "rad:reference", f"Cycles, {samples} samples, diffuse only "
                    "(tools/make_blender_reference.py)",
                    "-o", os.path.join(out_dir, "diffuse_room_cycles.exr")], check=True)
    os.remove(full)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
