"""The `aerosurvey` command group: lazy commands from entry points, plug-ins, logging, progress.

Start-up checks run fresh interpreters (a test process has long imported everything) and look
at what they imported; no test measures time (benchmarks/plan_bench.py --startup does).
"""

from __future__ import annotations

import io
import json
import logging
import os
import pty
import re
import select
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

import aerosurvey
from aerosurvey import console
from aerosurvey.cli import COMMANDS, GROUP, main, registry
from aerosurvey.commands import LazyGroup

REPO = Path(__file__).resolve().parents[1]
SRC = Path(aerosurvey.__file__).resolve().parents[1]
EXAMPLE = REPO / "missions" / "obratan-72ha.toml"

#: Libraries that no help page and no planning run may load (what the QA, web and MAVLink
#: commands need), and what a help page has no use for either.
NOT_FOR_HELP = ("dask", "distributed", "starlette", "uvicorn", "mavsdk", "scipy", "rasterio", "pymavlink", "pyulog",
                "PIL", "pyogrio", "numpy", "shapely", "pyproj", "rich")
NOT_FOR_PLANNING = ("dask", "distributed", "starlette", "uvicorn", "mavsdk", "scipy", "rasterio", "pymavlink", "pyulog",
                    "PIL", "affine")


def _env(extra_path: Path | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(str(p) for p in (extra_path, SRC) if p is not None)
    return env


def _modules_of(args: list[str], tmp_path: Path, extra_path: Path | None = None) -> tuple[set[str], subprocess.CompletedProcess]:
    """Every module a fresh `aerosurvey ARGS` imported (recorded when the interpreter exits)."""
    record = tmp_path / "modules.json"
    code = textwrap.dedent(f"""
        import atexit, json, sys
        atexit.register(lambda: open({str(record)!r}, "w").write(json.dumps(sorted(sys.modules))))
        from aerosurvey.cli import main
        main({args!r}, prog_name="aerosurvey")
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(extra_path), cwd=tmp_path)
    return set(json.loads(record.read_text())), res


def _imported_by(args: list[str], tmp_path: Path, extra_path: Path | None = None) -> tuple[set[str], subprocess.CompletedProcess]:
    """Top-level packages a fresh `aerosurvey ARGS` imported."""
    mods, res = _modules_of(args, tmp_path, extra_path)
    return {m.split(".")[0] for m in mods}, res


@pytest.fixture(autouse=True)
def _restore_logging():
    """Commands run in this process configure the root logger; put it back for the next test."""
    root = logging.getLogger()
    level, handlers = root.level, list(root.handlers)
    yield
    console.configure_logging(0)
    root.setLevel(level)
    root.handlers[:] = handlers


@pytest.mark.parametrize("args", [["--help"], ["plan", "--help"], ["qa", "--help"], ["log", "--help"], ["sitl", "--help"],
                                  ["cameras", "--help"], ["check", "--help"], ["qa", "accuracy", "--help"],
                                  ["qa", "bayes", "--help"], ["qa", "shift", "--help"]])
def test_help_pages_import_no_heavy_library(args, tmp_path):
    mods, res = _imported_by(args, tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Usage: aerosurvey" in res.stdout
    assert "click" in mods  # the record works: it sees what was imported
    assert sorted(mods & set(NOT_FOR_HELP)) == []


def test_group_help_pages_list_subcommands_without_importing_them(tmp_path):
    mods, res = _modules_of(["--help"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Plan a survey mission" in res.stdout and "Quality assessment" in res.stdout  # listed from the registry
    assert sorted(m for m in mods if m.startswith("aerosurvey.commands.")) == []
    mods, res = _modules_of(["qa", "--help"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Accuracy of a product from its check points" in res.stdout and "reproducibility" in res.stdout
    assert sorted(m for m in mods if m.startswith("aerosurvey.commands.")) == ["aerosurvey.commands.qa"]


def test_running_own_commands_reads_no_package_metadata(tmp_path):
    # importlib.metadata and the scan of every installed package's metadata: only to list or find a plug-in
    mods, res = _modules_of(["plan", "--help"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert "aerosurvey.commands.plan" in mods  # the record works
    assert "importlib.metadata" not in mods


def test_planning_loads_only_what_planning_needs(tmp_path):
    modules, res = _modules_of(["plan", str(EXAMPLE), "-o", str(tmp_path / "out")], tmp_path)
    mods = {m.split(".")[0] for m in modules}
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "out" / "mission.plan").exists()
    assert {"numpy", "shapely", "pyproj", "aerosurvey.rules.footprints"} <= mods | modules  # the example's rules ran
    assert sorted(mods & set(NOT_FOR_PLANNING)) == []
    assert "numpy.ma" not in modules  # np.median loads it (12-17 ms): the rules take statistics.median
    assert "jsonschema" not in mods  # the manifest just written is not checked again in the same process (~80 ms)
    # the other patterns' modules (plan/pattern.py loads a pattern when asked for), the faces' model (a structure's
    # plans only), `resume`'s writer
    others = {"aerosurvey.plan.oblique", "aerosurvey.plan.smart_oblique", "aerosurvey.plan.orbit", "aerosurvey.plan.faces",
              "aerosurvey.plan.surfaces", "aerosurvey.resumefile"}
    assert "aerosurvey.plan.area_grid" in modules and sorted(modules & others) == []


def test_registry_is_the_pyproject_entry_points():
    declared = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["entry-points"][GROUP]
    own, _ = registry()
    assert own == declared
    assert {"plan", "check", "gcp", "cameras", "qa", "log", "sitl", "refly", "upload", "serve"} <= set(own)


def _lazy_groups(group: click.Group, ctx: click.Context):
    """Every LazyGroup from `group` down, with its context (loading each subcommand)."""
    if isinstance(group, LazyGroup):
        yield group, ctx
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        if isinstance(cmd, click.Group):
            yield from _lazy_groups(cmd, click.Context(cmd, parent=ctx, info_name=name))


def test_registered_short_help_is_the_commands_own():
    """A help page lists a registered command from its short help: it must be what the command itself says."""
    checked = []
    for group, ctx in _lazy_groups(main, click.Context(main, info_name="aerosurvey")):
        for name, entry in group.lazy_subcommands().items():
            if entry.short_help is None:
                continue
            cmd = group.get_command(ctx, name)
            assert cmd is not None, name
            stand_in = click.Command(name, help=entry.short_help)
            for limit in (20, 45, 70, 1000):  # as click shortens it to any terminal width
                assert stand_in.get_short_help_str(limit) == cmd.get_short_help_str(limit), (name, limit)
            assert not cmd.hidden, name
            checked.append(name)
    assert set(COMMANDS) <= set(checked) and {"accuracy", "bayes", "reproducibility", "timeseries", "shift"} <= set(checked)


def _all_commands(group: click.Group, ctx: click.Context, prefix: list[str]):
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        assert cmd is not None, name
        yield [*prefix, name], cmd
        if isinstance(cmd, click.Group):
            yield from _all_commands(cmd, click.Context(cmd, parent=ctx, info_name=name), [*prefix, name])


def test_every_command_loads_and_shows_its_help():
    listing = CliRunner().invoke(main, ["--help"], prog_name="aerosurvey", terminal_width=200)
    assert listing.exit_code == 0, listing.output
    ctx = click.Context(main, info_name="aerosurvey", terminal_width=200)
    seen = []
    for path, cmd in _all_commands(main, ctx, []):
        res = CliRunner().invoke(main, [*path, "--help"], prog_name="aerosurvey")
        assert res.exit_code == 0, (path, res.output)
        assert res.output.startswith(f"Usage: aerosurvey {' '.join(path)}"), res.output
        if len(path) == 1:  # the top-level listing names every command with its short help
            line = next((ln for ln in listing.output.splitlines() if ln.split()[:1] == path), "")
            assert cmd.get_short_help_str(limit=150) in line, (path, line)
        seen.append(" ".join(path))
    assert set(registry()[0]) <= set(seen)
    assert {"qa accuracy", "qa bayes", "qa reproducibility", "qa timeseries", "qa shift", "log ingest", "sitl fly",
            "cameras show"} <= set(seen)


def _plugin(tmp_path: Path) -> Path:
    """An installed package (dist-info on the path) that adds two commands, one of them broken."""
    site = tmp_path / "site"
    dist = site / "aerosurvey_hello-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: aerosurvey-hello\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(f"[{GROUP}]\nhello = aerosurvey_hello:hello\n"
                                           "broken = aerosurvey_missing_module:cmd\nplan = aerosurvey_hello:hello\n")
    (site / "aerosurvey_hello.py").write_text(textwrap.dedent("""
        import click

        @click.command()
        @click.argument("name")
        def hello(name):
            \"\"\"Say hello from a plug-in.\"\"\"
            click.echo(f"hello {name}")
    """))
    return site


def test_plugins_add_commands_through_entry_points(tmp_path):
    site = _plugin(tmp_path)
    run = [sys.executable, "-m", "aerosurvey.cli"]
    listing = subprocess.run([*run, "--help"], capture_output=True, text=True, env=_env(site))
    assert listing.returncode == 0, listing.stderr
    assert "Say hello from a plug-in." in listing.stdout and "broken" in listing.stdout
    assert "Plan a survey mission" in listing.stdout  # aerosurvey's own, listed from the registry
    hello = subprocess.run([*run, "hello", "world"], capture_output=True, text=True, env=_env(site))
    assert (hello.returncode, hello.stdout) == (0, "hello world\n")
    # a plug-in that fails to load says so in one line; it does not break the other commands
    broken = subprocess.run([*run, "broken"], capture_output=True, text=True, env=_env(site))
    assert broken.returncode == 1 and "Traceback" not in broken.stderr
    assert "aerosurvey_missing_module" in broken.stderr and len(broken.stderr.strip().splitlines()) == 1
    # a plug-in cannot replace one of aerosurvey's own commands
    plan_help = subprocess.run([*run, "plan", "--help"], capture_output=True, text=True, env=_env(site))
    assert "Plan a survey mission" in plan_help.stdout


def test_verbosity_sets_the_log_level(tmp_path):
    def run(*opts: str) -> str:
        res = CliRunner().invoke(main, [*opts, "plan", str(EXAMPLE), "-o", str(tmp_path / "out")])
        assert res.exit_code == 0, res.output
        assert "wrote manifest.json" in res.stdout
        return res.stderr

    assert run() == ""  # results on stdout; nothing on stderr by default (not a terminal: no bar)
    info = run("-v")
    assert "info: planned in" in info and "debug:" not in info
    debug = run("-vv")
    assert "debug: aerosurvey.console: planning" in debug


def test_quiet_hides_warnings():
    log = logging.getLogger("aerosurvey.test")

    @click.command()
    def warn() -> None:
        log.warning("something to know")

    main.add_command(warn, "test-warn")
    try:
        assert CliRunner().invoke(main, ["test-warn"]).stderr == "warning: something to know\n"
        assert CliRunner().invoke(main, ["-q", "test-warn"]).stderr == ""
    finally:
        main.commands.pop("test-warn")


def test_level_for_verbosity():
    assert [console.level_for(v) for v in (-3, -2, -1, 0, 1, 2, 3)] == [
        logging.CRITICAL, logging.CRITICAL, logging.ERROR, logging.WARNING, logging.INFO, logging.DEBUG, logging.DEBUG]


def test_progress_draws_on_a_terminal_only():
    out = io.StringIO()
    with console.progress("planning", enabled=True, file=out) as report:
        report("reading the area", 0.1)
        report("route", 0.7)
        report("route", 0.5)  # never moves back
    text = out.getvalue()
    assert "planning: route" in text and "70%" in text and "50%" not in text
    quiet = io.StringIO()  # not a terminal
    with console.progress("planning", file=quiet) as report:
        report("route", 0.5)
    assert quiet.getvalue() == ""


def test_part_scales_a_share_into_its_range():
    got = []
    report = console.part(lambda stage, done: got.append((stage, round(done, 6))), 0.2, 0.6)
    for d in (-1.0, 0.0, 0.5, 1.0, 2.0):
        report("x", d)
    assert got == [("x", 0.2), ("x", 0.2), ("x", 0.4), ("x", 0.6), ("x", 0.6)]


def _run_on_a_terminal(args: list[str], cwd: Path) -> tuple[int, str]:
    """Run `aerosurvey ARGS` with stderr on a pseudo-terminal; its exit code and what the terminal got."""
    master, slave = pty.openpty()
    env = _env() | {"TERM": "xterm", "COLUMNS": "100"}
    proc = subprocess.Popen([sys.executable, "-m", "aerosurvey.cli", *args], stdout=subprocess.DEVNULL, stderr=slave,
                            env=env, cwd=cwd)
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 0.5)
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # the terminal closed: the process has ended
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    os.close(master)
    return proc.wait(), b"".join(chunks).decode("utf-8", "replace")


def test_plan_shows_progress_on_a_terminal_and_not_in_a_pipe(tmp_path):
    code, seen = _run_on_a_terminal(["plan", str(EXAMPLE), "-o", str(tmp_path / "tty")], tmp_path)
    assert code == 0, seen
    assert "planning obratan-72ha" in seen and "\x1b[" in seen, seen
    piped = subprocess.run([sys.executable, "-m", "aerosurvey.cli", "plan", str(EXAMPLE), "-o", str(tmp_path / "pipe")],
                           capture_output=True, text=True, env=_env())
    assert piped.returncode == 0 and piped.stderr == ""
    code, seen = _run_on_a_terminal(["-q", "plan", str(EXAMPLE), "-o", str(tmp_path / "q")], tmp_path)
    assert code == 0 and seen == ""


def test_help_pages_name_only_their_own_arguments_and_options():
    """What a help page names as an argument (an upper-case name another command uses) or an
    option (--name) is one of that command's own: `plan` once named an OUTDIR it did not have."""
    ctx = click.Context(main, info_name="aerosurvey", terminal_width=200)
    commands = list(_all_commands(main, ctx, []))
    arguments = {p.human_readable_name for _, cmd in commands for p in cmd.params if isinstance(p, click.Argument)}
    checked = 0
    for path, cmd in commands:
        text = CliRunner().invoke(main, [*path, "--help"], prog_name="aerosurvey", terminal_width=1000,
                                  max_content_width=1000).output  # no line wrapped inside a name
        text = text.split("\nCommands:\n")[0]  # a group lists its subcommands with their own short help
        own_args = {p.human_readable_name for p in cmd.params if isinstance(p, click.Argument)}
        own_opts = {o for p in cmd.params for o in p.opts + p.secondary_opts} | {"--help"}
        named_args = {w for w in re.findall(r"\b[A-Z][A-Z_]+\b", text) if w in arguments}
        named_opts = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))
        assert named_args <= own_args, (path, named_args - own_args)
        assert named_opts <= own_opts, (path, named_opts - own_opts)
        checked += 1
    assert checked >= 18


def test_a_plan_without_rule_profiles_loads_no_rules(tmp_path):
    """The rules' modules (~15-30 ms of imports) load only for a spec that names rule profiles."""
    import tomli_w

    spec = tomllib.loads(EXAMPLE.read_text())
    spec.pop("rules", None)
    spec["area"]["file"] = str(EXAMPLE.parent / spec["area"]["file"])
    path = tmp_path / "no-rules.toml"
    path.write_text(tomli_w.dumps(spec))
    modules, res = _modules_of(["plan", str(path), "-o", str(tmp_path / "out")], tmp_path)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "out" / "mission.plan").exists() and "aerosurvey.plan.planner" in modules  # the record works
    assert sorted(m for m in modules if m.startswith("aerosurvey.rules")) == []
