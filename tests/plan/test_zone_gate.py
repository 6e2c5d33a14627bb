"""The final gate and the legs to and from the survey around exclusion zones."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
import tomli_w
from click.testing import CliRunner

from aerosurvey.area import planning_crs
from aerosurvey.cli import main
from aerosurvey.mission.gate import check_legs, program_legs
from aerosurvey.mission.program import FlightProgram, Waypoint

LON0, LAT0 = 15.0, 49.4
LOCAL = pyproj.Transformer.from_crs(f"+proj=aeqd +lat_0={LAT0} +lon_0={LON0} +datum=WGS84", "EPSG:4326", always_xy=True)


def lonlat(x: float, y: float) -> list[float]:
    lo, la = LOCAL.transform(x, y)
    return [round(lo, 8), round(la, 8)]


def box_ring(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [lonlat(x0, y0), lonlat(x1, y0), lonlat(x1, y1), lonlat(x0, y1), lonlat(x0, y0)]


def write_fc(path: Path, ring: list[list[float]]) -> str:
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [ring]}}]}))
    return path.name


def test_gate_finds_a_leg_through_a_zone():
    planar = planning_crs("auto", shapely.Point(LON0, LAT0).buffer(0.01))
    zone = planar.forward(shapely.Polygon(box_ring(100, -50, 200, 50)))
    home = lonlat(0, 0)
    far = lonlat(300, 0)
    p = FlightProgram("t", "copter", "ardupilot", "ricoh-gr", (home[1], home[0], 0.0), "relative", 30.0, 0.0, 5.0, 10.0,
                      None, (Waypoint(far[1], far[0], 30.0, "lead_in", 0, "P1-L001-R1:lead-in", "P1-L001-R1", 90.0),),
                      "rtl", None, (), (), ())
    legs = program_legs(p, "mission", planar)
    assert [leg.seq for leg in legs] == [1, 2, 3]
    bad = check_legs(legs, zone, 10.0, 1.0, planar)
    # out through the zone (100 m inside) and back home through it again
    assert [v.leg.seq for v in bad] == [2, 3]
    assert all(v.zone and v.inside_m == pytest.approx(100.0, abs=0.5) for v in bad)
    assert "mission: the leg to point 2 (P1-L001-R1:lead-in) flies 100.0 m inside an exclusion zone" in bad[0].message()


def _landing_case(tmp_path: Path) -> Path:
    # a plane lands at home into a north wind: the approach starts 300 m south of home, inside the zone
    write_fc(tmp_path / "area.geojson", box_ring(-300, 400, 300, 900))
    write_fc(tmp_path / "zone.geojson", box_ring(-100, -400, 100, -200))
    spec = {"mission": {"name": "gate"}, "area": {"file": "area.geojson", "exclusions": ["zone.geojson"],
                                                  "launch": lonlat(0, 0)},
            "camera": {"model": "ricoh-gr"}, "targets": {"gsd_cm": 3.0},
            "vehicle": {"type": "plane"}, "flight": {"end": "land", "wind_from_deg": 0.0, "heading": 90.0}}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(spec))
    return tmp_path / "s.toml"


def test_a_landing_approach_across_a_zone_is_refused_with_a_valid_place(tmp_path: Path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_landing_case(tmp_path)), "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert "has its landing approach (flight.approach_m = 300 m into flight.wind_from_deg = 0) across an exclusion zone" in res.output
    assert "the nearest valid launch point on the area's edge is [" in res.output
    assert not out.exists()


def test_the_final_gate_stops_what_planning_let_through(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The gate is the last line: with the launch check switched off, the exported approach leg is caught."""
    import aerosurvey.plan.planner as planner
    import aerosurvey.plan.routing as routing

    for module in (routing, planner):
        monkeypatch.setattr(module, "check_launch", lambda *a, **k: None)
        monkeypatch.setattr(module, "end_of_flight", lambda landing, site, home: home)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_landing_case(tmp_path)), "-o", str(out)])
    assert res.exit_code == 1, res.output
    assert "the plan is not written: mission: the leg to point" in res.output
    assert "(approach) flies" in res.output and "inside an exclusion zone" in res.output
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def _legs_from_waypoints(text: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Legs of a QGC WPL 110 file as ArduPilot flies them, parsed here (not with our reader)."""
    to_local = pyproj.Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={LAT0} +lon_0={LON0} +datum=WGS84", always_xy=True)
    rows = [line.split("\t") for line in text.strip().splitlines()[1:]]
    home = np.array(to_local.transform(float(rows[0][9]), float(rows[0][8])))
    pts = [home]
    for r in rows[1:]:
        cmd, lat, lon = int(r[3]), float(r[8]), float(r[9])
        if cmd in (16, 21, 22):
            pts.append(pts[-1] if lat == 0 and lon == 0 else np.array(to_local.transform(lon, lat)))
        elif cmd == 20:
            pts.append(home)
    return list(zip(pts[:-1], pts[1:]))


@pytest.mark.parametrize("battery", [False, True])
def test_the_way_home_goes_round_a_zone(tmp_path: Path, battery: bool):
    # a zone straddles the area's south edge, between the survey's last line and the launch point (wider than the
    # area: a narrower one leaves a straight way home from a line's end past it, which the route's start now takes)
    write_fc(tmp_path / "area.geojson", box_ring(-200, 0, 200, 300))
    write_fc(tmp_path / "zone.geojson", box_ring(-250, -150, 250, 40))
    spec = {"mission": {"name": "home"}, "area": {"file": "area.geojson", "exclusions": ["zone.geojson"],
                                                  "launch": lonlat(0, -250)},
            "camera": {"model": "sony-a6000-16mm"}, "targets": {"gsd_cm": 2.0},
            "vehicle": {"type": "copter"}, "flight": {"heading": 90.0}}
    if battery:
        spec["battery"] = {"usable_min": 7.0, "reserve": 0.2}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(spec))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(tmp_path / "s.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    zone = shapely.box(-250, -150, 250, 40)
    files = sorted(out.glob("*.waypoints"))
    assert len(files) >= (3 if battery else 1)
    for f in files:
        legs = _legs_from_waypoints(f.read_text())
        inside = [shapely.LineString([a, b]).intersection(zone).length for a, b in legs]
        assert max(inside) == 0.0, (f.name, inside)
        # the survey starts and ends north of the zone: there is a way round it, and a copter lands at home
        assert "\t21\t" in f.read_text().splitlines()[-1]


def _rally_case(tmp_path: Path, rally: tuple[float, float]) -> Path:
    write_fc(tmp_path / "area.geojson", box_ring(-300, 400, 300, 900))
    write_fc(tmp_path / "zone.geojson", box_ring(400, -100, 600, 100))
    spec = {"mission": {"name": "rally"}, "area": {"file": "area.geojson", "exclusions": ["zone.geojson"],
                                                   "launch": lonlat(0, 0)},
            "camera": {"model": "ricoh-gr"}, "targets": {"gsd_cm": 3.0},
            "flight": {"heading": 90.0, "rally_points": [lonlat(*rally)]}}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(spec))
    return tmp_path / "s.toml"


def test_a_rally_point_is_where_rtl_may_go_and_the_fence_holds_it(tmp_path: Path):
    import json

    import shapely

    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_rally_case(tmp_path, (0.0, 1300.0))), "-o", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "mission.plan").read_text())
    want = lonlat(0.0, 1300.0)
    assert any(abs(p[1] - want[0]) < 1e-7 and abs(p[0] - want[1]) < 1e-7 for p in doc["rallyPoints"]["points"])
    fence = next(p for p in doc["geoFence"]["polygons"] if p["inclusion"])
    assert shapely.Polygon([(lon, lat) for lat, lon in fence["polygon"]]).contains(shapely.Point(*want))


def test_a_rally_point_in_a_zone_is_refused_as_a_launch_point_is(tmp_path: Path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(_rally_case(tmp_path, (500.0, 0.0))), "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert "flight.rally_points[1] = [" in res.output and "lies inside an exclusion zone" in res.output
    assert not out.exists()
