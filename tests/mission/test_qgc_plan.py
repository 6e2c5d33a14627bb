"""QGroundControl .plan writer and reader: round trips, determinism, QGC's keys, QGC-written files, errors."""

from __future__ import annotations

import copy
import dataclasses
import json
import math

import pytest
from hypothesis import given, settings
from mission_strategies import DO_JUMP, canon, missions

from aerosurvey.errors import InputError
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.formats.qgc_plan import dumps_plan, loads_plan, mission_to_plan_dict
from aerosurvey.mission.items import Mission, MissionItem

HOME = (49.3995, 14.9995, 402.5)


def survey() -> Mission:
    items = (
        MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, 49.4, 15.0, 80.0, tag="takeoff"),
        MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, 1, 12.5, -1, 0, tag="speed"),
        MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 21.37, 0, 1, tag="L1"),
        MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, 49.40012345, 15.00054321, 80.25, tag="S1"),
        MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, math.nan, 49.40112345, 15.00054321, 80.25, tag="S2"),
        MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0, 0, 0, tag="L1"),
        MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION, tag="rtl"),
    )
    inc = (((49.399, 14.999), (49.42, 14.999), (49.42, 15.008), (49.399, 15.008)),)
    exc = (((49.405, 15.002), (49.406, 15.002), (49.406, 15.003)),)
    return Mission("copter", "ardupilot", HOME, items, cruise_speed=12.5, hover_speed=5.0, name="field-7",
                   fence_inclusion=inc, fence_exclusion=exc)


@settings(max_examples=300, deadline=None)
@given(missions())
def test_round_trip_of_random_missions_keeps_everything(m: Mission) -> None:
    text = dumps_plan(m)
    back = loads_plan(text, "random.plan")
    assert canon(back) == canon(m)
    # the reader's output writes the same bytes again: the text is a fixed point
    assert dumps_plan(back) == text
    # the JSON written is exactly the dict (NaN as null on both sides)
    assert json.loads(text) == mission_to_plan_dict(m)


def test_output_is_deterministic_sorted_indented_and_ends_with_a_newline() -> None:
    m = survey()
    twin = Mission(**{f.name: copy.deepcopy(getattr(m, f.name)) for f in dataclasses.fields(m)})
    text = dumps_plan(m)
    assert text == dumps_plan(twin) == dumps_plan(m)
    assert text.endswith("}\n") and not text.endswith("\n\n")
    lines = text.splitlines()
    assert lines[0] == "{" and lines[1].startswith('    "') and not lines[1].startswith('     ')
    doc = json.loads(text)

    def keys_sorted(v):
        if isinstance(v, dict):
            assert list(v) == sorted(v)
            for x in v.values():
                keys_sorted(x)
        elif isinstance(v, list):
            for x in v:
                keys_sorted(x)
    keys_sorted(doc)


def test_plan_has_every_key_qgroundcontrol_reads() -> None:
    doc = json.loads(dumps_plan(survey()))
    assert doc["fileType"] == "Plan" and doc["version"] == 1 and doc["groundStation"] == "QGroundControl"
    mis = doc["mission"]
    assert {"version", "firmwareType", "vehicleType", "cruiseSpeed", "hoverSpeed", "globalPlanAltitudeMode",
            "plannedHomePosition", "items"} <= set(mis)
    assert mis["version"] == 2 and mis["firmwareType"] == mav.AUTOPILOT_ARDUPILOTMEGA and mis["vehicleType"] == mav.TYPE_QUADROTOR
    assert mis["cruiseSpeed"] == 12.5 and mis["hoverSpeed"] == 5 and mis["globalPlanAltitudeMode"] == 1
    assert mis["plannedHomePosition"] == [49.3995, 14.9995, 402.5]
    items = mis["items"]
    assert [i["doJumpId"] for i in items] == list(range(1, 8))
    for i in items:
        assert {"type", "command", "frame", "params", "autoContinue", "doJumpId"} <= set(i)
        assert i["type"] == "SimpleItem" and len(i["params"]) == 7 and i["autoContinue"] is True
    takeoff, speed, wp = items[0], items[1], items[3]
    assert takeoff["params"] == [0, 0, 0, None, 49.4, 15, 80]  # NaN yaw written as null, like QGC
    assert (takeoff["Altitude"], takeoff["AltitudeMode"], takeoff["AMSLAltAboveTerrain"]) == (80, 1, None)
    assert (wp["Altitude"], wp["AltitudeMode"]) == (80.25, 1) and wp["frame"] == 3 and wp["command"] == 16
    assert not {"Altitude", "AltitudeMode", "AMSLAltAboveTerrain"} & set(speed)  # no position, no altitude keys
    assert [i.get("aerosurveyTag") for i in items] == ["takeoff", "speed", "L1", "S1", "S2", "L1", "rtl"]
    assert doc["aerosurveyName"] == "field-7"
    fence = doc["geoFence"]
    assert fence["version"] == 2 and fence["circles"] == []
    assert [(p["inclusion"], p["version"], len(p["polygon"])) for p in fence["polygons"]] == [(True, 1, 4), (False, 1, 3)]
    assert fence["polygons"][0]["polygon"][1] == [49.42, 14.999]  # [latitude, longitude]
    assert doc["rallyPoints"] == {"points": [], "version": 2}


