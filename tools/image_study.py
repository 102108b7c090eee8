#!/usr/bin/env python3
"""Reference-image study: our radiosity images against a path-traced reference.

    python3 tools/image_study.py [run] [options]          # the whole study (below)
    python3 tools/image_study.py reference [options]      # only render + cache the references
    python3 tools/image_study.py compare OURS.exr REF.exr [--labels LABELS.npz]

One command (issue 15, item 3). For each scene (built-in Cornell box,
scenes/cornell_sphere.obj, scenes/cluttered_room.obj) it

1. renders a path-traced reference with Mitsuba 3 from the scene's OBJ + MTL
   (the true geometry, not our patches): `path` integrator, max_depth -1 (no
   depth limit; Russian roulette from depth 5), box reconstruction filter,
   independent sampler, same resolution and pinhole camera as `render`.
   Materials: Kd -> `diffuse` reflectance (one-sided, as radiosity's patches),
   Ke -> `area` emitter of radiance Ke/pi (Ke is exitance), emitting on the
   front side only (faces are wound counter-clockwise seen from the front,
   which is Mitsuba's convention too). Two seeds; their mean is the
   reference, and their difference measures its noise (the "noise floor"
   below). References are cached (--cache, default build/study/) as
   ref_<scene>_<W>x<H>_<spp>spp_seed<k>.exr (+ .json with the render time)
   and ref_<scene>_<W>x<H>_<spp>spp_mean.exr; reruns reuse them;
2. labels every pixel with the surface region it sees (floor, back wall,
   blocks' faces, light, ...) by casting 3 x 3 rays per pixel through the
   same camera against the OBJ's faces in numpy (labels_<scene>_<W>x<H>_v2.npz
   in the cache; a scene of more than 5 000 faces through Mitsuba's own
   rays against the reference's meshes, one region per OBJ group with its
   numbers dropped, table_3 -> table: labels_<scene>_<W>x<H>_v3.npz): a pixel whose 9 rays hit one region gets its label, one
   whose rays hit several is "mixed" (edges; counted in the overall numbers,
   not in any region's), one whose rays all miss is background. Pixels
   touching the light (any of whose rays hit it, and their 8 neighbours:
   a pixel the light's corner covers by less than a ray's ninth), and
   background pixels, are left out of the overall numbers;
3. runs our pipeline (build/formfactor -> solve -> render --quantity
   radiance) for each configuration and times each stage (wall clock):
   uniform --subdiv S for S = --min-subdiv .. --max-subdiv, and the
   refinement loop scripts/refine.sh at each of --refine-tols (skipped, with
   a note, when that script is missing). --ff-args go to every formfactor
   run (and to refine.sh as --ff-args when it accepts them);
4. compares luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the radiance
   images: per region the ratio of means ours/ref - 1 (%), the same over all
   pixels but the light, and the relative RMSE
   sqrt(mean((Y_ours - Y_ref)^2)) / mean(Y_ref) over those pixels;
5. writes to --out (default docs/): image_study.md (machine, date, command;
   per scene the reference's noise floor and a table per configuration),
   image_study.json (everything measured), diff_<scene>_<config>.png (signed
   relative error of Y, 256 px wide) and error_time_<scene>.png (relative
   RMSE against pipeline time, log-log, uniform and refined).

`compare` prints the step-4 numbers for one image pair as JSON; with
--labels (a labels_*.npz from the cache) it adds the regions and leaves the
light out of the overall numbers, without it every pixel counts.

Options of `run` / `reference` (defaults in brackets):
  --build DIR           our build directory [build]
  --scenes A,B          cornell_box,cornell_sphere,cluttered_room [all three], or OBJ
                        files with a .camera beside them (scenes/make_interior.py)
  --min-subdiv S, --max-subdiv S   uniform subdivisions [2, 4]; S = 5 costs
                        about 16 x S = 4's formfactor time
  --max-patches N       skip uniform runs of more patches [20000] (the cluttered
                        room's S = 4 has 47872)
  --ff-args "ARGS"      extra formfactor flags for every run
                        [--quad-rtol 1e-5 --shadow-rays 16]
  --refine-tols T,T     tolerances for scripts/refine.sh [0.05]; "" for none
  --hier-tols T,T       formfactor --method hierarchical at each --link-tol
                        [1e-2,3e-3,1e-3]; "" for none (--hier-args: more flags,
                        --hier-solve-args: solve's)
  --refine-budgets B,B  START:MAX_PATCHES[:GROWTH], each a refinement run from
                        --subdiv START to about MAX_PATCHES patches, passes
                        growing the mesh at most GROWTH times [per scene,
                        REFINE_BUDGETS: the uniform runs' patch counts]
  --refine-script PATH  the refinement script [scripts/refine.sh], called as
                        PATH --build DIR --scene OBJ|builtin --tol T --out DIR
                        --start-subdiv START --max-patches MAX_PATCHES
                        [--growth GROWTH --passes 8]
                        (+ --ff-args "ARGS" when its --help mentions --ff-args);
                        it must leave DIR/radiosity (DIR/refine.json is kept)
  --width N, --height N image size for both renderers [512 x 512]
  --ref-spp N           path-tracer samples per pixel per seed [2048]
  --seeds A,B           path-tracer seeds [1,2]
  --variant V           mitsuba variant: auto (llvm_ad_rgb when a libLLVM >= 16
                        is installed, else scalar_rgb), scalar_rgb, llvm_ad_rgb
                        [auto]. On the 2-core VM llvm_ad_rgb is 2.4 x faster
                        (Cornell box, 512 x 512, 64 spp: 11.0 s against 26.5 s);
                        it needs libLLVM >= 16 (Debian bookworm: apt-get install
                        libllvm19; its default 14 and 15 abort with "Cannot
                        select: fminimum"), found in /usr/lib/x86_64-linux-gnu
                        or named by DRJIT_LIBLLVM_PATH
  --cache DIR           references, labels and pipeline runs [build/study]
  --out DIR             where image_study.md/.json/.png go [docs]
  --rerun               run our pipeline again even if its image is cached

Dependencies: Python 3 with numpy, matplotlib and mitsuba (pip install
mitsuba numpy matplotlib, in a virtual environment). None of them is needed
by the project's build or test suite; this script says what is missing and
stops. `compare` needs numpy, and mitsuba or tools/exrread.py to read EXR.

Camera: the scene's sidecar (scenes/<scene>.camera) when there is one; the
cluttered room has none, and render's automatic camera stands outside that
closed room (back faces culled, which a path tracer does not do), so the
study puts the eye inside it (CAMERAS below). render gets the camera as
explicit --eye/--look-at/--up/--fov, Mitsuba as the same look-at frame
(Mitsuba's perspective camera also shows +x on the left for this frame).
"""
import argparse
import datetime
import json
import math
import os
import platform
import re
import shlex
import subprocess
import sys
import time

