"""The `aerosurvey` command: a click group whose subcommands are loaded on use.

aerosurvey's own commands are listed in `COMMANDS` (target and short help), the same
targets its metadata declares as entry points in the group `aerosurvey.commands`
(pyproject.toml's [project.entry-points."aerosurvey.commands"]; tests/test_cli.py checks
they agree). Another package adds a command by declaring an entry point in that group in
its own metadata, as rasterio's `rio` finds its commands. Running one of aerosurvey's
commands reads no package metadata (importlib.metadata and the scan of every installed
package's metadata cost 50-80 ms); the help page and a name aerosurvey does not know
look the plug-ins up.

A command's module is imported only when it runs or when its own help page is shown:
`aerosurvey --help` lists aerosurvey's commands from `COMMANDS` and loads only plug-ins,
`aerosurvey plan` loads what planning needs and nothing of the QA, web or MAVLink
commands; command modules keep their heavy imports inside the command functions.

Each command stays thin: it parses options, calls library functions and prints. Errors a
user can act on (AerosurveyError) become one line on stderr and the exit code 2 (bad input)
or 1 (a check failed). `-v`/`-q` on the group set the level of log messages on stderr.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Mapping

import click

from aerosurvey import __version__
from aerosurvey.commands import Lazy, LazyGroup, load_command
from aerosurvey.console import configure_logging
from aerosurvey.errors import AerosurveyError

#: The entry point group of commands (aerosurvey's own and plug-ins').
GROUP = "aerosurvey.commands"
DIST = "aerosurvey"

#: aerosurvey's own commands: {name: Lazy(target, short help)}. The targets are the entry
#: points pyproject.toml declares, the short helps the commands' own (tests/test_cli.py).
COMMANDS: Mapping[str, Lazy] = {
    "brief": Lazy("aerosurvey.commands.brief:brief",
                  "What a pilot checks before launch, for the day and time of the flight: go or no-go."),
    "cameras": Lazy("aerosurvey.commands.cameras:cameras", "List the camera database (or `cameras show ID` for one camera)."),
    "campaign": Lazy("aerosurvey.commands.campaign:campaign",
                     "Campaigns: many blocks planned in parallel (a process pool or Dask), one register of their lives."),
    "check": Lazy("aerosurvey.commands.check:check", "Check a mission spec or a plan folder against rule profiles."),
    "gcp": Lazy("aerosurvey.commands.gcp:gcp", "Propose GCPs (an envelope outside the perimeter) and check points (inside)."),
    "log": Lazy("aerosurvey.commands.log:log", "Flight logs: camera events, their match to the plan."),
    "plan": Lazy("aerosurvey.commands.plan:plan",
                 "Plan a survey mission from a mission spec (TOML) and write its files into the -o folder."),
    "qa": Lazy("aerosurvey.commands.qa:qa", "Quality assessment of finished products (accuracy, reproducibility, time series)."),
    "refly": Lazy("aerosurvey.commands.refly:refly", "Plan a re-fly over the cells of LOG_DIR/coverage.tif seen by too few photos."),
    "resume": Lazy("aerosurvey.commands.resume:resume",
                   "Missions for the rest of a flight of PLAN_DIR cut short, from its first station not photographed."),
    "serve": Lazy("aerosurvey.commands.serve:serve",
                  "Plan, check and download a survey mission in the browser (http://127.0.0.1:8765 by default)."),
    "sitl": Lazy("aerosurvey.commands.sitl:sitl",
                 "ArduPilot or PX4 SITL: fly the planned missions in simulation (needs a SITL binary you have)."),
    "upload": Lazy("aerosurvey.commands.upload:upload",
                   "Upload PLAN_FILE (.plan or .waypoints) to a vehicle, with its fence, then read it back and compare."),
}


@functools.cache
def plugin_commands() -> dict[str, Lazy]:
    """{name: Lazy(target)} of commands other packages add; a plug-in cannot replace one of aerosurvey's."""
    from importlib.metadata import entry_points  # reads every installed package's metadata: only to list or for a plug-in

    return {ep.name: Lazy(f"{ep.module}:{ep.attr}") for ep in entry_points(group=GROUP)
            if (ep.dist is None or ep.dist.name != DIST) and ep.name not in COMMANDS}


def registry() -> tuple[dict[str, str], dict[str, str]]:
    """(aerosurvey's own commands, plug-ins' commands), each {name: "module:attribute"}."""
    return {n: c.target for n, c in COMMANDS.items()}, {n: c.target for n, c in plugin_commands().items()}


def _broken(name: str, target: str, exc: Exception) -> click.Command:
    """A plug-in command that failed to load: listed, and says why when run."""
    why = f"the plug-in command {name!r} ({target}) cannot be loaded: {type(exc).__name__}: {exc}"

    def fail() -> None:
        raise click.ClickException(why)

    return click.Command(name, callback=fail, help=why, short_help="(plug-in that cannot be loaded; see its --help)")


class _Main(LazyGroup):
    def lazy_subcommands(self) -> Mapping[str, Lazy]:
        return {**plugin_commands(), **COMMANDS}

    def lazy(self, name: str) -> Lazy | None:
        return COMMANDS.get(name) or plugin_commands().get(name)  # one of aerosurvey's: no metadata read

    def load(self, name: str, target: str) -> click.Command:
        if name in COMMANDS:
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
@click.option("-q", "--quiet", count=True,
              help="Fewer: -q errors only (no progress bars, warnings or reports such as plan's summary), -qq critical only.")
def main(verbose: int, quiet: int) -> None:
    """Plan UAV photogrammetric surveys, check rules, export and fly MAVLink missions, QA the products."""
    configure_logging(verbose - quiet)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
