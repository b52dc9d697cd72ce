# A scene as a user animates one in Blender and exports it with Blender's own
# glTF exporter (issue 39): an arm, a tube skinned to a two-bone armature that
# bends its upper bone 80° over 24 frames, and a sheet whose shape key bulges it
# towards the camera, on a floor before a wall, lit by an emissive ceiling panel.
# Blender writes one action per object, so the file holds two animations (the
# armature's and the sheet's shape keys), which play together.
#
#   blender -b --factory-startup --python make_character.py -- OUTDIR [RINGS SEGMENTS [SPECULAR]]
#
# writes OUTDIR/character.gltf (one file, buffers embedded). RINGS × SEGMENTS
# sets the arm's vertex count (default 24 × 16); the deform benchmark raises it.
# SPECULAR (default 0.5, Blender's) is every Principled BSDF's Specular. 0 is the
# control that takes the specular layer out of both material models: Blender's
# exporter writes it as KHR_materials_specular (specularColorFactor 0), and Cycles
# renders Principled without it, so what is left to compare is the pose, the
# lights and the diffuse transport (bench/RESULTS.md, "Skins and morph targets").
# scenes/character/character.gltf is this script's output at the defaults
# (Blender 3.4.1), committed so that the tests render a file as Blender writes it
# without needing Blender.
import math
import os
import sys

import bmesh
import bpy
from mathutils import Vector

# The room's material and plane helpers, as a user's scripts share them.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "materials"))
from make_room import plane, principled  # noqa: E402

FRAMES = 24
ARM_RADIUS = 0.2
ARM_LENGTH = 2.0
ARM_X = -0.8


def tube_mesh(name, rings, segments):
    """A closed tube along +Z from 0 to ARM_LENGTH, rings × segments side vertices."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    grid = []
    for r in range(rings):
        z = ARM_LENGTH * r / (rings - 1)
        row = []
        for s in range(segments):
            a = 2.0 * math.pi * s / segments
            row.append(bm.verts.new((ARM_RADIUS * math.cos(a), ARM_RADIUS * math.sin(a), z)))
        grid.append(row)
    for r in range(rings - 1):
        for s in range(segments):
            t = (s + 1) % segments
            bm.faces.new((grid[r][s], grid[r][t], grid[r + 1][t], grid[r + 1][s]))
    bm.faces.new(list(reversed(grid[0])))
    bm.faces.new(grid[-1])
    bm.to_mesh(mesh)
    bm.free()
    for polygon in mesh.polygons:
        polygon.use_smooth = True
    return mesh


def smoothstep(edge0, edge1, x):
    t = min(1.0, max(0.0, (x - edge0) / (edge1 - edge0)))
    return t * t * (3.0 - 2.0 * t)


def add_arm(material, rings, segments):
    bpy.ops.object.armature_add(enter_editmode=True, location=(ARM_X, 0.0, 0.0))
    armature = bpy.context.object
    armature.name = "armature"
    bones = armature.data.edit_bones
    lower = bones[0]
    lower.name = "lower"
    lower.head = (0.0, 0.0, 0.0)
    lower.tail = (0.0, 0.0, ARM_LENGTH / 2)
    upper = bones.new("upper")
    upper.head = (0.0, 0.0, ARM_LENGTH / 2)
    upper.tail = (0.0, 0.0, ARM_LENGTH)
    upper.parent = lower
    upper.use_connect = True
    bpy.ops.object.mode_set(mode="OBJECT")

    arm = bpy.data.objects.new("arm", tube_mesh("arm", rings, segments))
    bpy.context.collection.objects.link(arm)
    arm.location = (ARM_X, 0.0, 0.0)
    arm.data.materials.append(material)
    # Weights blend over the elbow (z 0.8 .. 1.2 m), as a user paints them.
    lower_group = arm.vertex_groups.new(name="lower")
    upper_group = arm.vertex_groups.new(name="upper")
    for vertex in arm.data.vertices:
        w = smoothstep(0.8, 1.2, vertex.co.z)
        if w < 1.0:
            lower_group.add([vertex.index], 1.0 - w, "REPLACE")
        if w > 0.0:
            upper_group.add([vertex.index], w, "REPLACE")
    arm.parent = armature
    modifier = arm.modifiers.new("armature", "ARMATURE")
    modifier.object = armature

    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="POSE")
    bone = armature.pose.bones["upper"]
    bone.rotation_mode = "QUATERNION"
    for frame, degrees in ((1, 0.0), (FRAMES, 80.0)):
        half = math.radians(degrees) / 2.0
        bone.rotation_quaternion = (math.cos(half), math.sin(half), 0.0, 0.0)
        bone.keyframe_insert("rotation_quaternion", frame=frame)
    bpy.ops.object.mode_set(mode="OBJECT")


def add_sheet(material):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=1.6,
                                    location=(0.8, 0.2, 1.0), rotation=(math.pi / 2, 0.0, 0.0))
    sheet = bpy.context.object
    sheet.name = "sheet"
    sheet.data.materials.append(material)
    bpy.ops.object.shade_smooth()
    sheet.shape_key_add(name="Basis")
    bulge = sheet.shape_key_add(name="bulge")
    for point in bulge.data:
        r2 = point.co.x ** 2 + point.co.y ** 2
        # Local +Z faces the camera (-Y in the world) after the rotation.
        point.co = point.co + Vector((0.0, 0.0, 0.4 * math.exp(-r2 / 0.12)))
    for frame, value in ((1, 0.0), (FRAMES, 1.0)):
        bulge.value = value
        bulge.keyframe_insert("value", frame=frame)


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    out = args[0]
    rings = int(args[1]) if len(args) > 1 else 24
    segments = int(args[2]) if len(args) > 2 else 16
    specular = float(args[3]) if len(args) > 3 else 0.5
    os.makedirs(out, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start = 1
    scene.frame_end = FRAMES
    scene.render.fps = 24

    plane("floor", 8.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
          principled("floor", (0.5, 0.5, 0.5), roughness=0.8))
    plane("wall", 8.0, (0.0, 2.0, 4.0), (math.pi / 2, 0.0, 0.0),
          principled("wall", (0.7, 0.7, 0.7), roughness=0.9))
    plane("panel", 1.5, (0.0, -0.5, 3.6), (math.pi, 0.0, 0.0),
          principled("panel", (0.0, 0.0, 0.0), roughness=0.6, emission=(1.0, 1.0, 1.0),
                     strength=12.0))
    add_arm(principled("arm", (0.8, 0.3, 0.1), roughness=0.5), rings, segments)
    add_sheet(principled("sheet", (0.1, 0.3, 0.8), roughness=0.5))

    for material in bpy.data.materials:
        if material.use_nodes and "Principled BSDF" in material.node_tree.nodes:
            material.node_tree.nodes["Principled BSDF"].inputs["Specular"].default_value = specular

    bpy.ops.object.camera_add(location=(0.0, -6.0, 1.6), rotation=(math.radians(88), 0.0, 0.0))
    camera = bpy.context.object
    camera.data.lens = 35.0
    scene.camera = camera

    scene.frame_set(1)
    bpy.ops.export_scene.gltf(filepath=os.path.join(out, "character.gltf"),
                              export_format="GLTF_EMBEDDED", export_cameras=True,
                              export_skins=True, export_morph=True, export_morph_normal=True,
                              export_animations=True, export_apply=False)


main()