# Dr.Jit's LLVM backend needs a recent libLLVM (Debian bookworm's default 14 and 15 fail to compile its
# kernels: "Cannot select: fminimum"); point it at the newest one installed (apt-get install libllvm19).
# --variant auto takes llvm_ad_rgb only then (or when DRJIT_LIBLLVM_PATH is set): an LLVM that cannot
# compile the kernels aborts the process, it raises nothing.
LLVM_OK = "DRJIT_LIBLLVM_PATH" in os.environ
if not LLVM_OK:
    for _v in range(30, 15, -1):
        _p = f"/usr/lib/x86_64-linux-gnu/libLLVM-{_v}.so"
        if os.path.exists(_p):
            os.environ["DRJIT_LIBLLVM_PATH"] = _p
            LLVM_OK = True
            break

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "tools"))

try:
    import numpy as np
except ImportError:
    sys.exit("image_study.py: needs numpy (and, for references and plots, mitsuba and matplotlib):\n"
             "  python3 -m venv VENV && VENV/bin/pip install mitsuba numpy matplotlib\n"
             "and run it with VENV/bin/python. The project's tests do not need them.")

SCENES = {
    # name: (OBJ path relative to the repository, use the built-in scene for formfactor)
    "cornell_box": ("scenes/cornell_box.obj", True),
    "cornell_sphere": ("scenes/cornell_sphere.obj", False),
    "cluttered_room": ("scenes/cluttered_room.obj", False),
}
# Cameras for scenes without a sidecar. The cluttered room (10 x 3 x 10 m,
# closed, faces inward): from near the middle of the z = 0 wall, at eye
# height, looking across the grid of boxes.
CAMERAS = {
    "cluttered_room": {"eye": (5.0, 1.7, 0.3), "look_at": (5.0, 0.6, 6.0), "up": (0.0, 1.0, 0.0), "fov_y": 70.0},
}
DEFAULT_FOV_Y = 39.3077
LABEL_FACES_MAX = 5000     # above: labels_by_shapes (casting per face in numpy would take hours)
PASS_SPP = 64
LUMA = (0.2126, 0.7152, 0.0722)
BACKGROUND, MIXED = -1, -2


def need(module):
    """Imports an optional dependency or stops with a message that says how to get it."""
    try:
        return __import__(module)
    except ImportError:
        sys.exit(f"image_study.py: this step needs the Python module '{module}' (pip install mitsuba numpy "
                 "matplotlib in a virtual environment). The project's build and tests do not need it.")


def log(msg):
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- scenes


