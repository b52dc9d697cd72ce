# Renders a glTF file with Cycles exactly as Blender's own importer reads it
# (Principled BSDF, the importer's light units): the comparison issue 38 asks
# for, unlike bench/quality/cycles_render.py, which maps materials to
# photonfarm's. Film as photonfarm renders with --filter blackman-harris
# (Cycles' 1.5 px Blackman-Harris), no denoising, adaptive sampling or
# clamping, black world, 64 bounces (or MAX_BOUNCES, as photonfarm's
# --max-bounces). FRAME (default 1) is the frame rendered; every animation in
# the file plays, as photonfarm renders it: Blender's importer makes the first
# animation the active action and leaves the others muted in NLA tracks, so
# each of those is made its object's (or shape keys') action here.
#
#   blender -b --factory-startup --python cycles_import_render.py -- \
#       SCENE.gltf OUT.exr WIDTH HEIGHT SAMPLES [MAX_BOUNCES [FRAME]]
import os
import sys

import bpy
import numpy

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool, which numpy
# 1.24 removed; the alias it meant is the builtin.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def play_every_animation(scene):
    owners = list(scene.objects)
    owners += [o.data.shape_keys for o in scene.objects
               if o.type == "MESH" and o.data.shape_keys]
    for owner in owners:
        data = owner.animation_data
        if data and not data.action and data.nla_tracks:
            strips = [s for t in data.nla_tracks for s in t.strips]
            if strips:
                data.action = strips[0].action
                print("cycles_import_render: %s plays %s" % (owner.name, data.action.name))


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    scene_path, out_path, width, height, samples = args[:5]
    bounces = int(args[5]) if len(args) > 5 else 64
    frame = int(args[6]) if len(args) > 6 else 1
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(scene_path))
    scene = bpy.context.scene
    play_every_animation(scene)
    scene.frame_set(frame)
    cameras = [o for o in scene.objects if o.type == "CAMERA"]
    if not cameras:
        sys.exit("cycles_import_render: the scene has no camera")
    scene.camera = cameras[0]
    # The importer gives lights Blender's default 0.25 m radius; a glTF light
    # is punctual (KHR_lights_punctual), as photonfarm renders it.
    for obj in scene.objects:
        if obj.type == "LIGHT":
            obj.data.shadow_soft_size = 0.0
            print("cycles_import_render: light %s %s %.3f W"
                  % (obj.name, obj.data.type, obj.data.energy))
    scene.world = None
    scene.render.engine = "CYCLES"
    scene.render.resolution_x = int(width)
    scene.render.resolution_y = int(height)
    scene.render.resolution_percentage = 100
    scene.render.filter_size = 1.5
    cycles = scene.cycles
    cycles.samples = int(samples)
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    cycles.filter_width = 1.5
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = True
    cycles.caustics_refractive = True
    cycles.max_bounces = cycles.diffuse_bounces = cycles.glossy_bounces = bounces
    cycles.transmission_bounces = cycles.transparent_max_bounces = bounces
    cycles.seed = 1
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = os.path.abspath(out_path)
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    main()
