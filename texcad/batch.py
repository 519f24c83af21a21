"""Many texturing jobs at once, on a Dask cluster: :func:`batch`.

A job is a mapping of

* ``part``: a path to the part, ``.step``/``.stp`` (CAD) or ``.stl``/``.3mf``/``.obj`` (mesh);
* ``where``: CAD parts: face selectors as ``texcad texture --face`` takes them
  (``"top"``, ``"cylinder:all"``, ``"normal:0,0,1"``, a face index; one or a list;
  default ``"top"``); meshes: a region as ``--region`` takes it
  (``"not-bottom"``, ``"normal:+x:70"``, ``"REGION@TEXTURE@MODE"``; one or a list of layers;
  default ``"not-bottom"``);
* ``texture``: ``"builtin:NAME"`` or an image path (default ``builtin:stones``);
* ``options``: the keyword options of :func:`texcad.texture` (mm, degrees);
* ``outputs``: the files to write (``.stl``, ``.3mf``, ``.step``, ``.png``; one or a list);
* ``name`` (optional): how reports call the job (default ``job N``).

Every job is checked before anything runs (:func:`validate`). Each job runs whole in
one worker through the public API (:func:`texcad.texture`, :meth:`texcad.Textured.export`),
so its bytes do not depend on the number of workers or where it ran; outputs are
written atomically (a temporary file in the target folder, renamed when complete). A
job that fails is reported with its error and does not stop the others; a job whose
worker dies is run once more and then reported (the local cluster's scheduler allows
one failure per task; an existing cluster keeps its own ``allowed-failures``).

Dask is an optional extra: ``pip install texcad[dask]``.
"""

from __future__ import annotations

import csv
import os
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence

from .errors import InputError, ParameterError, ResourceError, TexcadError

__all__ = ["Job", "JobResult", "batch", "validate", "load_jobs", "run_job"]

#: The keys a job may have.
JOB_KEYS = ("name", "part", "where", "texture", "options", "outputs")
CAD_SUFFIXES = (".step", ".stp")
MESH_SUFFIXES = (".stl", ".3mf", ".obj")
OUTPUT_SUFFIXES = (".stl", ".3mf", ".step", ".stp", ".png")
#: Seconds to wait for an existing scheduler before giving up.
CONNECT_TIMEOUT = 5.0


@dataclass(frozen=True)
class Job:
    """One validated job (paths absolute; ``options`` as given, already checked by
    :meth:`texcad.options.Options.make`)."""

    name: str
    part: str
    where: tuple
    texture: str
    options: dict = field(default_factory=dict)
    outputs: tuple = ()

    @property
    def is_mesh(self) -> bool:
        return Path(self.part).suffix.lower() in MESH_SUFFIXES


@dataclass(frozen=True)
class JobResult:
    """What became of one job.

    Attributes:
        name: the job's name.
        status: ``"ok"`` or ``"failed"``.
        outputs: the files written (absolute paths; none when the job failed).
        error: the error's one-line message (``"InputError: ..."``), or None.
        seconds: wall time of the job in its worker (0 when its worker died).
        triangles: triangles of the textured mesh (0 when it failed).
        cpu_seconds: CPU time (user + system) of the worker process during the job,
            threads included: the job's cost apart from how busy the machine was.
    """

    name: str
    status: str
    outputs: tuple = ()
    error: Optional[str] = None
    seconds: float = 0.0
    triangles: int = 0
    cpu_seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status == "ok"


# -- job files ---------------------------------------------------------------------------------


def _split(text: str) -> list[str]:
    return [t.strip() for t in str(text).split(";") if t.strip()]


def _number(text: str) -> Any:
    """A CSV cell as a number, a boolean, a list (``a;b``: selectors, points) or text."""
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    for kind in (int, float):
        try:
            return kind(t)
        except ValueError:
            pass
    if "," in t and ";" not in t:  # a vector "0,0,1" or pair "10,20"
        try:
            return tuple(float(c) for c in t.split(","))
        except ValueError:
            pass
    return t