def load_obj(path):
    """The OBJ's faces: list of dicts {group, material, verts (k x 3 array)} and materials {name: {Kd, Ke}}."""
    verts, faces = [], []
    group, material, mtllib = "default", None, None
    with open(path) as f:
        for line in f:
            tok = line.split("#", 1)[0].split()
            if not tok:
                continue
            if tok[0] == "v":
                verts.append([float(x) for x in tok[1:4]])
            elif tok[0] in ("g", "o"):
                group = " ".join(tok[1:]) or "default"
            elif tok[0] == "usemtl":
                material = tok[1]
            elif tok[0] == "mtllib":
                mtllib = " ".join(tok[1:])
            elif tok[0] == "f":
                idx = []
                for t in tok[1:]:
                    i = int(t.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                faces.append({"group": group, "material": material, "verts": np.array([verts[i] for i in idx])})
    materials = {}
    if mtllib:
        name = None
        with open(os.path.join(os.path.dirname(path), mtllib)) as f:
            for line in f:
                tok = line.split("#", 1)[0].split()
                if not tok:
                    continue
                if tok[0] == "newmtl":
                    name = tok[1]
                    materials[name] = {"Kd": [0.0, 0.0, 0.0], "Ke": [0.0, 0.0, 0.0]}
                elif tok[0] in ("Kd", "Ke") and name:
                    materials[name][tok[0]] = [float(x) for x in tok[1:4]]
    for fc in faces:
        v = fc["verts"]
        n = np.zeros(3)
        for k in range(len(v)):      # Newell's normal: robust for slightly non-planar quads
            n += np.cross(v[k], v[(k + 1) % len(v)])
        fc["normal"] = n / np.linalg.norm(n)
        fc["emits"] = max(materials.get(fc["material"], {"Ke": [0]})["Ke"]) > 0
    return faces, materials


def load_camera(scene):
    """The scene's camera: its sidecar file, else CAMERAS[scene]."""
    obj = os.path.join(REPO, SCENES[scene][0])
    sidecar = os.path.splitext(obj)[0] + ".camera"
    if os.path.exists(sidecar):
        cam = {"up": (0.0, 1.0, 0.0), "fov_y": DEFAULT_FOV_Y}
        for line in open(sidecar):
            tok = line.split("#", 1)[0].split()
            if tok:
                vals = tuple(float(x) for x in tok[1:])
                cam[tok[0]] = vals[0] if tok[0] == "fov_y" else vals
        cam["source"] = os.path.relpath(sidecar, REPO)
        return cam
    cam = dict(CAMERAS[scene])
    cam["source"] = "tools/image_study.py CAMERAS"
    return cam


def camera_frame(cam, width, height):
    """render/camera.c's render_view_init: (eye, forward, right, up, tan_half_x, tan_half_y)."""
    eye, look, up = (np.array(cam[k], float) for k in ("eye", "look_at", "up"))
    fwd = (look - eye) / np.linalg.norm(look - eye)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    upv = np.cross(right, fwd)
    ty = math.tan(0.5 * math.radians(cam["fov_y"]))
    return eye, fwd, right, upv, ty * width / height, ty


def render_camera_args(cam):
    """The camera as explicit render flags."""
    fmt = lambda v: ",".join(f"{x:.9g}" for x in v)
    return ["--eye", fmt(cam["eye"]), "--look-at", fmt(cam["look_at"]), "--up", fmt(cam["up"]),
            "--fov", f"{cam['fov_y']:.9g}"]


# ----------------------------------------------------------------------------- region labels


def region_names(faces, cam, width, height):
    """One region name per face (see the module docstring): emitters are 'light'; a group whose faces are
    axis-like planes facing different ways (a block, the sphere scene's box) is split by the side each faces
    as seen from the camera; numbered copies (box_3_4) are pooled."""
    _, fwd, right, upv, _, _ = camera_frame(cam, width, height)
    allv = np.concatenate([f["verts"] for f in faces])
    lo, hi = allv.min(0), allv.max(0)
    ext = np.maximum(hi - lo, 1e-12)

    def side(fc):
        n = fc["normal"]
        comp = {"up": n @ upv, "toward": -(n @ fwd), "right": n @ right}
        key = max(comp, key=lambda k: abs(comp[k]))
        sign = comp[key] > 0
        # a room face: on the bounding box's boundary, facing inward
        c = fc["verts"].mean(0)
        axis = int(np.argmax(np.abs(n)))
        on_boundary = min(abs(c[axis] - lo[axis]), abs(c[axis] - hi[axis])) < 0.01 * ext[axis]
        inward = (n @ ((lo + hi) / 2 - c)) > 0
        if on_boundary and inward:
            return {("up", True): "floor", ("up", False): "ceiling", ("toward", True): "back wall",
                    ("toward", False): "front wall", ("right", True): "left wall",
                    ("right", False): "right wall"}[(key, sign)], True
        return {("up", True): "top", ("up", False): "bottom", ("toward", True): "front",
                ("toward", False): "back", ("right", True): "right side", ("right", False): "left side"}[(key, sign)], False

    by_group = {}
    for fc in faces:
        by_group.setdefault(fc["group"], []).append(fc)
    names = []
    for fc in faces:
        if fc["emits"]:
            names.append("light")
            continue
        base = re.sub(r"(_\d+)+$", "", fc["group"])
        members = [g for g in by_group[fc["group"]] if not g["emits"]]
        axis_like = all(np.max(np.abs(g["normal"])) > math.cos(math.radians(20)) or
                        max(abs(g["normal"] @ upv), abs(g["normal"] @ fwd), abs(g["normal"] @ right)) > math.cos(math.radians(25))
                        for g in members)
        sides = {side(g)[0] for g in members}
        if axis_like and len(sides) > 1:
            s, room = side(fc)
            if room:
                mat = fc["material"]
                names.append(s if mat in (None, "white") else f"{s} ({mat})")
            else:
                names.append(f"{base} {s}")
        else:
            names.append(base)
    return names


def pixel_rays(cam, width, height, sub):
    """Unit directions of sub x sub rays per pixel (pixel centres of a sub x sub grid), shape (H, W, sub*sub, 3)."""
    eye, fwd, right, upv, tx, ty = camera_frame(cam, width, height)
    o = (np.arange(sub) + 0.5) / sub
    xs = (np.arange(width)[:, None] + o[None, :]).reshape(-1)     # W*sub
    ys = (np.arange(height)[:, None] + o[None, :]).reshape(-1)
    ndx = 2.0 * xs / width - 1.0
    ndy = 1.0 - 2.0 * ys / height
    d = (fwd[None, None, :] + (ndx * tx)[None, :, None] * right[None, None, :] +
         (ndy * ty)[:, None, None] * upv[None, None, :])             # (H*sub, W*sub, 3)
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    d = d.reshape(height, sub, width, sub, 3).transpose(0, 2, 1, 3, 4).reshape(height, width, sub * sub, 3)
    return eye, d


def cast_labels(faces, face_region, eye, dirs):
    """Nearest face hit by each ray (convex planar polygons), as a region index; -1 for a miss."""
    shape = dirs.shape[:-1]
    d = dirs.reshape(-1, 3)
    best_t = np.full(len(d), np.inf)
    best = np.full(len(d), -1, dtype=np.int32)
    for fi, fc in enumerate(faces):
        v, n = fc["verts"], fc["normal"]
        denom = d @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((v[0] - eye) @ n) / denom
        ok = (np.abs(denom) > 1e-12) & (t > 0) & (t < best_t)
        idx = np.nonzero(ok)[0]
        if not len(idx):
            continue
        p = eye + t[idx, None] * d[idx]
        inside = np.ones(len(idx), bool)
        for k in range(len(v)):
            e = v[(k + 1) % len(v)] - v[k]
            inside &= (np.cross(e, p - v[k]) @ n) >= -1e-9 * np.linalg.norm(e) ** 2
        idx = idx[inside]
        best_t[idx] = t[idx]
        best[idx] = face_region[fi]
    return best.reshape(shape)


def with_neighbours(hit):
    """hit (H, W) bool grown by one pixel in all 8 directions."""
    near = hit.copy()
    near[1:, :] |= hit[:-1, :]
    near[:-1, :] |= hit[1:, :]
    grown = near.copy()
    grown[:, 1:] |= near[:, :-1]
    grown[:, :-1] |= near[:, 1:]
    return grown


def labels_by_brightness(materials, ref):
    """Labels for scenes too large to cast per face (LABEL_FACES_MAX): one region, 'all'; excluded are
    the pixels at least half as bright as the dimmest light (Ke / pi: a light seen directly) and their 8
    neighbours, as the light's pixels are in labels_for, and the background."""
    lights = [luminance(np.array(m["Ke"], float)) / math.pi for m in materials.values() if max(m["Ke"]) > 0]
    y = luminance(ref)
    hit = y >= 0.5 * min(lights) if lights else np.zeros(y.shape, bool)
    return np.zeros(y.shape, np.int16), ["all"], with_neighbours(hit) | (y <= 0.0)


def labels_by_shapes(scene, width, height, cache):
    """Per-pixel regions for scenes too large to cast per face in numpy: Mitsuba traces the 3 x 3 rays a
    pixel of labels_by_rays against the reference's own meshes (one per OBJ group and material). A
    region is the group's name without its trailing numbers (table_2 and table_3 are "table"), lights
    are "light"; mixed pixels, the light's and their neighbours, and background as in labels_by_rays.
    Returns labels, names, exclude; None where Mitsuba is missing."""
    try:
        mi = need("mitsuba")
        pick_variant("auto")
    except SystemExit:
        return None
    d = mitsuba_scene(scene, width, height, 1, cache)
    keys = [k for k in d if k.startswith("shape_")]
    region_of_key = {}
    for i, k in enumerate(keys):
        group = re.sub(r"^shape_\d+_", "", k)
        region_of_key[k] = "light" if "emitter" in d[k] else (re.sub(r"(_\d+)+$", "", group) or group)
        # A BSDF of its own per mesh: Mitsuba merges meshes whose materials are alike into one shape,
        # which would leave one label per material.
        d[k]["bsdf"] = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, (i + 1) / (len(keys) + 1)]}}
        d[k].pop("emitter", None)
    sc = mi.load_dict(d)
    names = sorted(set(region_of_key.values()))
    cam = load_camera(scene)
    eye, dirs = pixel_rays(cam, width, height, 3)
    dv = dirs.reshape(-1, 3).astype(np.float32)
    ray = mi.Ray3f(mi.Point3f(*[np.full(len(dv), e, np.float32) for e in eye]),
                   mi.Vector3f(dv[:, 0], dv[:, 1], dv[:, 2]))
    si = sc.ray_intersect(ray)
    hits = np.full(len(dv), BACKGROUND, np.int32)
    for shape in sc.shapes():
        hits[np.array(si.shape == mi.ShapePtr(shape), dtype=bool)] = names.index(region_of_key[shape.id()])
    hits = hits.reshape(height, width, 9)
    first = hits[..., 0]
    labels = np.where(np.all(hits == first[..., None], axis=-1), first, MIXED).astype(np.int16)
    light = names.index("light") if "light" in names else -99
    exclude = with_neighbours(np.any(hits == light, axis=-1)) | (labels == BACKGROUND)
    return labels, names, exclude


