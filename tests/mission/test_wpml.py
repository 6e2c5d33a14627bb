"""DJI WPML .kmz files checked with lxml against DJI's published WPML reference.

The required elements below are transcribed from the reference's tables (DJI Cloud API
documentation, DJI WPML: template.kml, waylines.wpml, common elements; the rows marked
"Yes" that apply to a waypoint template, or that become required by a value we use), not
from the emitter. The waypoints and actions are compared with the MAVLink mission of the
same flight program, read back from the .waypoints file.
"""

from __future__ import annotations

import zipfile
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner
from lxml import etree

from aerosurvey.cli import main
from aerosurvey.inputs import plan_from_files
from aerosurvey.mission.formats import wpml
from aerosurvey.mission.program import flight_program
from aerosurvey.spec import load_spec
from conftest import make_spec

NS = {"k": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}

# --- the reference's required elements (relative paths under their parent) ---
MISSION_CONFIG = ["wpml:flyToWaylineMode", "wpml:finishAction", "wpml:exitOnRCLost", "wpml:takeOffSecurityHeight",
                  "wpml:globalTransitionalSpeed", "wpml:droneInfo/wpml:droneEnumValue",
                  "wpml:payloadInfo/wpml:payloadEnumValue", "wpml:payloadInfo/wpml:payloadPositionIndex"]
WAYLINES_MISSION_CONFIG = [*MISSION_CONFIG, "wpml:globalRTHHeight"]
TEMPLATE_FOLDER = ["wpml:templateType", "wpml:templateId", "wpml:autoFlightSpeed", "wpml:globalWaypointTurnMode",
                   "wpml:gimbalPitchMode", "wpml:globalHeight", "wpml:waylineCoordinateSysParam/wpml:coordinateMode",
                   "wpml:waylineCoordinateSysParam/wpml:heightMode", "wpml:payloadParam/wpml:payloadPositionIndex",
                   "wpml:payloadParam/wpml:imageFormat"]
WAYLINES_FOLDER = ["wpml:templateId", "wpml:waylineId", "wpml:autoFlightSpeed", "wpml:executeHeightMode"]
TEMPLATE_PLACEMARK = ["k:Point/k:coordinates", "wpml:index", "wpml:useGlobalHeight", "wpml:useGlobalSpeed",
                      "wpml:useGlobalHeadingParam", "wpml:useGlobalTurnParam"]
# required when useGlobalHeight is 0
TEMPLATE_PLACEMARK_OWN_HEIGHT = ["wpml:ellipsoidHeight", "wpml:height"]
WAYLINES_PLACEMARK = ["k:Point/k:coordinates", "wpml:index", "wpml:executeHeight", "wpml:waypointSpeed",
                      "wpml:waypointHeadingParam/wpml:waypointHeadingMode",
                      "wpml:waypointHeadingParam/wpml:waypointHeadingPathMode",
                      "wpml:waypointTurnParam/wpml:waypointTurnMode"]
ACTION_GROUP = ["wpml:actionGroupId", "wpml:actionGroupStartIndex", "wpml:actionGroupEndIndex", "wpml:actionGroupMode",
                "wpml:actionTrigger/wpml:actionTriggerType"]
ACTION = ["wpml:actionId", "wpml:actionActuatorFunc"]
ACTION_PARAMS = {
    "gimbalRotate": ["wpml:payloadPositionIndex", "wpml:gimbalHeadingYawBase", "wpml:gimbalRotateMode",
                     "wpml:gimbalPitchRotateEnable", "wpml:gimbalPitchRotateAngle", "wpml:gimbalRollRotateEnable",
                     "wpml:gimbalRollRotateAngle", "wpml:gimbalYawRotateEnable", "wpml:gimbalYawRotateAngle",
                     "wpml:gimbalRotateTimeEnable", "wpml:gimbalRotateTime"],
    "takePhoto": ["wpml:payloadPositionIndex", "wpml:fileSuffix", "wpml:useGlobalPayloadLensIndex"],
    "hover": ["wpml:hoverTime"],
}
# enumerations the reference allows
ENUMS = {
    "flyToWaylineMode": {"safely", "pointToPoint"}, "finishAction": {"goHome", "noAction", "autoLand", "gotoFirstWaypoint"},
    "exitOnRCLost": {"goContinue", "executeLostAction"}, "templateType": {"waypoint", "mapping2d", "mapping3d", "mappingStrip"},
    "executeHeightMode": {"WGS84", "relativeToStartPoint", "realTimeFollowSurface"},
    "heightMode": {"EGM96", "relativeToStartPoint", "aboveGroundLevel", "realTimeFollowSurface"},
    "waypointHeadingMode": {"followWayline", "manually", "fixed", "smoothTransition", "towardPOI"},
    "waypointHeadingPathMode": {"clockwise", "counterClockwise", "followBadArc"},
    "waypointTurnMode": {"coordinateTurn", "toPointAndStopWithDiscontinuityCurvature",
                         "toPointAndStopWithContinuityCurvature", "toPointAndPassWithContinuityCurvature"},
    "actionGroupMode": {"sequence"},
    "actionTriggerType": {"reachPoint", "betweenAdjacentPoints", "multipleTiming", "multipleDistance"},
    "gimbalPitchMode": {"manual", "usePointSetting"},
}


