"""A revolved knob with two zones in one call: a raised diamond knurl on its grip cone,
engraved stones on its chamfer and top.

Run it as a plain script:  python recipes/zones_knob.py
It writes zones_knob.stl, zones_knob.3mf (one object: the base and one part per zone,
so a multi-material printer gives each texture its own filament), zones_knob.step,
zones_knob.png and zones_knob.json (each zone's height asked and reached) into $TEXCAD_OUT (default
./out). $TEXCAD_PITCH sets the pixel pitch in mm (default 0.125); the tests run it
coarser.

Each zone is ``(faces, texture, {options})``: its own texture, height and mode, the
call's options (pitch, build direction) for the rest. A zone's faces are textured as
patches of their own (never joined to another zone's), each ramped down at its
outline, so zones that touch meet cleanly. Printed standing on its skirt
(BUILD_DIR +z): both zones are limited so that no facet overhangs.
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

# The knob (mm): a 30 mm skirt, a 12 mm tall cone, a chamfer and a flat top, a 6 mm bore.
with BuildPart() as knob:
    with BuildSketch(Plane.XZ):
        with BuildLine():
            Polyline((3, 0), (15, 0), (15, 2), (12.5, 14), (11, 15.5), (3, 15.5), close=True)
        make_face()
    revolve(axis=Axis.Z)

cones = knob.part.faces().filter_by(GeomType.CONE).sort_by(Axis.Z)
grip, chamfer = cones[0], cones[-1]
top = knob.part.faces().sort_by(Axis.Z)[-1]

t0 = time.perf_counter()
part = texcad.texture(
    knob.part,
    [
        (grip, "builtin:diamond_knurl:period=2", {"height": 0.6}),
        ([chamfer, top], "builtin:stones", {"height": 0.4, "mode": "engraved"}),
    ],
    pitch=PITCH,
    build_dir=BUILD_DIR,
)
t1 = time.perf_counter()
part.export(OUT / "zones_knob.stl")
part.export(OUT / "zones_knob.3mf", separate_texture=True)
t2 = time.perf_counter()
part.export(OUT / "zones_knob.step")  # each zone's faces carry their texture in the B-rep
t3 = time.perf_counter()
part.render(OUT / "zones_knob.png", width=900)

m = part.mesh
figures = {
    "pitch_mm": PITCH,
    "triangles": m.num_triangles,
    "watertight": bool(m.is_watertight),
    "volume_mm3": m.volume,
    "zones": part.info["zones"],
    "zone_reliefs": part.info["zone_reliefs"],
    "layer_volumes_mm3": [layer.volume for layer in part.layer_meshes],
    "seconds": t1 - t0,
    "step_seconds": t3 - t2,
}
(OUT / "zones_knob.json").write_text(json.dumps(figures, indent=1))
print(f"textured     {m.num_triangles} triangles, watertight {m.is_watertight}, volume {m.volume:.0f} mm3, {t1 - t0:.1f} s")
for z in part.info["zone_reliefs"]:
    reached = f"depth {z['max_depth']:.2f}" if "max_depth" in z else f"height {z['max_height']:.2f}"
    print(f"{z['name']:<36} faces {z['faces']}: {z['mode']} {z['height']:g} mm asked, {reached} mm reached")
print(f"step         {t3 - t2:.1f} s")
print("wrote        zones_knob.stl, zones_knob.3mf (base + one part per zone), zones_knob.step, zones_knob.png, zones_knob.json")
