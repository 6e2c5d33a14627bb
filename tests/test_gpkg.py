"""plan.gpkg read back by GDAL (pyogrio): one layer per kind, each with its CRS, one geometry
type and a default QGIS style in the layer_styles table; the route of each sortie is checked
against that sortie's .waypoints file (read here, not by aerosurvey's reader)."""

from __future__ import annotations

import sqlite3
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pyogrio
import shapely

from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import MissionSpec, load_spec

ROOT = Path(__file__).resolve().parents[1]


def _spec(example: str) -> MissionSpec:
    return load_spec(ROOT / "missions" / f"{example}.toml")
LAYERS = {"area": "MultiPolygon", "zones": "MultiPolygon", "strips": "LineString", "route": "LineString",
          "stations": "Point", "footprints": "Polygon", "launch_points": "Point", "gcps": "Point",
          "check_points": "Point", "unphotographed": "Polygon"}
THREE_D = {"strips", "route", "stations", "launch_points"}
SYMBOL = {"Polygon": "fill", "MultiPolygon": "fill", "LineString": "line", "Point": "marker"}


def _wpl_rows(path: Path) -> list[list[str]]:
    lines = path.read_text().splitlines()
    assert lines[0].startswith("QGC WPL 110")
    return [ln.split("\t") for ln in lines[1:] if ln.strip()]


def test_every_layer_has_its_crs_geometry_type_and_a_default_style(written) -> None:
    name, plan, out = written
    path = out / "plan.gpkg"
    layers = dict(pyogrio.list_layers(path))
    assert set(layers) == set(LAYERS) | {"layer_styles"}
    three_d = name == "forest-dem"  # terrain mode follow: heights above mean sea level
    for layer, geom in LAYERS.items():
        info = pyogrio.read_info(path, layer=layer)
        assert info["crs"] == "EPSG:4326"
        want = geom + (" Z" if three_d and layer in THREE_D else "")
        assert info["geometry_type"] == want, layer
    with sqlite3.connect(path) as db:
        kind = dict(db.execute("select table_name, data_type from gpkg_contents").fetchall())
        rows = db.execute("select f_table_name, f_geometry_column, styleName, styleQML, useAsDefault "
                          "from layer_styles").fetchall()
        slds = dict(db.execute("select f_table_name, styleSLD from layer_styles").fetchall())
        geom_col = dict(db.execute("select table_name, column_name from gpkg_geometry_columns").fetchall())
    assert kind["layer_styles"] == "attributes"
    assert {r[0] for r in rows} == set(LAYERS) and len(rows) == len(LAYERS)
    for table, column, style_name, qml, default in rows:
        assert column == geom_col[table] and style_name == table and default == 1
        root = ET.fromstring(qml.split("\n", 1)[1])  # after the DOCTYPE line
        assert root.tag == "qgis"
        symbol = root.find("renderer-v2/symbols/symbol")
        assert symbol is not None and symbol.get("type") == SYMBOL[LAYERS[table]]
        assert _sld_style(slds[table], table) == _qml_style(symbol), table
    # GDAL reads the table as any attribute layer, the SLDs with it
    _, _, _, columns = pyogrio.raw.read(path, layer="layer_styles", columns=["f_table_name", "styleSLD"], read_geometry=False)
    assert dict(zip(columns[0], columns[1], strict=True)) == slds


# the QML's and the SLD's styles read with the standard library's parser, each into
# (symbolizer, fill "#rrggbb" or None, fill opacity, stroke, stroke opacity, stroke width in mm, marker size in mm)
_SLD = {"sld": "http://www.opengis.net/sld", "se": "http://www.opengis.net/se"}
_SYMBOLIZER = {"fill": "PolygonSymbolizer", "line": "LineSymbolizer", "marker": "PointSymbolizer"}


def _rgba(text: str) -> tuple[str, float]:
    r, g, b, a = (int(v) for v in text.split(","))
    return f"#{r:02x}{g:02x}{b:02x}", round(a / 255.0, 2)


