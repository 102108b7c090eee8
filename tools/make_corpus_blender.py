#!/usr/bin/env python3
"""Build the Blender part of the mesh corpus (tests/data/corpus/) with
Blender's own operators and OBJ exporter.

    python3 -m venv /work/bpyenv && /work/bpyenv/bin/pip install bpy
    /work/bpyenv/bin/python tools/make_corpus_blender.py [OUT_DIR]

OUT_DIR defaults to tests/data/corpus. Needs the `bpy` module (Blender as a
Python module; written against bpy 5.0, also meant for 4.2+); the test
suite does not: it reads the files this writes, which are committed.

Every scene is written twice, by bpy.ops.wm.obj_export with materials,
vertex normals, no UVs, modifiers applied and Blender's default axes
(OBJ Y up):
    NAME.obj / .mtl         the model(s) in a closed room
    NAME_alone.obj / .mtl   the model(s) alone
The room is a 4 x 4 m box, 3 m high (in OBJ terms x in [-2, 2], y in
[0, 3], z in [-2, 2]), a primitive cube with its normals flipped so that
they face into it; its ceiling face is inset and the inner 1 x 1 m face
gets the emissive material (Principled BSDF emission, which the exporter
writes as Ke = colour x strength), so the room stays closed and
watertight. Models rest on the floor (or on the table), so contact
cutting (core/rad_contact.h) meets them.

Scenes (what each exercises):
    suzanne_table    primitive_monkey_add on a table (a top and four legs
                     touching it and the floor), sunk 5 mm into the top:
                     faces crossing a face, contacts, an open mesh
    suzanne_subsurf  Suzanne with a Subdivision Surface modifier, level 2
                     (~7.9k quads, most not planar: the loader splits them)
    uv_sphere        UV sphere, Shade Smooth (vn per vertex)
    torus            primitive_torus_add
    cylinder_bevel   cylinder with a Bevel modifier (32-gon caps, bevel strips)
    cad_boolean      cube minus two cylinders (Boolean modifier, exact):
                     n-gons around holes, thin slivers
    text             text object converted to a mesh, extruded, exported
                     triangulated: many thin triangles
    thin_plates      six 0.2 mm plates (closed boxes) standing side by side
                     with gaps of 1e-3 .. 1e-5 of the room's size
"""
import math
import os
import sys

import bpy
from mathutils import Vector

ROOM_X, ROOM_Y, ROOM_Z = 4.0, 4.0, 3.0  # Blender axes: z up


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def material(name, colour, emission=None, strength=0.0):
    m = bpy.data.materials.new(name)
    if hasattr(m, "use_nodes") and not m.use_nodes:
        try:
            m.use_nodes = True  # deprecated in 5.0 (always on), needed before
        except Exception:
            pass
    bsdf = m.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    if emission:
        bsdf.inputs["Emission Color"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = strength
    return m


def active():
    return bpy.context.view_layer.objects.active


def world_bounds(obj):
    """Bounding box of the evaluated object (modifiers applied), world space."""
    bpy.context.view_layer.update()
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    pts = [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    lo = Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
    hi = Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
    return lo, hi


def rest_on(obj, z, sink=0.0):
    lo, _ = world_bounds(obj)
    obj.location.z += z - lo.z - sink


def add_room():
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, ROOM_Z / 2))
    room = active()
    room.name = "Room"
    room.scale = (ROOM_X, ROOM_Y, ROOM_Z)
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    room.data.materials.append(material("Wall", (0.7, 0.7, 0.7)))
    room.data.materials.append(material("Light", (0.78, 0.78, 0.78), (1.0, 0.9, 0.8), 10.0))
    # Normals into the room.
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.object.mode_set(mode="OBJECT")
    # The ceiling face, inset: the inner face is the light.
    top = max(room.data.polygons, key=lambda p: p.center.z)
    for p in room.data.polygons:
        p.select = p.index == top.index
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.inset(thickness=1.5)
    room.active_material_index = 1
    bpy.ops.object.material_slot_assign()
    bpy.ops.object.mode_set(mode="OBJECT")
    return room


def add_box(name, size, location, mat):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
    obj = active()
    obj.name = name
    obj.scale = size
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    obj.data.materials.append(mat)
    return obj


def export(out_dir, name, objects, triangulate=False):
    bpy.ops.object.select_all(action="DESELECT")
    for o in objects:
        o.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.wm.obj_export(filepath=os.path.join(out_dir, name + ".obj"), export_selected_objects=True,
                          export_materials=True, export_uv=False, export_normals=True, apply_modifiers=True,
                          export_triangulated_mesh=triangulate)


def write_scene(out_dir, name, models, triangulate=False):
    room = add_room()
    export(out_dir, name, [room] + models, triangulate)
    export(out_dir, name + "_alone", models, triangulate)


def scene_suzanne_table(out_dir):
    reset()
    wood = material("Wood", (0.45, 0.3, 0.15))
    top_z, thick = 0.75, 0.05
    parts = [add_box("TableTop", (1.2, 0.8, thick), (0, 0, top_z - thick / 2), wood)]
    for i, (x, y) in enumerate([(-0.55, -0.35), (0.55, -0.35), (-0.55, 0.35), (0.55, 0.35)]):
        parts.append(add_box(f"Leg{i}", (0.05, 0.05, top_z - thick), (x, y, (top_z - thick) / 2), wood))
    bpy.ops.mesh.primitive_monkey_add(size=0.6, location=(0, 0, 1.2))
    suz = active()
    suz.name = "Suzanne"
    suz.data.materials.append(material("Suzanne", (0.6, 0.5, 0.3)))
    rest_on(suz, top_z, sink=0.005)
    write_scene(out_dir, "suzanne_table", parts + [suz])


