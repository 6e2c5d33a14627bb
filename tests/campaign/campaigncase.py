"""A small campaign for the tests: tiny blocks, a template, and two campaign folders compared by meaning.

Shares no code with aerosurvey.campaign: blocks are written as plain GeoJSON, folders are read
with json and by splitting the .waypoints rows, the register with pyogrio.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyogrio
import tomli_w

TEMPLATE = {
    "mission": {"name": "template"},
    "camera": {"model": "sony-a6000-16mm"},
    "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.6},
    "vehicle": {"type": "copter", "cruise_speed_ms": 10.0},
}


def write_template(folder: Path, **tables: dict) -> Path:
    spec = json.loads(json.dumps(TEMPLATE))
    for table, values in tables.items():
        spec.setdefault(table, {}).update(values)
    path = folder / "template.toml"
    path.write_text(tomli_w.dumps(spec))
    return path


def write_blocks(path: Path, n: int, size_deg: tuple[float, float] = (0.0015, 0.001),
                 props: dict[int, dict] | None = None) -> Path:
    """`n` rectangles near 49.4 N 15.0 E in rows of 6, named t00 …, each ~1.2 ha by default."""
    feats = []
    for i in range(n):
        x = 15.0 + (i % 6) * size_deg[0] * 1.3
        y = 49.4 + (i // 6) * size_deg[1] * 1.3
        ring = [[x, y], [x + size_deg[0], y], [x + size_deg[0], y + size_deg[1]], [x, y + size_deg[1]], [x, y]]
        feats.append({"type": "Feature", "properties": {"name": f"t{i:02d}", **(props or {}).get(i, {})},
                      "geometry": {"type": "Polygon", "coordinates": [ring]}})
    path.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return path


def planned_campaign(folder: Path, n: int, *options: str) -> Path:
    """FOLDER/campaign: `n` blocks of 0.003 x 0.002 degrees (blocks.geojson) planned with the template
    (template.toml) through the command line on one worker, with `options`."""
    from click.testing import CliRunner

    from aerosurvey.cli import main

    blocks = write_blocks(folder / "blocks.geojson", n, size_deg=(0.003, 0.002))
    out = folder / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(out), "--spec", str(write_template(folder)),
                                    "--workers", "1", *options])
    assert res.exit_code == 0, res.output
    return out


def block_folders(campaign: Path) -> dict[str, Path]:
    """Block name → its folder (asserting there is exactly one folder per name, no temporary one)."""
    folders = sorted((campaign / "blocks").iterdir())
    hidden = [p.name for p in folders if p.name.startswith(".")]
    assert not hidden, f"temporary folders left: {hidden}"
    names = [p.name.split(".")[0] for p in folders]
    assert len(set(names)) == len(names), f"a block written twice: {names}"
    return dict(zip(names, folders))


def _waypoints(path: Path) -> np.ndarray:
    lines = path.read_text().splitlines()
    assert lines[0] == "QGC WPL 110"
    return np.array([[float(v) for v in ln.split("\t")] for ln in lines[1:]])


def same_block(a: Path, b: Path) -> None:
    files = sorted(p.name for p in a.iterdir())
    assert files == sorted(p.name for p in b.iterdir()), (a, b)
    for name in files:
        if name.endswith(".waypoints"):
            wa, wb = _waypoints(a / name), _waypoints(b / name)
            assert wa.shape == wb.shape and np.allclose(wa, wb, rtol=0, atol=1e-9), (a / name)
        elif name.endswith((".json", ".plan")):
            assert json.loads((a / name).read_text()) == json.loads((b / name).read_text()), (a / name)
        else:
            assert (a / name).read_bytes() == (b / name).read_bytes(), (a / name)


def register(campaign: Path) -> tuple[list[dict], list[dict]]:
    """The register's blocks (geometry as WKB hex) and events without their times."""
    meta, _, wkb, values = pyogrio.raw.read(campaign / "register.gpkg", layer="blocks")
    rows = [{**{f: (v[i].item() if hasattr(v[i], "item") else v[i]) for f, v in zip(meta["fields"], values)},
             "wkb": bytes(wkb[i]).hex()} for i in range(len(wkb))]
    emeta, _, _, evalues = pyogrio.raw.read(campaign / "register.gpkg", layer="events", read_geometry=False)
    events = [{f: v[i] for f, v in zip(emeta["fields"], evalues) if f != "time"} for i in range(len(evalues[0]))]
    return rows, events


def same_campaign(a: Path, b: Path) -> None:
    """Two campaign folders hold the same blocks (each once) with the same files, and the same register."""
    fa, fb = block_folders(a), block_folders(b)
    assert sorted(fa) == sorted(fb)
    for name in fa:
        assert fa[name].name == fb[name].name  # the same key
        same_block(fa[name], fb[name])
    ra, ea = register(a)
    rb, eb = register(b)
    assert ra == rb
    key = lambda e: (e["block"], e["key"], e["event"])  # noqa: E731
    assert sorted(ea, key=key) == sorted(eb, key=key)


def prove_union_coverage(campaign: Path, blocks_ll: dict, area_ll, k_side_overlap: float = 0.6,
                         k_forward_overlap: float = 0.75) -> int:
    """From each block's mission.waypoints alone (tests/independent_coverage.py): every point of `area_ll`
    seen by as many photos of all blocks as one area's plan guarantees, and every point two blocks share
    (`blocks_ll`: name → polygon, WGS84) by that many photos of each; returns the number of shared bands."""
    import math

    import shapely

    import independent_coverage as ic
    from aerosurvey.camera import get_camera

    to_xy = ic.local_projection(area_ll.centroid.x, area_ll.centroid.y)

    def proj(g):
        return shapely.transform(g, lambda a: np.column_stack(to_xy.transform(a[:, 0], a[:, 1])))

    cam = get_camera(TEMPLATE["camera"]["model"])
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm)
    k = math.floor(1 / (1 - k_side_overlap) + 1e-9) * math.floor(1 / (1 - k_forward_overlap) + 1e-9)
    folders = block_folders(campaign)
    photos, polys = {}, {}
    for name, g in blocks_ll.items():
        home, rows = ic.read_wpl(folders[name] / "mission.waypoints")
        photos[name] = ic.replay_triggers(rows, to_xy, None, home[2])
        polys[name] = proj(g)
    gx, gy = ic.grid_inside(proj(area_ll), 80)
    total = sum(ic.footprint_counts(p, gx, gy, sensor, "landscape") for p in photos.values())
    assert total.min() >= k, f"a point of the area seen by {total.min()} photos of all blocks, need {k}"
    shared = 0
    for a in polys:
        for b in polys:
            band = shapely.intersection(polys[a], polys[b])
            if a >= b or band.area < 1.0:
                continue
            shared += 1
            bx, by = ic.grid_inside(band, 40)
            for name in (a, b):
                seen = ic.footprint_counts(photos[name], bx, by, sensor, "landscape")
                assert seen.min() >= k, f"on the band {a}/{b}, a point seen by {seen.min()} photos of {name}, need {k}"
    return shared
