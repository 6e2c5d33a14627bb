"""A control point layout read back from control_points.geojson (`check` of a plan folder)."""

from __future__ import annotations

import json

import pytest

from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.rules.cp_files import control_point_files, read_layout
from aerosurvey.rules.engine import Evidence, layout_settings
from aerosurvey.rules.load import plan_documents
from aerosurvey.rules.planview import PlanView
from aerosurvey.spec import load_spec
from conftest import make_spec


@pytest.fixture(scope="module")
def view(tmp_path_factory) -> PlanView:
    spec = make_spec(tmp_path_factory.mktemp("layout"), {"targets": {"images_beyond_boundary": 8, "coverage_margin_m": 12.0}})
    loaded = load_spec(spec)
    manifest, features = plan_documents(plan_from_files(loaded), loaded)
    return PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")


def test_written_layout_reads_back_with_the_same_points(view):
    ev = Evidence(view, layout_settings(view, []))
    text = control_point_files(view, ev.points)["control_points.geojson"]
    back = read_layout(text, view, "control_points.geojson")
    assert [(p.id, p.role, p.images) for p in back] == [(p.id, p.role, p.images) for p in ev.points]
    # positions go through longitude/latitude rounded to 1e-8 degrees (about 1 mm)
    assert max(max(abs(a.x - b.x), abs(a.y - b.y)) for a, b in zip(back, ev.points)) < 2e-3


@pytest.mark.parametrize("feature,needle", [
    ({"type": "Feature", "properties": {"role": "gcp"}, "geometry": {"type": "Point", "coordinates": ["15.0", 49.4]}},
     "feature 1 has no point coordinates"),
    ({"type": "Feature", "properties": {"role": "gcp"}, "geometry": None}, "feature 1 has no point coordinates"),
    ({"type": "Feature", "properties": {"role": "anchor"}, "geometry": {"type": "Point", "coordinates": [15.0, 49.4]}},
     "feature 1 has role 'anchor'; allowed: gcp, check"),
    ("GCP01", "feature 1 is not a GeoJSON feature"),
])
def test_malformed_layout_is_bad_input_naming_the_feature(view, feature, needle):
    with pytest.raises(InputError, match=needle):
        read_layout(json.dumps({"type": "FeatureCollection", "features": [feature]}), view, "control_points.geojson")


def test_empty_layout_has_no_points(view):
    assert read_layout('{"type": "FeatureCollection", "features": []}', view, "cp.geojson") == []
    with pytest.raises(InputError, match="not a control point GeoJSON"):
        read_layout('{"type": "FeatureCollection", "features": {}}', view, "cp.geojson")
