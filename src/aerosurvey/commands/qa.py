"""`aerosurvey qa`: accuracy and reproducibility QA of finished products."""

from __future__ import annotations

import click


@click.group()
def qa() -> None:
    """Quality assessment of finished products (accuracy, reproducibility, time series)."""


from aerosurvey.commands.qa_accuracy import accuracy, bayes  # noqa: E402

qa.add_command(accuracy)
qa.add_command(bayes)

from aerosurvey.commands.qa_repro import reproducibility, shift, timeseries  # noqa: E402

qa.add_command(reproducibility)
qa.add_command(timeseries)
qa.add_command(shift)
