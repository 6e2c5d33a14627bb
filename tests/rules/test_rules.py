"""Rule profiles before flight: the examples from issue 4, user profiles, malformed profiles."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.rules.checks import evaluate_formula
from aerosurvey.rules.profile import available_profiles, parse_profile

REPO = Path(__file__).resolve().parents[2]
OBRATAN = REPO / "missions" / "obratan-72ha.toml"


def _variant(tmp_path: Path, replace: dict[str, str]) -> Path:
    text = OBRATAN.read_text()
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    (tmp_path / "areas").mkdir(exist_ok=True)
    (tmp_path / "areas" / "obratan-72ha.geojson").write_text((REPO / "missions/areas/obratan-72ha.geojson").read_text())
    p = tmp_path / "variant.toml"
    p.write_text(text)
    return p


def _check(target: Path, *args: str) -> tuple[int, dict]:
    res = CliRunner().invoke(main, ["check", str(target), "--json", *args])
    assert res.exit_code in (0, 1), res.output
    return res.exit_code, {r["rule"]: r for r in json.loads(res.stdout)["results"]}


def test_obratan_passes_cz_land_consolidation():
    code, res = _check(OBRATAN)
    assert code == 0
    failed = [k for k, r in res.items() if r["status"] == "fail"]
    assert failed == []
    assert res["cz-processing"]["status"] == "not-checkable"


def test_seventy_percent_forward_overlap_fails_with_the_measured_value(tmp_path):
    code, res = _check(_variant(tmp_path, {"forward_overlap = 0.75": "forward_overlap = 0.70"}))
    assert code == 1
    r = res["cz-forward-overlap"]
    measured = float(r["measured"].split(" %")[0])
    assert r["status"] == "fail" and 70.0 <= measured < 70.5, r["measured"]


def test_ricoh_gr_fails_the_pixel_rule(tmp_path):
    code, res = _check(_variant(tmp_path, {'model = "sony-a6000-16mm"': 'model = "ricoh-gr"'}))
    assert code == 1
    assert res["cz-pixel-pitch"]["status"] == "fail" and "4.78 um" in res["cz-pixel-pitch"]["measured"]


def test_lines_stopping_at_the_boundary_fail_the_8_image_rule(tmp_path):
    code, res = _check(_variant(tmp_path, {"images_beyond_boundary = 8": "images_beyond_boundary = 0"}))
    assert code == 1
    r = res["cz-images-beyond-boundary"]
    assert r["status"] == "fail"
    assert any(e.startswith("P1-L") and "photos outside" in e for e in r["evidence"])


def test_gcp_moved_inside_fails_the_envelope_rule(tmp_path):
    out = tmp_path / "out"
    assert CliRunner().invoke(main, ["plan", str(OBRATAN), "-o", str(out)]).exit_code == 0
    assert CliRunner().invoke(main, ["gcp", str(out)]).exit_code == 0
    code, res = _check(out)
    assert code == 0 and res["cz-gcp-envelope"]["status"] == "pass"
    fc = json.loads((out / "control_points.geojson").read_text())
    gcp = next(f for f in fc["features"] if f["properties"]["role"] == "gcp")
    area = json.loads((out / "plan.geojson").read_text())["features"][0]["geometry"]
    import shapely

    c = shapely.geometry.shape(area).centroid
    gcp["geometry"]["coordinates"] = [c.x, c.y]
    (out / "control_points.geojson").write_text(json.dumps(fc))
    code, res = _check(out)
    assert code == 1
    r = res["cz-gcp-envelope"]
    assert r["status"] == "fail" and any(gcp["properties"]["id"] in e and "inside" in e for e in r["evidence"])


def test_height_profiles(tmp_path):
    code, res = _check(OBRATAN, "--profile", "eu-open", "--profile", "us-part107")
    assert code == 0 and res["eu-open-height"]["status"] == "pass"
    code, res = _check(_variant(tmp_path, {"gsd_cm = 2.5": "height_m = 125", "max_height_agl_m = 120": "max_height_agl_m = 150"}),
                       "--profile", "eu-open", "--profile", "us-part107")
    assert code == 1
    assert res["eu-open-height"]["status"] == "fail" and res["part107-height"]["status"] == "fail"


def test_asprs_profiles_count_check_points():
    code, res = _check(OBRATAN, "--profile", "asprs-2014", "--profile", "asprs-2023")
    assert res["asprs2014-check-point-count"]["required"].startswith(">= 20 horizontal and 25 vertical")
    assert res["asprs2023-check-point-count"]["required"].startswith(">= 30")
    # the layout honours the stricter minimum of the chosen profiles
    assert res["asprs2023-check-point-count"]["status"] == "pass"


USER_PROFILE = """
[profile]
id = "acme-spec"
name = "ACME company spec"

