"""Knots and pcurves placed for OCCT's plain volume integration (issue 28).

``BRepGProp::VolumeProperties(shape, props)`` without a precision (what build123d's
``.volume`` calls) integrates each face by Green's theorem (``BRepGProp_Gauss``,
``BRepGProp_Vinert::Perform(face, domain)``): along every edge of the face, ``n``
Gauss-Legendre points over the edge's whole parameter range, and at each of them
``n`` points over the face's whole ``u`` range, from its lowest ``u`` to the edge's,
with ``n = min(max(IntegrationOrder(pcurve), VIntegrationOrder(surface)), 61)``
(``BRepGProp_Face``: ``2 (degree + 1) spans`` of a B-spline pcurve, at least 4 for a
line; ``max(8, 2 (degree + 1) v-spans)`` for a B-spline surface). One rule over many
knot spans: a degree-1 (bilinear) texture surface's integrand jumps at every knot
(the normal turns at each grid line), and a Gauss rule is off by about the jump times
the node spacing at each one; over a tile of 24 x 24 cells that is 0.1-0.3 % of a
textured plate's volume, and over one face of 100 spans more than 1 %.

The knots of a degree-1 surface are free (the poles fix the geometry; the knots only
how the parameter runs over each cell), so texcad puts them where the rule is exact
for a piecewise constant integrand: each knot at a partial sum of the Gauss weights
(:func:`gauss_knots`), every span holding its own nodes whose weights add up to the
span's length (the Stieltjes interlacing: a span's nodes lie inside it). The bilinear
integrand's first-order part is then integrated almost exactly too (measured on the
stones plate: 0.001 % instead of 0.2 %). That needs ``n`` known: the pcurves along
which the volume is integrated get at least :data:`PAD_SPANS` spans
(:func:`polyline_pcurve`, knots inserted: the same straight or broken line), so OCCT
uses its :data:`GAUSS_POINTS` points on them whatever the face's own spans; they keep
knots at the grid lines (OCCT's adaptive integration starts from a pcurve's knots).
Tile sides shorter than ``texcad.brep.solids.PLACED`` cells keep straight lines. The
small tiles under a CAD operation's tool, and the tiles around them that are not one
of the grid's runs, get knots of their own (``texcad.brep.solids._own_knots``): with
their run's knots (placed for 61 points over 24 cells) a 2-cell tile, on which OCCT
takes 8 points, put a drilled full cylinder's plain volume 0.7-1.7 % off; placed for
its own rule (each edge along ``v`` made on the tile whose right side it is, the
tile on its other side mapping it by a broken line) it is as exact as a whole tile.

The part's own face pieces a patch keeps around its walls (:mod:`texcad.brep.bands`)
are bounded by OCCT's section curves: B-spline pcurves of degree 5-8 with ten or so
knots each, continuous to the first derivative only, along which one 61-point rule
is 1-2 % off (on a fillet torus whose ``u`` runs a whole turn, the integrand is that
turn's volume): :func:`split_at_knots` cuts those edges at their knots (the same
curves, shorter ranges), each piece getting its own rule (a cylinder cap's fillet
+0.112 % -> +0.038 %, a box top's four fillets -0.143 % -> -0.001 %; pieces of at
least :data:`SPLIT_LENGTH`). The cut edges also let OCCT's mesher close the re-read
STEP of a box top with two mitred fillets and of an L plate at 0.5 rad (a hole
beside a long kept fillet strip before).
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["GAUSS_POINTS", "PAD_SPANS", "gauss_knots", "run_knots", "polyline_pcurve", "split_at_knots"]

#: Gauss points OCCT's plain integration puts along an edge and across a face's u range
#: at most (``math::GaussPointsMax``).
GAUSS_POINTS = 61
#: Spans a degree-1 pcurve gets at least so that OCCT's plain integration uses
#: :data:`GAUSS_POINTS` points along it (``2 (1 + 1) 16 = 64 > 61``).
PAD_SPANS = 16


def gauss_knots(lo: float, hi: float, spans: int, points: int = GAUSS_POINTS) -> np.ndarray:
    """``spans + 1`` knots from ``lo`` to ``hi`` (same unit) splitting the
    ``points``-point Gauss-Legendre rule on ``[lo, hi]`` into runs of nearly equal
    node counts, each knot at the partial sum of the weights before its run (the rule
    then integrates any function constant on each span exactly). More spans than
    points: equal spans."""
    if spans > points:
        return np.linspace(lo, hi, spans + 1)
    k = lo + (hi - lo) * _partial_sums(points)[np.round(np.arange(spans + 1) * points / spans).astype(np.int64)]
    k[0], k[-1] = lo, hi
    return k


@functools.lru_cache(maxsize=8)
def _partial_sums(points: int) -> np.ndarray:
    """``(points + 1,)`` partial sums of the ``points``-point Gauss-Legendre weights,
    divided by their total (0 to 1; computed once per rule: an eigenvalue problem)."""
    _, w = np.polynomial.legendre.leggauss(points)
    out = np.concatenate([[0.0], np.cumsum(w)]) / w.sum()
    out.setflags(write=False)
    return out


def run_knots(knots: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """``knots`` (increasing) with the ones inside each run ``bounds[i] .. bounds[i +
    1]`` (indices: a tile's cells) replaced by :func:`gauss_knots` between the run's
    end knots, which stay."""
    k = np.asarray(knots, np.float64).copy()
    for a, z in zip(np.asarray(bounds)[:-1].tolist(), np.asarray(bounds)[1:].tolist()):  # one per run of cells (tile)
        k[a : z + 1] = gauss_knots(k[a], k[z], z - a)
    return k


def polyline_pcurve(points: np.ndarray, params: np.ndarray, pad: bool = True):
    """The degree-1 ``Geom2d_BSplineCurve`` through ``points`` ``(m + 1, 2)`` at the
    increasing ``params`` ``(m + 1,)``; ``pad``: each span cut in equal parts (the same
    curve) until it has at least :data:`PAD_SPANS` spans."""
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.gp import gp_Pnt2d
    from OCP.TColgp import TColgp_Array1OfPnt2d
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

    p, t = np.asarray(points, np.float64), np.asarray(params, np.float64)
    m = len(t) - 1
    parts = max(1, -(-PAD_SPANS // m)) if pad else 1
    s = np.arange(parts) / parts
    tt = np.concatenate([(t[:-1, None] + np.diff(t)[:, None] * s).ravel(), t[-1:]])
    pp = np.concatenate([(p[:-1, None] + np.diff(p, axis=0)[:, None] * s[:, None]).reshape(-1, 2), p[-1:]])
    poles, knots, mults = TColgp_Array1OfPnt2d(1, len(tt)), TColStd_Array1OfReal(1, len(tt)), TColStd_Array1OfInteger(1, len(tt))
    for i, (a, q) in enumerate(zip(tt.tolist(), pp.tolist()), 1):  # per pole of one edge (tens)
        poles.SetValue(i, gp_Pnt2d(q[0], q[1]))
        knots.SetValue(i, a)
        mults.SetValue(i, 2 if i in (1, len(tt)) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, 1)


#: mm, the shortest piece :func:`split_at_knots` leaves (OCCT's mesher leaves holes in
#: the re-read STEP beside pieces as short as the knots' spacing, 0.05 mm and less).
SPLIT_LENGTH = 0.08


def _spaced(c, k: np.ndarray, least: float) -> list:
    """Of the parameters ``k`` (increasing) on the curve adaptor ``c``, those at
    least ``least`` mm (chord) from the last one kept and from the curve's end."""
    pts = np.array([c.Value(t).Coord() for t in [c.FirstParameter(), *k.tolist(), c.LastParameter()]])
    keep, last = [], pts[0]
    for t, p in zip(k.tolist(), pts[1:-1]):  # per knot (about ten)
        if np.linalg.norm(p - last) >= least and np.linalg.norm(pts[-1] - p) >= least:
            keep.append(t)
            last = p
    return keep


def _knot_points(faces: list, keep: list = ()) -> list:
    """Vertices at the interior knots of the B-spline pcurves of ``faces``' edges
    (each edge once), none on the edges ``keep``."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.Geom2dAdaptor import Geom2dAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_BSplineCurve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from .occt import explore

    seen, out = TopTools_IndexedMapOfShape(), []
    for e in keep:  # edges not to cut: as if seen
        seen.Add(e)
    for f in faces:  # the kept pieces (tens)
        f = TopoDS.Face_s(f)
        for e in explore(f, TopAbs_EDGE):  # their edges
            if seen.Contains(e):
                continue
            seen.Add(e)
            e = TopoDS.Edge_s(e)
            pc = Geom2dAdaptor_Curve(BRep_Tool.CurveOnSurface_s(e, f, 0.0, 0.0))
            if pc.GetType() != GeomAbs_BSplineCurve or BRep_Tool.Degenerated_s(e):
                continue
            c, bs = BRepAdaptor_Curve(e), pc.BSpline()
            k = np.array([bs.Knot(i) for i in range(1, bs.NbKnots() + 1)])
            k = k[(k > c.FirstParameter() + 1e-9) & (k < c.LastParameter() - 1e-9)]
            out += [BRepBuilderAPI_MakeVertex(c.Value(t)).Vertex() for t in _spaced(c, k, SPLIT_LENGTH)]
    return out


def split_at_knots(faces: list, others: list, keep: list = ()) -> tuple | None:
    """``(faces, others)`` with the edges of ``faces`` whose pcurve is a B-spline cut
    at its interior knots (module docstring), by OCCT's general fuse with vertices
    there (the edges' other faces among ``others`` get the same pieces; each face
    keeps its orientation); unchanged if there are none, None if the fuse fails.
    ``keep``: edges left whole (a patch's outline, which faces outside the fuse share:
    cut, they would no longer be shared)."""
    from .occt import general_fuse

    points = _knot_points(faces, keep)
    if not points:
        return faces, others
    gf = general_fuse([list(faces) + list(others), points])
    if gf is None:
        return None

    def image(f):
        mod = list(gf.Modified(f))
        if len(mod) > 1:
            raise ValueError("split")
        g = mod[0] if mod else f
        return g if g.Orientation() == f.Orientation() else g.Reversed()

    try:
        return [image(f) for f in faces], [image(f) for f in others]
    except ValueError:  # a face cut in two: not what vertices on its edges do
        return None
