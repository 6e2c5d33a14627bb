"""Exceptions a user can act on; the CLI turns them into one line and an exit code."""

from __future__ import annotations

from typing import Any


class AerosurveyError(Exception):
    """Base class: the message is shown to the user as it is."""

    exit_code = 2


class InputError(AerosurveyError):
    """Bad input: a file, a spec key or an option value that cannot be used (exit code 2).

    `key` names the spec key or option at fault when there is one (e.g. `targets.side_overlap`),
    so that a form can show the message next to the field that caused it.
    """

    exit_code = 2

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


class CheckFailed(AerosurveyError):
    """A rule or acceptance check failed on valid input (exit code 1)."""

    exit_code = 1


def bad_value(name: str, value: Any, allowed: str) -> InputError:
    """An error that names the input, the value given and what is allowed."""
    return InputError(f"{name} = {value!r} is not allowed: {allowed}", key=name)
