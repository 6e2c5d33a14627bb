"""The camera's aim and height per station, through every writer.

A scratch pattern written here (registered only for these tests) flies three passes: a ring
round the area's centre with the camera on that centre (a look at a point), the same ring
higher with the camera turned 90° right of the flight, and a nadir line across. It is planned
end to end through the command line and judged from the files written, by formulas written
here (pyproj's geodesic azimuths and distances, not the planner's Planar or altitudes):

- each station's look (the manifest's grid bearing plus the convergence at home) is the true
  azimuth to the point, or the flight's direction turned 90°, within 0.05°;
- the pitch of each station looking at the point is the angle down to the region of interest
  the .waypoints gives (DO_SET_ROI_LOCATION), within 0.05°; the first station's is the aim's;
- every pass sets the aim it needs before its first photo (the nadir pass too, after the ROI);
  the ROI is released (DO_SET_ROI_NONE) after its run's camera stop;
- DJI: every waypoint of the ring heads towards the point (towardPOI) with the gimbal pitched
  to it; the raised pass flies `rise_m` higher;
- the height cap is checked per station: a rise over it is refused naming the station.
"""

from __future__ import annotations

import json
import math
import zipfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from lxml import etree
from pymavlink import mavutil, mavwp
from pyproj import Geod
from tests.conftest import make_spec
from tests.plan.test_pattern_seam import Diagonals

from aerosurvey.cli import main
from aerosurvey.plan import pattern as registry
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.passes import NADIR, Aim, Pass
from aerosurvey.plan.polyline import stations_along, strips_clear_of
from aerosurvey.spec import FlightSpec, MissionSpec

M = mavutil.mavlink
GEOD = Geod(ellps="WGS84")
NS = {"k": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}


@dataclass(frozen=True)
class RingOptions:
    radius_m: float
    pitch_deg: float
    rise_m: float


