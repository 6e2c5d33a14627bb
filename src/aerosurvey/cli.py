"""The `aerosurvey` command: a click group whose subcommands are entry points, loaded on use.

Commands are registered like rasterio's `rio` commands: as entry points in the group
`aerosurvey.commands` (pyproject.toml's [project.entry-points."aerosurvey.commands"]), so
another package can add a command by declaring one in its own metadata. A command's module
is imported only when it runs or when `aerosurvey --help` lists it, and command modules keep
their heavy imports inside the command functions: `aerosurvey --help` loads click and the
command modules, `aerosurvey plan` what planning needs and nothing of the QA, web or
MAVLink commands.

Each command stays thin: it parses options, calls library functions and prints. Errors a
user can act on (AerosurveyError) become one line on stderr and the exit code 2 (bad input)
or 1 (a check failed). `-v`/`-q` on the group set the level of log messages on stderr.
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path

import click

from aerosurvey import __version__
from aerosurvey.commands import LazyGroup, load_command
from aerosurvey.console import configure_logging
from aerosurvey.errors import AerosurveyError

#: The entry point group of commands (aerosurvey's own and plug-ins').
GROUP = "aerosurvey.commands"
DIST = "aerosurvey"


@functools.cache
def registry() -> tuple[dict[str, str], dict[str, str]]:
    """({name: "module:attribute"} of aerosurvey's own commands, the same of plug-ins' commands).

    Both come from installed metadata. An editable install made before a command was
    registered does not list it until reinstalled (`pip install -e .`); when the installed
    metadata lists none of aerosurvey's own, they are read from the checkout's pyproject.toml.
    """
    from importlib.metadata import entry_points  # reads every installed package's metadata: only when a command is looked up

    own: dict[str, str] = {}
    plugins: dict[str, str] = {}
    for ep in entry_points(group=GROUP):
        dist = ep.dist.name if ep.dist is not None else None
        (own if dist == DIST else plugins)[ep.name] = f"{ep.module}:{ep.attr}"
    if not own:
        own = _checkout_commands()
    for name in own:
        plugins.pop(name, None)  # a plug-in cannot replace one of aerosurvey's commands
    return own, plugins


def _checkout_commands() -> dict[str, str]:
    """aerosurvey's commands as the source checkout's pyproject.toml declares them ({} when not in a checkout)."""
    import tomllib

    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    try:
        project = tomllib.loads(pyproject.read_text(encoding="utf-8")).get("project", {})
    except (OSError, tomllib.TOMLDecodeError):
        return {}
    if project.get("name") != DIST:
        return {}
    eps = project.get("entry-points", {}).get(GROUP, {})
    return {name: value.split("[")[0].replace(" ", "") for name, value in eps.items()}


def _broken(name: str, target: str, exc: Exception) -> click.Command:
    """A plug-in command that failed to load: listed, and says why when run."""
    why = f"the plug-in command {name!r} ({target}) cannot be loaded: {type(exc).__name__}: {exc}"

    def fail() -> None:
        raise click.ClickException(why)

    return click.Command(name, callback=fail, help=why, short_help="(plug-in that cannot be loaded; see its --help)")


class _Main(LazyGroup):
    def lazy_subcommands(self) -> dict[str, str]:
        own, plugins = registry()
        return {**plugins, **own}

    def load(self, name: str, target: str) -> click.Command:
        if name in registry()[0]:
            return load_command(target)  # aerosurvey's own: failing to load is a defect, shown as one
        try:
            return load_command(target)
        except Exception as exc:  # another package's defect must not break aerosurvey
            return _broken(name, target, exc)

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except AerosurveyError as exc:
            click.echo(f"Error: {exc}", err=True)
            ctx.exit(exc.exit_code)


@click.group(cls=_Main)
@click.version_option(__version__, prog_name="aerosurvey")
@click.option("-v", "--verbose", count=True, help="More log messages on stderr: -v informative, -vv debugging.")
@click.option("-q", "--quiet", count=True, help="Fewer: -q errors only and no progress bars, -qq critical only.")
def main(verbose: int, quiet: int) -> None:
    """Plan UAV photogrammetric surveys, check rules, export and fly MAVLink missions, QA the products."""
    configure_logging(verbose - quiet)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
