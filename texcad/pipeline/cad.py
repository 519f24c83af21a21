"""Textures on any faces of build123d and CadQuery parts that no adapter of their own
takes yet: several faces at once, chaining onto an earlier result, cones, spheres,
tori, B-splines, partial strips, engraved and centred modes, gradients (the general
method of :mod:`texcad.pipeline.faces`: a texture grid on a parameterization of each
face in mm, fused as a mesh; ``Textured.distortion`` reports the texture scale).

A single planar face (:class:`texcad.targets.plane.PlaneAdapter`) and a single full
strip of an extrusion (:class:`texcad.targets.extrusion.ExtrusionAdapter`) have their
adapters and run in the one driver (:func:`texcad.pipeline.driver.run`);
:func:`texture_faces` is the remaining handler for the rest, reached from
:func:`texcad.texture`. B-rep (:mod:`texcad.brep.targets`): each face parameterized on
its own (u, v) becomes a degree-1 B-spline on that parameter space in its place; faces
flattened together, and chained textures, have none: ``.shape`` raises
``GeometryError`` naming the STL / 3MF outputs.
"""

from __future__ import annotations

import os
from typing import Any, Sequence

import numpy as np

from ..brep import plane_frame, solids_of, to_topods
from ..brep import targets as _brep_faces
from ..errors import ParameterError
from ..sources import Heightmap
from ..solid import DEFAULT_TOLERANCE, check_tolerance
from ..targets.extrusion import LIFT
from ..util import Progress, report

__all__ = ["texture_faces", "LIFT"]


def _part_shape(part: Any):
    """The part's ``TopoDS_Shape`` (holding at least one solid)."""
    topo = to_topods(part)
    if not solids_of(topo):
        raise ParameterError(f"the {type(part).__name__} holds no solid to texture; pass a solid part")
    return topo


def _chain_base(part: Any):
    """``(topo, previous)``: the part's shape, and the earlier :class:`Textured` when
    ``part`` is one (chaining: its mesh is the base, its base B-rep gives the faces).

    Raises:
        ParameterError: a textured result that cannot be chained (no base part, or
            moved since).
    """
    from .result import Textured

    prev = part if isinstance(part, Textured) else getattr(part, "texcad", None)
    if not isinstance(prev, Textured):
        return _part_shape(part), None
    if prev.stages is None or prev.stages.placement.topo is None or not prev.is_unmoved:
        raise ParameterError(
            "this textured result cannot be textured again (it was moved, or did not come from a CAD part); "
            "texture all faces in one call: texcad.texture(part, [face1, face2, ...], texture)"
        )
    return prev.stages.placement.topo, prev


def _texture_general(part, topo, prev, faces, texture, *, progress, **opts):
    """Any face kind, several faces, chaining: :mod:`texcad.pipeline.faces`."""
    from .faces import texture_any_faces
    from .result import Textured

    done = []
    st = prev.stages if prev is not None else None
    while st is not None:  # the faces textured by the chain so far
        done += list(st.placement.face_ids)
        st = st.placement.previous
    res = texture_any_faces(topo, faces, texture, base_mesh=prev.mesh if prev is not None else None, progress=progress, **opts)
    again = sorted(set(done) & set(res["face_indices"]))
    if again:
        raise ParameterError(f"face(s) {again} are textured already; texture each face once (all faces in one call)")
    kinds = sorted({k for i in res["info"] for k in i["kinds"]})
    info = {
        "face": "faces" if len(res["info"]) > 1 else res["info"][0]["kinds"][0],
        "faces": res["info"],
        "grid": res["info"][0]["grid"],
        "brep": prev is None,
        "no_brep": (
            f"{', '.join(kinds)} face(s) textured by the general method (a texture grid on the face's "
            "parameterization, fused as a mesh) have no B-rep; write the mesh: export('part.stl') or export('part.3mf')"
        ),
        "distortion": None if res["distortion"] is None else res["distortion"].to_dict(),
        "chained": prev is not None,
        # the lean mesh may enclose up to its error times the textured area more or less than the grid's B-rep
        "volume_slack": res["max_error"] * res["textured_area"],
    }
    if opts.get("build_dir") is not None:
        info["build_dir"] = np.asarray(opts["build_dir"]).tolist()
        info["critical_angle"] = float(opts["critical_angle"])
    limits = _general_limits(res, opts) if opts.get("build_dir") is not None else None
    shape = None
    if prev is None:  # the B-rep on first use: each face textured on its own (u, v) (texcad.brep.uv_textured_solid)
        def make(fine=None):  # fine: (x0, x1, y0, y1) mm in a lone planar face's frame (CAD operations)
            return _brep_faces.general_brep(topo, res, info["no_brep"], opts["rotation"], fine=fine)

        shape = make
        lone = res["reliefs"][0] if len(res["reliefs"]) == 1 else None
        if lone is not None and lone["face"] is not None and lone["tables"] is None:  # one planar face
            p0, ex, ey, _ = plane_frame(lone["face"], opts["rotation"])
            info["fine_frame"] = (p0.tolist(), ex.tolist(), ey.tolist(), float(opts["pitch"]))

    from ..targets.legacy import legacy_stages

    stages = legacy_stages(
        mesh=res["mesh"], texture_mesh=res["texture_mesh"], base_mesh=res["base_mesh"], shape=shape,
        heightmap=res["heightmap"], limits=limits, distortion=res["distortion"], info=info, kind="faces", result_kind="face",
        max_error=res["max_error"],  # 3-D, lean mesh vs the texture grid (0: the grid itself)
        topo=topo, face_ids=tuple(res["face_indices"]), bodies=len(solids_of(topo)),
        previous=prev.stages if prev is not None else None,
    )
    report(progress, 1.0, "textured")
    return Textured(stages)


