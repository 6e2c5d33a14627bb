"""What a campaign learns (`campaign report`): the fit of RMSE against GSD recovers a known slope within its stated
interval at the stated rate (Monte Carlo, seeded); a campaign whose accepted blocks carry real `qa accuracy` verdicts
reports their figures, the ratios' spread and a suggestion that meets the class; bad verdict files get one line."""

from __future__ import annotations

import json
import math
from pathlib import Path

import campaigncase as cc
import jsonschema
import numpy as np
import pytest
from click.testing import CliRunner

from aerosurvey.campaign.learn import line_fit
from aerosurvey.cli import main


def test_line_fit_recovers_a_known_slope_at_the_stated_rate():
    """RMSE = k GSD + normal noise, 12 blocks at GSDs of 1.5 to 6 cm, 400 seeded campaigns: the stated 95 % interval
    of the slope holds k in 95 % of them (within 3.5 binomial standard errors), and the slope and its standard error
    are those of the textbook formulas (computed here with numpy alone)."""
    rng = np.random.default_rng(38)
    k, sigma, n, trials = 0.8, 0.4, 12, 400
    held = 0
    for t in range(trials):
        gsd = rng.uniform(1.5, 6.0, n)
        rmse = k * gsd + rng.normal(0.0, sigma, n)
        fit = line_fit(gsd, rmse)
        assert fit is not None and fit["level"] == 0.95 and fit["n"] == n
        lo, hi = fit["slope_interval"]
        held += lo <= k <= hi
        if t < 20:
            slope, intercept = np.polyfit(gsd, rmse, 1)
            sxx = float(np.sum((gsd - gsd.mean()) ** 2))
            s2 = float(np.sum((rmse - (intercept + slope * gsd)) ** 2)) / (n - 2)
            assert fit["slope"] == pytest.approx(slope, rel=1e-9) and fit["intercept_cm"] == pytest.approx(intercept, abs=1e-9)
            assert fit["slope_se"] == pytest.approx(math.sqrt(s2 / sxx), rel=1e-9)
            assert fit["intercept_se_cm"] == pytest.approx(math.sqrt(s2 * (1 / n + gsd.mean() ** 2 / sxx)), rel=1e-9)
            assert (hi - lo) / 2 / fit["slope_se"] == pytest.approx(2.228, abs=1e-3)  # Student's t, 10 dof, 97.5 %
    rate = held / trials
    assert abs(rate - 0.95) <= 3.5 * math.sqrt(0.95 * 0.05 / trials), rate
    assert line_fit([2.0, 2.0, 2.0], [1.0, 2.0, 3.0]) is None and line_fit([1.0, 2.0], [1.0, 2.0]) is None


def _accuracy(folder: Path, name: str, rmse_cm: tuple[float, float, float], gcps: int, class_h: float, class_v: float) -> Path:
    """`qa accuracy -o` on 20 check points whose residuals have exactly these RMSEs, and `gcps` control points."""
    rng = np.random.default_rng(len(name) + int(rmse_cm[0] * 100))
    rows = ["id,role,dx_cm,dy_cm,dz_cm"]
    cols = []
    for r in rmse_cm:
        e = rng.normal(0, 1, 20)
        cols.append(e * r / math.sqrt(float(np.mean(e**2))))
    rows += [f"C{i},check,{float(cols[0][i])!r},{float(cols[1][i])!r},{float(cols[2][i])!r}" for i in range(20)]
    rows += [f"G{i},control,0.1,0.1,0.1" for i in range(gcps)]
    csv = folder / f"{name}.csv"
    csv.write_text("\n".join(rows) + "\n")
    out = folder / f"qa-{name}"
    res = CliRunner().invoke(main, ["qa", "accuracy", str(csv), "--class-h", str(class_h), "--class-v", str(class_v),
                                    "-o", str(out)])
    assert (out / "accuracy.json").is_file(), res.output
    return out


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("learn")
    gsd = {0: 1.0, 1: 1.5, 2: 2.0, 3: 2.8, 4: 2.5}
    blocks = cc.write_blocks(folder / "blocks.geojson", 5, props={i: {"gsd_cm": g} for i, g in gsd.items()})
    out = folder / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(out), "--spec", str(cc.write_template(folder)),
                                    "--workers", "1"])
    assert res.exit_code == 0, res.output
    return out