def _qml_style(symbol: ET.Element) -> tuple:
    opts = {o.get("name"): o.get("value") for o in symbol.iter("Option") if o.get("name")}
    kind = symbol.get("type")
    if kind == "line":
        return ("LineSymbolizer", None, None, *_rgba(opts["line_color"]), float(opts["line_width"]), None)
    fill, stroke = _rgba(opts["color"]), _rgba(opts["outline_color"])
    if kind == "fill":
        return ("PolygonSymbolizer", *fill, *stroke, float(opts["outline_width"]), None)
    return ("PointSymbolizer", *fill, *stroke, float(opts["outline_width"]), float(opts["size"]))


def _sld_style(text: str, layer: str) -> tuple:
    """An SLD 1.1 document's one rule, as a client reads it: sizes from 0.28 mm pixels (SE 1.1)."""
    root = ET.fromstring(text)
    assert root.tag == "{http://www.opengis.net/sld}StyledLayerDescriptor" and root.get("version") == "1.1.0"
    assert root.findtext("sld:NamedLayer/se:Name", namespaces=_SLD) == layer
    rules = root.findall("sld:NamedLayer/sld:UserStyle/se:FeatureTypeStyle/se:Rule", _SLD)
    assert len(rules) == 1
    sym = next(iter(rules[0].findall("*")[1:]))  # after its se:Name
    kind = sym.tag.split("}")[1]
    where = sym.find("se:Graphic/se:Mark", _SLD) if kind == "PointSymbolizer" else sym

    def params(tag: str) -> dict[str, str]:
        el = where.find(f"se:{tag}", _SLD)
        return {} if el is None else {p.get("name"): p.text for p in el.findall("se:SvgParameter", _SLD)}

    fill, stroke = params("Fill"), params("Stroke")
    if kind == "PointSymbolizer":
        assert where.findtext("se:WellKnownName", namespaces=_SLD) == "circle"
    size = sym.findtext("se:Graphic/se:Size", namespaces=_SLD)
    return (kind, fill.get("fill"), round(float(fill["fill-opacity"]), 2) if fill else None,
            stroke["stroke"], round(float(stroke["stroke-opacity"]), 2), round(float(stroke["stroke-width"]) * 0.28, 2),
            None if size is None else round(float(size) * 0.28, 2))


def test_counts_match_the_plan(written) -> None:
    _, plan, out = written
    path = out / "plan.gpkg"
    n = len(plan.stations.ids)
    assert pyogrio.read_info(path, layer="stations")["features"] == n
    assert pyogrio.read_info(path, layer="footprints")["features"] == n
    assert pyogrio.read_info(path, layer="strips")["features"] == len(plan.route.runs)
    assert pyogrio.read_info(path, layer="route")["features"] == max(1, len(plan.sorties))
    _, _, _, fields = pyogrio.raw.read(path, layer="stations", columns=["id"], read_geometry=False)
    assert list(fields[0]) == list(plan.stations.ids)


def test_route_is_each_sortie_file_in_flight_order(written) -> None:
    """Each route line: the launch point, then every position item of the sortie's .waypoints
    file in its order, then the launch point; its z (3-D plans) is the file's home altitude
    plus the item's altitude above home."""
    name, plan, out = written
    _, geoms, fields = pyogrio.raw.read(out / "plan.gpkg", layer="route")[1:]
    files = sorted(out.glob("sortie-*.waypoints")) or [out / "mission.waypoints"]
    assert len(geoms) == len(files)
    for wkb, f in zip(geoms, files):
        line = shapely.from_wkb(wkb)
        rows = _wpl_rows(f)
        home = rows[0]
        home_alt = float(home[10])
        # position items after the takeoff (NAV_WAYPOINT = 16), in order
        wps = [r for r in rows[1:] if r[3] == "16"]
        coords = np.array(line.coords)
        assert coords.shape[0] == len(wps) + 2
        got = coords[1:-1]
        want = np.array([[float(r[9]), float(r[8])] for r in wps])
        np.testing.assert_allclose(got[:, :2], want, atol=1e-7)
        np.testing.assert_allclose(coords[0, :2], [float(home[9]), float(home[8])], atol=1e-7)
        np.testing.assert_allclose(coords[-1, :2], coords[0, :2])
        if name == "forest-dem":
            assert all(r[2] == "3" for r in wps)  # relative frame: heights above home
            np.testing.assert_allclose(got[:, 2], [home_alt + float(r[10]) for r in wps], atol=0.02)


