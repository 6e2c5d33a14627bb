"""`aerosurvey qa`: accuracy and reproducibility QA of finished products."""

from __future__ import annotations

import click

from aerosurvey.commands import Lazy, LazyGroup

# Subcommands load on use: their modules import scipy, numpy and pyproj, which `aerosurvey qa --help`
# (listing them from these short helps) and the other commands must not pay for.
_SUBCOMMANDS = {
    "accuracy": Lazy("aerosurvey.commands.qa_accuracy:accuracy", "Accuracy of a product from its check points, by a standard."),
    "bayes": Lazy("aerosurvey.commands.qa_accuracy:bayes", "Bayesian sigma from summary statistics alone, as published tables give them."),
    "reproducibility": Lazy("aerosurvey.commands.qa_repro:reproducibility",
                            "Reproducibility layer of orthomosaics processed several times with the same settings."),
    "timeseries": Lazy("aerosurvey.commands.qa_repro:timeseries", "Quality mask of pixels reproducible at every date."),
    "shift": Lazy("aerosurvey.commands.qa_repro:shift",
                  "Shift of the same objects digitised at several dates (bounding boxes and centroids)."),
}


@click.group(cls=LazyGroup, lazy_subcommands=_SUBCOMMANDS)
def qa() -> None:
    """Quality assessment of finished products (accuracy, reproducibility, time series)."""
