"""Slicer check: slice a part with PrusaSlicer's or CuraEngine's command line and
read the G-code.

:func:`slice_mesh` writes a mesh as it would be printed (build direction turned to
+z, resting on the bed, centred on a 200 x 200 mm bed), runs ``prusa-slicer
--export-gcode`` or ``CuraEngine slice`` under ``/usr/bin/time -v`` (wall time,
CPU time and peak memory), and reads the G-code back: the length of every extrusion
path by its ``;TYPE:`` section, and where the support material went (its extrusion
points, mapped back to the part's own coordinates). Both are external programs
(Debian: ``apt-get install prusa-slicer cura-engine``); :func:`find_slicer` says
whether one is installed. CuraEngine reads its machine from
``cura_fdm.def.json`` beside this module (a minimal FDM printer: 0.4 mm nozzle,
0.2 mm layers, support on at 45 degrees); :func:`support_config` gives either
slicer's settings for "support on, threshold = critical angle".

Every length here is in mm, every time in seconds, memory in MB (10^6 bytes).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError, ResourceError

__all__ = [
    "find_slicer",
    "support_config",
    "SliceReport",
    "slice_mesh",
    "read_gcode",
    "support_near",
    "extra_support",
    "SUPPORT_MARGIN",
    "SUPPORT_GRID",
    "Toolpaths",
    "read_toolpaths",
    "toolpath_deviation",
    "SLICERS",
    "SUPPORT_TYPES",
    "OUTER_WALLS",
    "CURA_DEFINITION",
]

#: The slicers :func:`slice_mesh` drives, by the names it takes.
SLICERS = ("prusaslicer", "curaengine")
#: The ``;TYPE:`` sections PrusaSlicer and CuraEngine write for support material.
SUPPORT_TYPES = ("Support material", "Support material interface", "SUPPORT", "SUPPORT-INTERFACE")
#: ``;TYPE:`` sections that print a part's outer surface, the texture itself:
#: PrusaSlicer's external perimeters (an external perimeter that overhangs is typed
#: an overhang perimeter) and CuraEngine's outer wall. Perimeters inside them and
#: infill print the part's inside.
OUTER_WALLS = ("External perimeter", "Overhang perimeter", "WALL-OUTER")
BED_CENTRE = (100.0, 100.0)  # the default bed of both: 0..200 mm in x and y
#: CuraEngine's machine definition (all the settings it reads, flattened).
CURA_DEFINITION = Path(__file__).with_name("cura_fdm.def.json")
_EXE = {"prusaslicer": ("prusa-slicer", "PrusaSlicer"), "curaengine": ("CuraEngine",)}


def _which(slicer: str) -> str:
    if slicer not in _EXE:
        raise InputError(f"slicer must be one of {', '.join(SLICERS)}, got {slicer!r}")
    return slicer


def find_slicer(slicer: str = "prusaslicer") -> str | None:
    """Path of ``prusa-slicer`` (``"prusaslicer"``) or ``CuraEngine``
    (``"curaengine"``) on PATH, or None."""
    for name in _EXE[_which(slicer)]:
        path = shutil.which(name)
        if path:
            return path
    return None


def support_config(slicer: str = "prusaslicer", threshold: float = 45.0, *, lines: float | None = None) -> dict:
    """Settings for support on everywhere with the overhang threshold at ``threshold``
    degrees from the build plate (texcad's critical angle): PrusaSlicer's
    ``support_material_threshold`` is that angle, CuraEngine's ``support_angle`` is
    measured from the vertical, ``90 - threshold``.

    ``lines``: CuraEngine's support as plain parallel lines ``lines`` mm apart, not
    joined along the support area's border (``support_pattern = lines``,
    ``zig_zaggify_support = false``), so that the support's length times ``lines``
    is its area. At its sparse zigzag (13.3 mm in :data:`CURA_DEFINITION`) the
    connectors run along the border (CuraEngine 4.13
    ``src/infill/ZigzagConnectorProcessor.h``), and a smaller support area with a
    more jagged border can take a longer path. PrusaSlicer has no such pattern:
    ``lines`` sets its ``support_material_spacing`` (2.5 mm by default)."""
    if _which(slicer) == "prusaslicer":
        cfg = {"support-material": True, "support-material-threshold": threshold}
        if lines is not None:
            cfg["support-material-spacing"] = float(lines)
        return cfg
    cfg = {"support_enable": True, "support_type": "everywhere", "support_angle": 90.0 - float(threshold)}
    if lines is not None:
        cfg.update(support_pattern="lines", zig_zaggify_support=False, support_line_distance=float(lines),
                   support_initial_layer_line_distance=float(lines))
    return cfg


@dataclass
class SliceReport:
    """What slicing a part gave.

    Attributes:
        seconds: wall time of the slicer process, s.
        cpu_seconds: its user + system CPU time, s (all threads; less sensitive
            than the wall time to other jobs on the machine).
        peak_mb: its peak resident memory, MB.
        lengths: ``{type: extrusion path length in mm}`` per ``;TYPE:`` section.
        support_mm: total support path length (both support types), mm.
        support_points: ``(K, 3)`` float64 end points of the support extrusions in
            the part's own frame (mm), for mapping support back to the part.
        support_paths: ``(S, 2, 3)`` float64 ends of every support extrusion segment
            in the print frame (mm): the part's own coordinates turned so that the
            build direction is +z, unmoved, so that two slices of the same part in
            the same orientation (bare and textured) compare point by point
            (:func:`extra_support`).
        layers: number of layer changes.
        slicer: ``"prusaslicer"`` or ``"curaengine"``.
        gcode_mb: size of the G-code, MB.
        returncode: the slicer's exit status.
        log: the tail of its stderr (for errors).
    """

    seconds: float
    peak_mb: float
    cpu_seconds: float = float("nan")
    lengths: dict = field(default_factory=dict)
    support_mm: float = 0.0
    support_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    support_paths: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)), repr=False)
    layers: int = 0
    gcode_mb: float = 0.0
    returncode: int = 0
    log: str = field(default="", repr=False)
    slicer: str = "prusaslicer"


# G0/G1 with the axes in the order both slicers write them; CuraEngine puts F first.
_MOVE = re.compile(rb"^G[01] (?:F[\d.]+ ?)?(?:X(-?[\d.]+) ?)?(?:Y(-?[\d.]+) ?)?(?:Z(-?[\d.]+) ?)?(?:E(-?[\d.]+) ?)?", re.M)
_TYPE = re.compile(rb"^;TYPE:([^\r\n]*)", re.M)


def read_gcode(path: str | os.PathLike) -> tuple[dict, np.ndarray, int]:
    """Extrusion path lengths per ``;TYPE:`` section of a G-code with **relative**
    E (``use_relative_e_distances``), and the support extrusion end points.

    Moves are read with one regular expression over the whole file; the position
    is carried forward with numpy (a coordinate a move leaves out keeps its last
    value), so nothing loops per move in Python.

    Returns:
        ``(lengths, support_points, layers)``: ``{type: mm}``, ``(K, 3)`` G-code
        coordinates (mm) of the support extrusions' end points, layer count.
    """
    lengths, pts, _, layers = _read(_gcode_bytes(path))
    return lengths, pts, layers


def _read(data: bytes) -> tuple[dict, np.ndarray, np.ndarray, int]:
    """``(lengths, support end points (K, 3), support segments (S, 2, 3), layers)``
    of a G-code's bytes (:func:`read_gcode`), in the G-code's frame, mm."""
    moves = _moves(data)
    if moves is None:
        return {}, np.zeros((0, 3)), np.zeros((0, 2, 3)), 0
    xyz, seg, extruding, kind, names = moves
    lengths: dict[str, float] = {}
    sums = np.bincount(kind[extruding], weights=seg[extruding], minlength=len(names))
    for i, s in enumerate(sums):
        if s > 0:
            lengths[names[i]] = lengths.get(names[i], 0.0) + float(s)
    is_support = np.isin(np.array(names, dtype=object), SUPPORT_TYPES)
    sup = extruding & is_support[kind]
    layers = data.count(b";LAYER_CHANGE") or data.count(b";LAYER:")
    i = np.flatnonzero(sup)
    i = i[i > 0]  # a segment needs the move before it
    segments = np.stack([xyz[i - 1], xyz[i]], axis=1)
    segments[:, 0, 2] = segments[:, 1, 2]  # the extrusion runs at its own height
    return lengths, xyz[sup], segments, layers


def _gcode_bytes(path) -> bytes:
    data = Path(path).read_bytes()
    if not data:
        raise InputError(f"the G-code {os.fspath(path)!r} is empty")
    return data


def _moves(data: bytes):
    """``(xyz (K, 3), xy length of each move (K,), extruding (K,) bool, ;TYPE:
    index (K,), type names)`` of a G-code's G0/G1 moves (relative E), or None."""
    moves = [(m.start(), m.groups()) for m in _MOVE.finditer(data) if any(g is not None for g in m.groups())]
    if not moves:
        return None
    pos = np.array([p for p, _ in moves], dtype=np.int64)
    vals = np.array([[np.nan if g is None else float(g) for g in gs] for _, gs in moves], dtype=np.float64)
    e = np.nan_to_num(vals[:, 3], nan=0.0)
    has_xy = ~np.isnan(vals[:, 0]) | ~np.isnan(vals[:, 1])
    xyz = vals[:, :3].copy()
    for k in range(3):  # carry each coordinate forward from the last move that set it
        col = xyz[:, k]
        idx = np.where(~np.isnan(col), np.arange(len(col)), 0)
        np.maximum.accumulate(idx, out=idx)
        col[:] = col[idx]
        col[np.isnan(col)] = 0.0
    seg = np.zeros(len(xyz))
    seg[1:] = np.hypot(np.diff(xyz[:, 0]), np.diff(xyz[:, 1]))
    extruding = has_xy & (e > 0)
    tmarks = [(m.start(), m.group(1).decode("ascii", "replace").strip()) for m in _TYPE.finditer(data)]
    names = ["(none)"] + [t for _, t in tmarks]
    tpos = np.array([p for p, _ in tmarks], dtype=np.int64)
    kind = np.searchsorted(tpos, pos, side="right")  # 0 = before any ;TYPE:
    return xyz, seg, extruding, kind, names


