"""The page's brief: `aerosurvey brief` of the plan shown, for the time the pilot chooses."""

from __future__ import annotations

import pytest
from webutil import client, copy_mission, run_plan


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    spec = copy_mission(tmp_path_factory.mktemp("brief"))
    with client(spec) as c:
        done = run_plan(c, c.get("/api/state").json()["spec"])
        assert done["state"] == "done", done
        yield c, done["result"]["plan_id"]


def test_the_brief_says_when_the_flights_end_after_sunset(planned):
    c, pid = planned
    day = c.post(f"/api/plans/{pid}/brief", json={"at": "2026-05-14T09:00:00+02:00"}).json()
    assert day["verdict"] == "advise"  # no official zone file: the airspace is said unchecked
    topics = {i["topic"]: i["verdict"] for i in day["items"]}
    assert topics == {"airspace": "advise", "wind": "go", "batteries": "go", "daylight": "go"}  # obratan flies in 3@270
    night = c.post(f"/api/plans/{pid}/brief", json={"at": "2026-05-14T17:00:00Z", "battery_change_min": 10}).json()
    daylight = next(i for i in night["items"] if i["topic"] == "daylight")
    assert night["verdict"] == "no-go" and daylight["verdict"] == "no-go" and "sunset 2026-05-14" in daylight["text"]


def test_a_bad_brief_request_is_refused_in_one_line(planned):
    c, pid = planned
    for body in ({"at": "tomorrow"}, {"at": "2026-05-14T09:00"}, {}, {"at": "2026-05-14T09:00Z", "battery_change_min": -1}):
        r = c.post(f"/api/plans/{pid}/brief", json=body)
        assert r.status_code == 400 and r.json()["key"] == "brief", (body, r.text)
    assert c.post("/api/plans/p999/brief", json={"at": "2026-05-14T09:00Z"}).status_code == 404
