"""One block of a campaign: its job (picklable inputs, the key derived from them) and `plan_block`,
the function every executor runs.

`plan_block` plans the block through the planner's public calls (`spec.parse_spec`,
`inputs.plan_from_files`, `outputs.render_outputs`: what `aerosurvey plan` calls), writes the
outputs asked for into a temporary folder next to the blocks' folders and renames it to the
block's folder, named after the job's key. The rename is the one step that makes a block done:
a crash before it leaves a temporary folder (removed by the next run), never a half block; two
attempts of one block (a retried task, a driver killed and run again while a worker of the
first run still works) write the same files, and the second rename finds the folder there and
drops its copy. A block folder's block.json is its result record.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import shutil
import tempfile
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.campaign.blocks import Block
from aerosurvey.errors import AerosurveyError, InputError
from aerosurvey.spec import MissionSpec

#: the version of the block folders' layout and of block.json; part of every key
#: (2: outline.geojson and block.json's vehicle)
FORMAT = 2
BLOCKS_DIR = "blocks"
RESULT_FILE = "block.json"
#: written in every block folder whatever --outputs says: plan.geojson's area and zone features, what
#: `campaign ingest` reads of the block besides manifest.json (rules/planview.py: PlanView.from_outdir)
OUTLINE_FILE = "outline.geojson"
TEMP_SUFFIX = ".tmp"

#: what `--outputs` chooses from: a group → whether an output file of `aerosurvey plan` belongs to it
OUTPUT_GROUPS = ("manifest", "pilot", "geojson", "kml", "preview", "gpkg")
DEFAULT_OUTPUTS = ("manifest", "pilot")
_GROUP_OF_SUFFIX = {".plan": "pilot", ".waypoints": "pilot", ".kmz": "pilot", ".geojson": "geojson", ".kml": "kml",
                    ".svg": "preview", ".gpkg": "gpkg"}


def output_group(file_name: str) -> str:
    """The `--outputs` group a file of `aerosurvey plan` belongs to."""
    if file_name == "manifest.json":
        return "manifest"
    return _GROUP_OF_SUFFIX[Path(file_name).suffix]


def parse_outputs(text: str) -> tuple[str, ...]:
    """`--outputs` (comma-separated groups, or "all") as the groups in OUTPUT_GROUPS' order."""
    asked = {g.strip() for g in text.split(",") if g.strip()}
    if asked == {"all"}:
        return OUTPUT_GROUPS
    unknown = sorted(asked - set(OUTPUT_GROUPS))
    if unknown or not asked:
        raise InputError(f"--outputs = {text!r} is not allowed: comma-separated groups of {', '.join(OUTPUT_GROUPS)}, or all",
                         key="--outputs")
    return tuple(g for g in OUTPUT_GROUPS if g in asked)


@dataclass(frozen=True)
class BlockJob:
    """Everything one block is planned from, picklable: the block (name, polygon as WKB, the
    attributes overriding the template), the CRS of the polygon, the template's TOML text and
    the folder its relative paths are taken from, the output groups; `key` is derived from them
    (`job_key`) and names the block's folder."""

    block: Block
    crs: str
    template: str
    base: str
    outputs: tuple[str, ...]
    key: str

    @property
    def name(self) -> str:
        return self.block.name

    @property
    def folder(self) -> str:
        return f"{self.block.name}.{self.key}"