@dataclass(frozen=True)
class Toolpaths:
    """The extrusion paths of a G-code, layer by layer (what the printer lays down).

    Attributes:
        z: ``(L,)`` float64 heights of the layers that extrude, mm, ascending.
        layer: ``(N,)`` int64 index into ``z`` of each extrusion segment.
        start, end: ``(N, 2)`` float64 x, y of each segment's ends, mm (G-code frame).
        run: ``(N,)`` int64 index of the unbroken extrusion (no travel between its
            segments) each segment belongs to, ascending; None if not known.
    """

    z: np.ndarray
    layer: np.ndarray
    start: np.ndarray
    end: np.ndarray
    run: np.ndarray | None = None

    def without_specks(self, size: float) -> "Toolpaths":
        """These paths without the unbroken extrusions whose extent (bounding-box
        diagonal, mm) is under ``size`` mm: specks such as a perimeter around a
        0.1 mm island, which print a dot of one bead whatever their shape. With
        ``run`` unknown, the paths as they are."""
        if self.run is None or not len(self.run):
            return self
        first = np.flatnonzero(np.r_[True, self.run[1:] != self.run[:-1]])
        pts = np.concatenate([self.start, self.end], axis=1)  # (N, 4): x0 y0 x1 y1
        lo = np.minimum(np.minimum.reduceat(pts[:, :2], first), np.minimum.reduceat(pts[:, 2:], first))
        hi = np.maximum(np.maximum.reduceat(pts[:, :2], first), np.maximum.reduceat(pts[:, 2:], first))
        big = np.linalg.norm(hi - lo, axis=1) >= size  # per run
        keep = np.repeat(big, np.diff(np.r_[first, len(self.run)]))
        return Toolpaths(self.z, self.layer[keep], self.start[keep], self.end[keep], self.run[keep])

    @property
    def lengths(self) -> np.ndarray:
        """``(L,)`` extrusion path length per layer, mm."""
        seg = np.linalg.norm(self.end - self.start, axis=1)
        return np.bincount(self.layer, weights=seg, minlength=len(self.z))

    def points(self, step: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
        """Points along every segment at most ``step`` mm apart (both ends
        included): ``(layer index (P,), x, y (P, 2))``."""
        seg = self.end - self.start
        n = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / step).astype(np.int64))  # pieces per segment
        owner = np.repeat(np.arange(len(n)), n + 1)
        first = np.cumsum(n + 1) - (n + 1)
        t = (np.arange(len(owner)) - first[owner]) / n[owner]
        return self.layer[owner], self.start[owner] + seg[owner] * t[:, None]


