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