def _missing(el: etree._Element, paths: list[str], where: str) -> list[str]:
    return [f"{where}: {p}" for p in paths if el.find(p, NS) is None]


def _check_reference(root: etree._Element, template: bool) -> list[str]:
    """Every required element present and every enumerated value allowed; what is not, named."""
    bad: list[str] = []
    doc = root.find("k:Document", NS)
    assert doc is not None
    bad += _missing(doc, ["wpml:missionConfig"], "Document")
    bad += _missing(doc.find("wpml:missionConfig", NS), MISSION_CONFIG if template else WAYLINES_MISSION_CONFIG, "missionConfig")
    folder = doc.find("k:Folder", NS)
    bad += _missing(folder, TEMPLATE_FOLDER if template else WAYLINES_FOLDER, "Folder")
    marks = folder.findall("k:Placemark", NS)
    for n, pm in enumerate(marks):
        bad += _missing(pm, TEMPLATE_PLACEMARK if template else WAYLINES_PLACEMARK, f"Placemark {n}")
        if template and pm.findtext("wpml:useGlobalHeight", namespaces=NS) == "0":
            bad += _missing(pm, TEMPLATE_PLACEMARK_OWN_HEIGHT, f"Placemark {n}")
        if pm.findtext("wpml:index", namespaces=NS) != str(n):
            bad.append(f"Placemark {n}: wpml:index is not {n} (indexes count from 0, continuously)")
        for mode in pm.iterfind(".//wpml:waypointHeadingMode", NS):
            if mode.text == "smoothTransition" and pm.find(".//wpml:waypointHeadingAngle", NS) is None:
                bad.append(f"Placemark {n}: smoothTransition without wpml:waypointHeadingAngle")
        for g in pm.findall("wpml:actionGroup", NS):
            bad += _missing(g, ACTION_GROUP, f"Placemark {n} actionGroup")
            if g.findtext("wpml:actionTrigger/wpml:actionTriggerType", namespaces=NS) in ("multipleTiming", "multipleDistance"):
                if float(g.findtext("wpml:actionTrigger/wpml:actionTriggerParam", "0", namespaces=NS)) <= 0:
                    bad.append(f"Placemark {n}: a multiple trigger needs actionTriggerParam > 0")
            lo, hi = (int(g.findtext(f"wpml:{k}", namespaces=NS)) for k in ("actionGroupStartIndex", "actionGroupEndIndex"))
            if not 0 <= lo <= hi < len(marks):
                bad.append(f"Placemark {n}: action group indexes {lo}..{hi} outside 0..{len(marks) - 1}")
            for a in g.findall("wpml:action", NS):
                bad += _missing(a, ACTION, f"Placemark {n} action")
                func = a.findtext("wpml:actionActuatorFunc", namespaces=NS)
                prm = a.find("wpml:actionActuatorFuncParam", NS)
                bad += _missing(prm, ACTION_PARAMS[func], f"Placemark {n} {func}")
                if func == "hover" and float(prm.findtext("wpml:hoverTime", namespaces=NS)) <= 0:
                    bad.append(f"Placemark {n}: hoverTime must be > 0")
    for name, allowed in ENUMS.items():
        for el in root.iterfind(f".//wpml:{name}", NS):
            if el.text not in allowed:
                bad.append(f"wpml:{name} = {el.text!r} is not one of {sorted(allowed)}")
    ids = [int(e.text) for e in root.iterfind(".//wpml:actionGroupId", NS)]
    if ids != list(range(len(ids))):
        bad.append("action group ids are not 0, 1, 2, ... (unique within the file)")
    return bad


def _kmz(path: Path) -> dict[str, etree._Element]:
    with zipfile.ZipFile(path) as z:
        assert sorted(z.namelist()) == ["wpmz/template.kml", "wpmz/waylines.wpml"]
        return {name: etree.fromstring(z.read(name)) for name in z.namelist()}


def _spec(tmp_path: Path, overrides: dict | None = None) -> Path:
    base = {"camera": {"model": "dji-mavic-3-enterprise"}}
    for k, v in (overrides or {}).items():
        base[k] = {**base.get(k, {}), **v}
    return make_spec(tmp_path, base)


def _waypoints_rows(path: Path) -> list[list[float]]:
    lines = path.read_text().splitlines()
    return [[float(v) for v in row.split("\t")] for row in lines[2:]]


@pytest.mark.parametrize("overrides", [None, {"camera": {"trigger": "time", "interval_s": 3.0}},
                                       {"battery": {"usable_min": 6.0, "reserve": 0.2}, "flight": {"fixed_yaw_deg": 30.0}}])
