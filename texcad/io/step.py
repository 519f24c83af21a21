"""STEP (AP214, mm) for CAD programs: written atomically, silently and reproducibly,
read back as one OCP shape.
"""

from __future__ import annotations

import io
import os
import re
from typing import Any

import numpy as np

from ..errors import GeometryError, InputError
from ..brep import compound, to_topods
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
    that meet there, the same geometry once, entities numbered densely. With
    ``tolerance`` > 0 (what :meth:`texcad.Textured.export` passes: the mesh's
    tolerance) a tile keeps only the rows and columns of poles, and an edge between
    tiles (or a tile and a planar face) only the points, needed to stay within
    ``tolerance`` of every grid point (least-squares fitted),
    with 3 decimals inside the tiles at 0.02 mm: a plain AP214 B-rep; its size against the
    binary STL at the same tolerance is in ``docs/benchmarks/step.md``.

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
            (0: every pole, to 5e-9 mm; the part's other faces as OCCT writes them).

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
    """Read a STEP file (silently) into one ``TopoDS_Shape`` (mm), strictly.

    OCCT's reader is lenient: it skips what it cannot parse, leaves an unresolved
    ``#N`` reference empty and reads a malformed number as nothing, and its translator
    then makes a part with holes in it, or loops or crashes on the empty places. So
    the file is refused, before the translation, when OCCT's parser reports a syntax
    error (a file cut short, a missing ``ENDSEC;``, an unbalanced parenthesis) or an
    entity it could not load (a number that is not a real, such as ``nan`` or
    ``1e999``; a reference to a missing entity or to one of the wrong type; a wrong
    count of parameters), and after it when the part holds no faces or a coordinate
    beyond :data:`MAX_COORDINATE_MM`.

    Raises:
        InputError: missing, empty, unreadable or damaged file, naming the line and
            the entity (``#N``) where OCCT found the fault.
    """
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    p = os.fspath(path)
    if not os.path.isfile(p):
        raise InputError(f"STEP file {p!r} does not exist; check the path")
    if os.path.getsize(p) == 0:
        raise InputError(f"STEP file {p!r} is empty (0 bytes); export the part again")
    twice = _label_fault(p)
    if twice:
        raise InputError(twice)
    with _Quiet() as quiet, _FailLog(quiet) as log:
        reader = STEPControl_Reader()
        status = reader.ReadFile(p)
    if status != IFSelect_RetDone or reader.StepModel() is None:
        raise InputError(_syntax_message(p, log.text))
    fault = _text_fault(p) or _first_fault(reader, p)  # the text check names a damaged pcurve more exactly
    if fault:
        raise InputError(fault)
    with _Quiet():
        reader.TransferRoots()
        shape = reader.OneShape()
    if shape.IsNull():
        raise InputError(f"STEP file {p!r} holds no shape OCCT can translate (no solid, shell or face); "
                         "export the part again as a solid body (STEP AP214 or AP242)")
    _check_shape(shape, p)
    return closed_shells_as_solids(shape)


def closed_shells_as_solids(shape, tolerance: float = 1e-3):
    """``shape`` with its closed shells made solids when it holds no solid: converters
    from meshes and some surface modellers write a body as a shell, or as faces that
    share no edges (a shell per triangle). The faces are sewn first when some shell is
    open (``BRepBuilderAPI_Sewing``, ``tolerance`` mm); each closed shell becomes a
    solid (``BRepBuilderAPI_MakeSolid``, turned outward by
    ``BRepLib::OrientClosedSolid``) that ``BRepCheck`` accepts, and faces on one
    surface are merged (:func:`_unified`). A shape with a solid, or with no closed
    shell even after sewing, is returned as it is."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    if TopExp_Explorer(shape, TopAbs_SOLID).More():
        return shape
    shells = _shells(shape)
    if not shells or not all(sh.Closed() for sh in shells):
        sewing = BRepBuilderAPI_Sewing(tolerance)
        sewing.Add(shape)
        sewing.Perform()
        shells = _shells(sewing.SewedShape())
    solids = [s for s in map(_solid_of, shells) if s is not None]
    return _unified(compound(solids)) if solids else shape


def _unified(shape):
    """``shape`` with the faces that lie on one plane or surface and meet along edges
    merged (``ShapeUpgrade_UnifySameDomain``): a mesh converted to STEP has a face per
    triangle, and its top should be one face to pick and texture. Kept as it was if the
    merged shape is not valid."""
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain

    unify = ShapeUpgrade_UnifySameDomain(shape, True, True, False)
    unify.Build()
    out = unify.Shape()
    return out if not out.IsNull() and BRepCheck_Analyzer(out).IsValid() else shape


def _shells(shape) -> list:
    """The shells of ``shape`` (OCP ``TopoDS_Shell``), with ``Closed()`` set from their
    free edges (``BRep_Tool::IsClosed``)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(shape, TopAbs_SHELL)
    while ex.More():  # per shell
        sh = TopoDS.Shell_s(ex.Current())
        sh.Closed(BRep_Tool.IsClosed_s(sh))
        out.append(sh)
        ex.Next()
    return out


def _solid_of(shell):
    """A closed shell as a valid outward solid, or None."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeSolid
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.BRepLib import BRepLib

    if not shell.Closed():
        return None
    solid = BRepBuilderAPI_MakeSolid(shell).Solid()
    return solid if BRepLib.OrientClosedSolid_s(solid) and BRepCheck_Analyzer(solid).IsValid() else None


#: mm; a STEP coordinate farther from the origin is refused (a damaged number: no
#: printable part is a kilometre across).
MAX_COORDINATE_MM = 1.0e6

_FIX = "the file is damaged; export the part again from its CAD program (STEP AP214 or AP242)"


class _FailLog:
    """OCCT's parser messages of gravity Fail and above (syntax errors with their line)
    written to a temporary file for the duration of a ``with`` block (inside
    :class:`_Quiet`, which detached the other printers)."""

    def __init__(self, quiet: _Quiet):
        self.quiet = quiet
        self.text = ""

    def __enter__(self):
        import tempfile

        from OCP.Message import Message_Gravity, Message_PrinterOStream

        fd, self.path = tempfile.mkstemp(prefix="texcad-step-", suffix=".log")
        os.close(fd)
        self.printer = Message_PrinterOStream(self.path, False, Message_Gravity.Message_Fail)
        self.printer.SetToColorize(False)
        self.quiet.messenger.AddPrinter(self.printer)
        return self

    def __exit__(self, *exc):
        self.quiet.messenger.RemovePrinter(self.printer)
        del self.printer  # closes the file
        try:
            with open(self.path, encoding="latin-1") as fh:
                self.text = fh.read(65536)
        finally:
            os.unlink(self.path)
        return False


def _syntax_message(p: str, log: str) -> str:
    """What is wrong with a STEP file OCCT's parser refused, with the line."""
    with open(p, "rb") as fh:
        head = fh.read(4096).lstrip()
    if not head.startswith(b"ISO-10303-21"):
        return (f"{p!r} is not a STEP file (it does not start with 'ISO-10303-21;'); give a .step / .stp file "
                "exported from a CAD program")
    found = re.search(r"Line (\d+):\s*(.*?)\s*\*{0,4}\s*$", log, re.M)
    where = f" at line {found.group(1)}: {found.group(2)}" if found else ""
    size = os.path.getsize(p)
    with open(p, "rb") as fh:
        fh.seek(max(size - 4096, 0))
        tail = fh.read()
    if b"END-ISO-10303-21" not in tail:
        return f"STEP file {p!r} is cut short (it does not end with 'END-ISO-10303-21;'){where}; {_FIX}"
    return f"STEP file {p!r} has a syntax error{where}; {_FIX}"


def _first_fault(reader, p: str) -> str | None:
    """The message for the first fault OCCT's parser recorded (a syntax error it read
    past, an entity it could not load), naming its line and entity, or None."""
    checks = reader.WS().ModelCheckList(True)
    faults = {}  # entity number in the model (0: the file) -> OCCT's messages
    checks.Start()
    while checks.More():  # per entity with a check
        check = checks.Value()
        if check.HasFailed():
            faults.setdefault(checks.Number(), []).extend(check.CFail(i) for i in range(1, check.NbFails() + 1))
        checks.Next()
    if not faults:
        return None
    general = [g for g in faults.pop(0, []) if not _HEADER_FAULT.search(g)]  # the header's names carry no shape
    if not faults and not general:
        return None
    if not faults:  # a syntax error the parser read past
        found = next((m for m in map(re.compile(r"Line (\d+):\s*(.*)").search, general) if m), None)
        where = f"a syntax error at line {found.group(1)}: {found.group(2).strip()}" if found else f"a fault: {general[0]}"
        return f"STEP file {p!r} has {where}; {_FIX}"
    ents = _entities(p, faults)
    harmless = {k for k, (_, _, kinds, default_unit) in ents.items() if default_unit or _METADATA.search(kinds)}
    harmless |= {k for k, said in faults.items() if all(map(_NAME_FAULT.search, said))}
    shape_faults = [k for k in sorted(faults) if k not in harmless]
    if not shape_faults:  # only styles, colours, product data... at fault: the shape itself reads whole
        return None
    n = shape_faults[0]
    label, line, _, _ = ents.get(n, (None, 0, "", False))
    what = "; ".join(dict.fromkeys(faults[n]))
    missing = [m.group(1) for m in (re.search(rf"Ent\.Id\.{label}\b.*\(Id\.(#\d+)\)", g) for g in general) if m]
    if label and missing:
        what += f" ({label} refers to {', '.join(missing)}, which the file does not define)"
    where = f"entity {label} (line {line})" if label else f"entity number {n} of the DATA section"
    more = f" ({len(faults) - 1} more entities have faults)" if len(faults) > 1 else ""
    return f"STEP file {p!r}: {where} cannot be read: {what}{more}; {_FIX}"


_NAME = rb"\s*\(\s*'[^']*'\s*,\s*"
_EXPONENT = re.compile(rb"[eE]\+?[0-9]{3,}")  # a plain search, fast on a large file
_HUGE = re.compile(rb"[-+]?[0-9]*\.?[0-9]*[eE]\+?[0-9]{3,}(?![0-9])")
_POINT = re.compile(rb"#([0-9]+)\s*=\s*(CARTESIAN_POINT|DIRECTION)" + _NAME + rb"\(([^()]*)\)")
_PCURVE = re.compile(rb"DEFINITIONAL_REPRESENTATION" + _NAME + rb"\(([^()]*)\)")
_KIND = re.compile(rb"#([0-9]+)\s*=\s*([A-Z_0-9]+)")
_DEFINED = re.compile(rb"#([0-9]+)\s*=")
_PCURVE_WHOLE = re.compile(rb"DEFINITIONAL_REPRESENTATION\s*\(\s*'(?:[^']|'')*'\s*,\s*\(\s*#[0-9]+(?:\s*,\s*#[0-9]+)*\s*\)"
                           rb"\s*,\s*#[0-9]+\s*\)")
_CURVES = {b"LINE", b"CIRCLE", b"ELLIPSE", b"PARABOLA", b"HYPERBOLA", b"POLYLINE", b""}  # b"": a complex entity
_NOT_CURVES = {b"EDGE_CURVE", b"SURFACE_CURVE", b"SEAM_CURVE", b"INTERSECTION_CURVE"}  # topology, 3D
_USER_3D = re.compile(rb"(VERTEX_POINT|AXIS2_PLACEMENT_3D)" + _NAME + rb"(#[0-9]+)(?:\s*,\s*(#[0-9]+|\$)\s*,\s*(#[0-9]+|\$))?")


def _label_fault(p: str) -> str | None:
    """An entity label (``#N =``) the file defines twice, which OCCT's parser does not
    refuse: once it has read another file in the process, it loops for ever in
    ``StepData_StepReaderData::SetEntityNumbers`` on it (found by fuzzing,
    ``tests/io/test_fuzz.py``). One regular expression over the bytes."""
    with open(p, "rb") as fh:
        data = fh.read()
    found = list(_DEFINED.finditer(data))
    labels = np.array([m.group(1) for m in found], dtype=bytes).astype(np.int64) if found else np.zeros(0, np.int64)
    _, first, count = np.unique(labels, return_index=True, return_counts=True)
    if not (count > 1).any():
        return None
    again = np.flatnonzero(labels == labels[first[count > 1][0]])[:2]
    lines = [data.count(b"\n", 0, found[k].start()) + 1 for k in again]
    return (f"STEP file {p!r}: #{labels[again[0]]} is defined twice (lines {lines[0]} and {lines[1]}); "
            f"the file is damaged; {_FIX}")


def _text_fault(p: str) -> str | None:
    """Faults OCCT's parser lets through and its translator crashes or loops on: a
    number of 1e100 or more (``-1E999`` is read as infinite, ``1.E300`` crashes), a
    pcurve (``DEFINITIONAL_REPRESENTATION``) holding something other than a 2D curve or
    an entity the file does not define, a
    vertex or a 3D placement on a point or direction that does not have 3 coordinates.
    Found by fuzzing (``tests/io/test_fuzz.py``); OCCT checks none of them. Regular
    expressions over the bytes: about 0.35 s for a 10 MB file that reads in 3 s.
    Other type mismatches the parser lets through may still crash the translator
    (running it in a child process would be the general guard)."""
    with open(p, "rb") as fh:
        data = fh.read()
    for e in _EXPONENT.finditer(data):  # per 3-digit exponent (rare): its whole number
        m = _HUGE.search(data, max(e.start() - 64, 0), e.end())
        try:
            value = float(m.group()) if m else 0.0
        except ValueError:
            continue
        if not abs(value) < 1e100:  # OCCT's translator crashed on a point at 1e300 (its squares overflow)
            line = data.count(b"\n", 0, m.start()) + 1
            what = "too large for a double (it reads as infinite)" if not np.isfinite(value) else "absurdly large"
            return f"STEP file {p!r}: the number {m.group().decode('ascii')!r} at line {line} is {what}; {_FIX}"
    whole = {m.start() for m in _PCURVE_WHOLE.finditer(data)}
    for m in re.finditer(rb"DEFINITIONAL_REPRESENTATION\s*\(", data):  # per pcurve: name, items, context, no more
        if m.start() not in whole:  # a parameter more, a curve '#-3': OCCT's parser let them through, its translator crashed
            line = data.count(b"\n", 0, m.start()) + 1
            return (f"STEP file {p!r}: DEFINITIONAL_REPRESENTATION at line {line} is not a name, a list of curves "
                    f"(#N, ...) and a context (#N); {_FIX}")
    pcurves = [(m.start(), ref) for m in _PCURVE.finditer(data) for ref in re.findall(rb"#([0-9]+)", m.group(1))]
    if pcurves:  # OCCT crashed on a pcurve made of a direction or an edge instead of a 2D curve, or of nothing
        kinds = dict(_KIND.findall(data))
        defined = set(_DEFINED.findall(data))
        for at, ref in pcurves:  # per pcurve
            if ref not in defined:  # its curve's label damaged (#\xa822 = LINE...): OCCT's parser let it through
                line = data.count(b"\n", 0, at) + 1
                return (f"STEP file {p!r}: DEFINITIONAL_REPRESENTATION at line {line} refers to #{ref.decode()}, "
                        f"which the file does not define; {_FIX}")
            kind = kinds.get(ref, b"")
            if kind not in _CURVES and (b"CURVE" not in kind or kind in _NOT_CURVES):
                line = data.count(b"\n", 0, at) + 1
                return (f"STEP file {p!r}: DEFINITIONAL_REPRESENTATION at line {line} "
                        f"holds {kind.decode()} #{ref.decode()} where a 2D curve belongs; {_FIX}")
    flat = {m.group(1): (m.group(2), m.group(3).count(b",") + 1, m.start()) for m in _POINT.finditer(data)
            if m.group(3).count(b",") != 2}  # points and directions that are not 3D (a pcurve's are 2D)
    if not flat:
        return None
    for m in _USER_3D.finditer(data):  # per vertex and 3D placement
        for ref in (m.group(2), m.group(3), m.group(4)):
            key = ref[1:] if ref and ref.startswith(b"#") else None
            if key in flat:
                kind, dim, at = flat[key]
                line, user_line = data.count(b"\n", 0, at) + 1, data.count(b"\n", 0, m.start()) + 1
                return (f"STEP file {p!r}: {m.group(1).decode()} at line {user_line} "
                        f"uses {kind.decode()} #{key.decode()} (line {line}), which has {dim} coordinate(s) instead "
                        f"of 3; {_FIX}")
    return None


#: Entities that carry no shape (presentation, colours, layers, product and document
#: data): a fault in one of them is left to OCCT, which reads the shape without it
#: (CAD programs write many of them; real files must not be refused for one).
_NAME_FAULT = re.compile(r"\((?:\w+\.)?(?:name|description)\) not a quoted String")  # a label left unset ($): Fusion 360
#: A fault in the header's FILE_NAME / FILE_DESCRIPTION fields (truck writes its
#: author and organization as nested lists): no shape depends on them.
_HEADER_FAULT = re.compile(r"\((?:author|organization|originating_system|authorization|preprocessor_version|"
                           r"time_stamp|implementation_level)\) not a quoted String")
#: Entities that carry no shape; PRESENTATION not after RE (a shape REPRESENTATION carries one).
_METADATA = re.compile(r"STYLE|COLOUR|(?<!RE)PRESENTATION|DRAUGHTING|ANNOTATION|PROPERTY|DOCUMENT|APPROVAL|PERSON|"
                       r"ORGANIZATION|DATE|TIME|SECURITY|CLASSIFICATION|PRODUCT|APPLICATION|DESCRIPTIVE|LAYER|"
                       r"INVISIBILITY|TEXT|FONT|OVER_RIDING|CONTEXT_DEPENDENT|MEASURE_REPRESENTATION_ITEM|VALUE_REPRESENTATION_ITEM")


def _entities(p: str, numbers) -> dict:
    """``{n: (label "#N", line, type names, a unit OCCT defaults (:func:`_default_unit`))}`` of the ``n``-th entities (from 1) of the
    DATA section, for the entity numbers ``numbers`` OCCT reported: one pass over the file."""
    want = set(numbers)
    with open(p, "rb") as fh:
        data = fh.read()
    start = data.find(b"DATA;")
    out = {}
    if start < 0 or not want:
        return out
    last = max(want)
    for k, m in enumerate(re.finditer(rb"#(\d+)\s*=(?=\s*(.{0,400}))", data[start:]), start=1):  # up to the last one asked
        if k in want:
            text = m.group(2).decode("latin-1")
            kinds = " ".join(re.findall(r"[A-Z_][A-Z_0-9]{2,}(?=\s*\()", text))
            out[k] = (f"#{int(m.group(1))}", data.count(b"\n", 0, start + m.start()) + 1, kinds, _default_unit(kinds, text))
        if k >= last:
            break
    return out


#: An angle unit as STL-to-STEP converters write it: ``NAMED_UNIT`` given its
#: dimensions (``#N``), which OCCT's parser faults ("Count of Parameters is not 2 for
#: si_unit"), in radians or steradians, OCCT's defaults. Nothing else passes: the
#: translator crashed on unit entities with a parameter more or less (tests/io/test_fuzz.py).
_CONVERTER_UNIT = re.compile(r"\(\s*NAMED_UNIT\(\s*#\d+\s*\)\s*(?:PLANE_ANGLE_UNIT\(\s*\)\s*SI_UNIT\(\s*\$\s*,\s*\.RADIAN\.\s*\)|"
                             r"SOLID_ANGLE_UNIT\(\s*\)\s*SI_UNIT\(\s*\$\s*,\s*\.STERADIAN\.\s*\))\s*\)\s*;")


def _default_unit(kinds: str, text: str) -> bool:
    """Is the entity an angle unit exactly as converters write it
    (:data:`_CONVERTER_UNIT`), which OCCT reads as its default when its parser faults
    it? A length unit, an angle in degrees or any other form stays a fault."""
    return "ANGLE_UNIT" in kinds and _CONVERTER_UNIT.match(text) is not None


def _check_shape(shape, p: str) -> None:
    """InputError if the translated shape has no face or a coordinate that is not a
    finite number within :data:`MAX_COORDINATE_MM`."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    if not TopExp_Explorer(shape, TopAbs_FACE).More():
        raise InputError(f"STEP file {p!r} holds no faces (only points, curves or empty bodies); "
                         "export the part again as a solid body")
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    if box.IsVoid():
        raise InputError(f"STEP file {p!r} holds no geometry with a position; export the part again as a solid body")
    lo, hi = box.CornerMin(), box.CornerMax()
    corners = [lo.X(), lo.Y(), lo.Z(), hi.X(), hi.Y(), hi.Z()]
    import math

    if not all(math.isfinite(c) and abs(c) <= MAX_COORDINATE_MM for c in corners):
        raise InputError(f"STEP file {p!r} has a coordinate out of range (the part spans "
                         f"{[round(c, 3) for c in corners[:3]]} .. {[round(c, 3) for c in corners[3:]]} mm; more than "
                         f"{MAX_COORDINATE_MM:g} mm from the origin is a damaged number); {_FIX}")
