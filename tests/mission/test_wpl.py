"""QGC WPL 110 writer and reader: exact round trips, pymavlink reads our files, tolerant reading, clear errors."""

from __future__ import annotations

import dataclasses
import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from mission_strategies import canon, missions, same_float
from pymavlink import mavwp

from aerosurvey.errors import InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.formats.wpl import dumps_wpl, format_number, loads_wpl
from aerosurvey.mission.items import Mission, MissionItem

HOME = (49.3995, 14.9995, 402.5)


def survey() -> Mission:
    items = (
        MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, 49.4, 15.0, 80.0),
        MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, 1, 12.5, -1, 0),
        MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, 1500.0, -1),
        MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, 49.40012345, -15.00054321, 80.25),
        MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_TERRAIN_ALT, 0, 0.00001, 0, 0, 49.40112345, 15.00054321, 60.0,
                    autocontinue=False),
        MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION),
    )
    return Mission("copter", "ardupilot", HOME, items, cruise_speed=12.5, hover_speed=5.0)


EXPECTED = (
    "QGC WPL 110\n"
    "0\t1\t0\t16\t0\t0\t0\t0\t49.3995\t14.9995\t402.5\t1\n"
    "1\t0\t3\t22\t0\t0\t0\tnan\t49.4\t15\t80\t1\n"
    "2\t0\t2\t178\t1\t12.5\t-1\t0\t0\t0\t0\t1\n"
    "3\t0\t2\t214\t1500\t-1\t0\t0\t0\t0\t0\t1\n"
    "4\t0\t3\t16\t0\t0\t0\tnan\t49.40012345\t-15.00054321\t80.25\t1\n"
    "5\t0\t10\t16\t0\t0.00001\t0\t0\t49.40112345\t15.00054321\t60\t0\n"
    "6\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\t1\n"
)


def test_exact_text_of_a_small_mission() -> None:
    text = dumps_wpl(survey())
    assert text == EXPECTED
    assert dumps_wpl(survey()) == text  # deterministic


def test_numbers_are_exact_and_positional() -> None:
    for v in (49.40012345, -0.1, 1e-05, 2.5e-12, 1e16, 1.7976931348623157e308, 5e-324, 0.1 + 0.2, 80.0, -0.0):
        text = format_number(v)
        assert "e" not in text.lower() and float(text) == v
    assert (format_number(1e-05), format_number(80.0), format_number(-0.0), format_number(math.nan)) == ("0.00001", "80", "0", "nan")
    # at least 1e-8 degrees survive: eight decimals are kept as they are
    assert format_number(49.12345678) == "49.12345678" and format_number(-179.00000001) == "-179.00000001"


def _without_tags(m: Mission) -> Mission:
    return dataclasses.replace(m, items=tuple(dataclasses.replace(i, tag="") for i in m.items))


@settings(max_examples=300, deadline=None)
@given(missions())
def test_round_trip_of_random_missions_is_exact(m: Mission) -> None:
    back = loads_wpl(dumps_wpl(m), "random.waypoints", vehicle=m.vehicle, firmware=m.firmware)
    # the format holds home and the items; tags, speeds, name and fence live in the .plan only
    assert canon(back.home) == canon(m.home)
    assert canon(back.items) == canon(_without_tags(m).items)
    assert (back.vehicle, back.firmware, back.cruise_speed, back.fence_inclusion) == (m.vehicle, m.firmware, 0.0, ())
    assert dumps_wpl(back) == dumps_wpl(m)


def _check_with_pymavlink(m: Mission, path: Path) -> None:
    path.write_text(dumps_wpl(m))
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(path)) == len(m.items) + 1
    home = loader.wp(0)
    assert (home.seq, home.current, home.frame, home.command) == (0, 1, mav.FRAME_GLOBAL, mav.NAV_WAYPOINT)
    assert all(same_float(a, b, 1e-7) for a, b in zip((home.x, home.y, home.z), m.home))
    for seq, it in enumerate(m.items, start=1):
        w = loader.wp(seq)
        assert (w.seq, w.current, w.command, w.frame, bool(w.autocontinue)) == (seq, 0, it.command, it.frame, it.autocontinue)
        ours = (*it.params, it.x, it.y, it.z)
        theirs = (w.param1, w.param2, w.param3, w.param4, w.x, w.y, w.z)
        assert all(same_float(a, b, 1e-7) for a, b in zip(theirs, ours)), (seq, theirs, ours)


def test_pymavlink_reads_our_waypoints_file(tmp_path: Path) -> None:
    _check_with_pymavlink(survey(), tmp_path / "mission.waypoints")


@settings(max_examples=60, deadline=None)
@given(missions(max_items=8))
def test_pymavlink_reads_random_missions(m: Mission) -> None:
    with tempfile.TemporaryDirectory() as d:
        _check_with_pymavlink(m, Path(d) / "random.waypoints")


def test_reads_crlf_bom_comments_blank_lines_and_space_separated_lines() -> None:
    text = "\ufeff" + EXPECTED.replace("\n", "\r\n").replace("2\t0\t2\t178", "# speed change\r\n\r\n2\t0\t2\t178") + "\r\n\r\n  \r\n"
    m = loads_wpl(text, "win.waypoints", vehicle="plane", firmware="px4")
    assert canon(m.items) == canon(survey().items) and m.home == HOME and (m.vehicle, m.firmware) == ("plane", "px4")
    spaced = EXPECTED.replace("\t", "  ")
    assert canon(loads_wpl(spaced).items) == canon(survey().items)


