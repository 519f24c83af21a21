"""The one result type of :func:`texcad.texture`: :class:`Textured`.

Every target (a planar or curved face, several faces, a 2.5D surface, a plate, a
mesh) gives a :class:`Textured` with the same attributes and methods. It holds the
:class:`~texcad.contracts.Stages` it came from; what is made on demand (the texture
body, the measured error, the B-rep) is made by that target's adapter from them, so
STL and 3MF users never wait for a B-rep. Results of CAD operations
(:mod:`texcad.pipeline.ops`) are :class:`Textured` too, derived from their parent.
"""

from __future__ import annotations

import contextlib

import os
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..brep.occt import matrix_of
from ..contracts import Stages
from ..errors import GeometryError, ParameterError
from ..solid import Mesh

__all__ = ["Textured", "as_textured", "checked_brep", "texture_in_brep", "VOLUME_TOLERANCE"]

#: Largest relative difference between the B-rep's and the mesh's volume accepted.
VOLUME_TOLERANCE = 1e-3


def _transformed(mesh: Mesh, m: np.ndarray) -> Mesh:
    """``mesh`` moved by the ``(3, 4)`` matrix ``m`` (rotation/translation, mm)."""
    if np.allclose(m, np.eye(3, 4), rtol=0, atol=1e-12):
        return mesh
    v = mesh.vertices.astype(np.float64) @ m[:, :3].T + m[:, 3]
    out = Mesh(v.astype(np.float32), mesh.faces, mesh.groups)
    if "is_watertight" in mesh.__dict__:
        out.__dict__["is_watertight"] = mesh.__dict__["is_watertight"]
    return out


def checked_brep(shape: Any, bodies: int, mesh: Mesh, slack: float = 0.0) -> tuple[Any, float]:
    """``(shape, volume)``: a B-rep checked against its mesh: one valid solid
    (``BRepCheck_Analyzer``) per body, enclosing the mesh's volume within
    :data:`VOLUME_TOLERANCE` plus ``slack`` mm^3 (a lean mesh's tolerance times its area).

    Raises:
        GeometryError: the B-rep is invalid or encloses another volume.
    """
    from ..brep import check_shape, volume

    chk = check_shape(shape)
    if not chk["valid"] or chk["solids"] != bodies:
        raise GeometryError(f"the textured B-rep is not valid ({chk}); the meshes are fine: write STL or 3MF, and please report this")
    vb, vm = volume(shape), float(mesh.volume)
    if abs(vb - vm) > VOLUME_TOLERANCE * abs(vm) + slack:
        raise GeometryError(
            f"the textured B-rep encloses {vb:.1f} mm3 but the mesh {vm:.1f} mm3 ({100 * (vb - vm) / vm:+.2f} %, "
            f"accepted {100 * VOLUME_TOLERANCE:g} % and {slack:.2f} mm3), so no B-rep is given; "
            "the meshes are fine: write STL or 3MF"
        )
    return shape, vb


@contextlib.contextmanager
def _occt_failures(kind: str):
    """An exception OCCT raises while the B-rep is built (OCP's ``Standard_*``
    classes, which share no base class) as the :class:`GeometryError` every other
    refusal is: it names the failure and the mesh outputs."""
    try:
        yield
    except Exception as exc:
        if not type(exc).__module__.startswith("OCP"):
            raise
        raise GeometryError(f"OCCT failed while building this {kind} result's B-rep ({type(exc).__name__}: "
                            f"{str(exc) or 'no message'}), so no B-rep is given; the mesh is fine: write STL or 3MF") from None


def texture_in_brep(vb: float, stages: Stages) -> None:
    """Check that the B-rep holds the texture: its volume ``vb`` (mm^3) beyond the
    untextured part's mesh is the texture's integral ``stages.relief.volume`` within the
    gate's accepted difference ``volume_slack`` plus the part's tessellation chord
    (:data:`texcad.brep.TESSELLATION`) times the area of its curved faces (planar ones
    are tessellated exactly): the check the gate makes on the
    mesh, made on the B-rep. On a large part a texture missing from the B-rep lies
    within :data:`VOLUME_TOLERANCE` of the whole; not of the texture. Skipped for
    chained results (their base is the earlier B-rep) and targets without an OCCT
    shape.

    Raises:
        GeometryError: naming both volume changes.
    """
    from ..brep import TESSELLATION
    from ..brep.occt import curved_area

    pl, relief = stages.placement, stages.relief
    if pl.topo is None or pl.previous is not None or relief.volume is None:
        return
    change, expected = vb - float(pl.base.volume), float(relief.volume)
    slack = float(relief.volume_slack) + TESSELLATION * curved_area(pl.topo)
    if abs(change - expected) > slack:
        raise GeometryError(
            f"the textured B-rep encloses {change:+.2f} mm3 beyond the part but the texture's integral is {expected:+.2f} "
            f"mm3 (accepted difference {slack:.2f} mm3): the texture is not all in the B-rep, so no B-rep is given; the "
            "meshes are fine: write STL or 3MF"
        )


