"""DJI WPML .kmz files checked with lxml against DJI's published WPML reference.

The required elements below are transcribed from the reference's tables (DJI Cloud API
documentation, DJI WPML: template.kml, waylines.wpml, common elements; the rows marked
"Yes" that apply to a waypoint template, or that become required by a value we use), not
from the emitter. The mapping templates' lists are from template.kml's sections "Template
common elements", "<wpml:payloadParam>", "Coordinate Parameter Info", "Mapping Aerial
Template Element" (mapping2d), "Waypoint Segment Flight Template Element" (mappingStrip) and
"Overlap Rate Information", with each row's type and range. The waypoints and actions are
compared with the MAVLink mission of the same flight program, read back from the .waypoints
file; a mapping template's polygon with the plan's area, its direction with the first photo
run of waylines.wpml.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import shapely
from click.testing import CliRunner
from lxml import etree
from pyproj import Transformer

from aerosurvey.cli import main
from aerosurvey.inputs import plan_from_files
from aerosurvey.mission.formats import wpml
from aerosurvey.mission.formats.dji_template import MappingTemplate, template_choice
from aerosurvey.mission.program import flight_program
from aerosurvey.mission.targets import M3E
from aerosurvey.spec import load_spec
from conftest import make_spec, write_geojson

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
    "shootType": {"time", "distance"},
}
# --- mapping templates (template.kml): under Folder, and under its Placemark ---
MAPPING_FOLDER = ["wpml:templateType", "wpml:templateId", "wpml:autoFlightSpeed",
                  "wpml:waylineCoordinateSysParam/wpml:coordinateMode", "wpml:waylineCoordinateSysParam/wpml:heightMode",
                  "wpml:waylineCoordinateSysParam/wpml:globalShootHeight",
                  "wpml:waylineCoordinateSysParam/wpml:surfaceFollowModeEnable",
                  "wpml:payloadParam/wpml:payloadPositionIndex", "wpml:payloadParam/wpml:imageFormat"]
MAPPING_PLACEMARK = {
    "mapping2d": ["wpml:elevationOptimizeEnable", "wpml:shootType", "wpml:direction", "wpml:margin", "wpml:ellipsoidHeight",
                  "wpml:height", "k:Polygon/k:outerBoundaryIs/k:LinearRing/k:coordinates"],
    "mappingStrip": ["wpml:caliFlightEnable", "wpml:shootType", "wpml:direction", "wpml:margin", "wpml:singleLineEnable",
                     "wpml:cuttingDistance", "wpml:boundaryOptimEnable", "wpml:leftExtend", "wpml:rightExtend",
                     "wpml:includeCenterEnable", "wpml:ellipsoidHeight", "wpml:height", "wpml:stripUseTemplateAltitude",
                     "k:LineString/k:coordinates"],
}
# each element's type and range as the reference gives it (None: no bound given)
BOOLEANS = ["caliFlightEnable", "elevationOptimizeEnable", "surfaceFollowModeEnable", "singleLineEnable",
            "boundaryOptimEnable", "includeCenterEnable", "stripUseTemplateAltitude"]
INTEGERS = {"templateId": (0, 65535), "direction": (0, 360), "margin": (None, None), "leftExtend": (None, None),
            "rightExtend": (None, None), "orthoCameraOverlapH": (0, 100), "orthoCameraOverlapW": (0, 100),
            "payloadPositionIndex": (0, 2)}
FLOATS = {"autoFlightSpeed": (0.0, 15.0), "globalShootHeight": (None, None), "ellipsoidHeight": (None, None),
          "height": (None, None), "cuttingDistance": (None, None)}


def _missing(el: etree._Element, paths: list[str], where: str) -> list[str]:
    return [f"{where}: {p}" for p in paths if el.find(p, NS) is None]


def _typed(root: etree._Element) -> list[str]:
    """Each boolean 0 or 1, each integer an integer, each number a number, within the reference's range."""
    bad = []
    for kind, names in (("boolean", {n: (0, 1) for n in BOOLEANS}), ("integer", INTEGERS), ("float", FLOATS)):
        for name, (lo, hi) in names.items():
            for el in root.iterfind(f".//wpml:{name}", NS):
                try:
                    v = float(el.text) if kind == "float" else int(el.text)
                except (TypeError, ValueError):
                    bad.append(f"wpml:{name} = {el.text!r} is not {'a number' if kind == 'float' else 'an integer'}")
                    continue
                if (lo is not None and v < lo) or (hi is not None and v > hi) or (kind == "float" and name == "autoFlightSpeed" and v <= 0):
                    bad.append(f"wpml:{name} = {v} is outside [{lo}, {hi}]")
    return bad


