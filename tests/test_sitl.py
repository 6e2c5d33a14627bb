"""End to end in ArduPilot SITL: the example missions fly as planned.

Marked `sitl`; skipped with the reason when no SITL binary is found (AEROSURVEY_SITL_BIN,
or arducopter/arduplane on PATH). A fake SITL (a script) checks, without ArduPilot, how the
harness passes paths, reports a SITL that fails and cleans up after it.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile

import pytest
from click.testing import CliRunner

from aerosurvey.cli import main
from conftest import REPO


def _binary(vehicle: str) -> str | None:
    name = "arduplane" if vehicle == "plane" else "arducopter"
    env = os.environ.get("AEROSURVEY_SITL_BIN")
    if env:
        path = os.path.join(env, name) if os.path.isdir(env) else env
        return path if os.access(path, os.X_OK) else None
    return shutil.which(name)


@pytest.mark.sitl
@pytest.mark.parametrize("name,vehicle", [("obratan-72ha", "copter"), ("forest-dem", "copter"),
                                          ("kubad-abad-fixed-wing", "plane")])
def test_example_flies_as_planned(name, vehicle, tmp_path):
    binary = _binary(vehicle)
    if binary is None:
        pytest.skip(f"no ArduPilot SITL {vehicle} binary: set AEROSURVEY_SITL_BIN or put it on PATH")
    out = tmp_path / name
    res = CliRunner().invoke(main, ["plan", str(REPO / "missions" / f"{name}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["sitl", "fly", str(out), "--sitl-bin", binary, "--speedup", "20"])
    report = json.loads((out / "sitl" / "sitl_report.json").read_text())
    assert res.exit_code == 0, res.output
    for row in report["sorties"]:
        assert row["completed"], row
        if row["triggers_match"] is not None:
            assert row["triggers_flown"] == row["photos_planned"], row
        assert abs(row["time_ratio"] - 1.0) <= 0.10, row
        assert (out / "sitl" / row["log"]).exists()


@pytest.mark.sitl
def test_a_resumed_flight_flies_as_planned(tmp_path):
    """The default 17 ha area cut after its 40th photo: `resume` writes the rest, and SITL takes
    exactly the stations left, each within the report's quarter base, in the estimated time."""
    from conftest import make_spec

    binary = _binary("copter")
    if binary is None:
        pytest.skip("no ArduPilot SITL copter binary: set AEROSURVEY_SITL_BIN or put it on PATH")
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}})
    out = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)]).exit_code == 0
    after = json.loads((out / "manifest.json").read_text())["stations"][39]["id"]
    resumed = tmp_path / "resume"
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), "--after", after, "-o", str(resumed)])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["sitl", "fly", str(out), "--resume", str(resumed), "--sitl-bin", binary, "--speedup", "20"])
    report = json.loads((resumed / "sitl" / "sitl_report.json").read_text())
    assert res.exit_code == 0, res.output
    planned = json.loads((resumed / "resume.json").read_text())["stations_left"]
    assert sum(row["photos_planned"] for row in report["sorties"]) == planned
    for row in report["sorties"]:
        assert row["completed"] and row["triggers_flown"] == row["photos_planned"], row
        assert abs(row["time_ratio"] - 1.0) <= 0.10, row


# ---- a fake SITL (a script): paths, failures and the temporary folder, without ArduPilot ------------

FAKE = """#!{python}
import os, sys, time
args = sys.argv[1:]
open({pidfile!r}, "w").write(str(os.getpid()))
print("fake SITL starting in", os.getcwd(), flush=True)
defaults = args[args.index("--defaults") + 1].split(",") if "--defaults" in args else []
for d in defaults:
    if not os.path.isfile(d):
        print("Failed to load defaults from", d, flush=True)
        sys.exit(1)
    print("loaded defaults from", d, flush=True)
if {mode!r} == "exit":
    print("no simulator model: giving up", flush=True)
    sys.exit(3)
time.sleep(60)  # never listens, never sends a heartbeat
"""


@pytest.fixture
def kubad_plan(tmp_path_factory):
    out = tmp_path_factory.mktemp("plan") / "kubad"
    res = CliRunner().invoke(main, ["plan", str(REPO / "missions" / "kubad-abad-fixed-wing.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out


def _fake(tmp_path, mode: str):
    pidfile = tmp_path / "fake.pid"
    fake = tmp_path / "bin" / "arduplane"
    fake.parent.mkdir()
    fake.write_text(FAKE.format(python=sys.executable, pidfile=str(pidfile), mode=mode))
    fake.chmod(0o755)
    return fake, pidfile


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.parametrize("mode", ["exit", "silent"])
def test_relative_paths_reach_sitl_and_a_failure_quotes_its_output(kubad_plan, tmp_path, monkeypatch, mode):
    fake, pidfile = _fake(tmp_path, mode)
    work = tmp_path / "caller"
    work.mkdir()
    (work / "wind.parm").write_text("SIM_WIND_SPD 3\n")
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.chdir(work)
    res = CliRunner().invoke(main, ["sitl", "fly", str(kubad_plan), "--sitl-bin", os.path.relpath(fake, work),
                                    "--defaults", "wind.parm", "--boot-timeout", "1.5"])
    assert res.exit_code == 1, res.output
    msg = res.stderr.strip()
    assert len(msg.splitlines()) == 1 and "Traceback" not in res.output
    # the defaults file was found by SITL in its own folder: the path was made absolute first
    assert f"loaded defaults from {work / 'wind.parm'}" in msg
    if mode == "exit":
        assert "exited with code 3 at start" in msg and "no simulator model: giving up" in msg
    else:
        assert "within 1.5 s" in msg and "SITL's last output: fake SITL starting" in msg
    assert list(temp.iterdir()) == []  # SITL's temporary folder is removed
    assert _gone(int(pidfile.read_text()))  # and its process stopped
    assert not (kubad_plan / "sitl").exists()
