"""The page's handlers as code: async handlers do no blocking file I/O (it goes to worker threads)
and stay small. A static check over the web package's source (the API tests run the handlers)."""

from __future__ import annotations

import ast
from pathlib import Path

import aerosurvey.web

WEB = Path(aerosurvey.web.__file__).parent

#: Calls that block the event loop: file reads and writes, folder changes, sleeping.
BLOCKING_NAMES = {"open", "atomic_write_text", "save_upload"}
BLOCKING_METHODS = {"read_text", "write_text", "read_bytes", "write_bytes", "mkdir", "unlink", "rmdir", "touch", "replace",
                    "rename", "iterdir", "glob", "rglob"}
BLOCKING_MODULES = {"shutil", "zipfile", "tempfile", "os"}  # any of their functions
BLOCKING_FUNCTIONS = {"time.sleep"}


def _async_functions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, ast.AsyncFunctionDef):
            yield node


def _own_calls(fn: ast.AsyncFunctionDef):
    """Calls made by the function itself, not by functions defined inside it (those run elsewhere)."""
    stack = list(fn.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        if isinstance(node, ast.Call):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def _blocking(call: ast.Call) -> str | None:
    f = call.func
    if isinstance(f, ast.Name) and f.id in BLOCKING_NAMES:
        return f.id
    if isinstance(f, ast.Attribute):
        if f.attr in BLOCKING_METHODS:
            return f.attr
        if isinstance(f.value, ast.Name) and (f.value.id in BLOCKING_MODULES or f"{f.value.id}.{f.attr}" in BLOCKING_FUNCTIONS):
            return f"{f.value.id}.{f.attr}"
    return None


def _handlers() -> list[tuple[str, ast.AsyncFunctionDef]]:
    out = []
    for path in sorted(WEB.glob("*.py")):
        for fn in _async_functions(ast.parse(path.read_text(encoding="utf-8"))):
            out.append((f"{path.name}:{fn.name}", fn))
    return out


def test_the_check_finds_blocking_calls():
    bad = ast.parse("async def h(request):\n    with open('x', 'wb') as fh:\n        fh.write(b'')\n"
                    "    p.write_text('y')\n    shutil.rmtree(d)\n    await blocking(shutil.rmtree, d)\n"
                    "    time.sleep(1)\n    t = time.monotonic()\n")
    fn = next(_async_functions(bad))
    assert sorted(filter(None, map(_blocking, _own_calls(fn)))) == ["open", "shutil.rmtree", "time.sleep", "write_text"]


def test_async_handlers_do_no_blocking_io():
    handlers = _handlers()
    assert len(handlers) >= 12  # every route's handler and the app's lifespan
    found = {name: sorted(filter(None, map(_blocking, _own_calls(fn)))) for name, fn in handlers}
    assert {name: calls for name, calls in found.items() if calls} == {}


def test_handlers_are_small_and_not_nested_in_create_app():
    routes = [(name, fn) for name, fn in _handlers() if name.startswith("routes_")]
    assert len(routes) >= 11
    for name, fn in routes:
        assert fn.end_lineno - fn.lineno < 30, name
    app = ast.parse((WEB / "app.py").read_text(encoding="utf-8"))
    create = next(n for n in ast.walk(app) if isinstance(n, ast.FunctionDef) and n.name == "create_app")
    assert [n.name for n in ast.walk(create) if isinstance(n, ast.AsyncFunctionDef)] == ["lifespan"]
