"""3MF projects whose objects hold modifiers, negative volumes and support enforcers /
blockers (session 10, real files: BambuStudio 2.3 projects cube_cilindrical_modifier.3mf,
cube_positive_n_negative.3mf and bridge_support_enforcers.3mf from
AdelinoGP/pinch_n_print_cli). Only model parts are the part; a negative volume is cut
out of its object, as the slicer prints it."""

import zipfile

import numpy as np
import pytest
import trimesh

import texcad
from texcad.io import read_part

CUBE = ((0, 0, 0), (20, 20, 20))  # the model part, mm
MODIFIER = ((10, 0, 0), (30, 20, 20))  # sticks out of the cube: a setting, not material
NEGATIVE = ((-5, -5, -5), (5, 5, 25))  # cuts a 5 x 5 x 20 mm corner out: 500 mm3
KINDS = (("ModelPart", "normal_part"), ("ParameterModifier", "modifier_part"), ("NegativeVolume", "negative_part"),
         ("SupportEnforcer", "support_enforcer"))
ENFORCER = ((0, 0, -10), (5, 5, -2))  # under the part


def _box(lo, hi):
    b = trimesh.creation.box(bounds=np.array([lo, hi], float))
    return np.asarray(b.vertices), np.asarray(b.faces)


def _mesh_xml(v, f):
    vs = "".join(f'<vertex x="{x:g}" y="{y:g}" z="{z:g}"/>' for x, y, z in v)
    ts = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in f)
    return f"<mesh><vertices>{vs}</vertices><triangles>{ts}</triangles></mesh>"


NS = 'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"'
PNS = 'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06"'


def _prusa(path):
    """PrusaSlicer: one object's volumes in one mesh, their types in Slic3r_PE_model.config."""
    boxes = [_box(*b) for b in (CUBE, MODIFIER, NEGATIVE, ENFORCER)]
    v = np.concatenate([b[0] for b in boxes])
    f = np.concatenate([b[1] + 8 * k for k, b in enumerate(boxes)])
    model = f'<?xml version="1.0"?><model unit="millimeter" {NS}><resources><object id="1" type="model">{_mesh_xml(v, f)}</object></resources><build><item objectid="1"/></build></model>'
    vols = "".join(f'<volume firstid="{12 * k}" lastid="{12 * k + 11}"><metadata type="volume" key="volume_type" value="{t}"/></volume>'
                   for k, (t, _) in enumerate(KINDS))
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", model)
        z.writestr("Metadata/Slic3r_PE_model.config", f'<?xml version="1.0"?><config><object id="1">{vols}</object></config>')


def _bambu(path):
    """BambuStudio / OrcaSlicer: each volume an object in 3D/Objects, a component of the
    build's object, its subtype in Metadata/model_settings.config."""
    objs = "".join(f'<object id="{k + 1}" type="model">{_mesh_xml(*_box(*b))}</object>'
                   for k, b in enumerate((CUBE, MODIFIER, NEGATIVE, ENFORCER)))
    comps = "".join(f'<component p:path="/3D/Objects/o.model" objectid="{k + 1}"/>' for k in range(4))
    model = (f'<?xml version="1.0"?><model unit="millimeter" {NS} {PNS}><resources><object id="5" type="model">'
             f'<components>{comps}</components></object></resources><build><item objectid="5"/></build></model>')
    parts = "".join(f'<part id="{k + 1}" subtype="{s}"><metadata key="name" value="v{k}"/></part>' for k, (_, s) in enumerate(KINDS))
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", model)
        z.writestr("3D/Objects/o.model", f'<?xml version="1.0"?><model unit="millimeter" {NS}><resources>{objs}</resources><build/></model>')
        z.writestr("Metadata/model_settings.config", f'<?xml version="1.0"?><config><object id="5">{parts}</object></config>')


@pytest.mark.parametrize("write", [_prusa, _bambu])
def test_only_model_parts_are_read_and_negative_volumes_cut(tmp_path, write):
    """The modifier was read as material (the bbox 10 mm wider, +4000 mm3), the
    enforcer as a second body, the negative volume added instead of cut."""
    write(tmp_path / "p.3mf")
    meshes = read_part(tmp_path / "p.3mf")
    body = trimesh.util.concatenate([trimesh.Trimesh(m.vertices, m.faces, process=False) for _, m in meshes])
    assert body.is_watertight
    assert body.volume == pytest.approx(8000 - 500, abs=1e-3)
    assert np.allclose(body.bounds, [[0, 0, 0], [20, 20, 20]])
    report = texcad.check(tmp_path / "p.3mf")
    assert report.shells == 1 and report.volume_mm3 == pytest.approx(7500, abs=1e-2)
