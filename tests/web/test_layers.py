"""The web page calls the library: it imports no command module (their logic lives in flight/, plan/ …)."""

from __future__ import annotations

import ast
from pathlib import Path

import aerosurvey.web

WEB = Path(aerosurvey.web.__file__).parent


def _imported(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_web_imports_no_command_module():
    modules = sorted(WEB.glob("*.py"))
    assert len(modules) > 5  # the walk sees the package
    bad = {p.name: sorted(m for m in _imported(p) if m.startswith("aerosurvey.commands")) for p in modules}
    assert {k: v for k, v in bad.items() if v} == {}