def load_jobs(path: "str | os.PathLike") -> list[dict]:
    """The jobs of a job file, as mappings (relative paths are relative to the file).

    ``.toml``: a table per job in ``[[job]]`` (keys as in the module docstring) and
    an optional ``[defaults]`` table merged into every job (its ``options`` merged
    key by key). ``.csv``: a header row; the columns ``name``, ``part``, ``where``,
    ``texture``, ``outputs`` (several values separated by ``;``) and any other column
    an option of :func:`texcad.texture` (``height``, ``pitch``...; empty cells: the default).

    Raises:
        InputError: the file is missing or not valid TOML / CSV.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"job file {str(p)!r} does not exist")
    base = p.resolve().parent
    if p.suffix.lower() == ".toml":
        import tomllib

        try:
            doc = tomllib.loads(p.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"job file {str(p)!r} is not valid TOML: {exc}") from None
        extra = sorted(set(doc) - {"job", "defaults"})
        if extra:
            raise ParameterError(f"{p.name}: unknown table(s) {', '.join(extra)}; use [defaults] and [[job]]")
        defaults = doc.get("defaults", {})
        jobs = []
        for j in doc.get("job", []):  # per job
            merged = {**defaults, **j}
            merged["options"] = {**defaults.get("options", {}), **j.get("options", {})}
            jobs.append(merged)
    elif p.suffix.lower() == ".csv":
        with open(p, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
        jobs = []
        for row in rows:  # per job
            job: dict = {"options": {}}
            for k, v in row.items():
                if k is None or v is None:
                    raise InputError(f"{p.name}: a row has more cells than the header ({row})")
                k, v = k.strip(), v.strip()
                if not v:
                    continue
                if k in ("where", "outputs"):
                    job[k] = _split(v)
                elif k in ("name", "part", "texture"):
                    job[k] = v
                else:
                    job["options"][k] = _number(v)
            jobs.append(job)
    else:
        raise InputError(f"job file {str(p)!r}: use a .toml or .csv file")
    if not jobs:
        raise InputError(f"job file {str(p)!r} holds no jobs")
    for j in jobs:  # relative paths from the job file's folder
        for k in ("part", "texture"):
            if isinstance(j.get(k), str) and not j[k].startswith("builtin:") and not os.path.isabs(j[k]):
                j[k] = str(base / j[k])
        if "outputs" in j:
            outs = [j["outputs"]] if isinstance(j["outputs"], str) else j["outputs"]
            j["outputs"] = [o if os.path.isabs(o) else str(base / o) for o in outs]
    return jobs


# -- validation ---------------------------------------------------------------------------------


def _check_texture(label: str, key: str, tex: str) -> str:
    """``tex`` if it names a built-in (with parameters it accepts: one tile sampled
    coarsely) or an existing image file."""
    if tex.startswith("builtin:"):
        from .sources import builtin

        try:
            builtin(tex, pitch=0.5)
        except ParameterError as exc:
            raise ParameterError(f"{label}: {key}: {exc}") from None
    elif not Path(tex).is_file():
        raise InputError(f"{label}: {key}: texture {tex!r} does not exist; use builtin:NAME or an image file")
    return tex


def _check_selector(label: str, which: str) -> None:
    """A ``--face`` selector's form (:func:`texcad.brep.selectors.check_selector`)."""
    from .brep.selectors import check_selector

    try:
        check_selector(which)
    except ParameterError as exc:
        raise ParameterError(f"{label}: where: {exc}") from None


