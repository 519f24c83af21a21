"""Looking at parts: PNG pictures of any part, and the OCP CAD viewer."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import ResourceError
from ..io import load_mesh
from ..solid import Mesh, shared_faces
from ..brep import mesh_face, shape_to_mesh
from .raster import render_mesh, write_png

__all__ = ["render_part", "texture_view", "show", "display_shape", "DEFAULT_VIEW"]

#: The direction a picture looks along unless told: from the front left, above.
DEFAULT_VIEW = (-1.0, 2.0, -1.2)

#: How much more texture another view must show to replace :data:`DEFAULT_VIEW`.
VIEW_GAIN = 1.25


def _is_textured(obj: Any) -> bool:
    """A :class:`texcad.Textured` (checked on the type: its meshes are made lazily)."""
    return hasattr(type(obj), "texture_mesh") and hasattr(type(obj), "base_mesh")


def _mesh_of(obj: Any) -> Mesh:
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load_mesh(obj)
    if _is_textured(obj):
        return obj.mesh
    return shape_to_mesh(obj)


def texture_view(mesh: Mesh, base: Mesh, view: Sequence[float] = DEFAULT_VIEW) -> tuple[float, float, float]:
    """The direction to look along that shows a textured part's texture: of ``view``
    and its seven mirror images (the signs of its components flipped), the one that
    maximises the texture's area seen,

        S(v) = sum_i A_i max(0, -n_i . v / |v|),

    over the faces ``i`` of ``mesh`` (area ``A_i`` mm2, unit normal ``n_i``) that
    ``base`` (the part before texturing) does not have (:func:`texcad.solid.shared_faces`);
    ``view`` itself unless another shows :data:`VIEW_GAIN` times as much (a knurled
    cylinder keeps the usual view, a plate textured underneath is seen from below).
    """
    new = ~shared_faces(mesh, base)[0]
    tri = mesh.vertices[mesh.faces[new]].astype(np.float64)
    an = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # (T, 3): area x unit normal
    signs = np.array([[sx, sy, sz] for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)], dtype=np.float64)
    cands = signs * np.asarray(view, dtype=np.float64)
    cands /= np.linalg.norm(cands, axis=1, keepdims=True)
    seen = np.clip(-(an @ cands.T), 0.0, None).sum(axis=0)  # (8,) mm2, cands[0] is view itself
    best = int(np.argmax(seen))
    return tuple(float(c) for c in (signs[best] if seen[best] > VIEW_GAIN * seen[0] else signs[0]) * np.asarray(view, float))


def render_part(
    obj: Any,
    path: str | os.PathLike,
    *,
    width: int = 1200,
    view: Sequence[float] | None = None,
    up: Sequence[float] | None = None,
    supersample: int = 2,
) -> Path:
    """Write a PNG picture of a part (offscreen, plain numpy: :mod:`texcad.render.raster`).

    Args:
        obj: a :class:`texcad.Textured`, a :class:`~texcad.solid.Mesh`, any build123d /
            CadQuery shape (tessellated), or a path to an STL, 3MF, OBJ or STEP file.
        path: output ``.png``.
        width: image width in pixels (height follows the part's aspect).
        view: direction the camera looks along (default :data:`DEFAULT_VIEW`; for a
            textured part, the mirror image of it that shows its texture,
            :func:`texture_view`).
        up: direction shown as up (default +z, or -z for a view that looks up at the
            part: a face seen from below is shown as if the part were turned over,
            lit from the camera's side).
        supersample: anti-aliasing factor.
    """
    if view is None:
        view = texture_view(obj.mesh, obj.base_mesh) if _is_textured(obj) else DEFAULT_VIEW
    if up is None:
        up = (0.0, 0.0, -1.0) if view[2] > 0 else (0.0, 0.0, 1.0)
    img = render_mesh(_mesh_of(obj), view=view, up=up, width=int(width), supersample=int(supersample))
    write_png(path, img)
    return Path(path)


def display_shape(obj: Any):
    """What :func:`show` sends to a viewer: for a :class:`texcad.Textured`, texcad's
    fused mesh as a triangulation-only ``TopoDS_Face`` (see
    :func:`texcad.brep.mesh_face`; OCCT-based viewers would otherwise tessellate
    the large B-spline faces themselves, which takes minutes); a Mesh the same way;
    any other object as it is. Also the object to hand to CQ-editor's ``show_object``."""
    if isinstance(obj, Mesh):
        return mesh_face(obj.vertices, obj.faces)
    if _is_textured(obj):
        m = obj.mesh
        return mesh_face(m.vertices, m.faces)
    return obj


def show(obj: Any, **kwargs: Any) -> Any:
    """Show a part in the OCP CAD viewer (``ocp_vscode``: VS Code, or its standalone
    viewer). A :class:`texcad.Textured` is sent as texcad's mesh (see
    :func:`display_shape`); ``kwargs`` go to ``ocp_vscode.show`` (``names``,
    ``colors``, ``port``...).

    Raises:
        ResourceError: ``ocp_vscode`` is not installed.
    """
    try:
        import ocp_vscode
    except ImportError:
        raise ResourceError("the OCP CAD viewer is not installed; pip install ocp_vscode") from None
    import warnings

    formatted = warnings.formatwarning  # the viewer sets its own for the whole process: put back
    try:
        return ocp_vscode.show(display_shape(obj), **kwargs)
    finally:
        warnings.formatwarning = formatted
