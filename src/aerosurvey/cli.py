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
def own_commands() -> dict[str, str]:
    """{name: "module:attribute"} of aerosurvey's own commands, from its installed metadata.

    An editable install made before a command was registered does not list it until
    reinstalled (`pip install -e .`); when the installed metadata lists none of aerosurvey's
    commands, they are read from the checkout's pyproject.toml.
    """
    from importlib.metadata import PackageNotFoundError, distribution  # pyproj imports it too

    try:
        eps = distribution(DIST).entry_points.select(group=GROUP)  # one package's metadata: running a command reads no other
    except PackageNotFoundError:
        return _checkout_commands()
    return {ep.name: f"{ep.module}:{ep.attr}" for ep in eps} or _checkout_commands()


@functools.cache
def plugin_commands() -> dict[str, str]:
    """{name: "module:attribute"} of commands other packages add; a plug-in cannot replace one of aerosurvey's."""
    from importlib.metadata import entry_points  # reads every installed package's metadata: only to list or for a plug-in

    own = own_commands()
    return {ep.name: f"{ep.module}:{ep.attr}" for ep in entry_points(group=GROUP)
            if (ep.dist is None or ep.dist.name != DIST) and ep.name not in own}


def registry() -> tuple[dict[str, str], dict[str, str]]:
    """(aerosurvey's own commands, plug-ins' commands), each {name: "module:attribute"}."""
    return own_commands(), plugin_commands()


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

    def target(self, name: str) -> str | None:
        return own_commands().get(name) or plugin_commands().get(name)

    def load(self, name: str, target: str) -> click.Command:
        if name in own_commands():
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
