"""STEP at the mesh's tolerance (issue 28, texcad.io.step_tiles): a textured part's STEP
against its binary STL at the same tolerance, re-read by OCCT as one valid solid
whose volume is the mesh's, on a plate, the plate drilled through (fine tiles under
the tool) and a cylinder; the file's own economy (one 2-D context, short numbers)
and its reproducibility."""

import re
import warnings

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape, occt_volume, shape_to_mesh

#: Issue 28: a textured part's STEP at most twice its binary STL; texcad aims lower.
MOST = 2.0


def _distance(points: np.ndarray, mesh) -> float:
    """Largest distance (mm) from ``points`` to the triangles of ``mesh`` (libigl)."""
    import igl

    d2 = igl.point_mesh_squared_distance(
        np.asarray(points, np.float64), mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    )[0]
    return float(np.sqrt(d2.max()))


def _written(tx, folder, name: str):
    """``tx`` exported as STEP and binary STL into ``folder``: (STEP / STL size,
    the STEP re-read). The re-read shape is one valid closed solid, its OCCT volume
    within 0.1 % of the mesh's (plus the lean mesh's own slack), and OCCT's mesh of
    it lies within the tolerance (+ 0.1 mm deflection) of texcad's mesh."""
    step, stl = folder / f"{name}.step", folder / f"{name}.stl"
    tx.export(step)
    tx.export(stl)
    back = texcad.io.read_step(step)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"], chk
    slack = tx.info.get("volume_slack", 0.0)
    assert abs(occt_volume(back) - tx.volume) <= 1e-3 * tx.volume + slack
    shown = shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5)
    assert _distance(shown.vertices, tx.mesh) < 0.1 + tx.info.get("tolerance", 0.0)
    return step.stat().st_size / stl.stat().st_size, back


@pytest.fixture(scope="module")
def plate():
    from build123d import Axis, Box

    box = Box(24, 24, 4)
    return texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.5, pitch=0.25)


def test_plate_step_size(plate, tmp_path):
    ratio, _ = _written(plate, tmp_path, "plate")
    assert ratio <= 0.59 * MOST, ratio  # 1.16 (1.21 before the minimax fits): at 0.25 mm the lean STL keeps most points too
    text = (tmp_path / "plate.step").read_bytes()
    # OCCT writes a 2-D context per pcurve; written once here
    assert text.count(b"GEOMETRIC_REPRESENTATION_CONTEXT(2)") == 1
    # no 3-D point with more than 9 decimals, no 2-D one with more than 10 (OCCT's own: 17 significant digits)
    coords = re.findall(rb"CARTESIAN_POINT\('',\(([^)]*)\)", text)
    assert coords and not any(re.search(rb"\.\d{10}" if c.count(b",") == 2 else rb"\.\d{11}", c) for c in coords)
    # every entity referred to exists; the ids are dense, from 1
    ids = [int(i) for i in re.findall(rb"^#(\d+)=", text, re.M)]
    ids += [int(i) for i in re.findall(rb"\);#(\d+)=", text)]  # four points to a line
    assert sorted(ids) == list(range(1, len(ids) + 1))
    assert {int(r) for r in re.findall(rb"#(\d+)(?!\d|=)", text)} <= set(ids)
    (tmp_path / "again").mkdir()
    plate.export(tmp_path / "again" / "plate.step")  # the same name: the header holds it
    assert (tmp_path / "again" / "plate.step").read_bytes() == text


