"""Outputs of the three examples recorded before the plan-contract rework (commit 85d44fb).

`tests/data/golden_outputs.json` holds the sha256 of every file `aerosurvey plan` wrote for each
example then. The manifest is compared with the fields that a later schema version added or
changed taken out: the version fields, and the keys below that record checks the old planner
did not make. Everything else must stay byte-for-byte the same.

One recorded hash was renewed for a fix, not a rewiring: the Kubad Abad plane lands into the
wind, and its sortie's time and distance now include the flight to the landing approach
(`sorties[0]`: 1604.6 s, 24,962.9 m before; 1593.4 s, 25,069.1 m after; the mission files are
unchanged).

The previews' hashes were renewed when their head came to be drawn from the plan's summary
(the figures `plan` and `check` print, with the planner's own rule in the rule count): only
the three lines of text at the top changed (checked against the recorded files); the
manifest is compared without the preview's hash in `outputs`.
"""

from __future__ import annotations

import json
from typing import Any

#: manifest keys whose content is allowed to differ from the recording, and why
VERSION_FIELDS = ("schema_version", "aerosurvey_version")
ADDED_KEYS = ("coverage", "checks")  # schema 2: required ground and its shortfall; the final gate's results
ADDED_RULES = ("uncovered-ground",)  # schema 2: a rule result the planner adds itself


#: schema 2 adds a KML style for the role of ground the plan cannot photograph
ADDED_KML = ('<Style id="uncovered">',)


def normalized_kml(text: bytes) -> bytes:
    return b"\n".join(line for line in text.split(b"\n") if not any(line.startswith(a.encode()) for a in ADDED_KML))


def normalized_manifest(doc: dict[str, Any]) -> bytes:
    doc = {k: v for k, v in doc.items() if k not in VERSION_FIELDS and k not in ADDED_KEYS}
    doc["rules"] = [r for r in doc.get("rules", []) if r.get("rule") not in ADDED_RULES]
    # plan.kml and preview.svg are compared on their own (normalized_kml, a renewed hash): their hashes in the
    # manifest follow the style the KML gained and the summary the preview shows
    doc["outputs"] = {k: v for k, v in doc.get("outputs", {}).items() if k not in ("plan.kml", "preview.svg")}
    return json.dumps(doc, sort_keys=True, ensure_ascii=False).encode("utf-8")
