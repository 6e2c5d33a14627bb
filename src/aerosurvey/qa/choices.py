"""What the accuracy QA offers: the standards and the length units (names only).

A light module (no numpy or scipy): `aerosurvey qa accuracy --help` lists these choices
without loading the statistics. `assessment` and `accuracy_input` use them from here.
"""

from __future__ import annotations

#: Standard id -> its full name, as results and reports give it.
STANDARDS = {
    "asprs2014": "ASPRS Positional Accuracy Standards, Edition 1 (2014)",
    "asprs2023": "ASPRS Positional Accuracy Standards, Edition 2 (2023)",
    "nssda": "NSSDA (FGDC-STD-007.3-1998)",
    "snooping": "Cadastral data snooping (Hellenic Cadastre practice)",
    "bayes": "Bayesian estimate with an uncertain reference survey (Jeffreys prior)",
}

#: Length unit -> metres.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048}