def test_drilled_plate_step_size(plate, tmp_path):
    """A hole drilled through with texcad's ops: the B-rep has fine tiles under the
    tool; the STEP merges those the tool left whole back into tiles (across the uneven
    spans of the knots placed for OCCT's plain Gauss rule, texcad.brep.gprop, but not
    across sliver spans: the test below), and the small tiles the tool trimmed in
    rectangles, runs of tile sides joined, OCCT's traces of the tool fitted as
    polylines. Issue 28 asks for twice its STL: 1.56 here (2.01 before the trimmed
    tiles were merged and the traces fitted: the hole's own edges were a sixth of the
    file; docs/benchmarks/step.md). The hole adds 32 faces to the plate's 22 (the
    tiles it meets, the trimmed rectangles around it, its wall), a third of the
    B-rep's 162 (whose small tiles under the tool have knots of their own). OCCT's
    plain rule (FreeCAD's volume) within 0.1 % too: +0.06 % (+0.16 % before the edges
    between tiles of different knots kept their points and those beside the plate's
    top kept 16 spans, texcad.io.step_tiles._foreign, _polyline)."""
    from build123d import Cylinder, Pos
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from texcad.brep import to_topods

    drilled = plate - Pos(3, 2, 0) * Cylinder(3, 10)
    ratio, back = _written(drilled, tmp_path, "drilled")
    assert ratio <= 0.8 * MOST, ratio
    faces = check_shape(back)["faces"]
    assert faces <= check_shape(plate.shape)["faces"] + 40, faces  # 22 + 32
    assert faces < 0.5 * check_shape(drilled.shape)["faces"], faces  # merged back: 54 of 162
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(to_topods(back), props)
    assert abs(props.Mass() - drilled.volume) <= 1e-3 * drilled.volume, (props.Mass(), drilled.volume)



def test_drilled_cylinder_plain_volume(tmp_path):
    """A cylinder drilled through its texture: the STEP's merged tiles around the hole
    are integrated right by OCCT's plain Gauss rule (``BRepGProp`` without a precision,
    FreeCAD's Part volume): within 0.1 % of the mesh (+0.12 % before their high-u
    sides got the rule's order, texcad.io.step_tiles._ruled; +0.16 % once the small
    tiles had knots of their own, before the edges between tiles of different knots
    kept their points, texcad.io.step_tiles._foreign; -0.013 % now)."""
    from build123d import Cylinder, GeomType, Pos
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from texcad.brep import to_topods

    cyl = Cylinder(10, 16)
    tx = texcad.texture(cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.4, pitch=0.5)
    drilled = tx - Pos(0, 0, 0) * Cylinder(1.5, 40, rotation=(90, 0, 0))
    drilled.export(tmp_path / "drilled.step")
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(to_topods(texcad.io.read_step(tmp_path / "drilled.step")), props)
    assert abs(props.Mass() - drilled.volume) <= 1e-3 * drilled.volume, (props.Mass(), drilled.volume)

def test_cylinder_step_size(tmp_path):
    from build123d import Cylinder, GeomType

    cyl = Cylinder(8, 16)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    tx = texcad.texture(cyl, side, "builtin:stones", height=0.6, pitch=0.25)
    ratio, _ = _written(tx, tmp_path, "cylinder")
    assert ratio <= 0.6 * MOST, ratio  # 1.15 (1.25 before the minimax fits)


def test_fine_cylinder_step_size(tmp_path):
    """At 0.125 mm the lean STL keeps few of the grid's points on a low relief, while
    a tile keeps whole rows and columns of poles: the tiles' rows are chosen and
    fitted (least squares, edges between tiles too) at even parameters, whatever the
    knots (placed for OCCT's plain Gauss rule by texcad.brep.uvstrips: checked at
    them, 3.09). Issue 28 asks for twice the STL: 1.99 here (2.22 with least-squares
    fits and edges fitted alone; 1.85 with the end rings' edges minimax-fitted within
    the whole tolerance, but OCCT's plain rule then missed a plate's volume by 0.14 %
    and a cylinder's by 0.27 %), the edges along the end faces least-squares fitted
    at their own knots (at even parameters OCCT's plain rule missed a plate's volume
    by 0.12 %)."""
    from build123d import Cylinder, GeomType

    cyl = Cylinder(10, 12)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    tx = texcad.texture(cyl, side, "builtin:stones", height=0.6, pitch=0.125)
    ratio, _ = _written(tx, tmp_path, "fine")
    assert ratio <= MOST, ratio


