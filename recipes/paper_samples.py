"""The paper's section 3.3: three textures on flat, curved and sinusoidal samples.

Run it as a plain script:  python recipes/paper_samples.py [SAMPLE ...]
For every row of the paper's Table 2 it builds the 100 x 100 mm sample as a build123d
part, textures its top face with texcad.texture (2 mm texture), made support-free for
the row's print orientation, checks it, and writes NAME.stl, NAME.3mf (texture as
its own object), NAME.step and NAME.png into $TEXCAD_OUT (default ./out), plus
paper_samples.json with the table it prints.

$TEXCAD_PITCH sets the pixel pitch in mm (default 0.125: the paper's 800 px per
100 mm); the tests run it coarser. The STEP is made at the same pitch (the textured
face replaces the base face: no OCCT union, which used to fail on the sine at
0.125 mm); STL and 3MF are always at $TEXCAD_PITCH. Choose rows by
name on the command line or in $TEXCAD_SAMPLES (comma-separated), e.g.
python recipes/paper_samples.py T1-flat T3-curved

The samples (paper, section 2.2.4): flat; curved, a circular arc of radius 80 mm
bulging up (eq. 5-8) on a concentric 5 mm shell; sinusoidal, z = 5 sin(2 pi x / 50)
(eq. 9) on a plate with a flat bottom. The paper does not give R, A and L; these are
the values texcad's tests use. 100 mm of texture run along the arc; the sine's
textured face is its arc length (eq. 13) long.

The textures (paper, Table 1): each is synthesized (texcad.synthesize, Liang's patch
sampling) from a small sample with the paper's sample, patch and overlap sizes, at
the paper's 0.125 mm per pixel (then resampled to $TEXCAD_PITCH):
  T1  diamond knurl (structured)  sample 150 x 100 px, patch 25, overlap 10
  T2  granite-like grain (sand)   sample 200 x 200 px, patch 45, overlap 25
  T3  pebbled leather             sample 200 x 200 px, patch 45, overlap 25

Print orientation (Table 2): the angle between the sample and the build plate. The
flat samples tilt so that +y rises, the curved and sine samples so that +x rises:
build direction texcad.orientation(tilt, toward), in the part's (world) frame.
"""

import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from build123d import Align, Box, CenterArc, GeomType, Line, Plane, Polyline, SortBy, Spline, extrude, make_face

import texcad

PITCH = float(os.environ.get("TEXCAD_PITCH", "0.125"))  # mm per pixel
OUT = Path(os.environ.get("TEXCAD_OUT", "out"))

SIZE = 100.0  # mm, the samples (Figure 13)
HEIGHT = 2.0  # mm, maximum texture height (section 3.3)
THICKNESS = 5.0  # mm, base under the texture
RADIUS = 80.0  # mm, curved sample (eq. 5)
AMPLITUDE, PERIOD = 5.0, 50.0  # mm, sinusoidal sample (eq. 9)
PAPER_PITCH = 0.125  # mm per pixel of the paper's textures (800 px per 100 mm)
# The STEP of the curved and sine samples is made at this pitch at most (it was 0.25 mm
# while their B-rep needed OCCT's union; the face is now replaced in place).
STEP_PITCH = 0.125  # mm

# Table 1: texture -> (built-in to cut the sample from, its parameters,
#                      sample size (cols, rows) px, patch px, overlap px)
TEXTURES = {
    "T1": ("diamond_knurl", {}, (150, 100), 25, 10),
    "T2": ("sand", {"scale": 3.0}, (200, 200), 45, 25),
    "T3": ("leather", {"scale": 2.0}, (200, 200), 45, 25),
}
# Table 2: (texture, sample, orientation to the build plate in degrees)
TABLE2 = [
    ("T1", "flat", 0), ("T1", "curved", 30), ("T1", "sine", 15),
    ("T2", "flat", 45), ("T2", "curved", 45), ("T2", "sine", 0),
    ("T3", "flat", 15), ("T3", "curved", 60), ("T3", "sine", 30),
]  # fmt: skip


