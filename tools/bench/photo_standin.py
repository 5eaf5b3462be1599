#!/usr/bin/env python3
"""Make the 12-megapixel photo stand-in of docs/benchmarks.md (issue 53) from the Realsee3D sample.

The three.js `kandao3` pair (a 4880 x 2440 photo with an 8-bit nearness map at 1024 x 512) is the
issue's input; where it cannot be fetched, this makes one of the same shape: the Realsee3D sample's
colour (`assets/panoImage_real.jpg` of github:realsee-developer/RealSee3D) resized to 4880 x 2440, its
LiDAR depth (`assets/depth_image.png`, 16-bit, 2 mm units, 71 % unknown; holes take the nearest
known value) as an 8-bit nearness JPEG at 1024 x 512 for `--depth-kind nearness --depth-range 1,8`.
Third-party images stay under target/.

usage: photo_standin.py RGB.jpg DEPTH.png OUT_DIR
then:  pomc prepare --colour OUT_DIR/colour.jpg --depth OUT_DIR/nearness.jpg --depth-kind nearness \\
           --depth-range 1,8 -o OUT_DIR/prepared.exr   (so that builds that read no nearness can run it)
"""
import os
import sys

import numpy as np
from PIL import Image
from scipy import ndimage


def main() -> None:
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rgb, depth, out = sys.argv[1:]
    os.makedirs(out, exist_ok=True)
    Image.open(rgb).convert("RGB").resize((4880, 2440), Image.BICUBIC).save(
        os.path.join(out, "colour.jpg"), quality=92)
    d = np.asarray(Image.open(depth)).astype(np.float64)
    known = d > 0
    idx = ndimage.distance_transform_edt(~known, return_distances=False, return_indices=True)
    metres = (d[idx[0], idx[1]] * 0.002).astype(np.float32)
    metres = np.asarray(Image.fromarray(metres).resize((1024, 512), Image.BILINEAR))
    # Nearness: 1 at 1 m, 0 at 8 m, linear in distance (three.js).
    v = np.clip((8.0 - metres) / 7.0, 0.0, 1.0)
    Image.fromarray((v * 255 + 0.5).astype(np.uint8)).save(os.path.join(out, "nearness.jpg"), quality=90)


if __name__ == "__main__":
    main()