def test_reads_mission_planner_style_numbers() -> None:
    text = ("QGC WPL 110\n"
            "0\t1\t0\t16\t0\t0\t0\t0\t49.399500\t14.999500\t402.500000\t1\n"
            "1\t0\t3\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t49.40012345\t15.00054321\t80.250000\t1\n")
    m = loads_wpl(text, "mp.waypoints")
    assert m.home == HOME and m.items == (MissionItem(16, 3, 0, 0, 0, 0, 49.40012345, 15.00054321, 80.25),)


@pytest.mark.parametrize("text, message", [
    ("", r"w.waypoints: line 1 is ''; a waypoint file starts with 'QGC WPL 110'"),
    ("<?xml version='1.0'?>\n", r"w.waypoints: line 1 is \"<\?xml version='1.0'\?>\"; a waypoint file starts with 'QGC WPL 110'"),
    ("QGC WPL 120\n1\t0\t3\t16\t0\t0\t0\t0\t49.4\t15\t80\t1\n", r"line 1 is 'QGC WPL 120'; only 'QGC WPL 110' files \(home on line 2\)"),
    ("QGC WPL 110\n\n", r"w.waypoints: no home line; line 2 of a QGC WPL 110 file is home"),
    (EXPECTED.replace("3\t0\t2\t214\t1500\t-1\t0\t0\t0\t0\t0\t1", "3\t0\t2\t214\t1500\t-1\t0\t0\t0\t0\t1"),
     r"w.waypoints: line 5 has 11 fields; QGC WPL 110 lines have 12"),
    (EXPECTED.replace("2\t0\t2\t178\t1\t12.5", "2\t0\t2\t178\t1\tfast"),
     r"w.waypoints: line 4 field 'param2' = 'fast' is not allowed: a number"),
    (EXPECTED.replace("4\t0\t3\t16\t0\t0\t0\tnan\t49.40012345", "4\t0\t3\t16\t0\t0\t0\tnan\t49.4N"),
     r"line 6 field 'latitude' = '49.4N' is not allowed: a number"),
    (EXPECTED.replace("4\t0\t3\t16", "5\t0\t3\t16", 1),
     r"w.waypoints: line 6 has sequence number 5, expected 4: lines must be numbered 0 \(home\), 1, 2"),
    (EXPECTED.replace("0\t1\t0\t16\t0", "1\t1\t0\t16\t0", 1), r"line 2 has sequence number 1, expected 0"),
    (EXPECTED.replace("3\t0\t2\t214", "3\t0\t2.0\t214"), r"line 5 field 'frame' = '2.0' is not allowed: a whole number"),
    (EXPECTED.replace("3\t0\t2\t214", "3\t2\t2\t214"), r"line 5 field 'current' = 2 is not allowed: 0-1"),
    (EXPECTED.replace("6\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\t1", "6\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\tyes"),
     r"line 8 field 'autocontinue' = 'yes' is not allowed: a whole number"),
    (EXPECTED.replace("3\t0\t2\t214", "3\t0\t2\t70000"), r"line 5 field 'command' = 70000 is not allowed: 0-65535"),
    (EXPECTED.replace("1500", "inf"), r"line 5 field 'param1' = 'inf' is not allowed: a finite number"),
    (EXPECTED.replace("49.40012345", "nan"), r"line 6 field 'latitude' = nan is not allowed: command 16 needs a position"),
    (EXPECTED.replace("402.5", "nan"), r"line 2 \(home\) field 'altitude' = nan is not allowed"),
])
def test_bad_files_are_refused_naming_the_line(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        loads_wpl(text, "w.waypoints")


def test_bad_reader_options_and_unwritable_missions() -> None:
    with pytest.raises(InputError, match=r"vehicle = 'boat' is not allowed: one of copter, plane"):
        loads_wpl(EXPECTED, "w.waypoints", vehicle="boat")
    with pytest.raises(InputError, match=r"firmware = 'inav' is not allowed: one of ardupilot, px4"):
        loads_wpl(EXPECTED, "w.waypoints", firmware="inav")
    m = survey()
    with pytest.raises(InputError, match=r"mission item 2 param3 = -inf is not allowed"):
        dumps_wpl(dataclasses.replace(m, items=(m.items[0], dataclasses.replace(m.items[1], param3=-math.inf))))
    with pytest.raises(InputError, match=r"mission item 1 altitude = nan is not allowed: a finite number$"):
        dumps_wpl(dataclasses.replace(m, items=(dataclasses.replace(m.items[0], z=math.nan),)))
    with pytest.raises(InputError, match=r"home latitude = nan is not allowed"):
        dumps_wpl(dataclasses.replace(m, home=(math.nan, 15.0, 400.0)))
    with pytest.raises(InputError, match=r"mission item 1 frame = 300 is not allowed: a MAV_FRAME number 0-255"):
        dumps_wpl(dataclasses.replace(m, items=(MissionItem(mav.NAV_WAYPOINT, 300, x=49.4, y=15.0, z=80.0),)))


@pytest.mark.parametrize("item, message", [
    (MissionItem(mav.NAV_WAYPOINT, x=math.nan), "mission item 2 latitude = nan"),
    (MissionItem(mav.DO_CHANGE_SPEED, param2=math.inf), "mission item 2 param2 = inf"),
    (MissionItem(70000), "mission item 2 command = 70000"),
    (MissionItem(mav.NAV_WAYPOINT, frame=300), "mission item 2 frame = 300"),
    (MissionItem(True), "mission item 2 command = True"),  # type: ignore[arg-type]
])
def test_a_refused_item_among_good_ones_is_named(item: MissionItem, message: str) -> None:
    m = dataclasses.replace(survey(), items=(survey().items[0], item, *survey().items[1:]))
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        dumps_wpl(m)
