"""Plain GeoJSON areas are read without GDAL, and give exactly what GDAL's reader gives: the same
coordinates bit for bit, the same union, the same errors (anything unusual goes to GDAL)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from aerosurvey import area
from aerosurvey.errors import InputError

REPO = Path(__file__).resolve().parents[1]


def by_gdal(path: Path, lines: bool = False) -> shapely.Geometry:
    geom, crs = area._parse_vector(path, str(path), path.name, "area", lines)
    return geom


def reads_as_gdal_reads_it(path: Path) -> None:
    """The fast reader gives GDAL's geometry, or refuses with GDAL's reader's message."""
    try:
        want = by_gdal(path)
    except InputError as exc:
        with pytest.raises(InputError) as got:
            area._read_vector(path, "area")
        assert str(got.value) == str(exc)
        return
    fast, _ = area._read_vector(path, "area")
    assert same(fast, want)


def same(a: shapely.Geometry, b: shapely.Geometry) -> bool:
    return a.geom_type == b.geom_type and np.array_equal(shapely.get_coordinates(a), shapely.get_coordinates(b)) \
        and shapely.equals_exact(a, b, tolerance=0.0)


@pytest.mark.parametrize("path", sorted((REPO / "missions" / "areas").glob("*.geojson")), ids=lambda p: p.name)
def test_repository_areas_read_as_gdal_reads_them(path: Path) -> None:
    assert area._plain_geojson(path) is not None  # the fast path is taken
    lines = "LineString" in path.read_text()  # a corridor's centreline
    fast, crs = area._read_vector(path, "area", lines)
    assert same(fast, by_gdal(path, lines))


digits = st.integers(0, 17)
lon = st.builds(lambda v, n: round(v, n), st.floats(14.0, 14.2), digits)
lat = st.builds(lambda v, n: round(v, n), st.floats(49.0, 49.2), digits)


@st.composite
def documents(draw: st.DrawFn) -> dict:
    feats = []
    for _ in range(draw(st.integers(1, 3))):
        cx, cy, r = draw(lon), draw(lat), draw(st.floats(0.001, 0.02))
        n = draw(st.integers(3, 9))
        ring = [[cx + r * math.cos(2 * math.pi * k / n) + draw(st.floats(-1e-4, 1e-4)),
                 cy + r * math.sin(2 * math.pi * k / n)] for k in range(n)]
        if draw(st.booleans()):
            ring = [[round(x, draw(digits)), round(y, draw(digits))] for x, y in ring]
        if draw(st.booleans()):
            ring = [[x, y, draw(st.floats(0, 500))] for x, y in ring]  # heights are dropped
        ring.append(list(ring[0]))
        kind = draw(st.sampled_from(["Polygon", "MultiPolygon", "Point", "null"]))
        geom = ({"type": "Polygon", "coordinates": [ring]} if kind == "Polygon"
                else {"type": "MultiPolygon", "coordinates": [[ring]]} if kind == "MultiPolygon"
                else {"type": "Point", "coordinates": ring[0]} if kind == "Point" else None)
        feats.append({"type": "Feature", "properties": {"n": 1}, "geometry": geom})
    if len(feats) == 1 and draw(st.booleans()):
        return feats[0] if draw(st.booleans()) else (feats[0]["geometry"] or {"type": "Point", "coordinates": [1.0, 2.0]})
    return {"type": "FeatureCollection", "features": feats}


@settings(max_examples=60, deadline=None)
@given(documents())
def test_random_documents_read_as_gdal_reads_them(tmp_path_factory, doc: dict) -> None:
    path = tmp_path_factory.mktemp("gj") / "a.geojson"
    path.write_text(json.dumps(doc))
    reads_as_gdal_reads_it(path)


SQ = [[14.0, 49.0], [14.01, 49.0], [14.01, 49.01], [14.0, 49.01], [14.0, 49.0]]