def test_altitude_modes_per_frame_and_global_mode() -> None:
    def doc_for(*frames: int) -> dict:
        items = tuple(MissionItem(mav.NAV_WAYPOINT, f, x=49.4, y=15.0, z=500.0 + k) for k, f in enumerate(frames))
        return json.loads(dumps_plan(Mission("plane", "px4", HOME, items, 18.0, 0.0)))["mission"]

    absolute = doc_for(mav.FRAME_GLOBAL, mav.FRAME_GLOBAL)
    assert [i["AltitudeMode"] for i in absolute["items"]] == [2, 2] and absolute["globalPlanAltitudeMode"] == 2
    assert absolute["firmwareType"] == mav.AUTOPILOT_PX4 and absolute["vehicleType"] == mav.TYPE_FIXED_WING
    terrain = doc_for(mav.FRAME_GLOBAL_TERRAIN_ALT)
    assert terrain["items"][0]["AltitudeMode"] == 4 and terrain["globalPlanAltitudeMode"] == 4
    mixed = doc_for(mav.FRAME_GLOBAL, mav.FRAME_GLOBAL_RELATIVE_ALT)
    assert [i["AltitudeMode"] for i in mixed["items"]] == [2, 1] and "globalPlanAltitudeMode" not in mixed
    # a frame QGC has no altitude mode for: no altitude keys, QGC derives the mode from the frame
    odd = doc_for(6)
    assert "AltitudeMode" not in odd["items"][0] and "globalPlanAltitudeMode" not in odd


# A plan as QGroundControl writes it: takeoff and waypoints with the altitude keys, a
# waypoint in AltitudeMode 3 (QGC computed the AMSL altitude from terrain), a speed change,
# NaN params as null, an extra fence key of newer QGC versions and a breach return point.
QGC_WRITTEN = """{
    "fileType": "Plan",
    "geoFence": {
        "breachReturn": [47.3978, 8.5456, 40],
        "circles": [],
        "polygons": [
            {"fenceAction": 2, "inclusion": true, "polygon": [[47.39, 8.54], [47.40, 8.54], [47.40, 8.55], [47.39, 8.55]], "version": 1}
        ],
        "version": 2
    },
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 15,
        "firmwareType": 12,
        "globalPlanAltitudeMode": 0,
        "hoverSpeed": 5,
        "items": [
            {"AMSLAltAboveTerrain": null, "Altitude": 20, "AltitudeMode": 1, "autoContinue": true, "command": 22,
             "doJumpId": 1, "frame": 3, "params": [0, 0, 0, null, 47.3977507, 8.5456074, 20], "type": "SimpleItem"},
            {"autoContinue": true, "command": 178, "doJumpId": 2, "frame": 2, "params": [1, 7.5, -1, 0, 0, 0, 0],
             "type": "SimpleItem"},
            {"AMSLAltAboveTerrain": 521.5, "Altitude": 30, "AltitudeMode": 3, "autoContinue": true, "command": 16,
             "doJumpId": 3, "frame": 0, "params": [0, 0, 0, null, 47.39919907, 8.54621452, 521.5], "type": "SimpleItem"},
            {"AMSLAltAboveTerrain": null, "Altitude": 30, "AltitudeMode": 1, "autoContinue": false, "command": 16,
             "doJumpId": 4, "frame": 3, "params": [2.5, 0, 0, null, 47.39886457, 8.54962802, 30], "type": "SimpleItem"},
            {"autoContinue": true, "command": 20, "doJumpId": 5, "frame": 2, "params": [0, 0, 0, 0, 0, 0, 0],
             "type": "SimpleItem"}
        ],
        "plannedHomePosition": [47.3977507, 8.5456074, 488.1],
        "vehicleType": 2,
        "version": 2
    },
    "rallyPoints": {"points": [], "version": 2},
    "version": 1
}
"""


