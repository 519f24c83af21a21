"""Texture a downloaded-style STL: grip on the sides, a logo-like pattern engraved on
top, printed standing on its bottom without support.

Most parts people want to texture are meshes (a download, an export from another CAD
program). Here a build123d block with rounded edges is written as an STL first, to
stand in for such a file; from then on only the STL is used:

* the sides (every face but the top, not the bed face: ``not:normal:+z:30``) get a
  raised diamond knurl in a triplanar projection, 0.8 mm high;
* the top (``normal:+z:10``) gets hexagons engraved 0.6 mm deep (the top stays
  where it was: the texture is cut into it);
* both fade out over 2 mm at their borders, and both are limited so that nothing
  overhangs for the build direction +z.

Run it as a plain script:  python recipes/mesh_part.py
It writes mesh_part_input.stl (the stand-in), mesh_part.stl, mesh_part.3mf (base and
the two textures as three objects of one build item) and mesh_part.png into
$TEXCAD_OUT (default ./out). $TEXCAD_PITCH sets the longest edge in mm (default
0.25); the tests run it coarser.
"""

import json
import os
import time
from pathlib import Path

from build123d import Axis, Box, Pos, export_stl, fillet

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.25"))  # mm, longest edge after subdivision
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
BUILD_DIR = (0, 0, 1)  # print orientation: standing on its bottom
OUT.mkdir(parents=True, exist_ok=True)

# The stand-in for a user's file: a 50 x 35 x 25 mm block, rounded vertical edges
# (r 8) and a rounded top rim (r 3), exported as an STL like any CAD program would.
block = Pos(0, 0, 12.5) * Box(50, 35, 25)
block = fillet(block.edges().filter_by(Axis.Z), radius=8)
block = fillet(block.edges().group_by(Axis.Z)[-1], radius=3)
stl_in = OUT / "mesh_part_input.stl"
export_stl(block, str(stl_in), tolerance=0.02, angular_tolerance=0.2)

t0 = time.perf_counter()
part = texcad.texture(
    stl_in,
    [
        ("not:normal:+z:30", "builtin:diamond_knurl:period=2.5", {"height": 0.8, "projection": "triplanar"}),
        ("normal:+z:10", "builtin:hexagons:period=6", {"height": 0.6, "mode": "engraved", "projection": "planar:+z"}),
    ],
    pitch=PITCH,
    border=2.0,
    build_dir=BUILD_DIR,
)
t1 = time.perf_counter()
part.export(OUT / "mesh_part.stl")
part.export(OUT / "mesh_part.3mf", separate_texture=True)
report = texcad.check(OUT / "mesh_part.3mf", build_dir=(0, 0, 1))  # the 3MF stands the part as printed
t2 = time.perf_counter()
part.render(OUT / "mesh_part.png", width=900, view=(-1.0, 1.6, -1.0))

m = part.mesh
figures = {
    "pitch_mm": PITCH,
    "input_triangles": part.info["input_triangles"],
    "triangles": m.num_triangles,
    "watertight": bool(m.is_watertight),
    "volume_mm3": m.volume,
    "input_volume_mm3": texcad.load_mesh(stl_in).volume,
    "objects": report.objects,
    "texture_area_mm2": report.texture_area_mm2,
    "texture_overhang_mm2": report.texture_overhang_area_mm2,
    "overhang_mm2": report.overhang_area_mm2,
    "lowered_vertices": part.limits.lowered,
    "seconds": {"texture": t1 - t0, "write_and_check": t2 - t1},
}
(OUT / "mesh_part.json").write_text(json.dumps(figures, indent=2))
print(f"input        {stl_in.name}: {figures['input_triangles']} triangles, {figures['input_volume_mm3']:.0f} mm3")
print(f"textured     {m.num_triangles} triangles, watertight {m.is_watertight}, volume {m.volume:.0f} mm3")
print(f"printing     +z: texture overhang {report.texture_overhang_area_mm2:.2f} mm2 of {report.texture_area_mm2:.0f} mm2 textured")
print(f"seconds      texture {t1 - t0:.1f}, write+check {t2 - t1:.1f}")