def _one_job(k: int, job: Any) -> Job:
    if isinstance(job, Job):
        job = {"name": job.name, "part": job.part, "where": list(job.where), "texture": job.texture,
               "options": job.options, "outputs": list(job.outputs)}
    if not isinstance(job, Mapping):
        raise ParameterError(f"job {k}: expected a mapping of {', '.join(JOB_KEYS)}, got {type(job).__name__}")
    name = str(job.get("name") or f"job {k}")
    label = f"job {k} ({name})" if job.get("name") else f"job {k}"
    bad = sorted(set(job) - set(JOB_KEYS))
    if bad:
        raise ParameterError(f"{label}: unknown key(s) {', '.join(map(str, bad))}; a job has {', '.join(JOB_KEYS)}")
    if "part" not in job:
        raise ParameterError(f"{label}: key 'part' is missing: the path of a STEP, STL, 3MF or OBJ file")
    part = Path(os.fspath(job["part"]))
    if part.suffix.lower() not in CAD_SUFFIXES + MESH_SUFFIXES:
        raise ParameterError(f"{label}: part {str(part)!r}: use a .step, .stp, .stl, .3mf or .obj file")
    if not part.is_file():
        raise InputError(f"{label}: part {str(part)!r} does not exist")
    mesh = part.suffix.lower() in MESH_SUFFIXES
    where = job.get("where") or ("not-bottom" if mesh else "top")
    where = (where,) if isinstance(where, (str, int)) else tuple(where)
    if not all(isinstance(w, (str, int)) for w in where):
        raise ParameterError(f"{label}: where {job.get('where')!r}: give face selectors or regions as text")
    where = tuple(str(w) for w in where)
    tex = _check_texture(label, "texture", str(job.get("texture") or "builtin:stones"))
    if mesh:
        for w in where:  # REGION@TEXTURE@MODE layers name their own textures
            region, _, rest = w.partition("@")
            t, _, _ = rest.rpartition("@") if rest.count("@") else (rest, "", "")
            if t:
                _check_texture(label, f"where {w!r}", t)
    if not mesh:
        for w in where:  # the selector's form (whether the part has such a face is known when it is read)
            _check_selector(label, w)
    if not isinstance(job.get("options") or {}, Mapping):
        raise ParameterError(f"{label}: options must be a mapping of texcad.texture's options, got {job['options']!r}")
    options = dict(job.get("options") or {})
    if "progress" in options:
        raise ParameterError(f"{label}: option 'progress' cannot be sent to a worker; batch() reports progress")
    from .options import Options, option_names

    names = option_names()
    for key, value in options.items():  # per option: name the key that is wrong
        if key not in names:
            raise ParameterError(f"{label}: unknown option {key!r}; the options of texcad.texture are {', '.join(names)}")
        try:
            Options.make(**{key: value})
        except ParameterError as exc:
            raise ParameterError(f"{label}: option {key!r}: {exc}") from None
    outs = job.get("outputs")
    if not outs:
        raise ParameterError(f"{label}: key 'outputs' is missing: the files to write (.stl, .3mf, .step, .png)")
    outs = (outs,) if isinstance(outs, (str, os.PathLike)) else tuple(outs)
    outputs = []
    for o in outs:
        po = Path(os.fspath(o)).resolve()
        if po.suffix.lower() not in OUTPUT_SUFFIXES:
            raise ParameterError(f"{label}: output {str(o)!r}: use .stl, .3mf, .step or .png")
        if mesh and po.suffix.lower() in (".step", ".stp"):
            raise ParameterError(f"{label}: output {str(o)!r}: a mesh part has no B-rep; write .stl or .3mf")
        outputs.append(str(po))
    return Job(name=name, part=str(part.resolve()), where=where, texture=tex, options=options, outputs=tuple(outputs))


def validate(jobs: Iterable[Any]) -> list[Job]:
    """The jobs checked, before anything runs: known keys, an existing part and
    texture, options :func:`texcad.texture` accepts, outputs of a known format, no
    output written by two jobs.

    Raises:
        ParameterError / InputError: naming the job (its number and name) and the key.
    """
    out = [_one_job(k, j) for k, j in enumerate(jobs)]
    if not out:
        raise ParameterError("batch: no jobs given")
    seen: dict = {}
    for k, j in enumerate(out):
        for o in j.outputs:
            if o in seen:
                raise ParameterError(f"job {k} ({j.name}): output {o!r} is written by job {seen[o]} too; give each job its own files")
            seen[o] = k
    return out


# -- one job (runs in a worker) --------------------------------------------------------------


def _layers(job: Job) -> list:
    """A mesh job's ``where`` as layers ``(region, texture, {mode})`` (``REGION@TEXTURE@MODE``,
    as ``texcad texture --region`` reads it)."""
    layers = []
    for spec in job.where:  # per layer
        region, _, rest = spec.partition("@")
        tex, _, mode = rest.rpartition("@") if rest.count("@") else (rest, "", "")
        layers.append((region, tex or job.texture, {"mode": mode} if mode else {}))
    return layers


def run_job(job: Job) -> JobResult:
    """Run one validated job here: texture, export every output. A
    :class:`texcad.TexcadError` (or any other exception) becomes a failed result."""
    import warnings

    from . import texture
    from .errors import TexcadWarning

    t0, c0 = time.perf_counter(), _cpu()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TexcadWarning)
            if job.is_mesh:
                tx = texture(job.part, _layers(job), **job.options)
            else:
                from build123d import Compound

                from .brep.selectors import faces_named  # the --face selectors, one definition
                from .io import read_step

                part = Compound(read_step(job.part))
                faces: list = []
                for which in job.where:  # per selector
                    faces += [f for f in faces_named(part, which) if not any(f.is_same(g) for g in faces)]
                tx = texture(part, faces[0] if len(faces) == 1 else faces, job.texture, **job.options)
            for o in job.outputs:  # atomic: Textured.export writes a temporary file and renames it
                Path(o).parent.mkdir(parents=True, exist_ok=True)
                tx.export(o)
        return JobResult(job.name, "ok", job.outputs, None, time.perf_counter() - t0, int(tx.mesh.num_triangles), _cpu() - c0)
    except TexcadError as exc:
        msg = f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # a bug: reported, the other jobs go on
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        msg = f"{type(exc).__name__}: {exc} (at {Path(tb.filename).name}:{tb.lineno}; please report this)"
    return JobResult(job.name, "failed", (), msg, time.perf_counter() - t0, 0, _cpu() - c0)


