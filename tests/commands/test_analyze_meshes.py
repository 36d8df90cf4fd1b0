"""A study whose ground truth is a vertex sequence: ``stimuli generate`` writes LVE and FDD in
each clip's summary.json, and ``analyze --measures`` puts them in the report's objective section,
beside (not in) the perceptual scale."""

import json

import numpy as np
from click.testing import CliRunner

from app.cli import main
from app.stimuli.meshes.regions import speech_energy
from tests.stimuli.meshes.synthetic import head_mesh, opening_from_energy, talking, write_layout

DEMO = "app/data/demo/speech.wav"


def test_lve_and_fdd_reach_the_report(tmp_path):
    from app.analysis import write_votes_csv
    from app.analysis.simulate import simulate_votes

    head = head_mesh(20, 24)
    opening = opening_from_energy(speech_energy(DEMO, 30.0, 120))
    runner = CliRunner()
    measures = []
    for k, clip in enumerate(["s1", "s2", "s3"]):
        folder = tmp_path / clip
        truth = write_layout(folder, "gt", head, talking(head, opening, brows=0.002), flat=True)
        late = write_layout(
            folder, "ff", head, talking(head, np.roll(opening, 1 + 2 * k)), flat=True
        )
        out = runner.invoke(
            main,
            [
                "stimuli", "generate", "--audio", DEMO, "--ground-truth", str(truth),
                "--conditions", "none,ground_truth", "--track", f"ff={late}",
                "--mesh-fps", "30", "--out", str(folder / "out"), "--no-plot",
            ],
        )  # fmt: skip
        assert out.exit_code == 0, out.output
        assert "mesh_eyes = 'match'" in out.output
        summary = json.loads((folder / "out" / "summary.json").read_text())
        assert summary["conditions"]["ff"]["measures"]["mesh"]["lve_mm"] > 0
        assert (folder / "out" / "ff.mesh.npz").is_file()
        measures += ["--measures", f"{clip}={folder / 'out' / 'summary.json'}"]
    truth = {"none": -0.5, "ff": 0.1, "ground_truth": 0.6}
    votes = simulate_votes(truth, participants=12, clips=["s1", "s2", "s3"], seed=2)
    write_votes_csv(votes, tmp_path / "v.csv")
    out = runner.invoke(
        main,
        [
            "analyze", str(tmp_path / "v.csv"), "--bootstrap", "0", "--no-mixed-model",
            "--json", str(tmp_path / "r.json"), "--report", str(tmp_path / "r.html"), *measures,
        ],
    )  # fmt: skip
    assert out.exit_code == 0, out.output
    objective = json.loads((tmp_path / "r.json").read_text())["objective"]
    field = objective["field_metrics"]
    assert field["ground_truth"]["lve_mm"] == 0.0 and field["ff"]["lve_mm"] > 0
    assert field["ff"]["clips"] == 3 and "none" not in field
    assert any(m["measure"] == "mesh.lve_mm" for m in objective["measures"])
    html = (tmp_path / "r.html").read_text()
    assert "Table 9d" in html and "LVE (mm)" in html and "FDD (mm)" in html
