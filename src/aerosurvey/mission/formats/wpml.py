"""DJI WPML waylines: a flight program as a .kmz that DJI Pilot 2 imports (M3E, M30, M350 RTK with P1).

The layout follows DJI's published WPML reference (DJI Cloud API documentation, "DJI WPML":
overview, template.kml, waylines.wpml, common elements; namespace wpmz/1.0.2 as in its
samples): a ZIP archive holding `wpmz/template.kml` (the editable template) and
`wpmz/waylines.wpml` (what the aircraft executes), both KML 2.2 documents with a
`wpml:missionConfig` and one `Folder`. waylines.wpml's Folder holds the program's waypoints as
`Placemark`s; template.kml's holds a mapping2d or mappingStrip template where one expresses the
flight (mission/formats/dji_template.py chooses, and says why not), else the same waypoints as
a waypoint template.

What is written:

- missionConfig: flyToWaylineMode "safely" (climb at the launch point, then fly level to the
  first waypoint), finishAction "goHome", exitOnRCLost "goContinue" (the route and the way
  home were checked against the zones; a straight return from where the link is lost was
  not), takeOffSecurityHeight the take-off altitude, globalTransitionalSpeed the cruise speed,
  globalRTHHeight the highest waypoint, droneInfo and payloadInfo of the aircraft.
- heights: heightMode / executeHeightMode "relativeToStartPoint", the program's altitudes
  above the launch point. A program in the terrain frame has no DJI counterpart for waypoint
  routes (aboveGroundLevel is FlightHub 2's, realTimeFollowSurface the M3E's mapping
  templates'): `refusal` says so and no .kmz is written.
- heading: waypointHeadingMode "followWayline", or "smoothTransition" at one angle for a fixed yaw,
  or, on the waypoints of a run whose camera is turned from the nose (a facade's lanes: a DJI
  gimbal yaws only a few degrees from the nose), at the bearing the camera looks to;
  "towardPOI" (waypointPoiPoint: latitude, longitude, height) on the waypoints of a run whose
  camera looks at a point, each with a gimbalRotate to the pitch towards it from there.
- every waypoint "toPointAndStopWithDiscontinuityCurvature": straight legs, the ones the
  final gate checked, and a stop at each waypoint.
- actions (wpml:actionGroup, ids from 0 across the file): the program's gimbal settings (at
  the first run of the flight, −90° straight down for a nadir plan, and wherever the aim
  changes) as gimbalRotate (pitch, and the yaw as a compass bearing when it is not along the nose); a
  distance or time trigger as takePhoto in a group from the run's first station to its line
  end with actionTrigger multipleDistance or multipleTiming; hover-and-shoot as a reachPoint
  group of hover (hoverTime, when above 0) and takePhoto; a place shot at several aims (a
  smart oblique: the program's hover waypoints one after another at one place) is one
  waypoint with one group, each shot's hover and takePhoto and the gimbalRotate to the next
  aim between them. takePhoto's fileSuffix is the
  station id (hover) or the run id, so photos name where they were taken.

The budget (mission/targets.py): at most 65535 waypoints and 65536 action groups per
wayline, at least 2 waypoints, speeds up to 15 m/s; a program beyond it is refused with its numbers.
"""

from __future__ import annotations

import io
import zipfile

from lxml import etree

from aerosurvey.mission.formats.dji_template import MappingTemplate
from aerosurvey.mission.formats.wpl import format_number
from aerosurvey.mission.program import CameraStart, CameraStop, FlightProgram, Gimbal, HoverShoot, Roi, Waypoint
from aerosurvey.mission.targets import (
    DJI_MAX_ACTION_GROUPS,
    DJI_MAX_SPEED_MS,
    DJI_MAX_WAYPOINTS,
    DJI_MIN_WAYPOINTS,
    DjiAircraft,
)

KML_NS = "http://www.opengis.net/kml/2.2"
WPML_NS = "http://www.dji.com/wpmz/1.0.2"
NSMAP = {None: KML_NS, "wpml": WPML_NS}
TEMPLATE = "wpmz/template.kml"
WAYLINES = "wpmz/waylines.wpml"
#: the payload's mount: position 1 (the main gimbal; an M350's front left)
PAYLOAD_POSITION = 0