def _coordinates(text: str) -> list[tuple[float, float, float]]:
    """KML coordinates: `lon,lat,height` tuples separated by white space."""
    return [tuple(float(v) for v in t.split(",")) for t in text.split()]  # type: ignore[misc]


def _enums(root: etree._Element) -> list[str]:
    return [f"wpml:{name} = {el.text!r} is not one of {sorted(allowed)}" for name, allowed in ENUMS.items()
            for el in root.iterfind(f".//wpml:{name}", NS) if el.text not in allowed]


def _check_mapping(doc: etree._Element, kind: str) -> list[str]:
    folder = doc.find("k:Folder", NS)
    bad = _missing(folder, MAPPING_FOLDER, "Folder")
    marks = folder.findall("k:Placemark", NS)
    if len(marks) != 1:
        return [*bad, f"{len(marks)} Placemarks in a {kind} template; one holds the area or strip"]
    bad += _missing(marks[0], MAPPING_PLACEMARK[kind], f"{kind} Placemark")
    if folder.findtext("wpml:waylineCoordinateSysParam/wpml:surfaceFollowModeEnable", namespaces=NS) == "1":
        bad += _missing(folder, ["wpml:waylineCoordinateSysParam/wpml:surfaceRelativeHeight"], "Folder")
    if folder.findtext("wpml:waylineCoordinateSysParam/wpml:heightMode", namespaces=NS) == "relativeToStartPoint":
        # "Mapping Aerial Template Element": relative to the take-off point, ellipsoidHeight is height
        if marks[0].findtext("wpml:ellipsoidHeight", namespaces=NS) != marks[0].findtext("wpml:height", namespaces=NS):
            bad.append("relativeToStartPoint: wpml:ellipsoidHeight differs from wpml:height")
    path = "k:Polygon/k:outerBoundaryIs/k:LinearRing/k:coordinates" if kind == "mapping2d" else "k:LineString/k:coordinates"
    pts = _coordinates(marks[0].findtext(path, "", namespaces=NS))
    if any(len(p) != 3 or not (-180 <= p[0] <= 180 and -90 <= p[1] <= 90) for p in pts):
        bad.append(f"{kind}: coordinates are not longitude,latitude,height in range")
    if kind == "mapping2d" and (len(pts) < 4 or pts[0] != pts[-1]):
        bad.append("mapping2d: the LinearRing is not closed with at least 4 positions (KML 2.2)")
    if kind == "mappingStrip" and len(pts) < 2:
        bad.append("mappingStrip: the LineString has fewer than 2 positions")
    return bad


def _check_reference(root: etree._Element, template: bool) -> list[str]:
    """Every required element present and every enumerated value allowed; what is not, named."""
    bad: list[str] = []
    doc = root.find("k:Document", NS)
    assert doc is not None
    bad += _missing(doc, ["wpml:missionConfig"], "Document")
    bad += _missing(doc.find("wpml:missionConfig", NS), MISSION_CONFIG if template else WAYLINES_MISSION_CONFIG, "missionConfig")
    bad += _typed(root)
    folder = doc.find("k:Folder", NS)
    kind = folder.findtext("wpml:templateType", namespaces=NS)
    if template and kind in MAPPING_PLACEMARK:
        return bad + _check_mapping(doc, kind) + _enums(root)
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
    bad += _enums(root)
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


