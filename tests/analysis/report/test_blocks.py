from app.analysis.report.blocks import fmt, fmt_p


def test_number_formats():
    assert fmt_p(0.0004) == "< .001" and fmt_p(0.0283) == ".028" and fmt_p(1.0) == "1"
    assert fmt_p(None) == "-" and fmt(None) == "-" and fmt(0.12345, 3) == "0.123"
    assert fmt(12) == "12"