def _groups(p: FlightProgram) -> int:
    """Action groups the waylines hold: one per gimbal, hover shot and camera start."""
    return sum(isinstance(a, (Gimbal, HoverShoot, CameraStart)) for w in p.waypoints for a in w.actions)


def refusal(p: FlightProgram) -> str | None:
    """Why `p` cannot be written as DJI waylines (with the numbers), or None."""
    n = len(p.waypoints)
    if p.vehicle != "copter":
        return f"vehicle.type = {p.vehicle!r}: the DJI aircraft that fly WPML waylines are copters"
    if p.altitude_frame != "relative":
        return ("terrain.mode = 'terrain-frame' has no DJI waypoint-route height mode (waylines take heights relative to "
                "the take-off point or ellipsoid heights); use terrain.mode = 'follow'")
    if n > DJI_MAX_WAYPOINTS:
        return f"{n} waypoints, more than the {DJI_MAX_WAYPOINTS} a DJI wayline holds; fly the sortie files"
    if n < DJI_MIN_WAYPOINTS:
        return f"{n} waypoint(s); a DJI wayline needs at least {DJI_MIN_WAYPOINTS}"
    groups = _groups(p)
    if groups > DJI_MAX_ACTION_GROUPS:
        return f"{groups} action groups, more than the {DJI_MAX_ACTION_GROUPS} a DJI wayline numbers; fly the sortie files"
    if p.speed_ms > DJI_MAX_SPEED_MS:
        return f"the survey speed {p.speed_ms:.2f} m/s is above the {DJI_MAX_SPEED_MS:g} m/s of DJI waylines"
    return None


def _num(v: float) -> str:
    return format_number(round(float(v), 8))


def _w(parent: etree._Element, tag: str, text: str | float | int | None = None) -> etree._Element:
    el = etree.SubElement(parent, f"{{{WPML_NS}}}{tag}")
    if text is not None:
        el.text = text if isinstance(text, str) else _num(text)
    return el


def _wrap180(deg: float) -> float:
    return (deg + 180.0) % 360.0 - 180.0


def _mission_config(doc: etree._Element, p: FlightProgram, a: DjiAircraft) -> None:
    c = _w(doc, "missionConfig")
    _w(c, "flyToWaylineMode", "safely")
    _w(c, "finishAction", "goHome")
    _w(c, "exitOnRCLost", "goContinue")
    _w(c, "executeRCLostAction", "hover")
    _w(c, "takeOffSecurityHeight", min(max(p.takeoff_alt_m, 1.2), 1500.0))
    _w(c, "globalTransitionalSpeed", min(p.cruise_speed_ms, DJI_MAX_SPEED_MS))
    _w(c, "globalRTHHeight", max(w.alt_m for w in p.waypoints))
    drone = _w(c, "droneInfo")
    _w(drone, "droneEnumValue", a.drone_enum)
    _w(drone, "droneSubEnumValue", a.drone_sub_enum)
    payload = _w(c, "payloadInfo")
    _w(payload, "payloadEnumValue", a.payload_enum)
    _w(payload, "payloadPositionIndex", PAYLOAD_POSITION)


def _heading(parent: etree._Element, p: FlightProgram, tag: str, roi: Roi | None = None, look: float | None = None) -> None:
    h = _w(parent, tag)
    if roi is not None:
        _w(h, "waypointHeadingMode", "towardPOI")
        _w(h, "waypointPoiPoint", f"{_num(roi.lat)},{_num(roi.lon)},{_num(roi.alt_m)}")
    elif (angle := look if look is not None else p.fixed_yaw_deg) is not None:
        _w(h, "waypointHeadingMode", "smoothTransition")
        _w(h, "waypointHeadingAngle", _wrap180(angle))
    else:
        _w(h, "waypointHeadingMode", "followWayline")
    _w(h, "waypointHeadingPathMode", "followBadArc")


def _group(pm: etree._Element, gid: int, start: int, end: int, trigger: str, param: float | None = None) -> etree._Element:
    g = _w(pm, "actionGroup")
    _w(g, "actionGroupId", gid)
    _w(g, "actionGroupStartIndex", start)
    _w(g, "actionGroupEndIndex", end)
    _w(g, "actionGroupMode", "sequence")
    t = _w(g, "actionTrigger")
    _w(t, "actionTriggerType", trigger)
    if param is not None:
        _w(t, "actionTriggerParam", param)
    return g