def read_toolpaths(path: str | os.PathLike, *, exclude=SUPPORT_TYPES, only=None) -> Toolpaths:
    """The extrusion segments of a G-code (relative E) by layer, leaving out the
    ``;TYPE:`` sections named in ``exclude`` (support by default: what prints the
    part) and, given ``only`` (e.g. :data:`OUTER_WALLS`), every section not named
    there. Layers are told apart by their z (mm, rounded to 1 um)."""
    moves = _moves(_gcode_bytes(path))
    if moves is None:
        return Toolpaths(np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64))
    xyz, seg, extruding, kind, names = moves
    named = np.array(names, dtype=object)
    wanted = ~np.isin(named, tuple(exclude)) & (np.isin(named, tuple(only)) if only is not None else True)
    keep = extruding & wanted[kind]
    keep[0] = False  # a segment needs the move before it
    i = np.flatnonzero(keep)
    z, layer = np.unique(np.round(xyz[i, 2], 3), return_inverse=True)
    run = np.cumsum(np.r_[0, np.diff(i) != 1]).astype(np.int64)  # a move that does not extrude breaks a run
    return Toolpaths(z, layer.astype(np.int64), xyz[i - 1, :2].copy(), xyz[i, :2].copy(), run)


def toolpath_deviation(a: Toolpaths, b: Toolpaths, *, step: float = 0.05) -> np.ndarray:
    """Per layer, the Hausdorff distance in mm between the extrusion paths of two
    G-codes of the same part: the farthest any point of one layer's paths lies
    from the other's paths at the same height (inf for a layer only one of them
    prints). Paths are sampled every ``step`` mm, so the figure is exact to within
    ``step / 2``; 0 for a layer where neither prints a path (both left out, e.g.
    by :meth:`Toolpaths.without_specks`). Returns ``(L,)`` float64 over the union of
    both layer heights (ascending)."""
    from scipy.spatial import cKDTree

    z = np.union1d(a.z, b.z)
    out = np.full(len(z), np.inf)
    (la, pa), (lb, pb) = a.points(step), b.points(step)
    ia, ib = np.searchsorted(z, a.z), np.searchsorted(z, b.z)
    la, lb = ia[la], ib[lb]
    oa, ob = np.argsort(la, kind="stable"), np.argsort(lb, kind="stable")
    ca, cb = np.searchsorted(la[oa], np.arange(len(z) + 1)), np.searchsorted(lb[ob], np.arange(len(z) + 1))
    for k in range(len(z)):  # per layer
        p, q = pa[oa[ca[k] : ca[k + 1]]], pb[ob[cb[k] : cb[k + 1]]]
        if len(p) and len(q):
            out[k] = max(cKDTree(q).query(p)[0].max(), cKDTree(p).query(q)[0].max())
        elif not len(p) and not len(q):  # a layer neither prints (e.g. only specks left out)
            out[k] = 0.0
    return out


