#!/usr/bin/env python3
"""Blender scene -> layered POMC panorama: bake the lit look of every mesh, export glTF, `pomc scene`.

`pomc scene` traces every surface along every ray of the panorama but computes no lighting: a hit's
colour is its material's base colour plus emission. This script gives it a lit scene: it bakes each
object's appearance under the scene's lights and world with Cycles into one texture per object,
swaps the object's materials for an Emission shader of that texture (glTF: black base colour,
emissiveTexture), exports the meshes as .glb (+Y up, modifiers applied), exports the world as an
equirect EXR (or a colour), and runs `pomc scene` from the panorama centre.

  <python with bpy> tools/blender/scene_to_pomc.py (--blend FILE | --corpus room|outdoor|extreme)
        -o PANO_DIR [--center x,y,z] [--freedom-radius 0.9] [--width 2048] [--samples 4]
        [--bake-samples 8] [--bake-type combined|diffuse] [--view-from centre|normal]
        [--texels-per-metre 64] [--max-texture 2048] [--min-texture 32] [--uv auto|smart]
        [--render-samples 16] [--peels 3] [--no-denoise] [--sky-samples 4] [--work DIR] [--report FILE] [--pomc BIN] [--keep-blend]

  e.g. target/bpy-venv/bin/python tools/blender/scene_to_pomc.py --corpus room -o target/scene-eval/room/pano \
           --width 1024 --freedom-radius 0.9 --pomc /tmp/pomc-scene-1

Steps (each timed, printed as `[scene_to_pomc] step: N s`, and written to the report JSON):
  load      open the .blend, or build a corpus scene with tools/eval/realistic/scenes.py
  prepare   make instances real, convert curves/text/metaballs to meshes with modifiers applied, make
            object data and materials single-user, give objects without UVs (or with UVs outside
            [0, 1] or overlapping, with --uv auto; every object with --uv smart) a smart-projected UV
            map; one float image per object, sized from the object's area and its distance to the
            centre (texel density min(--texels-per-metre, 1.5 x panorama density at the nearest point an
            eye in the freedom ball can be), capped by --max-texture)
  render    every hit lit as Cycles renders it (thesis 6.3.2 shades every intersection along a ray):
            --peels equirect Cycles renders at --width (--render-samples, OIDN) of the 1st, 2nd, ...
            surface along each ray from the centre (depth peeling: each material is wrapped so camera
            rays pass through the surfaces before; shadow and bounce rays see it as it is); `pomc scene
            --colour` puts render k on each pixel's k-th hit. The bake below colours the hits past the
            last peel (--peels 0: the bake colours everything)
  bake      one Cycles bake of all objects: COMBINED (direct + indirect diffuse, glossy, transmission
            and emission; glossy seen from the panorama centre with --view-from centre), or DIFFUSE
            (direct + indirect + colour). Low samples; then each image is denoised (OIDN, compositor)
  export    Emission-shader materials, .glb (only the baked meshes; no lights, cameras)
  sky       the world: a plain colour goes to --sky-colour; any other world (environment texture, sky
            texture, gradient) is rendered by an equirect camera at the centre into sky.exr (the
            `blender` convention)
  pomc      `pomc scene SCENE.glb -o PANO_DIR --center ... --json`

What a bake cannot carry: view-dependent looks (glossy reflections are baked as seen from the centre,
or along the normal), transparency and refraction, lights seen directly (light objects are not
meshes), and HDR above 1 (the glTF texture is 8-bit sRGB). One image per object means a huge object
(a 400 m ground plane) gets one coarse texel density.

Typical run time (2 cores shared with a CI run, Blender 5.0, --width 1024, the defaults): corpus room
4.0 min (peels 185 s, bake 48 s), outdoor 4.8 min (peels 96 s, bake 165 s), extreme 4.0 min (peels
80 s, bake 132 s); `pomc scene` itself 1-2 s.
Environment: POMC_BIN (default for --pomc; else target/release/pomc).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import bpy
import bmesh
import numpy as np
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
# An equirect camera with this rotation has its centre column along +X and +Z up (azimuth pi(1 - 2u)):
# pomc's `blender` convention (as tools/eval/realistic/scenes.py renders the corpus).
PANO_ROTATION = (math.radians(90), 0.0, math.radians(-90))
BAKE_UV = "pomc_bake"
GEOMETRY = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def log(msg):
    print(f"[scene_to_pomc] {msg}", flush=True)


class Timer:
    """Wall-clock seconds of each named step."""

    def __init__(self):
        self.steps = {}

    def __call__(self, name):
        timer = self

        class Step:
            def __enter__(self):
                self.t = time.perf_counter()
                log(f"{name} ...")

            def __exit__(self, *exc):
                timer.steps[name] = round(time.perf_counter() - self.t, 2)
                log(f"{name}: {timer.steps[name]:.1f} s")

        return Step()


# ---------------------------------------------------------------- loading

def load_corpus(name):
    """Build a corpus scene (tools/eval/realistic/scenes.py) into an empty file; returns the centre."""
    sys.path.insert(0, os.path.join(ROOT, "tools", "eval", "realistic"))
    import scenes
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scenes.SCENES[name]()
    c = bpy.context.scene.cycles
    c.max_bounces, c.sample_clamp_indirect = 4, 10.0  # as the corpus renders (scenes.setup_render)
    return Vector((0.0, 0.0, 0.0))  # the corpus panorama camera


def load_blend(path):
    """Open a .blend; the centre defaults to its scene camera (else the origin)."""
    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(path))
    cam = bpy.context.scene.camera
    return cam.matrix_world.translation.copy() if cam else Vector((0.0, 0.0, 0.0))


# ---------------------------------------------------------------- preparing the meshes

def select_only(objs, active=None):
    bpy.ops.object.select_all(action="DESELECT")
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = active or (objs[0] if objs else None)


def renderable(o):
    return o.type in GEOMETRY and not o.hide_render and o.visible_get()


def prepare_objects():
    """Every renderable geometry object as a single-user mesh with its modifiers applied."""
    if bpy.context.object and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    scene = bpy.context.scene
    for ob in bpy.context.view_layer.objects:  # operators skip hidden objects: show what renders
        if ob.type in GEOMETRY and not ob.hide_render:
            ob.hide_viewport = False
            ob.hide_set(False)
    inst = [o for o in scene.objects if o.visible_get() and (o.instance_type != "NONE" or o.particle_systems)]
    if inst:
        select_only(inst)
        bpy.ops.object.duplicates_make_real()
    objs = [o for o in scene.objects if renderable(o)]
    select_only(objs)
    bpy.ops.object.make_single_user(object=True, obdata=True, material=True)
    bpy.ops.object.convert(target="MESH")  # applies modifiers; curves, text, metaballs become meshes
    objs = [o for o in scene.objects if o.type == "MESH" and renderable(o) and len(o.data.polygons)]
    for o in objs:
        if not o.material_slots:  # Cycles shades a material-less surface grey: bake that
            m = bpy.data.materials.new(f"{o.name}-default")
            o.data.materials.append(m)
    return objs


def uv_area(mesh, layer):
    """Total UV area and whether every coordinate is inside [0, 1]."""
    uv = np.zeros(len(mesh.loops) * 2)
    mesh.uv_layers[layer].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    inside = bool(((uv > -1e-4) & (uv < 1 + 1e-4)).all())
    area = 0.0
    mesh.calc_loop_triangles()
    tris = np.zeros(len(mesh.loop_triangles) * 3, np.int64)
    mesh.loop_triangles.foreach_get("loops", tris)
    t = uv[tris.reshape(-1, 3)]
    if len(t):
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        area = float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() / 2)
    return area, inside


def world_area(o):
    bm = bmesh.new()
    bm.from_mesh(o.data)
    bm.transform(o.matrix_world)
    a = sum(f.calc_area() for f in bm.faces)
    bm.free()
    return a


def near_distance(o, centre):
    """Distance from the centre to the object's world bounding box (0 inside it)."""
    pts = [o.matrix_world @ Vector(b) for b in o.bound_box]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    return Vector([max(lo[k] - centre[k], 0.0, centre[k] - hi[k]) for k in range(3)]).length