def _comments(root: etree._Element) -> str:
    return " ".join(str(c.text) for c in root.iter(etree.Comment))


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
        # one area pass flown whole: a mapping2d template; a fixed yaw: the waypoint template, saying why
        tpl = docs["wpmz/template.kml"]
        kind = tpl.findtext(".//wpml:templateType", namespaces=NS)
        if overrides and "flight" in overrides:
            assert kind == "waypoint"  # the first reason: the sorties' own, then the mission's fixed yaw
            assert ("flight.fixed_yaw_deg" if stem == "mission" else "flies part of the pass") in _comments(tpl)
        else:
            assert kind == "mapping2d"
            assert tpl.findtext(".//wpml:shootType", namespaces=NS) == ("time" if overrides else "distance")


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
    path.write_bytes(wpml.kmz_bytes(program, M3E))
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
        # straight down at the first run (the first waypoint: every flight sets the camera's aim at its start),
        # tilted for run 1, down again after
        assert pitches == [-90.0, -60.0, -90.0]
    # the budget: numbers in the refusal
    many = replace(program, waypoints=program.waypoints * (65536 // len(program.waypoints) + 1))
    assert f"{len(many.waypoints)} waypoints, more than the 65535" in (wpml.refusal(many) or "")
    assert "at least 2" in (wpml.refusal(replace(program, waypoints=program.waypoints[:1])) or "")


# --- mapping templates ---

#: a five-sided area (not a rectangle along the axes) near 49.4 N 15.0 E
PENTAGON = [[15.000, 49.400], [15.007, 49.4005], [15.0085, 49.4040], [15.003, 49.4058], [14.9990, 49.4030], [15.000, 49.400]]


def _bearing(lon0: float, lat0: float, lon1: float, lat1: float) -> float:
    """Initial great-circle bearing on a sphere, degrees clockwise from north (the aviation formulary's)."""
    p0, p1, dl = math.radians(lat0), math.radians(lat1), math.radians(lon1 - lon0)
    y = math.sin(dl) * math.cos(p1)
    x = math.cos(p0) * math.sin(p1) - math.sin(p0) * math.cos(p1) * math.cos(dl)
    return math.degrees(math.atan2(y, x)) % 360.0


def _local(lon0: float, lat0: float) -> Transformer:
    return Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={lat0} +lon_0={lon0} +ellps=WGS84", always_xy=True)


def _lonlat(el: etree._Element) -> tuple[float, float]:
    lon, lat = (float(v) for v in el.findtext("k:Point/k:coordinates", namespaces=NS).split(",")[:2])
    return lon, lat


def _photo_runs(way: etree._Element) -> list[tuple[tuple[float, float], tuple[float, float], float]]:
    """Each photo run of waylines.wpml: lon/lat of its first and last waypoint, and its trigger's parameter."""
    marks = way.findall(".//k:Placemark", NS)
    out = []
    for g in way.iterfind(".//wpml:actionGroup", NS):
        if g.findtext("wpml:actionTrigger/wpml:actionTriggerType", namespaces=NS).startswith("multiple"):
            a, b = (int(g.findtext(f"wpml:{k}", namespaces=NS)) for k in ("actionGroupStartIndex", "actionGroupEndIndex"))
            out.append((_lonlat(marks[a]), _lonlat(marks[b]), float(g.findtext(".//wpml:actionTriggerParam", namespaces=NS))))
    return out


def test_mapping2d_holds_the_area_the_direction_and_the_overlaps_flown(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, {"camera": {"model": "dji-mavic-3-enterprise"}}, area=PENTAGON)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    docs = _kmz(out / "mission.kmz")
    tpl, way = docs["wpmz/template.kml"], docs["wpmz/waylines.wpml"]
    assert _check_reference(tpl, template=True) == [] and _check_reference(way, template=False) == []
    assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "mapping2d"
    pm = tpl.find("k:Document/k:Folder/k:Placemark", NS)
    # the polygon is the plan's area, within 0.1 m (on a local plane)
    plan = plan_from_files(load_spec(spec))
    ring = _coordinates(pm.findtext(".//k:LinearRing/k:coordinates", namespaces=NS))
    c = plan.site.area_wgs84.centroid
    tr = _local(c.x, c.y)
    written = shapely.Polygon(np.column_stack(tr.transform([p[0] for p in ring], [p[1] for p in ring])))
    area = shapely.transform(plan.site.area_wgs84, lambda a: np.column_stack(tr.transform(a[:, 0], a[:, 1])))
    assert shapely.hausdorff_distance(written, area) < 0.1
    # the direction: the compass bearing of the first photo run flown (to the degree it is written in)
    runs = _photo_runs(way)
    (lon0, lat0), (lon1, lat1), base = runs[0]
    direction = int(pm.findtext("wpml:direction", namespaces=NS))
    assert abs((direction - _bearing(lon0, lat0, lon1, lat1) + 180.0) % 360.0 - 180.0) <= 0.5 + 1e-6
    # the overlaps give DJI's spacing and base back: footprint (sensor · H / f, landscape) at globalShootHeight
    cam = plan.camera.camera
    h = float(tpl.findtext(".//wpml:globalShootHeight", namespaces=NS))
    across, along = h * cam.sensor_width_mm / cam.focal_mm, h * cam.sensor_height_mm / cam.focal_mm
    w = int(pm.findtext(".//wpml:orthoCameraOverlapW", namespaces=NS)) / 100.0
    f = int(pm.findtext(".//wpml:orthoCameraOverlapH", namespaces=NS)) / 100.0
    starts = np.column_stack(tr.transform([r[0][0] for r in runs], [r[0][1] for r in runs]))
    ends = np.column_stack(tr.transform([r[1][0] for r in runs], [r[1][1] for r in runs]))
    u = (ends[0] - starts[0]) / np.hypot(*(ends[0] - starts[0]))
    offsets = np.sort(starts @ np.array([-u[1], u[0]]))
    spacing = float(np.median(np.diff(offsets)))
    assert spacing == pytest.approx((1.0 - w) * across, abs=0.015 * across)
    assert base == pytest.approx((1.0 - f) * along, abs=0.015 * along)
    # one height above the take-off point: the height the photo runs are flown at
    heights = {float(m.findtext("wpml:executeHeight", namespaces=NS)) for m in way.iterfind(".//k:Placemark", NS)}
    assert float(pm.findtext("wpml:height", namespaces=NS)) in heights


def _waylines(path: Path) -> list[tuple]:
    """waylines.wpml by meaning: per waypoint its place, height, speed, turn and its actions' triggers and functions."""
    way = _kmz(path)["wpmz/waylines.wpml"]
    out = []
    for pm in way.iterfind(".//k:Placemark", NS):
        groups = tuple((g.findtext("wpml:actionTrigger/wpml:actionTriggerType", namespaces=NS),
                        g.findtext("wpml:actionTrigger/wpml:actionTriggerParam", namespaces=NS),
                        g.findtext("wpml:actionGroupEndIndex", namespaces=NS),
                        tuple(a.findtext("wpml:actionActuatorFunc", namespaces=NS) for a in g.iterfind("wpml:action", NS)))
                       for g in pm.iterfind("wpml:actionGroup", NS))
        out.append((_lonlat(pm), float(pm.findtext("wpml:executeHeight", namespaces=NS)),
                    float(pm.findtext("wpml:waypointSpeed", namespaces=NS)),
                    pm.findtext(".//wpml:waypointTurnMode", namespaces=NS), groups))
    return out


def test_waylines_are_the_same_whichever_template(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, {"camera": {"model": "dji-mavic-3-enterprise"}}, area=PENTAGON)
    for dji in ("mapping", "waypoint"):
        res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / dji), "--dji", dji])
        assert res.exit_code == 0, res.output
    kinds = [_kmz(tmp_path / d / "mission.kmz")["wpmz/template.kml"].findtext(".//wpml:templateType", namespaces=NS)
             for d in ("mapping", "waypoint")]
    assert kinds == ["mapping2d", "waypoint"]
    assert "asked for" in _comments(_kmz(tmp_path / "waypoint" / "mission.kmz")["wpmz/template.kml"])
    assert _waylines(tmp_path / "mapping" / "mission.kmz") == _waylines(tmp_path / "waypoint" / "mission.kmz")


