#!/usr/bin/env python3
"""cad-floor: a plant-scale benchmark scene built from REAL CAD assemblies.

A factory floor (no walls, Y up, metres, floor at y = 0) of rows of
assemblies with 3 m aisles between the rows and cross aisles between blocks:

* engines: the Khronos glTF sample "2CylinderEngine" (a real CAD assembly,
  115 parts) scaled to 2-3 m long, on a plinth, random yaw;
* control cabinets: open racks (0.8 x 2 x 0.6 m, no doors) holding 6-12
  horizontal (shelf) or vertical (card cage) PCBs, each populated with
  30-200 real KiCad component models (kicad-packages3d VRML) at real size.

Every distinct source mesh is one glTF mesh that many nodes instance (the
gigawalk importer expands each mesh-primitive instance into one object).
The output is a glTF 2.0 binary (.glb); a camera path (docs/path-format.md)
walks the aisles. See benches/cad-floor.md for the inputs and how to rerun.

Deterministic: the same inputs and --seed give byte-identical files. Rows
are generated independently per (row, block), so --double / --extra-rows-behind
only add rows behind (at +z of) the walked region, and the walk is the same.

Only the standard library and numpy are needed.
"""

import argparse
import hashlib
import io
import json
import math
import os
import pickle
import random
import re
import struct
import sys
import tarfile
import time

try:
    import numpy as np
except ImportError:  # pragma: no cover
    sys.exit("cad-floor.py needs numpy: pip install numpy")

# --------------------------------------------------------------------------
# Layout constants (metres)

AISLE = 3.0            # aisle width between rows and between blocks
ROW_DEPTH = 3.6        # depth (z) of a row of assemblies
BLOCK_LEN = 7.5        # length (x) of a block of a row between cross aisles
PITCH_Z = ROW_DEPTH + AISLE
PITCH_X = BLOCK_LEN + AISLE
SLOT_GAP = 0.5         # clear space between engine plinths / cabinet banks
EYE_HEIGHT = 1.7
WALK_SPEED = 1.4
DT = 0.1               # 10 poses a second
FOVY_DEG = 60.0
TURN_RADIUS = 1.2      # corners of the walk are arcs of this radius
FLOOR_TILE = 6.0       # floor quads on a fixed grid, so 1x and 2x share them
FLOOR_MARGIN = 3.0

CAB_W, CAB_H, CAB_D = 0.8, 2.0, 0.6
CAB_SPACING = 0.85     # centre distance of cabinets side by side in a bank
PCB_T = 0.0016         # PCB thickness
KICAD_UNIT = 0.00254   # KiCad VRML unit: 0.1 inch in metres

ENGINE_FILE = "2CylinderEngine.gltf"

# Component pool: categories of KiCad libraries, weight (chance a group of
# parts on a board is of this category), group size range, and the most
# triangles a model may have to be used. Low-poly models are preferred
# (weight 1/triangles within a category) so that a cabinet's 500-1000
# parts stay within a plant-scale triangle budget.
CATEGORIES = [
    ("passive_smd", 34, (4, 20), 800,
     ["Resistor_SMD", "Capacitor_SMD", "Capacitor_Tantalum_SMD",
      "Inductor_SMD", "Diode_SMD", "LED_SMD"]),
    ("ic_smd", 16, (1, 6), 2500,
     ["Package_SO", "Package_DFN_QFN", "Package_TO_SOT_SMD", "Package_QFP"]),
    ("ic_tht", 6, (1, 6), 2500,
     ["Package_DIP", "Package_TO_SOT_THT"]),
    ("passive_tht", 18, (2, 10), 1500,
     ["Capacitor_THT", "Resistor_THT", "Diode_THT", "LED_THT", "Crystal",
      "Fuse", "Potentiometer_THT", "Inductor_THT", "Varistor", "Oscillator"]),
    ("power", 8, (1, 3), 3000,
     ["Relay_THT", "Relay_SMD", "Converter_DCDC", "Converter_ACDC",
      "Transformer_THT", "Buzzer_Beeper", "Battery"]),
    ("connector", 18, (1, 4), 2500,
     ["Connector_PinHeader_2.54mm", "Connector_PinSocket_2.54mm",
      "Connector_JST", "Connector_Phoenix_MSTB", "TerminalBlock_Phoenix",
      "Connector_Molex", "Connector_IDC", "Connector_Dsub",
      "Button_Switch_THT", "Display_7Segment", "OptoDevice"]),
]
ALL_LIBS = [lib for c in CATEGORIES for lib in c[4]]
POOL_VERSION = 1   # of the VRML parser and the pool selection (the --cache key)
MAX_PART_FOOTPRINT = 0.10   # m; larger models are left out of the pool
MAX_PART_HEIGHT = 0.06      # m above the board


def log(*a):
    print(*a, flush=True)


# --------------------------------------------------------------------------
# VRML 2.0 (VRML97) parser: enough for kicad-packages3d and similar files.
# Nodes are (type, {field: value}); numeric arrays become numpy arrays.

_TOK = re.compile(r'(?:[\s,]+|#[^\n]*)*([{}\[\]]|"(?:[^"\\]|\\.)*"|[^\s,{}\[\]"#]+)')
_WS = re.compile(r'(?:[\s,]+|#[^\n]*)*')
_NUM0 = frozenset('0123456789+-.')
_COMMENT = re.compile(r'#[^\n]*')


class VrmlError(Exception):
    pass


class VrmlParser:
    def __init__(self, text):
        self.s = text
        self.i = 0
        self.defs = {}
        self.skipped = {}

    def skip(self, what, n=1):
        self.skipped[what] = self.skipped.get(what, 0) + n

    def peek(self):
        m = _TOK.match(self.s, self.i)
        return m.group(1) if m else None

    def next(self):
        m = _TOK.match(self.s, self.i)
        if not m:
            self.i = len(self.s)
            return None
        self.i = m.end()
        return m.group(1)

    def parse_file(self):
        nodes = []
        while True:
            t = self.next()
            if t is None:
                return nodes
            if t == "ROUTE":   # ROUTE a.b TO c.d
                for _ in range(3):
                    self.next()
                self.skip("ROUTE")
                continue
            if t in ("PROTO", "EXTERNPROTO"):
                self.next()
                self.skip_balanced()
                if t == "PROTO":
                    self.skip_balanced()
                else:
                    self.value()
                self.skip(t)
                continue
            n = self.node(t)
            if n is not None:
                nodes.append(n)

    def skip_balanced(self):
        t = self.next()
        if t not in ("[", "{"):
            return
        depth = 1
        while depth and t is not None:
            t = self.next()
            if t in ("[", "{"):
                depth += 1
            elif t in ("]", "}"):
                depth -= 1

    def node(self, t):
        if t == "DEF":
            name = self.next()
            n = self.node(self.next())
            self.defs[name] = n
            return n
        if t == "USE":
            name = self.next()
            if name not in self.defs:
                self.skip("USE of an undefined name")
            return self.defs.get(name)
        if t == "NULL":
            return None
        if t is None or not (t[0].isalpha() or t[0] == "_"):
            raise VrmlError(f"expected a node at offset {self.i}, got {t!r}")
        if self.next() != "{":
            raise VrmlError(f"expected '{{' after {t} at offset {self.i}")
        fields = {}
        while True:
            f = self.next()
            if f == "}":
                return (t, fields)
            if f is None:
                raise VrmlError(f"end of file inside {t}")
            if f == "ROUTE":
                for _ in range(3):
                    self.next()
                continue
            fields[f] = self.value()

    def value(self):
        t = self.peek()
        if t is None:
            raise VrmlError("unexpected end of file")
        if t == "[":
            self.next()
            j = _WS.match(self.s, self.i).end()
            if self.s[j:j + 1] in _NUM0:       # numeric array: fast path
                k = self.s.find("]", j)
                if k < 0:
                    raise VrmlError("unterminated array")
                body = self.s[j:k]
                if "#" in body:
                    body = _COMMENT.sub(" ", body)
                self.i = k + 1
                try:
                    return np.array(body.replace(",", " ").split(), dtype=np.float64)
                except ValueError:
                    raise VrmlError("bad number in an array")
            out = []
            while True:
                t = self.next()
                if t == "]":
                    return out
                if t is None:
                    raise VrmlError("unterminated list")
                if t[0] == '"':
                    out.append(t[1:-1])
                else:
                    n = self.node(t)
                    if n is not None:
                        out.append(n)
        if t[0] == '"':
            self.next()
            return t[1:-1]
        if t in ("DEF", "USE", "NULL"):
            return self.node(self.next())
        if t[0] in _NUM0:
            vals = []
            while True:
                t = self.peek()
                if t is None or t[0] not in _NUM0:
                    break
                try:
                    vals.append(float(self.next()))
                except ValueError:
                    raise VrmlError(f"bad number {t!r}")
            return np.array(vals)
        self.next()
        if self.peek() == "{":
            return self.node(t)
        return t   # TRUE, FALSE, enum words