def _action(g: etree._Element, func: str) -> etree._Element:
    k = len(g.findall(f"{{{WPML_NS}}}action"))
    act = _w(g, "action")
    _w(act, "actionId", k)
    _w(act, "actionActuatorFunc", func)
    return _w(act, "actionActuatorFuncParam")


def _gimbal_rotate(g: etree._Element, pitch: float, bearing: float | None) -> None:
    prm = _action(g, "gimbalRotate")
    _w(prm, "gimbalHeadingYawBase", "north")
    _w(prm, "gimbalRotateMode", "absoluteAngle")
    _w(prm, "gimbalPitchRotateEnable", 1)
    _w(prm, "gimbalPitchRotateAngle", pitch)
    _w(prm, "gimbalRollRotateEnable", 0)
    _w(prm, "gimbalRollRotateAngle", 0)
    _w(prm, "gimbalYawRotateEnable", 0 if bearing is None else 1)
    _w(prm, "gimbalYawRotateAngle", 0 if bearing is None else _wrap180(bearing))
    _w(prm, "gimbalRotateTimeEnable", 0)
    _w(prm, "gimbalRotateTime", 0)
    _w(prm, "payloadPositionIndex", PAYLOAD_POSITION)


def _take_photo(g: etree._Element, suffix: str) -> None:
    prm = _action(g, "takePhoto")
    _w(prm, "fileSuffix", suffix)
    _w(prm, "payloadPositionIndex", PAYLOAD_POSITION)
    _w(prm, "useGlobalPayloadLensIndex", 1)


def _hover_shoot(g: etree._Element, a: HoverShoot, suffix: str) -> None:
    if a.hold_s > 0:
        _w(_action(g, "hover"), "hoverTime", a.hold_s)
    _take_photo(g, suffix)


def _actions(pm: etree._Element, p: FlightProgram, i: int, k: int, ends: dict[int, int], gid: int) -> int:
    """The action groups of waypoint `i` into placemark `pm` (index `k`); returns the next group id."""
    w = p.waypoints[i]
    for a in w.actions:
        if isinstance(a, Gimbal):
            _gimbal_rotate(_group(pm, gid, k, k, "reachPoint"), a.pitch_deg, a.bearing_deg if a.yaw_deg != 0 else None)
        elif isinstance(a, Roi):  # the aircraft heads to the point (towardPOI), the gimbal pitches to it
            _gimbal_rotate(_group(pm, gid, k, k, "reachPoint"), a.pitch_deg, None)
        elif isinstance(a, HoverShoot):
            _hover_shoot(_group(pm, gid, k, k, "reachPoint"), a, w.tag)
        elif isinstance(a, CameraStart):
            trigger, param = ("multipleDistance", a.distance_m) if a.distance_m is not None else ("multipleTiming", a.interval_s)
            _take_photo(_group(pm, gid, k, ends[k], trigger, param), w.run_id)
        else:
            continue  # a camera stop is the end index of its start's group
        gid += 1
    return gid


def _capture_ends(p: FlightProgram) -> dict[int, int]:
    """Waypoint index of each camera start → the index of the stop after it (the last waypoint if none)."""
    ends: dict[int, int] = {}
    open_at: int | None = None
    for i, w in enumerate(p.waypoints):
        for a in w.actions:
            if isinstance(a, CameraStart):
                open_at = i
            elif isinstance(a, CameraStop) and open_at is not None:
                ends[open_at] = i
                open_at = None
    if open_at is not None:
        ends[open_at] = len(p.waypoints) - 1
    return ends


def _kml_coordinates(parent: etree._Element, points: tuple[tuple[float, float], ...]) -> None:
    """`lon,lat,0 lon,lat,0 …`: the reference reads the heights only with wpml:facadeWaylineEnable
    or wpml:stripUseTemplateAltitude, both 0 here."""
    etree.SubElement(parent, f"{{{KML_NS}}}coordinates").text = " ".join(f"{_num(x)},{_num(y)},0" for x, y in points)