def test_corridor_is_a_strip_template_along_its_centreline(tmp_path: Path) -> None:
    line = [[15.000, 49.400], [15.010, 49.402], [15.018, 49.398]]
    write_geojson(tmp_path / "line.geojson", line, "LineString")
    spec = make_spec(tmp_path, {"camera": {"model": "dji-mavic-3-enterprise"}, "area": {"file": "line.geojson"},
                                "pattern": {"kind": "corridor", "width_m": 150.0}})
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    docs = _kmz(out / "mission.kmz")
    tpl = docs["wpmz/template.kml"]
    assert _check_reference(tpl, template=True) == [] and _check_reference(docs["wpmz/waylines.wpml"], template=False) == []
    assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "mappingStrip"
    pm = tpl.find("k:Document/k:Folder/k:Placemark", NS)
    assert int(pm.findtext("wpml:leftExtend", namespaces=NS)) == int(pm.findtext("wpml:rightExtend", namespaces=NS)) == 75
    # the strip's line is the corridor's centreline: each vertex within 1 m of it (its ends on its end segments, extended)
    tr = _local(15.009, 49.400)
    xy = np.column_stack(tr.transform([p[0] for p in line], [p[1] for p in line]))
    d0, d1 = xy[0] - xy[1], xy[-1] - xy[-2]
    longer = shapely.LineString(np.vstack([xy[0] + 1000 * d0 / np.hypot(*d0), xy, xy[-1] + 1000 * d1 / np.hypot(*d1)]))
    pts = _coordinates(pm.findtext("k:LineString/k:coordinates", namespaces=NS))
    written = np.column_stack(tr.transform([p[0] for p in pts], [p[1] for p in pts]))
    assert max(longer.distance(shapely.Point(p)) for p in written) < 1.0
    # the lines: a line on the centreline when their count is odd
    plan = plan_from_files(load_spec(spec))
    lines = len({r.line for r in plan.route.runs})
    assert pm.findtext("wpml:includeCenterEnable", namespaces=NS) == str(lines % 2)
    assert pm.findtext("wpml:singleLineEnable", namespaces=NS) == str(int(lines == 1))
    assert float(pm.findtext("wpml:cuttingDistance", namespaces=NS)) >= shapely.LineString(written).length