def job_key(block: Block, crs: str, template_values: dict[str, Any], base: str, outputs: tuple[str, ...]) -> str:
    """20 hex digits of the SHA-256 of the block's inputs by value (the template's values, not its
    text: a comment changes no key). The files the template names (a DEM, zone files) count by
    their path, not their contents."""
    text = json.dumps({"format": FORMAT, "name": block.name, "wkb": block.wkb.hex(), "crs": crs,
                       "overrides": [list(o) for o in block.overrides], "template": template_values, "base": base,
                       "outputs": list(outputs)}, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def read_template(template_path: Path) -> tuple[str, dict[str, Any]]:
    """The spec template's text and values; a one-line InputError when it is missing or not TOML."""
    try:
        template = template_path.read_text(encoding="utf-8")
        return template, tomllib.loads(template)
    except FileNotFoundError:
        raise InputError(f"--spec {str(template_path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"--spec {str(template_path)!r} cannot be read as TOML: {exc}") from None


def make_jobs(blocks: list[Block], crs: str, template_path: Path, outputs: tuple[str, ...]) -> list[BlockJob]:
    """A job per block, with its key."""
    template, values = read_template(template_path)
    base = str(template_path.resolve().parent)
    return [BlockJob(b, crs, template, base, outputs, job_key(b, crs, values, base, outputs)) for b in blocks]


def block_spec(template: str, base: Path, block: Block, crs: str) -> MissionSpec:
    """The mission spec of one block (the template's TOML text with the block's area, name and
    overrides; relative paths from `base`), checked; an InputError names the block."""
    from aerosurvey.spec import parse_spec

    try:
        return parse_spec(spec_values(template, block, crs), base=base)
    except InputError as exc:
        raise InputError(f"block {block.name}: {exc}", key=exc.key) from None


def spec_values(template: str, block: Block, crs: str) -> dict[str, Any]:
    """The template's values (TOML text) with the block's area (in `crs`), name and overrides: a spec
    as TOML would give it."""
    import shapely

    data: dict[str, Any] = copy.deepcopy(tomllib.loads(template))
    area = data.setdefault("area", {})
    area.pop("file", None)
    area["wkt"] = shapely.to_wkt(shapely.from_wkb(block.wkb), rounding_precision=-1)
    area["wkt_crs"] = crs
    data.setdefault("mission", {})["name"] = block.name
    found = dict(block.overrides)
    targets = data.setdefault("targets", {})
    for key, other in (("gsd_cm", "height_m"), ("height_m", "gsd_cm")):
        if key in found:
            targets[key] = found[key]
            targets.pop(other, None)
    if "heading" in found:
        data.setdefault("flight", {})["heading"] = found["heading"]
    if "launch_lon" in found:
        area["launch"] = [found["launch_lon"], found["launch_lat"]]
    if "profiles" in found:
        data.setdefault("rules", {})["profiles"] = [p.strip() for p in found["profiles"].split(",") if p.strip()]
    return data


@dataclass(frozen=True)
class BlockResult:
    """What became of a block: `status` "planned", "rules-fail" (planned, written, an error-level
    rule fails) or "failed" (not planned: `message` says why); `record` is block.json's content
    for a written block."""

    name: str
    key: str
    status: str
    record: dict[str, Any] | None = None
    message: str = ""


def plan_block(job: BlockJob, campaign: str) -> BlockResult:
    """Plan one block and write its outputs into CAMPAIGN/blocks/NAME.KEY (see the module's doc);
    a block already there is read, not planned again. Bad input and a plan the final gate
    refuses come back as a "failed" result; nothing is written for them."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import render_outputs
    from aerosurvey.report.features import outline_features

    blocks = Path(campaign) / BLOCKS_DIR
    final = blocks / job.folder
    if final.is_dir():
        return read_result(job, final)
    try:
        spec = block_spec(job.template, Path(job.base), job.block, job.crs)
        plan = plan_from_files(spec)
        rendered = render_outputs(plan, spec, gpkg="gpkg" in job.outputs)
    except AerosurveyError as exc:
        return BlockResult(job.name, job.key, "failed", message=str(exc))
    outputs = rendered.text_bytes | rendered.binary
    chosen = sorted(n for n in outputs if output_group(n) in job.outputs)
    s = rendered.summary
    record: dict[str, Any] = {"format": FORMAT, "name": job.name, "key": job.key, "status": "rules-fail" if s.rules.failed else "planned",
              "area_ha": s.area_ha, "photos": s.photos, "time_min": s.time_min, "distance_km": s.distance_km,
              "sorties": len(s.sorties), "gsd_cm": s.gsd_target_cm, "heading_deg": s.heading_deg, "vehicle": spec.vehicle.type,
              "rules": {"evaluated": s.rules.evaluated, "passed": s.rules.passed, "failing": list(s.rules.failing),
                        "failed": list(s.rules.failed)},
              "warnings": len(rendered.warnings), "files": chosen}
    blocks.mkdir(parents=True, exist_ok=True)
    temp = Path(tempfile.mkdtemp(prefix=f".{job.folder}.", suffix=TEMP_SUFFIX, dir=blocks))
    try:
        for name in chosen:
            (temp / name).write_bytes(outputs[name])
        outline = {"type": "FeatureCollection", "features": outline_features(plan)}
        (temp / OUTLINE_FILE).write_text(json.dumps(outline, separators=(",", ":")) + "\n", encoding="utf-8")
        (temp / RESULT_FILE).write_text(json.dumps(record, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        os.chmod(temp, 0o755)  # mkdtemp makes 0700
        try:
            os.rename(temp, final)
        except OSError:
            if not (final / RESULT_FILE).is_file():
                raise
            # another attempt of this block renamed its folder first: the same inputs, the same files
    finally:
        shutil.rmtree(temp, ignore_errors=True)
    return BlockResult(job.name, job.key, record["status"], record)


def plan_blocks(jobs: Sequence[BlockJob], campaign: str) -> list[BlockResult | Exception]:
    """`plan_block` of each job in turn: one executor task for several blocks (a task costs a Dask
    worker and scheduler a few milliseconds of CPU, a small block ~50 ms). A block whose attempt
    raises has the exception as its outcome, and the next block is planned."""
    outcomes: list[BlockResult | Exception] = []
    for job in jobs:
        try:
            outcomes.append(plan_block(job, campaign))
        except Exception as exc:  # the block's own error, passed on as its outcome
            outcomes.append(exc)
    return outcomes


def read_result(job: BlockJob, folder: Path) -> BlockResult:
    """The result of a block written earlier, from its block.json."""
    record = json.loads((folder / RESULT_FILE).read_text(encoding="utf-8"))
    return BlockResult(job.name, job.key, record["status"], record)


def clean_temporary(campaign: Path) -> int:
    """Remove the temporary folders a killed run left in CAMPAIGN/blocks; how many there were."""
    blocks = campaign / BLOCKS_DIR
    if not blocks.is_dir():
        return 0
    left = [p for p in blocks.iterdir() if p.name.startswith(".") and p.name.endswith(TEMP_SUFFIX)]
    for p in left:
        shutil.rmtree(p, ignore_errors=True)
    return len(left)
