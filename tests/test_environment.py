"""The pinned CAD stack imports together and each kernel builds a solid."""

import importlib.metadata as md
import subprocess
import sys


def test_build123d_and_cadquery_share_one_ocp():
    import build123d
    import cadquery as cq
    import manifold3d
    import trimesh

    assert md.version("build123d").startswith("0.12.")
    assert md.version("cadquery").startswith("2.8.")
    assert md.version("cadquery-ocp").startswith("7.9.3")
    b = build123d.Box(10, 20, 30)
    assert abs(b.volume - 6000) < 1e-6
    w = cq.Workplane("XY").box(10, 20, 30)
    assert abs(w.val().Volume() - 6000) < 1e-6
    # One OCP module backs both wrappers (two copies would give two TopoDS_Shape classes).
    from OCP.TopoDS import TopoDS_Shape

    assert isinstance(b.wrapped, TopoDS_Shape) and isinstance(w.val().wrapped, TopoDS_Shape)
    assert manifold3d.Manifold.cube([1, 2, 3]).volume() == 6
    assert trimesh.creation.box([1, 2, 3]).volume == 6


def test_import_texcad_leaves_the_cad_stack_for_later():
    # build123d/OCP take seconds to import; the CAD layer loads on first use.
    code = (
        "import sys, texcad; assert 'build123d' not in sys.modules and 'OCP' not in sys.modules; "
        "from build123d import Box; b = Box(20, 20, 4); "
        "tx = texcad.texture(b, b.faces().sort_by()[-1], 'builtin:ridges', height=0.3, pitch=0.5); "
        "print(type(tx).__module__, tx.mesh.is_watertight)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "texcad.pipeline.result True"