def texture_size(area, coverage, dist, o):
    """Square texture side: texel density from the area and the distance the object is seen at."""
    pano = 1.5 * o.width / (2 * math.pi)  # texels per radian, 1.5 x the panorama's
    density = min(o.texels_per_metre, pano / max(dist - o.freedom_radius, 0.25))
    side = math.sqrt(area / max(coverage, 0.05)) * density
    return int(min(o.max_texture, max(o.min_texture, 8 * math.ceil(side / 8))))


def unwrap(o, size):
    """A new smart-projected UV map BAKE_UV (islands ~4 texels apart). The render UV map stays the
    one the materials read; the others are dropped after the bake."""
    me = o.data
    if len(me.uv_layers) >= 8:  # Blender's limit: drop the last non-render map
        me.uv_layers.remove([l for l in me.uv_layers if not l.active_render][-1])
    render = next((l.name for l in me.uv_layers if l.active_render), None)
    me.uv_layers.active = me.uv_layers.new(name=BAKE_UV)
    if render:
        me.uv_layers[render].active_render = True
    select_only([o])
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=min(0.05, 4.0 / size),
                             margin_method="FRACTION", scale_to_bounds=False)
    bpy.ops.object.mode_set(mode="OBJECT")
    return BAKE_UV


def plan_textures(objs, centre, o):
    """One float image per object, on a usable UV map; returns [(object, image, facts)]."""
    plan = []
    for ob in objs:
        area, dist = world_area(ob), near_distance(ob, centre)
        me = ob.data
        keep = False
        if o.uv == "auto" and me.uv_layers:
            uv = me.uv_layers.active.name
            cover, inside = uv_area(me, uv)
            keep = inside and 0.2 <= cover <= 1.001  # in [0, 1], not overlapping (area), not wasteful
        if not keep:
            uv = unwrap(ob, texture_size(area, 0.7, dist, o))
        cover, _ = uv_area(me, uv)
        size = texture_size(area, cover, dist, o)
        img = bpy.data.images.new(f"bake-{ob.name}", size, size, float_buffer=True, alpha=False)
        plan.append((ob, img, dict(object=ob.name, uv_map=uv, area_m2=round(area, 3), distance_m=round(dist, 3),
                                   uv="kept" if keep else "smart", uv_coverage=round(cover, 3), texture=size)))
    return plan


