# A product in two colourways as Blender users make one for a configurator: a plane wearing
# a red material, with glTF material variants "red" and "blue" authored in the exporter's
# Variants panel (its UI is an add-on preference, off by default), exported with Blender's
# own glTF exporter as KHR_materials_variants, lit by a sun and seen by a camera.
#
#   blender -b --python bench/materials/make_variants.py -- OUT_DIR
#   photonfarm render OUT_DIR/variants.gltf --frame 1 --quality preview [--variant blue]
import sys

import bpy

out_dir = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "."
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.preferences.addons["io_scene_gltf2"].preferences.KHR_materials_variants_ui = True
scene = bpy.context.scene


def material(name, rgb):
    made = bpy.data.materials.new(name)
    made.use_nodes = True
    made.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*rgb, 1)
    return made


bpy.ops.mesh.primitive_plane_add(size=2)
plane = bpy.context.active_object
red, blue = material("Red", (0.8, 0.05, 0.05)), material("Blue", (0.05, 0.05, 0.8))
plane.data.materials.append(red)
for index, name in enumerate(("red", "blue")):
    variant = scene.gltf2_KHR_materials_variants_variants.add()
    variant.name, variant.variant_idx = name, index
for worn, index in ((red, 0), (blue, 1)):
    mapping = plane.data.gltf2_variant_mesh_data.add()
    mapping.material_slot_index, mapping.material = 0, worn
    mapping.variants.add().variant.variant_idx = index
bpy.ops.object.camera_add(location=(0, 0, 4))
scene.camera = bpy.context.active_object
bpy.ops.object.light_add(type="SUN", location=(0, 0, 3))
bpy.ops.export_scene.gltf(filepath=f"{out_dir}/variants.gltf", export_format="GLTF_SEPARATE",
                          export_cameras=True, export_lights=True)
