"""Reference figures for gigawalk-ifc's tests, from IfcOpenShell.

For each IFC file in the models folder this writes `<file stem>.json`
beside this script: per product with geometry (by GlobalId) its class, its
world bounding box in metres, its triangle count and enclosed volume, as IfcOpenShell's
geometry iterator tessellates it (openings subtracted, IfcSpace and
IfcOpeningElement left out, as gigawalk leaves them out).

How the committed figures were made:

    python3 -m venv /tmp/ifcvenv && /tmp/ifcvenv/bin/pip install ifcopenshell
    /tmp/ifcvenv/bin/python crates/ifc/tests/reference/make_reference.py \
        ../shared/models/ifc

(IfcOpenShell 0.9.0.post1.)
"""

import json
import multiprocessing
import os
import sys

import ifcopenshell
import ifcopenshell.geom


def volume(verts, faces):
    """The enclosed volume by the divergence theorem (m³; meaningful for
    closed, outward meshes)."""
    v = 0.0
    for i in range(0, len(faces), 3):
        a, b, c = (verts[3 * faces[i + k] : 3 * faces[i + k] + 3] for k in range(3))
        v += (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        ) / 6.0
    return v


def reference(path):
    f = ifcopenshell.open(path)
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    it = ifcopenshell.geom.iterator(settings, f, multiprocessing.cpu_count())
    products = {}
    if it.initialize():
        while True:
            shape = it.get()
            verts = shape.geometry.verts
            faces = shape.geometry.faces
            el = f.by_guid(shape.guid)
            # Room volumes and the voids cut from walls are not drawn.
            skip = el.is_a("IfcSpace") or el.is_a("IfcOpeningElement")
            if len(faces) > 0 and not skip:
                xs, ys, zs = verts[0::3], verts[1::3], verts[2::3]
                products[shape.guid] = {
                    "class": el.is_a(),
                    "min": [min(xs), min(ys), min(zs)],
                    "max": [max(xs), max(ys), max(zs)],
                    "triangles": len(faces) // 3,
                    "volume": volume(verts, faces),
                }
            if not it.next():
                break
    return {
        "file": os.path.basename(path),
        "schema": f.schema,
        "ifcopenshell": ifcopenshell.version,
        "products": dict(sorted(products.items())),
        "triangles": sum(p["triangles"] for p in products.values()),
    }


def main():
    folder = sys.argv[1]
    out = os.path.dirname(os.path.abspath(__file__))
    for name in sorted(os.listdir(folder)):
        if not name.lower().endswith(".ifc"):
            continue
        ref = reference(os.path.join(folder, name))
        stem = os.path.splitext(name)[0]
        with open(os.path.join(out, stem + ".json"), "w") as w:
            json.dump(ref, w, indent=1, sort_keys=True)
            w.write("\n")
        print(f"{name}: {len(ref['products'])} products, {ref['triangles']} triangles")


if __name__ == "__main__":
    main()