def add_bake_nodes(plan):
    """In each (single-user) material of each object: an active image node of the object's image."""
    for ob, img, facts in plan:
        for slot in ob.material_slots:
            m = slot.material
            if m is None:
                continue
            m.use_nodes = True
            nt = m.node_tree
            uv = nt.nodes.new("ShaderNodeUVMap")
            uv.uv_map = facts["uv_map"]
            tex = nt.nodes.new("ShaderNodeTexImage")
            tex.image = img
            tex.name = "pomc-bake"
            nt.links.new(uv.outputs["UV"], tex.inputs["Vector"])
            for n in nt.nodes:
                n.select = False
            tex.select = True
            nt.nodes.active = tex


# ---------------------------------------------------------------- baking

def bake(plan, centre, o):
    s = bpy.context.scene
    s.render.engine = "CYCLES"
    s.cycles.device = "CPU"
    s.cycles.samples = o.bake_samples
    s.cycles.use_denoising = False  # Cycles does not denoise bakes: see denoise()
    cam = bpy.data.objects.new("pomc-bake-camera", bpy.data.cameras.new("pomc-bake-camera"))
    s.collection.objects.link(cam)
    cam.location = centre
    s.camera = cam
    b = s.render.bake
    b.view_from = "ACTIVE_CAMERA" if o.view_from == "centre" else "ABOVE_SURFACE"
    b.margin, b.margin_type = 4, "EXTEND"
    b.use_clear, b.target = True, "IMAGE_TEXTURES"
    objs = [ob for ob, _, _ in plan]
    select_only(objs)
    if o.bake_type == "combined":
        bpy.ops.object.bake(type="COMBINED", pass_filter={"DIRECT", "INDIRECT", "DIFFUSE", "GLOSSY",
                                                          "TRANSMISSION", "EMIT"}, margin=4, use_clear=True)
    else:
        bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT", "COLOR"}, margin=4, use_clear=True)


