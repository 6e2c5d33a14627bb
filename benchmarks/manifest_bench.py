"""Manifest schema check: jsonschema over the whole manifest against aerosurvey.schemas.first_error
(the stations table checked by column, jsonschema on the rest), same manifest, same run.

    python benchmarks/manifest_bench.py                   # plans the Obratan example (1756 stations) first
    python benchmarks/manifest_bench.py --plan PLAN_DIR   # an existing plan folder

Prints the median of 5 runs of each and their ratio; both must agree that the manifest is valid.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--plan", type=Path, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        plan = args.plan
        if plan is None:
            plan = Path(tmp) / "obratan"
            subprocess.run([sys.executable, "-m", "aerosurvey.cli", "plan", str(REPO / "missions" / "obratan-72ha.toml"),
                            "-o", str(plan)], check=True, stdout=subprocess.DEVNULL)
        import jsonschema

        from aerosurvey import schemas

        doc = json.loads((plan / "manifest.json").read_text(encoding="utf-8"))
        full = jsonschema.Draft202012Validator(schemas.schema("manifest"))
        schemas.first_error("manifest", doc)  # warm both (the schema's compiled state is cached)
        list(full.iter_errors(doc))
        t_full, t_ours = [], []
        for _ in range(5):
            t0 = time.perf_counter()
            errs = list(full.iter_errors(doc))
            t1 = time.perf_counter()
            ours = schemas.first_error("manifest", doc)
            t2 = time.perf_counter()
            t_full.append(t1 - t0)
            t_ours.append(t2 - t1)
            assert not errs and ours is None, (errs[:1], ours)
        a, b = statistics.median(t_full), statistics.median(t_ours)
        print(f"{len(doc['stations'])} stations: jsonschema {a:.3f} s, column check + jsonschema {b:.3f} s, ratio {a / b:.1f}x")


if __name__ == "__main__":
    main()