def scene_suzanne_subsurf(out_dir):
    reset()
    bpy.ops.mesh.primitive_monkey_add(size=1.2, location=(0, 0, 1))
    suz = active()
    suz.name = "SuzanneSubsurf"
    mod = suz.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 2
    mod.render_levels = 2
    bpy.ops.object.shade_smooth()
    suz.data.materials.append(material("Suzanne", (0.6, 0.5, 0.3)))
    rest_on(suz, 0.0)
    write_scene(out_dir, "suzanne_subsurf", [suz])


def scene_uv_sphere(out_dir):
    reset()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.5, location=(0.3, -0.2, 1))
    sph = active()
    sph.name = "Sphere"
    bpy.ops.object.shade_smooth()
    sph.data.materials.append(material("Blue", (0.2, 0.3, 0.7)))
    rest_on(sph, 0.0)
    write_scene(out_dir, "uv_sphere", [sph])


def scene_torus(out_dir):
    reset()
    bpy.ops.mesh.primitive_torus_add(major_radius=0.6, minor_radius=0.2, major_segments=48, minor_segments=12,
                                     location=(0, 0, 1))
    tor = active()
    tor.name = "Torus"
    tor.data.materials.append(material("Red", (0.7, 0.2, 0.15)))
    rest_on(tor, 0.0)
    write_scene(out_dir, "torus", [tor])


def scene_cylinder_bevel(out_dir):
    reset()
    bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.4, depth=0.9, location=(0, 0, 1))
    cyl = active()
    cyl.name = "Cylinder"
    mod = cyl.modifiers.new("Bevel", "BEVEL")
    mod.width = 0.05
    mod.segments = 3
    cyl.data.materials.append(material("Green", (0.2, 0.6, 0.25)))
    rest_on(cyl, 0.0)
    write_scene(out_dir, "cylinder_bevel", [cyl])


def scene_cad_boolean(out_dir):
    reset()
    part = add_box("Part", (0.8, 0.6, 0.4), (0, 0, 0.2), material("Steel", (0.55, 0.56, 0.58)))
    # A vertical hole through the block, and a tilted cutter grazing a side: slivers.
    bpy.ops.mesh.primitive_cylinder_add(vertices=24, radius=0.15, depth=1.0, location=(0.1, 0, 0.2))
    hole = active()
    hole.name = "Hole"
    bpy.ops.mesh.primitive_cylinder_add(vertices=16, radius=0.12, depth=1.2, location=(-0.33, 0.0, 0.3),
                                        rotation=(math.radians(90), 0, math.radians(7)))
    slot = active()
    slot.name = "Slot"
    for cutter in (hole, slot):
        mod = part.modifiers.new("Bool" + cutter.name, "BOOLEAN")
        mod.operation = "DIFFERENCE"
        mod.object = cutter
        mod.solver = "EXACT"
        cutter.display_type = "WIRE"  # not exported: only the selected objects are
    lo, _ = world_bounds(part)
    assert abs(lo.z) < 1e-9, lo  # resting on the floor, cutters in place
    write_scene(out_dir, "cad_boolean", [part])


def scene_text(out_dir):
    reset()
    bpy.ops.object.text_add(location=(0, 0, 1), rotation=(math.radians(90), 0, 0))
    txt = active()
    txt.data.body = "Radiosity"
    txt.data.size = 0.5
    txt.data.extrude = 0.03
    txt.data.align_x = "CENTER"
    bpy.ops.object.convert(target="MESH")
    txt = active()
    txt.name = "Text"
    txt.data.materials.append(material("Ink", (0.15, 0.15, 0.2)))
    rest_on(txt, 0.0)
    write_scene(out_dir, "text", [txt], triangulate=True)


def scene_thin_plates(out_dir):
    reset()
    mat = material("Plate", (0.6, 0.6, 0.55))
    size = max(ROOM_X, ROOM_Y, ROOM_Z)
    gaps = [1e-3 * size, 3e-4 * size, 1e-4 * size, 3e-5 * size, 1e-5 * size]
    # 0.2 mm sheets (5e-5 of the room): thinner than 1e-4 of most segments
    # between the room's faces, so a tracer that ignores hits that close to
    # either end sees through them.
    thick, x = 2e-4, -0.6
    plates = []
    for i in range(len(gaps) + 1):
        plates.append(add_box(f"Plate{i}", (thick, 0.6, 0.8), (x + thick / 2, 0, 0.4), mat))
        if i < len(gaps):
            x += thick + gaps[i]
    write_scene(out_dir, "thin_plates", plates)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "tests", "data", "corpus")
    os.makedirs(out_dir, exist_ok=True)
    for make in (scene_suzanne_table, scene_suzanne_subsurf, scene_uv_sphere, scene_torus, scene_cylinder_bevel,
                 scene_cad_boolean, scene_text, scene_thin_plates):
        make(out_dir)
        print("made", make.__name__[6:], file=sys.stderr)


if __name__ == "__main__":
    main()