def denoise(img, work):
    """OIDN through the compositor (an Image -> Denoise -> Group Output tree, rendered by Workbench at
    the image's size); the image is denoised in place (and saved as WORK/<image>.exr)."""
    s = bpy.context.scene
    ng = bpy.data.node_groups.get("pomc-denoise")
    if ng is None:
        ng = bpy.data.node_groups.new("pomc-denoise", "CompositorNodeTree")
        ng.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        src, d, out = ng.nodes.new("CompositorNodeImage"), ng.nodes.new("CompositorNodeDenoise"), ng.nodes.new("NodeGroupOutput")
        src.name = "src"
        d.inputs["HDR"].default_value = True
        ng.links.new(src.outputs["Image"], d.inputs["Image"])
        ng.links.new(d.outputs["Image"], out.inputs[0])
    ng.nodes["src"].image = img
    engine, comp = s.render.engine, s.compositing_node_group
    res = s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage
    s.compositing_node_group, s.render.use_compositing = ng, True
    s.render.engine = "BLENDER_WORKBENCH"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = img.size[0], img.size[1], 100
    hidden = [ob for ob in s.objects if not ob.hide_render]
    for ob in hidden:  # nothing to draw: only the compositor's output matters
        ob.hide_render = True
    bpy.ops.render.render()
    for ob in hidden:
        ob.hide_render = False
    path = os.path.join(work, f"{img.name}.exr")
    save_exr(bpy.data.images["Render Result"], path)
    s.render.engine, s.compositing_node_group = engine, comp
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = res
    # Back into the baked (generated, float) image: the glTF exporter encodes such an image to sRGB
    # PNG, but writes a loaded linear EXR's values unencoded (pomc would then read it far too dark).
    out = bpy.data.images.load(path)
    px = np.empty(len(out.pixels), np.float32)
    out.pixels.foreach_get(px)
    img.pixels.foreach_set(px)
    img.update()
    bpy.data.images.remove(out)
    return img


def save_exr(image, path):
    im = bpy.context.scene.render.image_settings
    im.media_type = "IMAGE"
    im.file_format, im.color_mode, im.color_depth, im.exr_codec = "OPEN_EXR", "RGB", "32", "ZIP"
    image.save_render(path, scene=bpy.context.scene)


# ---------------------------------------------------------------- export

