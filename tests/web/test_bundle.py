"""The map library the page loads is the committed bundle built from web-src/'s lock file, with its licences,
and the page loads nothing from another host."""

from __future__ import annotations

import json
import re

from webutil import REPO

VENDOR = REPO / "src" / "aerosurvey" / "web" / "static" / "vendor"
LOCK = REPO / "web-src" / "package-lock.json"


def test_bundle_matches_the_lock_file():
    lock = json.loads(LOCK.read_text())["packages"]
    pkg = json.loads((REPO / "web-src" / "package.json").read_text())
    built = json.loads((VENDOR / "versions.json").read_text())
    for name in ("ol", "proj4"):
        assert lock[f"node_modules/{name}"]["version"] == pkg["dependencies"][name] == built[name], name
    assert lock["node_modules/esbuild"]["version"] == built["esbuild"]
    head = (VENDOR / "olb.js").read_text(encoding="utf-8")[:200]
    m = re.match(r"/\* aerosurvey map bundle: ol (\S+), proj4 (\S+);", head)
    assert m is not None and (m[1], m[2]) == (built["ol"], built["proj4"])


def test_licences_are_kept():
    assert (VENDOR / "LICENSE-ol.md").read_text().startswith("BSD 2-Clause License")
    assert "Proj4js" in (VENDOR / "LICENSE-proj4.md").read_text()


def test_the_page_loads_only_its_own_files():
    html = (REPO / "src" / "aerosurvey" / "web" / "static" / "index.html").read_text()
    refs = re.findall(r'(?:src|href)="([^"]+)"', html)
    assert refs and all(r.startswith("/static/") or r.startswith("data:") for r in refs), refs
