"""STEP (AP214, mm) for CAD programs: written atomically, silently and reproducibly,
read back as one OCP shape.
"""

from __future__ import annotations

import io
import os
import re
from typing import Any

from ..errors import GeometryError, InputError
from ..brep import to_topods
from ..util import atomic_path
from .step_tiles import tiled_step_text

__all__ = ["write_step", "read_step"]


# -- STEP ----------------------------------------------------------------------------------------
class _Quiet:
    """Detach OCCT's message printers (the STEP translator prints banners to stdout)
    for the duration of a ``with`` block."""

    def __enter__(self):
        from OCP.Message import Message

        self.messenger = Message.DefaultMessenger_s()
        printers = self.messenger.Printers()
        self.saved = [printers.Value(i) for i in range(1, printers.Length() + 1)]  # one per printer
        for p in self.saved:
            self.messenger.RemovePrinter(p)
        return self

    def __exit__(self, *exc):
        for p in self.saved:
            self.messenger.AddPrinter(p)
        return False


_PRODUCT = re.compile(rb"PRODUCT\('[^']*',\s*'[^']*'")


def _ascii(text: str) -> str:
    return re.sub(r"[^ -~]", "_", str(text)).replace("'", "_").replace(";", "_")


def write_step(shape: Any, path: str | os.PathLike, *, name: str = "texcad part", tessellated: bool | None = None,
               tolerance: float = 0.0) -> None:
    """Write a shape as a STEP file in mm (atomic, silent, reproducible).

    The header's time stamp is fixed (1980-01-01, as in texcad's 3MF) and the product
    is named ``name`` instead of OCCT's per-session counter, so the same shape gives
    the same bytes.

    texcad's texture tiles (degree-1 B-spline faces through the texture's grid, see
    :func:`texcad.brep.tiled_grid_faces`) are written with numpy
    (:mod:`texcad.io.step_tiles`): every point once, shared by the tiles and edges
    that meet there. With ``tolerance`` > 0 (what :meth:`texcad.Textured.export`
    passes: the mesh's tolerance) a tile keeps only the rows and columns of poles,
    and an edge between tiles only the points, needed to stay within ``tolerance``
    of every grid point, with 3 decimals inside the tiles at 0.02 mm: a plain AP214
    B-rep; its size against the binary STL at the same tolerance is in
    ``docs/benchmarks/step.md``.

    ``tessellated=True`` adds each tile's triangulation (texcad's grid mesh) as AP242
    tessellated geometry (``COMPLEX_TRIANGULATED_FACE`` next to the B-spline face):
    OCCT's STEP reader attaches it to the face again and its mesher
    (``BRepMesh_IncrementalMesh``, what CQ-editor, ocp_vscode and FreeCAD run to show a
    part) keeps it instead of meshing the tiles, in a larger file (every pole, and
    every pixel twice). The schema is then AP242
    (``AP242_MANAGED_MODEL_BASED_3D_ENGINEERING``), else AP214.

    Args:
        shape: build123d / CadQuery object or ``TopoDS_Shape``.
        path: output ``.step`` / ``.stp`` file.
        name: product name shown by CAD programs (ASCII).
        tessellated: write the tiles' triangulations (default False).
        tolerance: mm, how far the written tiles may lie from their grid points
            (0: the exact B-rep, every number as OCCT holds it).

    Raises:
        GeometryError: OCCT could not translate or write the shape.
    """
    topo = to_topods(shape)
    label = _ascii(name)
    tessellated = bool(tessellated) and _has_tiles(topo)
    data = tiled_step_text(
        topo, lambda s: _occt_step(s, label, tessellated=False, ap242=tessellated, path=path),
        tessellate=tessellated, tolerance=float(tolerance),
    )  # fmt: skip
    if data is None:
        if tessellated:
            _keep_tile_meshes(topo)
        data = _occt_step(topo, label, tessellated=tessellated, ap242=tessellated, path=path)
    head, tail = data[:8192], data[8192:]
    head = _PRODUCT.sub(f"PRODUCT('{label}','{label}'".encode("ascii"), head, count=1)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(head)
            fh.write(tail)


