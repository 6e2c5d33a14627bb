"""Zone files as the states publish them, and damaged: each quirk read as it means, each fault
refusing the whole file in one line that names the file, the feature and what is wrong."""

from __future__ import annotations

import copy
import datetime as dt
import json

import pytest

import independent_airspace as ia
from aerosurvey.airspace.model import FOOT_M
from aerosurvey.airspace.read import read_zone_file
from aerosurvey.errors import InputError

RING = [(15.0, 49.4), (15.01, 49.4), (15.01, 49.41), (15.0, 49.41), (15.0, 49.4)]
HOLE = [(15.004, 49.404), (15.006, 49.404), (15.006, 49.406), (15.004, 49.406), (15.004, 49.404)]


def _zone(**kw) -> ia.Zone:
    base = dict(ident="Z1", restriction="PROHIBITED", lower=(0, "m", "AGL"), upper=(120, "m", "AGL"), ring=RING)
    return ia.Zone(**{**base, **kw})


def _269(tmp_path, features, bom=False):
    p = tmp_path / "zones269.json"
    p.write_bytes((b"\xef\xbb\xbf" if bom else b"") + json.dumps({"title": "t", "features": features}).encode())
    return p


def _318(tmp_path, features):
    p = tmp_path / "zones318.json"
    p.write_text(json.dumps({"type": "FeatureCollection", "metadata": {}, "features": features}))
    return p


def test_quirks_are_read_as_they_mean(tmp_path):
    f = ia.ed269_feature(_zone(upper=(99999, "ft", "AMSL"), lower=(100, "ft", "AGL"), holes=[HOLE]))
    f["geometry"][0]["uomDimensions"] = "FT"
    auth = ia.ed269_feature(_zone(ident="Z2", restriction="REQ_AUTHORISATION"), spelling="REQ_AUTHORIZATION")
    no_limits = ia.ed269_feature(_zone(ident="Z3", lower=None, upper=None))
    zones = read_zone_file(_269(tmp_path, [f, auth, no_limits], bom=True))
    z1, z2, z3 = zones
    assert z1.upper is None and z1.lower is not None and abs(z1.lower.value_m - 100 * FOOT_M) < 1e-9
    assert z1.lower.reference == "AGL" and len(z1.outline.interiors) == 1  # the hole kept
    assert z2.restriction == "REQ_AUTHORISATION"
    assert z3.lower is None and z3.upper is None  # not stated: the surface and no ceiling, never 0
    e318 = ia.ed318_feature(_zone(ident="Z4", restriction="REQ_AUTHORISATION", lower=None, upper=(400, "ft", "AMSL"),
                                  circle=(15.0, 49.4, 500.0, "ft"), ring=None))
    (z4,) = read_zone_file(_318(tmp_path, [e318]))
    assert z4.restriction == "REQ_AUTHORISATION" and z4.lower is None
    assert abs(z4.upper.value_m - 400 * FOOT_M) < 1e-9 and z4.upper.reference == "AMSL"
    assert abs(z4.radius_m - 500 * FOOT_M) < 1e-9


def test_schedules_apply_in_their_own_times(tmp_path):
    cest = dt.timezone(dt.timedelta(hours=2))
    night = ia.Period(schedule=(ia.Daily(("FRI",), dt.time(22, tzinfo=cest), dt.time(2, tzinfo=cest)),))
    (z,) = read_zone_file(_269(tmp_path, [ia.ed269_feature(_zone(periods=(night,)))]))
    saturday_1am = dt.datetime(2026, 5, 16, 1, 0, tzinfo=cest)  # Friday's night, across midnight
    assert z.applies_in(saturday_1am, saturday_1am + dt.timedelta(minutes=10))
    assert not z.applies_in(dt.datetime(2026, 5, 16, 3, tzinfo=cest), dt.datetime(2026, 5, 16, 21, tzinfo=cest))
    # a window of weeks: the schedule met in its first week
    assert z.applies_in(dt.datetime(2026, 1, 1, tzinfo=dt.UTC), dt.datetime(2026, 3, 1, tzinfo=dt.UTC))


