"""The options of :func:`texcad.texture`, typed and validated once.

One :class:`Options` object carries every option of every target kind, with one set
of defaults shared by the Python API and the ``texcad`` command (lengths in mm,
angles in degrees). :meth:`Options.make` validates the values the caller gave and
remembers which they were (:attr:`Options.given`), so that a target can refuse an
option that does not apply to it instead of ignoring it. Vocabularies are enums
(:class:`Mode`, :class:`Mapping`); their string values are accepted too.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from .errors import ParameterError

__all__ = ["Mode", "Mapping", "Options", "DEFAULTS", "RUN_OPTIONS", "option_names", "memory_bytes"]

#: Options of how a job runs, not of what it makes: every target takes them.
RUN_OPTIONS = ("progress", "max_memory", "client")


class Mode(str, enum.Enum):
    """Which way the texture goes: out of the part, into it, or half and half."""

    RAISED = "raised"  #: outward; the part's surface is the texture's floor
    ENGRAVED = "engraved"  #: inward; the part's outer envelope is the texture's top
    CENTRED = "centred"  #: half out, half in

    @property
    def share(self) -> float:
        """The share ``c`` of the height that goes into the part (0, 1, 1/2)."""
        return {"raised": 0.0, "engraved": 1.0, "centred": 0.5}[self.value]

    @classmethod
    def parse(cls, value: Any) -> "Mode":
        if isinstance(value, cls):
            return value
        text = str(value).strip().lower().replace("centered", "centred")
        try:
            return cls(text)
        except ValueError:
            raise ParameterError(f"mode {value!r}: use raised, engraved or centred") from None


class Mapping(str, enum.Enum):
    """How a texture is laid on a curved 2.5D face (paper, section 2.2)."""

    ANGLE = "angle"  #: algorithm 2: heights along the surface normal (angle-preserving)
    DISTANCE = "distance"  #: algorithm 1: heights along z (distance-preserving)

    @classmethod
    def parse(cls, value: Any) -> "Mapping":
        if isinstance(value, cls):
            return value
        try:
            return cls(str(value).strip().lower())
        except ValueError:
            raise ParameterError(f"unknown mapping {value!r}; use 'angle' (algorithm 2) or 'distance' (algorithm 1)") from None


def _positive(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ParameterError(f"{name} must be a positive number of mm, got {v!r}")
    return float(v)


def _finite(name: str, v: Any, unit: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ParameterError(f"{name} must be a number of {unit}, got {v!r}")
    return float(v)


def _pair(name: str, v: Any) -> tuple[float, float]:
    try:
        a, b = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be two numbers (mm), got {v!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ParameterError(f"{name} must be finite (mm), got {v!r}")
    return a, b


def _is_default(value: Any, default: Any) -> bool:
    """``value`` is the option's ``default``: the same enum member, string, flag or
    number (arrays and other objects never count as a default)."""
    if default is None:
        return value is None
    if isinstance(default, (enum.Enum, str, bool)):
        return type(value) is type(default) and value == default
    if isinstance(default, (int, float)):
        return isinstance(value, (int, float)) and not isinstance(value, bool) and float(value) == float(default)
    return False


@dataclass(frozen=True)
class Options:
    """Every option of :func:`texcad.texture`; lengths in mm, angles in degrees.

    Common to every target:
        height: largest texture height, mm (1.0).
        pitch: mm per texture pixel on faces and surfaces; the longest edge after
            subdivision on meshes (0.25).
        mode: :class:`Mode` (raised).
        tolerance: largest distance in mm from the mesh to the exact texture (0.02;
            0 = one vertex per pixel / the pitch grid itself).
        build_dir: print without support for this build direction ``(x, y, z)`` or
            axis word (``"+z"``, ``"-y"``), or each of several, in the part's frame;
            None: no overhang limit.
        critical_angle: the steepest overhang that prints without support, degrees
            from the build plate (45).
        gradient: ``((x0, y0, z0), (x1, y1, z1))`` (or the six numbers flat) mm: full height at the first
            point, none at the second; or None.
        rotation: turns the texture about the face normal (planar faces), the
            projection axis (meshes) or within a flattened patch of several faces
            (whose x lies along its outline's edges, else its long axis), degrees (0).
        max_memory: bound on the job's memory, bytes, or None (what the machine has).
        client: a ``dask.distributed.Client`` or a scheduler address
            (``"tcp://HOST:PORT"``): a part made in tiles or blocks (a plate, a mesh
            beyond ``max_memory``) makes them on that cluster, the same bytes as here;
            None: here. Needs ``pip install "texcad[dask]"``.
        progress: a ``progress(fraction, message)`` callback, or None.

    CAD faces and 2.5D surfaces:
        mapping: :class:`Mapping` (angle); depth: how far the texture slab reaches
        into the body, mm (0.5); edge_angle: the M-I ramp at a planar outline,
        degrees in (0, 90] (45); offset: ``(dx, dy)`` mm; periodic_x, transition:
        closed profiles and fades (:func:`texcad.mapping.map_texture`); brep: the
        B-rep can be made (True).

    2.5D surfaces: length (extrusion of a profile, mm), base, thickness (mm).

    Meshes: projection (``triplanar``), axis, origin, radius, blend (20 degrees),
    local_radius, border (2 mm fade at the region's border), scale (1), size (an
    image tile, ``(w, d)`` mm), mask, mask_size; union: unite overlapping or touching
    bodies first (manifold3d) instead of refusing them (False).
    """

    height: float = 1.0
    pitch: float = 0.25
    mode: Mode = Mode.RAISED
    tolerance: float = 0.02
    build_dir: Optional[tuple] = None
    critical_angle: float = 45.0
    gradient: Optional[tuple] = None
    rotation: float = 0.0
    max_memory: Optional[int] = None
    client: Any = field(default=None, compare=False, repr=False)
    progress: Optional[Callable[[float, str], None]] = field(default=None, compare=False, repr=False)
    # CAD faces and surfaces
    mapping: Mapping = Mapping.ANGLE
    depth: float = 0.5
    edge_angle: float = 45.0
    offset: tuple = (0.0, 0.0)
    periodic_x: Optional[bool] = None
    transition: Optional[float] = None
    brep: bool = True
    # 2.5D surfaces
    length: Optional[float] = None
    base: Any = None
    thickness: Optional[float] = None
    # meshes
    projection: Any = "triplanar"
    axis: Any = None
    origin: Any = None
    radius: Optional[float] = None
    blend: float = 20.0
    local_radius: Optional[float] = None
    border: float = 2.0
    scale: float = 1.0
    size: Optional[tuple] = None
    mask: Any = None
    mask_size: Optional[tuple] = None
    union: bool = False
    #: the names the caller gave (the rest are defaults)
    given: frozenset = field(default=frozenset(), compare=False, repr=False)

    @classmethod
    def make(cls, **options: Any) -> "Options":
        """Options from keyword arguments, validated once (ParameterError names the
        option, the value and what is allowed). ``None`` means the default."""
        names = option_names()
        bad = sorted(set(options) - set(names))
        if bad:
            raise ParameterError(f"{', '.join(bad)}: not an option of texcad.texture; the options are {', '.join(names)}")
        given = {k: v for k, v in options.items() if v is not None}
        return cls(**{k: _validate(k, v) for k, v in given.items()}, given=frozenset(given))

    def replace(self, **changes: Any) -> "Options":
        """A copy with ``changes`` validated (and counted as given)."""
        if not changes:
            return self
        names = option_names()
        bad = sorted(set(changes) - set(names))
        if bad:
            raise ParameterError(f"{', '.join(bad)}: not an option of texcad.texture; the options are {', '.join(names)}")
        given = {k: v for k, v in changes.items() if v is not None}
        return dataclasses.replace(self, **{k: _validate(k, v) for k, v in given.items()}, given=self.given | set(given))

    @property
    def changed(self) -> frozenset:
        """The options given at another value than their default: those that change
        what is made (``rotation=0`` from the command line changes nothing)."""
        defaults = {f.name: f.default for f in dataclasses.fields(self) if f.default is not dataclasses.MISSING}
        return frozenset(n for n in self.given if n not in defaults or not _is_default(getattr(self, n), defaults[n]))

    def refuse(self, allowed: "frozenset[str] | set[str]", target: str) -> None:
        """ParameterError for every option the caller gave that ``target`` does not
        use (an option is never silently ignored)."""
        extra = sorted(self.changed - set(allowed) - set(RUN_OPTIONS))
        if extra:
            raise ParameterError(
                f"{', '.join(extra)}: not an option when texturing {target}; "
                f"the options there are {', '.join(sorted(set(allowed) | set(RUN_OPTIONS)))}"
            )

    def report(self, fraction: float, message: str) -> None:
        """Tell the progress callback (if any)."""
        if self.progress is not None:
            self.progress(float(fraction), message)

    @property
    def directions(self):
        """``build_dir`` as ``(K, 3)`` unit float64 vectors, or None."""
        if self.build_dir is None:
            return None
        import numpy as np

        return np.asarray(self.build_dir, dtype=np.float64)

    def as_kwargs(self, names) -> dict:
        """``{name: value}`` for ``names``, enums as their strings (for the stage
        functions, which take plain data)."""
        out = {}
        for n in names:
            v = getattr(self, n)
            out[n] = v.value if isinstance(v, enum.Enum) else v
        if "build_dir" in out and self.build_dir is not None:  # one direction as a (3,) vector, several as (K, 3)
            d = self.directions
            out["build_dir"] = d[0] if len(d) == 1 else d
        return out


_UNITS = {"": 1, "B": 1, "K": 1 << 10, "KB": 1 << 10, "KIB": 1 << 10, "M": 1 << 20, "MB": 1 << 20, "MIB": 1 << 20,
          "G": 1 << 30, "GB": 1 << 30, "GIB": 1 << 30, "T": 1 << 40, "TB": 1 << 40, "TIB": 1 << 40}


def memory_bytes(value: Any) -> int:
    """A memory size as bytes: an int, or text such as ``"4GB"``, ``"512 MiB"``
    (K/M/G/T are powers of 1024)."""
    import re

    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
        return int(value)
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([A-Za-z]*)\s*", str(value))
    if not m or m.group(2).upper() not in _UNITS or float(m.group(1)) <= 0:
        raise ParameterError(f"max_memory must be a size such as 4GB or 512MB, got {value!r}")
    return int(float(m.group(1)) * _UNITS[m.group(2).upper()])


def option_names() -> tuple[str, ...]:
    """Every option's name, in declaration order."""
    return tuple(f.name for f in dataclasses.fields(Options) if f.name != "given")


def _validate(name: str, v: Any) -> Any:
    """One option's value, checked and normalised."""
    if name in ("height", "pitch", "depth", "scale"):
        return _positive(name, v)
    if name == "mode":
        return Mode.parse(v)
    if name == "mapping":
        return Mapping.parse(v)
    if name == "tolerance":
        from .solid import check_tolerance

        return check_tolerance(v)
    if name == "critical_angle":
        from .printability import check_critical_angle

        return check_critical_angle(v)
    if name == "build_dir":
        from .printability import build_directions

        return tuple(tuple(float(c) for c in row) for row in build_directions(v))
    if name == "edge_angle":
        a = _finite(name, v, "degrees")
        if not 0 < a <= 90:
            raise ParameterError(f"edge_angle must be in (0, 90] degrees, got {v!r}")
        return a
    if name in ("rotation", "blend"):
        return _finite(name, v, "degrees")
    if name == "border":
        b = _finite(name, v, "mm")
        if b < 0:
            raise ParameterError(f"border must be a width >= 0 in mm, got {v!r}")
        return b
    if name in ("offset", "size", "mask_size"):
        return _pair(name, v)
    if name == "gradient":
        try:
            flat = [float(c) for c in v] if len(v) == 6 else None  # (x0, y0, z0, x1, y1, z1) as the CLI gives it
            a, b = (tuple(flat[:3]), tuple(flat[3:])) if flat else (tuple(float(c) for c in p) for p in v)
        except (TypeError, ValueError):
            raise ParameterError(f"gradient must be two points ((x0, y0, z0), (x1, y1, z1)) or six numbers in mm, got {v!r}") from None
        if len(a) != 3 or len(b) != 3 or a == b or not all(map(math.isfinite, a + b)):
            raise ParameterError(f"gradient must be two different finite points (mm), got {v!r}")
        return a, b
    if name == "max_memory":
        return memory_bytes(v)
    if name == "client":
        if not (isinstance(v, str) and "://" in v) and not callable(getattr(v, "submit", None)):
            raise ParameterError(f"client must be a dask.distributed.Client or a scheduler address such as "
                                 f"'tcp://HOST:8786', got {v!r}")
        return v
    if name == "progress":
        if not callable(v):
            raise ParameterError(f"progress must be a callable progress(fraction, message), got {v!r}")
        return v
    if name == "brep":
        return bool(v)
    if name == "union":
        if not isinstance(v, (bool, int)) or v not in (0, 1):
            raise ParameterError(f"union must be True or False, got {v!r}")
        return bool(v)
    if name in ("length", "thickness", "radius", "local_radius", "transition"):
        return _positive(name, v)
    return v


#: The defaults, shared by the API and the ``texcad`` command.
DEFAULTS = Options()
