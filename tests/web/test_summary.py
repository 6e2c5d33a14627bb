"""One summary: `plan`'s stdout, `check`'s (text and JSON), preview.svg and the web API show the
same figures (height, GSD, spacing, photos, time, sorties, rules) for a plan, and the rule count
is the manifest's; `plan` names the `check` command that works for its plan; -q prints nothing.

Each view is read with its own pattern here (no code shared with the summary's writer), and the
figures are compared by meaning, with the manifest as the independent record."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main

REPO = Path(__file__).resolve().parents[2]
FIGURES = ("height", "gsd", "spacing", "photos", "time", "sorties", "rules")


def _from_text(text: str) -> dict:
    """The figures of the summary block printed by `plan` and `check`."""
    def one(pattern: str) -> re.Match:
        found = re.findall(pattern, text, re.M)
        assert len(found) == 1, (pattern, found)
        return re.search(pattern, text, re.M)

    gsd = one(r"^  GSD\s+([\d.]+)\.\.([\d.]+) cm")
    rules = one(r"^  rules\s+(\d+) evaluated: (\d+) passed, (\d+) failing")
    return {"height": float(one(r"^  height AGL\s+([\d.]+) m")[1]), "gsd": (float(gsd[1]), float(gsd[2])),
            "spacing": float(one(r"^  line spacing\s+([\d.]+) m")[1]),
            "photos": int(one(r"^  lines\s+\d+ lines in \d+ runs, (\d+) photos")[1]),
            "time": float(one(r"^  flight\s+[\d.]+ km, ([\d.]+) min estimated")[1]),
            "sorties": len(re.findall(r"^\s+S\d\d\s+\d+\s", text, re.M)),
            "rules": tuple(int(x) for x in rules.groups())}


def _from_svg(svg: str) -> dict:
    title = re.search(r">[^<>]*: ([\d.]+) m AGL, GSD (\d+\.\d+)(?:\.\.(\d+\.\d+))? cm, \d+ runs, (\d+) photos, [\d.]+ km, "
                      r"([\d.]+) min(?:, (\d+) sorties?)?<", svg)
    assert title, svg[:600]
    spacing = re.search(r"spacing ([\d.]+) m,", svg)
    rules = re.search(r">rules: (\d+) evaluated: (\d+) passed, (\d+) failing", svg)
    gsd = (float(title[2]), float(title[3] or title[2]))
    return {"height": float(title[1]), "gsd": gsd, "spacing": float(spacing[1]), "photos": int(title[4]),
            "time": float(title[5]), "sorties": int(title[6] or 0), "rules": tuple(int(x) for x in rules.groups())}


def _from_json(s: dict) -> dict:
    r = s["rules"]
    return {"height": s["height_agl_m"], "gsd": tuple(s["gsd_cm"]), "spacing": s["spacing_m"], "photos": s["photos"],
            "time": s["time_min"], "sorties": s["sorties"], "rules": (r["evaluated"], r["passed"], len(r["failing"]))}


def _plan(spec: Path, out: Path, *opts: str):
    res = CliRunner().invoke(main, [*opts, "plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return res


@pytest.fixture(scope="module")
def obratan(tmp_path_factory):
    from webutil import copy_mission

    tmp = tmp_path_factory.mktemp("summary")
    spec = copy_mission(tmp)
    out = tmp / "out folder"  # a space: the check command `plan` prints must quote it
    return spec, out, _plan(spec, out).stdout


def _cli_views(out: Path, plan_stdout: str) -> dict[str, dict]:
    """The figures as `plan`, `check`, `check --json` and preview.svg show them."""
    views = {"plan": _from_text(plan_stdout)}
    check = CliRunner().invoke(main, ["check", str(out)])
    assert check.exit_code == 0, check.output
    views["check"] = _from_text(check.stdout)
    check_json = CliRunner().invoke(main, ["check", str(out), "--json"])
    assert check_json.exit_code == 0, check_json.output
    views["check --json"] = _from_json(json.loads(check_json.stdout)["summary"])
    views["preview.svg"] = _from_svg((out / "preview.svg").read_text())
    return views


def _agree_with_the_manifest(figures: dict, manifest: dict) -> None:
    # the manifest, the plan's record: every rule it holds is counted, the planner's own included
    rules = manifest["rules"]
    assert figures["rules"] == (len(rules), sum(r["status"] == "pass" for r in rules),
                                sum(r["status"] in ("fail", "warning") for r in rules))
    assert any(r["rule"] == "uncovered-ground" for r in rules)
    assert figures["photos"] == len(manifest["stations"]) and figures["sorties"] == len(manifest["sorties"])
    d = manifest["derived"]
    assert figures["height"] == round(d["height_agl_m"], 1)
    assert figures["gsd"] == (round(d["gsd_min_cm"], 2), round(d["gsd_max_cm"], 2))
    assert figures["time"] == round(manifest["estimates"]["total_time_s"] / 60, 1)


def test_plan_check_preview_and_web_show_the_same_figures(obratan):
    from webutil import client, run_plan

    spec, out, plan_stdout = obratan
    views = _cli_views(out, plan_stdout)
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        assert st["state"] == "done", st
        views["web"] = _from_json(st["result"]["summary"])
    expected = views["plan"]
    for name, figures in views.items():
        assert figures == expected, name
    _agree_with_the_manifest(expected, json.loads((out / "manifest.json").read_text()))
    assert expected["rules"][0] == 14 and expected["sorties"] == 5


@pytest.mark.parametrize("example", ["forest-dem", "kubad-abad-fixed-wing"])
def test_the_other_examples_show_the_same_figures_everywhere(example, tmp_path):
    out = tmp_path / example
    views = _cli_views(out, _plan(REPO / "missions" / f"{example}.toml", out).stdout)
    for name, figures in views.items():
        assert figures == views["plan"], name
    _agree_with_the_manifest(views["plan"], json.loads((out / "manifest.json").read_text()))


@pytest.mark.parametrize("example", ["obratan-72ha", "kubad-abad-fixed-wing"])
def test_plan_names_a_check_command_that_works(example, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = Path("out dir") / example
    stdout = _plan(REPO / "missions" / f"{example}.toml", out).stdout
    hint = re.search(r"\(`(aerosurvey check [^`]+)` for the evidence\)", stdout)
    assert hint, stdout
    args = shlex.split(hint[1])
    assert args[:2] == ["aerosurvey", "check"]
    res = CliRunner().invoke(main, args[1:])
    assert res.exit_code == 0, res.output
    assert _from_text(res.stdout)["rules"] == _from_text(stdout)["rules"]


def test_quiet_prints_nothing_on_success(tmp_path):
    res = _plan(REPO / "missions" / "kubad-abad-fixed-wing.toml", tmp_path / "out", "-q")
    assert (res.stdout, res.stderr) == ("", "")
    assert (tmp_path / "out" / "manifest.json").exists()
    res = CliRunner().invoke(main, ["-q", "check", str(tmp_path / "out")])  # no profile: the warning is left out too
    assert (res.exit_code, res.stdout, res.stderr) == (0, "", "")


def test_a_failing_check_names_its_rules_on_stderr_also_with_quiet(tmp_path):
    out = tmp_path / "out"
    _plan(REPO / "missions" / "kubad-abad-fixed-wing.toml", out)  # flies at 158.9 m above the ground
    res = CliRunner().invoke(main, ["check", str(out), "--profile", "us-part107"])
    assert res.exit_code == 1
    assert "FAIL part107-height" in res.stdout and "rules           2 evaluated: 1 passed, 1 failing (part107-height)" in res.stdout
    assert res.stderr.strip().splitlines() == [f"Error: {out}: rules failing at error level: part107-height"]
    quiet = CliRunner().invoke(main, ["-q", "check", str(out), "--profile", "us-part107"])
    assert (quiet.exit_code, quiet.stdout, quiet.stderr) == (1, "", res.stderr)


def _faces_from_text(text: str) -> dict:
    agl = re.search(r"^  photos taken\s+([\d.]+)\.\.([\d.]+) m above the ground \([^)]*\), none straight down$", text, re.M)
    gsd = re.search(r"^  GSD on faces\s+([\d.]+)\.\.([\d.]+) cm$", text, re.M)
    assert agl and gsd, text
    assert not re.search(r"^  (height AGL|GSD)\s{2,}", text, re.M), text  # no nadir figure of a plan with no nadir photo
    return {"agl": (float(agl[1]), float(agl[2])), "gsd": (float(gsd[1]), float(gsd[2]))}


def _faces_from_svg(svg: str) -> dict:
    title = re.search(r">[^<>]*: photos (\d+\.\d)\.\.(\d+\.\d) m AGL, GSD on faces (\d+\.\d\d)(?:\.\.(\d+\.\d\d))? cm, \d+ runs", svg)
    assert title, svg[:600]
    return {"agl": (float(title[1]), float(title[2])), "gsd": (float(title[3]), float(title[4] or title[3]))}


def _faces_from_json(s: dict) -> dict:
    f = s["faces"]
    assert f["nadir_photos"] == 0
    return {"agl": tuple(f["station_agl_m"]), "gsd": tuple(f["gsd_cm"])}


@pytest.mark.parametrize("example", ["long-wall", "quarry-3-benches"])
def test_a_structure_is_summed_up_by_its_photos_heights_and_its_faces_everywhere(example, tmp_path):
    """A facade and a quarry take no photo straight down: `plan`, `check`, `check --json`, preview.svg and
    the web API give the heights the photos are taken at and the GSD on the faces (the manifest's `faces`
    record, itself checked against the stations' heights here), never the stand-off's nadir figures."""
    from webutil import client, copy_mission, run_plan

    spec = copy_mission(tmp_path, example)
    out = tmp_path / "out"
    views = {"plan": _faces_from_text(_plan(spec, out).stdout)}
    check = CliRunner().invoke(main, ["check", str(out)])
    views["check"] = _faces_from_text(check.stdout)
    check_json = CliRunner().invoke(main, ["check", str(out), "--json"])
    views["check --json"] = _faces_from_json(json.loads(check_json.stdout)["summary"])
    views["preview.svg"] = _faces_from_svg((out / "preview.svg").read_text())
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        assert st["state"] == "done", st
        views["web"] = _faces_from_json(st["result"]["summary"])
    manifest = json.loads((out / "manifest.json").read_text())
    heights = [s["agl_m"] for s in manifest["stations"]]
    expected = {"agl": (round(min(heights), 1), round(max(heights), 1)),
                "gsd": tuple(round(g, 2) for g in manifest["faces"]["gsd_cm"])}
    assert expected["agl"][0] < expected["agl"][1]  # the photos are taken at many heights, the stand-off's is one
    for name, figures in views.items():
        assert figures == expected, name
