#!/usr/bin/env python3
"""A lone lit floor (and optionally one wall) as glTF, for fast's self-illumination figures.

    bench/lpv/make_floor.py HALF_SIZE_M floor|wall OUT.gltf

The floor is 2 HALF_SIZE_M square at y = 0 (albedo 0.8, facing up), lit by a sun of
2,000 lux 60 degrees below the horizon; `wall` adds a 2 HALF_SIZE_M square wall at
z = -2 facing the camera. With the floor alone no light ever comes back to it: its
indirect light is exactly 0.
"""
import base64
import json
import math
import struct
import sys


def rotation_x(angle):
    return [math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2)]


def main():
    half = float(sys.argv[1])
    wall = sys.argv[2] == "wall"
    positions = [(-half, 0, -half), (half, 0, -half), (half, 0, half), (-half, 0, half)]
    normals = [(0, 1, 0)] * 4
    indices = [0, 2, 1, 0, 3, 2]
    if wall:
        positions += [(-half, 0, -2), (half, 0, -2), (half, 2 * half, -2), (-half, 2 * half, -2)]
        normals += [(0, 0, 1)] * 4
        indices += [4, 5, 6, 4, 6, 7]
    position_bytes = b"".join(struct.pack("<3f", *p) for p in positions)
    normal_bytes = b"".join(struct.pack("<3f", *n) for n in normals)
    index_bytes = b"".join(struct.pack("<H", i) for i in indices)
    data = position_bytes + normal_bytes + index_bytes
    count = len(positions)
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 2000.0, "color": [1, 1, 1]}]}},
        "nodes": [
            {"mesh": 0},
            {"extensions": {"KHR_lights_punctual": {"light": 0}},
             "rotation": rotation_x(-math.radians(60))},
            {"camera": 0, "translation": [0, 2.5, 5], "rotation": rotation_x(-math.radians(25))},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.9, "znear": 0.05, "aspectRatio": 4 / 3}}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                "metallicFactor": 0, "roughnessFactor": 1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                                    "material": 0}]}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," +
                            base64.b64encode(data).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(position_bytes)},
            {"buffer": 0, "byteOffset": len(position_bytes), "byteLength": len(normal_bytes)},
            {"buffer": 0, "byteOffset": len(position_bytes) + len(normal_bytes),
             "byteLength": len(index_bytes)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
             "min": [min(p[k] for p in positions) for k in range(3)],
             "max": [max(p[k] for p in positions) for k in range(3)]},
            {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        ],
    }
    with open(sys.argv[3], "w") as out:
        json.dump(gltf, out)


if __name__ == "__main__":
    main()
