# A small room as a user makes one in Blender and exports it with Blender's own
# glTF exporter (issue 38): rough gold, glossy red plastic, near-mirror chrome
# and white plastic spheres on a rough floor in front of a grey wall, lit by an
# emissive ceiling panel (room-panel.gltf) or by a Blender point and spot light
# instead (room-lamps.gltf). Untextured: textures are not read yet.
#
#   blender -b --factory-startup --python make_room.py -- OUTDIR
import math
import os
import sys

import bpy


def principled(name, base, metallic=0.0, roughness=0.5, emission=None, strength=1.0):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    node = material.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (*base, 1.0)
    node.inputs["Metallic"].default_value = metallic
    node.inputs["Roughness"].default_value = roughness
    node.inputs["Specular"].default_value = 0.5
    if emission:
        node.inputs["Emission"].default_value = (*emission, 1.0)
        node.inputs["Emission Strength"].default_value = strength
    return material


def plane(name, size, location, rotation, material):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location, rotation=rotation)
    obj = bpy.context.object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def sphere(name, radius, location, material):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=radius,
                                         location=location)
    obj = bpy.context.object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def build_room():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 24
    floor = principled("Floor", (0.60, 0.60, 0.60), roughness=0.8)
    wall = principled("Wall", (0.70, 0.70, 0.70), roughness=1.0)
    gold = principled("RoughGold", (1.0, 0.766, 0.336), metallic=1.0, roughness=0.35)
    red = principled("RedPlastic", (0.8, 0.05, 0.05), roughness=0.2)
    chrome = principled("Chrome", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.05)
    white = principled("WhitePlastic", (0.8, 0.8, 0.8), roughness=0.5)
    plane("Floor", 6.0, (0, 0, 0), (0, 0, 0), floor)
    plane("BackWall", 6.0, (0, 2.0, 3.0), (math.pi / 2, 0, 0), wall)
    sphere("GoldSphere", 0.45, (-0.75, 0.3, 0.45), gold)
    sphere("RedSphere", 0.45, (0.75, 0.3, 0.45), red)
    sphere("ChromeSphere", 0.3, (0.0, -0.5, 0.3), chrome)
    sphere("WhiteSphere", 0.3, (0.0, 1.0, 0.3), white)
    bpy.ops.object.camera_add(location=(0, -4.5, 1.6))
    camera = bpy.context.object
    camera.rotation_euler = (math.radians(75), 0, 0)
    camera.data.lens = 35
    scene.camera = camera
    return scene


def export(path, lights):
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLTF_SEPARATE",
                              export_cameras=True, export_lights=lights,
                              export_apply=True)


def main():
    out = sys.argv[sys.argv.index("--") + 1]
    os.makedirs(out, exist_ok=True)
    build_room()
    # A 1 m² panel 2.5 m up facing down (its front face: the exporter keeps
    # Blender's normals), radiance 8 W/(sr·m²).
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-panel.gltf"), lights=False)

    build_room()
    bpy.ops.object.light_add(type="POINT", location=(1.2, -0.8, 2.2))
    point = bpy.context.object.data
    point.energy = 150.0  # W, exported as 150/(4π)·683 = 8,153 cd
    point.shadow_soft_size = 0.0
    bpy.ops.object.light_add(type="SPOT", location=(-1.2, -0.6, 2.4),
                             rotation=(math.radians(25), math.radians(-20), 0))
    spot = bpy.context.object.data
    spot.energy = 300.0
    spot.spot_size = math.radians(70)
    spot.spot_blend = 0.3
    spot.shadow_soft_size = 0.0
    export(os.path.join(out, "room-lamps.gltf"), lights=True)


main()
