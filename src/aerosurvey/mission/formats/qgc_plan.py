"""QGroundControl .plan files (JSON): write and read SimpleItem missions with a geofence.

The layout follows QGroundControl's own writer and reader (PlanMasterController,
MissionController, SimpleMissionItem, MissionItem, GeoFenceController, QGCFencePolygon):
file version 1, mission version 2, each item a "SimpleItem" with a 7-value `params`
array in which NaN is written as null, `doJumpId` the item's 1-based sequence number,
and fence polygons as [latitude, longitude] pairs. Keys are sorted, as QGroundControl's
Qt JSON writer sorts them, and the text is indented by 4 spaces.

Altitude keys: items with a position in frame 3, 0 or 10 also carry `Altitude`,
`AltitudeMode` (QGroundControl's AltMode: 1 relative, 2 absolute, 4 terrain frame; 0 is
"mixed", 3 "calculated above terrain" in frame 0) and `AMSLAltAboveTerrain` (null).
QGroundControl requires the three together or none; without them it derives the mode
from `frame`. `globalPlanAltitudeMode` is written only when every positioned item uses
one of those frames (1 when there are none); for mixed frames it is left out, and
QGroundControl then treats the plan as mixed, which is the value it sets before reading
the key.

Two keys are aerosurvey's own: `aerosurveyName` (top level) and `aerosurveyTag` (on an
item with a non-empty tag). QGroundControl validates only the keys it knows, so it loads
such files, but it drops both keys when it saves the plan again.

Rally points: `rallyPoints` version 2, `points` a list of [latitude, longitude, altitude]
(RallyPointController::load reads them with altitudes required; the altitude is above home).

Mission Planner reads a .plan through MissionFile.cs, whose `cruiseSpeed`, `hoverSpeed`,
`firmwareType`, `vehicleType`, `version`, `command`, `doJumpId` and `frame` are C# ints and
`params` a list of doubles: the builder makes the speeds whole numbers, and this writer
writes every whole float as an integer.

Survey items (`surveys`, from mission/formats/qgc_survey.py): a run of items that flies one
photo pass is written as one QGroundControl Survey complex item (complexItemType "survey",
version 5; a corridor's pass as a Corridor Scan, "CorridorScan", version 2, with a polyline
and a width in place of the polygon and angle) holding a TransectStyleComplexItem (version 2)
with those items as `Items`, which
QGroundControl uploads as they are while the plan is not edited, and the polygon, angle,
spacing, turnaround and CameraCalc (version 2) its own generator rebuilds the pass from when
it is (docs/clients/qgroundcontrol.md). The items keep their doJumpId (their sequence number)
and tag.

Structure Scan items (an orbit's rings, `QgcStructureScan`): complexItemType "StructureScan",
version 3, the structure polygon, layers and CameraCalc; they hold no items: QGroundControl
always flies what it generates from them.

Reading: our own files and QGroundControl-written plans of SimpleItems, and Survey and
Corridor Scan items, read as the `Items` they hold (what QGroundControl uploads for them);
Structure Scan items as the items QGroundControl generates for them (`_structure_scan_items`).
Other ComplexItems (landing patterns) and circular fences have no place in aerosurvey's
mission model and are refused with what to do.
`mission.cruiseSpeed`/`hoverSpeed` are optional in QGroundControl and read as 0.0 when
absent; a missing `vehicleType` reads as a copter (QGroundControl's multirotor default).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.jsontext import dumps_indented
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem

if TYPE_CHECKING:
    from aerosurvey.mission.formats.qgc_survey import QgcCamera, QgcStructureScan, QgcSurvey

PLAN_FILE_VERSION = 1
SURVEY_VERSION = 5
CORRIDOR_VERSION = 2
TRANSECT_STYLE_VERSION = 2
CAMERA_CALC_VERSION = 2
STRUCTURE_SCAN_VERSION = 3
STRUCTURE_SCAN_ITEM = "StructureScan"
#: complex items whose stored `Items` the reader takes (TransectStyleComplexItem's children)
_TRANSECT_ITEMS = ("survey", "CorridorScan")
MISSION_VERSION = 2
GEOFENCE_VERSION = 2
FENCE_POLYGON_VERSION = 1
RALLY_VERSION = 2
NAME_KEY = "aerosurveyName"
TAG_KEY = "aerosurveyTag"

# MAV_CMD_DO_JUMP: its param1 names a doJumpId in a plan file, a sequence number on the vehicle
_DO_JUMP = 177
# MAV_FRAME -> QGroundControl AltMode (1 relative, 2 absolute, 4 terrain frame)
_ALT_MODE = {mav.FRAME_GLOBAL_RELATIVE_ALT: 1, mav.FRAME_GLOBAL: 2, mav.FRAME_GLOBAL_TERRAIN_ALT: 4}
_FIRMWARE = {"ardupilot": mav.AUTOPILOT_ARDUPILOTMEGA, "px4": mav.AUTOPILOT_PX4}
_VEHICLE = {"copter": mav.TYPE_QUADROTOR, "plane": mav.TYPE_FIXED_WING}
# MAV_TYPE read from a plan: multirotors and helicopters fly copter firmware; fixed wings and
# VTOLs (19-25) fly plane firmware (ArduPlane for ArduPilot quadplanes)
_COPTER_TYPES = frozenset({2, 3, 4, 13, 14, 15})
_PLANE_TYPES = frozenset({1, *range(19, 26)})
_PARAM_NAMES = ("param1", "param2", "param3", "param4", "x (latitude)", "y (longitude)", "z (altitude)")
_HOME_NAMES = ("latitude", "longitude", "altitude")
_LAT_LON = ("latitude", "longitude")
Polygon = tuple[tuple[float, float], ...]


def _json_numbers(values: Any, where: Callable[[int], str], nan_ok: bool = True) -> list[Any]:
    """Numbers as the JSON values of a plan file, in a list (nested as `values` is): whole numbers
    as integers (Mission Planner's C# reader takes ints where QGroundControl writes them), NaN as
    null as QGroundControl writes it (refused unless `nan_ok`), infinity refused; an error names
    the value's place, `where` of its flat index (made only then). One numpy pass for them all:
    a mission's items have thousands."""
    a = np.asarray(values, dtype=float)
    bad = np.isinf(a) | (np.isnan(a) & (not nan_ok))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        v = float(a.flat[i])
        allowed = "a finite number" if math.isnan(v) or not nan_ok else "a finite number (or NaN for 'unset')"
        raise InputError(f"{where(i)} = {v!r} is not allowed: {allowed}")
    out = a.astype(object)
    whole = (a == np.trunc(a)) & (np.abs(a) < 2**53)  # NaN is not whole
    out[whole] = a[whole].astype(np.int64)
    out[np.isnan(a)] = None
    numbers: list[Any] = out.tolist()
    return numbers


def _finite(value: float, where: str) -> float | int:
    """A JSON value for one number that must be finite (speeds, the survey's settings)."""
    v: float | int = _json_numbers([value], lambda _: where, nan_ok=False)[0]
    return v


def _lat_lons(points: Any, where: str) -> list[Any]:
    """[latitude, longitude] pairs (finite) as JSON values; an error names `where`, the vertex (from 1) and which."""
    return _json_numbers(np.reshape(np.asarray(points, float), (-1, 2)),
                         lambda i: f"{where} vertex {i // 2 + 1} {_LAT_LON[i % 2]}", nan_ok=False)


def _check_item(it: MissionItem, where: str) -> None:
    """Refuse what QGroundControl or the vehicle could not take: numbers out of range, a position item without a position."""
    if isinstance(it.command, bool) or not isinstance(it.command, int) or not 0 <= it.command <= 65535:
        raise InputError(f"{where} command = {it.command!r} is not allowed: a MAV_CMD number 0-65535")
    if isinstance(it.frame, bool) or not isinstance(it.frame, int) or not 0 <= it.frame <= 255:
        raise InputError(f"{where} frame = {it.frame!r} is not allowed: a MAV_FRAME number 0-255")
    if it.has_position:
        for name, v in (("x (latitude)", it.x), ("y (longitude)", it.y), ("z (altitude)", it.z)):
            if not math.isfinite(v):
                raise InputError(f"{where} {name} = {v!r} is not allowed: a position item needs a finite position")


def _item_dict(it: MissionItem, seq: int, params: list[float | int | None]) -> dict[str, Any]:
    """A SimpleItem as QGroundControl saves it, its `params` (param1-4, x, y, z) as `_json_numbers`
    makes them; `seq` (1-based) is also its doJumpId, as in QGC's own files."""
    d: dict[str, Any] = {"autoContinue": bool(it.autocontinue), "command": it.command, "doJumpId": seq, "frame": it.frame,
                         "params": params, "type": "SimpleItem"}
    if it.has_position and it.frame in _ALT_MODE:
        d["AMSLAltAboveTerrain"] = None
        d["Altitude"] = params[6]
        d["AltitudeMode"] = _ALT_MODE[it.frame]
    if it.tag:
        d[TAG_KEY] = it.tag
    return d


def _fence_polygons(m: Mission) -> list[dict[str, Any]]:
    """geoFence polygons, inclusions first; QGroundControl keeps vertices as [latitude, longitude]."""
    out = []
    for inclusion, polys in ((True, m.fence_inclusion), (False, m.fence_exclusion)):
        kind = "inclusion" if inclusion else "exclusion"
        for k, poly in enumerate(polys, start=1):
            where = f"{kind} fence polygon {k}"
            if len(poly) < 3:
                raise InputError(f"{where} has {len(poly)} vertices; a fence polygon needs at least 3")
            out.append({"inclusion": inclusion, "polygon": _lat_lons(poly, where), "version": FENCE_POLYGON_VERSION})
    return out


def _camera_calc(c: QgcCamera, side_m: float, frontal_m: float, distance_m: float, mode: int,
                 where: str) -> dict[str, Any]:
    """CameraCalc::save (version 2) of a custom camera, CameraSpec::save."""
    def num(v: float, name: str) -> float | int:
        return _finite(v, f"{where} {name}")

    return {
        "AdjustedFootprintFrontal": num(frontal_m, "frontal footprint"),
        "AdjustedFootprintSide": num(side_m, "side footprint"),
        "CameraName": "Custom Camera",
        "DistanceMode": mode,
        "DistanceToSurface": num(distance_m, "distance to surface"),
        "FixedOrientation": False,
        "FocalLength": num(c.focal_mm, "focal length"),
        "FrontalOverlap": num(c.frontal_overlap, "frontal overlap"),
        "ImageDensity": num(c.image_density_cm, "image density"),
        "ImageHeight": c.image_height_px,
        "ImageWidth": c.image_width_px,
        "Landscape": c.landscape,
        "MinTriggerInterval": num(c.min_trigger_interval_s, "minimum trigger interval"),
        "SensorHeight": num(c.sensor_height_mm, "sensor height"),
        "SensorWidth": num(c.sensor_width_mm, "sensor width"),
        "SideOverlap": num(c.side_overlap, "side overlap"),
        "ValueSetIsDistance": True,
        "version": CAMERA_CALC_VERSION,
    }


def _structure_scan_dict(s: QgcStructureScan) -> dict[str, Any]:
    """A Structure Scan complex item as QGroundControl saves it (StructureScanComplexItem::save):
    no items, only what it generates them from (qgc_survey.QgcStructureScan)."""
    where = f"structure scan item of passes {', '.join(map(str, s.passes))}"
    if len(s.polygon) < 3:
        raise InputError(f"{where} polygon has {len(s.polygon)} vertices; a structure polygon needs at least 3")
    return {
        "CameraCalc": _camera_calc(s.camera, s.trigger_m, s.layer_m, s.standoff_m, 1, where),
        "EntranceAltitude": _finite(s.entrance_m, f"{where} entrance altitude"),
        "GimbalPitch": _finite(s.pitch_deg, f"{where} gimbal pitch"),
        "Layers": s.layers,
        "ScanBottomAlt": _finite(s.bottom_m, f"{where} scan bottom altitude"),
        "StartFromTop": s.from_top,
        "StructureHeight": _finite(s.height_m, f"{where} structure height"),
        "complexItemType": STRUCTURE_SCAN_ITEM,
        "polygon": _lat_lons(s.polygon, f"{where} polygon"),
        "type": "ComplexItem",
        "version": STRUCTURE_SCAN_VERSION,
    }


def _survey_dict(s: QgcSurvey, items: list[dict[str, Any]]) -> dict[str, Any]:
    """A Survey (or, for a corridor, a Corridor Scan) complex item as QGroundControl saves it
    (SurveyComplexItem::_saveCommon, CorridorScanComplexItem::_saveCommon,
    TransectStyleComplexItem::_save, CameraCalc::save, CameraSpec::save)."""
    where = f"survey item of pass {s.pass_index}"

    def num(v: float, name: str) -> float | int:
        return _finite(v, f"{where} {name}")

    camera_calc = _camera_calc(s.camera, s.spacing_m, s.trigger_m, s.distance_m, s.distance_mode, where)
    transect: dict[str, Any] = {
        "CameraCalc": camera_calc,
        "CameraShots": s.camera_shots,
        "CameraTriggerInTurnAround": False,
        "HoverAndCapture": s.hover,
        "Items": items,
        "Refly90Degrees": False,
        "TurnAroundDistance": num(s.turnaround_m, "turnaround distance"),
        "VisualTransectPoints": _lat_lons(s.visual_points, f"{where} visual point"),
        "version": TRANSECT_STYLE_VERSION,
    }
    if s.distance_mode == 3:  # QGroundControl's own terrain following: it reads these only then
        transect |= {"TerrainAdjustMaxClimbRate": num(s.max_climb_ms, "climb rate"),
                     "TerrainAdjustMaxDescentRate": num(s.max_descent_ms, "descent rate"),
                     "TerrainAdjustTolerance": num(s.terrain_tolerance_m, "terrain tolerance"),
                     "TerrainFlightSpeed": num(s.flight_speed_ms, "flight speed")}
    if s.corridor_polyline:  # CorridorScanComplexItem::_saveCommon
        if len(s.corridor_polyline) < 2:
            raise InputError(f"{where} polyline has {len(s.corridor_polyline)} vertices; a corridor needs at least 2")
        return {
            "CorridorWidth": num(s.corridor_width_m, "corridor width"),
            "EntryPoint": s.entry_location,
            "TransectStyleComplexItem": transect,
            "complexItemType": "CorridorScan",
            "polyline": _lat_lons(s.corridor_polyline, f"{where} polyline"),
            "type": "ComplexItem",
            "version": CORRIDOR_VERSION,
        }
    if len(s.polygon) < 3:
        raise InputError(f"{where} polygon has {len(s.polygon)} vertices; a survey polygon needs at least 3")
    return {
        "TransectStyleComplexItem": transect,
        "angle": num(s.angle_deg, "angle"),
        "complexItemType": "survey",
        "entryLocation": s.entry_location,
        "flyAlternateTransects": s.fly_alternate,
        "polygon": _lat_lons(s.polygon, f"{where} polygon"),
        "splitConcavePolygons": False,
        "type": "ComplexItem",
        "version": SURVEY_VERSION,
    }


def mission_to_plan_dict(m: Mission, surveys: tuple[QgcSurvey | QgcStructureScan, ...] = ()) -> dict[str, Any]:
    """The plan as the JSON object QGroundControl reads (see the module docstring for the keys);
    the items of each of `surveys` go into one Survey (Corridor Scan, Structure Scan) complex item."""
    if m.firmware not in _FIRMWARE:
        raise InputError(f"mission firmware = {m.firmware!r} is not allowed: one of {', '.join(_FIRMWARE)}")
    if m.vehicle not in _VEHICLE:
        raise InputError(f"mission vehicle = {m.vehicle!r} is not allowed: one of {', '.join(_VEHICLE)}")
    if len(m.home) != 3:
        raise InputError(f"mission home = {m.home!r} is not allowed: (latitude, longitude, altitude AMSL)")
    for seq, it in enumerate(m.items, start=1):
        _check_item(it, f"mission item {seq}")
    params = _json_numbers([(*it.params, it.x, it.y, it.z) for it in m.items],
                           lambda i: f"mission item {i // 7 + 1} {_PARAM_NAMES[i % 7]}")
    if surveys:  # made there: the module is loaded
        from aerosurvey.mission.formats.qgc_survey import QgcStructureScan
    items: list[dict[str, Any]] = [_item_dict(it, seq, p) for seq, (it, p) in enumerate(zip(m.items, params), start=1)]
    for s in sorted(surveys, key=lambda s: s.first, reverse=True):  # from the end: earlier indices stay valid
        if not 0 <= s.first <= s.last < len(m.items):
            raise InputError(f"complex item of items {s.first + 1}-{s.last + 1}: not items of this mission (1-{len(m.items)})")
        items[s.first:s.last + 1] = [_structure_scan_dict(s) if isinstance(s, QgcStructureScan) else
                                     _survey_dict(s, items[s.first:s.last + 1])]
    for seq, it in enumerate(m.items, start=1):
        if it.command == _DO_JUMP and not (float(it.param1).is_integer() and 1 <= it.param1 <= len(m.items)):
            raise InputError(f"mission item {seq} DO_JUMP param1 = {it.param1!r} is not allowed: "
                             f"the sequence number of an item of this mission (1-{len(m.items)})")
    mission: dict[str, Any] = {
        "cruiseSpeed": _finite(m.cruise_speed, "mission cruise_speed"),
        "firmwareType": _FIRMWARE[m.firmware],
        "hoverSpeed": _finite(m.hover_speed, "mission hover_speed"),
        "items": items,
        "plannedHomePosition": _json_numbers(m.home, lambda i: f"mission home {_HOME_NAMES[i]}", nan_ok=False),
        "vehicleType": _VEHICLE[m.vehicle],
        "version": MISSION_VERSION,
    }
    frames = {it.frame for it in m.items if it.has_position}
    if not frames:
        mission["globalPlanAltitudeMode"] = _ALT_MODE[mav.FRAME_GLOBAL_RELATIVE_ALT]
    elif len(frames) == 1 and next(iter(frames)) in _ALT_MODE:
        mission["globalPlanAltitudeMode"] = _ALT_MODE[next(iter(frames))]
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": _fence_polygons(m), "version": GEOFENCE_VERSION},
        "groundStation": "QGroundControl",
        "mission": mission,
        NAME_KEY: m.name,
        "rallyPoints": {"points": _json_numbers(np.reshape(np.asarray(m.rally, float), (-1, 3)),
                                                lambda i: f"rally point {i // 3 + 1} {_HOME_NAMES[i % 3]}", nan_ok=False),
                        "version": RALLY_VERSION},
        "version": PLAN_FILE_VERSION,
    }


