# A small room as a user makes one in Blender and exports it with Blender's own
# glTF exporter (issue 38): rough gold, glossy red plastic, near-mirror chrome
# and white plastic spheres on a rough floor in front of a grey wall, lit by an
# emissive ceiling panel (room-panel.gltf) or by a Blender point and spot light
# instead (room-lamps.gltf). room-textured.gltf is the panel room with the maps
# users bring: a colour-checker floor (baseColorTexture), a bumpy wall
# (normalTexture, tangents left to the renderer as Blender exports them), a cube
# whose metallicRoughnessTexture alternates metal and rough plastic, and an
# alpha-masked leaf card (alphaMode MASK). The images are made here, so the
# exporter writes them as PNG files beside the scene. room-string.gltf is the
# room lit by strings of fairy lights alone: 140 coloured 1.5 W point lights,
# more than a renderer can afford a shadow ray each at every shaded point.
# room-coated.gltf is the panel room with clear coats (KHR_materials_clearcoat): a varnished
# floor (coat 1, roughness 0.1), a lacquered red sphere (coat 1, Blender's default coat
# roughness 0.03) and a satin-coated white one (coat 0.5, roughness 0.3). room-ortho.gltf
# is the panel room seen through an orthographic camera (ortho scale 4 m), as an
# architectural elevation is. room-unlit.gltf is the panel room with two shadeless
# (KHR_materials_unlit) surfaces made as Blender users make them, an emission only camera
# rays see (the "lightpath trick" the exporter looks for): a poster on the wall, its colour
# an image, and a bright sign standing between the panel and the floor, which must neither
# cast a shadow nor light the room. room-velvet.gltf is the panel room with velvet as Blender
# 3.4 users author it for glTF: a Velvet BSDF added to the Principled one, which the exporter
# writes as KHR_materials_sheen (its colour and sigma as the sheen's colour and roughness) on
# the floor and the red and white spheres. Cycles renders Blender's import of it (Principled
# plus Ashikhmin's velvet, added, no albedo scaling), not the spec's Charlie sheen.
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


def image(name, size, pixel, colour_space="sRGB"):
    """A size × size image whose texel (x, y) is pixel(x, y) -> (r, g, b, a)."""
    img = bpy.data.images.new(name, size, size, alpha=True)
    img.colorspace_settings.name = colour_space
    values = []
    for y in range(size):
        for x in range(size):
            values.extend(pixel(x, y))
    img.pixels = values
    img.file_format = "PNG"
    img.pack()
    return img


def image_node(material, img, non_color=False):
    nodes = material.node_tree.nodes
    node = nodes.new("ShaderNodeTexImage")
    node.image = img
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    return node