[[rules]]
id = "acme-gsd"
statement = "GSD at most 2 cm"
check = "gsd_max"
severity = "error"
source = "ACME survey handbook 4.2"
params = { max_cm = 2.0 }
"""


def test_user_profile_is_picked_up(tmp_path):
    d = tmp_path / "profiles"
    d.mkdir()
    (d / "acme.toml").write_text(USER_PROFILE)
    code, res = _check(OBRATAN, "--profile", "acme-spec", "--profile-dir", str(d))
    assert code == 1 and res["acme-gsd"]["status"] == "fail" and res["acme-gsd"]["measured"].startswith("2.50 cm")


def test_user_profile_from_environment(tmp_path, monkeypatch):
    (tmp_path / "acme.toml").write_text(USER_PROFILE.replace("max_cm = 2.0", "max_cm = 3.0"))
    monkeypatch.setenv("AEROSURVEY_PROFILES", str(tmp_path))
    assert "acme-spec" in available_profiles()
    code, res = _check(OBRATAN, "--profile", "acme-spec")
    assert code == 0 and res["acme-gsd"]["status"] == "pass"


@pytest.mark.parametrize("change,needle", [
    ('check = "gsd_max"', "field 'check' = 'gsd_maximum' is not a known check"),
    ('severity = "error"', "field 'severity' = 'fatal'"),
    ("params = { max_cm = 2.0 }", "parameter 'max_cm' = 'two' must be"),
    ('statement = "GSD at most 2 cm"', "field 'statement' is missing"),
])
def test_malformed_profile_names_file_rule_and_field(tmp_path, change, needle):
    bad = {
        'check = "gsd_max"': 'check = "gsd_maximum"',
        'severity = "error"': 'severity = "fatal"',
        "params = { max_cm = 2.0 }": 'params = { max_cm = "two" }',
        'statement = "GSD at most 2 cm"': "",
    }[change]
    f = tmp_path / "bad.toml"
    f.write_text(USER_PROFILE.replace(change, bad))
    with pytest.raises(InputError) as exc:
        parse_profile(f.read_text(), str(f))
    msg = str(exc.value)
    assert str(f) in msg and "acme-gsd" in msg and needle in msg


def test_override_from_the_spec(tmp_path):
    p = _variant(tmp_path, {'profiles = ["cz-land-consolidation"]':
                            'profiles = ["cz-land-consolidation"]\noverrides = { "cz-gsd.max_cm" = 2.0 }'})
    code, res = _check(p)
    assert code == 1 and res["cz-gsd"]["status"] == "fail" and "overridden" in res["cz-gsd"]["source"]


def test_no_profile_checks_the_planners_rules_and_lists_the_profiles(tmp_path):
    p = _variant(tmp_path, {'profiles = ["cz-land-consolidation"]': "profiles = []"})
    res = CliRunner().invoke(main, ["check", str(p)])
    assert res.exit_code == 0, res.output
    assert "PASS uncovered-ground" in res.stdout and "rules           1 evaluated: 1 passed, 0 failing" in res.stdout
    warning = [ln for ln in res.stderr.splitlines() if "no rule profile chosen" in ln]
    assert len(warning) == 1 and "asprs-2014, asprs-2023, cz-land-consolidation, eu-open, us-part107" in warning[0]


def test_formula_is_restricted():
    assert evaluate_formula("ceil(n_images / 100) + 1", n_images=903) == 11
    with pytest.raises(InputError, match="may use only"):
        evaluate_formula("__import__('os').system('true')", n_images=1)


@pytest.mark.parametrize("text", ["+n_images", "not n_images", "~n_images"])
def test_formula_with_another_unary_operator_is_bad_input(text):
    with pytest.raises(InputError, match="may use only"):
        evaluate_formula(text, n_images=903)
    assert evaluate_formula("-n_images + 1000", n_images=903) == 97


def _gsd_profile(folder: Path, max_cm: float) -> Path:
    d = folder / "profiles"
    d.mkdir(exist_ok=True)
    (d / "acme.toml").write_text(USER_PROFILE.replace("max_cm = 2.0", f"max_cm = {max_cm}"))
    return d


def test_the_gsd_of_a_tilted_photo_is_taken_at_its_centre_not_straight_down(tmp_path):
    """The oblique example's photos at −45°: at the image centre the ground is √2 farther and met at 45°, so the
    GSD there is twice the straight-down figure of the same height (worked here from the manifest's camera and
    stations). A limit between the two fails on the tilted photos, naming them, and passes above the centre GSD."""
    out = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(REPO / "missions" / "oblique-block.toml"), "-o", str(out)]).exit_code in (0, 1)
    raw = json.loads((out / "manifest.json").read_text())
    cam = raw["camera"]
    per_m = 100.0 * cam["sensor_mm"][0] / cam["image_px"][0] / cam["focal_mm"]
    tilted = [s for s in raw["stations"] if s["pitch_deg"] > -89.0]
    assert tilted, "the example tilts its camera"
    down = [s["agl_m"] * per_m for s in raw["stations"]]
    centre = [s["agl_m"] * per_m / math.sin(math.radians(-s["pitch_deg"])) ** 2 for s in raw["stations"]]
    limit = round((max(down) + max(centre)) / 2.0, 2)
    assert max(down) < limit < max(centre)
    code, res = _check(out, "--profile", "acme-spec", "--profile-dir", str(_gsd_profile(tmp_path, limit)))
    rule = res["acme-gsd"]
    assert rule["status"] == "fail" and rule["measured"] == f"{max(centre):.2f} cm (coarsest photo)"
    named = {w["station"] for w in rule["where"]}
    assert named == {s["id"] for s, c in zip(raw["stations"], centre) if c > limit + 1e-6} and named <= {s["id"] for s in tilted}
    code, res = _check(out, "--profile", "acme-spec", "--profile-dir", str(_gsd_profile(tmp_path, round(max(centre) + 0.01, 2))))
    assert res["acme-gsd"]["status"] == "pass"


def test_the_ground_gsd_of_a_plan_whose_photos_all_look_level_is_not_checkable(tmp_path):
    out = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(REPO / "missions" / "long-wall.toml"), "-o", str(out)]).exit_code in (0, 1)
    assert all(s["pitch_deg"] == 0.0 and s["gsd_cm"] is None for s in json.loads((out / "manifest.json").read_text())["stations"])
    _, res = _check(out, "--profile", "acme-spec", "--profile-dir", str(_gsd_profile(tmp_path, 2.0)))
    assert res["acme-gsd"]["status"] == "not-checkable"


def test_ground_profiles_judge_a_facade_without_failing_themselves(tmp_path):
    """A facade's photos look level: the ground-mapping profiles' control point layouts find no ground to place
    check points on (the hexagonal grid of an empty region), and their rules report it (exit 1, rules named),
    where `check` stopped on a traceback before."""
    out = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(REPO / "missions" / "long-wall.toml"), "-o", str(out)]).exit_code in (0, 1)
    for profile in ("cz-land-consolidation", "asprs-2023"):
        code, res = _check(out, "--profile", profile)
        assert code == 1, profile
        assert any(r["status"] == "fail" for r in res.values()), profile
        assert all(r["status"] in ("pass", "fail", "warning", "info", "not-checkable") for r in res.values()), res