def emission_material(name, img, uv_map):
    """Emission shader of the baked image: glTF black base colour + emissiveTexture (pomc adds them)."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    uv, tex = nt.nodes.new("ShaderNodeUVMap"), nt.nodes.new("ShaderNodeTexImage")
    em, out = nt.nodes.new("ShaderNodeEmission"), nt.nodes.new("ShaderNodeOutputMaterial")
    uv.uv_map = uv_map
    tex.image = img
    tex.extension = "EXTEND"  # glTF CLAMP_TO_EDGE: no bleeding across the atlas border
    nt.links.new(uv.outputs["UV"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], em.inputs["Color"])
    nt.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return m


def export_glb(plan, path):
    for ob, img, facts in plan:
        me = ob.data
        for layer in [l.name for l in me.uv_layers if l.name != facts["uv_map"]]:
            me.uv_layers.remove(me.uv_layers[layer])  # the baked map becomes glTF's TEXCOORD_0
        me.materials.clear()
        me.materials.append(emission_material(f"pomc-{ob.name}", img, facts["uv_map"]))
        me.polygons.foreach_set("material_index", np.zeros(len(me.polygons), np.int32))
    select_only([ob for ob, _, _ in plan])
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_selection=True, export_yup=True,
                              export_apply=True, export_lights=False, export_cameras=False,
                              export_materials="EXPORT", export_image_format="AUTO", export_texcoords=True,
                              export_normals=True, export_vertex_color="NONE", export_extras=False)


def pano_camera(centre):
    """An equirect camera at the centre, in pomc's `blender` convention, made the scene camera."""
    s = bpy.context.scene
    cam = bpy.data.objects.new("pomc-pano-camera", bpy.data.cameras.new("pomc-pano-camera"))
    s.collection.objects.link(cam)
    cam.data.type, cam.data.panorama_type = "PANO", "EQUIRECTANGULAR"
    cam.data.clip_start, cam.data.clip_end = 0.001, 1e5
    cam.location, cam.rotation_euler = centre, PANO_ROTATION
    s.camera = cam
    return cam


