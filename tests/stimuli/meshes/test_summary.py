"""A clip whose ground truth is a vertex sequence: LVE and FDD in summary.json, beside the head
measures, the eyes matched, and the tracks written with their bundles."""

import doctest
import json

import numpy as np
import pytest

from app.stimuli.generate import generate_conditions, write_outputs
from app.stimuli.meshes import summary
from app.stimuli.meshes.regions import speech_energy
from tests.stimuli.meshes.synthetic import (
    head_mesh,
    opening_from_energy,
    talking,
    write_layout,
)

DEMO = "app/data/demo/speech.wav"


def test_doctests():
    assert doctest.testmod(summary).failed == 0


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clip")
    head = head_mesh(24, 30)
    opening = opening_from_energy(speech_energy(DEMO, 30.0, 120))
    truth = write_layout(folder, "gt", head, talking(head, opening, brows=0.002), flat=True)
    late = write_layout(folder, "late", head, talking(head, np.roll(opening, 3)), flat=False)
    eyeless = head_mesh(24, 30, eyes=False)
    other = write_layout(folder, "other", eyeless, talking(eyeless, opening), flat=True)
    return folder, truth, late, other


def test_lve_and_fdd_go_in_the_summary_beside_the_head_measures(clip):
    folder, truth, late, other = clip
    result = generate_conditions(
        DEMO,
        conditions={
            "none": "none",
            "late": {"track": str(late)},
            "other": {"track": str(other)},
            "truth": "ground_truth",
        },
        ground_truth=truth,
        meshes={"fps": 30},
        eyes="generated",
    )
    conds = result.summary["conditions"]
    assert "mesh" not in conds["none"]["measures"] and "head" in conds["none"]["measures"]
    assert conds["truth"]["measures"]["mesh"]["lve_mm"] == 0.0
    late_m = conds["late"]["measures"]["mesh"]
    assert late_m["lve_mm"] > 1.0 and late_m["lve_squared"] > 0
    assert late_m["fdd_mm"] > 0  # the ground truth's brows move, the late one's do not
    assert "head" in conds["late"]["measures"]
    about = conds["late"]["mesh"]["field_metrics"]
    assert about["lip_vertices"] >= 6 and about["squared_units"] == "m^2"
    # a head of another topology (no eyeballs: fewer vertices) gets none, and a note why
    assert "mesh" not in conds["other"]["measures"]
    assert any("other: no LVE or FDD" in n for n in result.summary["notes"])
    # an eyeless mesh: no face blinks or looks about
    assert result.summary["mesh_eyes"]["mode"] == "match"
    for track in result.tracks.values():
        assert not any(track.get(c).any() for c in (19, 20, 21, 22, 23, 24, 25, 26))
    written = write_outputs(result, folder / "out", plot=False)
    saved = json.loads((folder / "out" / "summary.json").read_text())
    assert saved["conditions"]["late"]["measures"]["mesh"]["lve_mm"] == pytest.approx(
        late_m["lve_mm"]
    )
    assert (folder / "out" / "late.mesh.npz").is_file() and len(written) == 5
    assert not (folder / "out" / "none.mesh.npz").exists()


def test_lips_and_upper_face_come_from_the_ground_truths_region_file(clip):
    folder, truth, late, _ = clip
    (folder / "regions").mkdir(exist_ok=True)
    (folder / "regions" / "lve.txt").write_text("1, 2, 3")
    (folder / "regions" / "fdd.txt").write_text("4, 5")
    result = generate_conditions(
        DEMO,
        conditions={"none": "none", "late": {"track": str(late)}},
        ground_truth=truth,
        meshes={"fps": 30, "regions": str(folder / "regions")},
        eyes="generated",
    )
    about = result.summary["conditions"]["late"]["mesh"]["field_metrics"]
    assert about["lip_vertices"] == 3 and about["upper_vertices"] == 2
    assert about["lips_from"] == "the ground truth's region file"
