"""Bands of B-spline faces (issue 28): what real CAD files hold (lofts, SolidWorks and
Fusion exports) where a build123d extrusion has planes and cylinders. A hexagonal
prism and a frustum made by ``loft``, their slanted edges filleted (the fillets and
the frustum's sides are B-spline surfaces), textured all around as one closed band:
one valid closed solid whose volume (OCCT's adaptive integration and its plain rule)
is within 0.1 % of the mesh, whose STEP reads back the same and meshes closed.

The patch's outline runs along the B-spline faces' rims, whose pcurves are B-splines:
cut at their knots with the section edges (``texcad.brep.gprop.split_at_knots``),
they were no longer shared with the caps outside the patch, and the shell was open
along both rims (60 free edges on the prism)."""

import warnings
from functools import lru_cache

import pytest

import texcad
from texcad.brep import check_shape, occt_volume, shape_to_mesh
from texcad.brep.solids import flat_solids


def _lofted(top: float):
    """A hexagonal prism (``top`` 20 mm) or frustum (``top`` 14 mm) 20 mm high from a
    20 mm hexagon, lofted, its slanted edges filleted 3 mm, and its sides."""
    from build123d import Plane, RegularPolygon, fillet, loft

    part = loft([RegularPolygon(20, 6), Plane.XY.offset(20) * RegularPolygon(top, 6)])
    part = fillet([e for e in part.edges() if abs(e.tangent_at(0.5).Z) > 0.1], 3)
    return part, [f for f in part.faces() if abs(f.normal_at().Z) < 0.9]


CASES = {"lofted hexagonal prism": 20.0, "lofted frustum": 14.0}


@lru_cache(maxsize=None)
def _textured(case):
    part, sides = _lofted(CASES[case])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the texture scaled to fit around
        tx = texcad.texture(part, sides, "builtin:stones", height=0.4, pitch=0.5)
    return tx, sides


def _plain(shape) -> float:
    """OCCT's plain volume rule (no precision: build123d's ``.volume``)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


def _assert_matches(shape, volume, slack):
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert abs(occt_volume(shape) - volume) <= 1e-3 * volume + slack
    assert abs(_plain(shape) - volume) <= 1e-3 * volume + slack


@pytest.mark.parametrize("case", list(CASES))
def test_bspline_band_brep_matches_the_mesh(case):
    from build123d import GeomType

    tx, sides = _textured(case)
    assert sum(f.geom_type == GeomType.BSPLINE for f in sides) >= 6  # the fillets at least
    (patch,) = tx.info["faces"]  # one patch: the band
    assert len(patch["faces"]) == 12
    shape = flat_solids(tx.shape)
    _assert_matches(shape, tx.volume, tx.info.get("volume_slack", 0.0))
    assert check_shape(shape)["faces"] > 100  # the texture is in the B-rep: tiles and walls


@pytest.mark.parametrize("case", list(CASES))
def test_bspline_band_step_reads_back(case, tmp_path):
    tx, _ = _textured(case)
    tx.export(tmp_path / "band.step")
    back = texcad.io.read_step(tmp_path / "band.step")
    _assert_matches(flat_solids(back), tx.volume, tx.info.get("volume_slack", 0.0))
    assert shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5).is_watertight
