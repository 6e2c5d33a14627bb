"""Helpers for the web page's tests: the app over a copy of an example mission, a plan run to its end."""

from __future__ import annotations

import shutil
import time
import warnings
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # Starlette's notice that its test client will move to httpx2
    from starlette.testclient import TestClient


def copy_mission(tmp: Path, name: str = "obratan-72ha") -> Path:
    """The example mission and its area in a folder of the test's own (the page may write the spec)."""
    (tmp / "areas").mkdir(parents=True, exist_ok=True)
    spec = REPO / "missions" / f"{name}.toml"
    text = spec.read_text(encoding="utf-8")
    shutil.copy(spec, tmp / spec.name)
    for line in text.splitlines():
        if line.startswith("file = "):
            rel = line.split("=", 1)[1].strip().strip('"')
            shutil.copy(REPO / "missions" / rel, tmp / rel)
    return tmp / spec.name


def client(spec: Path | None, **kw: Any) -> TestClient:
    from aerosurvey.web.app import create_app

    return TestClient(create_app(spec, **kw))


def run_plan(c: TestClient, spec: dict[str, Any], timeout: float = 120.0) -> dict[str, Any]:
    """Submit a plan and wait for its job to end; returns the final job status."""
    r = c.post("/api/plan", json={"spec": spec})
    assert r.status_code == 202, r.text
    job = r.json()["job"]
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        st = c.get(f"/api/jobs/{job}?wait=2").json()
        if st["state"] not in ("queued", "running"):
            return st
    raise AssertionError(f"job {job} did not finish in {timeout} s")
