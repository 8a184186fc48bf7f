"""Writes the tiny hand-made glTF/OBJ fixtures in this directory.

Rerun with `python3 tests/data/make_fixtures.py` from the repository root;
the outputs are committed, so tests need no Python.
"""
import base64, json, math, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))

def f32s(vals): return struct.pack("<%df" % len(vals), *vals)
def u32s(vals): return struct.pack("<%dI" % len(vals), *vals)
def u16s(vals):
    b = struct.pack("<%dH" % len(vals), *vals)
    return b + b"\0" * (-len(b) % 4)

def doc(positions, indices=None, mode=4, normals=None, nodes=None, colour=None, idx16=False, extra_prims=()):
    """One mesh; returns (json dict, bin bytes)."""
    binb = b""; views = []; accs = []
    def add(data, count, comp, typ, mn=None, mx=None):
        nonlocal binb
        views.append({"buffer": 0, "byteOffset": len(binb), "byteLength": len(data)})
        binb += data + b"\0" * (-len(data) % 4)
        a = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": typ}
        if mn is not None: a["min"], a["max"] = mn, mx
        accs.append(a); return len(accs) - 1
    def prim(positions, indices, mode, normals):
        xs = [positions[i::3] for i in range(3)]
        mn = [min(x) if all(map(math.isfinite, x)) else 0 for x in xs]
        mx = [max(x) if all(map(math.isfinite, x)) else 0 for x in xs]
        p = {"attributes": {"POSITION": add(f32s(positions), len(positions) // 3, 5126, "VEC3", mn, mx)}, "mode": mode, "material": 0}
        if normals: p["attributes"]["NORMAL"] = add(f32s(normals), len(normals) // 3, 5126, "VEC3")
        if indices is not None:
            p["indices"] = add(u16s(indices), len(indices), 5123, "SCALAR") if idx16 else add(u32s(indices), len(indices), 5125, "SCALAR")
        return p
    prims = [prim(positions, indices, mode, normals)] + [prim(*e) for e in extra_prims]
    j = {"asset": {"version": "2.0"}, "scene": 0,
         "scenes": [{"nodes": [0]}],
         "nodes": nodes or [{"mesh": 0, "name": "only"}],
         "meshes": [{"name": "m", "primitives": prims}],
         "materials": [{"pbrMetallicRoughness": {"baseColorFactor": colour or [0.25, 0.5, 0.75, 1.0]}}],
         "accessors": accs, "bufferViews": views,
         "buffers": [{"byteLength": len(binb)}]}
    return j, binb

def write_gltf(name, j, binb, uri="embed"):
    j = json.loads(json.dumps(j))
    if uri == "embed":
        j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(binb).decode()
    else:
        j["buffers"][0]["uri"] = uri
    with open(os.path.join(HERE, name), "w") as f: json.dump(j, f, indent=1)

def glb(j, binb):
    js = json.dumps(j, separators=(",", ":")).encode(); js += b" " * (-len(js) % 4)
    binb += b"\0" * (-len(binb) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binb), b"BIN\0") + binb
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body

TRI = [0, 0, 0, 1, 0, 0, 0, 1, 0]

j, b = doc(TRI, [0, 1, 2])
write_gltf("triangle_embedded.gltf", j, b)
write_gltf("triangle_external.gltf", j, b, uri="triangle%20data.bin")
open(os.path.join(HERE, "triangle data.bin"), "wb").write(b)
write_gltf("missing_buffer.gltf", j, b, uri="does_not_exist.bin")

# Unit cube with normals, as .glb, and a truncated copy.
cube_p, cube_n, cube_i = [], [], []
for axis in range(3):
    for s in (1, -1):
        n = [0, 0, 0]; n[axis] = s
        u = [0, 0, 0]; u[(axis + 1) % 3] = 1
        v = [0, 0, 0]; v[(axis + 2) % 3] = 1
        base = len(cube_p) // 3
        for (a, c) in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            cube_p += [0.5 * (n[k] + a * u[k] * s + c * v[k]) for k in range(3)]
            cube_n += n
        cube_i += [base, base + 1, base + 2, base, base + 2, base + 3]
j, b = doc(cube_p, cube_i, normals=cube_n, idx16=True)
data = glb(j, b)
open(os.path.join(HERE, "cube.glb"), "wb").write(data)
open(os.path.join(HERE, "truncated.glb"), "wb").write(data[: len(data) * 6 // 10])

# Strip (4 vertices, 2 triangles), fan (5 vertices, 3 triangles), points (skipped).
QUAD = [0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0]
FAN = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0]
j, b = doc(QUAD, None, mode=5, extra_prims=[(FAN, None, 6, None), (TRI, None, 0, None)])
write_gltf("modes.gltf", j, b)

# Hierarchy 10^7 units from the origin; the child mirrors x (negative
# determinant, so winding must flip) via a matrix.
nodes = [{"name": "far", "translation": [10000000.5, 0, -10000000.25], "children": [1]},
         {"name": "mirrored", "mesh": 0, "matrix": [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.125, 0, 0, 1]}]
j, b = doc(TRI, [0, 1, 2], nodes=nodes)
write_gltf("far_mirrored.gltf", j, b)

j, b = doc(TRI, [0, 1, 5])
write_gltf("out_of_range_index.gltf", j, b)
j, b = doc([0, 0, 0, float("nan"), 0, 0, 0, 1, 0], [0, 1, 2])
write_gltf("nan_vertex.gltf", j.copy(), b)
j, b = doc([0, 0, 0, 1, 0, 0], None, mode=5)
write_gltf("empty_mesh.gltf", j, b)
# Second triangle has zero area (repeated vertex position).
j, b = doc([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 0, 0], [0, 1, 2, 0, 1, 3])
write_gltf("degenerate.gltf", j, b)
open(os.path.join(HERE, "not_json.gltf"), "w").write('{"asset": {"version": "2.0"}, "meshes": [')

open(os.path.join(HERE, "two_groups.obj"), "w").write("""# two groups, two materials
mtllib two_groups.mtl
o pipe
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
usemtl red
f 1 2 4 3
o valve
v 0 0 1
v 1 0 1
v 0 1 1
usemtl blue
f 5 6 7
""")
open(os.path.join(HERE, "two_groups.mtl"), "w").write("""newmtl red
Kd 1 0 0
newmtl blue
Kd 0 0 1
""")
open(os.path.join(HERE, "missing_mtl.obj"), "w").write("""mtllib nowhere.mtl
o lonely
v 0 0 0
v 1 0 0
v 0 1 0
usemtl ghost
f 1 2 3
""")
open(os.path.join(HERE, "obj_out_of_range.obj"), "w").write("""o first
v 0 0 0
v 1 0 0
v 0 1 0
f 1 2 3
o second
f 1 2 9
""")
open(os.path.join(HERE, "obj_nan.obj"), "w").write("""o bad
v 0 0 0
v nan 0 0
v 0 1 0
f 1 2 3
""")