def _mapping_folder(folder: etree._Element, p: FlightProgram, a: DjiAircraft, m: MappingTemplate) -> None:
    """A mapping2d or mappingStrip template (template.kml, "Template common elements", "Mapping Aerial
    Template Element", "Waypoint Segment Flight Template Element")."""
    _w(folder, "templateType", m.kind)
    _w(folder, "templateId", 0)
    sys = _w(folder, "waylineCoordinateSysParam")
    _w(sys, "coordinateMode", "WGS84")
    _w(sys, "heightMode", "relativeToStartPoint")
    _w(sys, "globalShootHeight", m.shoot_height_m)
    _w(sys, "surfaceFollowModeEnable", 0)
    _w(folder, "autoFlightSpeed", p.speed_ms)
    payload = _w(folder, "payloadParam")
    _w(payload, "payloadPositionIndex", PAYLOAD_POSITION)
    _w(payload, "imageFormat", a.image_format)
    pm = etree.SubElement(folder, f"{{{KML_NS}}}Placemark")
    strip = m.kind == "mappingStrip"
    _w(pm, "caliFlightEnable", 0)
    if not strip:
        _w(pm, "elevationOptimizeEnable", 0)  # no extra oblique photos at the end: waylines.wpml has none
    _w(pm, "shootType", m.shoot_type)
    _w(pm, "direction", m.direction_deg)
    _w(pm, "margin", m.margin_m)
    if strip:
        _w(pm, "singleLineEnable", int(m.single_line))
        _w(pm, "cuttingDistance", m.length_m)
        _w(pm, "boundaryOptimEnable", 0)
        _w(pm, "leftExtend", m.extend_m)
        _w(pm, "rightExtend", m.extend_m)
        _w(pm, "includeCenterEnable", int(m.include_centre))
    overlap = _w(pm, "overlap")
    _w(overlap, "orthoCameraOverlapH", m.overlap_h)
    _w(overlap, "orthoCameraOverlapW", m.overlap_w)
    # relative to the take-off point: the reference has the ellipsoid height equal to it then
    _w(pm, "ellipsoidHeight", m.height_m)
    _w(pm, "height", m.height_m)
    if strip:
        _w(pm, "stripUseTemplateAltitude", 0)
        _kml_coordinates(etree.SubElement(pm, f"{{{KML_NS}}}LineString"), m.coordinates)
    else:
        poly = etree.SubElement(pm, f"{{{KML_NS}}}Polygon")
        ring = etree.SubElement(etree.SubElement(poly, f"{{{KML_NS}}}outerBoundaryIs"), f"{{{KML_NS}}}LinearRing")
        _kml_coordinates(ring, m.coordinates)


