"""The paper's case study (section 3.4): a sledgehammer handle textured for grip, and
the paper's experiment of texturing it in two halves, each separately, then
assembling them: how well the texture continues across the joints with the angle-
and the distance-preserving mapping (figures 14, 15).

Run it as a plain script:  python recipes/sledgehammer.py
It writes into $TEXCAD_OUT (default ./out):
  sledgehammer.stl, .3mf, .step, .png  the handle to print, the grip textured in one
                                       piece (a closed face: the seam is closed on
                                       shared vertices, gap exactly zero)
  sledgehammer_halves.3mf, .png        the modular handle: two halves, each textured
                                       separately (angle-preserving), one build item
  sledgehammer_halves_distance.png     the same with distance-preserving halves (fig. 15)
  sledgehammer.json                    the figures
$TEXCAD_PITCH sets the pixel pitch in mm (default 0.25); the tests run it coarser.

The handle prints standing on its butt (build direction +y, the handle's axis), so
the grip texture is limited to 45 deg overhangs for that direction.
"""

import json
import os
import time
import warnings
from pathlib import Path

import numpy as np
from build123d import Circle, Cone, GeomType, Keep, Plane, Pos, Rot, SortBy, extrude, split

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.25"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))
BUILD_DIR = (0, 1, 0)  # print orientation: standing on its butt, the handle's axis up
OUT.mkdir(parents=True, exist_ok=True)

R, GRIP, HEIGHT = 16.0, 120.0, 1.0  # handle radius, grip length, texture height (mm)

# -- the handle (mm), axis along +y: a flared butt, the 120 mm grip (its own
# cylindrical face), a 45 deg collar and a thinner neck towards the head.
butt = Pos(0, -3, 0) * (Rot(-90, 0, 0) * Cone(R + 3, R, 6))
grip_body = extrude(Plane.XZ * Circle(R), amount=-GRIP)
collar = Pos(0, GRIP + 1, 0) * (Rot(-90, 0, 0) * Cone(R, R - 2, 2))
neck = Pos(0, GRIP + 2, 0) * extrude(Plane.XZ * Circle(R - 2), amount=-130)
handle = butt + grip_body + collar + neck
grip_face = handle.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]
assert abs(grip_face.area - 2 * np.pi * R * GRIP) < 1e-6 * grip_face.area, "the grip face is the R 16 mm cylinder"

