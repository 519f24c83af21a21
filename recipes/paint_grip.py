"""Paint two zones of a grip in the slicer, texture each with its own texture.

Where a texture goes is easiest to say with a brush: paint the zone in PrusaSlicer,
OrcaSlicer or BambuStudio (the multi-material painting tool), save the project, and
texture ``paint:N`` (the surface painted with extruder / filament N). Here the
painting is done by code, with texcad's encoder of the slicers' paint strings, so the
recipe runs anywhere:

* a round grip, 32 mm across and 110 mm tall with rounded ends, standing on its
  bottom (build direction +z);
* zone 2 (extruder 2): the finger side, 55 degrees either side of +x between 22 and
  88 mm up, painted 4 levels deep (as a slicer's brush subdivides triangles);
* zone 3 (extruder 3): the thumb side, 45 degrees either side of 115 degrees below +x
  (towards -y), 30 to 80 mm up;
* the project is saved as a PrusaSlicer 3MF (``paint_grip_project.3mf``), then
  textured in one call: a diamond knurl 0.8 mm high on zone 2, stones 0.6 mm on zone 3,
  each fading out over 1.5 mm at its border; nothing outside the paint moves;
* ``paint_grip.3mf`` is the project again with the grip as one object of three parts
  (the base, the knurl on extruder 2, the stones on extruder 3), ready to slice.

Run it as a plain script:  python recipes/paint_grip.py
It writes paint_grip_project.3mf, paint_grip.3mf, paint_grip.stl, paint_grip.png and
paint_grip.json into $TEXCAD_OUT (default ./out). $TEXCAD_PITCH sets the longest edge
in mm (default 0.3); the tests run it coarser.
"""

import json
import os
import time
from pathlib import Path

import numpy as np
import trimesh

import texcad
from texcad.io.paint import paint_by_points, read_project, write_painted_3mf

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.3"))  # mm, longest edge after subdivision
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
BUILD_DIR = (0, 0, 1)  # print orientation: standing on its rounded end
OUT.mkdir(parents=True, exist_ok=True)

# The grip: a capsule 32 mm across and 110 mm tall, a surface of revolution (48
# sections, rings about 4 mm apart), as a CAD program would export it.
R, H = 16.0, 110.0
arc = np.linspace(-np.pi / 2, 0, 9)
profile = np.vstack([np.c_[R * np.cos(arc), R + R * np.sin(arc)],
                     np.c_[np.full(19, R), np.linspace(R, H - R, 21)[1:-1]],
                     np.c_[R * np.cos(arc[::-1]), H - R - R * np.sin(arc[::-1])]])
grip = trimesh.creation.revolve(profile, sections=48)
v, f = np.asarray(grip.vertices), np.asarray(grip.faces)

def zones(p: np.ndarray) -> np.ndarray:
    """The state painted at points (mm): 2 on the finger side, 3 on the thumb side."""
    ang = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
    side = np.hypot(p[:, 0], p[:, 1]) > 15.0
    finger = side & (np.abs(ang) < 55) & (p[:, 2] > 22) & (p[:, 2] < 88)
    palm = side & (np.abs(ang + 115) < 45) & (p[:, 2] > 30) & (p[:, 2] < 80)
    return np.where(finger, 2, np.where(palm, 3, 0))


project = OUT / "paint_grip_project.3mf"
strings = paint_by_points(v[f], zones, 4)  # what the slicer's brush would store, 4 levels deep
place = np.array([[1.0, 0, 0, 125], [0, 1, 0, 105], [0, 0, 1, 0]])  # on the bed's centre
write_painted_3mf(project, [("grip", v, f, {"color": strings}, place)])
print(f"project      {project.name}: {len(f)} triangles, {sum(map(bool, strings))} painted, states {read_project(project).states()}")

t0 = time.perf_counter()
part = texcad.texture(
    project,
    {
        "paint:2": ("builtin:diamond_knurl:period=2.5", {"height": 0.8}),
        "paint:3": ("builtin:stones", {"height": 0.6}),
    },
    projection="cylindrical:+z",
    pitch=PITCH,
    border=1.5,
    build_dir=BUILD_DIR,
)
t1 = time.perf_counter()
part.export(OUT / "paint_grip.3mf", separate_texture=True)
part.export(OUT / "paint_grip.stl")
part.render(OUT / "paint_grip.png", width=900, view=(-0.55, 0.85, -0.35))

m = part.mesh
figures = {
    "pitch_mm": PITCH,
    "input_triangles": part.info["input_triangles"],
    "painted_triangles": int(sum(map(bool, strings))),
    "triangles": m.num_triangles,
    "watertight": bool(m.is_watertight),
    "volume_mm3": m.volume,
    "zones": part.info["zones"],
    "zone_faces": part.info["region_faces"],
    "max_error_mm": part.max_error,
    "seconds": t1 - t0,
}
(OUT / "paint_grip.json").write_text(json.dumps(figures, indent=2))
print(f"textured     {m.num_triangles} triangles, watertight {m.is_watertight}, volume {m.volume:.0f} mm3, {t1 - t0:.1f} s")
print(f"zones        {', '.join(part.info['zones'])}")
print(f"wrote        paint_grip.3mf (one object: base + one part per zone), paint_grip.stl, paint_grip.png")
