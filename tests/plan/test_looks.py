"""A pass whose camera is turned at each station through several aims (`Pass.looks`, the model of
a smart oblique): each station becomes one row per aim, in flight order station by station and
aim by aim, each with its aim's pitch and look and an id of its own in the look's pass.

Checked against plain expectations (regular expressions on the ids, bearings worked out here),
not against ids.py or the Aim code."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.plan.altitudes import assign_altitudes
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.plan.passes import NADIR, Aim
from aerosurvey.plan.pattern import AreaGrid, kind_of
from aerosurvey.plan.routing import plan_route
from aerosurvey.plan.sensor import solve_heights, solve_sensor, target_height
from aerosurvey.plan.site import prepare_site
from aerosurvey.spec import parse_spec

REPO = Path(__file__).resolve().parents[2]
ID = re.compile(r"^P(\d+)-L(\d{3,})-S(\d{4,})$")


def _stations(w_deg: float, h_deg: float, heading: float, looks: tuple[Aim, ...]):
    area = shapely.box(15.0, 49.4, 15.0 + w_deg, 49.4 + h_deg)
    spec = parse_spec({"mission": {"name": "looks"}, "area": {"wkt": area.wkt}, "camera": {"model": "sony-a6000-16mm"},
                       "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6},
                       "vehicle": {"type": "copter", "cruise_speed_ms": 10.0}, "flight": {"heading": heading}},
                      base=Path("."))
    h, gsd, _ = target_height(spec)
    site = prepare_site(spec, PlanInputs(area), h)
    heights = solve_heights(spec, h, None)
    sensor = solve_sensor(spec, h, gsd, heights, footprint=kind_of(spec.pattern.kind).footprint(spec, heights),
                          autopilot_stretch=site.autopilot_stretch())
    layout = next(AreaGrid(heading, False, 0, 0.0).layouts(site, sensor, lambda s, f: None))
    layout = replace(layout, passes=tuple(replace(p, looks=looks) for p in layout.passes))
    routed = plan_route(spec, site, sensor, layout)
    alts = assign_altitudes(routed.route, sensor.heights, None, 0.0, site.planar, spec.terrain.tolerance_m)
    return routed.route, alts.stations


@settings(max_examples=8, deadline=None)
@given(st.floats(0.002, 0.006), st.floats(0.0015, 0.004), st.floats(0.0, 179.0), st.floats(-70.0, -30.0),
       st.floats(0.0, 359.0))
def test_each_station_is_shot_at_every_aim(w_deg, h_deg, heading, pitch, first_bearing):
    looks = tuple(Aim(pitch, bearing_deg=(first_bearing + 90.0 * i) % 360.0) for i in range(4))
    plain_route, plain = _stations(w_deg, h_deg, heading, ())
    route, s = _stations(w_deg, h_deg, heading, looks)
    n = len(plain.ids)
    assert n > 0 and len(s.ids) == 5 * n and len(set(s.ids)) == 5 * n
    schema = json.loads((REPO / "src/aerosurvey/data/manifest.schema.json").read_text())
    allowed = re.compile(schema["$defs"]["station_id"]["pattern"])
    assert all(allowed.match(i) for i in s.ids)
    rows = np.arange(5 * n).reshape(n, 5)  # station by station, aim by aim
    for look in range(5):
        r = rows[:, look]
        # the same place, run and heading as the plain plan's station, five times over
        assert np.allclose(s.x[r], plain.x, atol=1e-9) and np.allclose(s.y[r], plain.y, atol=1e-9)
        assert np.array_equal(s.run[r], plain.run)
        assert np.allclose(s.alt_rel_m[r], plain.alt_rel_m)
        for got, was in zip((s.ids[i] for i in r), plain.ids):
            g, w = ID.match(got), ID.match(was)
            assert g and w
            # one pass of five looks: the look's pass number is 1 + look (P1 nadir, P2..P5 the obliques)
            assert int(g[1]) == int(w[1]) + look and g[2] == w[2] and g[3] == w[3]
    # nadir first: the plain plan's aim and look; then each oblique at its bearing
    assert np.allclose(s.pitch_deg[rows[:, 0]], -90.0) and np.allclose(s.camera_yaw_deg[rows[:, 0]], plain.camera_yaw_deg)
    for i in range(4):
        r = rows[:, 1 + i]
        assert np.allclose(s.pitch_deg[r], pitch)
        off = (s.camera_yaw_deg[r] - (first_bearing + 90.0 * i)) % 360.0
        assert np.all(np.minimum(off, 360.0 - off) < 1e-9)
    assert all(r.aims == (NADIR, *looks) for r in route.runs)
    assert all(r.aims == (NADIR,) for r in plain_route.runs)
