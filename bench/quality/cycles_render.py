# Renders a glTF scene with Cycles for bench/quality: the peer measured in the
# same run, on the same machine, against the same reference as photonfarm's
# presets.
#
#   blender -b --factory-startup -P bench/quality/cycles_render.py -- \
#       SCENE.gltf OUT.exr WIDTH HEIGHT SAMPLES SEED THREADS
#
# Prints "cycles_seconds S" (bpy.ops.render.render alone: no start-up, no
# import, no file write) and "cycles_samples N".
#
# The scene model is made photonfarm's, so that both converge to the same
# image and the error measured is noise, not a different material model. The
# materials follow core/scene/gltf_materials.c's rules, read from the glTF
# itself: transmission > 0 → smooth glass (Glass BSDF, roughness 0, the IOR,
# transmission tinted by the base colour); metallicFactor ≥ 0.5 and
# roughnessFactor ≤ 0.01 → ideal mirror (Glossy BSDF, roughness 0, tinted);
# otherwise Lambert (Diffuse BSDF, base colour). An emissive material adds
# emissiveFactor × emissiveStrength from its front face only (photonfarm's
# area lights are one-sided). Point lights: the importer's conversion is
# replaced by photonfarm's reading of KHR_lights_punctual (candela / 683, or
# W/sr where extras.photonfarm.intensityUnits says so; Blender watts =
# 4π × W/sr). Film: Blackman-Harris 1.5 px (Cycles' default; photonfarm
# renders this bench with --filter blackman-harris), no denoising, no
# adaptive sampling, no clamping, no filter glossy, caustics on, and bounce
# limits high enough not to cut paths that matter (128).
#
# With PF_CYCLES_AS_IMPORTED=1 in the environment the file renders as
# Blender's importer reads it instead (Principled BSDF with its textures, the
# importer's light units, punctual lights of radius 0): the comparison issue
# 38 asks for on users' files, such as bench/materials' room-textured.gltf.
import json
import math
import os
import sys
import time

import bpy
import numpy

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool, which numpy 1.24
# (Debian 12's) removed; the alias it meant is the builtin.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

MIRROR_ROUGHNESS_MAX = 0.01  # core/scene/gltf_materials.c
METALLIC_THRESHOLD = 0.5
DEFAULT_IOR = 1.5


def arguments():
    argv = sys.argv[sys.argv.index("--") + 1:]
    if len(argv) != 7:
        sys.exit("usage: ... -- SCENE OUT WIDTH HEIGHT SAMPLES SEED THREADS")
    scene, out, width, height, samples, seed, threads = argv
    return scene, out, int(width), int(height), int(samples), int(seed), int(threads)


def gltf_materials(path):
    with open(path) as f:
        document = json.load(f)
    kinds = {}
    for index, material in enumerate(document.get("materials", [])):
        pbr = material.get("pbrMetallicRoughness", {})
        extensions = material.get("extensions", {})
        base = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]
        metallic = pbr.get("metallicFactor", 1.0)
        roughness = pbr.get("roughnessFactor", 1.0)
        transmission = extensions.get("KHR_materials_transmission", {}).get(
            "transmissionFactor", 0.0)
        ior = extensions.get("KHR_materials_ior", {}).get("ior", DEFAULT_IOR)
        strength = extensions.get("KHR_materials_emissive_strength", {}).get(
            "emissiveStrength", 1.0)
        emission = [c * strength for c in material.get("emissiveFactor", [0, 0, 0])]
        if transmission > 0:
            kind = "glass"
        elif metallic >= METALLIC_THRESHOLD and roughness <= MIRROR_ROUGHNESS_MAX:
            kind = "mirror"
        else:
            kind = "lambert"
        kinds[material.get("name", "material%d" % index)] = (kind, base, ior, emission)
    lights = document.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    return kinds, lights


def photonfarm_material(material, kind, base, ior, emission):
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    color = (base[0], base[1], base[2], 1.0)
    if kind == "glass":
        surface = tree.nodes.new("ShaderNodeBsdfGlass")
        surface.distribution = "SHARP"
        surface.inputs["IOR"].default_value = ior
    elif kind == "mirror":
        surface = tree.nodes.new("ShaderNodeBsdfGlossy")
        surface.distribution = "SHARP"
    else:
        surface = tree.nodes.new("ShaderNodeBsdfDiffuse")
        surface.inputs["Roughness"].default_value = 0.0  # Lambert, not Oren-Nayar
    surface.inputs["Color"].default_value = color
    shader = surface.outputs[0]
    if max(emission) > 0:
        light = tree.nodes.new("ShaderNodeEmission")
        light.inputs["Color"].default_value = (emission[0], emission[1], emission[2], 1.0)
        light.inputs["Strength"].default_value = 1.0
        lit = tree.nodes.new("ShaderNodeAddShader")
        tree.links.new(light.outputs[0], lit.inputs[0])
        tree.links.new(shader, lit.inputs[1])
        # Front face only: the back face is the surface alone.
        geometry = tree.nodes.new("ShaderNodeNewGeometry")
        side = tree.nodes.new("ShaderNodeMixShader")
        tree.links.new(geometry.outputs["Backfacing"], side.inputs[0])
        tree.links.new(lit.outputs[0], side.inputs[1])
        tree.links.new(shader, side.inputs[2])
        shader = side.outputs[0]
    tree.links.new(shader, output.inputs["Surface"])


def radiant_intensity(light):
    """A point light's W/sr as photonfarm reads it: the spec's candela at
    683 lm/W, unless extras.photonfarm.intensityUnits says "W/sr"."""
    intensity = light.get("intensity", 1.0)
    units = light.get("extras", {}).get("photonfarm", {}).get("intensityUnits", "cd")
    return intensity if units == "W/sr" else intensity / 683.0


def main():
    scene_path, out_path, width, height, samples, seed, threads = arguments()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(scene_path))
    scene = bpy.context.scene
    as_imported = os.environ.get("PF_CYCLES_AS_IMPORTED") == "1"
    kinds, lights = gltf_materials(scene_path)
    if as_imported:
        kinds, lights = {}, []
        for obj in scene.objects:
            if obj.type == "LIGHT":
                obj.data.shadow_soft_size = 0.0  # glTF lights are punctual
    for material in bpy.data.materials if not as_imported else []:
        name = material.name
        while name not in kinds and "." in name:  # Blender's ".001" suffixes
            name = name.rsplit(".", 1)[0]
        if name in kinds:
            photonfarm_material(material, *kinds[name])
        else:
            print("cycles_render: material %r not in the glTF; left as imported" % name)
    point_lights = [o for o in scene.objects if o.type == "LIGHT"]
    for obj, light in zip(point_lights, lights):
        if obj.data.type == "POINT" and light.get("type") == "point":
            obj.data.energy = 4.0 * math.pi * radiant_intensity(light)
            obj.data.color = light.get("color", [1, 1, 1])
            obj.data.shadow_soft_size = 0.0
    cameras = [o for o in scene.objects if o.type == "CAMERA"]
    if not cameras:
        sys.exit("cycles_render: the scene has no camera")
    scene.camera = cameras[0]
    scene.world = None  # black background, as photonfarm's

    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = seed
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = True
    cycles.caustics_refractive = True
    for bounces in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                    "transmission_bounces", "transparent_max_bounces"):
        setattr(cycles, bounces, 128)
    cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    cycles.filter_width = 1.5
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"
    scene.render.threads = threads
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"

    start = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - start
    bpy.data.images["Render Result"].save_render(os.path.abspath(out_path))
    print("cycles_seconds %.6f" % seconds)
    print("cycles_samples %d" % samples)


main()