@dataclass(frozen=True)
class Rings:
    """Scratch pattern: a ring round the area's centre looking at it, the ring again `rise_m`
    higher looking 90° right of the flight, and a nadir line across the area."""

    options: RingOptions

    kind: ClassVar[str] = "rings"
    title: ClassVar[str] = "rings (a test's scratch pattern)"
    area_is_centreline: ClassVar[bool] = False
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = (
        Field("radius_m", "Radius (m)", "number", 90.0, lo=10.0, hi=500.0),
        Field("pitch_deg", "Pitch (°)", "number", -30.0, lo=-80.0, hi=0.0),
        Field("rise_m", "Rise (m)", "number", 20.0, lo=0.0, hi=500.0),
    )
    # what the other scratch pattern says of the ground: nadir photos, an area grid's bounds
    centreline_sides = Diagonals.centreline_sides
    stands_on = Diagonals.stands_on
    footprint = Diagonals.footprint
    bounds = Diagonals.bounds

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> RingOptions:
        return RingOptions(float(values["radius_m"]), float(values["pitch_deg"]), float(values["rise_m"]))

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Rings:
        assert isinstance(spec.pattern.options, RingOptions)
        return cls(spec.pattern.options)

    @classmethod
    def parameters(cls, plan: Any) -> dict[str, Any]:
        o = plan.pattern.options
        return {"radius_m": o.radius_m, "pitch_deg": o.pitch_deg, "rise_m": o.rise_m}

    def layouts(self, site: Any, sensor: Any, report: Any) -> Iterator[Layout]:
        k = site.grid_scale
        c = site.area.centroid
        t = np.linspace(0.0, 2.0 * np.pi, 73)  # clockwise from north, closed
        ring = np.column_stack([c.x + self.options.radius_m * k * np.sin(t), c.y + self.options.radius_m * k * np.cos(t)])
        x0, _, x1, _ = site.area.bounds
        across = np.array([[x0, c.y], [x1, c.y]])

        def own_metres(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return np.hypot(*(b - a).T) / k

        def strips(path: np.ndarray) -> tuple:
            length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
            return tuple(strips_clear_of(0, 0, 0, path, stations_along(path, own_metres, sensor.base_m, length, None, 0.1),
                                         site.zones_buffered, 0.0))

        o = self.options
        passes = (Pass(1, strips=strips(ring), aim=Aim(o.pitch_deg, point=(c.x, c.y))),
                  Pass(2, strips=strips(ring), aim=Aim(o.pitch_deg, turn_deg=90.0), rise_m=o.rise_m),
                  Pass(3, strips=strips(across), aim=NADIR))
        yield Layout(0.0, "a test's rings", passes, site.area, 0.0, check_exactly=site.area)


@pytest.fixture
def rings(monkeypatch):
    monkeypatch.setitem(registry.PATTERNS, Rings.kind, Rings)  # type: ignore[index]
    return Rings


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


def _items(path: Path) -> list:
    loader = mavwp.MAVWPLoader()
    loader.load(str(path))
    return [loader.wp(i) for i in range(1, loader.count())]


def _spec(tmp_path: Path, **pattern: float) -> Path:
    return make_spec(tmp_path, {"pattern": {"kind": "rings", **pattern},
                                "camera": {"model": "dji-mavic-3-enterprise", "trigger": "distance"}})


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setitem(registry.PATTERNS, Rings.kind, Rings)  # type: ignore[index]
    tmp = tmp_path_factory.mktemp("rings")
    out = tmp / "plan"
    code, text = _run("plan", _spec(tmp, radius_m=90.0, pitch_deg=-60.0, rise_m=20.0), "-o", out)
    mp.undo()
    assert code in (0, 1), text
    return json.loads((out / "manifest.json").read_text()), _items(out / "mission.waypoints"), out


def _pass_of(station: dict) -> int:
    return int(station["id"][1:station["id"].index("-")])


def test_each_station_looks_where_its_pass_aims(planned) -> None:
    m, items, _ = planned
    conv = m["crs"]["convergence_deg"]
    roi = [it for it in items if it.command == M.MAV_CMD_DO_SET_ROI_LOCATION]
    assert len(roi) == 1
    plat, plon, palt = roi[0].x, roi[0].y, roi[0].z
    by_pass: dict[int, list[dict]] = {}
    for s in m["stations"]:
        by_pass.setdefault(_pass_of(s), []).append(s)
    assert set(by_pass) == {1, 2, 3}
    for s in by_pass[1]:
        az, _, dist = GEOD.inv(s["lon"], s["lat"], plon, plat)
        assert abs(((s["camera_yaw_deg"] + conv) - az + 180.0) % 360.0 - 180.0) < 0.05, s
        down = math.degrees(math.atan2(palt - s["alt_rel_m"], dist))
        assert s["pitch_deg"] == pytest.approx(down, abs=0.05), s
    assert by_pass[1][0]["pitch_deg"] == pytest.approx(-60.0, abs=0.01)
    for s in by_pass[2]:
        assert ((s["camera_yaw_deg"] - s["heading_deg"] - 90.0 + 180.0) % 360.0 - 180.0) == pytest.approx(0.0, abs=1e-6)
        assert s["pitch_deg"] == -60.0
    assert all(s["pitch_deg"] == -90.0 for s in by_pass[3])
    # the raised pass flies its rise above the others
    assert {round(s["agl_m"] - by_pass[1][0]["agl_m"], 2) for s in by_pass[2]} == {20.0}
    assert {round(s["agl_m"] - by_pass[1][0]["agl_m"], 2) for s in by_pass[3]} == {0.0}
    passes = {p["pass"]: p for p in m["pattern"]["passes"]}
    assert "look_at" in passes[1] and passes[2]["turn_deg"] == 90.0 and passes[2]["rise_m"] == 20.0
    assert not {"look_at", "turn_deg", "rise_m"} & set(passes[3])


def test_every_pass_sets_its_aim_before_its_first_photo(planned) -> None:
    _, items, _ = planned
    aim: tuple | None = None  # what the mission last told the mount: ("roi", …) or ("gimbal", pitch, yaw)
    seen: list[tuple] = []
    for it in items:
        if it.command == M.MAV_CMD_DO_SET_ROI_LOCATION:
            aim = ("roi", it.x, it.y, it.z)
        elif it.command == M.MAV_CMD_DO_SET_ROI_NONE:
            aim = None
        elif it.command == M.MAV_CMD_DO_MOUNT_CONTROL:
            aim = ("gimbal", it.param1, it.param3)
        elif it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST and it.param1 > 0:
            assert aim is not None, "photos with the mount where the last flight left it"
            seen.append(aim)
        elif it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST and aim is not None and aim[0] == "roi":
            pass  # the camera stops, then the ROI is released
    assert [a[0] for a in seen] == ["roi", "gimbal", "gimbal"]
    assert seen[1][1:] == (-60.0, 90.0) and seen[2][1] == -90.0
    # the ROI is released after its run's camera stop, before the next pass's gimbal
    cmds = [it.command for it in items]
    i_none = cmds.index(M.MAV_CMD_DO_SET_ROI_NONE)
    stops = [i for i, it in enumerate(items) if it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST and it.param1 == 0]
    assert stops[0] < i_none < cmds.index(M.MAV_CMD_DO_MOUNT_CONTROL)


def test_dji_heads_to_the_point_with_the_gimbal_pitched_to_it(planned) -> None:
    m, items, out = planned
    roi = next(it for it in items if it.command == M.MAV_CMD_DO_SET_ROI_LOCATION)
    kmz = next(out.glob("*.kmz"))
    with zipfile.ZipFile(kmz) as z:
        doc = etree.fromstring(z.read("wpmz/waylines.wpml"))
    toward = 0
    for pm in doc.iterfind(".//k:Placemark", NS):
        mode = pm.findtext("wpml:waypointHeadingParam/wpml:waypointHeadingMode", namespaces=NS)
        if mode != "towardPOI":
            continue
        toward += 1
        lat, lon, alt = (float(v) for v in pm.findtext("wpml:waypointHeadingParam/wpml:waypointPoiPoint", namespaces=NS).split(","))
        assert (lat, lon, alt) == pytest.approx((roi.x, roi.y, roi.z), abs=1e-7)
        wlon, wlat = (float(v) for v in pm.findtext("k:Point/k:coordinates", namespaces=NS).split(","))
        walt = float(pm.findtext("wpml:executeHeight", namespaces=NS))
        _, _, dist = GEOD.inv(wlon, wlat, lon, lat)
        pitches = [float(a.findtext("wpml:actionActuatorFuncParam/wpml:gimbalPitchRotateAngle", namespaces=NS))
                   for a in pm.iterfind("wpml:actionGroup/wpml:action", NS)
                   if a.findtext("wpml:actionActuatorFunc", namespaces=NS) == "gimbalRotate"]
        # the last gimbal setting at the waypoint (the program's first one starts straight down, then turns)
        assert pitches[-1] == pytest.approx(math.degrees(math.atan2(alt - walt, dist)), abs=0.05)
    ring_waypoints = {w for w in (s["line"] for s in m["stations"]) if w.startswith("P1-")}
    assert ring_waypoints and toward >= 3


def test_a_station_over_the_height_cap_is_refused_naming_it(tmp_path: Path, rings) -> None:
    spec = make_spec(tmp_path, {"pattern": {"kind": "rings", "rise_m": 200.0}})
    code, text = _run("plan", spec, "-o", tmp_path / "out")
    assert code == 2
    assert "station P2-" in text and "vehicle.max_height_agl_m = 120" in text and "200 m above the plan's height" in text


@settings(max_examples=200, deadline=None)
@given(x=st.floats(-1e4, 1e4), y=st.floats(-1e4, 1e4), px=st.floats(-1e4, 1e4), py=st.floats(-1e4, 1e4),
       heading=st.floats(0.0, 359.999), turn=st.floats(-180.0, 180.0), bearing=st.floats(-720.0, 720.0),
       pitch=st.floats(-89.9, 30.0))
def test_an_aim_looks_along_at_a_bearing_or_at_a_point(x, y, px, py, heading, turn, bearing, pitch) -> None:
    xy, hd = np.array([[x, y]]), np.array([heading])

    def same(a: float, b: float) -> bool:
        return abs((a - b + 180.0) % 360.0 - 180.0) < 1e-6

    assert same(float(Aim(pitch, turn_deg=turn).bearings(xy, hd)[0]), heading + turn)
    assert same(float(Aim(pitch, bearing_deg=bearing).bearings(xy, hd)[0]), bearing)
    if math.hypot(px - x, py - y) > 1e-3:
        to = complex(px - x, py - y)  # east + i north: the bearing is the angle from north, clockwise
        assert same(float(Aim(pitch, point=(px, py)).bearings(xy, hd)[0]), math.degrees(math.atan2(to.real, to.imag)))


@settings(max_examples=200, deadline=None)
@given(w=st.floats(0.5, 500.0), d=st.floats(0.5, 500.0), turn=st.floats(0.0, 180.0), cx=st.floats(-1e4, 1e4),
       cy=st.floats(-1e4, 1e4), away=st.floats(0.1, 300.0), towards=st.floats(0.0, 360.0))
def test_an_aim_at_an_outline_looks_at_its_nearest_point(w, d, turn, cx, cy, away, towards) -> None:
    """A rotated rectangle (convex: one nearest point to a place outside it) and a place `away`
    metres off it: the look is the bearing to the nearest point found here, edge by edge."""
    t = math.radians(turn)
    rot = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    corners = np.array([[-w, -d], [w, -d], [w, d], [-w, d]]) / 2.0 @ rot.T + [cx, cy]
    # a place: from the centre towards `towards`, out to the outline, then `away` further
    u = np.array([math.sin(math.radians(towards)), math.cos(math.radians(towards))])
    local = u @ rot  # the direction in the rectangle's own axes
    reach = min(w / 2.0 / abs(local[0]) if abs(local[0]) > 1e-9 else math.inf,
                d / 2.0 / abs(local[1]) if abs(local[1]) > 1e-9 else math.inf)
    place = np.array([cx, cy]) + u * (reach + away)
    best, nearest = math.inf, None
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        k = float(np.clip((place - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        q = a + k * (b - a)
        if math.dist(q, place) < best:
            best, nearest = math.dist(q, place), q
    assert nearest is not None
    want = math.degrees(math.atan2(nearest[0] - place[0], nearest[1] - place[1]))
    aim = Aim(-30.0, outline=tuple((float(x), float(y)) for x, y in corners))
    got = float(aim.bearings(place[None, :], np.zeros(1))[0])
    assert abs((got - want + 180.0) % 360.0 - 180.0) < 1e-4 * max(1.0, 1.0 / best), (got, want, best)
    assert aim.look == "outline"


def test_an_aim_is_one_look() -> None:
    with pytest.raises(ValueError):
        Aim(-30.0, bearing_deg=10.0, point=(0.0, 0.0))
    with pytest.raises(ValueError):
        Aim(-30.0, turn_deg=90.0, bearing_deg=10.0)
    with pytest.raises(ValueError):
        Aim(-90.0, point=(0.0, 0.0))
    with pytest.raises(ValueError):
        Aim(-95.0)
    with pytest.raises(ValueError):
        Aim(-30.0, point=(0.0, 0.0), outline=((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)))
    with pytest.raises(ValueError):
        Aim(-30.0, outline=((0.0, 0.0), (1.0, 0.0)))