def _oriented(mesh, build_dir) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``R`` (3x3) taking ``build_dir`` to +z, and the vertices turned by it."""
    from ..printability import print_rotation

    R = print_rotation(build_dir)
    return R, mesh.vertices.astype(np.float64) @ R.T


def slice_mesh(
    mesh,
    *,
    slicer: str = "prusaslicer",
    build_dir=(0.0, 0.0, 1.0),
    config: dict | None = None,
    timeout: float = 1800.0,
    keep: str | os.PathLike | None = None,
    file: str = "stl",
    layout: bool = True,
) -> SliceReport:
    """Slice ``mesh`` (a :class:`texcad.solid.Mesh`, mm) with PrusaSlicer's or
    CuraEngine's CLI.

    The mesh is turned so that ``build_dir`` points up (+z), put on the bed (lowest
    point at z = 0) with its bounding box centred on the default bed, written as a
    binary STL and sliced with relative E (which only changes how E is written, not
    what is sliced).

    * ``slicer="prusaslicer"``: ``prusa-slicer --export-gcode --dont-arrange``;
      ``config`` adds options, e.g. :func:`support_config` or ``{"overhangs":
      False}`` (PrusaSlicer's "detect bridging perimeters"); True / False become
      ``--key`` / ``--no-key``. Everything else is PrusaSlicer's default.
    * ``slicer="curaengine"``: ``CuraEngine slice -j cura_fdm.def.json``
      (:data:`CURA_DEFINITION`); ``config`` adds ``-s key=value`` settings
      (True / False become ``true`` / ``false``).

    ``file="3mf"`` hands the slicer what :func:`texcad.io.export` writes into a 3MF
    instead of a plain STL: PrusaSlicer gets the 3MF, with the per-object settings of
    :func:`texcad.io.slicer_layout`; CuraEngine, which reads no 3MF, gets the STL
    with the 3MF's Cura per-object settings (:func:`texcad.io.cura_settings`) as
    ``-s`` settings of that mesh (after its ``-l``), as Cura's frontend passes them
    on when it loads the 3MF. ``layout=False`` writes the mesh as a plain one-part
    3MF instead (no settings, no cut: what the layout changes is then the only
    difference; CuraEngine: the STL alone). ``keep``: copy the G-code there.

    Returns:
        :class:`SliceReport` (support points mapped back to the mesh's own frame).

    Raises:
        ResourceError: the slicer is not installed, or it ran past ``timeout`` s.
    """
    from ..io import cura_settings, slicer_layout, write_3mf, write_stl
    from ..solid import Mesh

    if file not in ("stl", "3mf"):
        raise InputError(f"file must be 'stl' or '3mf', got {file!r}")

    exe = find_slicer(slicer)
    if exe is None:
        pkg = {"prusaslicer": "prusa-slicer", "curaengine": "cura-engine"}[slicer]
        raise ResourceError(f"{_EXE[slicer][0]} is not installed; install it (Debian: apt-get install {pkg})")
    R, v = _oriented(mesh, build_dir)
    lo, hi = v.min(axis=0), v.max(axis=0)
    shift = np.array([BED_CENTRE[0] - (lo[0] + hi[0]) / 2, BED_CENTRE[1] - (lo[1] + hi[1]) / 2, -lo[2]])
    placed = Mesh((v + shift).astype(np.float32), mesh.faces)
    placed.__dict__["is_watertight"] = mesh.is_watertight
    with tempfile.TemporaryDirectory() as tmp:
        gcode = Path(tmp) / "part.gcode"
        if file == "3mf" and slicer == "prusaslicer":
            stl = Path(tmp) / "part.3mf"
            if layout:
                lay = slicer_layout(placed, name="part")  # what export() writes
                parts = placed if len(lay.parts) == 1 else list(lay.parts)
                write_3mf(parts, stl, name="part", settings=lay.settings, part_settings=lay.part_settings or None,
                          cura_settings=cura_settings(placed))
            else:
                write_3mf(placed, stl, name="part")
        else:
            stl = Path(tmp) / "part.stl"
            write_stl(placed, stl)
        mesh_settings = cura_settings(placed) if file == "3mf" and layout else {}  # the 3MF's, for CuraEngine's mesh
        cmd = _command(exe, slicer, config or {}, stl, gcode, mesh_settings)
        full = (["/usr/bin/time", "-v"] if os.path.exists("/usr/bin/time") else []) + cmd
        try:
            proc = subprocess.run(full, capture_output=True, timeout=timeout, env={**os.environ, "LC_ALL": "C"})
        except subprocess.TimeoutExpired:
            raise ResourceError(f"{slicer} ran past {timeout:g} s; slice a leaner mesh (larger tolerance)") from None
        err = proc.stderr.decode("utf-8", "replace")
        wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", err)
        secs = (int(wall.group(1) or 0) * 3600 + int(wall.group(2)) * 60 + float(wall.group(3))) if wall else float("nan")
        rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", err)
        peak = int(rss.group(1)) * 1024 / 1e6 if rss else float("nan")
        cpu = [re.search(rf"{k} time \(seconds\): ([\d.]+)", err) for k in ("User", "System")]
        cpu_s = sum(float(c.group(1)) for c in cpu) if all(cpu) else float("nan")
        rep = SliceReport(seconds=secs, peak_mb=peak, cpu_seconds=cpu_s, returncode=proc.returncode, log=err[-2000:], slicer=slicer)
        if proc.returncode == 0 and gcode.exists() and gcode.stat().st_size:
            rep.lengths, pts, paths, rep.layers = _read(_gcode_bytes(gcode))
            rep.support_paths = paths - shift  # the print frame: build_dir is +z, the part where it lies
            rep.gcode_mb = gcode.stat().st_size / 1e6
            rep.support_mm = float(sum(rep.lengths.get(t, 0.0) for t in SUPPORT_TYPES))
            rep.support_points = (pts - shift) @ R  # back to the mesh's frame
            if keep is not None:
                shutil.copy(gcode, keep)
    return rep


def _command(exe: str, slicer: str, config: dict, src: Path, gcode: Path, mesh_settings: dict) -> list[str]:
    """The command line that slices ``src`` into ``gcode``: PrusaSlicer with
    ``config`` as options (True / False as ``--key`` / ``--no-key``), or CuraEngine
    with ``config`` as ``-s`` settings and ``mesh_settings`` as the mesh's own
    (``-s`` after its ``-l``)."""
    if slicer == "prusaslicer":
        args = ["--use-relative-e-distances"]
        for k, val in config.items():
            if val is True:
                args.append(f"--{k}")
            elif val is False:
                args.append(f"--no-{k}")
            else:
                args += [f"--{k}", str(val)]
        return [exe, "--export-gcode", "--dont-arrange", *args, "--output", str(gcode), str(src)]
    args, mesh_args = [], []
    for k, val in config.items():
        args += ["-s", f"{k}={str(val).lower() if isinstance(val, bool) else val}"]
    for k, val in mesh_settings.items():
        mesh_args += ["-s", f"{k}={str(val).lower() if isinstance(val, bool) else val}"]
    return [exe, "slice", "-j", str(CURA_DEFINITION), *args, "-l", str(src), *mesh_args, "-o", str(gcode)]


def support_near(points: np.ndarray, mesh, faces: np.ndarray, build_dir=(0.0, 0.0, 1.0), radius: float = 1.0) -> int:
    """How many support points lie below (along ``-build_dir``) and within
    ``radius`` mm across of the given faces of ``mesh`` (e.g. its texture faces):
    support the texture causes, as opposed to support elsewhere on the part.
    Uses a KD-tree on the faces' centroids in the plane normal to ``build_dir``."""
    from scipy.spatial import cKDTree

    if len(points) == 0 or len(faces) == 0:
        return 0
    R, v = _oriented(mesh, build_dir)
    c = v[mesh.faces[faces]].mean(axis=1)
    p = np.asarray(points, dtype=np.float64) @ R.T
    pairs = cKDTree(c[:, :2]).sparse_distance_matrix(cKDTree(p[:, :2]), radius, output_type="ndarray")
    under = np.zeros(len(p), dtype=bool)
    above = c[pairs["i"], 2] > p[pairs["j"], 2]
    under[pairs["j"][above]] = True
    return int(np.count_nonzero(under))


#: mm: the cell of the grid PrusaSlicer 2.5 snaps support areas to
#: (``SupportGridPattern`` in ``SupportMaterial.cpp``: the bounding box aligned to
#: multiples of the support spacing, 2.5 mm + a line's spacing, in the bed's frame).
SUPPORT_GRID = 2.9
#: mm across (in the bed's plane) within which support counts as the same support:
#: a :data:`SUPPORT_GRID` cell's diagonal. PrusaSlicer centres each part's bounding
#: box on the bed, so a texture that widens the box on one side moves the part
#: against that grid, and the support's edge by up to a cell each way (at a corner
#: of the first layer, whose support is widened, by the diagonal).
SUPPORT_MARGIN = 4.2


def extra_support(textured: SliceReport, bare: SliceReport, *, across: float = SUPPORT_MARGIN, along: float = 1.0,
                  step: float = 0.2) -> float:
    """Length in mm of ``textured``'s support paths that lie farther than ``across``
    mm (in the bed's plane) or ``along`` mm (in height) from every support path of
    ``bare``: support the part needs only because of its texture, where the bare
    part, sliced in the same orientation, needs none. Where both need support the
    paths differ anyway (the pattern follows the outline; PrusaSlicer snaps support
    to its grid, :data:`SUPPORT_MARGIN`, and rests a column standing beside a
    textured wall on the texture's upward facets, which adds layers and interfaces
    to it); those differences are not counted. Paths are sampled every ``step`` mm;
    each sample carries its piece's length."""
    from scipy.spatial import cKDTree

    p, w = _samples(textured.support_paths, step)
    if not len(p):
        return 0.0
    q, _ = _samples(bare.support_paths, step)
    if not len(q):
        return float(w.sum())
    scale = np.array([1.0, 1.0, across / along])  # an ellipsoid: across x across x along
    d, _ = cKDTree(q * scale).query(p * scale, distance_upper_bound=across * 1.0001)
    return float(w[~np.isfinite(d)].sum())


def _samples(paths: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints of pieces at most ``step`` mm long along segments ``(S, 2, 3)``, and
    each piece's length: ``((P, 3), (P,))``."""
    seg = paths[:, 1] - paths[:, 0]
    length = np.linalg.norm(seg, axis=1)
    n = np.maximum(1, np.ceil(length / step).astype(np.int64))
    owner = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(n) - n, n)
    t = (k + 0.5) / n[owner]
    return paths[owner, 0] + seg[owner] * t[:, None], length[owner] / n[owner]