def _axis_angle(r):
    x, y, z, a = (float(v) for v in r)
    n = math.sqrt(x * x + y * y + z * z)
    M = np.eye(4)
    if n == 0 or a == 0:
        return M
    x, y, z = x / n, y / n, z / n
    c, s = math.cos(a), math.sin(a)
    C = 1 - c
    M[:3, :3] = [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                 [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                 [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]
    return M


def _translate(v):
    M = np.eye(4)
    M[:3, 3] = v
    return M


def _fvec(fields, name, default):
    v = fields.get(name)
    if isinstance(v, np.ndarray) and v.size == len(default):
        return v
    return np.array(default, dtype=np.float64)


def triangulate(ci):
    """coordIndex with -1 terminators -> (M, 3) fan triangles (int64)."""
    ci = ci.astype(np.int64)
    if ci.size == 0:
        return np.zeros((0, 3), np.int64)
    if ci.size % 4 == 0:
        q = ci.reshape(-1, 4)
        if np.all(q[:, 3] == -1) and not np.any(q[:, :3] < 0):
            return q[:, :3].copy()
    if ci[-1] != -1:
        ci = np.append(ci, -1)
    ends = np.flatnonzero(ci == -1)
    starts = np.concatenate(([0], ends[:-1] + 1))
    lens = ends - starts
    ok = lens >= 3
    starts, lens = starts[ok], lens[ok]
    ntri = lens - 2
    total = int(ntri.sum())
    if total == 0:
        return np.zeros((0, 3), np.int64)
    first = np.repeat(starts, ntri)
    k = np.arange(total) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    return np.stack([ci[first], ci[first + k], ci[first + k + 1]], axis=1)


def srgb_to_linear(c):
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


_GROUPING = {"Group", "Anchor", "Collision", "Billboard"}
_IGNORED = {"WorldInfo", "NavigationInfo", "Viewpoint", "Background",
            "DirectionalLight", "PointLight", "SpotLight", "Fog", "Sound",
            "TimeSensor", "TouchSensor", "ProximitySensor", "Script"}


def vrml_shapes(nodes, p):
    """Flattens a VRML scene graph into (rgba_linear, points (N,3), tris (M,3))."""
    out = []

    def walk(node, M, depth):
        if node is None:
            return
        if depth > 64:
            p.skip("nesting deeper than 64")
            return
        ntype, f = node
        if ntype == "Transform":
            c = _fvec(f, "center", [0, 0, 0])
            SR = _axis_angle(_fvec(f, "scaleOrientation", [0, 0, 1, 0]))
            S = np.diag(np.append(_fvec(f, "scale", [1, 1, 1]), 1.0))
            L = (_translate(_fvec(f, "translation", [0, 0, 0])) @ _translate(c)
                 @ _axis_angle(_fvec(f, "rotation", [0, 0, 1, 0]))
                 @ SR @ S @ SR.T @ _translate(-c))
            M = L if M is None else M @ L
            kids = f.get("children", [])
        elif ntype in _GROUPING:
            kids = f.get("children", [])
        elif ntype == "Switch":
            ch = f.get("choice", [])
            w = f.get("whichChoice")
            w = int(w[0]) if isinstance(w, np.ndarray) and w.size else -1
            kids = [ch[w]] if isinstance(ch, list) and 0 <= w < len(ch) else []
        elif ntype == "LOD":
            lv = f.get("level", [])
            kids = lv[:1] if isinstance(lv, list) else []
        elif ntype == "Inline":
            p.skip("Inline node")
            return
        elif ntype == "Shape":
            shape(f, M)
            return
        elif ntype in _IGNORED:
            return
        else:
            p.skip(f"node {ntype}")
            return
        if not isinstance(kids, list):
            kids = [kids]
        for k in kids:
            if isinstance(k, tuple):
                walk(k, M, depth + 1)

    def shape(f, M):
        g = f.get("geometry")
        if g is None:
            return   # KiCad StepUp writes material-only Shapes to DEF materials
        if not isinstance(g, tuple):
            p.skip("geometry that is not a node")
            return
        gtype, gf = g
        if gtype != "IndexedFaceSet":
            p.skip(f"geometry {gtype}")
            return
        coord, ci = gf.get("coord"), gf.get("coordIndex")
        if not (isinstance(coord, tuple) and isinstance(ci, np.ndarray)):
            p.skip("empty IndexedFaceSet (no coordIndex or points)")
            return
        pts = coord[1].get("point")
        if not isinstance(pts, np.ndarray) or pts.size < 9 or pts.size % 3:
            p.skip("Coordinate with a bad point list")
            return
        pts = pts.reshape(-1, 3)
        tris = triangulate(ci)
        bad = ((tris < 0) | (tris >= len(pts))).any(axis=1)
        if bad.any():
            p.skip("triangles with out-of-range indices", int(bad.sum()))
            tris = tris[~bad]
        if len(tris) == 0:
            p.skip("IndexedFaceSet without triangles")
            return
        if gf.get("ccw") == "FALSE":
            tris = tris[:, [0, 2, 1]]
        if M is not None:
            pts = pts @ M[:3, :3].T + M[:3, 3]
            if np.linalg.det(M[:3, :3]) < 0:
                tris = tris[:, [0, 2, 1]]
        rgba = np.array([0.8, 0.8, 0.8, 1.0])
        app = f.get("appearance")
        if isinstance(app, tuple):
            mat = app[1].get("material")
            if isinstance(mat, tuple):
                d = mat[1].get("diffuseColor")
                if isinstance(d, np.ndarray) and d.size == 3:
                    rgba[:3] = srgb_to_linear(d)
                tr = mat[1].get("transparency")
                if isinstance(tr, np.ndarray) and tr.size == 1:
                    rgba[3] = 1.0 - float(np.clip(tr[0], 0.0, 1.0))
        out.append((rgba, pts, tris))

    for n in nodes:
        walk(n, None, 0)
    return out


def drop_degenerate(pos32, tris):
    """Drops triangles with a repeated index or exactly zero area (as the
    gigawalk importer does), computed on the f32 positions the file holds."""
    if len(tris) == 0:
        return tris
    keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
    p = pos32.astype(np.float64)
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    n = np.cross(b - a, c - a)
    keep &= np.any(n != 0.0, axis=1)
    return tris[keep]


# --------------------------------------------------------------------------
# Meshes held for the output: one glTF mesh per distinct source mesh.

class Prim:
    __slots__ = ("pos", "nrm", "idx", "rgba")

    def __init__(self, pos, idx, rgba, nrm=None):
        self.pos = np.ascontiguousarray(pos, dtype=np.float32)
        self.idx = np.ascontiguousarray(idx, dtype=np.uint32).reshape(-1)
        self.nrm = None if nrm is None else np.ascontiguousarray(nrm, dtype=np.float32)
        self.rgba = [float(x) for x in rgba]


class Mesh:
    def __init__(self, name, prims):
        self.name = name
        self.prims = prims
        self.tris = sum(len(p.idx) // 3 for p in prims)
        allp = np.concatenate([p.pos for p in prims])
        self.lo = allp.min(axis=0).astype(np.float64)
        self.hi = allp.max(axis=0).astype(np.float64)
        self.id = None      # glTF mesh index, assigned when first used


def load_kicad_mesh(path, name, stats):
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    p = VrmlParser(text)
    shapes = vrml_shapes(p.parse_file(), p)
    for k, v in p.skipped.items():
        stats["skipped"][k] = stats["skipped"].get(k, 0) + v
    # Merge the shapes of one colour into one primitive (one object per
    # instance and colour), keeping each shape's own vertices: StepUp writes
    # a shape per CAD face, so area-weighted normals (the importer's) stay
    # sharp across face edges.
    by_col = {}
    for rgba, pts, tris in shapes:
        key = tuple(np.round(rgba, 4))
        by_col.setdefault(key, []).append((pts, tris))
    prims = []
    for key in sorted(by_col):
        P, T, base = [], [], 0
        for pts, tris in by_col[key]:
            P.append(pts * KICAD_UNIT)
            T.append(tris + base)
            base += len(pts)
        pos = np.concatenate(P).astype(np.float32)
        tris = drop_degenerate(pos, np.concatenate(T))
        if len(tris):
            prims.append(Prim(pos, tris, key))
    if not prims:
        return None
    return Mesh(name, prims)


# --------------------------------------------------------------------------
# Inputs: the KiCad libraries (extracted from the .deb when asked) and the
# engine glTF.

def kicad_root(d):
    """Accepts the 3dmodels directory or any directory above it."""
    for cand in (d, os.path.join(d, "usr/share/kicad/3dmodels"),
                 os.path.join(d, "3dmodels")):
        if os.path.isdir(cand) and any(n.endswith(".3dshapes") for n in os.listdir(cand)):
            return cand
    return None


def extract_kicad(deb, dest, libs):
    """Extracts the .wrl files of `libs` from a kicad-packages3d .deb into
    dest/usr/share/kicad/3dmodels, with Python only (ar + tar.xz)."""
    want = {f"{lib}.3dshapes" for lib in libs}
    n = 0
    t0 = time.time()
    with open(deb, "rb") as fh:
        if fh.read(8) != b"!<arch>\n":
            sys.exit(f"{deb}: not a .deb (ar) archive")
        while True:
            hdr = fh.read(60)
            if len(hdr) < 60:
                sys.exit(f"{deb}: no data.tar member")
            name = hdr[:16].decode().strip().rstrip("/")
            size = int(hdr[48:58].decode().strip())
            if name.startswith("data.tar"):
                break
            fh.seek(size + (size & 1), 1)
        mode = {"data.tar.xz": "r|xz", "data.tar.gz": "r|gz", "data.tar.bz2": "r|bz2",
                "data.tar": "r|"}.get(name)
        if mode is None:
            sys.exit(f"{deb}: unsupported member {name} (use dpkg-deb, see cad-floor.md)")

        class Limited(io.RawIOBase):
            def __init__(self, f, left):
                self.f, self.left = f, left

            def readable(self):
                return True

            def readinto(self, b):
                k = min(len(b), self.left)
                if k <= 0:
                    return 0
                data = self.f.read(k)
                b[:len(data)] = data
                self.left -= len(data)
                return len(data)

        with tarfile.open(fileobj=io.BufferedReader(Limited(fh, size), 1 << 20), mode=mode) as tar:
            for m in tar:
                if not (m.isfile() and m.name.endswith(".wrl")):
                    continue
                if "3dmodels/" not in m.name:
                    continue
                rel = m.name.split("3dmodels/", 1)[1]
                if rel.split("/")[0] not in want or ".." in rel.split("/"):
                    continue
                out = os.path.join(dest, "usr/share/kicad/3dmodels", rel)
                os.makedirs(os.path.dirname(out), exist_ok=True)
                with tar.extractfile(m) as src, open(out, "wb") as dst:
                    dst.write(src.read())
                n += 1
    log(f"extracted {n} .wrl files of {len(libs)} libraries from {deb} in {time.time() - t0:.0f} s")


def build_pool(root, per_lib, stats):
    """The component pool: per library, up to per_lib models spread evenly
    over its (sorted) low-poly files; deterministic for given files."""
    pool = []   # (category index, Mesh, weight)
    t0 = time.time()
    parsed_bytes = 0
    for ci, (cat, _w, _g, max_tris, libs) in enumerate(CATEGORIES):
        for lib in libs:
            d = os.path.join(root, f"{lib}.3dshapes")
            if not os.path.isdir(d):
                stats["missing_libs"].append(lib)
                continue
            files = sorted(f for f in os.listdir(d) if f.endswith(".wrl"))
            # ~42 bytes of VRML text per triangle; some slack before parsing.
            cands = [f for f in files if os.path.getsize(os.path.join(d, f)) <= max_tris * 60]
            if not cands:
                continue
            step = max(1.0, len(cands) / (per_lib * 1.5))
            picked, k = [], 0.0
            while int(k) < len(cands) and len(picked) < per_lib * 1.5:
                picked.append(cands[int(k)])
                k += step
            got = 0
            for f in picked:
                if got >= per_lib:
                    break
                path = os.path.join(d, f)
                parsed_bytes += os.path.getsize(path)
                try:
                    m = load_kicad_mesh(path, f"kicad/{lib}/{f[:-4]}", stats)
                except (VrmlError, RecursionError, ValueError) as e:
                    stats["skipped"][f"file not parsed ({type(e).__name__})"] = \
                        stats["skipped"].get(f"file not parsed ({type(e).__name__})", 0) + 1
                    stats["unparsed_files"].append(f"{lib}/{f}: {e}")
                    continue
                if m is None:
                    stats["skipped"]["file without triangles"] = \
                        stats["skipped"].get("file without triangles", 0) + 1
                    continue
                ext = m.hi - m.lo
                if (m.tris > max_tris or max(ext[0], ext[1]) > MAX_PART_FOOTPRINT
                        or m.hi[2] > MAX_PART_HEIGHT or m.lo[2] < -0.012):
                    stats["rejected_models"] += 1
                    continue
                pool.append((ci, m, 1.0 / m.tris))
                got += 1
    stats["pool_seconds"] = time.time() - t0
    stats["pool_parsed_mb"] = parsed_bytes / 1e6
    return pool


def read_gltf(path):
    """A .gltf (buffers in files beside it) or .glb: its JSON and buffers."""
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:4] != b"glTF":
        g = json.loads(data)
        bufs = []
        for b in g["buffers"]:
            with open(os.path.join(os.path.dirname(path), b["uri"]), "rb") as fh:
                bufs.append(fh.read())
        return g, bufs
    _, _, total = struct.unpack_from("<III", data, 0)
    g, bufs, off = None, [], 12
    while off + 8 <= min(total, len(data)):
        ln, kind = struct.unpack_from("<II", data, off)
        chunk = data[off + 8:off + 8 + ln]
        if kind == 0x4E4F534A:
            g = json.loads(chunk)
        elif kind == 0x004E4942:
            bufs.append(chunk)
        off += 8 + ln
    if g is None:
        sys.exit(f"{path}: a GLB without a JSON chunk")
    return g, bufs


def load_engine(path, prefix="2CylinderEngine"):
    """Reads a CAD assembly (the engine glTF, or any .gltf/.glb): its meshes
    (degenerate triangles dropped) and the flattened list of (mesh, 4x4
    matrix) part instances."""
    g, bufs = read_gltf(path)
    size = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
    dt = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
          5125: np.uint32, 5126: np.float32}

    def acc(i):
        a = g["accessors"][i]
        bv = g["bufferViews"][a["bufferView"]]
        t = np.dtype(dt[a["componentType"]])
        n, k = a["count"], size[a["type"]]
        off = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
        stride = bv.get("byteStride", t.itemsize * k)
        raw = np.frombuffer(bufs[bv["buffer"]], dtype=np.uint8,
                            count=(n - 1) * stride + t.itemsize * k, offset=off)
        out = np.lib.stride_tricks.as_strided(raw, shape=(n, t.itemsize * k), strides=(stride, 1))
        return np.ascontiguousarray(out).view(t).reshape(n, k) if k > 1 else \
            np.ascontiguousarray(out).view(t).reshape(n)

    meshes = []
    for mi, m in enumerate(g["meshes"]):
        prims = []
        for p in m["primitives"]:
            if p.get("mode", 4) != 4:
                continue
            pos = acc(p["attributes"]["POSITION"]).astype(np.float32)
            nrm = acc(p["attributes"]["NORMAL"]).astype(np.float32) if "NORMAL" in p["attributes"] else None
            idx = acc(p["indices"]).astype(np.int64).reshape(-1, 3) if "indices" in p \
                else np.arange(len(pos)).reshape(-1, 3)
            rgba = [0.8, 0.8, 0.8, 1.0]
            if "material" in p:
                rgba = g["materials"][p["material"]].get("pbrMetallicRoughness", {}).get(
                    "baseColorFactor", rgba)
            idx = drop_degenerate(pos, idx)
            if len(idx):
                prims.append(Prim(pos, idx, rgba, nrm))
        meshes.append(Mesh(f"{prefix}/{m.get('name', mi)}", prims) if prims else None)

    def local(n):
        if "matrix" in n:
            return np.array(n["matrix"], dtype=np.float64).reshape(4, 4).T
        M = np.eye(4)
        if "scale" in n:
            M = np.diag(list(n["scale"]) + [1.0]) @ M
        if "rotation" in n:
            x, y, z, w = n["rotation"]
            R = np.eye(4)
            R[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
            M = R @ M
        if "translation" in n:
            M = _translate(n["translation"]) @ M
        return M

    parts = []

    def walk(i, M):
        n = g["nodes"][i]
        W = M @ local(n)
        if "mesh" in n and meshes[n["mesh"]] is not None:
            parts.append((meshes[n["mesh"]], W))
        for c in n.get("children", []):
            walk(c, W)

    for r in g["scenes"][g.get("scene", 0)]["nodes"]:
        walk(r, np.eye(4))
    lo = np.full(3, np.inf)
    hi = -lo
    for m, W in parts:
        c = np.array([[x, y, z] for x in (m.lo[0], m.hi[0]) for y in (m.lo[1], m.hi[1])
                      for z in (m.lo[2], m.hi[2])])
        w = c @ W[:3, :3].T + W[:3, 3]
        lo, hi = np.minimum(lo, w.min(0)), np.maximum(hi, w.max(0))
    return parts, lo, hi


def box_mesh(name, rgba):
    """Unit cube centred at the origin, 4 vertices per face (flat normals)."""
    P, T = [], []
    for axis in range(3):
        for sgn in (-1.0, 1.0):
            u, v = [(1, 2), (2, 0), (0, 1)][axis]
            corners = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = 0.5 * sgn
                p[u] = 0.5 * a
                p[v] = 0.5 * b
                corners.append(p)
            base = len(P)
            P.extend(corners)
            if sgn > 0:
                T += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
            else:
                T += [[base, base + 2, base + 1], [base, base + 3, base + 2]]
    return Mesh(name, [Prim(np.array(P), np.array(T), rgba)])


def quad_mesh(name, rgba):
    """Unit square in y = 0 facing +y, centred at the origin."""
    P = np.array([[-0.5, 0, -0.5], [0.5, 0, -0.5], [0.5, 0, 0.5], [-0.5, 0, 0.5]])
    return Mesh(name, [Prim(P, np.array([[0, 2, 1], [0, 3, 2]]), rgba)])


# --------------------------------------------------------------------------
# Scene nodes. A node: dict(mesh=Mesh|None, m=4x4 local matrix or None,
# t=translation, name=str, children=[...]). Kept light for big floors.

def N(mesh=None, m=None, t=None, s=None, name=None, children=None):
    return {"mesh": mesh, "m": m, "t": t, "s": s, "name": name, "children": children or []}


def yaw_matrix(yaw, t):
    c, s = math.cos(yaw), math.sin(yaw)
    M = np.eye(4)
    M[0, 0], M[0, 2], M[2, 0], M[2, 2] = c, s, -s, c
    M[:3, 3] = t
    return M


def box_node(mesh, lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return N(mesh, t=(lo + hi) / 2, s=hi - lo)


# Exact rotations about the board normal (KiCad +Z): 0, 90, 180, 270 degrees.
_ROT = [((1, 0), (0, 1)), ((0, -1), (1, 0)), ((-1, 0), (0, -1)), ((0, 1), (-1, 0))]


class Builder:
    """Generates assemblies deterministically per (seed, row, block)."""

    def __init__(self, args, pool, engine, stats):
        self.args = args
        self.pool = pool
        # engine: one (parts, lo, hi) for the 2CylinderEngine; with --models
        # a list of (parts, lo, hi, label), one per assembly file
        self.machines = engine if args.models else None
        if not args.models:
            self.engine_parts, self.engine_lo, self.engine_hi = engine
        self.stats = stats
        self.by_cat = [[(m, w) for (ci, m, w) in pool if ci == k] for k in range(len(CATEGORIES))]
        self.cat_w = [c[1] if self.by_cat[k] else 0 for k, c in enumerate(CATEGORIES)]
        if not any(self.cat_w) and not args.models:
            sys.exit("no KiCad component models found: see --kicad-dir / --kicad-deb")
        grey = srgb_to_linear([0.28, 0.29, 0.30]).tolist() + [1.0]
        self.rack_box = box_mesh("rack_steel", grey)
        self.rail_box = box_mesh("rack_rail", srgb_to_linear([0.62, 0.63, 0.64]).tolist() + [1.0])
        self.pcb_box = box_mesh("pcb", srgb_to_linear([0.05, 0.33, 0.14]).tolist() + [1.0])
        self.plinth_box = box_mesh("plinth", srgb_to_linear([0.55, 0.52, 0.40]).tolist() + [1.0])
        self.floor_quad = quad_mesh("floor", srgb_to_linear([0.42, 0.43, 0.42]).tolist() + [1.0])
        self.cache = {}

    # ---- cabinets -------------------------------------------------------

    def populate(self, rng, bw, bd, n_parts, max_h):
        """Components on a bw x bd board (board frame: u, v, normal +Z),
        grid-ish: groups of identical parts, rows packed and spread."""
        groups, total, tries = [], 0, 0
        cats = list(range(len(CATEGORIES)))
        while total < n_parts and tries < 10000:
            tries += 1
            ci = rng.choices(cats, weights=self.cat_w)[0]
            cands = [(m, w) for (m, w) in self.by_cat[ci] if m.hi[2] <= max_h]
            if not cands:
                continue
            m = rng.choices([c[0] for c in cands], weights=[c[1] for c in cands])[0]
            lo, hi = CATEGORIES[ci][2]
            k = min(rng.randint(lo, hi), n_parts - total)
            groups.append((m, rng.randrange(4), k))
            total += k
        if not groups:
            return []
        items = []
        for m, r, k in groups:
            (a, b), (c, d) = _ROT[r]
            ex, ey = m.hi[0] - m.lo[0], m.hi[1] - m.lo[1]
            w, h = (ex, ey) if r % 2 == 0 else (ey, ex)
            items += [(m, r, w, h)] * k
        # Taller rows first: similar parts end up in neat rows.
        items.sort(key=lambda it: -it[3])
        clear = 0.0015 + 0.001 * rng.random()

        def pack(width):
            rows, cur, used = [], [], 0.0
            for it in items:
                if cur and used + it[2] + clear > width:
                    rows.append(cur)
                    cur, used = [], 0.0
                cur.append(it)
                used += it[2] + clear
            if cur:
                rows.append(cur)
            return rows, [max(it[3] for it in row) + clear for row in rows]

        # Pack into a narrower board (bw / spread) and then spread rows and
        # parts evenly over the whole board: a grid-ish layout that covers it.
        rows, heights = pack(bw)
        widest = max(it[2] for it in items) + clear
        spread = 1.0
        while spread < 16:
            s2 = spread * 1.15
            if widest > bw / s2:
                break
            r2, h2 = pack(bw / s2)
            if sum(h2) * s2 > 0.92 * bd:
                break
            spread, rows, heights = s2, r2, h2
        while rows and sum(heights) > bd:   # too many parts: drop rows
            rows.pop()
            heights.pop()
        nrow = len(rows)
        gap_v = (bd - sum(heights)) / (nrow + 1)
        v = gap_v
        nodes = []
        for row, hgt in zip(rows, heights):
            rw = sum(it[2] + clear for it in row)
            gap_u = (bw - rw) / (len(row) + 1)
            u = gap_u + clear / 2
            for m, r, w, h in row:
                (a, b), (c, d) = _ROT[r]
                # rotated bbox min of the model, moved to (u, v)
                xs = [a * x + b * y for x in (m.lo[0], m.hi[0]) for y in (m.lo[1], m.hi[1])]
                ys = [c * x + d * y for x in (m.lo[0], m.hi[0]) for y in (m.lo[1], m.hi[1])]
                t = (u - min(xs), v + clear / 2 + (hgt - clear - h) / 2 - min(ys), 0.0)
                if r == 0:
                    nodes.append(N(m, t=t))
                else:
                    M = np.eye(4)
                    M[0, 0], M[0, 1], M[1, 0], M[1, 1] = a, b, c, d
                    M[:3, 3] = t
                    nodes.append(N(m, m=M))
                u += w + clear + gap_u
            v += hgt + gap_v
        return nodes

    def board(self, rng, frame, bw, bd, max_h, name):
        lo_p, hi_p = self.args.parts
        # most boards are lightly populated, a few dense (mean lo + (hi - lo) / 3)
        n_parts = lo_p + int((hi_p - lo_p + 1) * rng.random() ** 2)
        comps = self.populate(rng, bw, bd, n_parts, max_h)
        kids = [N(self.pcb_box, t=(bw / 2, bd / 2, -PCB_T / 2), s=(bw, bd, PCB_T))] + comps
        return N(m=frame, name=name, children=kids), len(comps)

    def cabinet(self, rng, name):
        """Open rack, local frame: x across [-0.4, 0.4], y up, front at z = +0.3."""
        hw, hd = CAB_W / 2, CAB_D / 2
        st = 0.02
        R = self.rack_box
        kids = [
            box_node(R, (-hw, 0, -hd), (hw, 0.1, hd)),                       # base
            box_node(R, (-hw, CAB_H - 0.03, -hd), (hw, CAB_H, hd)),          # top
            box_node(R, (-hw, 0.1, -hd), (-hw + st, CAB_H - 0.03, hd)),      # sides
            box_node(R, (hw - st, 0.1, -hd), (hw, CAB_H - 0.03, hd)),
            box_node(R, (-hw + st, 0.1, -hd), (hw - st, CAB_H - 0.03, -hd + st)),  # back
        ]
        lo_b, hi_b = self.args.boards
        nb = rng.randint(lo_b, hi_b)
        inner_w = CAB_W - 2 * st
        y0, y1 = 0.12, CAB_H - 0.05
        parts = 0
        vertical = rng.random() < 0.5
        if not vertical:
            pitch = (y1 - y0) / nb
            bw, bd = inner_w - 0.01, CAB_D - st - 0.05
            for i in range(nb):
                y = y0 + i * pitch + 0.01
                # board frame: u -> +x, v -> -z (front to back), normal -> +y
                F = np.array([[1, 0, 0, -bw / 2], [0, 0, 1, y], [0, -1, 0, hd - 0.02], [0, 0, 0, 1]], float)
                b, k = self.board(rng, F, bw, bd, min(MAX_PART_HEIGHT, pitch - 0.02), f"{name}.board{i}")
                kids.append(b)
                parts += k
                for x0 in (-hw + st, hw - st - 0.012):   # slide rails
                    kids.append(box_node(self.rail_box, (x0, y - 0.012, -hd + st), (x0 + 0.012, y - PCB_T, hd - 0.02)))
        else:
            tiers = 2 if nb <= 8 else 3
            per = -(-nb // tiers)
            th = (y1 - y0) / tiers
            pitch = inner_w / per
            bw, bd = CAB_D - st - 0.05, th - 0.06
            i = 0
            for tr in range(tiers):
                ty = y0 + tr * th
                kids.append(box_node(self.rail_box, (-hw + st, ty, -hd + st), (hw - st, ty + 0.012, hd - 0.02)))
                for c in range(per):
                    if i >= nb:
                        break
                    x = -hw + st + c * pitch + 0.012
                    # board frame: u -> -z (front to back), v -> +y, normal -> +x
                    F = np.array([[0, 0, 1, x], [0, 1, 0, ty + 0.03], [-1, 0, 0, hd - 0.02], [0, 0, 0, 1]], float)
                    b, k = self.board(rng, F, bw, bd, min(MAX_PART_HEIGHT, pitch - 0.024), f"{name}.board{i}")
                    kids.append(b)
                    parts += k
                    i += 1
            kids.append(box_node(self.rail_box, (-hw + st, y1 - 0.012, -hd + st), (hw - st, y1, hd - 0.02)))
        return kids, parts, nb, vertical

    # ---- engines --------------------------------------------------------

    def engine(self, rng):
        """A machine on a plinth: the engine 2-3 m long, or (--models) one of
        the assemblies, its longest side 1.8-3 m, narrow enough for its row
        at any yaw."""
        if self.machines is None:
            L = rng.uniform(2.0, 3.0)
            parts, lo, hi, label = self.engine_parts, self.engine_lo, self.engine_hi, "engine"
            s = L / (hi[0] - lo[0])
        else:
            parts, lo, hi, label = self.machines[rng.randrange(len(self.machines))]
            L = rng.uniform(1.8, 3.0)
            s = min(L / max(hi - lo), (ROW_DEPTH - 0.5) / math.hypot(hi[0] - lo[0], hi[2] - lo[2]))
        c = (lo + hi) / 2
        plinth_h = rng.uniform(0.3, 0.5)
        ext = (hi - lo) * s
        yaw = rng.uniform(0, 2 * math.pi)
        # engine frame: scale about its box centre, bottom on the plinth
        E = np.diag([s, s, s, 1.0])
        E[:3, 3] = [-c[0] * s, plinth_h - lo[1] * s, -c[2] * s]
        kids = [box_node(self.plinth_box, (-ext[0] / 2 - 0.15, 0, -ext[2] / 2 - 0.15),
                         (ext[0] / 2 + 0.15, plinth_h, ext[2] / 2 + 0.15))]
        kids += [N(m, m=E @ W) for (m, W) in parts]
        half = np.array([ext[0] / 2 + 0.15, ext[2] / 2 + 0.15])
        cy, sy = abs(math.cos(yaw)), abs(math.sin(yaw))
        foot = (half[0] * cy + half[1] * sy, half[0] * sy + half[1] * cy)   # half extents x, z
        return kids, yaw, foot, L, plinth_h + ext[1], label

    # ---- blocks ---------------------------------------------------------

    def block(self, r, b):
        """Assemblies of block b of row r, in block coordinates (x along the
        row in [0, BLOCK_LEN], z across it in [0, ROW_DEPTH]): dicts with the
        node, kind, AABB (x0, z0, x1, z1), triangles, objects, parts. The
        content depends only on (seed, r, b), never on the floor's size."""
        key = (r, b)
        if key in self.cache:
            return self.cache[key]
        rng = random.Random(f"cad-floor:{self.args.seed}:row{r}:block{b}")
        x_start = 0.0
        zc = ROW_DEPTH / 2
        slots = []          # (kind, length, payload)
        used = 0.0
        share = self.args.cabinet_share
        # Cabinets stand in back-to-back pairs, one facing each aisle. The
        # kind of each slot keeps the block's mix near `share` cabinets (by
        # count), a coin deciding when it is balanced; the constants were
        # tuned by simulating 3000 blocks (short pairs fill the ends of
        # blocks, so cabinets would otherwise win).
        p_engine = (1 - share) * 3.5 / (share + (1 - share) * 3.5) if share < 1 else 0.0
        ratio = 1.25 * (1 - share) / share if share > 0 else float("inf")
        n_eng = n_cab = 0
        while True:
            missing = ratio * n_cab - n_eng
            if share >= 1:
                engine = False
            elif share <= 0 or missing >= 0.5:
                engine = True
            elif missing <= -0.5:
                engine = False
            else:
                engine = rng.random() < p_engine
            if engine:
                kids, yaw, foot, L, top, label = self.engine(rng)
                slot = ("engine", 2 * foot[0], (kids, yaw, foot, L, top, label))
            else:
                slot = ("bank", CAB_W, 1)
            need = used + (SLOT_GAP if slots else 0) + slot[1]
            if need > BLOCK_LEN:
                break
            if engine:
                n_eng += 1
            else:
                n_cab += 2
            slots.append(slot)
            used = need
        # spread the slots over the block
        margin = (BLOCK_LEN - used) / (len(slots) + 1)
        gap = SLOT_GAP + margin
        x = x_start + margin
        out = []
        for si, (kind, length, payload) in enumerate(slots):
            if kind == "engine":
                kids, yaw, foot, L, top, label = payload
                cx = x + length / 2
                name = f"{label}.r{r}b{b}s{si}"
                node = N(m=yaw_matrix(yaw, (cx, 0, zc)), name=name, children=kids)
                out.append(self._assembly(label, name, node,
                                          (cx - foot[0], zc - foot[1], cx + foot[0], zc + foot[1]),
                                          parts=len(kids) - 1, top=top))
            else:
                for p in range(payload):
                    cx = x + CAB_W / 2 + p * CAB_SPACING
                    for side in (-1, 1):     # front faces the aisle on that side
                        name = f"cabinet.r{r}b{b}s{si}p{p}{'n' if side < 0 else 's'}"
                        kids, nparts, nb, vertical = self.cabinet(rng, name)
                        cz = zc + side * (ROW_DEPTH / 2 - CAB_D / 2)
                        yaw = 0.0 if side > 0 else math.pi
                        M = np.eye(4)
                        if side < 0:
                            M[0, 0] = M[2, 2] = -1.0
                        M[:3, 3] = (cx, 0, cz)
                        node = N(m=M, name=name, children=kids)
                        a = self._assembly("cabinet", name, node,
                                           (cx - CAB_W / 2, cz - CAB_D / 2, cx + CAB_W / 2, cz + CAB_D / 2),
                                           parts=nparts, top=CAB_H)
                        a["boards"] = nb
                        a["vertical"] = vertical
                        out.append(a)
            x += length + gap
        self.cache[key] = out
        return out

    def _assembly(self, kind, name, node, box, parts, top):
        tris, objs = count(node)
        return {"kind": kind, "name": name, "node": node, "box": box, "top": top,
                "triangles": tris, "objects": objs, "parts": parts}


def count(node):
    tris = objs = 0
    stack = [node]
    while stack:
        n = stack.pop()
        if n["mesh"] is not None:
            tris += n["mesh"].tris
            objs += len(n["mesh"].prims)
        stack.extend(n["children"])
    return tris, objs


# --------------------------------------------------------------------------
# glTF binary writer

class GlbWriter:
    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors, self.meshes, self.materials = [], [], [], []
        self.mat_ids = {}
        self.nodes = []

    def _blob(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        off = len(self.bin)
        self.bin += data
        self.views.append({"buffer": 0, "byteOffset": off, "byteLength": len(data), "target": target})
        return len(self.views) - 1

    def _material(self, rgba):
        key = tuple(round(x, 6) for x in rgba)
        if key not in self.mat_ids:
            m = {"pbrMetallicRoughness": {"baseColorFactor": list(key), "metallicFactor": 0.0,
                                          "roughnessFactor": 0.7}}
            if key[3] < 1.0:
                m["alphaMode"] = "BLEND"
            self.mat_ids[key] = len(self.materials)
            self.materials.append(m)
        return self.mat_ids[key]

    def mesh(self, mesh):
        if mesh.id is not None:
            return mesh.id
        prims = []
        for p in mesh.prims:
            pv = self._blob(p.pos.tobytes(), 34962)
            self.accessors.append({"bufferView": pv, "componentType": 5126, "count": len(p.pos),
                                   "type": "VEC3", "min": [float(x) for x in p.pos.min(axis=0)],
                                   "max": [float(x) for x in p.pos.max(axis=0)]})
            attrs = {"POSITION": len(self.accessors) - 1}
            if p.nrm is not None:
                nv = self._blob(p.nrm.tobytes(), 34962)
                self.accessors.append({"bufferView": nv, "componentType": 5126,
                                       "count": len(p.nrm), "type": "VEC3"})
                attrs["NORMAL"] = len(self.accessors) - 1
            iv = self._blob(p.idx.tobytes(), 34963)
            self.accessors.append({"bufferView": iv, "componentType": 5125,
                                   "count": len(p.idx), "type": "SCALAR"})
            prims.append({"attributes": attrs, "indices": len(self.accessors) - 1,
                          "material": self._material(p.rgba), "mode": 4})
        self.meshes.append({"name": mesh.name, "primitives": prims})
        mesh.id = len(self.meshes) - 1
        return mesh.id

    def node(self, n):
        """Adds node n and its subtree (depth first); returns its index."""
        j = {}
        if n["name"]:
            j["name"] = n["name"]
        if n["mesh"] is not None:
            j["mesh"] = self.mesh(n["mesh"])
        if n["m"] is not None:
            j["matrix"] = [_num(v) for v in np.asarray(n["m"]).T.reshape(-1)]
        else:
            if n["t"] is not None and any(n["t"]):
                j["translation"] = [_num(v) for v in n["t"]]
            if n["s"] is not None:
                j["scale"] = [_num(v) for v in n["s"]]
        idx = len(self.nodes)
        self.nodes.append(j)
        if n["children"]:
            j["children"] = [self.node(c) for c in n["children"]]
        return idx

    def write(self, path, roots, extras):
        doc = {
            "asset": {"version": "2.0", "generator": "gigawalk benches/cad-floor.py",
                      "extras": extras},
            "scene": 0,
            "scenes": [{"name": "cad-floor", "nodes": roots}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": len(self.bin)}],
        }
        js = json.dumps(doc, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        while len(self.bin) % 4:
            self.bin.append(0)
        total = 12 + 8 + len(js) + 8 + len(self.bin)
        if total >= 2 ** 32:
            sys.exit("output over 4 GiB: the GLB container cannot hold it")
        tmp = path + ".tmp"
        with open(tmp, "wb") as fh:
            fh.write(struct.pack("<III", 0x46546C67, 2, total))
            fh.write(struct.pack("<II", len(js), 0x4E4F534A))
            fh.write(js)
            fh.write(struct.pack("<II", len(self.bin), 0x004E4942))
            fh.write(self.bin)
        os.replace(tmp, path)
        return total, len(js), len(self.bin)


def _num(v):
    """A JSON number: 9 significant digits (f32 and then some), 0 for
    rounding noise, integers without a fraction."""
    v = float(v)
    if abs(v) < 1e-12:
        return 0
    r = float(f"{v:.9g}")
    if r == int(r) and abs(r) < 1e15:
        return int(r)
    return r


# --------------------------------------------------------------------------
# Camera path

def quat_yaw_pitch(yaw, pitch):
    """q = q_y(yaw) * q_x(pitch): the camera looks down -Z; yaw about +Y."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    # (0, sy, 0, cy) * (sp, 0, 0, cp)
    return (cy * sp, sy * cp, -sy * sp, cy * cp)


def heading(dx, dz):
    return math.atan2(-dx, -dz)


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def make_walk(xs, zs, seed, poses, boxes):
    """A walk on the aisle grid (x = xs[i] cross aisles, z = zs[j] row
    aisles): corners rounded, 1.4 m/s, glances at the machines."""
    rng = random.Random(f"cad-floor-walk:{seed}")
    nx, nz = len(xs), len(zs)
    # Start on a row aisle between two cross aisles, heading along it.
    j = rng.randrange(nz)
    i = rng.randrange(nx - 1)
    nodes = [(i, j), (i + 1, j)] if rng.random() < 0.5 else [(i + 1, j), (i, j)]
    need = poses * DT * WALK_SPEED * 1.3 + 40
    length = 0.0
    while length < need:
        (ai, aj), (bi, bj) = nodes[-2], nodes[-1]
        opts = []
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ci, cj = bi + di, bj + dj
            if 0 <= ci < nx and 0 <= cj < nz and (ci, cj) != (ai, aj):
                # prefer walking along row aisles (where the machines are)
                w = 3.0 if dj == 0 else 1.0
                if (di, dj) == (bi - ai, bj - aj):
                    w *= 1.5
                opts.append(((ci, cj), w))
        if not opts:
            opts = [((ai, aj), 1.0)]
        nxt = rng.choices([o[0] for o in opts], weights=[o[1] for o in opts])[0]
        nodes.append(nxt)
        length += abs(xs[nxt[0]] - xs[bi]) + abs(zs[nxt[1]] - zs[bj])
    pts = [(xs[i], zs[j]) for i, j in nodes]
    # polyline -> segments and arcs: list of (kind, data, length)
    pieces = []
    cur = pts[0]
    for k in range(1, len(pts) - 1):
        a, b, c = pts[k - 1], pts[k], pts[k + 1]
        d1 = ((b[0] - a[0]) / _dist(a, b), (b[1] - a[1]) / _dist(a, b))
        d2 = ((c[0] - b[0]) / _dist(b, c), (c[1] - b[1]) / _dist(b, c))
        cross = d1[0] * d2[1] - d1[1] * d2[0]
        if abs(cross) < 1e-9:
            continue   # straight on
        r = TURN_RADIUS
        p1 = (b[0] - d1[0] * r, b[1] - d1[1] * r)
        p2 = (b[0] + d2[0] * r, b[1] + d2[1] * r)
        pieces.append(("line", (cur, p1), _dist(cur, p1)))
        # centre of the quarter circle: p1 + r * (normal of d1 towards the turn)
        nrm = (-d1[1], d1[0]) if cross > 0 else (d1[1], -d1[0])
        ctr = (p1[0] + nrm[0] * r, p1[1] + nrm[1] * r)
        a0 = math.atan2(p1[1] - ctr[1], p1[0] - ctr[0])
        sweep = math.pi / 2 * (1 if cross > 0 else -1)
        pieces.append(("arc", (ctr, r, a0, sweep), r * math.pi / 2))
        cur = p2
    pieces.append(("line", (cur, pts[-1]), _dist(cur, pts[-1])))
    pieces = [p for p in pieces if p[2] > 1e-9]
    starts = np.cumsum([0.0] + [p[2] for p in pieces])

    def at(s):
        k = min(int(np.searchsorted(starts, s, side="right")) - 1, len(pieces) - 1)
        kind, d, ln = pieces[k]
        f = min(max((s - starts[k]) / ln, 0.0), 1.0)
        if kind == "line":
            (x0, z0), (x1, z1) = d
            return x0 + (x1 - x0) * f, z0 + (z1 - z0) * f, heading(x1 - x0, z1 - z0)
        ctr, r, a0, sweep = d
        ang = a0 + sweep * f
        x, z = ctr[0] + r * math.cos(ang), ctr[1] + r * math.sin(ang)
        tx, tz = -math.sin(ang) * sweep, math.cos(ang) * sweep
        return x, z, heading(tx, tz)

    # Glances: now and then slow down and turn the head to a machine side.
    out = []
    s = 0.0
    t_next_look = rng.uniform(4.0, 8.0)
    look = None   # (t_start, duration, side_angle)
    speed = WALK_SPEED
    for k in range(poses):
        t = k * DT
        x, z, hd = at(s)
        offset, pitch = 0.0, -0.06 + 0.03 * math.sin(t * 0.5)
        along_x = abs(math.sin(hd)) > 0.9      # walking along a row aisle
        if look is None and t >= t_next_look and along_x:
            # machines just ahead on which sides of this aisle?
            ax = x - 1.5 * math.sin(hd)
            sides = sorted({(1 if bz0 > z else -1) for (bx0, bz0, bx1, bz1) in boxes
                            if bx0 - 1.0 < ax < bx1 + 1.0
                            and (0 < bz0 - z < AISLE or 0 < z - bz1 < AISLE)})
            if sides:
                side_z = rng.choice(sides)
                # yaw that looks towards +z is pi (heading(0, 1)); towards -z is 0
                target = heading(0, side_z)
                rel = wrap(target - hd)
                look = (t, rng.uniform(2.5, 4.0), rel * rng.uniform(0.8, 0.95))
        w = 0.0
        if look is not None:
            t0, dur, rel = look
            u = (t - t0) / dur
            if u >= 1.0:
                look = None
                t_next_look = t + rng.uniform(5.0, 9.0)
            else:
                # ease in over the first 30%, hold, ease out over the last 30%
                w = _smooth(min(1.0, u / 0.3)) * _smooth(min(1.0, (1.0 - u) / 0.3))
                offset = rel * w
                pitch += -0.12 * w
        sway = 0.04 * math.sin(t * 0.9) * (1 - w)
        q = quat_yaw_pitch(hd + offset + sway, pitch)
        out.append((round(t, 10), x, EYE_HEIGHT, z, q))
        target_speed = WALK_SPEED * (1 - 0.6 * w)
        speed += (target_speed - speed) * 0.3
        s += speed * DT
    # the eye never enters an assembly's box (with a 0.3 m margin)
    for (t, x, y, z, q) in out:
        for (x0, z0, x1, z1) in boxes:
            if x0 - 0.3 < x < x1 + 0.3 and z0 - 0.3 < z < z1 + 0.3:
                sys.exit(f"internal error: the walk enters an assembly at t = {t}")
    return out


def _dist(a, b):
    return math.hypot(b[0] - a[0], b[1] - a[1])


def _smooth(u):
    u = min(max(u, 0.0), 1.0)
    return u * u * (3 - 2 * u)


def write_path(path, poses, note):
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write("# gigawalk camera path v1 (docs/path-format.md)\n")
        fh.write(f"# {note}\n")
        fh.write("# time_s x y z qx qy qz qw fovy_deg\n")
        for (t, x, y, z, q) in poses:
            fh.write(" ".join(repr(float(v)) for v in (t, x, y, z, *q, FOVY_DEG)) + "\n")
    os.replace(tmp, path)


# --------------------------------------------------------------------------

def parse_count(s):
    s = s.strip().lower().replace("_", "")
    mult = 1
    if s and s[-1] in "kmg":
        mult = {"k": 10 ** 3, "m": 10 ** 6, "g": 10 ** 9}[s[-1]]
        s = s[:-1]
    return int(float(s) * mult)


def parse_range(s):
    a, _, b = s.partition("-")
    a, b = int(a), int(b or a)
    if not 1 <= a <= b:
        raise argparse.ArgumentTypeError(f"bad range {s!r}")
    return a, b


def kicad_inputs(args, stats):
    """The engine and the KiCad component pool (the default assemblies)."""
    root = kicad_root(args.kicad_dir)
    missing = [lib for lib in ALL_LIBS if root is None or not os.path.isdir(os.path.join(root, lib + ".3dshapes"))]
    if missing and args.kicad_deb:
        extract_kicad(args.kicad_deb, args.kicad_dir, missing)
        root = kicad_root(args.kicad_dir)
    if root is None:
        sys.exit(f"no KiCad 3dmodels under {args.kicad_dir}: pass --kicad-deb (see benches/cad-floor.md)")
    if not os.path.exists(args.engine):
        sys.exit(f"{args.engine} not found (see benches/cad-floor.md)")

    t = time.time()
    engine = load_engine(args.engine)
    eng_tris = sum(m.tris for m, _ in engine[0])
    log(f"engine: {len(engine[0])} part instances of {len({id(m) for m, _ in engine[0]})} meshes, "
        f"{eng_tris} triangles, extent {np.round(engine[2] - engine[1], 1).tolist()} (source units, mm)"
        f" [{time.time() - t:.1f} s]")
    pool = None
    if args.cache:
        # keyed on the pool settings and the files (bump POOL_VERSION when
        # the parser or the pool selection changes)
        h = hashlib.sha256(repr((POOL_VERSION, CATEGORIES, MAX_PART_FOOTPRINT, MAX_PART_HEIGHT,
                                 KICAD_UNIT, args.per_lib)).encode())
        for lib in ALL_LIBS:
            d = os.path.join(root, lib + ".3dshapes")
            if os.path.isdir(d):
                for f in sorted(os.listdir(d)):
                    h.update(f"{lib}/{f}:{os.path.getsize(os.path.join(d, f))}".encode())
        cpath = os.path.join(args.cache, f"pool-{h.hexdigest()[:16]}.pickle")
        if os.path.exists(cpath):
            with open(cpath, "rb") as fh:
                pool, stats = pickle.load(fh)
            log(f"component pool read from {cpath}")
    if pool is None:
        pool = build_pool(root, args.per_lib, stats)
        if args.cache:
            os.makedirs(args.cache, exist_ok=True)
            with open(cpath + ".tmp", "wb") as fh:
                pickle.dump((pool, stats), fh)
            os.replace(cpath + ".tmp", cpath)
    if not pool:
        sys.exit("no usable KiCad models")
    pt = np.array([m.tris for _, m, _ in pool])
    log(f"component pool: {len(pool)} KiCad models from {len(ALL_LIBS) - len(stats['missing_libs'])} libraries, "
        f"{pt.min()}-{pt.max()} triangles (median {int(np.median(pt))}), "
        f"{stats['pool_parsed_mb']:.1f} MB of VRML parsed in {stats['pool_seconds']:.1f} s; "
        f"{stats['rejected_models']} models over the size/triangle limits left out")
    if stats["missing_libs"]:
        log(f"  warning: libraries not found: {', '.join(stats['missing_libs'])}")
    if stats["skipped"]:
        log("  VRML skips: " + ", ".join(f"{k}: {v}" for k, v in sorted(stats["skipped"].items())))
    for u in stats["unparsed_files"][:5]:
        log(f"  not parsed: {u}")
    return engine, pool


def load_models(d):
    """Every .glb/.gltf below d (sorted): (parts, lo, hi, label) each, the
    label its file's name without the extension."""
    files = sorted(os.path.join(r, f) for r, _, fs in os.walk(d) for f in fs
                   if f.lower().endswith((".glb", ".gltf")) and not f.startswith("."))
    if not files:
        sys.exit(f"no .glb or .gltf files under {d}")
    machines = []
    for f in files:
        label = os.path.splitext(os.path.basename(f))[0]
        parts, lo, hi = load_engine(f, prefix=label)
        if not parts:
            sys.exit(f"{f}: no triangles")
        tris = sum(m.tris for m, _ in parts)
        log(f"assembly {label}: {len(parts)} part instances, {tris} triangles, "
            f"extent {np.round(hi - lo, 3).tolist()}")
        machines.append((parts, lo, hi, label))
    return machines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("-o", "--output", required=True, help="output .glb")
    ap.add_argument("--triangles", type=parse_count, default=parse_count("10M"),
                    help="triangle budget of the (1x) scene; rows and blocks are chosen to come closest")
    ap.add_argument("--double", action="store_true",
                    help="the 2x variant: rows added behind the walked region until the triangles double")
    ap.add_argument("--times", type=float, default=None, metavar="F",
                    help="like --double, rows added behind until the triangles are closest to F times the 1x floor's")
    ap.add_argument("--extra-rows-behind", type=int, default=0, metavar="K",
                    help="add K rows behind the walked region (instead of --double)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--path", help="also write a camera path here (docs/path-format.md)")
    ap.add_argument("--poses", type=int, default=240, help="poses in the path (10 a second)")
    ap.add_argument("--engine", default="/work/cad/engine/" + ENGINE_FILE,
                    help="2CylinderEngine.gltf (with its 2CylinderEngine0.bin next to it)")
    ap.add_argument("--kicad-dir", default="/work/cad/kicad",
                    help="kicad-packages3d 3dmodels directory, or the directory it was extracted into")
    ap.add_argument("--kicad-deb", help="kicad-packages3d .deb: extract the needed libraries into --kicad-dir first if missing")
    ap.add_argument("--per-lib", type=int, default=12, help="component models taken from each KiCad library")
    ap.add_argument("--boards", type=parse_range, default=(6, 12), help="PCBs per cabinet, MIN-MAX")
    ap.add_argument("--parts", type=parse_range, default=(30, 200), help="components per PCB, MIN-MAX")
    ap.add_argument("--cabinet-share", type=float, default=0.6, help="fraction of assemblies that are cabinets")
    ap.add_argument("--summary", help="also write the summary as JSON here")
    ap.add_argument("--models", metavar="DIR",
                    help="machines from every .glb/.gltf below DIR (e.g. ../shared/models), "
                         "one picked at random per slot, instead of engines and KiCad cabinets")
    ap.add_argument("--cache", help="keep the parsed component pool in this directory (a pickle) for faster reruns")
    args = ap.parse_args()
    T0 = time.time()

    stats = {"skipped": {}, "missing_libs": [], "unparsed_files": [], "rejected_models": 0}
    if args.models:
        engine, pool = load_models(args.models), []
        args.cabinet_share = 0.0
    else:
        engine, pool = kicad_inputs(args, stats)

    b = Builder(args, pool, engine, stats)
    # ---- choose blocks per row (B) and rows (R1) for the budget -----------
    # Blocks are generated independently, so a floor is a choice of cells
    # (row, block, assemblies kept; 0 = all). A near-square floor, then the
    # last row trimmed from its far end to come closest to the budget.
    t = time.time()

    def block_tris(r, bb, k=0):
        blk = b.block(r, bb)
        return sum(a["triangles"] for a in (blk[:k] if k else blk))

    def fill_row(cells, tot, goal, r, nb):
        """Appends blocks of row r (then assemblies of one block) while the
        total comes closer to goal."""
        for bb in range(nb):
            bt = block_tris(r, bb)
            if tot + bt <= goal:
                cells.append((r, bb, 0))
                tot += bt
                continue
            best_k, best_err, cum = 0, goal - tot, 0
            for k, a in enumerate(b.block(r, bb)):
                cum += a["triangles"]
                if abs(goal - tot - cum) < best_err:
                    best_k, best_err = k + 1, abs(goal - tot - cum)
            if best_k:
                cells.append((r, bb, best_k))
                tot += block_tris(r, bb, best_k)
            break
        return cells, tot

    floor_tris = 2 * 16   # about; the floor is a few dozen quads
    goal1 = max(1, args.triangles - floor_tris)
    per_block = (block_tris(0, 0) + block_tris(0, 1)) / 2
    n_blocks = max(1.0, goal1 / per_block)
    # square floor: B * PITCH_X = R * PITCH_Z and B * R = n_blocks; at
    # least 3 blocks a row once there are 6 blocks, so that the walk has
    # interior cross aisles
    B = max(1, min(40, round(math.sqrt(n_blocks * PITCH_Z / PITCH_X))))
    if n_blocks >= 6:
        B = max(B, 3)
    def add_rows(cells, tot, goal, r):
        """Whole rows from row r on while they fit, then the last one
        trimmed; returns the cells, total and the number of rows used."""
        while tot < goal:
            rt = sum(block_tris(r, bb) for bb in range(B))
            if tot + rt <= goal:
                cells += [(r, bb, 0) for bb in range(B)]
                tot += rt
                r += 1
                continue
            cells, tot = fill_row(cells, tot, goal, r, B)
            if any(c[0] == r for c in cells):
                r += 1
            break
        return cells, tot, r

    cells, T1, R1 = add_rows([], 0, goal1, 0)
    if not cells:   # a budget below one assembly
        cells, T1, R1 = [(0, 0, 1)], block_tris(0, 0, 1), 1
    R = R1
    if args.double or args.times:
        # rows behind the 1x floor (its last row stays as it is) until the
        # triangles are closest to twice (--times F: F times) the 1x floor's
        cells, _, R = add_rows(cells, T1, (args.times or 2.0) * T1, R1)
    elif args.extra_rows_behind:
        cells += [(r, bb, 0) for r in range(R1, R1 + args.extra_rows_behind) for bb in range(B)]
        R += args.extra_rows_behind
    # Centre the 1x floor on the origin (f32 precision in the renderer); the
    # extra rows lie at +z.
    width = B * PITCH_X + AISLE
    depth1 = R1 * PITCH_Z + AISLE
    x0 = -width / 2 + AISLE
    z0 = -depth1 / 2 + AISLE
    assemblies, block_nodes = [], []
    for r, bb, k in cells:
        ox, oz = x0 + bb * PITCH_X, z0 + r * PITCH_Z
        blk = b.block(r, bb)
        blk = blk[:k] if k else blk
        for a in blk:
            bx0, bz0, bx1, bz1 = a["box"]
            assemblies.append(dict(a, box=(bx0 + ox, bz0 + oz, bx1 + ox, bz1 + oz), row=r))
        block_nodes.append(N(t=(ox, 0.0, oz), name=f"block.r{r}b{bb}", children=[a["node"] for a in blk]))
    layout_s = time.time() - t

    # ---- floor ------------------------------------------------------------
    x_lo, x_hi = x0 - AISLE - FLOOR_MARGIN, x0 - AISLE + width + FLOOR_MARGIN
    z_lo, z_hi = z0 - AISLE - FLOOR_MARGIN, z0 - AISLE + R * PITCH_Z + AISLE + FLOOR_MARGIN
    floor = []
    i0, i1 = math.floor(x_lo / FLOOR_TILE), math.ceil(x_hi / FLOOR_TILE)
    k0, k1 = math.floor(z_lo / FLOOR_TILE), math.ceil(z_hi / FLOOR_TILE)
    for i in range(i0, i1):
        for k in range(k0, k1):
            floor.append(N(b.floor_quad, t=((i + 0.5) * FLOOR_TILE, 0.0, (k + 0.5) * FLOOR_TILE),
                           s=(FLOOR_TILE, 1.0, FLOOR_TILE)))
    floor_node = N(name="floor", children=floor)
    x_lo, x_hi, z_lo, z_hi = i0 * FLOOR_TILE, i1 * FLOOR_TILE, k0 * FLOOR_TILE, k1 * FLOOR_TILE

    # ---- totals -------------------------------------------------------------
    kinds = {}
    for a in assemblies:
        k = kinds.setdefault(a["kind"], {"count": 0, "triangles": 0, "objects": 0, "parts": []})
        k["count"] += 1
        k["triangles"] += a["triangles"]
        k["objects"] += a["objects"]
        k["parts"].append(a["parts"])
    ftris, fobjs = count(floor_node)
    total_tris = sum(a["triangles"] for a in assemblies) + ftris
    total_objs = sum(a["objects"] for a in assemblies) + fobjs

    # ---- write ----------------------------------------------------------------
    t = time.time()
    w = GlbWriter()
    roots = [w.node(floor_node)]
    roots += [w.node(n) for n in block_nodes]
    instances = sum(1 for n in w.nodes if "mesh" in n)
    top = max(a["top"] for a in assemblies)
    extras = {"seed": args.seed, "triangles": int(total_tris), "rows": R, "rows_walked_region": R1,
              "blocks_per_row": B, "assemblies": len(assemblies)}
    size, js_len, bin_len = w.write(args.output, roots, extras)
    write_s = time.time() - t

    # ---- path -------------------------------------------------------------------
    walk_note = ""
    if args.path:
        xs_all = [x0 - AISLE / 2 + i * PITCH_X for i in range(B + 1)]
        zs_all = [z0 - AISLE / 2 + j * PITCH_Z for j in range(R1 + 1)]
        # The walked grid: the interior aisles of the 1x floor (machines on
        # both sides; row aisles only between two complete rows), the outer
        # ones only on floors too small to have two interior aisles each
        # way. The last row aisle is never walked: the extra rows of the 2x
        # variant lie behind it.
        full = sum(1 for r in range(R1)
                   if sum(1 for c in cells if c[0] == r and c[2] == 0) == B)
        xs = xs_all[1:-1] if B >= 3 else xs_all
        if full >= 3:
            zs = zs_all[1:full]          # aisles between two full rows
        elif R1 >= 2:
            zs = zs_all[:R1]
        else:
            zs = zs_all
        # the assemblies of the 1x floor: the path does not depend on --double
        boxes = [a["box"] for a in assemblies if a["row"] < R1]
        poses = make_walk(xs, zs, args.seed, args.poses, boxes)
        write_path(args.path, poses,
                   f"cad-floor.py --seed {args.seed} --triangles {args.triangles}: "
                   f"{len(poses)} poses, walks the aisles of the 1x floor")
        walk_note = f"path: {args.path}: {len(poses)} poses, {len(poses) * DT:.1f} s walk"

    # ---- summary ------------------------------------------------------------------
    distinct = len(w.meshes)
    kicad_used = sum(1 for m in w.meshes if m["name"].startswith("kicad/"))
    lo3 = [x_lo, 0.0, z_lo]
    hi3 = [x_hi, top, z_hi]
    log(f"layout: {R} rows x {B} blocks ({R1} rows in the walked 1x region; last rows may be trimmed), "
        f"rows along x with {AISLE:g} m aisles, floor {x_hi - x_lo:.1f} x {z_hi - z_lo:.1f} m")
    for kname, k in sorted(kinds.items()):
        p = np.array(k["parts"])
        log(f"  {kname}s: {k['count']}, {k['triangles']} triangles ({k['triangles'] / k['count']:.0f} each), "
            f"{k['objects']} objects ({k['objects'] / k['count']:.0f} each); "
            f"parts per assembly {p.min()}-{p.max()} (mean {p.mean():.0f})")
    cabs = [a for a in assemblies if a["kind"] == "cabinet"]
    if cabs:
        log(f"  cabinets: {sum(a['boards'] for a in cabs)} PCBs ({sum(1 for a in cabs if a['vertical'])} "
            f"card-cage cabinets, {sum(1 for a in cabs if not a['vertical'])} shelf cabinets)")
    eng_used = sum(1 for m in w.meshes if m["name"].startswith("2CylinderEngine/"))
    box_used = sum(1 for m in w.meshes if "/" not in m["name"])
    log(f"assemblies: {len(assemblies)}; distinct meshes: {distinct} ({kicad_used} KiCad, "
        f"{eng_used} engine, {distinct - kicad_used - eng_used - box_used} of --models, {box_used} boxes); "
        f"nodes: {len(w.nodes)}; instances (mesh nodes): {instances}; objects after expansion: {total_objs}")
    log(f"triangles after instance expansion: {total_tris}")
    log(f"bounds: min {np.round(lo3, 2).tolist()} max {np.round(hi3, 2).tolist()} (m)")
    log(f"output: {args.output}: {size} bytes (JSON {js_len}, BIN {bin_len})")
    if walk_note:
        log(walk_note)
    log(f"timing: layout {layout_s:.1f} s, write {write_s:.1f} s, total {time.time() - T0:.1f} s")
    if args.summary:
        summ = {"output": args.output, "bytes": size, "triangles": int(total_tris),
                "objects": int(total_objs), "instances": instances, "distinct_meshes": distinct,
                "nodes": len(w.nodes), "rows": R, "rows_walked_region": R1, "blocks_per_row": B,
                "kinds": {k: {kk: vv for kk, vv in v.items() if kk != "parts"} for k, v in kinds.items()},
                "bounds": [lo3, hi3], "seed": args.seed, "vrml_skips": stats["skipped"],
                "pool_models": len(pool)}
        with open(args.summary, "w") as fh:
            json.dump(summ, fh, indent=1)


if __name__ == "__main__":
    main()
