"""The page's profile of the route over the terrain: the clearance check's legs and heights, sampled for drawing."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
import shapely
from webutil import REPO, client, copy_mission, run_plan


@pytest.fixture(scope="module")
def forest(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("profile")
    spec = copy_mission(tmp, "forest-dem")
    shutil.copy(REPO / "missions" / "areas" / "forest-block-dem.tif", tmp / "areas")
    with client(spec) as c:
        done = run_plan(c, c.get("/api/state").json()["spec"])
        assert done["state"] == "done", done
        yield c, done["result"]


def test_the_profile_follows_the_route_and_its_lowest_clearance_is_the_checks(forest):
    c, view = forest
    p = view["profile"]
    d, amsl, ground = p["distance_m"], p["amsl_m"], p["ground_m"]
    assert len(d) == len(amsl) == len(ground) >= 1000
    assert all(b >= a for a, b in zip(d, d[1:]))  # distance flown only grows
    assert d[-1] == pytest.approx(view["summary"]["distance_km"] * 1000, rel=0.02)  # the route's length (turns drawn straight)
    manifest = c.get(f"/api/plans/{view['plan_id']}/files/manifest.json").json()
    exact = min(f["clearance_m"] for f in manifest["clearance"]["flights"] if f["flight"] == "mission")
    sampled = min(a - g for a, g, ok in zip(amsl, ground, p["checked"], strict=True) if ok)  # not the legs to the ground
    # the drawing samples the legs; the check finds the exact lowest: the drawing's is at or above it, and near
    assert exact - 0.05 <= sampled <= exact + 5.0
    assert p["min_clearance_m"] == manifest["clearance"]["min_clearance_m"]


def test_without_a_dem_there_is_no_profile(tmp_path):
    with client(copy_mission(tmp_path)) as c:
        done = run_plan(c, c.get("/api/state").json()["spec"])
        assert done["result"]["profile"] is None




def test_the_zones_height_bands_lie_where_the_route_crosses_them(tmp_path):
    """Two official zones over the forest block (one from 150 m above the ground to 900 m above sea level, one from
    the surface to 400 m above sea level): the profile's bands lie where the exported route (mission.waypoints,
    rebuilt by the independent leg reader) is inside each zone's outline, with the limits converted to sea level."""
    import independent_airspace as ia
    from independent_legs import Local

    spec = copy_mission(tmp_path, "forest-dem")
    shutil.copy(REPO / "missions" / "areas" / "forest-block-dem.tif", tmp_path / "areas")
    strip = [(8.7350, 50.8400), (8.7370, 50.8400), (8.7370, 50.8480), (8.7350, 50.8480), (8.7350, 50.8400)]
    box = [(8.7390, 50.8430), (8.7400, 50.8430), (8.7400, 50.8445), (8.7390, 50.8445), (8.7390, 50.8430)]
    zones = [ia.Zone("STRIP", "CONDITIONAL", (150.0, "m", "AGL"), (900.0, "m", "AMSL"), ring=strip),
             ia.Zone("BOX", "NO_RESTRICTION", None, (400.0, "m", "AMSL"), ring=box)]
    ia.write_ed269(tmp_path / "zones.json", zones)
    with client(spec) as c:
        state = c.get("/api/state").json()["spec"]
        done = run_plan(c, {**state, "airspace": {"zones": ["zones.json"]}})
        assert done["state"] == "done", done
        view = done["result"]
        wpl = tmp_path / "mission.waypoints"
        wpl.write_bytes(c.get(f"/api/plans/{view['plan_id']}/files/mission.waypoints").content)
    p = view["profile"]
    local = Local(8.7375, 50.8437)
    legs, _ = ia.flight_legs(wpl, local)
    assert p["distance_m"][-1] == pytest.approx(sum(math.dist(leg.a, leg.b) for leg in legs), abs=1.0)
    bands = p["bands"]
    for zone in zones:
        want = ia.stretches_inside(legs, local.geom(shapely.Polygon(zone.ring)))
        got = [b for b in bands if f"zone {zone.ident}" in b["name"]]
        assert want and len(got) == len(want), (zone.ident, len(got), len(want))
        for b, (a, e) in zip(got, want):
            d = b["distance_m"]
            assert d[0] == pytest.approx(a, abs=1.0) and d[-1] == pytest.approx(e, abs=1.0)
            assert all(y >= x for x, y in zip(d, d[1:]))
            ground = np.interp(d, p["distance_m"], p["ground_m"])
            if zone.ident == "STRIP":  # 150 m above the ground under each point to 900 m above sea level
                assert np.allclose(np.array(b["lower_m"]) - ground, 150.0, atol=0.02)
                assert b["upper_m"] == [900.0] * len(d)
            else:  # from the surface (the ground) to 400 m above sea level
                assert np.allclose(b["lower_m"], ground, atol=0.02)
                assert b["upper_m"] == [400.0] * len(d)
            assert b["kind"] == "official" and "m" in b["band"]
    assert sorted(b["distance_m"][0] for b in bands) == [b["distance_m"][0] for b in bands]
    assert all(b["kind"] == "official" for b in bands)  # the route flies round no exclusion zone here