def test_kmz_next_to_every_mission_file_holds_what_the_reference_requires(tmp_path: Path, overrides: dict | None) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, overrides)), "-o", str(out)])
    assert res.exit_code == 0, res.output
    stems = sorted(p.stem for p in out.glob("*.waypoints"))
    assert sorted(p.stem for p in out.glob("*.kmz")) == stems
    if overrides and "battery" in overrides:
        assert len(stems) > 2
    import json

    listed = json.loads((out / "manifest.json").read_text())["outputs"]
    for stem in stems:
        assert f"{stem}.kmz" in listed
        docs = _kmz(out / f"{stem}.kmz")
        assert _check_reference(docs["wpmz/template.kml"], template=True) == []
        assert _check_reference(docs["wpmz/waylines.wpml"], template=False) == []
        way = docs["wpmz/waylines.wpml"]
        cfg = way.find("k:Document/wpml:missionConfig", NS)
        assert cfg.findtext("wpml:droneInfo/wpml:droneEnumValue", namespaces=NS) == "77"  # M3E
        assert cfg.findtext("wpml:payloadInfo/wpml:payloadEnumValue", namespaces=NS) == "66"  # Mavic 3E camera
        # the waypoints are the MAVLink mission's, read from its .waypoints file (home and take-off first)
        rows = [r for r in _waypoints_rows(out / f"{stem}.waypoints") if r[3] == 16]
        marks = way.findall(".//k:Placemark", NS)
        assert len(marks) == len(rows)
        for pm, r in zip(marks, rows):
            lon, lat = (float(v) for v in pm.findtext("k:Point/k:coordinates", namespaces=NS).split(","))
            assert (lat, lon) == pytest.approx((r[8], r[9]), abs=1e-8)
            assert float(pm.findtext("wpml:executeHeight", namespaces=NS)) == pytest.approx(r[10], abs=0.01)
        # photos from each run's first station to its line end, at the MAVLink trigger's distance or interval
        trig = [r for r in _waypoints_rows(out / f"{stem}.waypoints") if r[3] in (206, 214) and r[4] > 0]
        groups = [g for g in way.iterfind(".//wpml:actionGroup", NS)
                  if g.findtext("wpml:actionTrigger/wpml:actionTriggerType", namespaces=NS).startswith("multiple")]
        assert len(groups) == len(trig)
        for g, r in zip(groups, trig):
            param = float(g.findtext("wpml:actionTrigger/wpml:actionTriggerParam", namespaces=NS))
            assert param == pytest.approx(r[4] if r[3] == 206 else r[4] / 1000.0)
            assert g.findtext("wpml:action/wpml:actionActuatorFunc", namespaces=NS) == "takePhoto"
        heading = way.findtext(".//wpml:waypointHeadingMode", namespaces=NS)
        assert heading == ("smoothTransition" if overrides and "flight" in overrides else "followWayline")


def test_no_kmz_for_a_camera_dji_pilot_does_not_fly(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(make_spec(tmp_path)), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert not list(out.glob("*.kmz")) and ".kmz" not in res.output


def test_terrain_frame_is_refused_with_a_reason_and_the_rest_written(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, {"terrain": {"mode": "terrain-frame"}})), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "mission.kmz (DJI waylines for the DJI Mavic 3 Enterprise (M3E)) is not written: terrain.mode = 'terrain-frame'" in res.output
    assert (out / "mission.waypoints").exists() and not list(out.glob("*.kmz"))


def test_hover_gimbal_and_the_budget(tmp_path: Path) -> None:
    plan = plan_from_files(load_spec(_spec(tmp_path)))
    st = plan.stations
    pitch = st.pitch_deg.copy()
    pitch[st.run == 1] = -60.0
    plan = replace(plan, altitudes=replace(plan.altitudes, stations=replace(st, pitch_deg=pitch)),
                   camera=replace(plan.camera, trigger="hover", settle_s=1.5))
    program = flight_program(plan)
    assert wpml.refusal(program) is None
    path = tmp_path / "h.kmz"
    path.write_bytes(wpml.kmz_bytes(program, wpml.M3E))
    for name, root in _kmz(path).items():
        assert _check_reference(root, template=name.endswith(".kml")) == []
        marks = root.findall(".//k:Placemark", NS)
        shots = [pm for pm in marks if pm.find("wpml:actionGroup/wpml:action[wpml:actionActuatorFunc='takePhoto']", NS) is not None]
        assert [pm.findtext(".//wpml:fileSuffix", namespaces=NS) for pm in shots] == list(st.ids)
        for pm in shots:
            funcs = [a.findtext("wpml:actionActuatorFunc", namespaces=NS) for a in pm.iterfind(".//wpml:action", NS)]
            assert funcs[-2:] == ["hover", "takePhoto"]
            assert float(pm.findtext(".//wpml:hoverTime", namespaces=NS)) == 1.5
        pitches = [float(e.text) for e in root.iterfind(".//wpml:gimbalPitchRotateAngle", NS)]
        assert pitches == [-90.0, -60.0, -90.0]  # straight down at the start, tilted for run 1, down again after
    # the budget: numbers in the refusal
    many = replace(program, waypoints=program.waypoints * (65536 // len(program.waypoints) + 1))
    assert f"{len(many.waypoints)} waypoints, more than the 65535" in (wpml.refusal(many) or "")
    assert "at least 2" in (wpml.refusal(replace(program, waypoints=program.waypoints[:1])) or "")
