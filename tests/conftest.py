"""Shared test fixtures: a small mission spec written into a temporary folder."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import tomli_w

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


def write_geojson(path: Path, coords: list, geom_type: str = "Polygon") -> Path:
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": geom_type, "coordinates": coords}}]}
    path.write_text(json.dumps(fc))
    return path


def make_spec(tmp: Path, overrides: dict[str, Any] | None = None, area: list | None = None,
              rings: list | None = None) -> Path:
    """A spec over a ~17 ha rectangle near 49.4 N 15.0 E, unless `area` (one lon/lat ring)
    or `rings` (outer ring and holes) is given."""
    ring = area or [[15.000, 49.400], [15.006, 49.400], [15.006, 49.4035], [15.000, 49.4035], [15.000, 49.400]]
    write_geojson(tmp / "area.geojson", rings or [ring])
    spec: dict[str, Any] = {
        "mission": {"name": "test"},
        "area": {"file": "area.geojson"},
        "camera": {"model": "sony-a6000-16mm"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6},
        "vehicle": {"type": "copter", "cruise_speed_ms": 10.0},
    }
    for table, values in (overrides or {}).items():
        if values is None:
            spec.pop(table, None)
        else:
            spec.setdefault(table, {}).update(values)
    p = tmp / "spec.toml"
    p.write_text(tomli_w.dumps(spec))
    return p


@pytest.fixture
def spec_factory(tmp_path: Path):
    def factory(overrides: dict[str, Any] | None = None, area: list | None = None) -> Path:
        return make_spec(tmp_path, overrides, area)

    return factory