def test_reads_a_qgroundcontrol_written_plan() -> None:
    m = loads_plan(QGC_WRITTEN, "qgc.plan")
    assert (m.firmware, m.vehicle, m.cruise_speed, m.hover_speed, m.name) == ("px4", "copter", 15.0, 5.0, "mission")
    assert m.home == (47.3977507, 8.5456074, 488.1)
    assert [(i.command, i.frame) for i in m.items] == [(22, 3), (178, 2), (16, 0), (16, 3), (20, 2)]
    takeoff, speed, terrain_wp, wp, rtl = m.items
    assert math.isnan(takeoff.param4) and (takeoff.x, takeoff.y, takeoff.z) == (47.3977507, 8.5456074, 20.0)
    assert speed.params == (1.0, 7.5, -1.0, 0.0)
    assert terrain_wp.z == 521.5  # the AMSL altitude in params, which is what QGC uploads
    assert wp.param1 == 2.5 and wp.autocontinue is False
    assert all(i.tag == "" for i in m.items)
    assert m.fence_inclusion == (((47.39, 8.54), (47.40, 8.54), (47.40, 8.55), (47.39, 8.55)),) and m.fence_exclusion == ()


def test_rally_points_are_read_as_qgroundcontrol_writes_them() -> None:
    """RallyPointController saves version 2 with points [latitude, longitude, altitude]."""
    doc = json.loads(QGC_WRITTEN)
    doc["rallyPoints"]["points"] = [[47.3981, 8.5462, 40], [47.3990, 8.5470, 45.5]]
    m = loads_plan(json.dumps(doc), "qgc.plan")
    assert m.rally == ((47.3981, 8.5462, 40.0), (47.399, 8.547, 45.5))
    back = json.loads(dumps_plan(m))["rallyPoints"]
    assert back == {"points": [[47.3981, 8.5462, 40], [47.399, 8.547, 45.5]], "version": 2}


def test_vtol_and_fixed_wing_vehicle_types_read_as_plane() -> None:
    for vt, vehicle in ((1, "plane"), (20, "plane"), (13, "copter")):
        doc = json.loads(QGC_WRITTEN)
        doc["mission"]["vehicleType"] = vt
        assert loads_plan(json.dumps(doc)).vehicle == vehicle
    doc = json.loads(QGC_WRITTEN)
    del doc["mission"]["vehicleType"], doc["mission"]["cruiseSpeed"]
    m = loads_plan(json.dumps(doc))
    assert m.vehicle == "copter" and m.cruise_speed == 0.0


def test_do_jump_targets_are_resolved_from_do_jump_ids() -> None:
    doc = json.loads(QGC_WRITTEN)
    items = doc["mission"]["items"]
    for k, it in enumerate(items):
        it["doJumpId"] = 10 * (k + 1)  # ids that are not sequence numbers
    items.insert(4, {"autoContinue": True, "command": DO_JUMP, "doJumpId": 99, "frame": 2,
                     "params": [30, 3, 0, 0, 0, 0, 0], "type": "SimpleItem"})
    m = loads_plan(json.dumps(doc), "jump.plan")
    assert m.items[4].command == DO_JUMP and m.items[4].param1 == 3.0 and m.items[4].param2 == 3.0
    # our own files: doJumpId is the sequence number, so a jump survives the round trip unchanged
    assert loads_plan(dumps_plan(m)).items[4].param1 == 3.0
    items[4]["params"][0] = 31
    with pytest.raises(InputError, match=r"jump.plan: mission item 5 is a DO_JUMP to doJumpId 31.0, which no item has"):
        loads_plan(json.dumps(doc), "jump.plan")


