"""The one result type of :func:`texcad.texture`: :class:`Textured`.

Every target (a plate, a 2.5D surface, faces of a build123d or CadQuery part) gives a
:class:`Textured` with the same attributes and methods. Its meshes are made by the
texturing itself (they are what STL and 3MF are written from); its B-rep
(:attr:`Textured.shape`, for STEP and further CAD work) is made on first use, so STL
and 3MF users never wait for it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import GeometryError, ParameterError
from ..solid import Mesh

__all__ = ["Textured", "as_textured"]

MeshSource = "Mesh | Callable[[], Mesh] | None"


def _transformed(mesh: Mesh, m: np.ndarray) -> Mesh:
    """``mesh`` moved by the ``(3, 4)`` matrix ``m`` (rotation/translation, mm)."""
    if np.allclose(m, np.eye(3, 4), rtol=0, atol=1e-12):
        return mesh
    v = mesh.vertices.astype(np.float64) @ m[:, :3].T + m[:, 3]
    out = Mesh(v.astype(np.float32), mesh.faces, mesh.groups)
    if "is_watertight" in mesh.__dict__:
        out.__dict__["is_watertight"] = mesh.__dict__["is_watertight"]
    return out


def _matrix(location: Any) -> np.ndarray:
    """``(3, 4)`` float64 matrix of a build123d ``Location``, an OCP ``gp_Trsf`` /
    ``TopLoc_Location`` or a ``(3, 4)``/``(4, 4)`` array."""
    trsf = getattr(location, "wrapped", location)
    if hasattr(trsf, "Transformation"):
        trsf = trsf.Transformation()
    if hasattr(trsf, "Value"):
        return np.array([[trsf.Value(i, j) for j in range(1, 5)] for i in range(1, 4)], dtype=np.float64)
    m = np.asarray(location, dtype=np.float64)
    if m.shape not in ((3, 4), (4, 4)):
        raise ParameterError(f"a placement is a build123d Location or a (3, 4) / (4, 4) matrix, got {m.shape}")
    return m[:3]


class Textured:
    """A textured part: texcad's meshes, the texture as applied, and the B-rep on
    demand. All lengths in mm.

    Attributes:
        heightmap: the texture as applied (heights in mm: clipped and ramped on planar
            faces, lowered by the overhang limiter), or None where several faces
            were textured (see ``info["faces"]``).
        limits: the overhang limiter's :class:`texcad.printability.LimitReport` for
            ``build_dir``, or None without a build direction.
        height_limits: where the height was limited so that the relief cannot
            intersect itself (:class:`texcad.mapping.HeightLimit`, curved faces).
        distortion: texture scale relative to the nominal mm on mapped faces
            (:class:`texcad.mapping.Distortion`), or None on planar faces.
        mapped: the :class:`texcad.mapping.MappedSurface` of a 2.5D surface (vertex
            grids in mm), or None.
        max_error: the measured largest height error in mm of the texture surface
            at any pixel centre (:func:`texcad.solid.mesh_error`, sampled
            independently of the triangulation; 0 with ``tolerance=0``), computed on
            first use.
        info: what was done (face kind, frame, grid size, mapping...).
    """

    def __init__(
        self,
        *,
        mesh: "Mesh | Callable[[], Mesh]",
        texture_mesh: "Mesh | Callable[[], Mesh] | None" = None,
        base_mesh: "Mesh | Callable[[], Mesh] | None" = None,
        shape: Any = None,
        heightmap: Any = None,
        limits: Any = None,
        height_limits: list | None = None,
        distortion: Any = None,
        mapped: Any = None,
        max_error: "float | Callable[[], float] | None" = None,
        info: dict | None = None,
        kind: str = "mesh",
    ) -> None:
        self._mesh = mesh
        self._texture_mesh = texture_mesh
        self._base_mesh = base_mesh
        self._shape = shape
        self._placement = np.eye(3, 4)
        self.heightmap = heightmap
        self.limits = limits
        self.height_limits = list(height_limits or [])
        self.distortion = distortion
        self.mapped = mapped
        self._max_error = max_error
        self.info = info if info is not None else {}
        self.kind = kind

    def __repr__(self) -> str:
        m = self.mesh
        return f"Textured({self.info.get('face', self.kind)}, {m.num_triangles} triangles, {m.volume:.1f} mm3)"

    # -- meshes --------------------------------------------------------------------------
    def _placed(self, attr: str, what: str) -> Mesh:
        value = getattr(self, attr)
        if value is None:
            raise GeometryError(f"this result carries no {what}")
        if callable(value):
            value = value()
            setattr(self, attr, value)
        return _transformed(value, self._placement)

    @property
    def mesh(self) -> Mesh:
        """The fused, watertight mesh (base + texture), mm, where the part is now."""
        return self._placed("_mesh", "mesh")

    @property
    def texture_mesh(self) -> Mesh:
        """The texture alone (watertight; touches the base without overlapping it),
        mm. Made on first use (one manifold3d difference)."""
        return self._placed("_texture_mesh", "texture mesh")

    @property
    def base_mesh(self) -> Mesh:
        """The base body's mesh, mm."""
        return self._placed("_base_mesh", "base mesh")

    @property
    def volume(self) -> float:
        """Volume of the fused mesh in mm^3."""
        return float(self.mesh.volume)

    @property
    def max_error(self) -> "float | None":
        """Measured largest height error in mm of the texture surface at any pixel
        centre (computed on first use; None if unknown)."""
        if callable(self._max_error):
            self._max_error = float(self._max_error())
        return self._max_error

    # -- B-rep ---------------------------------------------------------------------------
    @property
    def shape(self):
        """The textured B-rep as an OCP ``TopoDS_Shape`` (the texture as B-spline
        faces sewn into the body). Made on first use and checked against the mesh
        (valid, one solid per input solid, volume within 0.1 %).

        Raises:
            GeometryError: no B-rep can be made for this result (the message says why
                and names the mesh outputs).
        """
        if self._shape is None:
            raise GeometryError(
                f"this {self.kind} result has no B-rep ({self.info.get('no_brep', 'made from a mesh')}); "
                "write STL or 3MF instead"
            )
        if callable(self._shape):
            self._shape = self._shape()
        shape = self._shape
        if not np.allclose(self._placement, np.eye(3, 4), rtol=0, atol=1e-12):
            from OCP.gp import gp_Trsf
            from OCP.TopLoc import TopLoc_Location

            t = gp_Trsf()
            m = self._placement
            t.SetValues(*[float(m[i, j]) for i in range(3) for j in range(4)])
            shape = shape.Moved(TopLoc_Location(t))
        return shape

    @property
    def wrapped(self):
        """:attr:`shape`, under the name build123d and CadQuery objects use, so that a
        :class:`Textured` can be handed to their functions (``export_step``,
        ``show_object``)."""
        return self.shape

    @property
    def part(self):
        """The B-rep as a build123d ``Part``."""
        from build123d import Part

        return Part(self.shape)

    @property
    def workplane(self):
        """The B-rep as a CadQuery ``Workplane``."""
        import cadquery as cq

        return cq.Workplane("XY").newObject([cq.Shape.cast(self.shape)])

    # -- placement -----------------------------------------------------------------------
    def moved(self, location: Any) -> "Textured":
        """A copy moved by ``location`` (a build123d ``Location``, e.g. ``Pos(10, 0,
        0)``, ``Rot(0, 0, 90)``, or a ``(3, 4)`` matrix): meshes and B-rep move
        together; ``Pos(10, 0, 0) * textured`` does the same."""
        m = _matrix(location)
        out = object.__new__(Textured)
        out.__dict__.update(self.__dict__)
        out.info = dict(self.info)
        m4 = np.vstack([m, [0, 0, 0, 1]]) @ np.vstack([self._placement, [0, 0, 0, 1]])
        out._placement = m4[:3]
        return out

    def __rmul__(self, location: Any) -> "Textured":
        return self.moved(location)

    # -- CAD work on the result ----------------------------------------------------------
    def __sub__(self, tool: Any) -> "Textured":
        """``textured - tool``: cut a build123d / CadQuery shape (a hole, a slot) out of
        the textured part; see :func:`texcad.pipeline.cad_op`."""
        from .ops import cad_op

        return cad_op(self, tool, "cut")

    def __add__(self, tool: Any) -> "Textured":
        """``textured + tool``: union with a shape (a boss, a tab)."""
        from .ops import cad_op

        return cad_op(self, tool, "fuse")

    def __and__(self, tool: Any) -> "Textured":
        """``textured & tool``: the common part with a shape."""
        from .ops import cad_op

        return cad_op(self, tool, "common")

    def fillet(self, edges: Any, radius: float) -> "Textured":
        """Round ``edges`` (from ``self.part.edges()`` or the original part, away from
        the texture) to ``radius`` mm; see :func:`texcad.pipeline.ops.fillet`."""
        from .ops import fillet

        return fillet(self, edges, radius)

    def mirrored(self, origin: Any = (0.0, 0.0, 0.0), normal: Any = (1.0, 0.0, 0.0)) -> "Textured":
        """A mirror image about the plane through ``origin`` (mm) with ``normal``;
        see :func:`texcad.pipeline.ops.mirror`."""
        from .ops import mirror

        return mirror(self, origin, normal)

    def patterned(self, locations: Any) -> "Textured":
        """Copies at ``locations`` (build123d ``GridLocations`` / ``PolarLocations`` /
        ``Locations``, a list of ``Pos``/``Location``s or ``(3, 4)`` matrices; mm and
        degrees), which must not overlap; see :func:`texcad.pipeline.ops.pattern`."""
        from .ops import pattern

        return pattern(self, locations)

    # -- output --------------------------------------------------------------------------
    def export(self, path: "str | os.PathLike", *, separate_texture: bool = False, name: str | None = None) -> Path:
        """Write by the file's extension: ``.stl`` (binary, mm) and ``.3mf`` from the
        mesh (``separate_texture``: the texture as its own object, so a slicer can
        give it another filament), ``.step``/``.stp`` from the B-rep, ``.png`` a
        picture (:meth:`render`). Atomic: a failure leaves no file."""
        from ..io import export

        if Path(path).suffix.lower() == ".png":
            return self.render(path)
        return export(self, path, separate_texture=separate_texture, name=name)

    def render(self, path: "str | os.PathLike", **kwargs: Any) -> Path:
        """PNG picture of the mesh (see :func:`texcad.render.render_part`)."""
        from ..render import render_part

        return render_part(self.mesh, path, **kwargs)

    def show(self, **kwargs: Any) -> Any:
        """Show the mesh in the OCP CAD viewer (see :func:`texcad.render.show`)."""
        from ..render import show

        return show(self, **kwargs)

    def check(self, **kwargs: Any):
        """:func:`texcad.check` on this result (watertight, volume, overhang area of
        the texture faces for ``build_dir=``)."""
        from ..report import check

        return check(self, **kwargs)

    # -- aliases kept for one release ----------------------------------------------------
    def export_stl(self, path: "str | os.PathLike") -> Path:
        """Deprecated alias of ``export(path)`` with a ``.stl`` path."""
        return self._export_as(path, ".stl")

    def export_3mf(self, path: "str | os.PathLike", *, separate_texture: bool = False, name: str | None = None) -> Path:
        """Deprecated alias of ``export(path)`` with a ``.3mf`` path."""
        return self._export_as(path, ".3mf", separate_texture=separate_texture, name=name)

    def export_step(self, path: "str | os.PathLike", *, name: str | None = None) -> Path:
        """Deprecated alias of ``export(path)`` with a ``.step`` path."""
        return self._export_as(path, (".step", ".stp"), name=name)

    def _export_as(self, path: Any, suffixes: Any, **kwargs: Any) -> Path:
        if isinstance(suffixes, str):
            suffixes = (suffixes,)
        if Path(path).suffix.lower() not in suffixes:
            raise ParameterError(f"{str(path)!r} must end in {' or '.join(suffixes)}")
        return self.export(path, **kwargs)


def as_textured(obj: Any) -> Textured:
    """``obj`` itself when it is a :class:`Textured` (or carries one as ``.texcad``).

    Raises:
        ParameterError: ``obj`` did not come from :func:`texcad.texture`.
    """
    if isinstance(obj, Textured):
        return obj
    tx = getattr(obj, "texcad", None)
    if isinstance(tx, Textured):
        return tx
    raise ParameterError(
        f"a {type(obj).__name__} carries no texcad texture; make it with texcad.texture(part, faces, texture)"
    )
