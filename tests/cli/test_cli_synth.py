"""Tests of ``texcad synth`` (texcad/cli/synth.py) at reduced resolution."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from texcad.synthesis import quality as Q
from conftest import assert_heightmap_picture
from texcad.cli import main
from texcad.sources import Heightmap

SMALL = ["--patch", "32", "--overlap", "14"]


def _read(path, pitch: float = 0.125) -> np.ndarray:
    return Heightmap.from_image(path, pitch=pitch, height=1.0).heights.astype(float)


def test_builtin_sample_writes_png_preview_and_summary(tmp_path, capsys) -> None:
    out, prev = tmp_path / "stones.png", tmp_path / "preview.png"
    argv = ["synth", "builtin:stones", "-o", str(out), "--shape", "150x170", "--sample-size", "12",
            "--preview", str(prev), *SMALL]
    assert main(argv) == 0
    text = capsys.readouterr().out
    for word in ("sample", "96 x 96 px", "output", "150 x 170 px", "quality", "histogram", "spectrum",
                 "blur", "wrap seam", "seconds", "wrote"):
        assert word in text, word
    h = _read(out)
    assert h.shape == (150, 170)  # rows x cols as given to --shape
    assert h.max() == pytest.approx(1.0, abs=1e-4) and h.min() >= 0
    assert_heightmap_picture(prev)


def test_image_sample_wraps_and_is_reproducible(tmp_path, capsys) -> None:
    # A non-procedural, scan-like sample: filtered noise written as a 16-bit PNG.
    rng = np.random.default_rng(3)
    a = ndimage.gaussian_filter(rng.standard_normal((110, 130)), 2.5)
    a += 0.02 * rng.standard_normal(a.shape)  # sensor-like noise
    sample = tmp_path / "scan.png"
    Heightmap.from_array(a - a.min(), pitch=0.1).to_png(sample)
    outs = []
    for name in ("a.png", "b.png"):
        out = tmp_path / name
        argv = ["synth", str(sample), "-o", str(out), "--pitch", "0.1", "--shape", "140x200",
                "--wrap", "x", "--blend", "cut", "--seed", "5", *SMALL]
        assert main(argv) == 0
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]  # same seed, same bytes
    h = _read(tmp_path / "a.png", 0.1)
    assert h.shape == (140, 200)
    assert Q.wrap_seam_error(h, "x") < 1.5  # tiles along x
    assert Q.wrap_seam_error(h, "y") > 2.0  # and not along y (not asked for)
    seam_line = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("wrap seam")][-1]
    assert float(seam_line.split()[3].rstrip(",")) == pytest.approx(Q.wrap_seam_error(h, "x"), abs=0.01)


@pytest.mark.parametrize(
    "options, words",
    [
        (["--patch", "500"], ["patch 500 px is larger than the sample"]),
        (["--patch", "32", "--overlap", "32"], ["overlap 32 px must be smaller than patch 32 px"]),
        (["--tolerance", "-1"], ["tolerance"]),
        (["--seed", "-3"], ["seed"]),
        (["--sample-size", "1", *SMALL], ["patch 32 px is larger than the sample (8 x 8 px)"]),
    ],
)
def test_bad_option_is_one_line_exit_2_and_no_file(tmp_path, capsys, options, words) -> None:
    out = tmp_path / "out.png"
    assert main(["synth", "builtin:stones", "-o", str(out), "--shape", "100x100", *options]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("texcad: error: ")
    for w in words:
        assert w in err[0]
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary file left either


def test_output_must_be_png_and_sample_size_is_for_builtins(tmp_path, capsys) -> None:
    assert main(["synth", "builtin:stones", "-o", str(tmp_path / "out.stl")]) == 2
    assert "must be a .png" in capsys.readouterr().err
    img = tmp_path / "s.png"
    Heightmap.from_array(np.random.default_rng(0).random((64, 64)), pitch=0.1).to_png(img)
    assert main(["synth", str(img), "-o", str(tmp_path / "o.png"), "--sample-size", "5"]) == 2
    assert "--sample-size applies to built-in samples only" in capsys.readouterr().err
    assert not (tmp_path / "o.png").exists()


def test_argparse_errors_exit_2_without_output(tmp_path, capsys) -> None:
    out = tmp_path / "out.png"
    for bad in (["--shape", "3y4"], ["--wrap", "z"], ["--blend", "smooth"], ["--patch", "4.5"]):
        with pytest.raises(SystemExit) as e:
            main(["synth", "builtin:stones", "-o", str(out), *bad])
        assert e.value.code == 2
        assert capsys.readouterr().err.strip().splitlines()[-1].startswith("texcad synth: error: argument")
        assert not out.exists()


def test_large_outputs_report_progress(tmp_path, capsys, monkeypatch) -> None:
    import texcad.cli.synth as cli

    monkeypatch.setattr(cli, "PROGRESS_PIXELS", 10_000)
    out = tmp_path / "big.png"
    assert main(["synth", "builtin:stones", "-o", str(out), "--shape", "120x120", "--sample-size", "12", *SMALL]) == 0
    err = capsys.readouterr().err
    assert "%] synthesizing 120 x 120 px" in err and "[100%]" in err
