from app.analysis import analyze
from app.analysis.report.results_text import results_paragraphs
from app.analysis.simulate import simulate_votes


def test_the_paragraphs_name_votes_agreement_ballots_tests_scale_and_consistence():
    votes = simulate_votes({"a": -1.0, "b": 0.0, "c": 1.5}, participants=12, seed=5)
    results = analyze(votes, bootstrap=20)
    text = results_paragraphs(results)
    n, pooled = results["input"], results["pooled"]
    assert text[0].startswith(f"12 participants cast {n['votes']} votes on 2 clips ")
    assert text[0].endswith("No rows of the votes file were skipped.")
    assert text[1].startswith("Pooled over clips, the judgements agreed beyond chance")
    ballots = sorted(pooled["ballots"].items(), key=lambda kv: -kv[1])
    assert text[2] == "Ballots per condition, pooled over clips, in decreasing order: " + (
        ", ".join(f"{c} ({v})" for c, v in ballots) + "."
    )
    assert text[3].startswith("Exact sign tests (undecided votes excluded, Holm-adjusted over 3")
    assert text[4].startswith("Paired t-tests on each participant's ballots per condition")
    assert "Thurstone Case V scale (JOD, mean fixed at 0; 95 % bootstrap" in text[5]
    assert text[6].startswith("The participants' median coefficient of consistence was")


def test_skipped_rows_and_an_anchor_are_said():
    votes = simulate_votes({"a": -1.0, "b": 0.0}, participants=4, seed=1)
    results = analyze(votes, bootstrap=0, anchor="a")
    results["input"]["skipped_rows"] = 3
    text = results_paragraphs(results)
    assert (
        "3 bad rows of the votes file were skipped and are not part of any statistic." in (text[0])
    )
    assert text[-1].startswith("On the Thurstone Case V scale (JOD, a fixed at 0; 95 % bootstrap")
    assert text[-1].endswith("a 0.00 [-, -].")