def labels_by_rays(faces, scene, width, height):
    """Per-pixel regions from rays cast at every face (3 x 3 a pixel): labels, names, exclude."""
    cam = load_camera(scene)
    per_face = region_names(faces, cam, width, height)
    names = sorted(set(per_face))
    face_region = [names.index(s) for s in per_face]
    eye, dirs = pixel_rays(cam, width, height, 3)
    hits = np.concatenate([cast_labels(faces, face_region, eye, dirs[r:r + 64]) for r in range(0, height, 64)])
    first = hits[..., 0]
    same = np.all(hits == first[..., None], axis=-1)
    labels = np.where(same, first, MIXED).astype(np.int16)     # all misses: first = -1 = BACKGROUND
    light = names.index("light") if "light" in names else -99
    # A pixel touching the light: one whose 3 x 3 rays hit it, and its 8 neighbours. A pixel
    # the light's edge or corner covers by less than a ray's ninth is missed by the rays alone,
    # and there the light (about 150x the walls) decides the pixel: a 4x4-sample render and the
    # reference disagree by aliasing alone (one such pixel was 23 % of the Cornell box's squared
    # error). The light is a large convex polygon, so every pixel it touches borders one its
    # rays hit. (Caches before this rule were labels_<scene>_<W>x<H>.npz, without _v2.)
    exclude = with_neighbours(np.any(hits == light, axis=-1)) | (labels == BACKGROUND)
    return labels, names, exclude


def labels_for(scene, width, height, cache, ref=None):
    """Per-pixel labels (cached): dict with labels (H, W) int16, names, exclude (H, W) bool. Scenes of
    more than LABEL_FACES_MAX faces take them from Mitsuba's rays (labels_by_shapes, cached as _v3),
    or without Mitsuba from the reference ref (labels_by_brightness, one region)."""
    path = os.path.join(cache, f"labels_{scene}_{width}x{height}_v2.npz")
    shapes_path = os.path.join(cache, f"labels_{scene}_{width}x{height}_v3.npz")
    if os.path.exists(shapes_path):
        return load_labels(shapes_path)
    if os.path.exists(path):
        cached = load_labels(path)
        if cached["names"] != ["all"]:   # a small scene's regions; ["all"] is a large one's by brightness
            return cached
    t0 = time.time()
    faces, materials = load_obj(os.path.join(REPO, SCENES[scene][0]))
    if len(faces) <= LABEL_FACES_MAX:
        labels, names, exclude = labels_by_rays(faces, scene, width, height)
        how = f"{len(names)} regions"
    else:
        by_shapes = labels_by_shapes(scene, width, height, cache)
        if by_shapes is not None:
            labels, names, exclude = by_shapes
            how, path = f"{len(names)} regions by Mitsuba's rays", shapes_path
        elif os.path.exists(path):
            return cached
        elif ref is not None:
            labels, names, exclude = labels_by_brightness(materials, ref)
            how = f"by brightness, {int(exclude.sum())} pixels left out"
        else:
            raise RuntimeError(f"labels for {scene} ({len(faces)} faces) come from its reference: render it first")
    os.makedirs(cache, exist_ok=True)
    np.savez_compressed(path, labels=labels, names=np.array(names), exclude=exclude)
    log(f"labels for {scene}: {how}, {time.time() - t0:.1f} s -> {path}")
    return {"labels": labels, "names": names, "exclude": exclude, "path": path}


def load_labels(path):
    z = np.load(path)
    return {"labels": z["labels"], "names": [str(s) for s in z["names"]], "exclude": z["exclude"], "path": path}


# ----------------------------------------------------------------------------- images and metrics


def read_exr(path):
    """RGB float32 (H, W, 3): mitsuba's Bitmap when importable, else tools/exrread.py."""
    try:
        import mitsuba as mi
        if mi.variant() is None:
            mi.set_variant("scalar_rgb")
        return np.array(mi.Bitmap(path), dtype=np.float32)[..., :3]
    except ImportError:
        from exrread import read_exr as _read
        return _read(path)[..., :3]


def write_exr(path, rgb):
    import mitsuba as mi
    mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(path)


def luminance(rgb):
    return rgb[..., 0] * LUMA[0] + rgb[..., 1] * LUMA[1] + rgb[..., 2] * LUMA[2]


def compare(ours, ref, labels=None):
    """Step 4's numbers for RGB images ours, ref (H, W, 3); labels from labels_for() or None."""
    if ours.shape != ref.shape:
        raise ValueError(f"image sizes differ: {ours.shape} vs {ref.shape}")
    yo, yr = luminance(ours).astype(np.float64), luminance(ref).astype(np.float64)
    if labels is not None:
        if labels["labels"].shape != yo.shape:
            raise ValueError(f"labels are {labels['labels'].shape}, images {yo.shape}")
        mask = ~labels["exclude"]
    else:
        mask = np.ones(yo.shape, bool)
    mr = yr[mask].mean()
    out = {
        "pixels": int(mask.sum()),
        "overall": "all pixels but those touching the light and background" if labels is not None else "all pixels",
        "mean_ref": mr,
        "mean_ours": yo[mask].mean(),
        "mean_error_pct": 100.0 * (yo[mask].mean() / mr - 1.0),
        "rel_rmse": math.sqrt(np.mean((yo[mask] - yr[mask]) ** 2)) / mr,
        "regions": {},
    }
    if labels is not None:
        for k, name in enumerate(labels["names"]):
            m = labels["labels"] == k
            if m.sum() == 0:
                continue
            r = yr[m].mean()
            counted = m & mask   # the pixels the overall numbers count
            out["regions"][name] = {"pixels": int(m.sum()), "mean_ref": r,
                                    "error_pct": 100.0 * (yo[m].mean() / r - 1.0) if r > 0 else None,
                                    "rel_rmse": math.sqrt(np.mean((yo[m] - yr[m]) ** 2)) / r if r > 0 else None,
                                    # its share of the overall reference, and what it adds to mean_error_pct
                                    "share_pct": 100.0 * yr[counted].sum() / yr[mask].sum(),
                                    "contribution_pct": 100.0 * (yo[counted] - yr[counted]).sum() / yr[mask].sum()}
    return out


