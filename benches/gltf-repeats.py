#!/usr/bin/env python3
"""gltf-repeats: how much of a glTF binary's geometry repeats a mesh.

glTF instances a mesh by pointing many nodes at it; gigawalk's import
expands every instance into an object of its own, and the scene and the
3D Tiles export store each copy. This counts, over the nodes of every
scene, the triangles drawn (each instance counted) against the triangles
of the distinct meshes they use: the share that repeats is what writing
each mesh once (EXT_mesh_gpu_instancing, shared buffers) could save.

    python3 benches/gltf-repeats.py model.glb [more.glb ...]

Prints one line per file: nodes with a mesh, distinct meshes, triangles
drawn, distinct triangles and the repeated share.
"""
import json
import struct
import sys


def glb_json(path):
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF":
            raise SystemExit(f"{path}: not a glTF binary (.glb)")
        length, kind = struct.unpack("<II", head[12:20])
        if kind != 0x4E4F534A:
            raise SystemExit(f"{path}: the first chunk is not JSON")
        return json.loads(f.read(length))


def triangles(gltf, mesh):
    accessors = gltf.get("accessors", [])
    n = 0
    for p in gltf["meshes"][mesh].get("primitives", []):
        if p.get("mode", 4) != 4:
            continue
        if "indices" in p:
            n += accessors[p["indices"]]["count"] // 3
        else:
            n += accessors[p["attributes"]["POSITION"]]["count"] // 3
    return n


def main(paths):
    if not paths:
        raise SystemExit(__doc__)
    for path in paths:
        g = glb_json(path)
        nodes = g.get("nodes", [])
        # Nodes reachable from the scenes, each counted once per path to
        # it (a node reached twice is drawn twice).
        uses = {}
        stack = [n for s in g.get("scenes", []) for n in s.get("nodes", [])]
        while stack:
            n = stack.pop()
            node = nodes[n]
            if "mesh" in node:
                uses[node["mesh"]] = uses.get(node["mesh"], 0) + 1
            stack.extend(node.get("children", []))
        drawn = sum(triangles(g, m) * k for m, k in uses.items())
        distinct = sum(triangles(g, m) for m in uses)
        share = 1 - distinct / drawn if drawn else 0.0
        print(
            f"{path}: {sum(uses.values())} mesh nodes, {len(uses)} meshes, "
            f"{drawn} triangles drawn, {distinct} distinct, {share:.1%} repeated"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
