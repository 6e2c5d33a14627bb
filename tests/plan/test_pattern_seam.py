"""The pattern seam: a pattern is its module and one registry entry.

A scratch pattern written here, in the test only (nothing else in the code names it), is
registered and planned end to end through the command line: the spec reads its own field, the
sensor takes its footprint, the manifest records its parameters and is read back, the writers
branch on its passes' shape (strips: no QGroundControl Survey item; a strip that is no offset
of a polyline stays plain items), the page is offered its field. No kind is tested by name
outside its own module: `test_no_kind_is_named_outside_its_module` reads the sources.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from click.testing import CliRunner
from shapely.geometry.base import BaseGeometry
from tests.conftest import make_spec

from aerosurvey.cli import main
from aerosurvey.plan import pattern as registry
from aerosurvey.plan.bounds import GridBounds, covered, grid_bounds
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.passes import Pass
from aerosurvey.plan.polyline import stations_along, strips_clear_of
from aerosurvey.plan.sensor import Footprint, nadir_footprint
from aerosurvey.plan.site import Site
from aerosurvey.spec import FlightSpec, MissionSpec


@dataclass(frozen=True)
class Diagonals:
    """Scratch pattern: `count` strips along the area's diagonal, each bent once at the middle."""

    count: int

    kind: ClassVar[str] = "diagonals"
    title: ClassVar[str] = "diagonal strips (a test's scratch pattern)"
    area_is_centreline: ClassVar[bool] = False
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = (Field("count", "Strips", "number", 2.0, lo=1.0, hi=5.0),)

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        return None, None

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return None

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> int:
        return int(values["count"])

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Diagonals:
        assert isinstance(spec.pattern.options, int)
        return cls(spec.pattern.options)

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Any) -> Footprint:
        return nadir_footprint(spec, heights)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Any, sensor: Any, layout: Layout) -> GridBounds:
        return grid_bounds(covered(site.area, layout.margin_m, site.grid_scale), site.grid_scale, sensor.across_m,
                           sensor.spacing_m, sensor.base_m, sensor.side_images_per_point, 1)

    @classmethod
    def parameters(cls, plan: Any) -> dict[str, Any]:
        return {"count": plan.pattern.options}

    def layouts(self, site: Any, sensor: Any, report: Any) -> Iterator[Layout]:
        x0, y0, x1, y1 = site.area.bounds
        k = site.grid_scale
        strips = []
        for line in range(self.count):
            dy = (line - (self.count - 1) / 2.0) * sensor.spacing_m * k
            path = np.array([[x0, y0 + dy], [(x0 + x1) / 2 + 0.3 * (x1 - x0), (y0 + y1) / 2 + dy], [x1, y1 + dy]])

            def own_metres(a: np.ndarray, b: np.ndarray) -> np.ndarray:
                return np.hypot(*(b - a).T) / k

            length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
            at = stations_along(path, own_metres, sensor.base_m, length, None, 0.1)
            strips += strips_clear_of(line, 0, 0, path, at, site.zones_buffered, 0.0)
        yield Layout(45.0, "a test's diagonals", (Pass(1, strips=tuple(strips)),), site.area, 0.0, check_exactly=site.area)


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


@pytest.fixture
def diagonals(monkeypatch):
    monkeypatch.setitem(registry.PATTERNS, Diagonals.kind, Diagonals)  # type: ignore[index]
    return Diagonals


def test_a_pattern_is_its_module_and_one_registry_entry(tmp_path: Path, diagonals) -> None:
    spec = make_spec(tmp_path, {"pattern": {"kind": "diagonals", "count": 3}})
    out = tmp_path / "plan"
    code, text = _run("plan", spec, "-o", out)
    assert code in (0, 1), text
    m = json.loads((out / "manifest.json").read_text())
    assert m["pattern"]["kind"] == "diagonals" and m["pattern"]["parameters"] == {"count": 3}
    assert {s["line"][:6] for s in m["stations"]} == {"P1-L00"}
    assert len({s["line"] for s in m["stations"]}) == 3
    # read back as any reader does
    code, text = _run("check", out)
    assert code in (0, 1), text
    # the writers branch on the pass's shape: strips that bend are never a Survey item
    plan = json.loads((out / "mission.plan").read_text())
    kinds = {i.get("complexItemType") for i in plan["mission"]["items"] if i["type"] == "ComplexItem"}
    assert "survey" not in kinds
    # the spec refuses a value out of the field's range, naming it
    (tmp_path / "bad").mkdir()
    bad = make_spec(tmp_path / "bad", {"pattern": {"kind": "diagonals", "count": 9}})
    code, text = _run("plan", bad, "-o", tmp_path / "bad-out")
    assert code == 2 and "pattern.count" in text


def test_the_page_is_offered_every_registered_pattern_with_its_fields(diagonals) -> None:
    table = {p["kind"]: p for p in registry.field_table()}
    assert set(table) == set(registry.PATTERNS)
    assert table["diagonals"]["fields"][0]["key"] == "count" and table["diagonals"]["fields"][0]["max"] == 5.0
    keys = {kind: [f["key"] for f in table[kind]["fields"]] for kind in ("facade", "faces")}
    assert {"standoff_m", "base_m", "top_m", "side", "pitch_deg", "max_gsd_cm"} <= set(keys["facade"])
    assert {"face_angle_deg", "face_height_m", "benches", "berm_m"} <= set(keys["faces"]) and table["faces"]["area_is_centreline"]


def test_each_registry_entry_is_the_pattern_of_its_kind() -> None:
    """The registry names each pattern's module (imported when the pattern is first asked for):
    the class found there says the kind it is registered under."""
    assert list(registry.PATTERNS) == ["area", "corridor", "oblique", "smart-oblique", "orbit", "facade", "faces"]
    for kind, pattern in registry.PATTERNS.items():
        assert pattern.kind == kind and registry.kind_of(kind) is pattern


def test_an_unknown_kind_is_refused_naming_the_registry(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, {"pattern": {"kind": "spiral"}})
    code, text = _run("plan", spec, "-o", tmp_path / "out")
    assert code == 2
    assert "pattern.kind" in text and all(k in text for k in registry.PATTERNS)


SRC = Path(__file__).resolve().parents[2] / "src" / "aerosurvey"


def test_no_kind_is_named_outside_its_module() -> None:
    """A kind's name in quotes (as code compares it) appears only in its own pattern module and the
    registry's docstring; messages may name a kind (pattern.kind = 'area'), comparisons may not."""
    own = {"area": "area_grid.py", "corridor": "corridor.py", "oblique": "oblique.py", "facade": "faces.py", "faces": "faces.py"}
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for kind, module in own.items():
            for hit in re.finditer(rf"""(==|!=|\bin)\s*\(?[^\n]*["']{kind}["']""", text):
                line = text[:hit.start()].count("\n") + 1
                code_line = text.splitlines()[line - 1]
                if "pattern" not in code_line and "kind" not in code_line:
                    continue
                assert path.name == module, f"{path.relative_to(SRC)}:{line} tests pattern kind {kind!r} by name: {code_line.strip()}"
