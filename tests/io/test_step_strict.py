"""Hand-made bad STEP files (issue 27): each is an InputError naming the file, the
line or entity and the fix, before OCCT's translator (which looped on a NaN
coordinate and crashed on a missing parameter or a 2D vertex point); through the
CLI, one line ``texcad: error: ...``, status 2 and no output file."""

from __future__ import annotations

import re

import pytest

from texcad.errors import InputError


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    from build123d import Box

    from texcad.io import write_step

    path = tmp_path_factory.mktemp("step") / "good.step"
    write_step(Box(20, 10, 5), path)
    return path.read_text()


def _line(text: str, start: str) -> str:
    return next(ln for ln in text.splitlines() if ln.startswith(start))


def _face(text):  # the first face: '#N = ADVANCED_FACE('',(#a),#b,.T.);'
    return next(ln for ln in text.splitlines() if "ADVANCED_FACE(" in ln)


def _point(text):
    return next(ln for ln in text.splitlines() if "= CARTESIAN_POINT(" in ln and ln.count(",") == 3)


BAD = {
    "reference": (lambda t: t.replace(_face(t), _face(t).rsplit(",", 2)[0] + ",#99999,.T.);"),
                  r"entity #\d+ \(line \d+\) cannot be read.*refers to #99999, which the file does not define"),
    "nan": (lambda t: t.replace(_point(t), re.sub(r"\(([-0-9.E]+),", "(nan,", _point(t), count=1)),
            r"entity #\d+ \(line \d+\) cannot be read: .*not a Real"),
    "infinite": (lambda t: t.replace(_point(t), re.sub(r"\(([-0-9.E]+),", "(-1E999,", _point(t), count=1)),
                 r"the number '-1E999' at line \d+ is too large for a double"),
    "cut": (lambda t: t[: len(t) // 2], r"is cut short .* at line \d+"),
    "endsec": (lambda t: t[: t.rindex("ENDSEC;")] + t[t.rindex("ENDSEC;") + 7:], r"syntax error at line \d+"),
    "parameters": (lambda t: t.replace(_face(t), _face(t).replace(",.T.);", ");").replace(",.F.);", ");")),
                   r"Count of Parameters"),
    "not step": (lambda t: "solid x\nendsolid x\n", r"is not a STEP file"),
}


@pytest.mark.parametrize("how", sorted(BAD))
def test_bad_step_is_an_input_error_naming_the_place(tmp_path, good, how):
    from texcad.io import read_step

    make, message = BAD[how]
    p = tmp_path / "bad.step"
    p.write_text(make(good))
    assert p.read_text() != good
    with pytest.raises(InputError, match=message) as info:
        read_step(p)
    assert "bad.step" in str(info.value) and ("export" in str(info.value) or "give a .step" in str(info.value))


def test_a_vertex_on_a_2d_point_is_refused(tmp_path, good):
    from texcad.io import read_step

    pt = next(ln for ln in good.splitlines() if "VERTEX_POINT(" in ln).rsplit("#", 1)[1].rstrip(");")
    line = _line(good, f"#{pt} = CARTESIAN_POINT(")
    p = tmp_path / "flat.step"
    p.write_text(good.replace(line, line.rsplit(",", 1)[0] + "));"))
    with pytest.raises(InputError, match=rf"VERTEX_POINT at line \d+ uses CARTESIAN_POINT #{pt} .* 2 coordinate"):
        read_step(p)


@pytest.mark.parametrize("command", ["faces", "texture"])
def test_cli_prints_one_line_and_writes_nothing(tmp_path, good, capsys, command):
    from texcad.cli import main

    p = tmp_path / "bad.step"
    p.write_text(BAD["reference"][0](good))
    out = tmp_path / "x.stl"
    argv = [command, str(p)] + (["-o", str(out)] if command == "texture" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("texcad: error: STEP file") and "\n" not in err and "export the part again" in err
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_a_pcurve_made_of_a_direction_is_refused(tmp_path, good):
    """Found by fuzzing: OCCT crashed on a DEFINITIONAL_REPRESENTATION whose item was
    a DIRECTION (a reference turned to another entity)."""
    from texcad.io import read_step

    rep = next(ln for ln in good.splitlines() if "DEFINITIONAL_REPRESENTATION(" in ln)
    direction = next(ln for ln in good.splitlines() if "= DIRECTION(" in ln).split(" =")[0]
    p = tmp_path / "pcurve.step"
    p.write_text(good.replace(rep, re.sub(r"\(#\d+\)", f"({direction})", rep, count=1)))
    with pytest.raises(InputError, match=rf"DEFINITIONAL_REPRESENTATION at line \d+ holds DIRECTION {direction} where"):
        read_step(p)


def test_a_damaged_colour_does_not_refuse_the_part(good, tmp_path):
    """Faults in entities that carry no shape (a colour, a style, product data) are
    left to OCCT, which reads the shape whole: real CAD exports are full of such
    entities. A damaged point of the shape is refused."""
    from texcad.io import read_step

    colour = good.replace("ENDSEC;\nEND-ISO", "#99990 = COLOUR_RGB('',nan,0.5,0.2);\nENDSEC;\nEND-ISO")
    assert colour != good
    (tmp_path / "colour.step").write_text(colour)
    shape = read_step(tmp_path / "colour.step")
    assert not shape.IsNull()
    p = _point(good)
    at = p.index("',(") + 3  # the first coordinate
    nan_point = good.replace(p, p[:at] + "nan" + p[p.index(",", at):])
    (tmp_path / "point.step").write_text(nan_point)
    with pytest.raises(InputError, match="cannot be read"):
        read_step(tmp_path / "point.step")


def test_an_unset_name_does_not_refuse_the_part(good, tmp_path):
    """A name left unset (``$``, as Fusion 360's translator writes in its assembly
    transforms: OCCT reports "not a quoted String") carries no shape: the part is
    read, with the same faces."""
    from texcad.io import read_step
    from texcad.brep import occt_volume

    unset = re.sub(r"ADVANCED_FACE\('[^']*'", "ADVANCED_FACE($", good, count=1)
    assert unset != good
    (tmp_path / "unset.step").write_text(unset)
    shape = read_step(tmp_path / "unset.step")
    (tmp_path / "good.step").write_text(good)
    assert occt_volume(shape) == pytest.approx(occt_volume(read_step(tmp_path / "good.step")), rel=1e-12)


def test_header_names_at_fault_do_not_refuse_the_part_but_a_shape_representation_does(good, tmp_path):
    """truck (a Rust CAD kernel) writes the header's author and organization as
    nested lists, which OCCT reports as "not a quoted String": no shape depends on
    them, so the part is read. A shape representation whose context is not defined is
    at fault in the shape itself (it matched PRESENTATION and was let through)."""
    from texcad.io import read_step

    header = good.replace("(''),(''),", "(('')),(('')),", 1)
    assert header != good
    (tmp_path / "header.step").write_text(header)
    assert not read_step(tmp_path / "header.step").IsNull()
    rep = _line(good, "#10 = ADVANCED_BREP_SHAPE_REPRESENTATION")
    broken = good.replace(rep, re.sub(r"#\d+\);$", "#999999);", rep))
    assert broken != good
    (tmp_path / "context.step").write_text(broken)
    with pytest.raises(InputError, match=r"ADVANCED_BREP|#10 .*cannot be read"):
        read_step(tmp_path / "context.step")
