"""Exceptions raised by texcad.

Every error texcad raises on purpose derives from :class:`TexcadError`. The message
names what is wrong, with the offending value, and what to do instead, so that the
CLI can print it on one line and a recipe author can act on it without a traceback.
"""

from __future__ import annotations

__all__ = [
    "TexcadError",
    "InputError",
    "ParameterError",
    "GeometryError",
    "ResourceError",
    "TexcadWarning",
]


class TexcadError(Exception):
    """Base class of every error texcad raises on purpose."""


class InputError(TexcadError):
    """An input file or array cannot be used (unreadable, empty, NaN, no contrast...)."""


class ParameterError(TexcadError, ValueError):
    """A parameter is out of range or unknown (non-positive size, unknown option...)."""


class GeometryError(TexcadError):
    """The requested geometry cannot be made (texture too tall, not watertight...)."""


class ResourceError(TexcadError):
    """The job would need more memory (or disk) than this machine has."""


class TexcadWarning(UserWarning):
    """texcad changed something to make the geometry possible (e.g. limited the
    texture height where it would fold); the message says what and where."""
