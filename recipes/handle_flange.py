"""A handle with a flange: a diamond-knurl grip on the handle's cylindrical face.

Run it as a plain script:  python recipes/handle_flange.py
It writes handle_flange.stl, .3mf (texture as its own object), .step (B-rep: the
knurl is a B-spline face sewn to the part's own faces) and .png into $TEXCAD_OUT
(default ./out). $TEXCAD_PITCH sets the pixel pitch in mm (default 0.25: one mesh
vertex and one B-spline pole per 0.25 mm); the tests run it coarser.

Printed standing on its flange (BUILD_DIR +z): the knurl is limited so that no facet
overhangs (slicer threshold 45 degrees, the critical angle); the 3MF stands it so.
"""

import os
import time
import warnings
from pathlib import Path

from build123d import Axis, BuildPart, BuildSketch, Circle, GeomType, Hole, Locations, PolarLocations, SortBy, extrude, fillet

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.25"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
BUILD_DIR = (0, 0, 1)  # print orientation: standing on the flange

# The part (mm): a 70 mm flange, 8 mm thick, with four bolt holes, and a 24 mm
# handle standing 80 mm on it with a rounded end.
with BuildPart() as handle:
    with BuildSketch():
        Circle(35)
    extrude(amount=8)
    with Locations((0, 0, 8)):
        with PolarLocations(26, 4):
            Hole(3.3)
    with BuildSketch(handle.faces().sort_by(Axis.Z)[-1]):
        Circle(12)
    extrude(amount=80)
    fillet(handle.edges().sort_by(Axis.Z)[-1], radius=3)

# The grip face, chosen with selectors: the largest cylindrical face (the handle).
grip = handle.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]

t0 = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore", texcad.TexcadWarning)  # the knurl is stretched to close around
    part = texcad.texture(handle, grip, "builtin:diamond_knurl:period=3", height=0.8, pitch=PITCH, mapping="angle", build_dir=BUILD_DIR)
t1 = time.perf_counter()

part.export(OUT / "handle_flange.stl")
part.export(OUT / "handle_flange.3mf", separate_texture=True)
part.export(OUT / "handle_flange.step")
t2 = time.perf_counter()
part.render(OUT / "handle_flange.png", width=900, view=(-1.0, 1.6, -0.9))
t3 = time.perf_counter()

m = part.mesh
print(f"grid         {part.info['grid'][0]} x {part.info['grid'][1]} poles, pitch {PITCH:g} mm")
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
print(f"volume       mesh {m.volume:.1f} mm3, B-rep {part.info['brep_volume']:.1f} mm3")
print(f"seconds      texture {t1 - t0:.1f}, write STL+3MF+STEP {t2 - t1:.1f}, render {t3 - t2:.1f}")
for suffix in ("stl", "3mf", "step", "png"):
    f = OUT / f"handle_flange.{suffix}"
    print(f"wrote        {f} ({f.stat().st_size / 1e6:.1f} MB)")
