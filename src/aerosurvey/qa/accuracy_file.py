"""accuracy.json of `aerosurvey qa accuracy -o DIR`: the figures other commands take from it (its one reader).

`campaign record CAMPAIGN BLOCK qa --accuracy FILE` files a block's verdict with them and `campaign
report` learns from them (docs/campaign.md). Read: `standard`, `settings.class_h_cm` and
`class_v_cm` (the class asked), `statistics.x/y/z.rmse_m` (the RMSE per axis of the points
tested), `input.check_points` and `input.control_points`, `verdict.result`; every figure is checked.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError

FILE = "accuracy.json"


@dataclass(frozen=True)
class AccuracyFigures:
    """What one accuracy test found: the RMSE per axis (metres; z None when the points have no heights),
    the points, the class asked (cm; None when none was) and the verdict."""

    standard: str
    rmse_x_m: float
    rmse_y_m: float
    rmse_z_m: float | None
    check_points: int
    control_points: int
    class_h_cm: float | None
    class_v_cm: float | None
    result: str  # "met", "not met", "reported only", or the reason the test is not valid

    def text(self) -> str:
        """One line: the figures as `campaign record` puts them in the event's detail."""
        z = f" z {self.rmse_z_m * 100:.2f}" if self.rmse_z_m is not None else ""
        asked = ", ".join(f"{k} {v:g} cm" for k, v in (("class h", self.class_h_cm), ("class v", self.class_v_cm)) if v is not None)
        return (f"{self.standard}: RMSE x {self.rmse_x_m * 100:.2f} y {self.rmse_y_m * 100:.2f}{z} cm, "
                f"{self.check_points} check points, {self.control_points} control points"
                + (f"; {asked}: {self.result}" if asked else f"; {self.result}"))


def read_accuracy(path: Path) -> AccuracyFigures:
    """The figures of an accuracy.json (or of the folder `qa accuracy -o` wrote it in); a one-line InputError
    naming the file and the field for a file that is not one."""
    file = path / FILE if path.is_dir() else path
    try:
        doc = json.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"--accuracy {str(path)!r}: no {FILE} there; give the file `aerosurvey qa accuracy -o DIR` wrote") from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"--accuracy {str(file)!r} cannot be read as JSON: {exc}") from None
    where = f"--accuracy {str(file)!r}"

    def field(*keys: str) -> Any:
        value: Any = doc
        for k in keys:
            if not isinstance(value, dict) or k not in value:
                raise InputError(f"{where} is not an accuracy.json of `qa accuracy`: it has no {'.'.join(keys)}")
            value = value[k]
        return value

    def length(*keys: str, optional: bool = False) -> float | None:
        value = field(*keys)
        if value is None and optional:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise InputError(f"{where}: {'.'.join(keys)} = {value!r} is not allowed: a length of 0 or more"
                             + (", or null" if optional else ""))
        return float(value)

    def count(*keys: str) -> int:
        value = field(*keys)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InputError(f"{where}: {'.'.join(keys)} = {value!r} is not allowed: a count of 0 or more")
        return value

    standard, result = field("standard"), field("verdict", "result")
    if not isinstance(standard, str) or not isinstance(result, str):
        raise InputError(f"{where}: standard = {standard!r}, verdict.result = {result!r} are not allowed: texts")
    rmse_x, rmse_y = length("statistics", "x", "rmse_m"), length("statistics", "y", "rmse_m")
    assert rmse_x is not None and rmse_y is not None
    return AccuracyFigures(standard, rmse_x, rmse_y, length("statistics", "z", "rmse_m", optional=True) if "rmse_m" in
                           field("statistics", "z") else None, count("input", "check_points"), count("input", "control_points"),
                           length("settings", "class_h_cm", optional=True), length("settings", "class_v_cm", optional=True),
                           result)