@pytest.mark.parametrize("coords", [
    [[[x, y, 300.0] if k % 2 else [x, y] for k, (x, y) in enumerate(SQ)]],  # 2-D and 3-D positions mixed
    [[[x, y, 300.0, 7.0] for x, y in SQ]],  # four numbers a position
    [[[x, [y, y]] for x, y in SQ]],  # nested deeper
    [[[x, y] for x, y in SQ], [[14.002, 49.002], [14.003, 49.002], [14.003, 49.003], [14.002, 49.002]]],  # a hole
    [[[14, 49], [2**63 + 5, 49], [14, 50], [14, 49]]],  # an integer beyond int64 that uint64 holds
    [[[14.0, 49.0], [14.01, 49.0], [14.0, 49.0]]],  # a ring of three positions
    [[14.0, 49.0]],  # too shallow
], ids=["mixed-dims", "4d", "nested", "hole", "uint64", "short-ring", "shallow"])
@pytest.mark.parametrize("kind", ["Polygon", "MultiPolygon"])
def test_odd_polygons_read_as_gdal_reads_them(tmp_path: Path, coords: list, kind: str) -> None:
    path = tmp_path / "a.geojson"
    path.write_text(json.dumps({"type": kind, "coordinates": coords if kind == "Polygon" else [coords]}))
    reads_as_gdal_reads_it(path)


@pytest.mark.parametrize("doc", [
    {"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "EPSG:5514"}}, "features": []},
    {"type": "GeometryCollection", "geometries": []},
    {"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": {"type": "Polygon", "coordinates": "x"}}]},
    [1, 2],
])
def test_anything_unusual_goes_to_gdal(tmp_path: Path, doc: object) -> None:
    path = tmp_path / "a.geojson"
    path.write_text(json.dumps(doc))
    assert area._plain_geojson(path) is None
    path.write_text("{not json")
    assert area._plain_geojson(path) is None


def test_a_plain_geojson_plan_loads_no_gdal(tmp_path: Path) -> None:
    import subprocess

    code = ("import sys; from aerosurvey.area import read_area; from pathlib import Path; "
            f"read_area(Path({str(REPO / 'missions' / 'areas' / 'obratan-72ha.geojson')!r}), None, '', 'area'); "
            "print(sorted(m for m in sys.modules if m.startswith('pyogrio')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


SQUARE = [[14.0, 49.0], [14.01, 49.0], [14.01, 49.01], [14.0, 49.01], [14.0, 49.0]]


@pytest.mark.parametrize("text", [
    json.dumps({"type": "Polygon", "coordinates": [[[str(x), str(y)] for x, y in SQUARE]]}),  # numbers as strings
    json.dumps({"type": "Polygon", "coordinates": [[[14.0, 49.0], [True, 49.0], [True, True], [14.0, True], [14.0, 49.0]]]}),
    json.dumps({"type": "Polygon", "coordinates": [[[14, 49], [14.01, 49], [10**400, 49.01], [14, 49.01], [14, 49]]]}),
    '{"type": "Polygon", "coordinates": ' + "[" * 100_000 + "]" * 100_000 + "}",  # nested too deep
], ids=["strings", "booleans", "huge-integer", "deep"])
def test_odd_coordinates_give_gdals_answer(tmp_path: Path, text: str) -> None:
    """Coordinates GDAL does not read as numbers are not taken as numbers (shapely would take
    "14.0" and true), and nothing a file holds ends in a traceback: the same one-line error."""
    path = tmp_path / "a.geojson"
    path.write_text(text)
    with pytest.raises(InputError) as want:
        by_gdal(path)
    with pytest.raises(InputError) as got:
        area._read_vector(path, "area")
    assert str(got.value) == str(want.value)


def test_an_unclosed_ring_is_one_line_error_on_both_paths(tmp_path: Path) -> None:
    path = tmp_path / "open.geojson"
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [[[14.0, 49.0], [14.01, 49.0], [14.01, 49.01], [14.0, 49.01]]]}))
    assert area._plain_geojson(path) is None  # shapely would close it quietly: GDAL's path decides
    with pytest.raises(InputError, match=r"^area: layer .* holds a geometry that is not valid: .*closed.*close every ring"):
        area._read_vector(path, "area")


def test_a_large_geojson_goes_to_gdal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Above PLAIN_GEOJSON_MAX_BYTES GDAL reads the file (faster on huge rings); the geometry is the same."""
    src = REPO / "missions" / "areas" / "obratan-72ha.geojson"
    calls: list[int] = []
    real = area._plain_geojson
    monkeypatch.setattr(area, "_plain_geojson", lambda path: calls.append(path.stat().st_size) or real(path))
    small, _ = area._read_vector(src, "area")
    monkeypatch.setattr(area, "PLAIN_GEOJSON_MAX_BYTES", src.stat().st_size - 1)
    large, _ = area._read_vector(src, "area")
    assert calls == [src.stat().st_size] and same(small, large)