def peel_materials(objs):
    """Wrap every material of `objs` so that a camera ray passes through its first K surfaces (a
    Transparent BSDF while the path's transparent depth is below K; shadow, diffuse and glossy rays
    see the material as it is, so lighting and shadows stay). Returns (set K, undo)."""
    thresholds, undo = [], []
    for m in {slot.material for ob in objs for slot in ob.material_slots if slot.material}:
        m.use_nodes = True
        nt = m.node_tree
        out = next((n for n in nt.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
        if out is None or not out.inputs["Surface"].is_linked:
            continue
        src = out.inputs["Surface"].links[0].from_socket
        lp, below, cam = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeMath"), nt.nodes.new("ShaderNodeMath")
        mix, clear = nt.nodes.new("ShaderNodeMixShader"), nt.nodes.new("ShaderNodeBsdfTransparent")
        below.operation, cam.operation = "LESS_THAN", "MULTIPLY"
        below.inputs[1].default_value = 0.0
        nt.links.new(lp.outputs["Transparent Depth"], below.inputs[0])
        nt.links.new(below.outputs[0], cam.inputs[0])
        nt.links.new(lp.outputs["Is Camera Ray"], cam.inputs[1])
        nt.links.new(cam.outputs[0], mix.inputs["Fac"])
        nt.links.new(src, mix.inputs[1])
        nt.links.new(clear.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], out.inputs["Surface"])
        thresholds.append(below)
        undo.append((nt, src, out, [lp, below, cam, mix, clear]))

    def set_k(k):
        for node in thresholds:
            node.inputs[1].default_value = float(k)

    def restore():
        for nt, src, out, nodes in undo:
            nt.links.new(src, out.inputs["Surface"])
            for n in nodes:
                nt.nodes.remove(n)
    return set_k, restore


def render_centre(centre, work, o, objs):
    """The scene as the centre sees it, with its own materials and lights: equirect Cycles renders
    (OIDN-denoised) of the 1st, 2nd, ... surface along every ray (depth peeling: the surfaces before
    are made transparent to camera rays only), which `pomc scene --colour` puts on each pixel's hits
    in order. Returns their paths."""
    s = bpy.context.scene
    pano_camera(centre)
    s.render.engine = "CYCLES"
    s.cycles.device, s.cycles.samples = "CPU", o.render_samples
    s.cycles.use_denoising = not o.no_denoise
    if s.cycles.use_denoising:
        s.cycles.denoiser = "OPENIMAGEDENOISE"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = o.width, o.width // 2, 100
    s.render.film_transparent = False
    s.render.use_compositing = False
    s.view_settings.view_transform, s.view_settings.look = "Standard", "None"
    s.cycles.transparent_max_bounces = max(s.cycles.transparent_max_bounces, o.peels + 1)
    set_k, restore = peel_materials(objs)
    paths = []
    try:
        filter_width = s.cycles.filter_width
        for k in range(o.peels):
            set_k(k)
            # The first peel is what the centre sees, anti-aliased as any render. A later peel's
            # pixel must be its own hit's colour: anti-aliasing would mix in, at the peel's edges,
            # the next surface or the sky (a peel ends where a ray has fewer hits).
            s.cycles.filter_width = filter_width if k == 0 else 0.01
            bpy.ops.render.render()
            paths.append(os.path.join(work, f"centre-{k}.exr"))
            save_exr(bpy.data.images["Render Result"], paths[-1])
            log(f"render of hit {k + 1}: {paths[-1]}")
    finally:
        restore()
        s.cycles.filter_width = filter_width
    return paths


def sky(centre, work, o):
    """pomc sky options: --sky-colour of a plain world, else an equirect EXR of the rendered world."""
    w = bpy.context.scene.world
    if w is None:
        return ["--sky-colour", "0,0,0"], "none (black)"
    if not w.use_nodes or w.node_tree is None:
        return ["--sky-colour", ",".join(f"{c:g}" for c in w.color)], "colour"
    nt = w.node_tree
    out = next((n for n in nt.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    link = out.inputs["Surface"].links[0] if out and out.inputs["Surface"].is_linked else None
    if link is None:
        return ["--sky-colour", "0,0,0"], "none (black)"
    bg = link.from_node
    if bg.type == "BACKGROUND" and not bg.inputs["Color"].is_linked and not bg.inputs["Strength"].is_linked:
        k = bg.inputs["Strength"].default_value
        return ["--sky-colour", ",".join(f"{k * c:g}" for c in bg.inputs["Color"].default_value[:3])], "colour"
    # Anything else: render the world alone through an equirect camera at the centre.
    s = bpy.context.scene
    pano_camera(centre)
    shown = [ob for ob in s.objects if not ob.hide_render]
    for ob in shown:
        ob.hide_render = True
    s.render.engine = "CYCLES"
    # The world alone is smooth: a few samples are exact enough, and a denoiser would only blur it.
    s.cycles.samples, s.cycles.use_denoising = o.sky_samples, False
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = o.width, o.width // 2, 100
    s.render.film_transparent = False
    s.render.use_compositing = False
    bpy.ops.render.render()
    for ob in shown:
        ob.hide_render = False
    path = os.path.join(work, "sky.exr")
    save_exr(bpy.data.images["Render Result"], path)
    return ["--sky", path], "rendered world (equirect EXR)"


# ---------------------------------------------------------------- main

def options(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--blend", help=".blend file")
    src.add_argument("--corpus", choices=["room", "outdoor", "extreme"], help="a scene of tools/eval/realistic/scenes.py")
    p.add_argument("-o", "--output", required=True, help="panorama directory")
    p.add_argument("--center", help="panorama centre x,y,z (Blender world); default the scene camera / origin")
    p.add_argument("--freedom-radius", type=float, default=0.9)
    p.add_argument("--width", type=int, default=2048, help="panorama width")
    p.add_argument("--samples", type=int, default=4, help="pomc scene rays per pixel")
    p.add_argument("--bake-samples", type=int, default=8)
    p.add_argument("--bake-type", choices=["combined", "diffuse"], default="combined")
    p.add_argument("--view-from", choices=["centre", "normal"], default="centre",
                   help="view direction of the bake (glossy): from the panorama centre, or along the normal")
    p.add_argument("--texels-per-metre", type=float, default=64.0, help="largest texel density")
    p.add_argument("--max-texture", type=int, default=2048)
    p.add_argument("--min-texture", type=int, default=32)
    p.add_argument("--uv", choices=["auto", "smart"], default="auto",
                   help="auto: keep an object's UVs when inside [0, 1] and not overlapping; smart: always re-unwrap")
    p.add_argument("--no-denoise", action="store_true")
    p.add_argument("--sky-samples", type=int, default=4)
    p.add_argument("--render-samples", type=int, default=16,
                   help="samples of the render from the centre that colours what the centre sees")
    p.add_argument("--peels", type=int, default=3,
                   help="renders from the centre: the 1st, 2nd, ... surface along each ray (0: none, "
                        "every surface keeps its baked colour)")
    p.add_argument("--work", help="intermediate files (default PANO_DIR-work)")
    p.add_argument("--report", help="report JSON (default WORK/report.json)")
    p.add_argument("--pomc", default=os.environ.get("POMC_BIN", os.path.join(ROOT, "target", "release", "pomc")))
    p.add_argument("--keep-blend", action="store_true", help="save the baked scene as WORK/baked.blend")
    return p.parse_args(argv)


def main():
    argv = sys.argv[1:]
    o = options(argv[argv.index("--") + 1:] if "--" in argv else argv)
    work = os.path.abspath(o.work or o.output.rstrip("/") + "-work")
    os.makedirs(work, exist_ok=True)
    t = Timer()
    with t("load"):
        centre = load_corpus(o.corpus) if o.corpus else load_blend(o.blend)
    if o.center:
        centre = Vector([float(x) for x in o.center.split(",")])
    log(f"centre {tuple(round(c, 4) for c in centre)}")
    with t("prepare"):
        objs = prepare_objects()
        plan = plan_textures(objs, centre, o)
        add_bake_nodes(plan)
    texels = sum(img.size[0] * img.size[1] for _, img, _ in plan)
    log(f"{len(plan)} objects, {texels / 1e6:.2f} M texels: " +
        ", ".join(f"{f['object']} {f['texture']}" for _, _, f in plan))
    renders = []
    if o.peels > 0:
        with t("render"):
            renders = render_centre(centre, work, o, [ob for ob, _, _ in plan])
    with t("bake"):
        bake(plan, centre, o)
    if not o.no_denoise:
        with t("denoise"):
            for _, img, _ in plan:
                denoise(img, work)
    glb = os.path.join(work, "scene.glb")
    with t("export"):
        export_glb(plan, glb)
    with t("sky"):
        sky_args, sky_kind = sky(centre, work, o)
    if o.keep_blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(work, "baked.blend"))
    cmd = [o.pomc, "scene", glb, "-o", o.output, f"--center={','.join(f'{c:g}' for c in centre)}",
           "--freedom-radius", f"{o.freedom_radius:g}", "--width", str(o.width), "--samples", str(o.samples),
           *sky_args, *[a for r in renders for a in ("--colour", r)], "--convention", "blender", "--json"]
    with t("pomc scene"):
        p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        log(f"pomc scene failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr[-3000:]}")
    try:
        pomc_report = json.loads(p.stdout)
    except json.JSONDecodeError:
        pomc_report = None
    report = dict(source=o.blend or f"corpus:{o.corpus}", centre=list(centre), glb=glb, glb_bytes=os.path.getsize(glb),
                  sky=sky_kind, sky_args=sky_args, command=cmd, returncode=p.returncode,
                  stderr=p.stderr[-3000:] if p.returncode else "", seconds=t.steps, texels=texels,
                  objects=[f for _, _, f in plan], options=vars(o), pomc=pomc_report)
    path = o.report or os.path.join(work, "report.json")
    with open(path, "w") as fh:
        json.dump(report, fh, indent=1)
    log("times: " + ", ".join(f"{k} {v:.1f} s" for k, v in t.steps.items()) + f"; total {sum(t.steps.values()):.1f} s")
    log(f"report {path}; panorama {o.output}")
    sys.exit(0 if p.returncode == 0 else 1)


if __name__ == "__main__":
    main()