def test_sliver_tiles_are_not_merged(tmp_path):
    """A box's quarter-cylinder fillet textured in place ends in sliver tiles (the
    texture's walls, 1e-3 of a cell wide): merged with the full tiles beside them,
    OCCT's reader and mesher left the merged tile without triangles. Every face of
    the re-read STEP is meshed, and the shown mesh covers texcad's."""
    from build123d import Axis, Box, GeomType, fillet
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    from texcad.brep import faces_of

    box = fillet(Box(30, 20, 10).edges().filter_by(Axis.Z), 4)
    rounded = box.faces().filter_by(GeomType.CYLINDER)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        tx = texcad.texture(box, rounded, "builtin:diamond_knurl", height=0.8, pitch=0.5, mapping="angle",
                            build_dir=texcad.orientation(15, "+x"))  # fmt: skip
    tx.export(tmp_path / "fillet.step")
    back = texcad.io.read_step(tmp_path / "fillet.step")
    assert check_shape(back)["valid"]
    shown = shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5)
    assert all(BRep_Tool.Triangulation_s(f, TopLoc_Location()) is not None for f in faces_of(back))
    assert _distance(tx.mesh.vertices, shown) < 0.1 + 0.5  # OCCT's nodes sample the tiles: + the pitch


def test_exact_step_keeps_every_pole(plate, tmp_path):
    """At tolerance 0 (``write_step``'s default) every pole is written, within 5e-9 mm."""
    from OCP.BRep import BRep_Tool

    from texcad.brep import faces_of, tile_grid, to_topods

    texcad.io.write_step(plate.shape, tmp_path / "exact.step")
    back = texcad.io.read_step(tmp_path / "exact.step")
    grids = [tile_grid(BRep_Tool.Surface_s(f)) for f in faces_of(to_topods(plate.shape))]
    grids = sorted((g[0].shape, round(g[1][0], 6), round(g[2][0], 6), g) for g in grids if g is not None)
    written = []
    for f in faces_of(back):  # one per face
        s = BRep_Tool.Surface_s(f)
        if hasattr(s, "UDegree") and s.UDegree() == 1:
            written.append(((s.NbVPoles(), s.NbUPoles(), 3), round(s.UKnot(1), 6), round(s.VKnot(1), 6), s))
    written.sort(key=lambda w: w[:3])
    assert [w[:3] for w in written] == [g[:3] for g in grids]
    for (_, _, _, (g, _, _)), (_, _, _, s) in zip(grids, written):  # one per tile
        poles = np.array([[s.Pole(i + 1, j + 1).Coord() for i in range(s.NbUPoles())] for j in range(s.NbVPoles())])
        assert np.abs(poles - g).max() <= 5e-9


def test_edge_keeps_the_points_its_tiles_keep():
    """An edge's polyline (texcad.io.step_tiles._edge_fit) is, among those within the
    tolerance, the one whose points add the fewest rows and columns of poles to the
    tiles beside it: a straight edge with one kink that either of two points can hold
    takes the one the tiles keep already."""
    from texcad.io.step_tiles import _edge_fit

    t = np.arange(9, dtype=np.float64)
    pts = np.stack([t, np.zeros(9), np.zeros(9)], axis=-1)
    pts[4, 1] = 0.03  # a bump between two points: a polyline needs a point at 3, 4 or 5
    plain, _ = _edge_fit(pts, t, 0.02)
    for at in (3, 5):  # the tiles keep a row there already: nothing else is added
        new = np.ones(9)
        new[at] = 0.0
        sel, q = _edge_fit(pts, t, 0.02, new)
        assert at in sel and len(sel) <= len(plain) + 1, (sel, plain)
        miss = np.abs(np.interp(t, t[sel], q[:, 1]) - pts[:, 1]).max()
        assert miss <= 0.02 + 1e-12, miss


def test_minimax_fit_holds_where_least_squares_misses():
    """A polyline's inner points fitted by least squares miss a bump's top by more than
    the tolerance; Lawson's reweighting (texcad.io.step_tiles._minimax) brings every
    point within it: the fewer points the edge then keeps."""
    from texcad.io.step_tiles import _hats, _minimax

    t = np.arange(11, dtype=np.float64)
    pts = np.zeros((11, 3))
    pts[:, 0] = t
    pts[:, 2] = [0, 0, 0.02, 0.05, 0.1, 0.12, 0.1, 0.05, 0.02, 0, 0]  # a bump, mm
    kept = np.array([0, 3, 7, 10])
    h = _hats(t, kept)
    q = pts[kept].copy()
    q[1:-1] = np.linalg.lstsq(h[:, 1:-1], pts - h[:, [0, -1]] @ q[[0, -1]], rcond=None)[0]
    ls = np.sqrt(((h @ q - pts) ** 2).sum(-1)).max()
    got = _minimax(pts, h, pts[kept].copy(), 0.8 * ls)
    assert got is not None
    assert np.sqrt(((h @ got - pts) ** 2).sum(-1)).max() <= 0.8 * ls
    assert (got[[0, -1]] == pts[kept][[0, -1]]).all()  # the ends stay (other edges meet there)


