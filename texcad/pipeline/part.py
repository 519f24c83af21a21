"""``Textured.part``: a build123d ``Part`` whose booleans go through texcad.

A build123d user drills a textured part the way they drill any part:
``tx.part - Cylinder(1.5, 40)``. OCCT's boolean alone on the textured B-rep is not
checked by anything, and on some parts it is silently wrong (a radial hole through a
textured full cylinder comes back uncut, as a valid solid). :class:`TexturedPart`
keeps a link to the :class:`~texcad.Textured` it is the B-rep of, and its ``-``,
``+``, ``&``, ``cut``, ``fuse`` and ``intersect`` run texcad's operation instead
(:func:`texcad.pipeline.ops.cad_op`: the tiles re-made under the tool, or the face
textured again on the operated part, and the answer checked against the same
operation on the mesh), returning that result's ``.part``: a valid solid within
0.1 % of the mesh, or a :class:`~texcad.errors.GeometryError` with the figures.

A copy (``copy``, ``deepcopy``, so also ``moved``, ``located``, ``mirror``) drops
the link and is a plain ``Part``'s boolean again, as is every other build123d
operation (``fillet``: use ``Textured.fillet``).
"""

from __future__ import annotations

from typing import Any

from build123d import Part, Shape

__all__ = ["TexturedPart"]


class _Link:
    """The textured result a part is the B-rep of; copies of the part do not keep it
    (a moved copy is another solid, and deep-copying meshes would be slow)."""

    __slots__ = ("textured",)

    def __init__(self, textured: Any) -> None:
        self.textured = textured

    def __copy__(self) -> "_Link":
        return _Link(None)

    def __deepcopy__(self, memo: dict) -> "_Link":
        return _Link(None)


def _tools(other: Any) -> list:
    """``other`` as a list of tools, each textured part as its textured result."""
    items = [other] if isinstance(other, Shape) or not hasattr(other, "__iter__") else list(other)
    return [_textured_of(t) or t for t in items if t is not None]


def _textured_of(shape: Any) -> Any:
    link = getattr(shape, "__dict__", {}).get("_texcad_link")
    return link.textured if isinstance(link, _Link) else None


class TexturedPart(Part):
    """A build123d ``Part`` (module docstring): booleans through texcad while it is
    the B-rep of its textured result. Lengths mm."""

    @classmethod
    def of(cls, shape: Any, textured: Any) -> "TexturedPart":
        """The part of ``shape`` (an OCP solid or compound) linked to ``textured``."""
        part = cls(shape)
        part._texcad_link = _Link(textured)
        return part

    def _op(self, tools: list, kind: str) -> Any:
        from .ops import cad_op

        result = _textured_of(self)
        for tool in tools:  # one checked operation per tool
            result = cad_op(result, tool, kind)
        return result.part

    def cut(self, *to_cut: Shape) -> Any:
        """``self - tools`` through texcad (:func:`texcad.pipeline.ops.cad_op`)."""
        if _textured_of(self) is None:
            return super().cut(*to_cut)
        return self._op(_tools(list(to_cut)), "cut")

    def fuse(self, *to_fuse: Shape, glue: bool = False, tol: float | None = None) -> Any:
        """``self + tools`` through texcad (OCCT's own with ``glue`` or ``tol``)."""
        if _textured_of(self) is None or glue or tol is not None:
            return super().fuse(*to_fuse, glue=glue, tol=tol)
        return self._op(_tools(list(to_fuse)), "fuse")

    def intersect(self, *to_intersect: Any, **kwargs: Any) -> Any:
        """``self & tools`` through texcad for solids (OCCT's own for anything else)."""
        if _textured_of(self) is None or kwargs or not all(isinstance(t, Shape) and t._dim == 3 for t in to_intersect):
            return super().intersect(*to_intersect, **kwargs)
        return self._op(_tools(list(to_intersect)), "common")

    def __add__(self, other: Any) -> Any:
        if _textured_of(self) is None or other is None:
            return super().__add__(other)
        return self._op(_tools(other), "fuse")

    def __and__(self, other: Any) -> Any:
        if _textured_of(self) is None or other is None:
            return super().__and__(other)
        return self._op(_tools(other), "common")
