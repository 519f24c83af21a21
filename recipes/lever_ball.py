"""A lever with a ball end: dimples on the sphere, faded out at its pole.

Run it as a plain script:  python recipes/lever_ball.py
Writes lever_ball.stl, .3mf, .png and .json (distortion figures) into $TEXCAD_OUT
(default ./out); $TEXCAD_PITCH sets the pitch in mm (default 0.125).

On a sphere the circumference of a ring shrinks to 0 at the pole: the texture keeps
whole tiles per ring at the mean radius, and where its local scale falls below
texcad.targets.patches.FADE_FULL it fades smoothly to 0 (a TexcadWarning says how much)
instead of pinching into spikes. Printed standing on its foot (build_dir +z): the
overhang limiter lowers the dimples' flanks that would face down too steeply.
"""

import json
import os
import time
import warnings
from pathlib import Path

from build123d import Align, Cylinder, GeomType, Pos, Sphere

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
BUILD_DIR = (0, 0, 1)  # print orientation: standing on the shaft's foot
OUT.mkdir(parents=True, exist_ok=True)

# The lever (mm): a 6 mm shaft 40 mm long with a 16 mm ball on its end.
lever = Cylinder(3, 40, align=(Align.CENTER, Align.CENTER, Align.MIN)) + Pos(0, 0, 46) * Sphere(8)
ball = lever.faces().filter_by(GeomType.SPHERE)

t0 = time.perf_counter()
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", texcad.TexcadWarning)
    part = texcad.texture(lever, ball, "builtin:dimples", height=0.5, pitch=PITCH, build_dir=BUILD_DIR)
t1 = time.perf_counter()
part.export(OUT / "lever_ball.stl")
part.export(OUT / "lever_ball.3mf", separate_texture=True)
part.render(OUT / "lever_ball.png", width=700)
m = part.mesh
figures = {"distortion": part.distortion.to_dict(), "faces": part.info["faces"], "warnings": [str(w.message) for w in caught],
           "limits": part.limits.to_dict()}
(OUT / "lever_ball.json").write_text(json.dumps(figures, indent=1, default=str))
print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
print(f"distortion   {part.distortion}")
print(f"overhangs    {part.limits.removed_volume_mm3:.1f} mm3 removed, {part.limits.remaining_overhang_mm2:.2f} mm2 left")
for w in caught:
    print(f"warning      {w.message}")
print(f"seconds      texture {t1 - t0:.1f}")
