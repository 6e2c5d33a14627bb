"""Rule profiles: TOML data files, shipped ones and the user's own.

A profile is a list of rules; each rule names a check (a function in checks.py) and
gives its parameters, so a company or national specification is a new file, not code.
Search order: the package's profiles/, then every folder in AEROSURVEY_PROFILES
(os.pathsep-separated), then the folders given on the command line.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from aerosurvey.errors import InputError

SEVERITIES = ("error", "warning", "info")

#: A rule parameter's value: the checks take numbers and strings (Check.validate).
ParamValue = int | float | str


@dataclass(frozen=True)
class Rule:
    """One rule of a profile: what it states, the check that measures it, its severity, source and parameters."""

    id: str
    statement: str
    check: str
    severity: str
    source: str
    params: dict[str, ParamValue] = field(default_factory=dict)


@dataclass(frozen=True)
class Profile:
    """A rule profile (a TOML file: the Czech land consolidation rules, ASPRS …) and its rules."""

    id: str
    name: str
    source: str
    rules: tuple[Rule, ...]
    path: str


def parse_profile(text: str, where: str) -> Profile:
    from aerosurvey.rules.checks import CHECKS

    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"rule profile {where}: not valid TOML: {exc}") from None
    head = data.get("profile")
    if not isinstance(head, dict) or not isinstance(head.get("id"), str):
        raise InputError(f"rule profile {where}: needs a [profile] table with an 'id'")
    raw_rules = data.get("rules")
    if not isinstance(raw_rules, list) or not raw_rules:
        raise InputError(f"rule profile {where}: needs at least one [[rules]] table")
    rules = []
    seen = set()
    for i, r in enumerate(raw_rules):
        rid = r.get("id") if isinstance(r, dict) else None
        name = f"rule profile {where}, rule {rid or f'#{i + 1}'}"
        if not isinstance(rid, str) or not rid:
            raise InputError(f"{name}: field 'id' is missing")
        if rid in seen:
            raise InputError(f"{name}: field 'id' = {rid!r} is used twice")
        seen.add(rid)
        unknown = set(r) - {"id", "statement", "check", "severity", "source", "params"}
        if unknown:
            raise InputError(f"{name}: unknown field(s) {sorted(unknown)}")
        for key in ("statement", "check", "source"):
            if not isinstance(r.get(key), str) or not r.get(key):
                raise InputError(f"{name}: field '{key}' is missing or not a string")
        if r["check"] not in CHECKS:
            raise InputError(f"{name}: field 'check' = {r['check']!r} is not a known check; known: {', '.join(sorted(CHECKS))}")
        sev = r.get("severity", "error")
        if sev not in SEVERITIES:
            raise InputError(f"{name}: field 'severity' = {sev!r}; allowed: {', '.join(SEVERITIES)}")
        params = r.get("params", {})
        if not isinstance(params, dict):
            raise InputError(f"{name}: field 'params' must be a table")
        rules.append(Rule(rid, r["statement"], r["check"], sev, r["source"], CHECKS[r["check"]].validate(params, name)))
    return Profile(head["id"], str(head.get("name", head["id"])), str(head.get("source", "")), tuple(rules), where)


def _search_dirs(extra: list[Path]) -> list[Path]:
    dirs = [Path(p) for p in os.environ.get("AEROSURVEY_PROFILES", "").split(os.pathsep) if p]
    return dirs + list(extra)


def available_profiles(extra_dirs: list[Path] | None = None) -> dict[str, Profile]:
    """Every profile by id; a user profile with a shipped id replaces the shipped one."""
    out: dict[str, Profile] = {}
    pkg = resources.files("aerosurvey").joinpath("rules/profiles")
    for entry in sorted(pkg.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".toml"):
            p = parse_profile(entry.read_text(encoding="utf-8"), entry.name)
            out[p.id] = p
    for d in _search_dirs(extra_dirs or []):
        if not d.is_dir():
            raise InputError(f"rule profile folder {str(d)!r} does not exist")
        for f in sorted(d.glob("*.toml")):
            p = parse_profile(f.read_text(encoding="utf-8"), str(f))
            out[p.id] = p
    return out


def select_profiles(ids: list[str], extra_dirs: list[Path] | None = None) -> list[Profile]:
    have = available_profiles(extra_dirs)
    missing = [i for i in ids if i not in have]
    if missing:
        raise InputError(f"rule profile(s) {', '.join(map(repr, missing))} not found; available: {', '.join(sorted(have))}")
    return [have[i] for i in ids]


def apply_overrides(profiles: list[Profile], overrides: Mapping[str, object]) -> list[Profile]:
    """Override rule parameters from the mission spec: {"rule-id.param": value}."""
    from aerosurvey.rules.checks import CHECKS

    rules = {r.id: (pi, ri) for pi, p in enumerate(profiles) for ri, r in enumerate(p.rules)}
    out = [list(p.rules) for p in profiles]
    for key, value in overrides.items():
        rid, _, param = key.rpartition(".")
        if rid not in rules:
            raise InputError(f"rules.overrides: {key!r} names no rule of the chosen profiles")
        pi, ri = rules[rid]
        r = out[pi][ri]
        params: dict[str, object] = dict(r.params)
        params[param] = value
        checked = CHECKS[r.check].validate(params, f"rules.overrides {key!r}")
        out[pi][ri] = Rule(r.id, r.statement, r.check, r.severity, r.source + " (overridden by the mission spec)", checked)
    return [Profile(p.id, p.name, p.source, tuple(rs), p.path) for p, rs in zip(profiles, out)]
