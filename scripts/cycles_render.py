"""Render a polyrad scene (JSON + OBJ) with Blender's Cycles on the CPU, to a linear EXR.

Run inside Blender's Python (docs/cycles-study.md):

    blender -b --factory-startup -P scripts/cycles_render.py -- SCENE.json -o OUT.exr \
        [--spp N] [--threads N] [--seed S] [--phong refuse|beckmann] [--scale S] \
        [--light-threshold T] [--blend FILE.blend]

What it builds, so that Cycles computes what polyrad's path tracer computes:
- geometry: every `polygon` and every OBJ face with the same vertices, in the same order (the
  front is the counter-clockwise side in both programs), flat shaded, all coordinates scaled
  so that the longest emitting edge is 1e-3 long (radiance does not depend on the units;
  Cycles 3.4's mesh-light sampling does: see auto_scale);
- materials: diffuse -> Diffuse BSDF (Lambert); mirror -> Glossy BSDF, Sharp, colour =
  reflectance; glossy -> Diffuse BSDF(diffuse) + Glossy BSDF(GGX, colour = specular,
  roughness = sqrt(alpha), because Blender squares its roughness into the GGX alpha; no
  Fresnel, as polyrad's constant-Fresnel lobe); phong -> refused, as Cycles has no Phong
  closure without OSL, or with --phong beckmann approximated by Beckmann whose peak and width
  at normal incidence match, alpha = 1 / sqrt(2 (n + 2));
- one-sided surfaces: the shader is mixed, by Geometry > Backfacing, with a black diffuse BSDF:
  the back reflects and emits nothing and still blocks light, as in polyrad;
- emission: Emission shader of strength 1 and colour = the object's radiance, added to its
  material on the front side only;
- camera: same position, look-at and up (image right = forward x up, Blender's own
  convention), field of view across the shorter image side, same resolution;
- film: black world, box pixel filter 1 px wide (polyrad's box pixel), no denoising, no
  clamping, no glossy filter, caustics on, no adaptive sampling, 64 bounces of every kind,
  linear scene-referred output (Standard view, 32-bit float EXR).

It prints one line `cycles: ...` with the seconds spent loading the scene and rendering.
"""
import argparse
import json
import math
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector

T_START = time.time()


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_render.py")
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True, help="linear EXR (32-bit float)")
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--threads", type=int, default=0, help="0: all")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--phong", choices=("refuse", "beckmann"), default="refuse",
                   help="Phong has no Cycles closure: refuse the scene (default) or "
                        "approximate the lobe by Beckmann of the same peak")
    p.add_argument("--bounces", type=int, default=64)
    p.add_argument("--light-threshold", type=float, default=None,
                   help="Cycles' light sampling threshold (default: Blender's, 0.01)")
    p.add_argument("--scale", type=float, default=0.0,
                   help="multiply every coordinate by this (default: 1e-3 / the longest edge "
                        "of an emitting face; see auto_scale)")
    p.add_argument("--blend", help="also save the built scene as a .blend file")
    return p.parse_args(argv)


def fail(msg):
    print("cycles_render: error: " + msg, file=sys.stderr)
    sys.exit(2)


# ---- reading the polyrad scene -----------------------------------------------------------

