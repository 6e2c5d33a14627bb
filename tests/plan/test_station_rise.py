"""A height per station (`Strip.rise_m`): carried through the route (`Run.station_rise_m`, in
flight order, reversed with a strip flown backwards) into the stations' and the waypoints'
altitudes (a lead-in at its run's first station's height, a line end at its last's)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey.inputs import load_inputs
from aerosurvey.plan.altitudes import assign_altitudes
from aerosurvey.plan.pattern import kind_of, pattern_for
from aerosurvey.plan.routing import plan_route
from aerosurvey.plan.sensor import solve_heights, solve_sensor, target_height
from aerosurvey.plan.site import prepare_site
from aerosurvey.spec import load_spec

REPO = Path(__file__).resolve().parents[2]


def _wall():
    spec = load_spec(REPO / "missions/long-wall.toml")
    h, gsd, _ = target_height(spec)
    site = prepare_site(spec, load_inputs(spec), h)
    heights = solve_heights(spec, h, None)
    sensor = solve_sensor(spec, h, gsd, heights, footprint=kind_of(spec.pattern.kind).footprint(spec, heights),
                          autopilot_stretch=site.autopilot_stretch())
    layout = next(pattern_for(spec).layouts(site, sensor, lambda s, f: None))
    return spec, site, sensor, layout


WALL = _wall()


@settings(max_examples=10, deadline=None)
@given(st.lists(st.floats(-1.5, 30.0), min_size=1, max_size=400), st.booleans())
def test_each_station_flies_its_own_height(rises, back_and_forth):
    spec, site, sensor, layout = WALL
    # each strip's stations given heights from the list (cycled); flown each its own way or back and forth
    passes = tuple(replace(p, one_way=not back_and_forth, strips=tuple(
        replace(s, rise_m=np.resize(np.asarray(rises, float), len(s.stations))) for s in p.strips))
        for p in layout.passes)
    routed = plan_route(spec, site, sensor, replace(layout, passes=passes))
    h = sensor.heights.nominal_agl_m
    alts = assign_altitudes(routed.route, sensor.heights, None, 0.0, site.planar, spec.terrain.tolerance_m)
    by_pass = {p.index: p for p in passes}
    want_alt = []
    for r in routed.route.runs:
        s = next(s for s in by_pass[r.pass_index].strips if s.line == r.line and s.part == r.part)
        # the strip's stations matched to the run's by their places: the run flies them in either order
        order = [int(np.argmin(np.hypot(*(s.stations - p).T))) for p in r.station_xy]
        want_alt.extend(h + by_pass[r.pass_index].rise_m + s.rise_m[order])
    assert np.allclose(alts.stations.alt_rel_m, want_alt, atol=1e-9)
    assert np.allclose(alts.stations.agl_m, want_alt, atol=1e-9)  # no DEM: the launch point's ground
    firsts = np.searchsorted(alts.stations.run, np.arange(len(routed.route.runs)))
    lasts = np.searchsorted(alts.stations.run, np.arange(len(routed.route.runs)), side="right") - 1
    ends = {"lead_in": firsts, "line_start": firsts, "line_end": lasts}
    seen = set()
    for w in alts.waypoints:
        if w.kind in ends:
            assert w.alt_m == pytest.approx(alts.stations.alt_rel_m[ends[w.kind][w.run]], abs=1e-9), w
            seen.add(w.kind)
    assert seen == set(ends)


def test_without_station_heights_the_pass_height_holds():
    spec, site, sensor, layout = WALL
    routed = plan_route(spec, site, sensor, layout)
    assert all(r.station_rise_m is None for r in routed.route.runs)
    for r in routed.route.runs:
        assert np.array_equal(r.rises(), np.full(len(r.station_xy), r.rise_m))
