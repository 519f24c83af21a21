"""A filleted enclosure textured on all its sides: hexagons running round the corners.

Run it as a plain script:  python recipes/enclosure.py
Writes enclosure.stl, .3mf, .png and .json into $TEXCAD_OUT (default ./out);
$TEXCAD_PITCH sets the pitch in mm (default 0.125).

The four walls and four rounded corners meet along tangent edges: texcad flattens them
together as one band (arc length round the cross-section x height), so the texture runs
on across the fillets with no seam; at the sharp top and bottom edges it ramps down to
0 (M-I). Printed upright (build_dir +z), the overhang limiter trims the hexagons'
downward flanks. The lid recess is cut first; the texture stays off it.
"""

import json
import os
import time
from pathlib import Path

from build123d import Axis, Box, Pos, fillet

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
BUILD_DIR = (0, 0, 1)  # print orientation: upright, standing on its bottom
OUT.mkdir(parents=True, exist_ok=True)

# The enclosure (mm): 70 x 45 x 30 with 8 mm corner fillets, hollowed to 2.5 mm walls.
outer = fillet(Box(70, 45, 30).edges().filter_by(Axis.Z), 8)
inner = Pos(0, 0, 2.5) * fillet(Box(65, 40, 30).edges().filter_by(Axis.Z), 5.5)
shell = outer - inner


def outside(face) -> bool:
    """The face reaches the outer box's extent (the inner walls stop 2.5 mm short)."""
    bb = face.bounding_box()
    return max(abs(bb.min.X), abs(bb.max.X)) > 34.99 or max(abs(bb.min.Y), abs(bb.max.Y)) > 22.49


sides = [f for f in shell.faces().filter_by(Axis.Z, reverse=True) if outside(f)]

t0 = time.perf_counter()
part = texcad.texture(shell, sides, "builtin:hexagons", height=0.6, pitch=PITCH, build_dir=BUILD_DIR)
t1 = time.perf_counter()
part.export(OUT / "enclosure.stl")
part.export(OUT / "enclosure.3mf", separate_texture=True)
part.render(OUT / "enclosure.png", width=900)
m = part.mesh
figures = {"distortion": part.distortion.to_dict(), "faces": part.info["faces"], "limits": part.limits.to_dict(), "sides": len(sides)}
(OUT / "enclosure.json").write_text(json.dumps(figures, indent=1, default=str))
print(f"faces        {len(sides)} sides in {len(part.info['faces'])} patch(es): {part.info['faces'][0]['parameterization']}")
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
print(f"distortion   {part.distortion}")
print(f"overhangs    {part.limits.removed_volume_mm3:.1f} mm3 removed, {part.limits.remaining_overhang_mm2:.2f} mm2 left")
print(f"seconds      texture {t1 - t0:.1f}")
