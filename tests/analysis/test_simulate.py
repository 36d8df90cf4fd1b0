from app.analysis import analyze, read_votes
from app.analysis.simulate import simulate_votes

TRUTH = {"a": -1.0, "b": 0.0, "c": 1.0}


def test_design_and_recovery_without_abstentions():
    votes = simulate_votes(TRUTH, participants=40, clips=("s2", "s7"), undecided_width=0.0, seed=3)
    assert len(votes) == 40 * 2 * 9 and len(read_votes(votes)) == len(votes)
    assert (votes["choice"] != "undecided").all()
    scale = {s["condition"]: s for s in analyze(votes, bootstrap=200)["pooled"]["scale"]}
    for c, v in TRUTH.items():
        assert scale[c]["ci_low"] <= v <= scale[c]["ci_high"]


def test_abstentions_keep_the_order():
    votes = simulate_votes(TRUTH, participants=40, clips=("s2",), undecided_width=0.5, seed=4)
    assert 0.1 < (votes["choice"] == "undecided").mean() < 0.4
    scale = [s["score"] for s in analyze(votes, bootstrap=0)["pooled"]["scale"]]
    assert scale[0] < scale[1] < scale[2]
