"""Beyond the paper: a heat-sink base plate with a pin-fin texture, in a few lines.

The pins (paper, section 2: textures for heat transfer) grow straight up from the
plate's top face; the face has four mounting holes and rounded corners, and the
texture is clipped to it with M-I ramps (45 deg) along its outline, so the part
prints flat on the bed without any support (BUILD_DIR +z: the limiter finds nothing
to change, and the 3MF lies that way).

Run it as a plain script:  python recipes/heat_sink.py
It writes heat_sink.stl, .3mf (pins as their own object), .step and .png into
$TEXCAD_OUT (default ./out). $TEXCAD_TOLERANCE the lean mesh's height error in mm
(default texcad's, 0.02; 0 = one vertex per pixel). $TEXCAD_PITCH sets the pixel pitch in mm (default 0.1);
the tests run it coarser.
"""

import json
import os
import time
from pathlib import Path

from build123d import Axis, BuildPart, BuildSketch, GridLocations, Hole, Locations, Rectangle, extrude, fillet

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.1"))  # mm per pixel
LEAN = {"tolerance": float(os.environ["TEXCAD_TOLERANCE"])} if "TEXCAD_TOLERANCE" in os.environ else {}
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
BUILD_DIR = (0, 0, 1)  # print orientation: base on the bed, pins up (nothing overhangs)

# The base (mm): 60 x 60 x 4, rounded corners, four M3 clearance holes.
with BuildPart() as sink:
    with BuildSketch():
        Rectangle(60, 60)
    extrude(amount=4)
    fillet(sink.edges().filter_by(Axis.Z), radius=6)
    with Locations((0, 0, 4)):
        with GridLocations(48, 48, 2, 2):
            Hole(1.7)

t0 = time.perf_counter()
top = sink.faces().sort_by(Axis.Z)[-1]
part = texcad.texture(sink, top, "builtin:pins:period=3,diameter=1.4", height=4.0, pitch=PITCH, build_dir=BUILD_DIR, **LEAN)
t1 = time.perf_counter()

report = texcad.check(part.mesh, build_dir=BUILD_DIR)
part.export(OUT / "heat_sink.stl")
part.export(OUT / "heat_sink.3mf", separate_texture=True)
part.export(OUT / "heat_sink.step")
t2 = time.perf_counter()
part.render(OUT / "heat_sink.png", width=900, view=(-1.0, 1.4, -1.1))

base_area = top.area
m = part.mesh
figures = {
    "pitch_mm": PITCH,
    "triangles": m.num_triangles,
    "watertight": bool(m.is_watertight),
    "volume_mm3": m.volume,
    "wetted_area_mm2": m.area,
    "flat_area_mm2": part.base_mesh.area,
    "overhang_mm2": report.overhang_area_mm2,
    "step_mb": (OUT / "heat_sink.step").stat().st_size / 1e6,
    "seconds": {"texture": t1 - t0, "check_and_write": t2 - t1},
}
(OUT / "heat_sink.json").write_text(json.dumps(figures, indent=2))
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}, volume {m.volume:.1f} mm3")
print(f"surface      {m.area:.0f} mm2 with pins, {figures['flat_area_mm2']:.0f} mm2 without ({m.area / figures['flat_area_mm2']:.2f}x)")
print(f"printing     flat (+z): overhang {report.overhang_area_mm2:.2f} mm2")
print(f"seconds      texture {t1 - t0:.1f}, check+STL+3MF+STEP {t2 - t1:.1f} (STEP {figures['step_mb']:.1f} MB)")
