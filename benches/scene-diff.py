#!/usr/bin/env python3
"""Which sections of two scene files differ (docs/scene-format.md).

    python3 benches/scene-diff.py a.gwk b.gwk

Prints one line per section tag: identical, or differing (with both
lengths). An OBJT section whose bytes differ is also compared after
decompression (its body, zstd frames, through the zstd command), since
the same object table may be compressed differently. Exits 0 when every
section is identical, or differs only in how OBJT is compressed; 1
otherwise.
"""
import struct
import subprocess
import sys


def sections(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"GIGAWALK":
        sys.exit(f"{path}: not a gigawalk scene file")
    count, toc = struct.unpack_from("<IQ", data, 12)
    out = {}
    for i in range(count):
        tag, _flags, off, length = struct.unpack_from("<4sIQQ", data, toc + 32 * i)
        out[tag.decode("ascii", "replace")] = data[off : off + length]
    return out


def objt_body(section):
    _version, _count, _lods, compressed, body_len = struct.unpack_from("<IIIIQ", section)
    stored = section[24:]
    if compressed == 0:
        return stored
    body = subprocess.run(
        ["zstd", "-d", "-c"], input=stored, capture_output=True, check=True
    ).stdout
    if len(body) != body_len:
        sys.exit(f"OBJT body is {len(body)} bytes, the section says {body_len}")
    return section[:12] + body


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = (sections(p) for p in sys.argv[1:])
    same = True
    for tag in sorted(set(a) | set(b)):
        x, y = a.get(tag), b.get(tag)
        if x == y:
            print(f"{tag}: identical ({len(x)} bytes)")
        elif x is not None and y is not None and tag == "OBJT" and objt_body(x) == objt_body(y):
            print(f"{tag}: the same table, compressed differently ({len(x)} and {len(y)} bytes)")
        else:
            same = False
            print(f"{tag}: differs ({'absent' if x is None else len(x)} and {'absent' if y is None else len(y)} bytes)")
    sys.exit(0 if same else 1)


main()