def _broken(change) -> str:
    doc = json.loads(QGC_WRITTEN)
    change(doc)
    return json.dumps(doc)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["mission"]["items"].insert(1, {"type": "ComplexItem", "complexItemType": "survey", "version": 5}),
     r"p.plan: mission item 2 is a ComplexItem \('survey'\) without stored items; aerosurvey reads SimpleItems, "
     r"the stored Items of Survey and Corridor Scan items and what Structure Scan items generate\. Convert it to "
     r"simple items in QGroundControl first"),
    (lambda d: d["mission"]["items"].insert(1, {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3}),
     r"p.plan: mission item 2 \(StructureScan\): field 'polygon' is missing"),
    (lambda d: d["mission"]["items"].insert(1, {"type": "ComplexItem", "complexItemType": "FWLandingPattern", "version": 2}),
     r"p.plan: mission item 2 is a ComplexItem \('FWLandingPattern'\) without stored items"),
    (lambda d: d["mission"]["items"].insert(1, {"type": "ComplexItem", "complexItemType": "survey",
                                                "TransectStyleComplexItem": {"Items": [{"type": "SimpleItem"}]}}),
     r"p.plan: mission item 2 \(survey\) item 1: field 'command' is missing"),
    (lambda d: d["mission"]["items"][2].update(type="CorridorScan"), r"mission item 3 field 'type' = 'CorridorScan' is not allowed"),
    (lambda d: d["mission"]["items"][0].pop("command"), r"p.plan: mission item 1: field 'command' is missing"),
    (lambda d: d["mission"]["items"][3].pop("frame"), r"mission item 4: field 'frame' is missing"),
    (lambda d: d["mission"]["items"][1].pop("params"), r"mission item 2: field 'params' is missing"),
    (lambda d: d["mission"]["items"][1].pop("autoContinue"), r"mission item 2: field 'autoContinue' is missing"),
    (lambda d: d["mission"]["items"][1].pop("type"), r"mission item 2: field 'type' is missing"),
    (lambda d: d["mission"]["items"][1]["params"].pop(), r"mission item 2 field 'params' has 6 values; QGroundControl items have 7"),
    (lambda d: d["mission"]["items"][1]["params"].__setitem__(2, "fast"),
     r"mission item 2 field 'params' param3 = 'fast' is not allowed: a number or null"),
    (lambda d: d["mission"]["items"][1].update(command=17.5), r"mission item 2 field 'command' = 17.5 is not allowed"),
    (lambda d: d["mission"]["items"][1].update(frame=-1), r"mission item 2 field 'frame' = -1 is not allowed"),
    (lambda d: d["mission"]["items"][1].update(autoContinue=1), r"mission item 2 field 'autoContinue' = 1 is not allowed: true or false"),
    (lambda d: d["mission"]["items"][3]["params"].__setitem__(4, None),
     r"mission item 4 field 'params' x \(latitude\) is null: a position item needs a position"),
    (lambda d: d["mission"]["items"].__setitem__(0, 5), r"mission item 1 = int is not allowed: a JSON object"),
    (lambda d: d["mission"].update(firmwareType=0), r"mission field 'firmwareType' = 0 is not allowed: 3 \(ArduPilot\) or 12 \(PX4\)"),
    (lambda d: d["mission"].pop("firmwareType"), r"p.plan: mission: field 'firmwareType' is missing"),
    (lambda d: d["mission"].update(vehicleType=10), r"field 'vehicleType' = 10 is not allowed: a multirotor"),
    (lambda d: d["mission"].update(version=1), r"mission field 'version' = 1 is not allowed: 2"),
    (lambda d: d["mission"].update(plannedHomePosition=[47.3, 8.5]), r"field 'plannedHomePosition' = \[47.3, 8.5\] is not allowed"),
    (lambda d: d["mission"]["plannedHomePosition"].__setitem__(2, None),
     r"field 'plannedHomePosition' altitude = None is not allowed: a number"),
    (lambda d: d["mission"].update(hoverSpeed="5"), r"mission field 'hoverSpeed' = '5' is not allowed: a number"),
    (lambda d: d.pop("mission"), r"p.plan: field 'mission' is missing"),
    (lambda d: d["mission"].pop("items"), r"mission: field 'items' is missing"),
    (lambda d: d.update(version=2), r"p.plan: field 'version' = 2 is not allowed: 1"),
    (lambda d: d.update(fileType="Mission"), r"p.plan: not a QGroundControl plan \(fileType = 'Mission', expected 'Plan'\)"),
    (lambda d: d["geoFence"]["circles"].append({"circle": {"center": [47.39, 8.54], "radius": 100}, "inclusion": True}),
     r"geoFence has 1 circular fence\(s\); aerosurvey uploads polygon fences only"),
    (lambda d: d["geoFence"]["polygons"][0]["polygon"].__delitem__(slice(2, None)),
     r"p.plan: geoFence polygon 1 has 2 vertices; a fence polygon needs at least 3"),
    (lambda d: d["geoFence"]["polygons"][0].pop("inclusion"), r"geoFence polygon 1: field 'inclusion' is missing"),
    (lambda d: d["geoFence"]["polygons"][0]["polygon"].__setitem__(1, [47.4]),
     r"geoFence polygon 1 vertex 2 = \[47.4\] is not allowed: \[latitude, longitude\]"),
    (lambda d: d["rallyPoints"]["points"].append([47.39, 8.54]),
     r"p.plan: rallyPoints point 1 = \[47.39, 8.54\] is not allowed: \[latitude, longitude, altitude\]"),
    (lambda d: d["rallyPoints"]["points"].append([47.39, 8.54, None]),
     r"p.plan: rallyPoints point 1 altitude = None is not allowed: a number"),
    (lambda d: d["rallyPoints"]["points"].append([147.39, 8.54, 30]),
     r"rallyPoints point 1 = \[147.39, 8.54, 30\] is not allowed: latitude -90..90"),
    (lambda d: d["rallyPoints"].update(version=1, points=[[47.39, 8.54, 30]]),
     r"rallyPoints field 'version' = 1 is not allowed: 2"),
])
def test_bad_plans_are_refused_naming_item_and_field(change, message) -> None:
    with pytest.raises(InputError, match=message):
        loads_plan(_broken(change), "p.plan")