def _broken_269():
    good = ia.ed269_feature(_zone())

    def change(fn):
        f = copy.deepcopy(good)
        fn(f)
        return [f]

    return {
        "two volumes in one feature": (change(lambda f: f["geometry"].append(copy.deepcopy(f["geometry"][0]))), "2 geometries"),
        "latitude first": (change(lambda f: f["geometry"][0]["horizontalProjection"].update(
            coordinates=[[[p[1], p[0] + 80] for p in RING]])), "latitude first"),
        "unknown restriction": (change(lambda f: f.update(restriction="FORBIDDEN")), "features\\[1\\].restriction"),
        "no restriction field": (change(lambda f: f.pop("restriction")), "restriction"),
        "limit not a number": (change(lambda f: f["geometry"][0].update(upperLimit="high")), "upperLimit"),
        "unknown unit": (change(lambda f: f["geometry"][0].update(uomDimensions="NM")), "uomDimensions"),
        "hole outside the outline": (change(lambda f: f["geometry"][0]["horizontalProjection"]["coordinates"].append(
            [[p[0] + 1, p[1]] for p in RING])), "feature 1 \\(Z1\\) polygon is not valid"),
        "ring of two points": (change(lambda f: f["geometry"][0]["horizontalProjection"].update(
            coordinates=[[list(RING[0]), list(RING[1])]])), "ring 0 has 2 distinct positions"),
        "circle without radius": (change(lambda f: f["geometry"][0].update(
            horizontalProjection={"type": "Circle", "center": [15.0, 49.4]})), "circle radius"),
        "negative radius": (change(lambda f: f["geometry"][0].update(
            horizontalProjection={"type": "Circle", "center": [15.0, 49.4], "radius": -5})), "radius"),
        "bad time": (change(lambda f: f.update(applicability=[{"permanent": "NO", "schedule": [
            {"day": ["MON"], "startTime": "25:00Z", "endTime": "10:00Z"}]}])), "startTime = '25:00Z'"),
        "bad day": (change(lambda f: f.update(applicability=[{"permanent": "NO", "schedule": [
            {"day": ["MONDAY"], "startTime": "08:00Z", "endTime": "10:00Z"}]}])), "day"),
        "end before start": (change(lambda f: f.update(applicability=[{"permanent": "NO", "startDateTime": "2026-05-02T00:00:00Z",
                                                                       "endDateTime": "2026-05-01T00:00:00Z"}])), "before the start"),
        "no features": ([], "holds no zone"),
    }


@pytest.mark.parametrize("case", list(_broken_269()))
def test_a_damaged_ed269_file_is_refused_whole(case, tmp_path):
    features, match = _broken_269()[case]
    good = ia.ed269_feature(_zone(ident="OK"))
    p = _269(tmp_path, [good, *features] if features else [])
    with pytest.raises(InputError, match="zones269.json") as exc:
        read_zone_file(p)
    msg = str(exc.value)
    assert "\n" not in msg
    assert __import__("re").search(match, msg), msg
    if features:
        assert "1" in msg  # the damaged feature is the second (index 1)


def test_damaged_ed318_files_are_refused_whole(tmp_path):
    good = ia.ed318_feature(_zone())
    collection = {"type": "GeometryCollection", "geometries": [good["geometry"], good["geometry"]]}
    for geometry, match in ((collection, "GeometryCollection of 2 geometries"),
                            ({"type": "LineString", "coordinates": [[15, 49], [15.1, 49]]}, "not a zone outline"),
                            ({"type": "Point", "coordinates": [15, 49]}, "without a circle extent"),
                            ({**good["geometry"], "layer": {"uom": "yd", "upper": 5, "upperReference": "AGL"}}, "uom"),
                            ({**good["geometry"], "layer": {"uom": "m", "upper": 5, "upperReference": "GND"}}, "upperReference")):
        with pytest.raises(InputError, match=match):
            read_zone_file(_318(tmp_path, [good, {**good, "geometry": geometry}]))
    with pytest.raises(InputError, match="properties.type"):
        read_zone_file(_318(tmp_path, [{**good, "properties": {**good["properties"], "type": "CLOSED"}}]))
    for text, match in ((b"{", "is not JSON"), (b"[1, 2]", "neither ED-269"), (b"\xff\xfe{}", "is not JSON")):
        (tmp_path / "bad.json").write_bytes(text)
        with pytest.raises(InputError, match=match):
            read_zone_file(tmp_path / "bad.json")
    with pytest.raises(InputError, match="does not exist"):
        read_zone_file(tmp_path / "missing.json")


def test_a_file_in_latitude_longitude_order_is_refused_by_where_it_lies(tmp_path):
    """Coordinates within range either way round: the file is refused when only the swapped reading lies near the area."""
    from aerosurvey.inputs import load_inputs
    from aerosurvey.spec import load_spec
    from conftest import make_spec

    swapped = [(lat, lon) for lon, lat in RING]
    ia.write_ed269(tmp_path / "z.json", [_zone(ring=swapped)])
    spec = load_spec(make_spec(tmp_path, {"airspace": {"zones": ["z.json"]}}))
    with pytest.raises(InputError, match="seem to be \\[latitude, longitude\\]"):
        load_inputs(spec)
    spec = load_spec(make_spec(tmp_path, {"airspace": {"zones": ["z.json"], "authorisations": ["NOPE"]}}))
    ia.write_ed269(tmp_path / "z.json", [_zone()])
    with pytest.raises(InputError, match="airspace.authorisations names 'NOPE'"):
        load_inputs(spec)
