"""The `aerosurvey` subcommands, one module each, and the group class that loads them on use.

A command module is imported when its command runs or when its own help page is shown; a
group's help page lists its subcommands from a registry (target and short help), so listing
them imports none of them. A command module imports only click and light modules at its
top; heavy libraries (scipy, rasterio, dask, starlette, pymavlink …) are imported inside
the command function that needs them.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from gettext import gettext as _
from typing import NamedTuple

import click


class Lazy(NamedTuple):
    """A subcommand not imported yet: where it is and what a help page lists for it.

    `short_help` is the command's own short help (`get_short_help_str`), so a group's help
    page lists the command without importing it (tests/test_cli.py checks that every
    registered one equals the loaded command's); None loads the command to list it
    (plug-ins, whose help only their module knows).
    """

    target: str  # "package.module:attribute"
    short_help: str | None = None


def load_command(target: str) -> click.Command:
    """The click command at `target`, "package.module:attribute"."""
    module_name, _, attr = target.partition(":")
    if not module_name or not attr:
        raise ValueError(f"command target {target!r} is not 'package.module:attribute'")
    obj = getattr(importlib.import_module(module_name), attr)
    if not isinstance(obj, click.Command):
        raise TypeError(f"{target} is a {type(obj).__name__}, not a click command")
    return obj


class LazyGroup(click.Group):
    """A click group whose subcommands load when they run or when their own help is shown.

    `lazy_subcommands` maps a subcommand's name to a `Lazy` (target and short help)::

        @click.group(cls=LazyGroup, lazy_subcommands={
            "shift": Lazy("aerosurvey.commands.qa_repro:shift", "Shift of the same objects digitised at several dates.")})
        def qa() -> None: ...

    The group's help page lists them from their short help without importing them.
    Subclasses may override `lazy_subcommands()` to find them elsewhere (entry points).
    """

    def __init__(self, *args: object, lazy_subcommands: Mapping[str, Lazy] | None = None, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._lazy = dict(lazy_subcommands or {})

    def lazy_subcommands(self) -> Mapping[str, Lazy]:
        """Every lazily loaded subcommand: {name: Lazy} (for listing)."""
        return self._lazy

    def lazy(self, name: str) -> Lazy | None:
        """One subcommand's entry (subclasses may find it without listing them all)."""
        return self.lazy_subcommands().get(name)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy_subcommands()})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        cmd = super().get_command(ctx, cmd_name)
        if cmd is not None:
            return cmd
        entry = self.lazy(cmd_name)
        if entry is None:
            return None
        cmd = self.load(cmd_name, entry.target)
        self.add_command(cmd, cmd_name)
        return cmd

    def load(self, name: str, target: str) -> click.Command:
        """Import one subcommand; an error here is a defect of the package and propagates."""
        return load_command(target)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """List the subcommands as click does, a registered one from its short help without importing it."""
        rows: list[tuple[str, click.Command]] = []
        for name in self.list_commands(ctx):
            entry = None if name in self.commands else self.lazy(name)
            if entry is not None and entry.short_help is not None:
                # a stand-in that click shortens to the width exactly as it does the command's own help
                cmd: click.Command | None = click.Command(name, help=entry.short_help)
            else:
                cmd = self.get_command(ctx, name)
            if cmd is not None and not cmd.hidden:
                rows.append((name, cmd))
        if rows:
            limit = formatter.width - 6 - max(len(name) for name, _ in rows)  # click's own layout
            with formatter.section(_("Commands")):
                formatter.write_dl([(name, cmd.get_short_help_str(limit)) for name, cmd in rows])