def _cpu() -> float:
    """CPU seconds (user + system) of this process so far."""
    import resource

    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


# -- the cluster ------------------------------------------------------------------------------


def _dask():
    try:
        import distributed
    except ImportError:
        raise ParameterError("texcad.batch needs Dask: pip install 'texcad[dask]' (dask[distributed])") from None
    return distributed


def connect(scheduler: str, timeout: float = CONNECT_TIMEOUT):
    """A ``dask.distributed.Client`` of the scheduler at ``scheduler``
    (``tcp://HOST:PORT``), or :class:`texcad.ResourceError` within ``timeout`` seconds."""
    distributed = _dask()
    import logging

    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        return distributed.Client(scheduler, timeout=f"{timeout}s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ResourceError(
            f"cannot reach the Dask scheduler at {scheduler!r} within {timeout:g} s ({type(exc).__name__}); "
            "start it (dask scheduler), check the address and port, or leave out the scheduler to run on a local cluster"
        ) from None
    finally:
        quiet.setLevel(level)


def local_cluster(workers: Optional[int] = None):
    """A local Dask cluster of ``workers`` processes (default: the cores), one thread
    each, and its client. Each worker's texcad uses ``cores / workers`` threads."""
    distributed = _dask()
    n = int(workers or os.cpu_count() or 1)
    if n < 1:
        raise ParameterError(f"workers must be at least 1, got {workers!r}")
    threads = max(1, (os.cpu_count() or 1) // n)
    import dask

    # a task whose worker dies is run once more, then reported (KilledWorker)
    with dask.config.set({"distributed.scheduler.allowed-failures": 1, "logging.distributed": "error"}):
        cluster = distributed.LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
            env={"TEXCAD_THREADS": str(threads)}, silence_logs=50,
        )
    return cluster, distributed.Client(cluster, set_as_default=False)


def batch(
    jobs: "Iterable[Mapping[str, Any]] | str | os.PathLike",
    client: Any = None,
    *,
    workers: Optional[int] = None,
    progress: Optional[Callable[[float, str], None]] = None,
    timeout: float = CONNECT_TIMEOUT,
    runner: Callable[[Job], JobResult] = None,
) -> list[JobResult]:
    """Run texturing jobs on a Dask cluster; the results in the jobs' order.

    Args:
        jobs: job mappings (module docstring) or :class:`Job`; or the path of a job
            file (``.toml`` or ``.csv``, :func:`load_jobs`).
        client: a ``dask.distributed.Client``, or a scheduler address
            ``"tcp://HOST:PORT"``; None: a local cluster of ``workers`` processes,
            started and closed here.
        workers: local cluster size (default: the cores). Not with ``client``.
        progress: ``progress(fraction, message)`` after each job: jobs done / total.
        timeout: seconds to wait for a scheduler at an address.
        runner: what runs one job in a worker (default :func:`run_job`; a wrapper
            for tests or logging).

    Returns:
        One :class:`JobResult` per job (``status``, ``outputs``, ``error``, ``seconds``).

    Raises:
        ParameterError / InputError: a bad job, before any job runs.
        ResourceError: the scheduler cannot be reached.
    """
    if isinstance(jobs, (str, os.PathLike)):
        jobs = load_jobs(jobs)
    checked = validate(jobs)
    if client is not None and workers is not None:
        raise ParameterError("batch: give workers (a local cluster) or client (an existing one), not both")
    distributed = _dask()
    cluster = None
    own = False
    if client is None:
        cluster, client = local_cluster(workers)
        own = True
    elif isinstance(client, str):
        client = connect(client, timeout)
        own = True
    try:
        futures = {}
        for k, job in enumerate(checked):  # per job; pure=False: a job writes files, run it each time
            futures[client.submit(runner or run_job, job, retries=1, pure=False, key=f"texcad-job-{k}-{os.getpid()}-{time.time_ns()}")] = k
        results: list = [None] * len(checked)
        done = 0
        for fut in distributed.as_completed(list(futures), loop=client.loop):  # per finished job
            k = futures[fut]
            try:
                r = fut.result()
            except distributed.KilledWorker:
                r = JobResult(checked[k].name, "failed", (), "the worker running it died twice (out of memory?); run it alone or give workers more memory")
            except Exception as exc:  # lost on the way (cancelled, scheduler gone)
                r = JobResult(checked[k].name, "failed", (), f"{type(exc).__name__}: {exc}")
            results[k] = r
            done += 1
            if progress is not None:
                progress(done / len(checked), f"{done}/{len(checked)} jobs: {r.name} {r.status}")
        return results
    finally:
        if own:
            client.close()
        if cluster is not None:
            cluster.close()
