import pytest

from app.stimuli import fap


def test_table_has_68_faps_with_known_units_and_directions():
    assert len(fap.FAPS) == 68
    assert (fap.FAPS[3].unit, fap.FAPS[3].bidirectional, fap.FAPS[3].positive) == (
        "MNS",
        False,
        "down",
    )
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


def test_feature_points_directions_and_axes_follow_the_reference():
    # reference mpeg4-fap: "The 68 FAPs" and "Feature points (FDP)"; +x is the face's left
    assert [fap.FEATURE_POINT[n] for n in fap.EYEBROW_RAISE] == [
        "4.1",
        "4.2",
        "4.3",
        "4.4",
        "4.5",
        "4.6",
    ]
    assert fap.FEATURE_POINT[fap.OPEN_JAW] == "2.1" and fap.FEATURE_POINT[18] == "2.10"
    assert [fap.FEATURE_POINT[n] for n in fap.EYELIDS] == ["3.1", "3.2", "3.3", "3.4"]
    assert {fap.FEATURE_POINT[n] for n in fap.HEAD} == {"7.1"}
    assert fap.DIRECTION[fap.OPEN_JAW] == (0.0, -1.0, 0.0)
    assert fap.DIRECTION[37] == (-1.0, 0.0, 0.0) and fap.DIRECTION[38] == (1.0, 0.0, 0.0)
    assert fap.DIRECTION[6] == (1.0, 0.0, 0.0) and fap.DIRECTION[fap.SHIFT_JAW] == (-1.0, 0, 0)
    assert fap.DIRECTION[fap.THRUST_JAW] == (0.0, 0.0, 1.0)
    assert [fap.AXIS[n] for n in fap.HEAD] == ["x", "y", "z"]
    assert [fap.AXIS[n] for n in fap.GAZE] == ["y", "y", "x", "x"]
    assert 47 not in fap.AXIS and 47 not in fap.DIRECTION  # tongue roll curls
    assert [fap.SIDE[n] for n in fap.EYEBROWS] == ["l", "r"] * 4
    assert fap.SIDE[8] == "l" and fap.SIDE[56] == "r" and 4 not in fap.SIDE


def test_every_moving_fap_has_a_feature_point_and_one_way_of_moving():
    for n, f in fap.FAPS.items():
        if n <= 2:
            assert f.feature_point is None
            continue
        assert f.feature_point and f.feature_point.split(".")[0].isdigit()
        assert (n in fap.DIRECTION) + (n in fap.AXIS) <= 1
        if f.unit == "AU":
            assert n not in fap.DIRECTION
    for inner, outer in zip(fap.INNER_LIPS, fap.OUTER_LIPS, strict=True):
        assert fap.FEATURE_POINT[inner].startswith("2.")
        assert fap.FEATURE_POINT[outer].startswith("8.")
        assert fap.DIRECTION[inner] == fap.DIRECTION[outer]


def test_fapu_values_divide_the_neutral_distances():
    distances = {"ES0": 69.0, "IRISD0": 16.0, "ENS0": 51.0, "MNS0": 30.0, "MW0": 50.0}
    values = fap.fapu_values(distances)
    assert set(values) == set(fap.FAPU) - {"AU"}
    assert values["ENS"] == 51.0 / 1024 and values["IRISD"] == 16.0 / 1024
    with pytest.raises(KeyError):
        fap.fapu_values({"ES0": 1.0})
