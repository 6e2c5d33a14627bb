"""Shared test fixtures: a small mission spec written into a temporary folder."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

# pymavlink picks its wire version when first imported: MAVLink 2, as the vehicles and aerosurvey's link
# speak it, whichever test module imports it first (mavwp built MAVLink 1 messages when a plan test did)
os.environ.setdefault("MAVLINK20", "1")

import numpy as np
import pytest
import shapely
import tomli_w

REPO = Path(__file__).resolve().parents[1]


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


def example_for_px4(name: str, tmp: Path) -> Path:
    """missions/NAME.toml with `[vehicle] firmware = "px4"`, written into `tmp` (its area and DEM
    taken from missions/)."""
    import tomllib

    spec = tomllib.loads((REPO / "missions" / f"{name}.toml").read_text())
    spec["vehicle"]["firmware"] = "px4"
    for table, key in (("area", "file"), ("terrain", "dem")):
        if key in spec.get(table, {}):
            spec[table][key] = str(REPO / "missions" / spec[table][key])
    path = tmp / f"{name}.toml"
    path.write_text(tomli_w.dumps(spec))
    return path


def plan_and_fly(spec: Path, out: Path, *fly: str) -> tuple[dict, dict]:
    """Plan `spec` into `out` and fly every sortie with `aerosurvey sitl fly OUT *fly`; (the
    manifest, the SITL report), both as JSON."""
    from click.testing import CliRunner

    from aerosurvey.cli import main

    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["sitl", "fly", str(out), *fly])
    report = json.loads((out / "sitl" / "sitl_report.json").read_text())
    assert res.exit_code == 0, res.output
    return json.loads((out / "manifest.json").read_text()), report


def assert_sitl_cleaned_up(temp: Path, pidfile: Path, plan_dir: Path) -> None:
    """After a SITL that failed: its temporary folder (under `temp`) removed, its process (pid in
    `pidfile`) stopped, no report written into the plan folder."""
    assert list(temp.iterdir()) == []
    pid = int(pidfile.read_text())
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        pass
    else:
        raise AssertionError(f"SITL process {pid} still runs")
    assert not (plan_dir / "sitl").exists()


@pytest.fixture
def spec_factory(tmp_path: Path):
    def factory(overrides: dict[str, Any] | None = None, area: list | None = None) -> Path:
        return make_spec(tmp_path, overrides, area)

    return factory


@pytest.fixture(scope="module", params=["obratan-72ha", "forest-dem"])
def written(request, tmp_path_factory):
    """(example name, its plan, the folder `plan --gpkg` wrote it into): the 72 ha example
    (flat, 2-D layers) and the forest one (terrain following, 3-D layers)."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.spec import load_spec

    spec = load_spec(Path(__file__).resolve().parents[1] / "missions" / f"{request.param}.toml")
    plan = plan_from_files(spec)
    out = tmp_path_factory.mktemp(request.param)
    write_outputs(plan, spec, out, gpkg=True)
    return request.param, plan, out


def random_polygon(kind: str, seed: int, size_m: float) -> list[list[float]]:
    """Lon/lat rings of a random convex, concave (star) or holed polygon near 49.4 N 15 E."""
    rng = np.random.default_rng(seed)
    if kind == "convex":
        p = rng.uniform(-size_m, size_m, (12, 2))
        g = shapely.convex_hull(shapely.MultiPoint(p))
    elif kind == "concave":
        ang = np.sort(rng.uniform(0, 2 * np.pi, 9))
        rad = rng.uniform(0.35, 1.0, 9) * size_m
        g = shapely.Polygon(np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
        g = g if g.is_valid else shapely.convex_hull(g)
    else:
        outer = shapely.Point(0, 0).buffer(size_m, quad_segs=4)
        g = outer.difference(shapely.box(-size_m / 4, -size_m / 5, size_m / 5, size_m / 4))
    lat0, lon0 = 49.4, 15.0
    k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(lat0)))
    rings = [[[lon0 + x * k_lon, lat0 + y * k_lat] for x, y in r.coords] for r in [g.exterior, *g.interiors]]
    return rings


def planned(exit_code: int, output: str) -> bool:
    """Whether `aerosurvey plan` wrote its plan: exit 0, or 1 when an error-severity rule fails
    (the plan is written for inspection only, and its last line says so)."""
    return exit_code == 0 or (exit_code == 1 and "for inspection only" in output)