# ----------------------------------------------------------------------------- Mitsuba reference


def pick_variant(want):
    mi = need("mitsuba")
    if want == "auto":
        for v in ("llvm_ad_rgb", "scalar_rgb") if LLVM_OK else ("scalar_rgb",):
            try:
                mi.set_variant(v)
                return v
            except Exception:   # no LLVM library: the scalar variant
                continue
    mi.set_variant(want)
    return want


def mitsuba_scene(scene, width, height, spp, cache):
    """The Mitsuba scene dict: one mesh per (group, material) written as OBJ files under cache/mesh_<scene>/."""
    faces, materials = load_obj(os.path.join(REPO, SCENES[scene][0]))
    cam = load_camera(scene)
    mi = need("mitsuba")
    mdir = os.path.join(cache, f"mesh_{scene}")
    os.makedirs(mdir, exist_ok=True)
    parts = {}
    for fc in faces:
        parts.setdefault((fc["group"], fc["material"]), []).append(fc)
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective", "fov": cam["fov_y"], "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=list(cam["eye"]), target=list(cam["look_at"]),
                                                       up=list(cam["up"])),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
        },
    }
    for i, ((group, mat), fcs) in enumerate(parts.items()):
        path = os.path.join(mdir, f"{i:03d}.obj")
        with open(path, "w") as f:
            base = 1
            for fc in fcs:
                for p in fc["verts"]:
                    f.write("v %.9g %.9g %.9g\n" % tuple(p))
                f.write("f " + " ".join(str(base + k) for k in range(len(fc["verts"]))) + "\n")
                base += len(fc["verts"])
        m = materials[mat]
        shape = {"type": "obj", "filename": path, "face_normals": True,
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["Kd"]}}}
        if max(m["Ke"]) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": [k / math.pi for k in m["Ke"]]}}
        d[f"shape_{i:03d}_{re.sub(r'[^A-Za-z0-9_]', '_', group)}"] = shape
    return d