# -- the grip texture: grown from a small sample, seamless around (M-II, wrap="x"),
# with a whole number of columns around the handle.
t0 = time.perf_counter()
n = 2 * round(np.pi * R / PITCH)  # texture columns around the handle (even: two halves)
p = 2 * np.pi * R / n  # x pitch: the columns fill the perimeter exactly
rows = round(GRIP / PITCH)
sample = texcad.builtin("stones", size=(25, 25), pitch=PITCH, height=HEIGHT)
patch = min(45, *sample.shape)
grown = texcad.synthesize(sample, (rows, n), patch=patch, overlap=patch * 5 // 9, seed=0, wrap="x")
grip = texcad.Heightmap(grown.heights, (p, PITCH))

# -- the part: the grip face textured in one piece, printable upright (+y).
part = texcad.texture(handle, grip_face, grip, mapping="angle", periodic_x=True, build_dir=BUILD_DIR)
t1 = time.perf_counter()
report = texcad.check(part, build_dir=BUILD_DIR)
part.export(OUT / "sledgehammer.stl")
part.export(OUT / "sledgehammer.3mf", separate_texture=True)
t2 = time.perf_counter()
part.export(OUT / "sledgehammer.step")
t3 = time.perf_counter()
view = dict(width=1400, view=(0.55, 0.35, -0.75), up=(0, 0, 1))
part.render(OUT / "sledgehammer.png", **view)

# -- the paper's experiment: the same (limited) texture in two halves. Half A takes
# columns 0 .. n/2, half B columns n/2 .. n (= 0): each joint column is mapped twice.
h = part.heightmap.heights
half_a = texcad.Heightmap(h[:, : n // 2 + 1], (p, PITCH))
half_b = texcad.Heightmap(np.concatenate([h[:, n // 2 :], h[:, :1]], axis=1), (p, PITCH))
# The two halves of the grip, both clockwise seen along -y (texture on the convex
# side): A over the top from (-R, 0) to (R, 0), B underneath and back.
upper = texcad.Profile.arc(R, 180)
lower = texcad.Profile.parametric(
    lambda th: (R * np.cos(th), R * np.sin(th)),
    0.0,
    -np.pi,
    derivative=lambda th: (-R * np.sin(th), R * np.cos(th)),
    name=f"lower half R {R:g} mm",
)
results = {}
pieces = {}
for mapping in ("angle", "distance"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)  # distance mode fades at the joints
        a = texcad.mapping.map_texture(upper, half_a, mapping=mapping, length=GRIP, depth=0.5)
        b = texcad.mapping.map_texture(lower, half_b, mapping=mapping, length=GRIP, depth=0.5)
    pieces[mapping] = (a, b)
    right, left = texcad.report.seam_gap(a, b), texcad.report.seam_gap(b, a)
    worst = max(right, left, key=lambda g: g.max_um)
    bare = float(np.mean(np.concatenate([a.factor, b.factor]) < 0.5))
    results[mapping] = {"seam_gap_max_um": worst.max_um, "seam_gap_rms_um": max(right.rms_um, left.rms_um), "bare_fraction": bare}
    print(f"{mapping:9s} {worst}; texture below half height on {100 * bare:.1f} % of the circumference")

# The paper's algorithm 1 as such (no fade): each half adds its heights along its own
# vertical (sigma = +1 on the upper half, -1 on the lower one), so at the joints, where
# the surface is vertical, the two copies of a column lie 2 h apart (figure 15).
joint_h = np.concatenate([h[:, 0], h[:, n // 2]])
results["distance"]["algorithm1_gap_max_um"] = float(2 * joint_h.max() * 1e3)
print(f"distance  paper's algorithm 1 without texcad's fade: gap up to {2 * joint_h.max():.3f} mm at the joints")

# The modular handle: each half of the handle (split at the joint plane z = 0) with
# its own texture half, a watertight part of its own; the two make one build item of
# sledgehammer_halves.3mf (figure 14), and likewise with distance-preserving halves
# for the picture of figure 15.
body = {"A": split(handle, Plane.XY, keep=Keep.TOP), "B": split(handle, Plane.XY, keep=Keep.BOTTOM)}
halves = {
    mapping: [(f"half {k}", texcad.solid.fuse(texcad.brep.shape_to_mesh(body[k]), piece.solid())) for k, piece in zip("AB", pair)]
    for mapping, pair in pieces.items()
}
texcad.io.write_3mf(halves["angle"], OUT / "sledgehammer_halves.3mf", name="sledgehammer halves")
for mapping, suffix in (("angle", ""), ("distance", "_distance")):
    both = texcad.Mesh(
        np.concatenate([halves[mapping][0][1].vertices, halves[mapping][1][1].vertices]),
        np.concatenate([halves[mapping][0][1].faces, halves[mapping][1][1].faces + len(halves[mapping][0][1].vertices)]),
    )
    # Seen from the side (-x), where the joint at (-R, 0) faces the camera.
    texcad.render.render_part(both, OUT / f"sledgehammer_halves{suffix}.png", width=1400, view=(1.0, 0.35, -0.12), up=(0, 0, 1))

m = part.mesh
step_mb = (OUT / "sledgehammer.step").stat().st_size / 1e6
results.update(
    pitch_mm=PITCH,
    grid=[rows, n],
    triangles=m.num_triangles,
    watertight=bool(m.is_watertight),
    volume_mm3=m.volume,
    step_volume_mm3=texcad.brep.volume(part.shape),
    step_mb=step_mb,
    halves_watertight=all(h.is_watertight for _, h in halves["angle"]),
    halves_volume_mm3=sum(h.volume for _, h in halves["angle"]),
    texture_overhang_mm2=report.texture_overhang_area_mm2,
    seconds={"texture": t1 - t0, "check_stl_3mf": t2 - t1, "step": t3 - t2},
)
(OUT / "sledgehammer.json").write_text(json.dumps(results, indent=2))
print(f"grid         {rows} x {n} px around, pitch {PITCH:g} mm (x {p:.4f} mm)")
print(f"part         {m.num_triangles} triangles, watertight {m.is_watertight}, volume {m.volume:.1f} mm3 (STEP {results['step_volume_mm3']:.1f})")
print(f"halves       watertight {results['halves_watertight']}, volume {results['halves_volume_mm3']:.1f} mm3 together")
print(f"printing     upright (+y): texture overhang {report.texture_overhang_area_mm2:.2f} mm2")
print(f"seconds      texture {t1 - t0:.1f}, check+STL+3MF {t2 - t1:.1f}, STEP {t3 - t2:.1f} ({step_mb:.1f} MB)")