def test_a_corridor_polygon_is_a_strip_template_as_wide_as_its_derived_widths(tmp_path: Path) -> None:
    """The corridor's outline (the line above buffered by 75 m) and no width: the strip's extents are
    the widths the plan derived (the manifest's), half their sum each side."""
    line = [[15.000, 49.400], [15.010, 49.402], [15.018, 49.398]]
    tr = _local(15.009, 49.400)
    xy = np.column_stack(tr.transform([p[0] for p in line], [p[1] for p in line]))
    ring = shapely.get_coordinates(shapely.LineString(xy).buffer(75.0).exterior)
    lon, lat = tr.transform(ring[:, 0], ring[:, 1], direction="INVERSE")
    write_geojson(tmp_path / "outline.geojson", [[[float(a), float(b)] for a, b in zip(lon, lat)]])
    spec = make_spec(tmp_path, {"camera": {"model": "dji-mavic-3-enterprise"}, "area": {"file": "outline.geojson"},
                                "pattern": {"kind": "corridor"}})
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    tpl = _kmz(out / "mission.kmz")["wpmz/template.kml"]
    assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "mappingStrip"
    pm = tpl.find("k:Document/k:Folder/k:Placemark", NS)
    sides = json.loads((out / "manifest.json").read_text())["pattern"]["parameters"]
    assert int(pm.findtext("wpml:leftExtend", namespaces=NS)) == round((sides["left_m"] + sides["right_m"]) / 2.0)
    assert 70.0 <= sides["left_m"] <= 90.0 and 70.0 <= sides["right_m"] <= 90.0  # 75 m, give or take the medial axis


@pytest.mark.parametrize(("overrides", "reason"), [
    ({"flight": {"cross_hatch": True}}, "2 passes at "),
    ({"camera": {"trigger": "hover"}}, "camera.trigger = 'hover'"),
    ({"pattern": {"kind": "oblique"}}, "2 passes at "),  # a double grid: two passes, the camera tilted
    ({"area": {"exclusions": ["zone.geojson"]}}, "exclusion zones"),
])
def test_what_a_mapping_template_cannot_say_stays_waypoints_with_why(tmp_path: Path, overrides: dict, reason: str) -> None:
    write_geojson(tmp_path / "zone.geojson", [[[15.002, 49.401], [15.003, 49.401], [15.003, 49.402], [15.002, 49.401]]])
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, overrides)), "-o", str(out)])
    # with the zone, a layout may leave a corner next to it that no two photos see: the plan is then written for
    # inspection (exit 1); the template is what is judged here
    assert res.exit_code in ((0, 1) if "area" in overrides else (0,)), res.output
    tpl = _kmz(out / "mission.kmz")["wpmz/template.kml"]
    assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "waypoint"
    assert reason in _comments(tpl)
    assert _check_reference(tpl, template=True) == []


