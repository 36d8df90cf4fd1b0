import pytest

from app.stimuli import fap


def test_table_has_68_faps_with_known_units_and_directions():
    assert len(fap.FAPS) == 68
    assert (fap.FAPS[3].unit, fap.FAPS[3].bidirectional, fap.FAPS[3].positive) == (
        "MNS", False, "down")
    assert (fap.FAPS[19].unit, fap.FAPS[19].positive) == ("IRISD", "down")
    assert (fap.FAPS[23].unit, fap.FAPS[23].positive) == ("AU", "left")
    assert (fap.FAPS[25].unit, fap.FAPS[25].positive) == ("AU", "down")
    assert [fap.FAPS[n].positive for n in fap.HEAD] == ["down", "left", "right"]
    assert {fap.FAPS[n].unit for n in fap.EYEBROW_RAISE} == {"ENS"}
    assert {fap.FAPS[n].unit for n in fap.FAPS if n > 2} <= set(fap.FAPU)


def test_groups_match_the_issue():
    assert fap.GAZE == (23, 24, 25, 26) and fap.EYELIDS == (19, 20, 21, 22)
    assert fap.EYEBROWS == tuple(range(31, 39)) and fap.HEAD == (48, 49, 50)
    assert set(fap.JAW_LIPS) == set(range(3, 19)) | set(range(51, 61))


def test_outer_lip_faps_mirror_inner_ones():
    for inner, outer in zip(range(4, 14), range(51, 61), strict=True):
        assert fap.FAPS[outer].name == fap.FAPS[inner].name + "_o"
        assert fap.FAPS[outer].unit == fap.FAPS[inner].unit


@pytest.mark.parametrize("name,number", [("fap48_head_pitch", 48), ("fap3", 3), (" fap68 ", 68)])
def test_parse_column_name(name, number):
    assert fap.parse_column_name(name) == number


@pytest.mark.parametrize("name", ["fap0", "fap69", "head_pitch", "fap4x", ""])
def test_parse_column_name_refuses(name):
    with pytest.raises(ValueError):
        fap.parse_column_name(name)


def test_column_names_round_trip():
    for n in fap.FAPS:
        assert fap.parse_column_name(fap.column_name(n)) == n
