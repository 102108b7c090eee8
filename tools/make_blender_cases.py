#!/usr/bin/env python3
"""Build the Blender scenes of issue 30 (items 1, 2, 3, 7, 8) and export
them with tools/blender_export.py: the cases a Blender user meets on the way
from the modeller to a picture, each of which must give a right picture or
stop with a message naming the cause and the remedy.

    /work/bpyenv/bin/python tools/make_blender_cases.py [OUT_DIR]

OUT_DIR defaults to tests/data/blender/cases. Needs the `bpy` module
(written against bpy 5.0); the test suite (tests/blender_cases.sh) does not:
it reads the files this writes, which are committed. Each scene is
NAME.obj / NAME.mtl / NAME.camera.

Blender axes, Z up, metres. The room is a primitive cube scaled to
4 x 4 x 3 m (z in [0, 3]); "inward" rooms have their normals flipped (Mesh >
Normals > Flip), "outward" ones are the cube as Blender makes it, which is
what a user who models a room from the default cube exports. The light is
a separate 1 x 1 m plane object 'Light' facing down (emission strength 10:
Ke is the radiance, so formfactor --ke radiance); the objects are two boxes
and a UV sphere resting on the floor. The camera stands inside.

    room_inward_objects    the right room with objects (the reference case)
    room_outward_objects   the same room, cube unflipped (items 1, 2)
    room_outward_empty     the unflipped room with only its light (item 1)
    default_scene          Blender's factory startup scene: cube, lamp,
                           camera (item 3)
    panel_on_ceiling       inward room, the light snapped onto the ceiling:
                           coplanar with it, facing the same way (item 7)
    panel_below_ceiling    a 5 m inward room, the light 1 cm below its
                           ceiling (item 7)
    sphere_smooth          inward room with a UV sphere, Shade Smooth (item 8)
    suzanne_smooth         inward room with Suzanne, Subdivision Surface
                           level 1, Shade Smooth (item 8: real non-planar quads)
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_export  # noqa: E402
import make_corpus_blender as corpus  # noqa: E402


def add_room(size, inward):
    sx, sy, sz = size
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, sz / 2))
    room = corpus.active()
    room.name = "Room"
    room.scale = size
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    room.data.materials.append(corpus.material("Wall", (0.7, 0.7, 0.7)))
    if inward:
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.flip_normals()
        bpy.ops.object.mode_set(mode="OBJECT")
    return room


def add_light(z, size=1.0):
    """A plane facing down (-z) at height z."""
    bpy.ops.mesh.primitive_plane_add(size=size, location=(0, 0, z), rotation=(math.pi, 0, 0))
    light = corpus.active()
    light.name = "Light"
    light.data.materials.append(corpus.material("Emitter", (0.8, 0.8, 0.8), (1.0, 0.9, 0.8), 10.0))
    return light


def add_objects():
    red = corpus.material("Red", (0.7, 0.15, 0.1))
    corpus.add_box("BoxTall", (0.6, 0.6, 1.2), (-0.8, 0.6, 0.6), red)
    corpus.add_box("BoxLow", (0.7, 0.7, 0.5), (0.9, 0.3, 0.25), corpus.material("Blue", (0.1, 0.2, 0.7)))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=0.35, location=(0.2, -0.6, 0.35))
    sphere = corpus.active()
    sphere.name = "Sphere"
    sphere.data.materials.append(corpus.material("Green", (0.1, 0.6, 0.2)))


def add_camera(room_size):
    sx, sy, sz = room_size
    bpy.ops.object.camera_add(location=(0, -sy / 2 + 0.1, sz / 2), rotation=(math.radians(90), 0, 0))
    cam = corpus.active()
    cam.data.lens = 18
    scene = bpy.context.scene
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 160, 120, 100


def export(out_dir, name):
    path = os.path.join(out_dir, name + ".obj")
    blender_export.export_scene(path, warn=lambda m: print(f"{name}: {m}"))
    print("wrote", path, os.path.getsize(path), "bytes")


def build(out_dir, name):
    corpus.reset()
    room = (4.0, 4.0, 3.0)
    if name == "default_scene":
        bpy.ops.wm.read_factory_settings(use_empty=False)
        export(out_dir, name)
        return
    if name == "panel_below_ceiling":
        room = (5.0, 5.0, 5.0)
    add_room(room, inward=not name.startswith("room_outward"))
    if name == "panel_on_ceiling":
        add_light(room[2])
    elif name == "panel_below_ceiling":
        add_light(room[2] - 0.01)
    else:
        add_light(room[2] - 0.5)
    if name.endswith("_objects"):
        add_objects()
    elif name == "sphere_smooth":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.6, location=(0, 0.3, 0.6))
        bpy.ops.object.shade_smooth()
        corpus.active().data.materials.append(corpus.material("Green", (0.1, 0.6, 0.2)))
    elif name == "suzanne_smooth":
        bpy.ops.mesh.primitive_monkey_add(size=1.2, location=(0, 0.3, 0.8))
        suzanne = corpus.active()
        subsurf = suzanne.modifiers.new("Subdivision", "SUBSURF")
        subsurf.levels = subsurf.render_levels = 1
        bpy.ops.object.shade_smooth()
        suzanne.data.materials.append(corpus.material("Clay", (0.6, 0.5, 0.4)))
    add_camera(room)
    export(out_dir, name)


NAMES = ["room_inward_objects", "room_outward_objects", "room_outward_empty", "default_scene",
         "panel_on_ceiling", "panel_below_ceiling", "sphere_smooth", "suzanne_smooth"]

if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "tests", "data",
                                                               "blender", "cases")
    os.makedirs(out, exist_ok=True)
    for n in NAMES:
        build(out, n)
