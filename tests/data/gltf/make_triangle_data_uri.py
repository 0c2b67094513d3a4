#!/usr/bin/env python3
"""Writes triangle_data_uri.gltf: a JSON glTF whose buffer and image are data URIs.

It exercises the JSON path of load_gltf: an interleaved bufferView (byteStride 16: float POSITION
+ normalized UNSIGNED_BYTE COLOR_0), UNSIGNED_SHORT indices, no NORMAL (computed on load), a
node matrix, no "scenes" (roots = parentless nodes) and a 2x2 RGB PNG (expanded to RGBA8).
"""
import base64, json, struct, zlib

def png_rgb(w, h, rows):
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    raw = b"".join(b"\0" + bytes(r) for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

verts = [((0, 0, 0), (255, 0, 0, 255)), ((1, 0, 0), (0, 128, 0, 255)), ((0, 1, 0), (0, 0, 255, 51))]
buf = b"".join(struct.pack("<3f4B", *p, *c) for p, c in verts)
buf += struct.pack("<3H", 0, 1, 2) + b"\0\0"
png = png_rgb(2, 2, [[255, 0, 0, 0, 255, 0], [0, 0, 255, 10, 20, 30]])
doc = {
    "asset": {"version": "2.0", "generator": "make_triangle_data_uri.py"},
    "buffers": [{"byteLength": len(buf),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48, "byteStride": 16, "target": 34962},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 6, "target": 34963}],
    "accessors": [
        {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3",
         "min": [0, 0, 0], "max": [1, 1, 0]},
        {"bufferView": 0, "byteOffset": 12, "componentType": 5121, "normalized": True, "count": 3,
         "type": "VEC4"},
        {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(png).decode()}],
    "textures": [{"source": 0, "name": "checker"}],
    "materials": [{"name": "painted", "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "baseColorTexture": {"index": 0}}}],
    "meshes": [{"name": "tri", "primitives": [
        {"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2, "material": 0}]}],
    "nodes": [{"name": "tri", "mesh": 0,
               "matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1]},
              {"name": "empty"}],
}
with open(__file__.replace("make_triangle_data_uri.py", "triangle_data_uri.gltf"), "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
