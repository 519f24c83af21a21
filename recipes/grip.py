"""A lofted ergonomic grip: leather grain on a B-spline face, all the way round.

Run it as a plain script:  python recipes/grip.py
Writes grip.stl, .3mf, .png and .json (distortion figures) into $TEXCAD_OUT (default
./out); $TEXCAD_PITCH sets the pitch in mm (default 0.125).

The grip's side is one B-spline face (a loft through four ellipses). Its own (u, v)
parameters, corrected by its metric (mean arc length along each direction), are the
texture coordinates in mm; u closes around, so a whole number of tiles fits per ring.

Printed standing on its wide end (BUILD_DIR +z): the texture is limited so that no
facet overhangs there (slicer threshold 45 degrees, the critical angle), and the 3MF
stands it on the bed that way.
"""

import json
import os
import time
from pathlib import Path

from build123d import BuildPart, BuildSketch, Ellipse, GeomType, Plane, loft

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
BUILD_DIR = (0, 0, 1)  # print orientation: standing on its z = 0 end

# The grip (mm): 90 mm long, through ellipses 24 x 18, 30 x 22, 26 x 20 and 22 x 16.
with BuildPart() as grip:
    for z, (a, b) in zip((0, 30, 60, 90), ((12, 9), (15, 11), (13, 10), (11, 8))):  # one section per station
        with BuildSketch(Plane.XY.offset(z)):
            Ellipse(a, b)
    loft()

side = grip.part.faces().filter_by(GeomType.BSPLINE)

t0 = time.perf_counter()
part = texcad.texture(grip.part, side, "builtin:leather", height=0.6, pitch=PITCH, build_dir=BUILD_DIR)
t1 = time.perf_counter()
part.export(OUT / "grip.stl")
part.export(OUT / "grip.3mf", separate_texture=True)
part.render(OUT / "grip.png", width=600)
m = part.mesh
figures = {"distortion": part.distortion.to_dict(), "faces": part.info["faces"], "volume": m.volume}
(OUT / "grip.json").write_text(json.dumps(figures, indent=1, default=str))
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
print(f"distortion   {part.distortion}")
print(f"seconds      texture {t1 - t0:.1f}")