def test_same_plan_same_bytes(written, tmp_path) -> None:
    name, plan, out = written
    write_outputs(plan, _spec(name), tmp_path / "again", gpkg=True)
    assert (tmp_path / "again" / "plan.gpkg").read_bytes() == (out / "plan.gpkg").read_bytes()


def test_manifest_lists_the_package_hash(written) -> None:
    import hashlib
    import json

    _, _, out = written
    outputs = json.loads((out / "manifest.json").read_text())["outputs"]
    assert outputs["plan.gpkg"] == hashlib.sha256((out / "plan.gpkg").read_bytes()).hexdigest()


def test_control_points_are_the_rules_proposals(written) -> None:
    """The gcps and check_points layers hold the points the rule profiles propose, where they are."""
    from aerosurvey.outputs import render_outputs

    name, plan, out = written
    spec = _spec(name)
    ev = render_outputs(plan, spec).evidence
    points = ev.points if ev is not None else []
    for layer, role in (("gcps", "gcp"), ("check_points", "check")):
        _, _, geoms, fields = pyogrio.raw.read(out / "plan.gpkg", layer=layer, columns=["id"])
        want = [p for p in points if p.role == role]
        assert list(fields[0]) == [p.id for p in want]
        for wkb, p in zip(geoms, want):
            g = shapely.from_wkb(wkb)
            x, y = plan.site.planar.forward(g).coords[0]
            assert abs(x - p.x) < 0.01 and abs(y - p.y) < 0.01
    if spec.profiles:
        assert any(p.role == "gcp" for p in points)


def test_plan_geojson_splits_by_role_in_gdal(written) -> None:
    """plan.geojson stays one collection of mixed geometry; GDAL reads its `role` field, and each
    role selects features of one geometry type (`ogr2ogr -where "role='station'"`)."""
    _, _, out = written
    path = out / "plan.geojson"
    _, _, _, fields = pyogrio.raw.read(path, columns=["role"], read_geometry=False)
    roles = set(fields[0])
    assert {"area", "line", "station", "footprint", "home"} <= roles
    total = 0
    for role in roles:
        _, _, geoms, _ = pyogrio.raw.read(path, columns=["role"], where=f"role = '{role}'")
        kinds = {shapely.from_wkb(g).geom_type for g in geoms}
        assert len(kinds) == 1 or kinds <= {"Polygon", "MultiPolygon"}, (role, kinds)
        total += len(geoms)
    assert total == pyogrio.read_info(path)["features"]


def test_a_plan_without_sorties_has_one_route_from_home(spec_factory, tmp_path) -> None:
    spec = load_spec(spec_factory())
    plan = plan_from_files(spec)
    assert not plan.sorties
    write_outputs(plan, spec, tmp_path / "o", gpkg=True)
    path = tmp_path / "o" / "plan.gpkg"
    _, _, geoms, fields = pyogrio.raw.read(path, layer="route")
    assert list(fields[0]) == ["mission"]
    rows = _wpl_rows(tmp_path / "o" / "mission.waypoints")
    coords = np.array(shapely.from_wkb(geoms[0]).coords)
    want = [[float(r[9]), float(r[8])] for r in rows[1:] if r[3] == "16"]
    np.testing.assert_allclose(coords[1:-1], want, atol=1e-7)
    _, _, _, lp = pyogrio.raw.read(path, layer="launch_points", read_geometry=False)
    assert len(lp[0]) == max(1, len(plan.launch.sites))
