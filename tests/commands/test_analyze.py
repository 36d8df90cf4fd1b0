import json
import re

from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from app.cli import main

ROWS = "participant,clip,left,right,choice\n" + "".join(
    f"p{k},s2,{a},{b},{c}\n"
    for k in range(5)
    for a, b, c in [
        ("A", "B", "left"),
        ("B", "A", "right"),
        ("A", "C", "left"),
        ("C", "B", "undecided"),
        ("A", "A", "left"),
    ]
)


def test_analyze_writes_everything_and_prints_a_summary(tmp_path):
    (tmp_path / "v.csv").write_text(ROWS)
    out = CliRunner().invoke(
        main,
        [
            "analyze",
            str(tmp_path / "v.csv"),
            "--json",
            str(tmp_path / "o.json"),
            "--report",
            str(tmp_path / "r.html"),
            "--pdf",
            str(tmp_path / "r.pdf"),
            "--undecided",
            "split",
            "--conditions",
            "C,B,A",
            "--bootstrap",
            "50",
        ],
    )
    assert out.exit_code == 0, out.output
    data = json.loads((tmp_path / "o.json").read_text())
    assert data["conditions"] == ["C", "B", "A"] and data["options"]["undecided"] == "split"
    assert data["pooled"]["ballots"] == {"C": 0, "B": 0, "A": 20}  # 4 per participant
    assert "skipped bad rows: 0" in out.output and "undecided: split" in out.output
    assert (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")


def test_bad_row_exits_2_with_one_line(tmp_path):
    (tmp_path / "v.csv").write_text(ROWS + "p9,s2,A,B,maybe\n")
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "v.csv")])
    assert out.exit_code == 2
    lines = [ln for ln in out.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and ":27: choice: unknown choice 'maybe'" in lines[0]
    assert "Traceback" not in out.output


def test_skip_bad_rows_counts_in_every_output(tmp_path):
    (tmp_path / "v.csv").write_text(ROWS + "p9,s2,A,B,maybe\n,s2,A,B,left\n")
    out = CliRunner().invoke(
        main,
        [
            "analyze",
            str(tmp_path / "v.csv"),
            "--skip-bad-rows",
            "--json",
            str(tmp_path / "o.json"),
            "--report",
            str(tmp_path / "r.html"),
            "--bootstrap",
            "0",
        ],
    )
    assert out.exit_code == 0, out.output
    assert "skipped 2 bad rows" in out.output and "skipped bad rows: 2" in out.output
    assert json.loads((tmp_path / "o.json").read_text())["input"]["skipped_rows"] == 2
    assert "2 bad rows of the votes file were skipped" in (tmp_path / "r.html").read_text()


def test_header_mismatch_and_unknown_condition(tmp_path):
    (tmp_path / "h.csv").write_text("who,clip,left,right,choice\np,c,A,B,left\n")
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "h.csv")])
    assert out.exit_code == 2 and "h.csv:1: header does not match" in out.output
    (tmp_path / "v.csv").write_text(ROWS)
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "v.csv"), "--conditions", "A,B"])
    assert out.exit_code == 2 and "unknown condition 'C'" in out.output


def test_pdf_needs_report(tmp_path):
    (tmp_path / "v.csv").write_text(ROWS)
    out = CliRunner().invoke(
        main, ["analyze", str(tmp_path / "v.csv"), "--pdf", str(tmp_path / "r.pdf")]
    )
    assert out.exit_code == 2 and "--pdf needs --report" in out.output


def test_exclude_rules_list_who_was_left_out(tmp_path):
    (tmp_path / "v.csv").write_text(
        ROWS
        + "".join(
            f"p9,s2,{a},{b},left\n" for a, b in [("A", "B"), ("B", "A"), ("C", "A"), ("B", "C")]
        )
    )
    out = CliRunner().invoke(
        main,
        [
            "analyze",
            str(tmp_path / "v.csv"),
            "--exclude",
            "side_p<0.2",
            "--json",
            str(tmp_path / "o.json"),
            "--bootstrap",
            "0",
        ],
    )
    assert out.exit_code == 0, out.output
    data = json.loads((tmp_path / "o.json").read_text())
    assert list(data["quality"]["excluded"]) == ["p9"] and "p9" not in data["participants"]
    assert "excluded by side_p<0.2: p9" in out.output