def _general_limits(res: dict, opts: dict):
    """One :class:`texcad.printability.LimitReport` over the patches."""
    from ..printability import LimitReport

    li = [i["overhang_limit"] for i in res["info"] if "overhang_limit" in i]
    return LimitReport(
        removed_volume_mm3=float(sum(x["removed_volume_mm3"] for x in li)),
        max_removed_mm=float(max((x["max_removed_mm"] for x in li), default=0.0)),
        touched_fraction=float(max((x["touched_fraction"] for x in li), default=0.0)),
        ramped_borders=(),
        critical_angle_deg=float(opts["critical_angle"]),
        margin_deg=1.0,
        directions=np.asarray(opts["build_dir"]),
        remaining_overhang_mm2=float(sum(x["remaining_overhang_mm2"] for x in li)),
        surface_overhang=any(x["surface_overhang"] for x in li),
        iterations=int(max((x["rounds"] for x in li), default=1)),
    )


def _check_options(mapping: str, height: float, pitch: float, depth: float, edge_angle: float, offset) -> None:
    from ..mapping import MAPPINGS

    if mapping not in MAPPINGS:
        raise ParameterError(f"unknown mapping {mapping!r}; use 'angle' (algorithm 2) or 'distance' (algorithm 1)")
    for label, v in (("height", height), ("pitch", pitch), ("depth", depth)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    if not (0 < float(edge_angle) <= 90):
        raise ParameterError(f"edge_angle must be in (0, 90] degrees, got {edge_angle!r}")
    if np.shape(offset) != (2,):
        raise ParameterError(f"offset must be (dx, dy) in mm, got {offset!r}")


def texture_faces(
    part: Any,
    face: Any,
    texture: "str | os.PathLike | Heightmap",
    *,
    height: float = 2.0,
    pitch: float = 0.125,
    mapping: str = "angle",
    depth: float = 0.5,
    edge_angle: float = 45.0,
    rotation: float = 0.0,
    offset: Sequence[float] = (0.0, 0.0),
    periodic_x: bool | None = None,
    transition: float | None = None,
    brep: bool = True,
    build_dir: Any = None,
    critical_angle: float = 45.0,
    tolerance: float = DEFAULT_TOLERANCE,
    mode: str = "raised",
    gradient: Any = None,
    progress: Progress = None,
):
    """Texture a face of a build123d or CadQuery part: see :func:`texcad.texture`
    for the arguments (mm and degrees). Returns a :class:`texcad.Textured` whose
    B-rep is made on first use of ``.shape`` (STEP, CAD work)."""
    from .faces import face_list

    _check_options(mapping, height, pitch, depth, edge_angle, offset)
    tolerance = check_tolerance(tolerance)
    dirs = None
    if build_dir is not None:
        from ..printability import build_directions, check_critical_angle

        dirs = build_directions(build_dir)
        critical_angle = check_critical_angle(critical_angle)
    if not isinstance(texture, Heightmap):
        texture = os.fspath(texture)
    topo, prev = _chain_base(part)
    faces = face_list(face)
    return _texture_general(part, topo, prev, faces, texture, height=height, pitch=pitch, depth=depth,
                            edge_angle=float(edge_angle), rotation=float(rotation), build_dir=dirs,
                            critical_angle=critical_angle, progress=progress, tolerance=tolerance,
                            mode=mode, gradient=gradient)
