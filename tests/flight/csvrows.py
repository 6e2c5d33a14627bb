"""events.csv read with the standard csv module, not aerosurvey's reader (an independent check of the file)."""

from __future__ import annotations

import csv
from pathlib import Path


def event_rows(path: Path) -> list[dict[str, str]]:
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    assert lines[0] == "# aerosurvey-events 2\n", lines[0]
    return list(csv.DictReader(lines[1:]))