def test_staircase_walls_joined_keep_the_solid():
    """Where a patch's outline crosses the grid (a box top and two mitred fillets) the
    writer joins its walls end to end (texcad.io.step_tiles._joined_walls): fewer
    faces, each joined wall a strip through its strips' columns that folds at the
    steps, the same solid (valid, closed, OCCT's volume the same to 1e-9 of it)."""
    from build123d import Box, GeomType, fillet
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
    from OCP.TopAbs import TopAbs_FACE

    from texcad.brep.occt import explore, to_topods
    from texcad.io.step_tiles import _folded, _grids, _is_wall, _joined_walls, _tiles_of

    part = fillet(Box(24, 18, 8).edges().group_by()[-1], 2)
    faces = [part.faces().sort_by()[-1], *part.faces().filter_by(GeomType.CYLINDER)[:2]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # turned 30 degrees off the box's edges (its default squares the texture with them)
        tx = texcad.texture(part, faces, "builtin:stones", height=0.4, pitch=0.5, rotation=-30)
    shape = to_topods(tx.shape)
    joined = _joined_walls(BRepBuilderAPI_Copy(shape, False, False).Shape())
    walls = [g for g in _grids(_tiles_of(joined)[1]) if _is_wall(*g)]
    folded = [g for g, _, _ in walls if _folded(g[0])]
    assert len(folded) > 5 and max(g.shape[1] for g in folded) > 10  # long walls folding along the staircase
    assert len(explore(joined, TopAbs_FACE)) < len(explore(shape, TopAbs_FACE)) - 100
    chk = check_shape(joined)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert occt_volume(joined) == pytest.approx(occt_volume(shape), rel=1e-9)


def test_merged_runs_start_at_the_same_grid_lines():
    """Rows of 4-cell tiles that start at different columns (a patch's outline crosses
    the grid in a staircase) are cut into merged runs at the same grid lines
    (texcad.io.step_tiles._blocks), so that the rows' runs lie one above the other and
    merge into one rectangle: without the blocks each row's runs start at its first
    tile (column 8, 4 and 0 here) and none lines up."""
    from texcad.io.step_tiles import _blocks, _chains

    cols = {0: [8, 12, 16, 20, 24, 28, 32], 1: [4, 8, 12, 16, 20, 24, 28, 32], 2: [0, 4, 8, 12, 16, 20, 24, 28, 32]}
    keys = [(r, c) for r, cs in cols.items() for c in cs]
    right = {(r, c): (r, c + 4) for r, c in keys if (r, c + 4) in keys}
    up = {(r, c): (r + 1, c) for r, c in keys if (r + 1, c) in keys}
    start, size = {k: k[1] for k in keys}, {k: 4 for k in keys}
    plain = _chains(right, size, 12)
    aligned = _chains(right, size, 12, _blocks(keys, [right, up], start, size, 12))

    def edges(runs):  # each row's runs: the columns they start at
        return {r: sorted({run[0][1] for run in runs if run[0][0] == r}) for r in cols}

    assert edges(plain) == {0: [8, 20, 32], 1: [4, 16, 28], 2: [0, 12, 24]}
    assert edges(aligned) == {0: [8, 16, 28], 1: [4, 16, 28], 2: [0, 4, 16, 28]}  # cut at 4 (where most rows
    # begin), 16, 28: the rows' runs from 16 on lie one above the other
    assert all(sum(size[k] for k in run) <= 12 for run in aligned)


def test_straight_pcurve_where_the_plain_rule_integrates_no_knot():
    """OCCT's plain volume rule integrates along an iso-u tile side and, at each of its
    points, along u from the tile's first knot to the side: a side needs its padded
    pcurve only where either range holds a knot of the tile as written."""
    from texcad.io.step_tiles import _kinked

    one, two, four = np.array([0.0, 1.0]), np.array([0.0, 1.0, 2.0]), np.arange(5.0)
    assert not _kinked(one, one, 1, 1.0, one)  # a one-cell tile's right side
    assert not _kinked(two, four, 1, 0.0, four)  # its first side: the range along u is empty
    assert not _kinked(two, four, 0, 2.0, two)  # along u: adds nothing
    assert _kinked(two, one, 1, 2.0, one)  # across a knot in u
    assert _kinked(one, two, 1, 1.0, two)  # along a knot in v
    assert not _kinked(one, four, 1, 1.0, four[1:3])  # a part of the side within one span


def test_dense_numbers_the_most_referred_first():
    """The DATA section renumbered by how often each entity is referred to (texcad.io.
    step_tiles._dense): the point four entities use gets #1, ties keep their order,
    the ids stay 1..n, a string with '#' and ';' in it is left alone, and the
    entities run end to end in lines of at most LINE characters, broken only after
    an entity's ';'."""
    from texcad.io.step_tiles import LINE, _dense

    body = (b"#7=PRODUCT('part #3; left','',(#9));\n#8=VECTOR('',#9,1.);\n#9=CARTESIAN_POINT('',(0.,0.,0.));\n"
            b"#10=EDGE_LOOP('',(#9,#9,#8));\n#11=CARTESIAN_POINT('',(1.,2.,3.));\n")
    out = _dense(body)
    assert out == (b"#3=PRODUCT('part #3; left','',(#1));#2=VECTOR('',#1,1.);#1=CARTESIAN_POINT('',(0.,0.,0.));"
                   b"#4=EDGE_LOOP('',(#1,#1,#2));#5=CARTESIAN_POINT('',(1.,2.,3.));\n")
    many = b"".join(b"#%d=CARTESIAN_POINT('',(%d.,0.,0.));\n" % (i, i) for i in range(1, 200))
    lines = _dense(many).split(b"\n")[:-1]
    assert all(len(line) <= LINE and line.endswith(b";") for line in lines) and len(lines) <= 50
    assert sorted(int(x) for x in re.findall(rb"#(\d+)=", _dense(many))) == list(range(1, 200))


def _rough_polylines(rng, n: int, m: int):
    """``m`` rough polylines of ``n`` points (mm) at uneven, increasing parameters
    (two equal where there are enough: a span of zero length)."""
    p = rng.normal(size=(n, m, 3)) * np.array([1.0, 1.0, 0.05])
    t = np.cumsum(rng.uniform(0.2, 2.0, n))
    if n > 5:
        t[4] = t[3]
    return p, t


def _misses_whole_square(p: np.ndarray, t: np.ndarray) -> np.ndarray | None:
    """texcad.io.step_tiles._misses as it was, over the whole (skipped point, chord
    end) square: the reference the faster one is compared with."""
    from texcad.io.step_tiles import SPAN

    n = len(t)
    w_ = min(n - 1, SPAN)
    if n <= 2 or n * w_**2 * p.shape[1] > 4_000_000:
        return None
    i = np.arange(n)[:, None, None]
    j = np.minimum(i + np.arange(1, w_ + 1)[None, None, :], n - 1)  # (i, 1, s): chords up to SPAN long
    k = np.minimum(i + np.arange(1, w_)[None, :, None], n - 1)  # (i, q, 1): the points they skip
    span = t[j] - t[i]  # 0 only for the last point's (empty) chords
    w = np.clip((t[k] - t[i]) / np.where(span > 0, span, 1.0), 0.0, 1.0)[..., None, None]  # (i, q, s, 1, 1)
    chord = p[i] * (1 - w) + p[j] * w  # (i, q, s, m, 3)
    d = np.sqrt(((chord - p[k]) ** 2).sum(-1)).max(-1)  # (i, q, s)
    return np.where(k < j, d, 0.0).max(1)  # (i, s): the chord from i, s + 1 points on, its largest miss


def _cheapest_per_point(ok: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """texcad.io.step_tiles._cheapest as it was (numpy per point): the reference."""
    n, w = len(cost), ok.shape[1]
    best, prev = np.full(n, np.inf), np.zeros(n, np.int64)
    best[0] = 0.0
    for j in range(1, n):  # one per point of the edge
        i = j - 1 - np.arange(w)
        s = np.flatnonzero((i >= 0) & ((i == j - 1) | ok[np.maximum(i, 0), np.arange(w)]))
        cand = i[s][::-1]  # the longest chord first
        at = cand[np.argmin(best[cand])]
        best[j], prev[j] = best[at] + cost[j], at
    kept = [n - 1]
    while kept[-1] > 0:  # one per kept point
        kept.append(int(prev[kept[-1]]))
    return np.asarray(kept[::-1])


def test_misses_over_the_pairs_that_count_are_the_whole_squares():
    """texcad.io.step_tiles._misses computes a chord's misses only over the points it
    skips (half of the (skipped point, chord end) square): the same numbers, bit for
    bit, as the whole square (as it was), on polylines shorter and longer
    than SPAN, one and several at once."""
    from texcad.io.step_tiles import SPAN, _misses

    rng = np.random.default_rng(7)
    for n in range(1, 3 * SPAN + 2):  # one per length
        for m in (1, 5):
            p, t = _rough_polylines(rng, n, m)
            got, want = _misses(p, t), _misses_whole_square(p, t)
            assert (got is None) == (want is None), n
            if want is not None:
                assert got.shape == want.shape and np.array_equal(got, want), n


def test_greedy_keeps_at_every_share_what_keep_keeps():
    """texcad.io.step_tiles._greedy (every tolerance at once, the chain of longest
    chords followed by pointer doubling) keeps the points _keep keeps one tolerance at
    a time, at each of a tile's shares (INNER_SHARES) of a tolerance."""
    from texcad.io.step_tiles import INNER_SHARES, _greedy, _keep, _misses

    rng = np.random.default_rng(8)
    for n in (1, 2, 3, 5, 9, 17, 25, 40):  # one per length
        for scale in (0.01, 0.1, 1.0):  # from keeping every point to keeping few
            p, t = _rough_polylines(rng, n, 3)
            p *= scale
            misses = _misses(p, t)
            tols = np.array([f * 0.05 for f in INNER_SHARES])
            on = _greedy(misses, n, tols)
            assert on.shape == (len(tols), n)
            for tol, row in zip(tols.tolist(), on):  # one per share
                assert np.array_equal(np.flatnonzero(row), _keep(p, t, tol, misses)), (n, scale, tol)


def test_weighted_pair_is_each_weighted_alone():
    """texcad.io.step_tiles._weighted_pair solves a tile's rows and columns together
    when their bases have the same shape: the same numbers, bit for bit, as
    _weighted for each, as when the shapes differ."""
    from texcad.io.step_tiles import _hats, _weighted, _weighted_pair

    rng = np.random.default_rng(9)
    t = np.arange(25, dtype=np.float64)
    for kv, ku in (([0, 3, 7, 12, 18, 24], [0, 2, 9, 13, 20, 24]), ([0, 5, 11, 24], [0, 4, 8, 16, 20, 24])):
        hv, hu = _hats(t, np.array(kv))[:, 1:-1], _hats(t, np.array(ku))[:, 1:-1]
        wv, wu = rng.uniform(1e-3, 1.0, 25), rng.uniform(1e-3, 1.0, 25)
        got = _weighted_pair(hv, wv, hu, wu)
        assert np.array_equal(got[0], _weighted(hv, wv)) and np.array_equal(got[1], _weighted(hu, wu))


def test_cheapest_chain_is_the_per_point_one():
    """texcad.io.step_tiles._cheapest (the chords into every point found at once, the
    recurrence on Python floats) keeps the chain the numpy-per-point dynamic
    programme keeps, ties to the longer chords included: edges of every length, from
    every chord holding to none, the tiles' costs per point (halves: 0.5 a point, one
    more per tile it adds a row or column to) and uneven ones."""
    from texcad.io.step_tiles import NEW_POINT, SPAN, _cheapest, _misses

    rng = np.random.default_rng(10)
    for n in (2, 3, 5, 9, 17, 25, 40):  # one per length
        for scale in (0.0, 0.01, 0.1, 1.0):
            p, t = _rough_polylines(rng, n, 1)
            misses = _misses(p * scale, t)
            if misses is None:
                misses = np.zeros((n, min(n - 1, SPAN)))
            ok = misses <= 0.05
            for cost in (NEW_POINT + rng.integers(0, 3, n).astype(np.float64), rng.uniform(0.1, 2.0, n)):
                assert np.array_equal(_cheapest(ok, cost), _cheapest_per_point(ok, cost)), (n, scale)