def _occt_step(topo, label: str, *, tessellated: bool, ap242: bool, path) -> bytes:
    """OCCT's STEP text of ``topo`` in mm with texcad's fixed header; ``tessellated``:
    the faces' triangulations too; ``ap242``: schema AP242 (else AP214)."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Controller, STEPControl_Writer
    from OCP.TCollection import TCollection_HAsciiString

    with _Quiet():
        STEPControl_Controller.Init_s()
        Interface_Static.SetCVal_s("write.step.unit", "MM")
        saved = Interface_Static.IVal_s("write.step.tessellated"), Interface_Static.IVal_s("write.step.schema")
        # 1: triangulations written along with the B-rep; 0: not at all. Schema 5: AP242.
        Interface_Static.SetIVal_s("write.step.tessellated", 1 if tessellated else 0)
        if ap242:
            Interface_Static.SetIVal_s("write.step.schema", 5)
        try:
            writer = STEPControl_Writer()
            ok = writer.Transfer(topo, STEPControl_AsIs) == IFSelect_RetDone
        finally:
            Interface_Static.SetIVal_s("write.step.tessellated", saved[0])
            Interface_Static.SetIVal_s("write.step.schema", saved[1])
        if not ok:
            raise GeometryError("OCCT could not translate the shape to STEP")
        header = APIHeaderSection_MakeHeader(writer.Model())
        header.SetName(TCollection_HAsciiString(label))
        header.SetTimeStamp(TCollection_HAsciiString("1980-01-01T00:00:00"))
        header.SetOriginatingSystem(TCollection_HAsciiString("texcad"))
        header.SetAuthorValue(1, TCollection_HAsciiString(""))
        header.SetOrganizationValue(1, TCollection_HAsciiString(""))
        header.Apply(writer.Model())
        buf = io.BytesIO()
        if writer.WriteStream(buf) != IFSelect_RetDone:
            raise GeometryError(f"OCCT could not write the STEP data for {os.fspath(path)!r}")
    return buf.getvalue()


def _has_tiles(topo) -> bool:
    """Does a face of ``topo`` carry a triangulation on a degree-1 B-spline surface (a
    texcad texture tile)?"""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    exp = TopExp_Explorer(topo, TopAbs_FACE)
    while exp.More():  # one per face, until the first tile
        face = TopoDS.Face_s(exp.Current())
        surf = BRep_Tool.Surface_s(face)
        if isinstance(surf, Geom_BSplineSurface) and surf.UDegree() == 1 and surf.VDegree() == 1:
            if BRep_Tool.Triangulation_s(face, TopLoc_Location()) is not None:
                return True
        exp.Next()
    return False


def _keep_tile_meshes(topo) -> None:
    """Drop the triangulations a STEP file must not carry: those of faces that are not
    texcad tiles (OCCT's own meshes, e.g. of the untouched faces, made by an earlier
    tessellation) and of located faces (OCCT's writer stores their nodes without the
    location). The faces are the same; OCCT meshes them again on reading."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    builder = BRep_Builder()
    exp = TopExp_Explorer(topo, TopAbs_FACE)
    while exp.More():  # one per face
        face = TopoDS.Face_s(exp.Current())
        exp.Next()
        if BRep_Tool.Triangulation_s(face, TopLoc_Location()) is None:
            continue
        surf = BRep_Tool.Surface_s(face)
        tile = isinstance(surf, Geom_BSplineSurface) and surf.UDegree() == 1 and surf.VDegree() == 1
        if not tile or not face.Location().IsIdentity():
            builder.UpdateFace(face, None)


def read_step(path: str | os.PathLike):
    """Read a STEP file (silently) into one ``TopoDS_Shape`` (mm).

    Raises:
        InputError: missing or unreadable file.
    """
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    p = os.fspath(path)
    if not os.path.isfile(p):
        raise InputError(f"STEP file {p!r} does not exist")
    with _Quiet():
        reader = STEPControl_Reader()
        if reader.ReadFile(p) != IFSelect_RetDone:
            raise InputError(f"cannot read {p!r} as STEP")
        reader.TransferRoots()
        shape = reader.OneShape()
    if shape.IsNull():
        raise InputError(f"{p!r} holds no shape")
    return shape
