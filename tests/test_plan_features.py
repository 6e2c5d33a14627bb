"""plan_features: the stations, footprints and lines of a plan as GeoJSON features, and the
cyclic garbage collector left alone while they are made (it is one switch for the whole
process: `serve` plans on worker threads)."""

from __future__ import annotations

import gc
from pathlib import Path

import pytest

from aerosurvey.inputs import plan_from_files
from aerosurvey.report.features import plan_features
from aerosurvey.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def plan():
    return plan_from_files(load_spec(ROOT / "missions" / "obratan-72ha.toml"))


def test_planning_and_rendering_leave_the_collector_on(monkeypatch) -> None:
    from aerosurvey.outputs import render_outputs
    from aerosurvey.report import features

    seen = []
    corners = features.bounded_footprint_corners

    def record(*args, **kwargs):
        seen.append(gc.isenabled())
        return corners(*args, **kwargs)

    monkeypatch.setattr(features, "bounded_footprint_corners", record)
    assert gc.isenabled()
    fc = plan_features(plan_from_files(load_spec(ROOT / "missions" / "obratan-72ha.toml")))
    roles = [f["properties"]["role"] for f in fc["features"]]
    assert roles.count("station") == roles.count("footprint") > 0
    loaded = load_spec(ROOT / "missions" / "kubad-abad-fixed-wing.toml")
    render_outputs(plan_from_files(loaded), loaded)
    assert seen == [True, True] and gc.isenabled()


def test_each_line_names_its_first_and_last_station_and_counts_its_photos(plan) -> None:
    fc = plan_features(plan, with_footprints=False)
    st = plan.stations
    lines = [f["properties"] for f in fc["features"] if f["properties"]["role"] == "line"]
    assert len(lines) == len(plan.route.runs)
    for i, props in enumerate(lines):
        mine = [sid for sid, r in zip(st.ids, st.run.tolist()) if r == i]
        assert (props["first_station"], props["last_station"], props["photos"]) == (mine[0], mine[-1], len(mine))


def test_geojson_text_is_the_features_as_json(plan) -> None:
    """plan.geojson's text (stations and footprints written straight from columns and arrays)
    is the FeatureCollection with footprints, as json writes it; the collection handed to the
    KML and the rules has all but the stations and footprints, and the stations' layer makes
    the very station features."""
    import json

    from aerosurvey.report.features import plan_geojson

    fc, stations, text = plan_geojson(plan)
    full = plan_features(plan)
    assert text == json.dumps(full, separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n"
    role = [f["properties"]["role"] for f in full["features"]]
    assert fc["features"] == [f for f, r in zip(full["features"], role) if r not in ("station", "footprint")]
    assert stations.features() == [f for f, r in zip(full["features"], role) if r == "station"]


def test_geojson_text_with_ids_json_escapes_is_json_text(plan) -> None:
    """Station ids JSON must escape (a quote, a backslash, a control character) or keeps as they
    are (non-ASCII) are written as json writes them (footprints take another path for those)."""
    import dataclasses
    import json

    from aerosurvey.report.features import plan_geojson

    for odd in ['"', "\\", "\t", "é"]:
        ids = [f"{sid}{odd}" for sid in plan.stations.ids]
        renamed = dataclasses.replace(plan.stations, ids=ids)
        other = dataclasses.replace(plan, altitudes=dataclasses.replace(plan.altitudes, stations=renamed))
        _, _, text = plan_geojson(other)
        assert text == json.dumps(plan_features(other), separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n"
        footprints = [f for f in json.loads(text)["features"] if f["properties"]["role"] == "footprint"]
        assert [f["properties"]["station"] for f in footprints] == ids


def test_geojson_text_at_the_greenwich_meridian_is_json_text(tmp_path: Path) -> None:
    """Coordinates within ~11 m of longitude 0 are below 1e-4: json writes them 5e-05, as
    plan.geojson always had them (orjson would write 0.00005)."""
    import json

    from aerosurvey.report.features import plan_geojson
    from conftest import make_spec

    ring = [[-0.006, 51.478], [0.00005, 51.478], [0.00005, 51.4815], [-0.006, 51.4815], [-0.006, 51.478]]
    near = plan_from_files(load_spec(make_spec(tmp_path, area=ring)))
    _, _, text = plan_geojson(near)
    assert "5e-05" in text
    assert text == json.dumps(plan_features(near), separators=(",", ":"), ensure_ascii=False, allow_nan=False) + "\n"