def _document(p: FlightProgram, a: DjiAircraft, name: str, mapping: MappingTemplate | None = None,
              why: str = "") -> etree._Element:
    """`name` TEMPLATE (template.kml: `mapping`, or the waypoint template with `why` in a comment)
    or WAYLINES (waylines.wpml, what the aircraft flies)."""
    is_template = name == TEMPLATE
    root = etree.Element(f"{{{KML_NS}}}kml", nsmap=NSMAP)
    doc = etree.SubElement(root, f"{{{KML_NS}}}Document")
    if is_template:
        _w(doc, "author", "aerosurvey")
    _mission_config(doc, p, a)
    folder = etree.SubElement(doc, f"{{{KML_NS}}}Folder")
    if mapping is not None:
        _mapping_folder(folder, p, a, mapping)
        return root
    if why:  # why the waypoint template (a comment holds no "--")
        folder.append(etree.Comment(f" waypoint template: {why.replace('--', '- -')} "))
    if is_template:
        _w(folder, "templateType", "waypoint")
    _w(folder, "templateId", 0)
    if is_template:
        sys = _w(folder, "waylineCoordinateSysParam")
        _w(sys, "coordinateMode", "WGS84")
        _w(sys, "heightMode", "relativeToStartPoint")
        _w(folder, "autoFlightSpeed", p.speed_ms)
        _w(folder, "globalWaypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
        _w(folder, "gimbalPitchMode", "manual")
        _w(folder, "globalHeight", p.takeoff_alt_m)
        _heading(folder, p, "globalWaypointHeadingParam")
        payload = _w(folder, "payloadParam")
        _w(payload, "payloadPositionIndex", PAYLOAD_POSITION)
        _w(payload, "imageFormat", a.image_format)
    else:
        _w(folder, "executeHeightMode", "relativeToStartPoint")
        _w(folder, "waylineId", 0)
        _w(folder, "autoFlightSpeed", p.speed_ms)
    places = _places(p)
    at = {i: k for k, rows in enumerate(places) for i in rows}
    ends = {at[i]: at[j] for i, j in _capture_ends(p).items()}
    gid = 0
    turned: float | None = None  # the bearing the camera looks at, where it is not along the nose
    for k, rows in enumerate(places):
        i = rows[0]
        w = p.waypoints[i]
        for act in w.actions:
            if isinstance(act, Gimbal) and len(rows) == 1:
                turned = act.bearing_deg if act.yaw_deg != 0 else None
        # a DJI gimbal turns only a few degrees from the nose: on a run whose camera looks
        # elsewhere the aircraft faces where it looks (a place shot at several aims: the
        # aircraft follows the wayline, each gimbalRotate gives its compass bearing)
        look = turned if w.run >= 0 and len(rows) == 1 else None
        pm = etree.SubElement(folder, f"{{{KML_NS}}}Placemark")
        pt = etree.SubElement(pm, f"{{{KML_NS}}}Point")
        etree.SubElement(pt, f"{{{KML_NS}}}coordinates").text = f"{_num(w.lon)},{_num(w.lat)}"
        _w(pm, "index", k)
        roi = next((a for a in w.actions if isinstance(a, Roi)), None)
        if is_template:
            _w(pm, "useGlobalHeight", 0)
            # heights relative to the take-off point; the reference pairs an ellipsoid height
            # with every height, which a relative plan does not know: the same value is written
            _w(pm, "ellipsoidHeight", w.alt_m)
            _w(pm, "height", w.alt_m)
            _w(pm, "useGlobalSpeed", 1)
            _w(pm, "useGlobalHeadingParam", int(roi is None and look is None))
            if roi is not None or look is not None:
                _heading(pm, p, "waypointHeadingParam", roi, look)
            _w(pm, "useGlobalTurnParam", 1)
        else:
            _w(pm, "executeHeight", w.alt_m)
            _w(pm, "waypointSpeed", p.speed_ms)
            _heading(pm, p, "waypointHeadingParam", roi, look)
            turn = _w(pm, "waypointTurnParam")
            _w(turn, "waypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
            _w(turn, "waypointTurnDampingDist", 0)
        gid = _actions(pm, p, i, k, ends, gid) if len(rows) == 1 else _shots(pm, p, rows, k, gid)
    return root


def _places(p: FlightProgram) -> list[list[int]]:
    """The program's waypoints by place: one placemark for each, the waypoints of a place shot at
    several aims (hover-and-shoot waypoints one after another at the same place and altitude, the
    gimbal turned between them) together."""
    out: list[list[int]] = []
    for i, w in enumerate(p.waypoints):
        if out and _shoots(w) and _shoots(prev := p.waypoints[out[-1][-1]]) and (w.lat, w.lon, w.alt_m) == (prev.lat, prev.lon, prev.alt_m):
            out[-1].append(i)
        else:
            out.append([i])
    return out


def _shoots(w: Waypoint) -> bool:
    return any(isinstance(a, HoverShoot) for a in w.actions)


def _shots(pm: etree._Element, p: FlightProgram, rows: list[int], k: int, gid: int) -> int:
    """The one action group of placemark `k`, a place shot at several aims (program waypoints `rows`):
    in the program's order each shot's hover and takePhoto, and the gimbalRotate to the next aim
    between them (its yaw a compass bearing); returns the next group id."""
    g = _group(pm, gid, k, k, "reachPoint")
    for i in rows:
        w = p.waypoints[i]
        for a in w.actions:
            if isinstance(a, Gimbal):
                _gimbal_rotate(g, a.pitch_deg, a.bearing_deg)
            elif isinstance(a, HoverShoot):
                _hover_shoot(g, a, w.tag)
    return gid + 1


def _xml(root: etree._Element) -> bytes:
    return bytes(etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True))


def kmz_bytes(p: FlightProgram, aircraft: DjiAircraft, template: MappingTemplate | str = "") -> bytes:
    """The .kmz (a ZIP archive) of `p` for `aircraft`; equal programs give equal bytes. `template`:
    the mapping template of template.kml (dji_template.template_choice), or why it is the waypoint
    template; waylines.wpml is the program's waypoints either way. The caller checks `refusal(p)` first."""
    mapping = template if isinstance(template, MappingTemplate) else None
    why = template if isinstance(template, str) else ""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, doc in ((TEMPLATE, _document(p, aircraft, TEMPLATE, mapping, why)), (WAYLINES, _document(p, aircraft, WAYLINES))):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, _xml(doc))
    return buf.getvalue()