def test_a_strip_flown_in_two_pieces_is_waypoints_saying_so(tmp_path: Path) -> None:
    """A strip 100 m wide bent once is flown as two pieces at their own headings: two passes,
    which a mapping template cannot hold; the reason names both headings and the layout."""
    bent = shapely.LineString([(0, 0), (700, 0), (1100, 350)]).buffer(50, cap_style="flat", join_style="mitre")
    k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(49.4)))
    area = [[15.0 + x * k_lon, 49.4 + y * k_lat] for x, y in bent.exterior.coords]
    out = tmp_path / "out"
    spec = make_spec(tmp_path, {"camera": {"model": "dji-mavic-3-enterprise"}}, area=area)
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    chosen = json.loads((out / "manifest.json").read_text())["derived"]["heading_chosen"]
    tpl = _kmz(out / "mission.kmz")["wpmz/template.kml"]
    assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "waypoint"
    why = _comments(tpl)
    assert "2 passes at " in why and chosen in why and "cross_hatch" not in why, why


def test_a_sortie_of_several_is_waypoints_the_whole_mission_mapping(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_spec(tmp_path, {"battery": {"usable_min": 6.0, "reserve": 0.2}})), "-o", str(out)])
    assert res.exit_code == 0, res.output
    sorties = sorted(out.glob("sortie-*.kmz"))
    assert len(sorties) > 1
    assert _kmz(out / "mission.kmz")["wpmz/template.kml"].findtext(".//wpml:templateType", namespaces=NS) == "mapping2d"
    for k in sorties:
        tpl = _kmz(k)["wpmz/template.kml"]
        assert tpl.findtext(".//wpml:templateType", namespaces=NS) == "waypoint"
        assert "flies part of the pass" in _comments(tpl)


def test_template_choice_on_a_terrain_following_plan(tmp_path: Path) -> None:
    plan = plan_from_files(load_spec(_spec(tmp_path)))
    program = flight_program(plan)
    assert isinstance(template_choice(plan, program, whole=True), MappingTemplate)
    follow = replace(plan, sensor=replace(plan.sensor, heights=replace(plan.sensor.heights, mode="follow")))
    assert "terrain.mode = 'follow'" in str(template_choice(follow, program, whole=True))
    assert "part of the pass" in str(template_choice(plan, program, whole=False))
    assert "asked for" in str(template_choice(plan, program, whole=True, asked="waypoint"))


def test_a_nadir_flight_points_the_gimbal_down_at_its_first_waypoint(tmp_path: Path) -> None:
    """Every DJI flight of a nadir plan (the mission and each sortie) turns the gimbal straight down at
    its first waypoint, once: the aircraft may take off with it where another flight left it."""
    plan = plan_from_files(load_spec(_spec(tmp_path, {"battery": {"usable_min": 6.0, "reserve": 0.2}})))
    assert (plan.stations.pitch_deg == -90).all() and len(plan.sorties) >= 2
    for k in (None, *range(len(plan.sorties))):
        path = tmp_path / f"{k}.kmz"
        path.write_bytes(wpml.kmz_bytes(flight_program(plan, k), M3E))
        root = _kmz(path)["wpmz/waylines.wpml"]
        marks = root.findall(".//k:Placemark", NS)
        rotates = [(i, a) for i, pm in enumerate(marks) for a in pm.iterfind(".//wpml:action", NS)
                   if a.findtext("wpml:actionActuatorFunc", namespaces=NS) == "gimbalRotate"]
        assert len(rotates) == 1 and rotates[0][0] == 0, k
        prm = rotates[0][1].find("wpml:actionActuatorFuncParam", NS)
        assert float(prm.findtext("wpml:gimbalPitchRotateAngle", namespaces=NS)) == -90.0
        assert prm.findtext("wpml:gimbalYawRotateEnable", namespaces=NS) == "0"
