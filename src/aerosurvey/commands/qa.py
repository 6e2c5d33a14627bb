"""`aerosurvey qa`: accuracy and reproducibility QA of finished products."""

from __future__ import annotations

import click

from aerosurvey.commands import LazyGroup

# Subcommands load on use: their modules import scipy, numpy and pyproj, which `aerosurvey --help`
# (listing this group) and the other commands must not pay for.
_SUBCOMMANDS = {
    "accuracy": "aerosurvey.commands.qa_accuracy:accuracy",
    "bayes": "aerosurvey.commands.qa_accuracy:bayes",
    "reproducibility": "aerosurvey.commands.qa_repro:reproducibility",
    "timeseries": "aerosurvey.commands.qa_repro:timeseries",
    "shift": "aerosurvey.commands.qa_repro:shift",
}


@click.group(cls=LazyGroup, lazy_subcommands=_SUBCOMMANDS)
def qa() -> None:
    """Quality assessment of finished products (accuracy, reproducibility, time series)."""
