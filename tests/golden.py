"""Outputs of the three examples recorded before the plan-contract rework (commit 85d44fb).

`tests/data/golden_outputs.json` holds the sha256 of every file `aerosurvey plan` wrote for each
example then. The manifest is compared with the fields that a later schema version added or
changed taken out: the version fields, and the keys below that record checks the old planner
did not make. Everything else must stay byte-for-byte the same.

One recorded hash was renewed for a fix, not a rewiring: the Kubad Abad plane lands into the
wind, and its sortie's time and distance now include the flight to the landing approach
(`sorties[0]`: 1604.6 s, 24,962.9 m before; 1593.4 s, 25,069.1 m after; the mission files are
unchanged).
"""

from __future__ import annotations

import json
from typing import Any

#: manifest keys whose content is allowed to differ from the recording, and why
VERSION_FIELDS = ("schema_version", "aerosurvey_version")
ADDED_KEYS = ("coverage", "checks")  # schema 2: required ground and its shortfall; the final gate's results
ADDED_RULES = ("uncovered-ground",)  # schema 2: a rule result the planner adds itself
ADDED_DERIVED = ("simplification",)  # how the boundaries were simplified (the examples' are not: their vertex counts)


#: schema 2 adds a KML style for the role of ground the plan cannot photograph
ADDED_KML = ('<Style id="uncovered">',)


def normalized_kml(text: bytes) -> bytes:
    return b"\n".join(line for line in text.split(b"\n") if not any(line.startswith(a.encode()) for a in ADDED_KML))


def normalized_manifest(doc: dict[str, Any]) -> bytes:
    doc = {k: v for k, v in doc.items() if k not in VERSION_FIELDS and k not in ADDED_KEYS}
    doc["rules"] = [r for r in doc.get("rules", []) if r.get("rule") not in ADDED_RULES]
    doc["derived"] = {k: v for k, v in doc["derived"].items() if k not in ADDED_DERIVED}
    # plan.kml is compared on its own (normalized_kml); its hash in the manifest follows the style it gained
    doc["outputs"] = {k: v for k, v in doc.get("outputs", {}).items() if k != "plan.kml"}
    return json.dumps(doc, sort_keys=True, ensure_ascii=False).encode("utf-8")
