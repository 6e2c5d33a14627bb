"""NSSDA (FGDC-STD-007.3-1998) accuracy at 95 % from check point residuals (pure).

Horizontal: 1.7308 RMSE_r when RMSE_x = RMSE_y; 2.4477 × 0.5 × (RMSE_x + RMSE_y) when
0.6 ≤ RMSE_min / RMSE_max ≤ 1 (both ends included, compared within a few ulps: see
asprs.nssda_horizontal_95); below 0.6 the exact circular error (the standard asks for it
there). Vertical: 1.9600 RMSE_z. At least 20 check points.
Reporting statement (section 3.2.3, as secondary sources give it; not confirmed
against the standard's text): "Tested ___ (meters, feet) horizontal accuracy at 95% confidence
level", and the same for vertical accuracy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aerosurvey.qa import statistics as st
from aerosurvey.qa.asprs import nssda_horizontal_95, record_verdicts, within
from aerosurvey.qa.choices import STANDARDS

MIN_CHECK_POINTS = 20
NAME = STANDARDS["nssda"]


def evaluate(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, max_h95_cm: float | None = None,
             max_v95_cm: float | None = None) -> dict[str, Any]:
    """Accuracy at 95 %, the method used, an optional test against required values, the report sentences."""
    rx, ry = st.rmse(dx), st.rmse(dy)
    acc_h, method = nssda_horizontal_95(rx, ry)
    v = st.vertical_summary(dz)
    acc_v = v.get("le95_m")
    out: dict[str, Any] = {"rmse_x_m": rx, "rmse_y_m": ry, "horizontal_95_m": acc_h, "horizontal_method": method,
                           "rmse_z_m": v.get("rmse_z_m"), "vertical_95_m": acc_v,
                           "required_h95_cm": max_h95_cm, "required_v95_cm": max_v95_cm}
    record_verdicts(out, within(acc_h, max_h95_cm / 100) if max_h95_cm is not None else None,
                    within(acc_v, max_v95_cm / 100) if max_v95_cm is not None and acc_v is not None else None)
    out["sentences"] = [f"Tested {acc_h:.3f} meters horizontal accuracy at 95% confidence level"]
    if acc_v is not None:
        out["sentences"].append(f"Tested {acc_v:.3f} meters vertical accuracy at 95% confidence level")
    return out


def figures(r: dict[str, Any]) -> list[str]:
    """The figures in our own words, for a set that does not make a valid test (no statement)."""
    text = (f"Figures only, no {NAME} statement (see the result's reasons): horizontal accuracy at 95 % "
            f"{r['horizontal_95_m']:.3f} m ({r['horizontal_method']})")
    if r["vertical_95_m"] is not None:
        text += f", vertical accuracy at 95 % {r['vertical_95_m']:.3f} m"
    return [text + "."]