RATIOS = {"t00": (0.9, 1.1, 1.6), "t01": (1.0, 0.9, 1.5), "t02": (0.8, 0.85, 1.4), "t03": (1.2, 1.0, 1.9)}
GSD = {"t00": 1.0, "t01": 1.5, "t02": 2.0, "t03": 2.8}
GCPS = {"t00": 5, "t01": 4, "t02": 6, "t03": 3}


def test_report_of_accepted_blocks_with_their_verdicts(campaign, tmp_path):
    def record(*args: str) -> str:
        res = CliRunner().invoke(main, ["campaign", "record", str(campaign), *args])
        return f"{res.exit_code} {res.output}"

    for name, ratio in RATIOS.items():
        rmse = tuple(r * GSD[name] for r in ratio)
        acc = _accuracy(tmp_path, name, rmse, GCPS[name], 6.0, 12.0)  # type: ignore[arg-type]
        text = record(name, "qa", "--accuracy", str(acc), "--detail", "by Jana")
        assert text.startswith(f"0 {name}: qa recorded; status qa"), text
        if name != "t03":  # t03 stays at qa: not learned from
            assert record(name, "accepted").startswith("0 ")
    assert record("t04", "accepted").startswith("0 ")  # accepted without a verdict filed: counted, not learned from
    rows, events = cc.register(campaign)
    qa = next(e for e in events if e["block"] == "t00" and e["event"] == "qa")
    assert qa["detail"].startswith("asprs2014: RMSE x 0.90 y 1.10 z 1.60 cm, 20 check points, 5 control points; class h 6 cm, "
                                   "class v 12 cm: ") and qa["detail"].endswith("; by Jana")
    folders = {r["name"]: r["folder"] for r in rows}
    assert (campaign / "qa" / folders["t00"] / "accuracy.json").is_file()

    out = tmp_path / "report.json"
    res = CliRunner().invoke(main, ["campaign", "report", str(campaign), "--json", "-o", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert json.loads(res.output) == doc
    schema = json.loads((Path(__file__).parents[2] / "src/aerosurvey/data/campaign_report.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.Draft202012Validator(schema).validate(doc)
    learned = ["t00", "t01", "t02"]
    assert doc["accepted"] == 4 and doc["learned"] == 3 and [b["name"] for b in doc["blocks"]] == learned
    area = {r["name"]: r["area_ha"] for r in rows}
    for b in doc["blocks"]:
        name = b["name"]
        assert b["gsd_cm"] == pytest.approx(GSD[name])
        for axis, r in zip("xyz", RATIOS[name]):
            assert b[f"rmse_{axis}_cm"] == pytest.approx(r * GSD[name], rel=1e-6)
        assert b["gcp_per_ha"] == pytest.approx(GCPS[name] / area[name]) and b["relief_m"] is None  # no DEM
    assert doc["class_h_cm"] == 6.0 and doc["class_v_cm"] == 12.0 and doc["gsd_flown_cm"] == pytest.approx([1.0, 2.0])
    for k, axis in enumerate("xyz"):
        ratios = sorted(RATIOS[n][k] for n in learned)
        fig = doc["axes"][axis]
        assert fig["n"] == 3 and fig["ratio"]["median"] == pytest.approx(ratios[1], rel=1e-6)
        assert ratios[0] <= fig["ratio"]["q25"] <= fig["ratio"]["median"] <= fig["ratio"]["q75"] <= ratios[2] + 1e-9
        assert ratios[1] <= fig["ratio"]["p95"] <= ratios[2] + 1e-9
        assert fig["line"]["n"] == 3
    s = doc["suggestion"]
    # the largest GSD whose predicted RMSE meets the class on every axis: between the worst ratio's and the p95's
    worst = min(6.0 / max(RATIOS[n][0] for n in learned), 6.0 / max(RATIOS[n][1] for n in learned),
                12.0 / max(RATIOS[n][2] for n in learned))
    assert worst <= s["gsd_cm"] + 1e-9
    assert all(s["gsd_cm"] * doc["axes"][a]["ratio"]["p95"] <= c + 1e-9 for a, c in (("x", 6.0), ("y", 6.0), ("z", 12.0)))
    assert s["within_flown"] is False and s["gcp_per_ha"] == pytest.approx(np.median([GCPS[n] / area[n] for n in learned]))
    text = CliRunner().invoke(main, ["campaign", "report", str(campaign)]).output
    assert text.startswith("3 of 4 accepted block(s) have a QA verdict") and "suggestion: GSD up to" in text
    assert "outside the GSDs flown: an extrapolation" in text


def test_bad_verdicts_get_one_line(campaign, tmp_path):
    def record(*args: str) -> str:
        res = CliRunner().invoke(main, ["campaign", "record", str(campaign), "t04", *args])
        return f"{res.exit_code} {res.output}"

    before = cc.register(campaign)
    good = json.loads((_accuracy(tmp_path, "g", (1.0, 1.0, 2.0), 2, 5.0, 10.0) / "accuracy.json").read_text())
    assert "--accuracy is given with event = 'accepted'" in record("accepted", "--accuracy", str(tmp_path / "qa-g"))
    assert "no accuracy.json there" in record("qa", "--accuracy", str(tmp_path))
    damaged = tmp_path / "damaged.json"
    damaged.write_text(json.dumps(good)[:200])
    assert "cannot be read as JSON" in record("qa", "--accuracy", str(damaged))
    for keys, value, says in ((("statistics", "x", "rmse_m"), -1.0, "statistics.x.rmse_m = -1.0 is not allowed"),
                              (("statistics", "y", "rmse_m"), "1", "statistics.y.rmse_m = '1' is not allowed"),
                              (("input", "control_points"), 2.5, "input.control_points = 2.5 is not allowed"),
                              (("settings", "class_h_cm"), float("nan"), "settings.class_h_cm = nan is not allowed"),
                              (("verdict",), None, "it has no verdict.result"),
                              (("statistics",), None, "it has no statistics.x.rmse_m")):
        doc = json.loads(json.dumps(good))
        target = doc
        for k in keys[:-1]:
            target = target[k]
        if value is None:
            del target[keys[-1]]
        else:
            target[keys[-1]] = value
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps(doc))
        text = record("qa", "--accuracy", str(bad))
        assert text.startswith("2 ") and says in text and len(text.strip().splitlines()) == 1, text
    assert cc.register(campaign) == before


def test_relief_under_each_block_from_its_dem(tmp_path):
    """With a DEM in the template each block's relief is the range of the ground under it: on a plane rising 10 m
    per 0.001 degree of latitude, a block 0.002 degrees tall has about 20 m (more by the margin the plan reads round it)."""
    import rasterio
    from rasterio.transform import from_origin

    dem = tmp_path / "dem.tif"
    res = 0.0001
    rows, cols = 200, 300
    lat = 49.41 - (np.arange(rows) + 0.5) * res
    z = np.repeat((300.0 + 10_000.0 * (lat - 49.4))[:, None], cols, axis=1).astype("float32")
    with rasterio.open(dem, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="float32", crs="EPSG:4326",
                       transform=from_origin(14.995, 49.41, res, res)) as ds:
        ds.write(z, 1)
    blocks = cc.write_blocks(tmp_path / "blocks.geojson", 2, size_deg=(0.003, 0.002))
    out = tmp_path / "campaign"
    template = cc.write_template(tmp_path, terrain={"dem": str(dem)})
    res_ = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(out), "--spec", str(template), "--workers", "1"])
    assert res_.exit_code == 0, res_.output
    for name in ("t00", "t01"):
        acc = _accuracy(tmp_path, name, (1.0, 1.0, 2.0), 4, 5.0, 10.0)
        for args in (("qa", "--accuracy", str(acc)), ("accepted",)):
            assert CliRunner().invoke(main, ["campaign", "record", str(out), name, *args]).exit_code == 0
    doc = json.loads(CliRunner().invoke(main, ["campaign", "report", str(out), "--json"]).output)
    assert [b["name"] for b in doc["blocks"]] == ["t00", "t01"]
    for b in doc["blocks"]:
        assert 19.0 <= b["relief_m"] <= 30.0, b
    assert "relief m" in CliRunner().invoke(main, ["campaign", "report", str(out)]).output
