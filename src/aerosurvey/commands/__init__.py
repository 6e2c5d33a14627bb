"""The `aerosurvey` subcommands, one module each, and the group class that loads them on use.

A command module is imported when its command runs or when a help page lists it, so it
imports only click and light modules at its top; heavy libraries (scipy, rasterio, dask,
starlette, pymavlink …) are imported inside the command function that needs them.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping

import click


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
    """A click group whose subcommands load when they run or when its help lists them.

    `lazy_subcommands` maps a subcommand's name to "package.module:attribute"::

        @click.group(cls=LazyGroup, lazy_subcommands={"shift": "aerosurvey.commands.qa_repro:shift"})
        def qa() -> None: ...

    Subclasses may override `lazy_subcommands()` to find them elsewhere (entry points).
    """

    def __init__(self, *args: object, lazy_subcommands: Mapping[str, str] | None = None, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._lazy = dict(lazy_subcommands or {})

    def lazy_subcommands(self) -> Mapping[str, str]:
        """Every lazily loaded subcommand: {name: "package.module:attribute"} (for listing)."""
        return self._lazy

    def target(self, name: str) -> str | None:
        """Where one subcommand is (subclasses may find it without listing them all)."""
        return self.lazy_subcommands().get(name)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy_subcommands()})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        cmd = super().get_command(ctx, cmd_name)
        if cmd is not None:
            return cmd
        target = self.target(cmd_name)
        if target is None:
            return None
        cmd = self.load(cmd_name, target)
        self.add_command(cmd, cmd_name)
        return cmd

    def load(self, name: str, target: str) -> click.Command:
        """Import one subcommand; an error here is a defect of the package and propagates."""
        return load_command(target)
