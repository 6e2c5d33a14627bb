"""What the accuracy QA offers: the standards, the length units and the snooping defaults.

A light module (no numpy or scipy): `aerosurvey qa accuracy --help` lists these choices
without loading the statistics. `assessment` and `accuracy_input` use them from here.
"""

from __future__ import annotations

#: Standard id -> its full name, as results and reports give it.
STANDARDS = {
    "asprs2014": "ASPRS Positional Accuracy Standards, Edition 1 (2014)",
    "asprs2023": "ASPRS Positional Accuracy Standards, Edition 2 (2023)",
    "nssda": "NSSDA (FGDC-STD-007.3-1998)",
    # the id is the one it had as "Cadastral data snooping (Hellenic Cadastre practice)": the method is now
    # Baarda's and Pope's, the cadastral practice's thresholds it was derived from are in docs/qa-accuracy.md
    "snooping": "Data snooping (Baarda's w-test / Pope's tau-test)",
    "bayes": "Bayesian estimate with an uncertain reference survey (Jeffreys prior)",
}

#: Length unit -> metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048}

#: Data snooping's defaults (qa/snooping.py, and the `qa accuracy` options that change them):
#: the per-value false-alarm probability (Baarda's customary choice, k = 3.29), the power at
#: which the minimal detectable bias is stated, the largest MDB (in σ) a decision is made with,
#: and the limit on the share of rejected points (the Hellenic Cadastre practice's 5 %).
SNOOPING_ALPHA0 = 0.001
SNOOPING_POWER = 0.80
SNOOPING_MAX_MDB = 8.0
SNOOPING_MAX_SHARE = 0.05