def test_bad_exclude_rule_exits_2_with_one_line(tmp_path):
    (tmp_path / "v.csv").write_text(ROWS)
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "v.csv"), "--exclude", "speed<1"])
    assert out.exit_code == 2
    lines = [ln for ln in out.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "exclude: unknown field 'speed'" in lines[0]


def test_plan_prints_power_and_writes_json_and_plot(tmp_path):
    out = CliRunner().invoke(
        main,
        [
            "plan",
            "--effects",
            "a=0,b=0.5,c=1",
            "--participants",
            "8-16:8",
            "--simulations",
            "100",
            "--json",
            str(tmp_path / "p.json"),
            "--plot",
            str(tmp_path / "p.png"),
        ],
    )
    assert out.exit_code == 0, out.output
    data = json.loads((tmp_path / "p.json").read_text())
    assert [lv["participants"] for lv in data["levels"]] == [8, 16]
    assert "16 participants: power" in out.output and "a vs c" in out.output
    assert (tmp_path / "p.png").read_bytes().startswith(b"\x89PNG")
    pilot = CliRunner().invoke(
        main,
        [
            "plan",
            "--pilot",
            "app/data/examples/votes.csv",
            "--participants",
            "14",
            "--simulations",
            "50",
        ],
    )
    assert pilot.exit_code == 0, pilot.output and "app/data/examples/votes.csv" in pilot.output


def test_plan_bad_input_exits_2_with_one_line():
    for args in (
        ["--effects", "a=0,b"],
        ["--effects", "a=0,b=1", "--participants", "x"],
        ["--effects", "a=0,b=1", "--participants", "10,²"],
        ["--effects", "a=0,b=1", "--pilot", "app/data/examples/votes.csv"],
        ["--adaptive", "8,x"],
        ["--adaptive", "2"],
        ["--adaptive", "8", "--spread-jod", "-1"],
    ):
        out = CliRunner().invoke(main, ["plan", *args])
        lines = [ln for ln in out.output.splitlines() if ln.strip()]
        assert out.exit_code == 2 and len(lines) == 1 and "Traceback" not in out.output


def test_the_summary_names_the_mixed_model_unless_left_out(tmp_path):
    from app.analysis import write_votes_csv
    from app.analysis.simulate import simulate_votes

    write_votes_csv(
        simulate_votes({"a": -0.5, "b": 0.0, "c": 0.6}, participants=10, seed=2), tmp_path / "v.csv"
    )
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "v.csv"), "--bootstrap", "0"])
    assert out.exit_code == 0, out.output
    assert (
        "mixed model (participant × condition and clip × condition random effects): "
        "sd participant" in out.output
    )
    out = CliRunner().invoke(
        main, ["analyze", str(tmp_path / "v.csv"), "--bootstrap", "0", "--no-mixed-model"]
    )
    assert out.exit_code == 0 and "mixed model" not in out.output


def test_plan_compares_the_adaptive_design_with_the_full_one(tmp_path):
    out = CliRunner().invoke(
        main,
        ["plan", "--adaptive", "8", "--simulations", "10", "--json", str(tmp_path / "a.json")],
    )
    assert out.exit_code == 0, out.output
    assert "Kendall tau" in out.output and "95% CI width (JOD)" in out.output
    result = json.loads((tmp_path / "a.json").read_text())[0]
    assert result["conditions"] == 8 and result["full_votes"] == 2 * 8 * 7
    assert result["reached"]["kendall"]["adaptive"] is not None


def test_objective_measures_are_regressed_on_the_scores(tmp_path):
    from app.analysis import write_votes_csv
    from app.analysis.simulate import simulate_votes

    truth = {"a": -0.8, "b": 0.0, "c": 0.4, "d": 0.9}
    votes = simulate_votes(truth, participants=20, clips=["s1", "s2", "s3"], seed=4)
    write_votes_csv(votes, tmp_path / "v.csv")
    args = []
    for k, clip in enumerate(["s1", "s2", "s3"]):
        summary = {
            "conditions": {
                c: {"measures": {"head": {"speed": 3.0 * v + 0.1 * k}, "noise": [(k * 7 + i) % 5]}}
                for i, (c, v) in enumerate(truth.items())
            }
        }
        (tmp_path / f"{clip}.json").write_text(json.dumps(summary))
        args += ["--measures", f"{clip}={tmp_path / f'{clip}.json'}"]
    out = CliRunner().invoke(
        main,
        [
            "analyze",
            str(tmp_path / "v.csv"),
            "--bootstrap",
            "0",
            "--no-mixed-model",
            "--json",
            str(tmp_path / "r.json"),
            "--report",
            str(tmp_path / "r.html"),
            *args,
        ],
    )
    assert out.exit_code == 0, out.output
    rows = json.loads((tmp_path / "r.json").read_text())["objective"]["measures"]
    assert rows[0]["measure"] == "head.speed" and rows[0]["ci"][0] > 0
    assert rows[0]["p_holm"] < 0.01
    assert "Table 9c" in (tmp_path / "r.html").read_text()


def test_bad_measures_are_one_line(tmp_path):
    (tmp_path / "bad.json").write_text("{")
    (tmp_path / "list.json").write_text("[]")
    for item in (
        "s1",
        f"s1={tmp_path / 'missing.json'}",
        f"s1={tmp_path / 'bad.json'}",
        f"s1={tmp_path / 'list.json'}",
    ):
        out = CliRunner().invoke(
            main, ["analyze", "app/data/examples/votes.csv", "--bootstrap", "0", "--measures", item]
        )
        lines = [ln for ln in out.output.splitlines() if ln.strip()]
        assert out.exit_code == 2 and len(lines) == 1 and "Traceback" not in out.output


@settings(max_examples=40, deadline=None)
@given(st.text(max_size=12).filter(lambda t: not re.fullmatch(r"\s*\d+(\s*,\s*\d+)*\s*", t)))
def test_any_other_adaptive_text_is_one_line(text):
    out = CliRunner().invoke(main, ["plan", "--adaptive", text, "--simulations", "10"])
    lines = [ln for ln in out.output.splitlines() if ln.strip()]
    assert out.exit_code == 2 and len(lines) == 1 and "Traceback" not in out.output