def textured_materials():
    # A 6 × 4 colour checker of saturated and grey patches, 8 texels a patch.
    patches = [(0.8, 0.1, 0.1), (0.1, 0.6, 0.1), (0.1, 0.2, 0.8), (0.9, 0.8, 0.1),
               (0.8, 0.4, 0.1), (0.5, 0.1, 0.6), (0.9, 0.9, 0.9), (0.6, 0.6, 0.6),
               (0.35, 0.35, 0.35), (0.15, 0.15, 0.15), (0.05, 0.05, 0.05), (0.3, 0.6, 0.7)]
    checker = image("checker", 64,
                    lambda x, y: (*patches[((x // 8) + 3 * (y // 8)) % len(patches)], 1.0))
    floor = principled("CheckerFloor", (1, 1, 1), roughness=0.8)
    tree = floor.node_tree
    node = image_node(floor, checker)
    tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])

    # Bumps: a tangent-space normal map of rounded ridges along u.
    def bump(x, y):
        slope = 0.6 * math.sin(2 * math.pi * x / 16)
        n = (-slope, 0.0, 1.0)
        length = math.sqrt(sum(c * c for c in n))
        return (*(0.5 * c / length + 0.5 for c in n), 1.0)
    wall = principled("BumpyWall", (0.7, 0.7, 0.7), roughness=0.9)
    tree = wall.node_tree
    node = image_node(wall, image("bumps", 64, bump), non_color=True)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(node.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], tree.nodes["Principled BSDF"].inputs["Normal"])

    # Metal and rough plastic in 4 × 4 squares: G roughness, B metallic (glTF's packing).
    def metal_rough(x, y):
        metal = ((x // 16) + (y // 16)) % 2
        return (0.0, 0.25 if metal else 0.7, 1.0 if metal else 0.0, 1.0)
    cube = principled("MetalRoughCube", (0.9, 0.7, 0.4), roughness=1.0)
    tree = cube.node_tree
    node = image_node(cube, image("metal_rough", 64, metal_rough), non_color=True)
    separate = tree.nodes.new("ShaderNodeSeparateRGB")
    tree.links.new(node.outputs["Color"], separate.inputs["Image"])
    bsdf = tree.nodes["Principled BSDF"]
    tree.links.new(separate.outputs["G"], bsdf.inputs["Roughness"])
    tree.links.new(separate.outputs["B"], bsdf.inputs["Metallic"])

    # A leaf: opaque inside an ellipse, cut away outside (alpha 0).
    def leaf(x, y):
        u, v = (x - 31.5) / 14.0, (y - 31.5) / 30.0
        inside = u * u + v * v <= 1.0
        return (0.15, 0.55, 0.1, 1.0 if inside else 0.0)
    card = principled("LeafCard", (1, 1, 1), roughness=0.6)
    tree = card.node_tree
    node = image_node(card, image("leaf", 64, leaf))
    bsdf = tree.nodes["Principled BSDF"]
    tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(node.outputs["Alpha"], bsdf.inputs["Alpha"])
    card.blend_method = "CLIP"
    card.alpha_threshold = 0.5
    return floor, wall, cube, card


def unlit(name, colour=None, img=None):
    """A shadeless material: Emission (a colour or an image) for camera rays, Transparent
    for every other ray, as the exporter detects KHR_materials_unlit."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    emission = tree.nodes.new("ShaderNodeEmission")
    if img is not None:
        tree.links.new(image_node(material, img).outputs["Color"], emission.inputs["Color"])
    else:
        emission.inputs["Color"].default_value = (*colour, 1.0)
    light_path = tree.nodes.new("ShaderNodeLightPath")
    transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(light_path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    tree.links.new(transparent.outputs[0], mix.inputs[1])
    tree.links.new(emission.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return material


def velvet(material, colour, sigma):
    """Adds a Velvet BSDF to the material's Principled one (Add Shader), as KHR_materials_sheen
    is authored in Blender 3.4."""
    tree = material.node_tree
    node = tree.nodes.new("ShaderNodeBsdfVelvet")
    node.inputs["Color"].default_value = (*colour, 1.0)
    node.inputs["Sigma"].default_value = sigma
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(tree.nodes["Principled BSDF"].outputs[0], add.inputs[0])
    tree.links.new(node.outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], tree.nodes["Material Output"].inputs["Surface"])


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

    build_room()
    # Two strings of fairy lights: 80 sagging across the wall, 60 across the room
    # above the spheres; warm white, red, green and blue in turn.
    colours = [(1.0, 0.8, 0.5), (1.0, 0.15, 0.1), (0.2, 1.0, 0.2), (0.2, 0.3, 1.0)]
    strings = [(80, 1.9, 1.6, 0.6), (60, 0.3, 2.0, 0.4)]  # lights, y, lowest z, sag
    n = 0
    for count, y, low, sag in strings:
        for i in range(count):
            x = -2.5 + 5.0 * i / (count - 1)
            bpy.ops.object.light_add(type="POINT", location=(x, y, low + sag * (x / 2.5) ** 2))
            bulb = bpy.context.object.data
            bulb.energy = 1.5
            bulb.color = colours[n % len(colours)]
            bulb.shadow_soft_size = 0.0
            n += 1
    export(os.path.join(out, "room-string.gltf"), lights=True)

    build_room()
    camera = bpy.context.scene.camera.data
    camera.type = "ORTHO"
    camera.ortho_scale = 4.0
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-ortho.gltf"), lights=False)

    build_room()
    coats = {"Floor": (1.0, 0.1), "RedPlastic": (1.0, 0.03), "WhitePlastic": (0.5, 0.3)}
    for name, (coat, roughness) in coats.items():
        node = bpy.data.materials[name].node_tree.nodes["Principled BSDF"]
        node.inputs["Clearcoat"].default_value = coat
        node.inputs["Clearcoat Roughness"].default_value = roughness
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-coated.gltf"), lights=False)

    build_room()
    floor, wall, cube, card = textured_materials()
    bpy.data.objects["Floor"].data.materials[0] = floor
    bpy.data.objects["BackWall"].data.materials[0] = wall
    bpy.data.objects["WhiteSphere"].hide_render = True
    bpy.data.objects.remove(bpy.data.objects["WhiteSphere"])
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.0, 1.0, 0.3))
    bpy.context.object.data.materials.append(cube)
    plane("Leaf", 1.0, (1.5, -0.3, 0.8), (math.pi / 2, 0, math.radians(-30)), card)
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-textured.gltf"), lights=False)

    build_room()
    # A poster of coloured bands, 1.2 × 0.8 m on the wall (5 mm in front of it).
    bands = [(0.9, 0.2, 0.1), (0.95, 0.8, 0.2), (0.1, 0.5, 0.8), (0.1, 0.1, 0.1)]
    poster = unlit("Poster", img=image("poster", 64, lambda x, y: (*bands[(x + y) // 32], 1.0)))
    plane("Poster", 1.0, (-1.0, 1.995, 1.15), (math.pi / 2, 0, 0), poster)
    bpy.context.object.scale = (1.2, 0.8, 1.0)
    # A sign 0.8 × 0.5 m standing upright right of the chrome sphere, under the panel.
    sign = unlit("Sign", colour=(0.1, 0.9, 0.3))
    plane("Sign", 1.0, (0.5, -0.2, 0.6), (math.pi / 2, 0, math.radians(15)), sign)
    bpy.context.object.scale = (0.8, 0.5, 1.0)
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-unlit.gltf"), lights=False)

    build_room()
    velvet(bpy.data.materials["Floor"], (0.9, 0.35, 0.3), 0.6)
    velvet(bpy.data.materials["RedPlastic"], (1.0, 0.6, 0.6), 0.5)
    velvet(bpy.data.materials["WhitePlastic"], (1.0, 1.0, 1.0), 0.3)
    panel = principled("Panel", (0.0, 0.0, 0.0), emission=(1.0, 1.0, 1.0), strength=8.0)
    plane("Panel", 1.0, (0, 0.3, 2.5), (math.pi, 0, 0), panel)
    export(os.path.join(out, "room-velvet.gltf"), lights=False)


if __name__ == "__main__":
    main()
