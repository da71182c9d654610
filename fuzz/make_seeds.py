#!/usr/bin/env python3
"""Writes the hand-made seed inputs of corpus/fuzz/<target>/ (deterministic).

Run from the repository root: python3 fuzz/make_seeds.py. Inputs found by campaigns are
merged into the same folders by tools/fuzz-campaign.sh; this script only (re)writes the
files named seed-*. Structure-aware targets get inputs whose decoder choices cover every
mode of lib/scene/byte_decoder.h (the mode is the last byte's value mod 12)."""
import os
import random
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "corpus", "fuzz")
MODES = 12  # lib/scene/byte_decoder.cpp decoder_modes()


def put(target, name, data):
    # A seed that was moved to open/<target>/ (it triggers an open finding) stays there.
    for sub in ("", "asan"):
        if os.path.exists(os.path.join(ROOT, "open", target, sub, "seed-" + name)):
            return
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, "seed-" + name), "wb") as f:
        f.write(data)


def decoder_seeds(target, selector):
    rng = random.Random(20261122)
    for k in range(3 * MODES):
        mode = k % MODES
        body = bytearray(rng.randrange(256) for _ in range(rng.randrange(24, 160)))
        body[-1] = mode  # first choice consumed: the mode
        prefix = struct.pack("<I", rng.randrange(1 << 32)) if selector else b""
        put(target, "mode%02d-%d" % (mode, k // MODES), prefix + bytes(body))


def scene_json_seeds():
    t = "fuzz_scene_json"
    put(t, "inline", """{"format":"visgate-scene","version":1,"name":"tiny",
"meshes":[{"vertices":[[0,0,1],[1,0,1],[0,1,1]],"triangles":[[0,1,2]]}],
"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]],"samples":4,"pattern":"stratified","jitter":4,"seed":1}],
"receivers":[{"p":[0.25,0.25,0],"n":[0,0,1]},{"p":[2,2,0],"n":[0,0,1]}]}
""")
    put(t, "hex-grid", """{"format":"visgate-scene","version":1,"name":"hex",
"meshes":[{"vertices":[["0x1p-1","0x0p+0","0x1.8p+0"],["0x1p+0","-0x1p-149","0x1.8p+0"],["0x0p+0","0x1p+0","0x1.8p+0"]],
"triangles":[[0,1,2]]}],
"lights":[{"polygon":[["-0x1p-1","-0x1p-1","0x1p+1"],["-0x1p-1","0x1p-1","0x1p+1"],["0x1p-1","0x1p-1","0x1p+1"],["0x1p-1","-0x1p-1","0x1p+1"]],
"samples":3,"pattern":"random","jitter":2,"seed":18446744073709551615}],
"receivers":{"grid":{"origin":[-1,-1,0],"u":[2,0,0],"v":[0,2,0],"nu":3,"nv":2,"normal":[0,0,1],"offset":"1e-4"}}}
""")
    put(t, "explicit", """{"format":"visgate-scene","version":1,"name":"explicit",
"meshes":[{"vertices":[[0,0,1],[1,0,1],[0,1,1],[0,0,1.5],[1,1,1.5],[0,1,1.5]],"triangles":[[0,1,2],[3,4,5]]}],
"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]],"samples":2,"jitter":1,"pattern":"explicit",
"explicit_samples":[[0,0,2],[0.5,0.5,2]]},
{"polygon":[[0,0,3],[0,1,3],[1,0,3]],"samples":2,"pattern":"grid","jitter":1}],
"receivers":[{"p":[0,0,0]}]}
""")
    put(t, "decimal9", """{"format":"visgate-scene","version":1,"name":"d",
"meshes":[{"vertices":[[0.100000001,1e-45,3.40282347e+38],[1.17549435e-38,-0,2],[0,1,2]],"triangles":[[0,1,2]]}],
"lights":[{"polygon":[[-1,-1,4],[-1,1,4],[1,1,4],[1,-1,4]],"samples":1}],"receivers":[{"p":[0,0,0],"n":[0,0,1]}]}
""")
    put(t, "bad-nan", """{"format":"visgate-scene","version":1,"meshes":[{"vertices":[["nan",0,0],[1,0,0],[0,1,0]],"triangles":[[0,1,2]]}],
"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]]}],"receivers":[{"p":[0,0,0]}]}
""")
    put(t, "bad-index", """{"format":"visgate-scene","version":1,"meshes":[{"vertices":[[0,0,1]],"triangles":[[0,1,-2]]}],
"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]]}],"receivers":[]}
""")
    put(t, "bad-light", """{"format":"visgate-scene","version":1,"lights":[{"polygon":[[0,0,2],[1,1,2],[2,2,2]],"samples":0}],
"receivers":{"grid":{"origin":[0,0,0],"u":[1,0,0],"v":[0,1,0],"nu":0,"nv":1}}}
""")
    put(t, "mesh-file", """{"format":"visgate-scene","version":1,"meshes":[{"file":"missing.obj"}],
"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]]}],"receivers":[{"p":[0,0,0]}]}
""")
    put(t, "truncated", """{"format":"visgate-scene","version":1,"meshes":[{"vertices":[[0,0,1],[1,0""")


def mesh_seeds():
    t = "fuzz_mesh_files"
    # First byte: extension (value mod 4: 0 .obj, 1 .off, 2 .ply, 3 .stl).
    put(t, "obj", b"\x00" + b"""# tiny
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0.5
vn 0 0 1
vt 0 0
f 1/1/1 2/1/1 3/1/1
f 2 4 3
f -1 -2 -3
""")
    put(t, "obj-quad", b"\x00" + b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl 1 2\n")
    put(t, "off", b"\x01" + b"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n3 0 1 2\n3 1 3 2\n")
    put(t, "coff", b"\x01" + b"COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2\n")
    put(t, "ply-ascii", b"\x02" + b"""ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
0 1 0
3 0 1 2
""")
    verts = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    face = struct.pack("<B3i", 3, 0, 1, 2)
    put(t, "ply-binary", b"\x02" + b"""ply
format binary_little_endian 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
""" + verts + face)
    put(t, "stl-ascii", b"\x03" + b"""solid t
facet normal 0 0 1
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 1 0
 endloop
endfacet
endsolid t
""")
    tri = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
    put(t, "stl-binary", b"\x03" + b"binary stl header".ljust(80, b" ") + struct.pack("<I", 2) + tri + tri)


def main():
    for t in ("fuzz_iss", "fuzz_ssv", "fuzz_plucker", "fuzz_embree"):
        decoder_seeds(t, True)
    decoder_seeds("fuzz_prepare", False)
    scene_json_seeds()
    mesh_seeds()


if __name__ == "__main__":
    main()