def test_not_json_or_not_an_object() -> None:
    with pytest.raises(InputError, match=r"x.plan: not a QGroundControl plan \(invalid JSON: "):
        loads_plan("{not json", "x.plan")
    with pytest.raises(InputError, match=r"x.plan: not a QGroundControl plan \(the JSON is a list"):
        loads_plan("[1, 2]", "x.plan")


def test_writer_refuses_what_no_reader_could_use() -> None:
    m = survey()
    with pytest.raises(InputError, match=r"mission item 2 param2 = inf is not allowed: a finite number"):
        dumps_plan(dataclasses.replace(m, items=(m.items[0], dataclasses.replace(m.items[1], param2=math.inf))))
    with pytest.raises(InputError, match=r"mission item 1 x \(latitude\) = nan is not allowed: a position item"):
        dumps_plan(dataclasses.replace(m, items=(dataclasses.replace(m.items[0], x=math.nan),)))
    with pytest.raises(InputError, match=r"mission firmware = 'inav' is not allowed: one of ardupilot, px4"):
        dumps_plan(dataclasses.replace(m, firmware="inav"))
    with pytest.raises(InputError, match=r"mission vehicle = 'rover' is not allowed"):
        dumps_plan(dataclasses.replace(m, vehicle="rover"))
    with pytest.raises(InputError, match=r"mission home altitude = nan is not allowed: a finite number"):
        dumps_plan(dataclasses.replace(m, home=(49.4, 15.0, math.nan)))
    with pytest.raises(InputError, match=r"mission item 8 DO_JUMP param1 = 9 is not allowed: the sequence number .* \(1-8\)"):
        dumps_plan(dataclasses.replace(m, items=m.items + (MissionItem(DO_JUMP, mav.FRAME_MISSION, 9, 1),)))
    with pytest.raises(InputError, match=r"exclusion fence polygon 1 has 2 vertices"):
        dumps_plan(dataclasses.replace(m, fence_exclusion=(((49.4, 15.0), (49.5, 15.0)),)))
    with pytest.raises(InputError, match=r"mission item 1 command = 70000 is not allowed"):
        dumps_plan(dataclasses.replace(m, items=(MissionItem(70000),)))


@pytest.mark.parametrize("item, message", [
    (MissionItem(mav.NAV_WAYPOINT, x=math.nan), r"mission item 2 x \(latitude\) = nan"),
    (MissionItem(mav.DO_CHANGE_SPEED, param2=math.inf), "mission item 2 param2 = inf"),
    (MissionItem(mav.DO_CHANGE_SPEED, x=-math.inf), r"mission item 2 x \(latitude\) = -inf"),
    (MissionItem(70000), "mission item 2 command = 70000"),
    (MissionItem(mav.NAV_WAYPOINT, frame=-1), "mission item 2 frame = -1"),
])
def test_a_refused_item_among_good_ones_is_named(item: MissionItem, message: str) -> None:
    m = dataclasses.replace(survey(), items=(survey().items[0], item, *survey().items[1:]))
    with pytest.raises(InputError, match=message):
        dumps_plan(m)
