"""QA verdicts of a campaign's blocks: filed by `campaign record CAMPAIGN BLOCK qa --accuracy FILE` and
read back for `campaign report` (docs/campaign.md).

The accuracy.json `qa accuracy -o` wrote for a block is copied to CAMPAIGN/qa/FOLDER/accuracy.json
(FOLDER: the block's folder name, NAME.KEY, so a block planned again under a new key starts with no
verdict) and its figures go into the "qa" event's detail. `campaign report` learns from the
accepted blocks that have one (campaign/learn.py), with the relief under each block from its
manifest.json (`derived.terrain`: the DEM's range; none without a DEM).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from aerosurvey.campaign.job import BLOCKS_DIR
from aerosurvey.campaign.learn import BlockAccuracy
from aerosurvey.campaign.register import BlockRow, record
from aerosurvey.qa.accuracy_file import FILE, read_accuracy

QA_DIR = "qa"


def verdict_path(campaign: Path, row: BlockRow) -> Path:
    return campaign / QA_DIR / row.folder / FILE


def file_accuracy(campaign: Path, row: BlockRow, accuracy: Path) -> None:
    """Copy an accuracy.json (or the one in a folder), read with `read_accuracy` before, under the block's QA
    folder, whole."""
    from aerosurvey.fileio import atomic_write_bytes

    source = accuracy / FILE if accuracy.is_dir() else accuracy
    target = verdict_path(campaign, row)
    target.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(target, source.read_bytes())


def record_verdict(campaign: Path, block: str | None, accuracy: Path, detail: str, now: str, *,
                   folder: str | None = None) -> BlockRow:
    """File a block's QA verdict (by its name, or its folder: `register.record`): a "qa" event whose detail is the
    figures of the accuracy.json (or of the one in a folder), `detail` after them, and the file copied under the
    block's QA folder, both under the register's lock. The one place a verdict is filed."""
    figures = read_accuracy(accuracy)
    return record(campaign, block, "qa", figures.text() + (f"; {detail}" if detail else ""), now, folder=folder,
                  file=lambda row: file_accuracy(campaign, row, accuracy))


def relief_m(campaign: Path, row: BlockRow) -> float | None:
    """The range of the DEM under the block as planned (manifest derived.terrain); None without a DEM."""
    from aerosurvey import manifest as mf

    terrain = mf.read_manifest(campaign / BLOCKS_DIR / row.folder, f"block {row.name}").raw["derived"]["terrain"]
    low, high = terrain.get("ground_min_m"), terrain.get("ground_max_m")
    return float(high) - float(low) if low is not None and high is not None else None


def accepted_figures(campaign: Path, rows: Sequence[BlockRow]) -> tuple[int, list[BlockAccuracy]]:
    """How many blocks are accepted, and the figures of those with a filed QA verdict."""
    accepted = [r for r in rows if r.status == "accepted"]
    out = []
    for r in accepted:
        path = verdict_path(campaign, r)
        if not path.is_file():
            continue
        f = read_accuracy(path)
        out.append(BlockAccuracy(r.name, r.gsd_cm, r.area_ha, f.control_points, relief_m(campaign, r),
                                 (f.rmse_x_m * 100, f.rmse_y_m * 100, f.rmse_z_m * 100 if f.rmse_z_m is not None else None),
                                 f.class_h_cm, f.class_v_cm, f.result))
    return len(accepted), out
