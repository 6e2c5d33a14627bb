"""The `aerosurvey` command: a click group with one subcommand module per user task.

Each command lives in `aerosurvey.commands.<name>` and stays thin: it parses options,
calls library functions and prints. Errors a user can act on (AerosurveyError) become
one line on stderr and the exit code 2 (bad input) or 1 (a check failed).
"""

from __future__ import annotations

import sys

import click

from aerosurvey import __version__
from aerosurvey.errors import AerosurveyError


class _Group(click.Group):
    def invoke(self, ctx: click.Context):  # type: ignore[override]
        try:
            return super().invoke(ctx)
        except AerosurveyError as exc:
            click.echo(f"Error: {exc}", err=True)
            ctx.exit(exc.exit_code)


@click.group(cls=_Group)
@click.version_option(__version__, prog_name="aerosurvey")
def main() -> None:
    """Plan UAV photogrammetric surveys, check rules, export and fly MAVLink missions, QA the products."""


def _register() -> None:
    from aerosurvey.commands import cameras, check, gcp, plan, qa

    main.add_command(plan.plan)
    main.add_command(check.check)
    main.add_command(gcp.gcp)
    main.add_command(cameras.cameras)
    main.add_command(qa.qa)
    from aerosurvey.commands import log, sitl

    main.add_command(sitl.sitl)
    main.add_command(log.log)
    from aerosurvey.commands import refly

    main.add_command(refly.refly)
    from aerosurvey.commands import upload
    main.add_command(upload.upload)
    from aerosurvey.commands import serve
    main.add_command(serve.serve)


_register()

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
