"""The page's profile of the route over the terrain: the clearance check's legs and heights, sampled for drawing."""

from __future__ import annotations

import shutil

import pytest
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
