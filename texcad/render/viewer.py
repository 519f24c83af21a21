"""Looking at parts: PNG pictures of any part, and the OCP CAD viewer."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from ..errors import ResourceError
from ..io import load_mesh
from ..solid import Mesh
from ..brep import mesh_face, shape_to_mesh
from .raster import render_mesh, write_png

__all__ = ["render_part", "show", "display_shape"]


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


def render_part(
    obj: Any,
    path: str | os.PathLike,
    *,
    width: int = 1200,
    view: Sequence[float] = (-1.0, 2.0, -1.2),
    up: Sequence[float] = (0.0, 0.0, 1.0),
    supersample: int = 2,
) -> Path:
    """Write a PNG picture of a part (offscreen, plain numpy: :mod:`texcad.render.raster`).

    Args:
        obj: a :class:`texcad.Textured`, a :class:`~texcad.solid.Mesh`, any build123d /
            CadQuery shape (tessellated), or a path to an STL, 3MF, OBJ or STEP file.
        path: output ``.png``.
        width: image width in pixels (height follows the part's aspect).
        view: direction the camera looks along.
        up: direction shown as up.
        supersample: anti-aliasing factor.
    """
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
    return ocp_vscode.show(display_shape(obj), **kwargs)
