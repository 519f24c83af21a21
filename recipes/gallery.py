"""Render every recipe's result into docs/gallery/ (the pictures in the README).

Run it as a plain script:  python recipes/gallery.py [--pitch MM] [--out DIR] [NAME ...]
Each recipe runs as its own process (as a user would run it) with $TEXCAD_OUT set to
a scratch folder; the PNG renders it writes are copied into the gallery folder
(default docs/gallery). --pitch sets $TEXCAD_PITCH for all of them (default: each
recipe's own full resolution); NAME limits the run to some recipes.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RECIPES = ["flat_plate", "paper_samples", "sledgehammer", "handle_flange", "heat_sink"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help=f"recipes to run (default: all of {', '.join(RECIPES)})")
    ap.add_argument("--pitch", type=float, default=None, help="mm per pixel for every recipe (default: each one's own)")
    ap.add_argument("--out", default=str(HERE.parent / "docs" / "gallery"), help="gallery folder (default docs/gallery)")
    args = ap.parse_args(argv)
    names = args.names or RECIPES
    unknown = sorted(set(names) - set(RECIPES))
    if unknown:
        ap.error(f"unknown recipe(s) {', '.join(unknown)}; choose from {', '.join(RECIPES)}")
    gallery = Path(args.out)
    gallery.mkdir(parents=True, exist_ok=True)
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ, TEXCAD_OUT=tmp)
            if args.pitch is not None:
                env["TEXCAD_PITCH"] = str(args.pitch)
            t0 = time.perf_counter()
            r = subprocess.run([sys.executable, str(HERE / f"{name}.py")], env=env, capture_output=True, text=True)
            if r.returncode != 0:
                sys.stderr.write(r.stderr)
                print(f"gallery: recipe {name} failed (exit {r.returncode})", file=sys.stderr)
                return 1
            pngs = sorted(Path(tmp).glob("*.png"))
            for png in pngs:
                shutil.copyfile(png, gallery / png.name)
            print(f"{name:14s} {time.perf_counter() - t0:6.1f} s  {', '.join(p.name for p in pngs)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
