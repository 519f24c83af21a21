"""A revolved knob: a diamond knurl on its cone and ridges on its top, in one call.

Run it as a plain script:  python recipes/knob.py
It writes knob.stl, knob.3mf (texture as its own object), knob.png and knob.json (the
distortion figures) into $TEXCAD_OUT (default ./out). $TEXCAD_PITCH sets the pixel
pitch in mm (default 0.125); the tests run it coarser.

The cone is a face of revolution: texture x follows the meridian's arc length, y runs
around with a whole number of knurl periods per ring, so the knurl is stretched by
r / R_ref where the radius is r (the figures printed). The top is planar (exact).

Printed standing on its skirt (BUILD_DIR +z): the knurl on the cone is limited so
that no facet overhangs (slicer threshold 45 degrees, the critical angle); the 3MF
stands it so.
"""

import json
import os
import time
from pathlib import Path

from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Plane, Polyline, make_face, revolve

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
BUILD_DIR = (0, 0, 1)  # print orientation: standing on its skirt, top up

# The knob (mm): a 30 mm skirt, a 12 mm tall knurled cone, a chamfer and a flat top,
# with a 6 mm bore through it.
with BuildPart() as knob:
    with BuildSketch(Plane.XZ):
        with BuildLine():
            Polyline((3, 0), (15, 0), (15, 2), (12.5, 14), (11, 15.5), (3, 15.5), close=True)
        make_face()
    revolve(axis=Axis.Z)

cone = knob.part.faces().filter_by(GeomType.CONE).sort_by(Axis.Z)[0]  # the grip, not the chamfer
top = knob.part.faces().sort_by(Axis.Z)[-1]

t0 = time.perf_counter()
part = texcad.texture(knob.part, [cone, top], "builtin:diamond_knurl:period=2", height=0.6, pitch=PITCH, build_dir=BUILD_DIR)
t1 = time.perf_counter()
part.export(OUT / "knob.stl")
part.export(OUT / "knob.3mf", separate_texture=True)
part.render(OUT / "knob.png", width=900)
m = part.mesh
figures = {"distortion": part.distortion.to_dict(), "faces": part.info["faces"], "volume": m.volume, "triangles": m.num_triangles}
(OUT / "knob.json").write_text(json.dumps(figures, indent=1, default=str))
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
print(f"distortion   {part.distortion}")
print(f"seconds      texture {t1 - t0:.1f}")
