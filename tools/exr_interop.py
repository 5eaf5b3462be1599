#!/usr/bin/env python3
"""Bit-exact EXR interoperability checks against the OpenEXR C++ library (through its Python
binding), driven by tests/it/exr_interop.rs.

A *dump directory* holds `channels.txt` (one line per channel: `name type width height`, type
one of half/float/uint) and, per channel, `<name>.bin`: the samples' raw little-endian bits,
row-major.

    exr_interop.py read  FILE.exr DUMP_DIR               # OpenEXR reads FILE, compares with DUMP_DIR
    exr_interop.py write FILE.exr DUMP_DIR COMPRESSION [tiled]  # OpenEXR writes DUMP_DIR as FILE

Exit status 0 when all is well, 1 on any mismatch (details on stderr), 3 when the OpenEXR or
numpy packages are missing (install them with `pip install -r tools/requirements-test.txt`).
"""
import os
import sys

try:
    import numpy as np
    import OpenEXR
except ImportError as e:  # pragma: no cover
    print(f"missing Python package: {e}; run `pip install -r tools/requirements-test.txt`", file=sys.stderr)
    sys.exit(3)

DTYPES = {"half": (np.float16, np.uint16), "float": (np.float32, np.uint32), "uint": (np.uint32, np.uint32)}
COMPRESSIONS = {
    "none": OpenEXR.NO_COMPRESSION,
    "rle": OpenEXR.RLE_COMPRESSION,
    "zips": OpenEXR.ZIPS_COMPRESSION,
    "zip": OpenEXR.ZIP_COMPRESSION,
    "piz": OpenEXR.PIZ_COMPRESSION,
}


def load_dump(d):
    chans = {}
    with open(os.path.join(d, "channels.txt")) as f:
        for line in f:
            if not line.strip():
                continue
            name, typ, w, h = line.split()
            value_t, bits_t = DTYPES[typ]
            raw = np.fromfile(os.path.join(d, name + ".bin"), dtype=np.dtype(bits_t).newbyteorder("<"))
            chans[name] = (typ, raw.astype(bits_t).reshape(int(h), int(w)).view(value_t))
    return chans


def type_of(arr):
    for typ, (value_t, _) in DTYPES.items():
        if arr.dtype == value_t:
            return typ
    return str(arr.dtype)


def read(path, d):
    expected = load_dump(d)
    f = OpenEXR.File(path, separate_channels=True)
    got = {name: c.pixels for name, c in f.channels().items()}
    ok = True
    if sorted(got) != sorted(expected):
        print(f"channels differ: file {sorted(got)} vs expected {sorted(expected)}", file=sys.stderr)
        return 1
    for name, (typ, want) in expected.items():
        have = got[name]
        if type_of(have) != typ or have.shape != want.shape:
            print(f"{name}: {type_of(have)} {have.shape} vs expected {typ} {want.shape}", file=sys.stderr)
            ok = False
            continue
        bits_t = DTYPES[typ][1]
        diff = np.nonzero(have.view(bits_t) != want.view(bits_t))
        if len(diff[0]):
            y, x = diff[0][0], diff[1][0]
            print(f"{name}: {len(diff[0])} samples differ, first at ({x},{y}): "
                  f"{have.view(bits_t)[y, x]:#x} vs {want.view(bits_t)[y, x]:#x}", file=sys.stderr)
            ok = False
    return 0 if ok else 1


def write(path, d, compression, tiled):
    chans = {name: arr for name, (_, arr) in load_dump(d).items()}
    header = {"compression": COMPRESSIONS[compression], "type": OpenEXR.scanlineimage}
    if tiled:
        header["type"] = OpenEXR.tiledimage
        tiles = OpenEXR.TileDescription()
        tiles.xSize, tiles.ySize, tiles.mode = 16, 16, OpenEXR.ONE_LEVEL
        header["tiles"] = tiles
    OpenEXR.File(header, chans).write(path)
    return 0


def main(argv):
    if len(argv) >= 3 and argv[0] == "read":
        return read(argv[1], argv[2])
    if len(argv) >= 4 and argv[0] == "write":
        return write(argv[1], argv[2], argv[3], len(argv) > 4 and argv[4] == "tiled")
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