class Textured:
    """A textured part: texcad's meshes, the texture as applied, and the B-rep on
    demand. All lengths in mm.

    Attributes:
        stages: the :class:`~texcad.contracts.Stages` it came from (None for the
            results of CAD operations, which keep their parent's).
        heightmap: the texture as applied (heights in mm: clipped and ramped, lowered
            by the overhang limiter), or None where several faces were textured.
        limits: the overhang limiter's report for ``build_dir``, or None.
        height_limits: where the height was limited so that the relief cannot cross
            itself (curved faces).
        distortion: texture scale against the nominal mm on mapped faces, or None.
        mapped: the :class:`texcad.mapping.MappedSurface` of a 2.5D surface, or None.
        gate: what the gate measured (:class:`texcad.report.gate.GateReport`).
        info: what was done (face kind, grid size, fuse path...), plain values.
        kind: ``"face"``, ``"surface"``, ``"plate"`` or ``"mesh"``.
    """

    def __init__(self, stages: Stages) -> None:
        self.stages = stages
        r = stages.relief
        self._mesh: Any = stages.fused.mesh
        self._base_mesh: Any = stages.fused.base_mesh
        self._texture_mesh: Any = None
        self._shape: Any = None
        self._brep_volume: "float | None" = None
        self._max_error: Any = r.max_error
        self._derived: "dict | None" = None
        self._placement = np.eye(3, 4)
        self.heightmap = r.heightmap
        self.limits = r.limits
        self.height_limits = list(r.height_limits)
        self.distortion = r.distortion
        self.mapped = r.mapped
        self.gate = stages.gate
        self.info = dict(stages.fused.info)
        self.kind = stages.adapter.result_kind

    @classmethod
    def derived(cls, parent: "Textured", *, mesh: Mesh, base_mesh: "Mesh | Callable[[], Mesh]",
                texture_mesh: "Mesh | Callable[[], Mesh]", shape: "Callable[[], Any] | None", info: dict, history: Any,
                layer_meshes: "Callable[[], list] | None" = None) -> "Textured":
        """A result made from ``parent`` by a CAD operation (:mod:`texcad.pipeline.ops`):
        its meshes, the B-rep's maker (or None) and the operation history."""
        out = object.__new__(cls)
        out.__dict__.update(parent.__dict__)
        out._mesh, out._base_mesh, out._texture_mesh = mesh, base_mesh, texture_mesh
        out._shape, out._brep_volume, out._placement = None, None, np.eye(3, 4)
        out._derived = {"shape": shape, "history": history, "layers": layer_meshes}
        out.info = info
        return out

    def __repr__(self) -> str:
        m = self.mesh
        return f"Textured({self.info.get('face', self.kind)}, {m.num_triangles} triangles, {m.volume:.1f} mm3)"

    # -- meshes --------------------------------------------------------------------------
    def _made(self, attr: str, make: Callable[[], Any]) -> Any:
        value = getattr(self, attr)
        if value is None:
            value = make()
        elif callable(value) and not isinstance(value, Mesh):
            value = value()
        setattr(self, attr, value)
        return value

    @property
    def mesh(self) -> Mesh:
        """The fused, watertight mesh (base + texture), mm, where the part is now."""
        return _transformed(self._made("_mesh", lambda: None), self._placement)

    @property
    def texture_mesh(self) -> Mesh:
        """The texture alone (closed; touches the base without overlapping it), mm.
        Made on first use."""
        return _transformed(self._made("_texture_mesh", lambda: self.stages.adapter.texture_mesh(self.stages)), self._placement)

    @property
    def base_mesh(self) -> Mesh:
        """The base the texture is measured against, mm (the part; for meshes, the
        part with every texture at its lowest)."""
        return _transformed(self._made("_base_mesh", lambda: None), self._placement)

    @property
    def layer_meshes(self) -> list[Mesh]:
        """One closed texture body per layer (one unless several textures were put
        on one part), mm."""
        if self._derived is not None:
            make = self._derived.get("layers")
            return [self.texture_mesh] if make is None else [_transformed(m, self._placement) for m in make()]
        if "_layers" not in self.__dict__:
            self.__dict__["_layers"] = self.stages.adapter.layer_meshes(self.stages)
        return [_transformed(m, self._placement) for m in self.__dict__["_layers"]]

    @property
    def volume(self) -> float:
        """Volume of the fused mesh in mm^3."""
        return float(self.mesh.volume)

    @property
    def max_error(self) -> "float | None":
        """Measured largest height error in mm of the texture surface at the pitch
        grid's points (computed on first use; None if unknown)."""
        if self._max_error is None and self._derived is None:
            self._max_error = self.stages.adapter.max_error(self.stages)
        return None if self._max_error is None else float(self._max_error)

    # -- B-rep ---------------------------------------------------------------------------
    @property
    def has_brep(self) -> bool:
        """Whether this result can have a B-rep at all (it may still fail its check)."""
        if self._derived is not None:
            return self._derived["shape"] is not None
        return self.stages.placement.topo is not None and self.stages.options.brep

    def brep(self, fine: Any = None) -> Any:
        """The textured B-rep in the part's own frame (not moved), unchecked;
        ``fine``: regions tiled finely (CAD operations, :mod:`texcad.pipeline.ops`)."""
        if self._derived is not None:
            raise GeometryError("a result of CAD operations is rebuilt from its history; use .shape")
        return self.stages.adapter.brep(self.stages, fine=fine)

    @property
    def base_shape(self) -> Any:
        """The untextured part's OCCT shape (CAD targets), or None."""
        return self.stages.placement.topo if self.stages is not None else None

    @property
    def history(self) -> Any:
        """The CAD operations made on this result (:mod:`texcad.pipeline.ops`), or None."""
        return None if self._derived is None else self._derived["history"]

    def fine_frame(self) -> Any:
        """The frame in which CAD operations ask for fine tiles, or None."""
        return self.stages.adapter.fine_frame(self.stages) if self._derived is None else None

    @property
    def shape(self):
        """The textured B-rep as an OCP ``TopoDS_Shape`` (the texture as B-spline
        faces sewn into the body), where the part is now. Made on first use and checked
        against the mesh (valid, one solid per body, volume within 0.1 %).

        Raises:
            GeometryError: no B-rep can be made for this result (the message says why
                and names the mesh outputs).
        """
        if self._shape is None:
            if self._derived is not None:
                make = self._derived["shape"]
                if make is None:
                    raise GeometryError(f"this {self.kind} result has no B-rep ({self.info.get('no_brep', 'made from a mesh')}); "
                                        "write STL or 3MF instead")
                with _occt_failures(self.kind):
                    self._shape = make()
            else:
                st = self.stages
                slack = float(self.info.get("volume_slack", 0.0))
                with _occt_failures(self.kind):
                    shape, vb = checked_brep(self.brep(), st.placement.bodies, st.fused.mesh, slack)
                texture_in_brep(vb, st)
                self._shape, self._brep_volume = shape, vb
                self.info["brep_volume"] = self._brep_volume
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
        """:attr:`shape`, under the name build123d and CadQuery objects use."""
        return self.shape

    @property
    def part(self):
        """The B-rep as a build123d ``Part`` whose booleans (``-``, ``+``, ``&``) go
        through texcad's checked operations (:class:`texcad.pipeline.part.TexturedPart`)."""
        from ..brep import flat_solids
        from .part import TexturedPart

        return TexturedPart.of(flat_solids(self.shape), self)  # solids directly in one compound (build123d's volume counts only those)

    @property
    def workplane(self):
        """The B-rep as a CadQuery ``Workplane``."""
        import cadquery as cq

        return cq.Workplane("XY").newObject([cq.Shape.cast(self.shape)])

    # -- placement -----------------------------------------------------------------------
    @property
    def placement(self) -> np.ndarray:
        """Where the part is now against where it was textured: a ``(3, 4)`` matrix."""
        return self._placement.copy()

    @property
    def is_unmoved(self) -> bool:
        """Not moved since texturing (chaining needs the part where it was)."""
        return bool(np.allclose(self._placement, np.eye(3, 4), rtol=0, atol=1e-12))

    def moved(self, location: Any) -> "Textured":
        """A copy moved by ``location`` (a build123d ``Location``, e.g. ``Pos(10, 0,
        0)``, ``Rot(0, 0, 90)``, or a ``(3, 4)`` matrix): meshes and B-rep move
        together; ``Pos(10, 0, 0) * textured`` does the same."""
        m = matrix_of(location)
        out = object.__new__(Textured)
        out.__dict__.update(self.__dict__)
        out.info = dict(self.info)
        out._placement = (np.vstack([m, [0, 0, 0, 1]]) @ np.vstack([self._placement, [0, 0, 0, 1]]))[:3]
        return out

    def __rmul__(self, location: Any) -> "Textured":
        return self.moved(location)

    # -- CAD work on the result ----------------------------------------------------------
    def __sub__(self, tool: Any) -> "Textured":
        """``textured - tool``: cut a build123d / CadQuery shape (a hole, a slot) out of
        the textured part; see :func:`texcad.pipeline.ops.cad_op`."""
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
        """Round ``edges`` (away from the texture) to ``radius`` mm; see
        :func:`texcad.pipeline.ops.fillet`."""
        from .ops import fillet

        return fillet(self, edges, radius)

    def mirrored(self, origin: Any = (0.0, 0.0, 0.0), normal: Any = (1.0, 0.0, 0.0)) -> "Textured":
        """A mirror image about the plane through ``origin`` (mm) with ``normal`` (three
        numbers or an axis such as ``"+x"``), or about a build123d ``Plane`` (``Plane.YZ``)."""
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
        mesh (``separate_texture``: the base and each texture as parts of one object,
        so a slicer can give each texture its own filament; a mesh read from a 3MF of
        several build items as one object per item, each of its own base and texture
        parts, placed by its item), ``.step``/``.stp`` from
        the B-rep, ``.png`` a picture (:meth:`render`). Atomic: a failure leaves no file."""
        from ..io import cura_settings, export, slicer_settings, write_3mf

        p = Path(path)
        if p.suffix.lower() == ".png":
            return self.render(p)
        if separate_texture and p.suffix.lower() == ".3mf" and "paint" in self.info:  # back into the slicer project
            from ..io.paint import write_zones

            write_zones(self.info["paint"], self.base_mesh, self.layer_meshes, self.info["zones"], p)
            return p
        if p.suffix.lower() == ".3mf" and self.kind == "mesh" and self._derived is None and self.is_unmoved \
                and self.info.get("source_3mf"):
            from .items import write_build_items

            # a 3MF of several build items: one object per item, placed as it was (of its base and texture parts)
            if write_build_items(self, p, self._texture_parts() if separate_texture else None):
                return p
        if separate_texture and p.suffix.lower() == ".3mf":
            d = self.stages.options.directions
            up = None if d is None else d[0]
            write_3mf(self._texture_parts(), p, name=name or p.stem,
                      build_dir=up, settings=slicer_settings(self.mesh, up), cura_settings=cura_settings(self.mesh, up))  # as printed
            return p
        write = getattr(self._mesh, "write", None) if self._derived is None and self.is_unmoved else None
        if write is not None and not separate_texture and p.suffix.lower() in (".stl", ".3mf"):
            write(p, **({} if p.suffix.lower() == ".stl" else self._streamed_3mf(name or p.stem)))  # kept in tiles: streamed
            return p
        return export(self, p, separate_texture=separate_texture, name=name)

    def _texture_parts(self) -> list[tuple[str, Mesh]]:
        """``(part name, mesh)``: the base, then each texture layer (named for its zone
        where the texture was painted), the closed meshes that make :attr:`mesh`."""
        layers = self.layer_meshes
        names = ["texture"] if len(layers) == 1 and self.kind != "mesh" else [f"texture {k + 1}" for k in range(len(layers))]
        zones = self.info.get("zones") or []
        names = [zones[k] if k < len(zones) else n for k, n in enumerate(names)]
        return [("base", self.base_mesh)] + list(zip(names, layers))

    def _streamed_3mf(self, name: str) -> dict:
        """A streamed 3MF's name, placement and slicer settings, as :func:`texcad.io.export`
        writes them for a whole mesh (PrusaSlicer's seam; its bridging test needs the
        whole mesh and is left to the profile)."""
        from ..io import cura_settings
        from ..io.export import TEXTURE_SEAM

        d = self.stages.options.directions
        return {"name": name, "build_dir": None if d is None else d[0], "settings": {"seam_position": TEXTURE_SEAM},
                "cura_settings": cura_settings()}

    def render(self, path: "str | os.PathLike", **kwargs: Any) -> Path:
        """PNG picture of the mesh (see :func:`texcad.render.render_part`), seen from
        the side that shows the texture unless ``view=`` says otherwise."""
        from ..render import render_part

        return render_part(self, path, **kwargs)

    def show(self, **kwargs: Any) -> Any:
        """Show the mesh in the OCP CAD viewer (see :func:`texcad.render.show`)."""
        from ..render import show

        return show(self, **kwargs)

    def check(self, **kwargs: Any):
        """:func:`texcad.check` on this result (watertight, volume, overhang area of
        the texture faces for ``build_dir=``)."""
        from ..report import check

        return check(self, **kwargs)


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
