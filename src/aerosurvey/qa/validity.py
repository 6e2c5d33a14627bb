"""Whether a set of points makes a valid test by the chosen standard (pure).

A verdict ("tested to meet") is given only when every condition holds; otherwise the
result is **not tested** (no independent check point at all) or **indicative only** (a
test ran, but a condition of the standard is not met), with the reasons. The conditions:

- independent check points: control points used in the adjustment show the fit, never the
  accuracy (ASPRS 2014 and NSSDA ask for independent check points);
- their number: the standard's minimum for the project area (asprs.Required), and the
  plan's own rule (e.g. the Czech land-consolidation profile's 1 check point per 3 ha) when
  a campaign is given;
- their own accuracy: ASPRS 2014 asks check points 3× more accurate than the product,
  Edition 2 about 2× (secondary source); a known survey σ that misses it makes the test
  indicative only, an unknown one is stated as such;
- enough evidence for the method (`evidence`): the fewest points a method can decide on
  (data snooping: a blunder of the stated size detectable at the stated power; the Bayesian
  estimate: the standards' minimum of 20); below it the result is *not tested*;
- the inputs a standard's reporting statement needs (`statement_inputs`): the product's
  identity, the CRS and vertical datum, the check point survey's accuracy and source;
  without them no statement is issued and the result is *not tested*.
The mean error is reported and flagged (review.mean_error_findings), never a condition: the
25 % limit found in secondary sources could not be quoted from the standards.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

NOT_TESTED = "not tested"
INDICATIVE = "indicative only"
VALID = "valid"


@dataclass
class Validity:
    conditions: list[dict[str, Any]] = field(default_factory=list)

    def add(self, name: str, met: bool | None, detail: str, severity: str = INDICATIVE) -> None:
        """met None: could not be checked (stated, not held against the test)."""
        self.conditions.append({"condition": name, "met": met, "detail": detail,
                                "severity": severity if met is False else None})

    @property
    def status(self) -> str:
        failed = [c["severity"] for c in self.conditions if c["met"] is False]
        if NOT_TESTED in failed:
            return NOT_TESTED
        return INDICATIVE if failed else VALID

    @property
    def reasons(self) -> list[str]:
        return [c["detail"] for c in self.conditions if c["met"] is False]

    def as_dict(self) -> dict[str, Any]:
        return {"status": self.status, "reasons": self.reasons, "conditions": self.conditions}


def independence(v: Validity, n_check: int, n_control: int) -> None:
    if n_check == 0:
        v.add("independent check points", False,
              f"no independent check point: the {n_control} point(s) are ground control used in the adjustment, "
              "whose residuals show the fit of the adjustment, not the accuracy of the product", NOT_TESTED)
    else:
        v.add("independent check points", True, f"{n_check} check point(s) not used in the adjustment")


def count(v: Validity, n: int, need: int, what: str) -> None:
    if need <= 0:
        return
    v.add(f"number of {what}", n >= need, f"{n} {what}, {need} required" if n >= need else
          f"too few {what}: {n} < {need} required")


def survey_accuracy(v: Validity, label: str, survey_m: float | None, product_m: float | None, ratio: float,
                    rule: str) -> None:
    if product_m is None or not product_m > 0:
        return
    if survey_m is None:
        v.add(f"check point survey accuracy ({label})", None,
              f"the check point survey's accuracy ({label}) is not given: whether it is {ratio:g}x better than the "
              f"product ({rule}) is not known")
        return
    ok = survey_m * ratio <= product_m * (1 + 1e-12)
    v.add(f"check point survey accuracy ({label})", ok,
          f"check point survey {survey_m * 100:.2f} cm {'is' if ok else 'is NOT'} {ratio:g}x more accurate than the "
          f"product's {product_m * 100:.2f} cm ({label}; {rule})")


def evidence(v: Validity, method: str, n: int, need: int | None, why: str) -> None:
    """The fewest points `method` can decide on; fewer (or None: no number is enough) is *not tested*."""
    ok = need is not None and n >= need
    v.add(f"evidence for {method}", ok,
          f"{n} points, {need} needed for {method} ({why})" if ok else
          f"too little evidence for {method}: {n} points, "
          + (f"{need} needed" if need is not None else "no number of points is enough") + f" ({why})", NOT_TESTED)


def statement_inputs(v: Validity, standard: str, missing: list[str]) -> None:
    """Everything a reporting statement names must be known before it is issued."""
    v.add(f"inputs of the {standard} statement", not missing,
          f"no {standard} statement without: {', '.join(missing)}" if missing else
          f"every input of the {standard} statement is given", NOT_TESTED)
