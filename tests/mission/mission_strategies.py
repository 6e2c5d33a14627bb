"""Hypothesis strategies for random missions and a NaN-aware comparison, shared by the format tests."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from hypothesis import strategies as st

from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem

DO_JUMP = 177
KNOWN_COMMANDS = [mav.NAV_WAYPOINT, mav.NAV_RETURN_TO_LAUNCH, mav.NAV_LAND, mav.NAV_TAKEOFF, mav.NAV_VTOL_TAKEOFF,
                  mav.NAV_VTOL_LAND, mav.CONDITION_YAW, mav.DO_CHANGE_SPEED, mav.DO_LAND_START,
                  mav.DO_SET_CAM_TRIGG_DIST, mav.DO_SET_CAM_TRIGG_INTERVAL, mav.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                  mav.NAV_FENCE_POLYGON_VERTEX_EXCLUSION]

finite = st.floats(allow_nan=False, allow_infinity=False)
param = st.one_of(finite, st.just(math.nan))
lat = st.floats(-90.0, 90.0)
lon = st.floats(-180.0, 180.0)
# DO_JUMP needs a valid target; it has its own tests
commands = st.one_of(st.sampled_from(KNOWN_COMMANDS), st.integers(0, 65535).filter(lambda c: c != DO_JUMP))
frames = st.one_of(st.sampled_from([mav.FRAME_GLOBAL, mav.FRAME_MISSION, mav.FRAME_GLOBAL_RELATIVE_ALT,
                                    mav.FRAME_GLOBAL_TERRAIN_ALT]), st.integers(0, 255))
tags = st.text(st.characters(blacklist_categories=("Cs",)), max_size=12)


@st.composite
def mission_items(draw: st.DrawFn) -> MissionItem:
    """Any command and frame; a positioned command gets a finite position, others may have NaN there."""
    command = draw(commands)
    params = [draw(param) for _ in range(4)]
    if MissionItem(command).has_position:
        x, y, z = draw(lat), draw(lon), draw(finite)
    else:
        x, y, z = draw(param), draw(param), draw(param)
    return MissionItem(command, draw(frames), *params, x, y, z, draw(st.booleans()), draw(tags))


polygons = st.lists(st.tuples(lat, lon), min_size=3, max_size=6).map(tuple)


@st.composite
def missions(draw: st.DrawFn, max_items: int = 12) -> Mission:
    return Mission(
        vehicle=draw(st.sampled_from(["copter", "plane"])),
        firmware=draw(st.sampled_from(["ardupilot", "px4"])),
        home=(draw(lat), draw(lon), draw(finite)),
        items=tuple(draw(st.lists(mission_items(), max_size=max_items))),
        cruise_speed=draw(finite),
        hover_speed=draw(finite),
        name=draw(tags),
        fence_inclusion=tuple(draw(st.lists(polygons, max_size=2))),
        fence_exclusion=tuple(draw(st.lists(polygons, max_size=2))),
        rally=tuple(draw(st.lists(st.tuples(lat, lon, finite), max_size=3))),
    )


def canon(obj: Any) -> Any:
    """`obj` with NaN replaced by a marker, so that missions compare equal when their NaNs sit in the same places."""
    if dataclasses.is_dataclass(obj):
        return (type(obj).__name__, *(canon(getattr(obj, f.name)) for f in dataclasses.fields(obj)))
    if isinstance(obj, (tuple, list)):
        return tuple(canon(v) for v in obj)
    if isinstance(obj, float) and math.isnan(obj):
        return "NaN"
    return obj


def same_float(a: float, b: float, tol: float = 0.0) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= tol
