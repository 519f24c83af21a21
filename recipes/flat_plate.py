"""The paper's flat sample: a 100 x 100 mm plate with a 2 mm texture (section 2.2).

Run it as a plain script:  python recipes/flat_plate.py
It writes flat_plate.stl, flat_plate.3mf, flat_plate.png (the heightmap) and
flat_plate_part.png (the part) into $TEXCAD_OUT (default ./out). $TEXCAD_PITCH sets
the pixel pitch in mm (default 0.125: 800 x 800 px, one mesh vertex per pixel, as in
the paper); the tests run it coarser.

Printed lying flat, texture up (BUILD_DIR +z, the paper's orientation 0): nothing can
overhang, so the limiter changes nothing; the 3MF is placed that way on the bed.
"""

import os
from pathlib import Path

from build123d import Align, Axis, Box

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
OUT.mkdir(parents=True, exist_ok=True)
BUILD_DIR = (0, 0, 1)  # print orientation: lying flat, texture up

# The base body: a 100 x 100 x 5 mm plate whose top face lies at z = 0.
plate = Box(100, 100, 5, align=(Align.MIN, Align.MIN, Align.MAX))

# The texture: irregular stones, 2 mm high (white = 2 mm, black = on the surface).
texture = texcad.builtin("stones", size=(100, 100), pitch=PITCH, height=2.0)

# Texture the top face: clipped to the outline with 45-degree M-I ramps at its borders.
part = texcad.texture(plate, plate.faces().sort_by(Axis.Z)[-1], texture, build_dir=BUILD_DIR)

part.export(OUT / "flat_plate.stl")
part.export(OUT / "flat_plate.3mf")
texcad.render.render_heightmap(part.heightmap, OUT / "flat_plate.png")
part.render(OUT / "flat_plate_part.png", width=900)
print(f"{part.mesh.num_triangles} triangles, watertight={part.mesh.is_watertight}, volume={part.mesh.volume:.1f} mm3")