def render_reference(scene, args):
    """Renders (or reuses) one image per seed and their mean; returns dict with paths, times, noise."""
    W, H, spp = args.width, args.height, args.ref_spp
    stem = os.path.join(args.cache, f"ref_{scene}_{W}x{H}_{spp}spp")
    seeds = [int(s) for s in args.seeds.split(",")]
    images, info = [], {"seeds": seeds, "spp": spp, "runs": []}
    for seed in seeds:
        exr, meta = f"{stem}_seed{seed}.exr", f"{stem}_seed{seed}.json"
        if os.path.exists(exr) and os.path.exists(meta):
            run = json.load(open(meta))
            log(f"reference {scene} seed {seed}: cached {exr}")
        else:
            mi = need("mitsuba")
            variant = pick_variant(args.variant)
            sc = mi.load_dict(mitsuba_scene(scene, W, H, spp, args.cache))
            log(f"reference {scene} seed {seed}: {W}x{H}, {spp} spp, {variant} ...")
            t0 = time.time()
            # in passes of at most PASS_SPP samples: the LLVM variant holds a whole pass's samples in memory
            passes = max(1, -(-spp // PASS_SPP))
            img = np.zeros((H, W, 3))
            for p in range(passes):
                n = spp // passes + (1 if p < spp % passes else 0)
                img += n * np.array(mi.render(sc, spp=n, seed=seed * 100003 + p), dtype=np.float64)
            img = (img / spp).astype(np.float32)
            dt = time.time() - t0
            os.makedirs(args.cache, exist_ok=True)
            write_exr(exr, img)
            run = {"seed": seed, "variant": variant, "seconds": dt, "spp": spp, "width": W, "height": H,
                   "mitsuba": mi.__version__, "threads": os.cpu_count(), "machine": machine(),
                   "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
            json.dump(run, open(meta, "w"), indent=1)
            log(f"reference {scene} seed {seed}: {dt:.0f} s -> {exr}")
        info["runs"].append(run)
        images.append(read_exr(exr))
    mean_path = f"{stem}_mean.exr"
    mean = sum(images) / len(images)
    if not os.path.exists(mean_path):
        write_exr(mean_path, mean)
    info["mean"] = mean_path
    labels = labels_for(scene, W, H, args.cache, mean)
    info["labels"] = labels["path"]
    if len(images) >= 2:
        c = compare(images[1], images[0], labels)
        # one seed against another: sqrt(2) x one seed's error; the mean of two: 1/sqrt(2) x one seed's
        info["seed_to_seed_rel_rmse"] = c["rel_rmse"]
        info["seed_to_seed_mean_pct"] = c["mean_error_pct"]
        info["mean_ref_rel_rmse"] = c["rel_rmse"] / 2.0
        info["seed_to_seed_regions"] = {k: v["error_pct"] for k, v in c["regions"].items()}
    return info, mean, labels


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


# ----------------------------------------------------------------------------- our pipeline


def patch_count(radiosity):
    """N from the radiosity file's header (docs/formats.md: u64 at offset 16)."""
    with open(radiosity, "rb") as f:
        head = f.read(24)
    return int.from_bytes(head[16:24], "little")


def timed(cmd, log_path):
    """Runs cmd (list), appending its output to log_path; returns wall seconds. Stops the study on failure."""
    t0 = time.time()
    with open(log_path, "a") as lf:
        lf.write("$ " + " ".join(shlex.quote(c) for c in cmd) + "\n")
        lf.flush()
        r = subprocess.run(cmd, stdout=lf, stderr=subprocess.STDOUT, cwd=REPO)
    dt = time.time() - t0
    if r.returncode != 0:
        raise RuntimeError(f"failed (exit {r.returncode}): {' '.join(cmd)}; see {log_path}")
    return dt


# Refinement runs per scene, START:MAX_PATCHES[:GROWTH]: the loop starts at
# --subdiv START and stops at about MAX_PATCHES, which match the uniform
# runs' patch counts (equal-patch-count comparisons) and a smaller budget
# between them; GROWTH (refine.sh --growth, default 2) is how much one pass
# may grow the mesh. The cluttered room, with a contact shadow at each of
# its 36 boxes, needs smaller, more passes (1.5: relative RMSE 0.088 at
# 3099 patches, where 2 gives 0.101 at 3150).
REFINE_BUDGETS = {"cornell_box": "2:1300,2:2400", "cornell_sphere": "2:1500,2:2944",
                  "cluttered_room": "1:1600:1.5,1:3084:1.5"}


def configurations(scene, args):
    """The list of configurations: uniform subdivisions, then the refinement loop at each
    tolerance (--refine-tols) and budget (REFINE_BUDGETS, or --refine-budgets)."""
    cfgs = [{"name": f"S{s}", "kind": "uniform", "subdiv": s}
            for s in range(args.min_subdiv, args.max_subdiv + 1)]
    budgets = args.refine_budgets or REFINE_BUDGETS.get(scene, "2:2400")
    for t in [x for x in args.refine_tols.split(",") if x]:
        for b in [x for x in budgets.split(",") if x]:
            start, most, *growth = b.split(":")
            cfg = {"name": f"refine_{t}_S{start}_N{most}", "kind": "refine", "tol": t,
                   "start": start, "max_patches": most}
            if growth:
                cfg["name"] += f"_g{growth[0]}"
                cfg["growth"] = growth[0]
            cfgs.append(cfg)
    for t in [x for x in args.hier_tols.split(",") if x]:
        cfgs.append({"name": f"hier_{t}", "kind": "hierarchical", "tol": t})
    return cfgs


def run_ours(scene, cfg, args, cam):
    """Runs (or reuses) one configuration of our pipeline; returns its record, or one with 'skipped'."""
    obj, builtin = SCENES[scene]
    build = os.path.abspath(args.build)
    wd = os.path.abspath(os.path.join(args.cache, "runs", scene, cfg["name"]))
    img, meta = os.path.join(wd, "radiance.exr"), os.path.join(wd, "run.json")
    ff_args = shlex.split(args.ff_args)
    key = {"cfg": cfg, "ff_args": ff_args, "width": args.width, "height": args.height,
           "camera": render_camera_args(cam), "render_args": shlex.split(args.render_args)}
    if cfg["kind"] == "refine":
        key["refine_script"] = os.path.abspath(args.refine_script)
    if cfg["kind"] == "hierarchical":
        key["hier_args"] = shlex.split(args.hier_args)
        key["hier_solve_args"] = shlex.split(args.hier_solve_args)
    if not args.rerun and os.path.exists(img) and os.path.exists(meta):
        rec = json.load(open(meta))
        if rec.get("key") == key:
            log(f"ours {scene} {cfg['name']}: cached {img}")
            return rec
    if cfg["kind"] == "uniform":
        n = len(load_obj(os.path.join(REPO, obj))[0]) * 4 ** cfg["subdiv"]
        if n > args.max_patches:
            return {"config": cfg["name"], "kind": cfg["kind"],
                    "skipped": f"{n} patches, over --max-patches {args.max_patches} (not run)"}
    refine = os.path.abspath(args.refine_script)
    if cfg["kind"] == "refine" and not os.access(refine, os.X_OK):
        return {"config": cfg["name"], "kind": cfg["kind"], "skipped": f"{args.refine_script} is missing (not run)"}
    os.makedirs(wd, exist_ok=True)
    lg = os.path.join(wd, "log.txt")
    open(lg, "w").close()
    rec = {"config": cfg["name"], "kind": cfg["kind"], "key": key, "log": lg}
    rad = os.path.join(wd, "radiosity")
    log(f"ours {scene} {cfg['name']} ...")
    if cfg["kind"] == "hierarchical":
        ff = os.path.join(wd, "links")
        cmd = [os.path.join(build, "formfactor"), "--method", "hierarchical", "--link-tol", cfg["tol"],
               *shlex.split(args.hier_args), *ff_args, "--stats", os.path.join(wd, "formfactor.json"), "-o", ff, "-q"]
        if not builtin:
            cmd.append(os.path.join(REPO, obj))
        rec["t_formfactor"] = timed(cmd, lg)
        rec["t_solve"] = timed([os.path.join(build, "solve"), ff, *shlex.split(args.hier_solve_args), "-o", rad, "-q"],
                               lg)
        os.remove(ff)
    elif cfg["kind"] == "uniform":
        ff = os.path.join(wd, "formfactors")
        cmd = [os.path.join(build, "formfactor"), "--subdiv", str(cfg["subdiv"]), *ff_args,
               "--stats", os.path.join(wd, "formfactor.json"), "-o", ff, "-q"]
        if not builtin:
            cmd.append(os.path.join(REPO, obj))
        rec["t_formfactor"] = timed(cmd, lg)
        rec["t_solve"] = timed([os.path.join(build, "solve"), ff, "-o", rad, "-q"], lg)
        os.remove(ff)    # the matrix: large, and not needed again
    else:
        help_text = subprocess.run([refine, "--help"], capture_output=True, text=True, cwd=REPO)
        cmd = [refine, "--build", build, "--scene", "builtin" if builtin else os.path.join(REPO, obj),
               "--tol", cfg["tol"], "--out", wd]
        if "start" in cfg:
            cmd += ["--start-subdiv", cfg["start"], "--max-patches", cfg["max_patches"]]
        if "growth" in cfg:
            cmd += ["--growth", cfg["growth"], "--passes", "8"]
        if ff_args:
            if "--ff-args" in help_text.stdout + help_text.stderr:
                cmd += ["--ff-args", args.ff_args]
            else:
                rec["note"] = "refine.sh --help does not mention --ff-args: formfactor flags not passed"
        try:
            rec["t_refine"] = timed(cmd, lg)
        except RuntimeError as e:
            log(f"ours {scene} {cfg['name']}: {args.refine_script} {e}")
            return {"config": cfg["name"], "kind": cfg["kind"], "skipped": f"{args.refine_script} {e}"}
        rj = os.path.join(wd, "refine.json")
        if os.path.exists(rj):
            rec["refine"] = json.load(open(rj))
    rec["t_render"] = timed([os.path.join(build, "render"), rad, "--quantity", "radiance", "--width",
                             str(args.width), "--height", str(args.height), *render_camera_args(cam),
                             *shlex.split(args.render_args), "-o", img, "-q"], lg)
    rec["seconds"] = sum(v for k, v in rec.items() if k.startswith("t_"))
    rec["patches"] = patch_count(rad)
    rec["image"] = img
    json.dump(rec, open(meta, "w"), indent=1)
    log(f"ours {scene} {cfg['name']}: {rec['patches']} patches, {rec['seconds']:.1f} s")
    return rec


# ----------------------------------------------------------------------------- outputs


def diff_png(path, ours, ref, labels, width=256):
    """Signed relative error of Y, (ours - ref) / ref, on a 2 x 2-binned image, full colour at +-20 %;
    light and background grey."""
    import matplotlib.pyplot as plt
    H, W = ref.shape[:2]
    f = max(1, W // width)
    bin_ = lambda a: a[:H // f * f, :W // f * f].reshape(H // f, f, W // f, f).mean(axis=(1, 3))
    yo, yr = bin_(luminance(ours)), bin_(luminance(ref))
    ex = bin_(labels["exclude"].astype(float)) > 0
    floor = 0.05 * yr[~ex].mean()
    rel = (yo - yr) / np.maximum(yr, floor)
    rgba = plt.get_cmap("RdBu_r")(np.clip(rel / 0.4 + 0.5, 0, 1))
    rgba[ex] = (0.5, 0.5, 0.5, 1.0)
    plt.imsave(path, rgba)


def error_time_png(path, scene, rows, noise):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3.6), dpi=100)
    for kind, style in (("uniform", "o-"), ("refine", "s-"), ("hierarchical", "^-")):
        pts = sorted((r["seconds"], r["metrics"]["rel_rmse"], r["config"]) for r in rows
                     if r["kind"] == kind and "metrics" in r)
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], style, label="refined" if kind == "refine" else kind)
            for x, y, name in pts:
                ax.annotate(name, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    if noise:
        ax.axhline(noise, ls="--", c="grey", lw=1, label="reference noise (mean of 2 seeds)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("formfactor + solve + render wall time (s)")
    ax.set_ylabel("relative RMSE of luminance")
    ax.set_title(scene)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def fmt_pct(v):
    return "" if v is None else f"{v:+.1f} %"


def markdown(study):
    """The image_study.md text."""
    L = []
    ref0 = next(iter(study["scenes"].values()))["reference"]["runs"][0]
    L += ["## Images against a path-traced reference", "",
          f"Generated by `{study['command']}` on {study['machine']}, {study['date']} "
          f"(tools/image_study.py; {study['threads']} cores).", "",
          f"Reference: Mitsuba {ref0['mitsuba']} (`{ref0['variant']}`), `path` integrator with max_depth -1 "
          "(no depth limit, Russian roulette), box pixel filter, independent sampler, the scene's OBJ + MTL "
          "(true geometry; Kd diffuse, one-sided; Ke/π area emitters on the front side), same camera and "
          f"{study['width']} × {study['height']} pixels as `render`; {len(study['seeds'])} seeds × "
          f"{study['ref_spp']} spp, the reference is their mean. Ours: `formfactor {study['ff_args']}` → "
          f"`solve` → `render --quantity radiance` ({study['render_args'] or 'smooth shading, 16 spp'}), "
          "wall time of the three.", "",
          "Numbers are on luminance Y = 0.2126 R + 0.7152 G + 0.0722 B: *mean error* = mean(Y_ours) / "
          "mean(Y_ref) − 1 over all pixels but those touching the light and the background; *rel. RMSE* "
          "= sqrt(mean((Y_ours − Y_ref)²)) / mean(Y_ref) over the same pixels; *less noise*: "
          "sqrt(rel. RMSE² − noise²), the reference's own noise removed. Regions: pixels whose 3 × 3 "
          "sub-pixel rays all see one region (edge pixels count only in the overall numbers). "
          "Noise floor: seed-to-seed rel. RMSE; the mean of two seeds has half that (σ/√2 against σ√2).", ""]
    for scene, s in study["scenes"].items():
        ref = s["reference"]
        secs = ", ".join(f"{r['seconds']:.0f} s" for r in ref["runs"])
        L += [f"### {scene}", "",
              f"Camera: {s['camera_source']}. Reference: {len(ref['runs'])} × {ref['spp']} spp, render time "
              f"{secs} ({ref['runs'][0]['variant']}). Noise: seed-to-seed rel. RMSE "
              f"{ref.get('seed_to_seed_rel_rmse', float('nan')):.4f}, mean differs by "
              f"{ref.get('seed_to_seed_mean_pct', float('nan')):+.2f} %; the reference (mean) ≈ "
              f"{ref.get('mean_ref_rel_rmse', float('nan')):.4f}.", "",
              "| config | patches | time (s): ff + solve + render = total | mean error | rel. RMSE | less noise |",
              "|---|---:|---|---:|---:|---:|"]
        rows = s["runs"]
        for r in rows:
            if "skipped" in r:
                L.append(f"| {r['config']} | | {r['skipped']} | | | |")
                continue
            m = r["metrics"]
            parts = " + ".join(f"{r[k]:.2f}" for k in ("t_formfactor", "t_solve", "t_render") if k in r)
            if "t_refine" in r:
                parts = f"refine {r['t_refine']:.2f} + render {r['t_render']:.2f}"
            L.append(f"| {r['config']} | {r['patches']} | {parts} = {r['seconds']:.2f} | "
                     f"{fmt_pct(m['mean_error_pct'])} | {m['rel_rmse']:.4f} | {m['rel_rmse_less_noise']:.4f} |")
        done = [r for r in rows if "metrics" in r]
        if done:
            names = [n for n, v in sorted(done[0]["metrics"]["regions"].items(), key=lambda kv: -kv[1]["pixels"])
                     if v["pixels"] >= 200 and n != "light"]
            L += ["", "Mean error per region (ours/ref − 1; pixels; noise = the two seeds' difference):", "",
                  "| region | pixels | " + " | ".join(r["config"] for r in done) + " | noise |",
                  "|---|---:|" + "---:|" * (len(done) + 1)]
            for n in names:
                noise = ref.get("seed_to_seed_regions", {}).get(n)
                L.append(f"| {n} | {done[0]['metrics']['regions'][n]['pixels']} | " +
                         " | ".join(fmt_pct(r["metrics"]["regions"][n]["error_pct"]) for r in done) +
                         f" | {fmt_pct(noise)} |")
            L += ["", "Difference images (Y_ours / Y_ref − 1, blue: ours darker, red: ours brighter, full colour "
                  "at ±20 %; light and background grey): " +
                  " ".join(f"{r['config']} ![{scene} {r['config']}]({os.path.basename(r['diff_png'])})" for r in done),
                  "", f"![error against time, {scene}]({os.path.basename(s['plot'])})"]
        for r in rows:
            if r.get("note"):
                L.append(f"\nNote ({r['config']}): {r['note']}")
        L.append("")
    if study.get("notes"):
        L += ["### Notes", ""] + [f"- {n}" for n in study["notes"]] + [""]
    return "\n".join(L)


# ----------------------------------------------------------------------------- commands


def cmd_compare(args):
    labels = load_labels(args.labels) if args.labels else None
    out = compare(read_exr(args.ours), read_exr(args.ref), labels)
    print(json.dumps(out, indent=1))


def cmd_reference(args):
    for scene in args.scenes.split(","):
        info, _, _ = render_reference(scene, args)
        print(json.dumps({scene: {k: v for k, v in info.items()}}, indent=1))


def cmd_run(args):
    need("matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    os.makedirs(args.out, exist_ok=True)
    study = {"command": " ".join(shlex.quote(a) for a in ["tools/image_study.py"] + sys.argv[1:]),
             "machine": machine(), "threads": os.cpu_count(),
             "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
             "width": args.width, "height": args.height, "ref_spp": args.ref_spp,
             "seeds": [int(s) for s in args.seeds.split(",")], "ff_args": args.ff_args,
             "render_args": args.render_args, "scenes": {}, "notes": []}
    scenes = args.scenes.split(",")
    refs = {}
    for scene in scenes:          # all references first: our timings then run on an otherwise idle machine
        refs[scene] = render_reference(scene, args)
    for scene in scenes:
        info, ref, labels = refs[scene]
        cam = load_camera(scene)
        noise = info.get("mean_ref_rel_rmse", 0.0)
        rows = []
        for cfg in configurations(scene, args):
            rec = run_ours(scene, cfg, args, cam)
            rec = dict(rec)
            if "skipped" not in rec:
                ours = read_exr(rec["image"])
                m = compare(ours, ref, labels)
                m["rel_rmse_less_noise"] = math.sqrt(max(m["rel_rmse"] ** 2 - noise ** 2, 0.0))
                rec["metrics"] = m
                rec["diff_png"] = os.path.join(args.out, f"diff_{scene}_{cfg['name']}.png")
                diff_png(rec["diff_png"], ours, ref, labels)
            else:
                study["notes"].append(rec["skipped"] if "missing" in rec["skipped"]
                                      else f"{scene} {cfg['name']}: {rec['skipped']}")
            rows.append(rec)
        plot = os.path.join(args.out, f"error_time_{scene}.png")
        error_time_png(plot, scene, rows, noise)
        study["scenes"][scene] = {"camera": {k: cam[k] for k in ("eye", "look_at", "up", "fov_y")},
                                  "camera_source": cam["source"], "reference": info, "runs": rows, "plot": plot}
    study["notes"] = sorted(set(study["notes"]))
    json.dump(study, open(os.path.join(args.out, "image_study.json"), "w"), indent=1, default=float)
    open(os.path.join(args.out, "image_study.md"), "w").write(markdown(study))
    log(f"wrote {args.out}/image_study.md, image_study.json and PNGs")


def parse_args(argv):
    p = argparse.ArgumentParser(prog="image_study.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd")
    c = sub.add_parser("compare", help="numbers for one image pair, as JSON")
    c.add_argument("ours")
    c.add_argument("ref")
    c.add_argument("--labels", help="labels_<scene>_<W>x<H>.npz from the cache: regions, light left out")
    for name in ("run", "reference"):
        r = sub.add_parser(name, help="the whole study" if name == "run" else "only the references",
                           description="Options: see image_study.py --help.")
        r.add_argument("--build", default="build")
        r.add_argument("--scenes", default="cornell_box,cornell_sphere,cluttered_room")
        r.add_argument("--min-subdiv", type=int, default=2)
        r.add_argument("--max-subdiv", type=int, default=4)
        r.add_argument("--max-patches", type=int, default=20000)
        r.add_argument("--ff-args", default="--quad-rtol 1e-5 --shadow-rays 16")
        r.add_argument("--render-args", default="", help="extra render flags (e.g. '--shading flat')")
        r.add_argument("--refine-tols", default="0.05")
        r.add_argument("--refine-budgets", default="",
                       help="START:MAX_PATCHES,... for every scene (default: REFINE_BUDGETS per scene)")
        r.add_argument("--refine-script", default=os.path.join(REPO, "scripts", "refine.sh"))
        r.add_argument("--hier-tols", default="1e-2,3e-3,1e-3",
                       help="formfactor --method hierarchical at each --link-tol; \"\" for none")
        r.add_argument("--hier-args", default="", help="extra formfactor flags for the hierarchical runs")
        r.add_argument("--hier-solve-args", default="",
                       help="extra solve flags for the hierarchical runs (e.g. --shape off)")
        r.add_argument("--width", type=int, default=512)
        r.add_argument("--height", type=int, default=512)
        r.add_argument("--ref-spp", type=int, default=2048)
        r.add_argument("--seeds", default="1,2")
        r.add_argument("--variant", default="auto", choices=("auto", "scalar_rgb", "llvm_ad_rgb"))
        r.add_argument("--cache", default=os.path.join("build", "study"))
        r.add_argument("--out", default="docs")
        r.add_argument("--rerun", action="store_true")
    if not argv or argv[0] not in ("run", "reference", "compare", "-h", "--help"):
        argv = ["run"] + list(argv)
    args = p.parse_args(argv)
    names = []
    for s in getattr(args, "scenes", "").split(",") if args.cmd != "compare" else []:
        if s.endswith(".obj") and os.path.exists(s):   # a scene file of one's own, its camera beside it
            name = os.path.splitext(os.path.basename(s))[0]
            SCENES[name] = (os.path.abspath(s), False)
            if not os.path.exists(os.path.splitext(s)[0] + ".camera"):
                p.error(f"{s}: no camera file {os.path.splitext(s)[0]}.camera beside it")
            s = name
        if s not in SCENES:
            p.error(f"unknown scene '{s}' (known: {', '.join(SCENES)}, or an .obj file with a .camera beside it)")
        names.append(s)
    if args.cmd != "compare":
        args.scenes = ",".join(names)
    return args


def main(argv):
    args = parse_args(argv)
    try:
        dispatch(args)
    except RuntimeError as e:
        sys.exit(f"image_study.py: {e}")


def dispatch(args):
    if args.cmd == "compare":
        cmd_compare(args)
    elif args.cmd == "reference":
        cmd_reference(args)
    else:
        cmd_run(args)


if __name__ == "__main__":
    main(sys.argv[1:])
