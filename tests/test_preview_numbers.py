"""The preview's numbers made by numpy and orjson are the very texts `format(v, ".1f")` makes,
ties (exact binary halves like 0.25, and values like 0.35 just below one) included."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from aerosurvey.report.preview import tenths

ties = st.builds(lambda k: k / 20, st.integers(-10**6, 10**6))  # every multiple of 0.05
near = st.builds(lambda k, e: k / 20 + e, st.integers(-10**5, 10**5), st.sampled_from([1e-12, -1e-12, 1e-7, -1e-7]))


@given(st.lists(st.floats(-1e6, 1e6) | ties | near | st.floats(), max_size=50))
def test_tenths_is_format_1f(values: list[float]) -> None:
    assert tenths(values) == [f"{v:.1f}" for v in values]


def test_tenths_edges() -> None:
    values = [0.0, -0.0, -0.04, 0.04, 0.05, -0.05, 0.15, 0.25, 0.35, 2.5, 1e15, -3e17, 5e-324, math.nan, math.inf]
    assert tenths(values) == [f"{v:.1f}" for v in values]
