"""Side overlaps measured per heading, and the GCPs the rules propose, checked against their
definitions on random footprints and on planned missions: each GCP outside the outline and the
no-go zones, within the envelope's offset of the outline, seen by as many photos as it says
(counted here on the rectangles as polygons), its note saying whether it stayed on the
envelope, moved towards the outline or is seen by too few photos."""

from __future__ import annotations

import json
import math
import re
from types import SimpleNamespace

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerosurvey.inputs import plan_from_files
from aerosurvey.rules.control_points import propose_gcps
from aerosurvey.rules.engine import Evidence, layout_settings
from aerosurvey.rules.footprints import side_overlaps
from aerosurvey.rules.load import plan_documents
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import select_profiles
from aerosurvey.spec import load_spec
from conftest import REPO, make_spec, random_polygon
from rules.rectangles import rect_footprints


def _check_gcps(gcps, area, fp, count: int, min_images: int, offset: float, max_spacing: float, nogo) -> None:
    """The GCPs as propose_gcps defines them: GCP01 … in order; at least `count` (and 3 a part of
    the envelope, one every `max_spacing` of its length); each outside the outline (the area's
    parts without their holes) and the no-go zones, at most `offset` from the outline: on the
    envelope (`offset`, less the buffer's chords) when enough photos see it there, else moved
    towards the outline (the note says how far and by how many photos), or seen by too few."""
    outline = shapely.union_all([shapely.Polygon(p.exterior) for p in shapely.get_parts(area)])
    envelope = shapely.get_parts(shapely.buffer(outline, offset, quad_segs=8))
    assert [g.id for g in gcps] == [f"GCP{k:02d}" for k in range(1, len(gcps) + 1)]
    assert all(g.role == "gcp" for g in gcps)
    assert len(gcps) >= max(count, 3 * len(envelope), sum(math.ceil(e.exterior.length / max_spacing) for e in envelope))
    rects = shapely.polygons(fp.corners)
    # quad_segs=8: the envelope's chords are at most 11.25° of arc, their middles at least this share of
    # the offset out (above the first place moved in, 19/20 of the way)
    chord = math.cos(math.radians(90 / 8))
    for g in gcps:
        seen = int(shapely.intersects_xy(rects, g.x, g.y).sum())
        if g.note.startswith("no place"):
            assert g.images == 0
            continue
        assert g.images == seen, g
        assert not shapely.contains_xy(outline, g.x, g.y) and (nogo is None or not shapely.contains_xy(nogo, g.x, g.y))
        d = shapely.distance(outline, shapely.Point(g.x, g.y))
        assert 0 < d <= offset * (1 + 1e-9) + 1e-9, g
        moved = re.fullmatch(r"moved to ([\d.]+) m outside the outline to be seen by (\d+) photos", g.note)
        short = re.match(r"seen by only (\d+) photos even at ([\d.]+) m from the outline", g.note)
        if g.note == "":
            assert g.images >= min_images and d >= offset * chord - 1e-6, g
        elif moved:
            assert int(moved[2]) == g.images >= min_images and d <= float(moved[1]) + 0.05 + 1e-6 <= offset + 0.1, g
        else:
            assert short and int(short[1]) == g.images < min_images and d <= float(short[2]) + 0.05 + 1e-6, g


def _runs_of_lines(rng: np.random.Generator, n_runs: int, headings: list[float], interleave: bool):
    """Stations along parallel lines (several runs a heading, some reversed), as run ids and footprints."""
    run_ids, xs, ys, hs = [], [], [], []
    for r in range(n_runs):
        h = headings[r % len(headings)] + (np.pi if r % 2 else 0.0) + rng.choice([0.0, rng.normal(0, 0.03)])
        k = int(rng.integers(1, 30))
        along = np.sort(rng.uniform(-300, 300, k)) + rng.normal(0, 2, k)
        off = r * 40.0 + rng.normal(0, 3)
        s, c = np.sin(h), np.cos(h)
        xs += list(along * s + off * c)
        ys += list(along * c - off * s)
        hs += list(np.full(k, h) + rng.choice([0.0, 1e-4], k))
        run_ids += [f"L{r}"] * k
    order = rng.permutation(len(run_ids)) if interleave else np.arange(len(run_ids))
    ids = [run_ids[i] for i in order]
    fp = rect_footprints(np.asarray(xs)[order], np.asarray(ys)[order], np.asarray(hs)[order],
                    rng.uniform(50, 90, len(ids)), rng.uniform(30, 70, len(ids)))
    return SimpleNamespace(run_ids=ids), fp


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_runs=st.integers(1, 12), heading=st.floats(0, 2 * np.pi), width=st.floats(30, 90),
       missing=st.integers(0, 11))
