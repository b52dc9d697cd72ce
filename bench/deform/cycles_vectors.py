# Cycles' Vector pass of one frame of a glTF file, as Blender's importer reads it,
# with every animation playing (as cycles_import_render.py): the reference for
# photonfarm's motion.X/Y (deform_bench vectors). Box filter of 0.01 px, so a
# pixel's vector is its centre's, as photonfarm's.
#
#   blender -b --factory-startup --python cycles_vectors.py -- SCENE.gltf OUT.exr WIDTH HEIGHT FRAME
import os
import sys

import bpy
import numpy

if "bool" not in numpy.__dict__:
    numpy.bool = bool
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "materials"))
from cycles_import_render import play_every_animation  # noqa: E402


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    scene_path, out_path, width, height, frame = args[:5]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(scene_path))
    scene = bpy.context.scene
    play_every_animation(scene)
    scene.camera = [o for o in scene.objects if o.type == "CAMERA"][0]
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.render.resolution_x = int(width)
    scene.render.resolution_y = int(height)
    scene.render.resolution_percentage = 100
    scene.render.use_motion_blur = False
    scene.view_layers[0].use_pass_vector = True
    scene.frame_set(int(frame))
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = os.path.abspath(out_path)
    bpy.ops.render.render(write_still=True)


main()