# -- the three samples as build123d parts --------------------------------------------------
def flat_sample():
    """100 x 100 x 5 mm plate, top face at z = 0."""
    part = Box(SIZE, SIZE, THICKNESS, align=(Align.MIN, Align.MIN, Align.MAX))
    return part, part.faces().sort_by(SortBy.AREA)[-1], SIZE


def curved_sample():
    """A 5 mm shell: outer arc of radius 80 mm and 100 mm arc length, along +y."""
    angle = np.degrees(SIZE / RADIUS)  # the arc's opening, degrees (eq. 8: s = R theta)
    outer = CenterArc((0, 0), RADIUS, 90 - angle / 2, angle)
    inner = CenterArc((0, 0), RADIUS - THICKNESS, 90 - angle / 2, angle)
    section = make_face([outer, Line(outer @ 1, inner @ 1), inner, Line(inner @ 0, outer @ 0)])
    part = extrude(Plane.XZ * section, amount=-SIZE)  # y from 0 to 100 mm
    return part, part.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1], SIZE


def sine_sample():
    """z = A sin(2 pi x / L) for 0 <= x <= 100 mm on a plate with a flat bottom."""
    k = 2 * np.pi / PERIOD
    x = np.linspace(0, SIZE, 129)
    top = Spline(*[(a, AMPLITUDE * np.sin(k * a)) for a in x], tangents=[(1, AMPLITUDE * k), (1, AMPLITUDE * k * np.cos(k * SIZE))])
    bottom = -(AMPLITUDE + THICKNESS)
    section = make_face([top, Polyline(top @ 1, (SIZE, bottom), (0, bottom), (0, 0))])
    part = extrude(Plane.XZ * section, amount=-SIZE)
    arc_length = texcad.Profile.sine(AMPLITUDE, PERIOD, SIZE).length  # eq. 13
    return part, part.faces().sort_by(SortBy.AREA)[-1], arc_length


SAMPLES = {  # sample -> (builder, mapping, direction that rises when tilted)
    "flat": (flat_sample, "angle", "+y"),
    "curved": (curved_sample, "angle", "+x"),  # heights along the normal (Algorithm 2)
    "sine": (sine_sample, "distance", "+x"),  # heights along z (Algorithm 1)
}


# -- the textures (Table 1) ------------------------------------------------------------------
def synthesized(tex: str, width: float, seed: int = 1) -> texcad.Heightmap:
    """Texture ``tex`` grown from its small sample to ``width`` x 100 mm."""
    name, params, (cols, rows), patch, overlap = TEXTURES[tex]
    sample = texcad.builtin(name, size=(cols * PAPER_PITCH, rows * PAPER_PITCH), pitch=PAPER_PITCH, height=HEIGHT, **params)
    sample = texcad.Heightmap(sample.heights, PAPER_PITCH)  # exactly cols x rows px
    shape = (int(round(SIZE / PAPER_PITCH)), int(round(width / PAPER_PITCH)))
    hm = texcad.synthesize(sample, shape, patch=patch, overlap=overlap, seed=seed)
    return hm if PITCH == PAPER_PITCH else hm.resampled(PITCH)