def read_obj(path):
    verts, faces = [], []
    with open(path) as f:
        for lineno, line in enumerate(f, 1):
            s = line.split("#", 1)[0].split()
            if not s:
                continue
            if s[0] == "v":
                verts.append(tuple(float(c) for c in s[1:4]))
            elif s[0] == "f":
                idx = []
                for tok in s[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                faces.append(idx)
            elif s[0] in ("vn", "vt", "vp", "g", "o", "s", "usemtl", "mtllib"):
                continue
            else:
                fail("%s:%d: unknown OBJ statement %r" % (path, lineno, s[0]))
    return verts, faces


def object_geometry(obj, scene_dir):
    if "polygon" in obj:
        pts = [tuple(float(c) for c in p) for p in obj["polygon"]]
        return pts, [list(range(len(pts)))]
    return read_obj(os.path.join(scene_dir, obj["mesh"]))


# ---- materials ---------------------------------------------------------------------------

def new_material(name, spec, emission, phong_mode):
    """A Cycles material equal to polyrad material `spec` on the front side, black (absorbing,
    not emitting) on the back; `emission` is the front's radiance or None."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.target = "CYCLES"

    def diffuse(colour):
        n = nt.nodes.new("ShaderNodeBsdfDiffuse")
        n.inputs["Color"].default_value = (*colour, 1.0)
        n.inputs["Roughness"].default_value = 0.0
        return n.outputs["BSDF"]

    def glossy(colour, distribution, alpha):
        n = nt.nodes.new("ShaderNodeBsdfGlossy")
        n.distribution = distribution
        n.inputs["Color"].default_value = (*colour, 1.0)
        # Blender's roughness r becomes the microfacet alpha r^2.
        n.inputs["Roughness"].default_value = math.sqrt(alpha)
        return n.outputs["BSDF"]

    def add(a, b):
        n = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(a, n.inputs[0])
        nt.links.new(b, n.inputs[1])
        return n.outputs["Shader"]

    t = spec["type"]
    if t == "diffuse":
        front = diffuse(spec["reflectance"])
    elif t == "mirror":
        front = glossy(spec["reflectance"], "SHARP", 0.0)
    elif t == "glossy":
        # polyrad: below alpha 1e-3 the lobe is the perfect mirror.
        alpha = float(spec["roughness"])
        lobe = glossy(spec["specular"], "SHARP" if alpha < 1e-3 else "GGX", alpha)
    elif t == "phong":
        if phong_mode == "refuse":
            fail("material %r: Cycles 3.4 has no Phong lobe (without OSL); --phong beckmann "
                 "approximates it" % name)
        # Beckmann's Gaussian core, exp(-tan^2 / alpha^2), matches the Phong lobe's cos^n
        # about the mirror direction at normal incidence (peak and width) when
        # alpha^2 = 1 / (2 (n + 2)). Away from it the two differ: a microfacet lobe keeps its
        # albedo near 1 at grazing angles, where the modified Phong lobe's falls with
        # cos(theta_i) (docs/cycles-study.md has the figures).
        alpha = 1.0 / math.sqrt(2.0 * (float(spec["exponent"]) + 2.0))
        print("cycles_render: material %r: Phong n = %g approximated by Beckmann alpha %.4f"
              % (name, spec["exponent"], alpha))
        lobe = glossy(spec["specular"], "BECKMANN", alpha)
    else:
        fail("material %r: unknown type %r" % (name, t))
    if t in ("glossy", "phong"):
        d = spec.get("diffuse", [0.0, 0.0, 0.0])
        front = add(diffuse(d), lobe) if max(d) > 0 else lobe

    if emission is not None:
        e = nt.nodes.new("ShaderNodeEmission")
        e.inputs["Color"].default_value = (*emission, 1.0)
        e.inputs["Strength"].default_value = 1.0
        front = add(front, e.outputs["Emission"])

    geom = nt.nodes.new("ShaderNodeNewGeometry")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(geom.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(front, mix.inputs[1])
    nt.links.new(diffuse((0.0, 0.0, 0.0)), mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    if emission is not None:
        # Emission sampling (the property's name changed in Blender 3.5).
        if hasattr(m.cycles, "sample_as_light"):
            m.cycles.sample_as_light = True
        if hasattr(m.cycles, "emission_sampling"):
            m.cycles.emission_sampling = "FRONT"
    return m


# ---- scene -------------------------------------------------------------------------------

def auto_scale(objects, geometry):
    """A scale for the coordinates under which Cycles samples its mesh lights without bias.

    Cycles 3.4 samples an emitting triangle by solid angle (Arvo) when longest_edge^2 >
    (dist / |N|)^2, dist the distance to the triangle's plane and N its unnormalised normal:
    a length^2 against a 1 / length^2, so the choice depends on the scene's units. The solid
    angle it then computes, alpha + beta + gamma - pi with an approximate acos, loses its
    precision when the triangle subtends little (small and far, or seen at grazing angles from
    near its plane). Millimetre scenes take that branch almost everywhere: the Cornell box's
    walls came out 0.3 to 0.6 percent dark near the ceiling, and 16 percent dark with its lamp
    cut into 1 cm quads. Radiance does not depend on the units; with every emitting edge
    1e-3 long, the comparison picks area sampling, which is exact, everywhere but practically
    in a light's plane.
    """
    longest = 0.0
    for obj, (verts, faces) in zip(objects, geometry):
        if "emission" not in obj:
            continue
        for f in faces:
            for a, b in zip(f, f[1:] + f[:1]):
                longest = max(longest, math.dist(verts[a], verts[b]))
    return 1e-3 / longest if longest > 0 else 1.0


def build(args):
    with open(args.scene) as f:
        sc = json.load(f)
    scene_dir = os.path.dirname(os.path.abspath(args.scene))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    # Read everything first: the scale depends on the emitters' edges.
    geometry = []
    for obj in sc["objects"]:
        if obj["material"] not in sc["materials"]:
            fail("object %r: unknown material %r" % (obj["name"], obj["material"]))
        geometry.append(object_geometry(obj, scene_dir))
    scale = args.scale if args.scale else auto_scale(sc["objects"], geometry)

    shared = {}
    lo = Vector((math.inf,) * 3)
    hi = Vector((-math.inf,) * 3)
    for obj, (verts, faces) in zip(sc["objects"], geometry):
        name = obj["name"]
        mname = obj["material"]
        verts = [tuple(scale * c for c in v) for v in verts]
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(verts, [], faces)
        mesh.update()
        for p in mesh.polygons:
            p.use_smooth = False
        if "emission" in obj:
            mat = new_material(name + "_emitting", sc["materials"][mname],
                               [float(c) for c in obj["emission"]], args.phong)
        else:
            if mname not in shared:
                shared[mname] = new_material(mname, sc["materials"][mname], None, args.phong)
            mat = shared[mname]
        mesh.materials.append(mat)
        ob = bpy.data.objects.new(name, mesh)
        scene.collection.objects.link(ob)
        for v in verts:
            for k in range(3):
                lo[k] = min(lo[k], v[k])
                hi[k] = max(hi[k], v[k])

    # Camera: Blender's camera looks along its -Z with +Y up and +X right; polyrad's image
    # right is forward x up, the same right-handed frame.
    c = sc["camera"]
    pos = scale * Vector(c["position"])
    fwd = (scale * Vector(c["look_at"]) - pos).normalized()
    up = Vector(c.get("up", [0, 1, 0]))
    right = fwd.cross(up).normalized()
    true_up = right.cross(fwd)
    rot = Matrix((right, true_up, -fwd)).transposed()  # columns: camera X, Y, Z in the world
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    w, h = int(c["width"]), int(c["height"])
    fov = math.radians(float(c["fov_deg"]))
    cam_data.sensor_width = cam_data.sensor_height = 36.0
    cam_data.sensor_fit = "VERTICAL" if w >= h else "HORIZONTAL"  # the shorter side
    cam_data.lens = 18.0 / math.tan(0.5 * fov)
    diag = (hi - lo).length if lo.x < math.inf else 1.0
    cam_data.clip_start = 1e-6 * diag
    cam_data.clip_end = 1e3 * diag
    cam = bpy.data.objects.new("camera", cam_data)
    cam.matrix_world = Matrix.Translation(pos) @ rot.to_4x4()
    scene.collection.objects.link(cam)
    scene.camera = cam

    # A black world.
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0, 0, 0, 1)
    bg.inputs["Strength"].default_value = 0.0
    scene.world = world

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.use_compositing = False
    r.use_sequencer = False
    if args.threads > 0:
        r.threads_mode = "FIXED"
        r.threads = args.threads
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_mode = "RGB"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0

    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = args.spp
    cy.seed = args.seed
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.max_bounces = args.bounces
    cy.diffuse_bounces = args.bounces
    cy.glossy_bounces = args.bounces
    cy.transmission_bounces = args.bounces
    cy.transparent_max_bounces = args.bounces
    cy.volume_bounces = 0
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    if args.light_threshold is not None:
        cy.light_sampling_threshold = args.light_threshold
    if args.blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.blend))
    return scene, len(sc["objects"]), scale


def main():
    args = parse_args()
    scene, nobj, scale = build(args)
    t_built = time.time()
    scene.render.filepath = os.path.abspath(args.output)
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    t_done = time.time()
    print("cycles: %s: %d objects, scale %.6g, %dx%d, %d spp, threads %s: scene %.2f s, "
          "render %.2f s, script total %.2f s; wrote %s"
          % (args.scene, nobj, scale, scene.render.resolution_x, scene.render.resolution_y,
             args.spp, scene.render.threads, t_built - T_START, t_done - t_built,
             t_done - T_START, args.output))


main()
