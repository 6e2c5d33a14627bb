"""What a reporting statement names besides the figures: the product, its CRS and datums, the
number of check points and the check point survey.

A statement ("This data set was tested to meet …", "Tested … at 95 % confidence level") is
issued only when every item is known (`Identity.missing`); otherwise the result is *not
tested* with the list of what is missing (qa/validity.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import pyproj


@dataclass(frozen=True)
class Product:
    """The tested product as the user states it (`--product`, `--gsd-cm`, `--product-date`,
    `--vertical-datum`, `--survey-source`)."""

    kind: str | None = None  # e.g. orthoimagery, DEM
    gsd_cm: float | None = None  # ground sample distance (or cell size) of the product
    date: str | None = None  # ISO date of the product
    vertical_datum: str | None = None  # when the CRS has no vertical part, e.g. "EGM2008 geoid"
    survey_source: str | None = None  # how the check points were surveyed, e.g. "GNSS RTK, CZEPOS"


@lru_cache(maxsize=64)
def datums(crs_text: str | None) -> tuple[str | None, str | None]:
    """(horizontal datum, vertical datum) of a CRS by pyproj's database; a compound CRS gives both."""
    if not crs_text:
        return None, None
    crs = pyproj.CRS.from_user_input(crs_text)
    parts = crs.sub_crs_list or [crs]
    horizontal = next((p.datum.name for p in parts if not p.is_vertical and p.datum is not None), None)
    vertical = next((p.datum.name for p in parts if p.is_vertical and p.datum is not None), None)
    return horizontal, vertical


def crs_label(crs_text: str | None) -> str | None:
    return f"{pyproj.CRS.from_user_input(crs_text).name} ({crs_text})" if crs_text else None


@dataclass(frozen=True)
class Identity:
    product: Product
    crs: str | None  # as the points state it (e.g. EPSG:5514)
    check_points: int
    heights: bool  # heights are tested
    survey_xy_m: float | None  # σ of one horizontal coordinate of the check point survey
    survey_z_m: float | None

    @property
    def horizontal_datum(self) -> str | None:
        return datums(self.crs)[0]

    @property
    def vertical_datum(self) -> str | None:
        return datums(self.crs)[1] or self.product.vertical_datum

    def missing(self) -> list[str]:
        """Every item a statement needs and that is not given, with the option that gives it."""
        p = self.product
        need = [(p.kind, "the product type (--product)"), (p.gsd_cm, "its GSD (--gsd-cm)"),
                (p.date, "its date (--product-date)"), (self.crs, "the CRS (--crs, a crs column or GeoJSON crs)"),
                (self.survey_xy_m, "the check point survey's horizontal accuracy (--ref-sigma-xy or sigma_xy)"),
                (p.survey_source, "the check point survey's source (--survey-source)")]
        if self.crs and self.horizontal_datum is None:
            need.append((None, f"a horizontal datum (the CRS {self.crs} has none)"))
        if self.heights:
            need += [(self.vertical_datum, "the vertical datum or geoid (--vertical-datum, or a compound CRS)"),
                     (self.survey_z_m, "the check point survey's vertical accuracy (--ref-sigma-z or sigma_z)")]
        return [what for value, what in need if value is None]

    def sentence(self) -> str:
        """The identification that goes with the statement (only when nothing is missing)."""
        p = self.product
        text = (f"Product: {p.kind}, GSD {p.gsd_cm:g} cm, dated {p.date}; CRS {crs_label(self.crs)}, horizontal "
                f"datum {self.horizontal_datum}")
        if self.heights:
            text += f", vertical datum {self.vertical_datum}"
        survey = f"{(self.survey_xy_m or 0.0) * 100:.2f} cm per horizontal coordinate"
        if self.heights:
            survey += f", {(self.survey_z_m or 0.0) * 100:.2f} cm in height"
        return (f"{text}. Tested on {self.check_points} independent check points surveyed by {p.survey_source} "
                f"(standard deviation {survey}).")
