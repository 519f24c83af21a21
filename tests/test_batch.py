"""texcad.batch: jobs on a local Dask cluster of two worker processes give the same
bytes as one process; bad jobs are refused before anything runs; a failing job is
reported while the others succeed; an unreachable scheduler is an error in seconds."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

import texcad
from texcad.batch import batch, load_jobs, run_job, validate

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    from build123d import Box, export_step

    d = tmp_path_factory.mktemp("parts")
    export_step(Box(20, 16, 5), str(d / "box.step"))
    texcad.export(Box(16, 12, 6), d / "box.stl")
    return d


def _jobs(parts: Path, out: Path) -> list[dict]:
    return [
        {"name": "lid", "part": str(parts / "box.step"), "where": "top", "options": {"pitch": 0.5, "height": 0.6},
         "outputs": [str(out / "lid.stl"), str(out / "lid.3mf")]},
        {"name": "side", "part": str(parts / "box.step"), "where": ["front"], "texture": "builtin:ridges",
         "options": {"pitch": 0.5, "height": 0.5}, "outputs": [str(out / "side.stl")]},
        {"name": "mesh", "part": str(parts / "box.stl"), "options": {"pitch": 1.0, "height": 0.6}, "outputs": [str(out / "mesh.stl")]},
        {"name": "broken", "part": str(parts / "box.step"), "where": "cone", "outputs": [str(out / "broken.stl")]},
    ]


@pytest.fixture(scope="module")
def cluster():
    c = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50)
    client = distributed.Client(c, set_as_default=False)
    yield client
    client.close()
    c.close()


def test_two_workers_same_bytes_as_one_process_failure_reported(parts, tmp_path, cluster):
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir()
    two.mkdir()
    single = [run_job(j) for j in validate(_jobs(parts, one))]  # here, one process
    seen = []
    results = batch(_jobs(parts, two), cluster, progress=lambda f, m: seen.append((f, m)))
    assert [r.name for r in results] == ["lid", "side", "mesh", "broken"]
    assert [r.status for r in results] == [r.status for r in single] == ["ok", "ok", "ok", "failed"]
    assert "ParameterError" in results[3].error and "cone" in results[3].error and not results[3].outputs
    assert not (two / "broken.stl").exists()
    for r in results[:3]:
        assert r.seconds > 0 and r.triangles > 0
        assert 0 < r.cpu_seconds < 2 * r.seconds + 1.0  # the worker's CPU time for the job, one thread each
        for o in r.outputs:
            assert Path(o).read_bytes() == (one / Path(o).name).read_bytes(), o
    assert len(seen) == 4 and seen[-1][0] == 1.0 and "4/4 jobs" in seen[-1][1]
    assert not list(two.glob(".*.part"))  # no temporary files left
    m = texcad.load_mesh(two / "lid.stl")
    assert m.is_watertight and m.volume > 20 * 16 * 5


def test_bad_jobs_refused_before_running(parts, tmp_path):
    good = {"part": str(parts / "box.step"), "outputs": [str(tmp_path / "a.stl")]}
    cases = [
        ({**good, "colour": "red"}, "job 1: unknown key(s) colour"),
        ({**good, "part": str(parts / "nope.step")}, "does not exist"),
        ({**good, "options": {"height": -1}}, "option 'height'"),
        ({**good, "options": {"hieght": 1}}, "unknown option 'hieght'"),
        ({**good, "outputs": [str(tmp_path / "a.obj")]}, "output"),
        ({k: v for k, v in good.items() if k != "outputs"}, "'outputs' is missing"),
        ({**good, "texture": str(tmp_path / "none.png")}, "texture"),
        ({**good, "where": "upside"}, "job 1: where: face selector 'upside'"),
        ({**good, "options": [1, 2]}, "options must be a mapping"),
        ({**good, "texture": "builtin:ribs"}, "job 1: texture: unknown built-in texture 'ribs'"),
    ]
    for bad, words in cases:
        with pytest.raises(texcad.TexcadError, match=words.replace("(", r"\(").replace(")", r"\)")):
            batch([good, bad], workers=1)  # refused before a cluster starts
    assert not (tmp_path / "a.stl").exists()
    with pytest.raises(texcad.ParameterError, match="written by job 0 too"):
        validate([good, dict(good)])


def test_unreachable_scheduler_is_a_clear_error_in_seconds(parts, tmp_path):
    job = {"part": str(parts / "box.step"), "outputs": [str(tmp_path / "a.stl")]}
    t0 = time.perf_counter()
    with pytest.raises(texcad.ResourceError, match="cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'"):
        batch([job], "tcp://127.0.0.1:9", timeout=2)
    assert time.perf_counter() - t0 < 15


def test_job_files_toml_and_csv(parts, tmp_path):
    (tmp_path / "jobs.toml").write_text(
        '[defaults]\noptions = {pitch = 0.5}\n\n'
        f'[[job]]\nname = "lid"\npart = "{parts / "box.step"}"\nwhere = ["top"]\noptions = {{height = 0.6}}\noutputs = ["out/lid.stl"]\n'
    )
    (tmp_path / "jobs.csv").write_text(f"name,part,where,outputs,height,pitch\nlid,{parts / 'box.step'},top;front,out/lid.stl;out/lid.3mf,0.6,0.5\n")
    t = validate(load_jobs(tmp_path / "jobs.toml"))[0]
    assert t.options == {"pitch": 0.5, "height": 0.6} and t.where == ("top",)
    assert t.outputs == (str((tmp_path / "out" / "lid.stl").resolve()),)
    c = validate(load_jobs(tmp_path / "jobs.csv"))[0]
    assert c.options == {"height": 0.6, "pitch": 0.5} and c.where == ("top", "front") and len(c.outputs) == 2
    (tmp_path / "bad.csv").write_text(f"part,outputs,colour\n{parts / 'box.step'},a.stl,red\n")
    with pytest.raises(texcad.ParameterError, match="job 0: unknown option 'colour'"):
        validate(load_jobs(tmp_path / "bad.csv"))


def test_cli_batch_refuses_and_reports(parts, tmp_path, capsys):
    from texcad.cli import main

    (tmp_path / "bad.toml").write_text(f'[[job]]\npart = "{parts / "box.step"}"\noutputs = ["a.stl"]\nwhere = "top"\nfoo = 1\n')
    assert main(["batch", str(tmp_path / "bad.toml"), "--workers", "1"]) == 2
    assert "job 0: unknown key(s) foo" in capsys.readouterr().err
    assert main(["batch", str(tmp_path / "bad.toml"), "--scheduler", "tcp://127.0.0.1:9", "--workers", "2"]) == 2


def _dying(job):
    """Runs a job, but a job named "die" kills its worker process."""
    import os

    if job.name == "die":
        os._exit(3)
    return run_job(job)


def test_dead_worker_retried_once_then_reported(parts, tmp_path):
    import cloudpickle

    cloudpickle.register_pickle_by_value(__import__(__name__))  # the workers need not import this test module
    jobs = [
        {"name": "die", "part": str(parts / "box.stl"), "outputs": [str(tmp_path / "die.stl")]},
        {"name": "mesh", "part": str(parts / "box.stl"), "options": {"pitch": 1.5, "height": 0.5}, "outputs": [str(tmp_path / "mesh.stl")]},
    ]
    results = batch(jobs, workers=2, runner=_dying)
    assert [r.status for r in results] == ["failed", "ok"]
    assert "died twice" in results[0].error and not (tmp_path / "die.stl").exists()
    # batch's own cluster (TEXCAD_THREADS=1 in each worker): the bytes of one process (every core) still
    here = validate([{**jobs[1], "outputs": [str(tmp_path / "here.stl")]}])[0]
    assert run_job(here).ok and (tmp_path / "here.stl").read_bytes() == (tmp_path / "mesh.stl").read_bytes()