def dumps_plan(m: Mission, surveys: tuple[QgcSurvey | QgcStructureScan, ...] = ()) -> str:
    """The plan as JSON text: sorted keys, indent 4, newline at the end, so equal missions give
    equal bytes. Every float in `mission_to_plan_dict` has passed `_json_numbers`
    (NaN is None there, infinity refused), as `dumps_indented` requires."""
    return dumps_indented(mission_to_plan_dict(m, surveys)) + "\n"


def _number(v: Any, where: str, *, nullable: bool = False) -> float:
    """A JSON number as a float; null is NaN where QGroundControl allows it (params, home)."""
    if v is None and nullable:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        allowed = "a number or null" if nullable else "a number"
        raise InputError(f"{where} = {v!r} is not allowed: {allowed}")
    return float(v)


def _is(v: Any, number: int) -> bool:
    """True for the JSON number `number` (JSON true is not 1 here)."""
    return not isinstance(v, bool) and isinstance(v, (int, float)) and v == number


def _whole(v: Any, where: str, lo: int, hi: int, what: str) -> int:
    """A JSON whole number in lo..hi (QGC's Qt JSON may write 16 or 16.0; both are the same command)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not float(v).is_integer() or not lo <= v <= hi:
        raise InputError(f"{where} = {v!r} is not allowed: {what} (a whole number {lo}-{hi})")
    return int(v)


def _get(d: dict[str, Any], key: str, where: str) -> Any:
    """A required key, or an error naming it."""
    if key not in d:
        raise InputError(f"{where}: field '{key}' is missing")
    return d[key]


def _object(v: Any, where: str) -> dict[str, Any]:
    """`v` if it is a JSON object, else an error naming where it was expected."""
    if not isinstance(v, dict):
        raise InputError(f"{where} = {type(v).__name__} is not allowed: a JSON object")
    return v


def _list(v: Any, where: str) -> list[Any]:
    """`v` if it is a JSON array, else an error naming where it was expected."""
    if not isinstance(v, list):
        raise InputError(f"{where} = {type(v).__name__} is not allowed: a JSON array")
    return v


def _read_items(d: Any, i: int, source: str) -> list[tuple[MissionItem, int | None]]:
    """The items one entry of `items` stands for: a SimpleItem, or the stored `Items` of a
    Survey or Corridor Scan item (what QGroundControl uploads for it while it is not edited)."""
    where = f"{source}: mission item {i}"
    d = _object(d, where)
    kind = _get(d, "type", where)
    if kind == "ComplexItem" and d.get("complexItemType") in _TRANSECT_ITEMS and "TransectStyleComplexItem" in d:
        inner = _object(d["TransectStyleComplexItem"], f"{where} field 'TransectStyleComplexItem'")
        stored = _list(_get(inner, "Items", f"{where} field 'TransectStyleComplexItem'"),
                       f"{where} field 'TransectStyleComplexItem' field 'Items'")
        return [_read_item(e, f"{where} ({d['complexItemType']}) item {k}") for k, e in enumerate(stored, start=1)]
    if kind == "ComplexItem" and d.get("complexItemType") == STRUCTURE_SCAN_ITEM:
        return [(it, None) for it in _structure_scan_items(d, f"{where} ({STRUCTURE_SCAN_ITEM})")]
    if kind == "ComplexItem":
        raise InputError(
            f"{where} is a ComplexItem ({d.get('complexItemType', 'unknown kind')!r}) without stored items; aerosurvey "
            "reads SimpleItems, the stored Items of Survey and Corridor Scan items and what Structure Scan items generate. "
            "Convert it to simple items in QGroundControl first: upload the plan to the vehicle (or SITL), "
            "download it again and save; QGroundControl then writes every waypoint as a SimpleItem")
    return [_read_item(d, where)]


def _structure_scan_items(d: dict[str, Any], where: str) -> list[MissionItem]:
    """What QGroundControl uploads for a Structure Scan item (StructureScanComplexItem::
    appendMissionItems; the polygon offset as QGCMapPolygon::offset does on 5.1's plane): an
    entrance waypoint at the flight polygon's vertex 0, the camera turned 90° right of the next
    waypoint at the gimbal pitch, each layer round the vertices from 0 to 0 again with the
    distance trigger on after the first and off after the last, the camera freed, the exit."""
    from aerosurvey.mission.formats.qgc_survey import QGC_FRAMES, offset_polygon, tangent_plane

    version = _get(d, "version", where)
    if not _is(version, STRUCTURE_SCAN_VERSION):
        raise InputError(f"{where} field 'version' = {version!r} is not allowed: {STRUCTURE_SCAN_VERSION}")
    poly = _list(_get(d, "polygon", where), f"{where} field 'polygon'")
    if len(poly) < 3:
        raise InputError(f"{where} field 'polygon' has {len(poly)} vertices; a structure polygon needs at least 3")
    lat_lon = np.array([[_number(v, f"{where} field 'polygon' vertex {k} {name}") for name, v in zip(_LAT_LON, p)]
                        if isinstance(p, list) and len(p) == 2 else [math.nan, math.nan] for k, p in enumerate(poly, 1)])
    if not np.isfinite(lat_lon).all():
        raise InputError(f"{where} field 'polygon' holds a vertex that is not [latitude, longitude]")
    cam = _object(_get(d, "CameraCalc", where), f"{where} field 'CameraCalc'")
    side, frontal, distance = (_number(_get(cam, k, f"{where} field 'CameraCalc'"), f"{where} field 'CameraCalc' field {k!r}")
                               for k in ("AdjustedFootprintSide", "AdjustedFootprintFrontal", "DistanceToSurface"))
    bottom, height, entrance, pitch = (_number(_get(d, k, where), f"{where} field {k!r}")
                                       for k in ("ScanBottomAlt", "StructureHeight", "EntranceAltitude", "GimbalPitch"))
    from_top = _get(d, "StartFromTop", where)
    if not isinstance(from_top, bool):
        raise InputError(f"{where} field 'StartFromTop' = {from_top!r} is not allowed: true or false")
    if not frontal > 0:
        raise InputError(f"{where} field 'CameraCalc' field 'AdjustedFootprintFrontal' = {frontal!r} is not allowed: "
                         "a layer height above 0 m")
    layers = max(math.ceil(max(height - bottom, 0.0) / frontal), 1)  # _recalcLayerInfo
    written = _get(d, "Layers", where)
    if not _is(written, layers):
        raise InputError(f"{where} field 'Layers' = {written!r} is not allowed: QGroundControl recounts it as "
                         f"{layers} from StructureHeight, ScanBottomAlt and AdjustedFootprintFrontal")
    tr = tangent_plane(float(lat_lon[0, 0]), float(lat_lon[0, 1]), QGC_FRAMES["survey"])
    en = np.column_stack(tr.transform(lat_lon[:, 1], lat_lon[:, 0]))
    flight = offset_polygon(en, distance)
    lon, lat = tr.transform(flight[:, 0], flight[:, 1], direction="INVERSE")
    ring = [(float(a), float(b)) for a, b in zip(lat, lon)]
    wp, rel = mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT
    out = [MissionItem(wp, rel, 0.0, 0.0, 0.0, math.nan, *ring[0], entrance),
           MissionItem(mav.DO_SET_ROI_WPNEXT_OFFSET, mav.FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, pitch, 0.0, 90.0)]
    for k in range(layers):
        z = height - frontal * (k + 0.5) if from_top else bottom + frontal * (k + 0.5)
        for j, (a, b) in enumerate([*ring, ring[0]]):
            out.append(MissionItem(wp, rel, 0.0, 0.0, 0.0, math.nan, a, b, z))
            if j == 0:
                out.append(MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, side, 0.0, 1.0))
        out.append(MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0.0, 0.0, 0.0))
    out += [MissionItem(mav.DO_SET_ROI_NONE, mav.FRAME_MISSION), MissionItem(wp, rel, 0.0, 0.0, 0.0, math.nan, *ring[0], entrance)]
    return out


def _read_item(d: Any, where: str) -> tuple[MissionItem, int | None]:
    """One SimpleItem and its doJumpId (None when the file has none)."""
    d = _object(d, where)
    kind = _get(d, "type", where)
    if kind != "SimpleItem":
        raise InputError(f"{where} field 'type' = {kind!r} is not allowed: 'SimpleItem'")
    command = _whole(_get(d, "command", where), f"{where} field 'command'", 0, 65535, "a MAV_CMD number")
    frame = _whole(_get(d, "frame", where), f"{where} field 'frame'", 0, 255, "a MAV_FRAME number")
    params = _list(_get(d, "params", where), f"{where} field 'params'")
    if len(params) != 7:
        raise InputError(f"{where} field 'params' has {len(params)} values; QGroundControl items have 7 (param1-4, x, y, z)")
    vals = [_number(v, f"{where} field 'params' {name}", nullable=True) for name, v in zip(_PARAM_NAMES, params)]
    auto = _get(d, "autoContinue", where)
    if not isinstance(auto, bool):
        raise InputError(f"{where} field 'autoContinue' = {auto!r} is not allowed: true or false")
    jump_id = None
    if "doJumpId" in d:
        jump_id = _whole(d["doJumpId"], f"{where} field 'doJumpId'", 0, 2**31 - 1, "the item's jump id")
    tag = d.get(TAG_KEY, "")
    if not isinstance(tag, str):
        raise InputError(f"{where} field '{TAG_KEY}' = {tag!r} is not allowed: a string")
    it = MissionItem(command, frame, vals[0], vals[1], vals[2], vals[3], vals[4], vals[5], vals[6], autocontinue=auto, tag=tag)
    if it.has_position:
        for name, v in zip(_PARAM_NAMES[4:], vals[4:]):
            if math.isnan(v):
                raise InputError(
                    f"{where} field 'params' {name} is null: a position item needs a position (QGroundControl leaves "
                    "the altitude empty for AltitudeMode 3 until terrain heights are downloaded; open the plan with "
                    "terrain data available and save it again)")
    return it, jump_id


def _resolve_jumps(items: list[MissionItem], jump_ids: list[int | None], source: str) -> list[MissionItem]:
    """DO_JUMP targets as sequence numbers: a plan names them by doJumpId, as QGroundControl resolves them on load."""
    seq_of = {jid: seq for seq, jid in enumerate(jump_ids, start=1) if jid is not None}
    out = []
    for seq, it in enumerate(items, start=1):
        if it.command == _DO_JUMP:
            target = it.param1
            if not math.isfinite(target) or not target.is_integer() or int(target) not in seq_of:
                raise InputError(f"{source}: mission item {seq} is a DO_JUMP to doJumpId {target!r}, which no item has")
            it = MissionItem(it.command, it.frame, float(seq_of[int(target)]), it.param2, it.param3, it.param4,
                             it.x, it.y, it.z, it.autocontinue, it.tag)
        out.append(it)
    return out


def _read_fence(doc: dict[str, Any], source: str) -> tuple[list[Polygon], list[Polygon]]:
    """Inclusion and exclusion polygons; circles are refused rather than dropped, so no fence is lost unnoticed."""
    inc: list[Polygon] = []
    exc: list[Polygon] = []
    if "geoFence" not in doc:
        return inc, exc
    fence = _object(doc["geoFence"], f"{source}: geoFence")
    circles = _list(fence.get("circles", []), f"{source}: geoFence field 'circles'")
    if circles:
        raise InputError(f"{source}: geoFence has {len(circles)} circular fence(s); aerosurvey uploads polygon fences "
                         "only: draw the circle as a polygon in QGroundControl or remove it")
    for k, poly in enumerate(_list(fence.get("polygons", []), f"{source}: geoFence field 'polygons'"), start=1):
        where = f"{source}: geoFence polygon {k}"
        poly = _object(poly, where)
        if "version" in poly and not _is(poly["version"], FENCE_POLYGON_VERSION):
            raise InputError(f"{where} field 'version' = {poly['version']!r} is not allowed: {FENCE_POLYGON_VERSION}")
        inclusion = _get(poly, "inclusion", where)
        if not isinstance(inclusion, bool):
            raise InputError(f"{where} field 'inclusion' = {inclusion!r} is not allowed: true or false")
        pts = []
        for j, p in enumerate(_list(_get(poly, "polygon", where), f"{where} field 'polygon'"), start=1):
            if not isinstance(p, list) or len(p) != 2:
                raise InputError(f"{where} vertex {j} = {p!r} is not allowed: [latitude, longitude]")
            pts.append((_number(p[0], f"{where} vertex {j} latitude"), _number(p[1], f"{where} vertex {j} longitude")))
        if len(pts) < 3:
            raise InputError(f"{where} has {len(pts)} vertices; a fence polygon needs at least 3")
        (inc if inclusion else exc).append(tuple(pts))
    return inc, exc


def loads_plan(text: str, source: str = "<string>") -> Mission:
    """A Mission from QGroundControl plan text; errors name `source`, the item and the field."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{source}: not a QGroundControl plan (invalid JSON: {exc})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{source}: not a QGroundControl plan (the JSON is a {type(doc).__name__}, not an object)")
    if doc.get("fileType") != "Plan":
        raise InputError(f"{source}: not a QGroundControl plan (fileType = {doc.get('fileType')!r}, expected 'Plan')")
    version = _get(doc, "version", source)
    if not _is(version, PLAN_FILE_VERSION):
        raise InputError(f"{source}: field 'version' = {version!r} is not allowed: {PLAN_FILE_VERSION} "
                         "(the QGroundControl plan file version)")
    mis = _object(_get(doc, "mission", source), f"{source}: mission")
    where = f"{source}: mission"
    if "version" in mis and not _is(mis["version"], MISSION_VERSION):
        raise InputError(f"{where} field 'version' = {mis['version']!r} is not allowed: {MISSION_VERSION}")
    firmware_type = _get(mis, "firmwareType", where)
    firmware = None
    if isinstance(firmware_type, (int, float)) and not isinstance(firmware_type, bool) and float(firmware_type).is_integer():
        firmware = {v: k for k, v in _FIRMWARE.items()}.get(int(firmware_type))
    if firmware is None:
        raise InputError(f"{where} field 'firmwareType' = {firmware_type!r} is not allowed: "
                         f"{mav.AUTOPILOT_ARDUPILOTMEGA} (ArduPilot) or {mav.AUTOPILOT_PX4} (PX4)")
    vehicle = "copter"
    if "vehicleType" in mis:
        vt = _whole(mis["vehicleType"], f"{where} field 'vehicleType'", 0, 255, "a MAV_TYPE number")
        if vt in _COPTER_TYPES:
            vehicle = "copter"
        elif vt in _PLANE_TYPES:
            vehicle = "plane"
        else:
            raise InputError(f"{where} field 'vehicleType' = {vt} is not allowed: a multirotor or helicopter "
                             "(2, 3, 4, 13, 14, 15), a fixed wing (1) or a VTOL (19-25)")
    home = _list(_get(mis, "plannedHomePosition", where), f"{where} field 'plannedHomePosition'")
    if len(home) != 3:
        raise InputError(f"{where} field 'plannedHomePosition' = {home!r} is not allowed: [latitude, longitude, altitude AMSL]")
    h_lat, h_lon, h_alt = (_number(v, f"{where} field 'plannedHomePosition' {name}") for name, v in zip(_HOME_NAMES, home))
    speeds = {key: _number(mis[key], f"{where} field '{key}'") if key in mis else 0.0 for key in ("cruiseSpeed", "hoverSpeed")}
    read = [r for i, d in enumerate(_list(_get(mis, "items", where), f"{where} field 'items'"), start=1)
            for r in _read_items(d, i, source)]
    items = _resolve_jumps([it for it, _ in read], [jid for _, jid in read], source)
    rally = _read_rally(doc, source)
    inc, excl = _read_fence(doc, source)
    name = doc.get(NAME_KEY, "mission")
    if not isinstance(name, str):
        raise InputError(f"{source}: field '{NAME_KEY}' = {name!r} is not allowed: a string")
    return Mission(
        vehicle=vehicle, firmware=firmware, home=(h_lat, h_lon, h_alt), items=tuple(items),
        cruise_speed=speeds["cruiseSpeed"], hover_speed=speeds["hoverSpeed"], name=name,
        fence_inclusion=tuple(inc), fence_exclusion=tuple(excl), rally=rally,
    )


def _read_rally(doc: dict[str, Any], source: str) -> tuple[tuple[float, float, float], ...]:
    """Rally points as QGroundControl reads them: version 2, each [latitude, longitude, altitude]."""
    if "rallyPoints" not in doc:
        return ()
    where = f"{source}: rallyPoints"
    rally = _object(doc["rallyPoints"], where)
    points = _list(rally.get("points", []), f"{where} field 'points'")
    if points and not _is(rally.get("version"), RALLY_VERSION):
        raise InputError(f"{where} field 'version' = {rally.get('version')!r} is not allowed: {RALLY_VERSION}")
    out = []
    for k, p in enumerate(points, start=1):
        if not isinstance(p, list) or len(p) != 3:
            raise InputError(f"{where} point {k} = {p!r} is not allowed: [latitude, longitude, altitude]")
        lat, lon, alt = (_number(v, f"{where} point {k} {name}") for name, v in zip(_HOME_NAMES, p))
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise InputError(f"{where} point {k} = {p!r} is not allowed: latitude -90..90, longitude -180..180")
        out.append((lat, lon, alt))
    return tuple(out)