# -- one row of Table 2 ----------------------------------------------------------------------
def make_sample(tex: str, kind: str, tilt: float) -> dict:
    name = f"{tex}-{kind}"
    build, mapping, toward = SAMPLES[kind]
    part, face, width = build()
    hm = synthesized(tex, width)
    d = texcad.orientation(tilt, toward)  # build direction, world frame

    coarse_step = kind != "flat" and PITCH < STEP_PITCH
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        # As synthesized, for comparison (meshes only).
        plain = texcad.texture(part, face, hm, mapping=mapping, brep=False)
        t0 = time.perf_counter()
        textured = texcad.texture(part, face, hm, mapping=mapping, build_dir=d, brep=not coarse_step)
        t1 = time.perf_counter()
        textured.export(OUT / f"{name}.stl")
        textured.export(OUT / f"{name}.3mf", separate_texture=True)
        for_step = textured
        if coarse_step:  # the same texture, sampled at STEP_PITCH, as a B-rep
            for_step = texcad.texture(part, face, hm.resampled(STEP_PITCH), mapping=mapping, build_dir=d)
        for_step.export(OUT / f"{name}.step")
        t2 = time.perf_counter()
    textured.render(OUT / f"{name}.png", width=900)

    # Printable? The STL is one watertight body; the texture is support-free: checked
    # on the 3MF just written (its "texture" object), and on the texture as
    # synthesized, written the same way to a scratch file.
    body = texcad.check(OUT / f"{name}.stl", build_dir=d)
    after = texcad.check(OUT / f"{name}.3mf", build_dir=(0, 0, 1))  # the 3MF is placed as printed: d is +z there
    with tempfile.TemporaryDirectory() as scratch:
        plain.export(Path(scratch) / "plain.3mf", separate_texture=True)
        before = texcad.check(Path(scratch) / "plain.3mf", build_dir=d)
    return {
        "sample": name,
        "tilt_deg": tilt,
        "build_dir": [round(float(v), 6) for v in d],
        "mapping": mapping,
        "triangles": body.triangles,
        "watertight": body.watertight,
        "shells": body.shells,
        "seconds_texture": round(t1 - t0, 2),
        "seconds_export": round(t2 - t1, 2),
        "step_mb": round((OUT / f"{name}.step").stat().st_size / 1e6, 1),
        "step_pitch_mm": STEP_PITCH if coarse_step else PITCH,
        "overhang_mm2": after.texture_overhang_area_mm2,
        "overhang_without_limiter_mm2": before.texture_overhang_area_mm2,
        "removed_mm3": round(textured.limits.removed_volume_mm3, 1),
    }


def selected(names: list[str]) -> list[tuple[str, str, int]]:
    """The Table 2 rows named ``T1-flat``, ``T3-curved``, ... (all if none)."""
    unknown = set(names) - {f"{t}-{k}" for t, k, _ in TABLE2}
    if unknown:
        sys.exit(f"no sample named {', '.join(sorted(unknown))}; choose from {', '.join(f'{t}-{k}' for t, k, _ in TABLE2)}")
    return [r for r in TABLE2 if not names or f"{r[0]}-{r[1]}" in names]


def main() -> None:
    rows = selected(sys.argv[1:] or [s for s in os.environ.get("TEXCAD_SAMPLES", "").split(",") if s])
    OUT.mkdir(parents=True, exist_ok=True)
    print(f"pitch {PITCH:g} mm, texture height {HEIGHT:g} mm, critical angle 45 deg")
    print(f"{'sample':10} {'tilt':>5} {'triangles':>10} {'texture s':>9} {'export s':>9} {'STEP MB':>8} "
          f"{'overhang mm2':>13} {'w/o limiter':>12} {'removed mm3':>12}")  # fmt: skip
    results = []
    for tex, kind, tilt in rows:  # one per sample
        r = make_sample(tex, kind, tilt)
        results.append(r)
        print(f"{r['sample']:10} {tilt:5d} {r['triangles']:10d} {r['seconds_texture']:9.1f} {r['seconds_export']:9.1f} "
              f"{r['step_mb']:8.1f} {r['overhang_mm2']:13.2f} {r['overhang_without_limiter_mm2']:12.2f} "
              f"{r['removed_mm3']:12.1f}", flush=True)  # fmt: skip
    if PITCH < STEP_PITCH:
        print(f"(STEP of the curved and sine samples made at {STEP_PITCH:g} mm; 'export s' includes that texturing)")
    (OUT / "paper_samples.json").write_text(json.dumps({"pitch_mm": PITCH, "samples": results}, indent=1))


if __name__ == "__main__":
    main()