def test_side_overlap_pairs_each_run_with_its_nearest_neighbours_once(seed, n_runs, heading, width, missing):
    """Parallel runs at random offsets, one left out (a line flown without photos): every two runs
    next to each other across the lines are one pair, listed once, their overlap 1 - d / width
    with d their distance; the runs either side of the missing one are such a pair."""
    rng = np.random.default_rng(seed)
    offsets = np.sort(rng.uniform(0, 40 * n_runs, n_runs + 1))
    offsets = np.delete(offsets, missing % len(offsets))
    s, c = np.sin(heading), np.cos(heading)
    run_ids, xs, ys = [], [], []
    for r, off in enumerate(offsets):
        along = np.linspace(-300, 300, 7) + rng.uniform(-5, 5)
        xs += list(along * s + off * c)
        ys += list(along * c - off * s)
        run_ids += [f"L{r}"] * len(along)
    n = len(run_ids)
    fp = rect_footprints(np.array(xs), np.array(ys), np.full(n, heading), np.full(n, width), np.full(n, 40.0))
    pairs = side_overlaps(SimpleNamespace(run_ids=run_ids), fp)
    got = {(a, b): overlap for a, b, overlap in pairs}
    assert len(got) == len(pairs) and len({frozenset(p) for p in got}) == len(pairs)  # each pair once
    want = {(f"L{r}", f"L{r + 1}"): 1 - (offsets[r + 1] - offsets[r]) / width for r in range(len(offsets) - 1)}
    assert got.keys() == want.keys()
    for pair, overlap in want.items():
        assert got[pair] == pytest.approx(overlap, abs=1e-6)


@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["convex", "concave", "holed", "two"]),
       reach=st.floats(10, 140), min_images=st.integers(1, 12), count=st.integers(3, 12), offset=st.floats(2, 40),
       nogo=st.booleans())
def test_gcps_keep_their_definition(seed, kind, reach, min_images, count, offset, nogo):
    """Random photo rectangles over random areas (some reaching past the GCP ring, some not), with
    and without a no-go zone."""
    rng = np.random.default_rng(seed)
    if kind == "two":
        area = shapely.union(shapely.box(0, 0, 300, 200), shapely.box(500, 0, 700, 250))
    else:
        area = shapely.Polygon(np.asarray(random_polygon(kind, seed % 10_000, 300.0)[0]) * [60_000, 110_000])
        area = area if area.is_valid else area.convex_hull
    x0, y0, x1, y1 = area.bounds
    n = 400
    fp = rect_footprints(rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(0, 2 * np.pi, n),
                    rng.uniform(reach / 2, reach, n), rng.uniform(reach / 2, reach, n))
    zone = shapely.buffer(shapely.Point(x0, y1), 0.3 * (x1 - x0)) if nogo else None
    got = propose_gcps(area, fp, count, min_images, offset, 400.0, zone)
    assert got
    _check_gcps(got, area, fp, count, min_images, offset, 400.0, zone)


def test_obratan_side_overlaps_hold_and_gcps_keep_their_definition():
    loaded = load_spec(REPO / "missions" / "obratan-72ha.toml")
    manifest, features = plan_documents(plan_from_files(loaded), loaded)
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    ev = Evidence(view, layout_settings(view, select_profiles(["cz-land-consolidation"])))
    pairs = side_overlaps(view, ev.footprints)
    # every run has a parallel neighbour, each pair of neighbours is listed once, and the planned
    # spacing gives at least the asked 60 %
    assert {r for p in pairs for r in p[:2]} == set(view.run_ids)
    assert len({frozenset(p[:2]) for p in pairs}) == len(pairs) and min(p[2] for p in pairs) >= 0.6 - 1e-6
    s = ev.settings
    got = propose_gcps(view.area, ev.footprints, s.gcp_count, s.gcp_min_images, s.gcp_offset_m, s.gcp_max_spacing_m, s.nogo)
    assert len(got) >= s.gcp_count >= 17  # the profile's ceil(n_images / 100) + 1 (1,595 photos planned)
    _check_gcps(got, view.area, ev.footprints, s.gcp_count, s.gcp_min_images, s.gcp_offset_m, s.gcp_max_spacing_m, s.nogo)
    assert all(g.images >= s.gcp_min_images for g in got)  # the plan extends past the GCPs' envelope


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000), size=st.floats(200, 450),
       cross=st.booleans(), margin=st.sampled_from([0.0, 12.0]))
def test_planned_gcps_keep_their_definition(tmp_path_factory, kind, seed, size, cross, margin):
    tmp = tmp_path_factory.mktemp("exact")
    spec = make_spec(tmp, {"targets": {"images_beyond_boundary": 2, "coverage_margin_m": margin}, "flight": {"cross_hatch": cross}},
                     rings=random_polygon(kind, seed, size))
    loaded = load_spec(spec)
    manifest, features = plan_documents(plan_from_files(loaded), loaded)
    view = PlanView.from_documents(json.loads(json.dumps(manifest)), features, "test")
    ev = Evidence(view, layout_settings(view, select_profiles(["cz-land-consolidation"])))
    s = ev.settings
    args = (view.area, ev.footprints, s.gcp_count, s.gcp_min_images, s.gcp_offset_m, s.gcp_max_spacing_m, s.nogo)
    _check_gcps(propose_gcps(*args), *args)
