"""STEP of texcad's texture tiles, written with numpy instead of OCCT's per-number writer.

OCCT's STEP writer formats every number on its own; for the demo plate (1089 tiles,
680 k poles, each also a node of the tile's stored triangulation) that was 8.5 s of
the 10 s write and 142 MB. Here OCCT writes everything but the tiles' poles and
triangulations: each degree-1 tile surface is swapped, in a topological copy of the
shape, for a 2 x 2-pole stand-in with the same parameter range (its edges get the
same pcurves on it), and the STEP text is then completed with numpy:

* the stand-in's ``B_SPLINE_SURFACE_WITH_KNOTS`` is rewritten with the tile's poles
  (``CARTESIAN_POINT`` entities: 8 decimals on the tile's border, 5e-9 mm, inside the
  edges' 1e-7 mm; 4 decimals inside, 5e-5 mm, far below any mesh tolerance; trailing
  zeros dropped; the stand-in's four corner points are the tile's corner poles) and
  knots;
* each tile that carries its triangulation (texcad's mesh: two triangles per grid
  cell) gets a ``COMPLEX_TRIANGULATED_FACE`` linked to its ``ADVANCED_FACE`` (AP242),
  with its nodes (``COORDINATES_LIST``, the same numbers as the poles, formatted
  once), no normals (optional in AP242; OCCT's viewers compute them) and its
  triangles as one strip per column of cells (two numbers per node instead of six);
* a ``TESSELLATED_SOLID`` per solid lists them, as OCCT's own writer does.

The stand-ins are matched to the STEP entities through the shells' face order and
checked by their corner points; anything unexpected returns None and the caller uses
OCCT's own writer.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from ..brep import surface_grid, tile_grid

__all__ = ["tiled_step_text"]

_ENTITY = re.compile(rb"#(\d+) = ([A-Z0-9_]*)\(([^;]*)\);")
_REF = re.compile(rb"#(\d+)")


def _real(v: float) -> str:
    """A STEP REAL (always with a decimal point), exact."""
    s = repr(float(v)).upper()
    mant, _, exp = s.partition("E")
    if "." not in mant:
        mant += "."
    return mant + ("E" + exp if exp else "")


def _reals(a) -> str:
    return ",".join(map(_real, np.asarray(a, np.float64).tolist()))  # per knot (tens per tile)


def _tiles_of(topo) -> tuple[list, list]:
    """Faces of ``topo`` in shell order (what OCCT's writer lists in each shell) and,
    for each degree-1 B-spline face without location, ``(index, face, surface)``."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    order, tiles = [], []
    exp = TopExp_Explorer(topo, TopAbs_SHELL)
    while exp.More():  # one per shell
        it = TopoDS_Iterator(exp.Current())
        while it.More():  # one per face
            face = TopoDS.Face_s(it.Value())
            surf = BRep_Tool.Surface_s(face)
            if (
                isinstance(surf, Geom_BSplineSurface)
                and surf.UDegree() == 1
                and surf.VDegree() == 1
                and face.Location().IsIdentity()
                and not surf.IsURational()
                and not surf.IsVRational()
                and not surf.IsUPeriodic()
                and not surf.IsVPeriodic()
                and surf.NbUKnots() == surf.NbUPoles()
                and surf.NbVKnots() == surf.NbVPoles()
            ):
                tiles.append((len(order), face, surf))
            order.append(face)
            it.Next()
        exp.Next()
    return order, tiles


def _stand_in(b, face, surf) -> None:
    """Swap the face's surface for a 2 x 2-pole degree-1 surface over the same
    parameter range (corner poles kept), with its edges' pcurves re-attached."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TColgp import TColgp_Array2OfPnt
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    nu, nv = surf.NbUPoles(), surf.NbVPoles()
    poles = TColgp_Array2OfPnt(1, 2, 1, 2)
    for i, ii in ((1, 1), (2, nu)):  # the four corners
        for j, jj in ((1, 1), (2, nv)):
            poles.SetValue(i, j, surf.Pole(ii, jj))
    uk, vk, mult = TColStd_Array1OfReal(1, 2), TColStd_Array1OfReal(1, 2), TColStd_Array1OfInteger(1, 2)
    uk.SetValue(1, surf.UKnot(1))
    uk.SetValue(2, surf.UKnot(nu))
    vk.SetValue(1, surf.VKnot(1))
    vk.SetValue(2, surf.VKnot(nv))
    mult.SetValue(1, 2)
    mult.SetValue(2, 2)
    stand = Geom_BSplineSurface(poles, uk, vk, mult, mult, 1, 1)
    curves = []
    exp = TopExp_Explorer(face, TopAbs_EDGE)
    while exp.More():  # one per edge (a seam twice)
        e = TopoDS.Edge_s(exp.Current())
        if BRep_Tool.IsClosed_s(e, face):
            c1 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD)), face, 0.0, 0.0)
            c2 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(e.Oriented(TopAbs_REVERSED)), face, 0.0, 0.0)
            curves.append((e, c1, c2))
        else:
            curves.append((e, BRep_Tool.CurveOnSurface_s(e, face, 0.0, 0.0), None))
        exp.Next()
    b.UpdateFace(face, stand, TopLoc_Location(), BRep_Tool.Tolerance_s(face))
    for e, c1, c2 in curves:  # one per edge
        if c1 is None:
            raise ValueError("edge without pcurve")
        if c2 is None:
            b.UpdateEdge(e, c1, face, BRep_Tool.Tolerance_s(e))
        else:
            b.UpdateEdge(e, c1, c2, face, BRep_Tool.Tolerance_s(e))


def _grids(tiles: list) -> list:
    """Each tile's ``(grid, u, v)``: remembered by texcad (:func:`texcad.brep.tile_grid`)
    or read from OCCT."""
    out = []
    for _, _, surf in tiles:  # one per tile
        got = tile_grid(surf)
        out.append(got if got is not None else surface_grid(surf))
    return out


def _carries_grid_mesh(face, rows: int, cols: int) -> bool:
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
    return tri is not None and tri.NbNodes() == rows * cols and tri.NbTriangles() == 2 * (rows - 1) * (cols - 1)


def _mults(n: int) -> str:
    return "2" if n == 1 else "2," + "1," * (n - 2) + "2"


def _grid_ids_template(cols: int, rows: int) -> str:
    return "(" + "),(".join([",".join(["#%d"] * rows)] * cols) + ")"


def _strips_text(rows: int, cols: int) -> str:
    """The triangles of :func:`texcad.solid.grid_faces` (``rows x cols`` nodes,
    row-major, 1-based: the same cells, diagonals and orientation) as one triangle
    strip per column of cells, two numbers per node instead of six.

    The order is the one OCCT's STEP reader turns into counter-clockwise triangles
    (``StepToTopoDS_TranslateFace``: ``(s1, s3, s2), (s2, s3, s4), ...``): the strip of
    cell column c runs up the rows as ``(r, c + 1), (r, c)``."""
    a = np.arange(rows)[None, :] * cols + np.arange(cols - 1)[:, None] + 1  # (c, r) -> node (r, c)
    strips = np.stack([a + 1, a], axis=-1).reshape(cols - 1, 2 * rows)
    one = "(" + ",".join(["%d"] * (2 * rows)) + ")"
    return ",".join([one] * (cols - 1)) % tuple(strips.ravel().tolist())


def _border(rows: int, cols: int) -> np.ndarray:
    """True for the nodes of a ``rows x cols`` tile grid on its border, u-major
    (index ``c * rows + r``)."""
    on = np.zeros((cols, rows), bool)
    on[[0, -1], :], on[:, [0, -1]] = True, True
    return on.ravel()


_TRAILING = re.compile(r"(\.\d*?)0+(?=[,\n])")


def _tokens(p: np.ndarray, decimals: int) -> np.ndarray:
    """``"x,y,z"`` per point with ``decimals`` decimals, trailing zeros dropped."""
    if not len(p):
        return np.empty(0, dtype=object)
    fmt = f"%.{decimals}f,%.{decimals}f,%.{decimals}f\n"
    text = _TRAILING.sub(r"\1", (fmt * len(p)) % tuple(p.ravel().tolist()))
    return np.array(text.split("\n")[:-1], dtype=object)


def tiled_step_text(topo: Any, occt_write) -> bytes | None:
    """STEP text of ``topo`` whose texture tiles' poles and triangulations are written
    with numpy (see the module docstring).

    Args:
        topo: ``TopoDS_Shape`` (not changed: the stand-ins go into a topological copy).
        occt_write: ``occt_write(shape) -> bytes``, OCCT's AP242 writer without
            tessellation.

    Returns:
        The STEP bytes, or None where this does not apply or a check fails (write
        with OCCT's own writer then).
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy

    order0, tiles0 = _tiles_of(topo)
    if not tiles0:
        return None
    copy = BRepBuilderAPI_Copy(topo, False, False).Shape()  # new topology, the same geometry
    order, tiles = _tiles_of(copy)
    if len(order) != len(order0) or [t[0] for t in tiles] != [t[0] for t in tiles0]:
        return None
    grids = _grids(tiles)
    if any(g is None for g in grids):
        return None
    meshed = [_carries_grid_mesh(f, g[0].shape[0], g[0].shape[1]) for (_, f, _), g in zip(tiles0, grids)]
    b = BRep_Builder()
    try:
        for _, face, surf in tiles:  # one per tile
            _stand_in(b, face, surf)
    except ValueError:
        return None
    data = occt_write(copy)
    return _complete(data, len(order), tiles, grids, meshed)


def _layout(ents: dict):
    """Faces of the shells in order, the shell of each face, the solid of each shell
    and the shape representation of each solid, from OCCT's STEP entities."""
    face_ids, shell_of, msb, absr = [], {}, {}, []
    for eid in sorted(ents):  # one per entity
        m = ents[eid]
        if m.group(2) in (b"CLOSED_SHELL", b"OPEN_SHELL"):
            refs = [int(r) for r in _REF.findall(m.group(3))]
            face_ids += refs
            shell_of.update((r, eid) for r in refs)
        elif m.group(2) == b"MANIFOLD_SOLID_BREP":
            msb[int(_REF.findall(m.group(3))[0])] = eid
        elif m.group(2) == b"ADVANCED_BREP_SHAPE_REPRESENTATION":
            absr.append(eid)
    absr_of = {int(r): eid for eid in absr for r in _REF.findall(ents[eid].group(3))}  # item -> representation
    return face_ids, shell_of, msb, absr_of


def _stand_in_ids(ents: dict, face: int, pts: np.ndarray, corners: list) -> tuple[int, list] | None:
    """The stand-in surface entity of the ``ADVANCED_FACE`` ``face`` and its four
    corner point entities, checked against the tile's corner poles ``pts[corners]``."""
    fm = ents.get(face)
    if fm is None or fm.group(2) != b"ADVANCED_FACE":
        return None
    sid = int(_REF.findall(fm.group(3))[-1])
    sm = ents.get(sid)
    if sm is None or sm.group(2) != b"B_SPLINE_SURFACE_WITH_KNOTS":
        return None
    corner_ids = [int(r) for r in _REF.findall(sm.group(3))]
    if len(corner_ids) != 4:
        return None
    for cid, at in zip(corner_ids, corners):  # the four corners
        cm = ents.get(cid)
        if cm is None or cm.group(2) != b"CARTESIAN_POINT":
            return None
        xyz = np.array(cm.group(3).split(b"(")[1].split(b")")[0].split(b","), np.float64)
        if np.abs(xyz - pts[at]).max() > 1e-6 * (1.0 + np.abs(pts[at]).max()):
            return None
    return sid, corner_ids


def _complete(data: bytes, n_faces: int, tiles: list, grids: list, meshed: list) -> bytes | None:
    """Rewrite the stand-in surfaces of OCCT's STEP text ``data`` with the tiles' poles
    and add their triangulations; None when the text is not laid out as expected."""
    ents = {int(m.group(1)): m for m in _ENTITY.finditer(data)}
    face_ids, shell_of, msb, absr_of = _layout(ents)
    if len(face_ids) != n_faces:
        return None
    pts = np.concatenate([g.transpose(1, 0, 2).reshape(-1, 3) for g, _, _ in grids])
    # Each pole formatted once, for its point and its mesh node: on the tile's border
    # (on its edges' curves) 8 decimals (5e-9 mm, inside the edges' 1e-7 mm), inside
    # 4 decimals (5e-5 mm, far below any mesh tolerance).
    border = np.concatenate([_border(g.shape[0], g.shape[1]) for g, _, _ in grids])
    tok = np.empty(len(pts), dtype=object)
    tok[border], tok[~border] = _tokens(pts[border], 8), _tokens(pts[~border], 4)
    ids, emit = np.zeros(len(pts), np.int64), np.ones(len(pts), bool)
    swaps, tess = {}, []
    off = 0
    for (k, _, _), (g, u, v), mesh in zip(tiles, grids, meshed):  # one per tile
        rows, cols = g.shape[:2]
        corners = [off, off + rows - 1, off + (cols - 1) * rows, off + cols * rows - 1]  # u-major
        got = _stand_in_ids(ents, face_ids[k], pts, corners)
        if got is None:
            return None
        ids[corners], emit[corners] = got[1], False
        swaps[got[0]] = (off, rows, cols, u, v)
        if mesh:
            if absr_of.get(msb.get(shell_of.get(face_ids[k], -1), -1)) is None:
                return None
            tess.append((face_ids[k], off, rows, cols))
        off += rows * cols
    next_id = max(ents) + 1
    n_emit = int(emit.sum())
    ids[emit] = next_id + np.arange(n_emit)
    inter = [None] * (2 * n_emit)
    inter[0::2], inter[1::2] = ids[emit].tolist(), tok[emit].tolist()
    new = [("#%d=CARTESIAN_POINT('',(%s));\n" * n_emit) % tuple(inter)]
    repl = _surfaces_text(swaps, ids)
    new_ids, items = _tessellation_text(tess, tok, next_id + n_emit, shell_of, msb, new)
    for rep in sorted({absr_of[solid] for solid, _ in items}):  # one per shape representation
        mine = [t for solid, t in items if absr_of[solid] == rep]
        refs = [int(r) for r in _REF.findall(ents[rep].group(3))]
        ctx, listed = refs[-1], ",".join(f"#{r}" for r in refs[:-1] + mine)
        repl[rep] = f"#{rep} = ADVANCED_BREP_SHAPE_REPRESENTATION('',({listed}),#{ctx});"
        new.append(f"#{new_ids} = TESSELLATED_SHAPE_REPRESENTATION('',({','.join(f'#{r}' for r in mine)}),#{ctx});\n")
        new_ids += 1
    end = data.rindex(b"ENDSEC;")
    chunks, at = [], 0
    for eid in sorted(repl, key=lambda e: ents[e].start()):  # one per rewritten entity
        chunks += [data[at : ents[eid].start()], repl[eid].encode("ascii")]
        at = ents[eid].end()
    if at > end:
        return None
    return b"".join(chunks + [data[at:end], "".join(new).encode("ascii"), data[end:]])


def _surfaces_text(swaps: dict, ids: np.ndarray) -> dict:
    """``{surface entity: its B_SPLINE_SURFACE_WITH_KNOTS text}`` with the tiles'
    pole ids (u-major) and knots."""
    repl, templates = {}, {}
    for sid, (o, rows, cols, u, v) in swaps.items():  # one per tile
        if (cols, rows) not in templates:
            templates[cols, rows] = _grid_ids_template(cols, rows)
        poles = templates[cols, rows] % tuple(ids[o : o + rows * cols].tolist())
        repl[sid] = (
            f"#{sid} = B_SPLINE_SURFACE_WITH_KNOTS('',1,1,({poles}),\n  .UNSPECIFIED.,.F.,.F.,.F.,({_mults(cols)}),"
            f"({_mults(rows)}),({_reals(u)}),({_reals(v)}),.UNSPECIFIED.);"
        )
    return repl


def _tessellation_text(tess: list, tok: np.ndarray, next_id: int, shell_of: dict, msb: dict, new: list):
    """Append ``COORDINATES_LIST`` + ``TRIANGULATED_FACE`` per triangulated tile and a
    ``TESSELLATED_SOLID`` per solid to ``new``; returns the next free id and the
    ``(solid, tessellated solid)`` ids."""
    tri_text, by_solid = {}, {}
    for face, o, rows, cols in tess:  # one per triangulated tile
        if (rows, cols) not in tri_text:
            tri_text[rows, cols] = _strips_text(rows, cols)
        node = o + (np.arange(cols)[None, :] * rows + np.arange(rows)[:, None]).ravel()  # row-major nodes
        cid, tid = next_id, next_id + 1
        next_id += 2
        new.append(f"#{cid}=COORDINATES_LIST('',{rows * cols},(({'),('.join(tok[node].tolist())})));\n")
        new.append(
            f"#{tid}=COMPLEX_TRIANGULATED_FACE('',#{cid},{rows * cols},(),#{face},(),({tri_text[rows, cols]}),());\n"
        )
        by_solid.setdefault(msb[shell_of[face]], []).append(tid)
    items = []
    for solid, tfs in by_solid.items():  # one per solid
        new.append(f"#{next_id} = TESSELLATED_SOLID('',({','.join(f'#{t}' for t in tfs)}),#{solid});\n")
        items.append((solid, next_id))
        next_id += 1
    return next_id, items
