"""Bad input across the public API and the CLI: a clear error naming the value, never a hang.

The cases live in ``tests/invalid_cases/*.py`` (one module per area).  Each runs under a
per-case timeout, so a case that would hang fails instead of stalling the suite.
"""

from __future__ import annotations

import importlib
import pkgutil

import invalid_cases
import pytest
from invalid_cases import Case

#: Seconds one case may take before it counts as a hang.
CASE_TIMEOUT = 60


def _collect() -> list[Case]:
    cases: list[Case] = []
    for info in sorted(pkgutil.iter_modules(invalid_cases.__path__), key=lambda m: m.name):
        mod = importlib.import_module(f"invalid_cases.{info.name}")
        cases.extend(mod.CASES)
    return cases


ALL_CASES = _collect()


def test_there_are_at_least_150_cases_with_unique_ids():
    ids = [c.id for c in ALL_CASES]
    assert len(ids) >= 150
    assert len(set(ids)) == len(ids), sorted({i for i in ids if ids.count(i) > 1})


@pytest.mark.timeout(CASE_TIMEOUT)
@pytest.mark.parametrize("case", ALL_CASES, ids=[c.id for c in ALL_CASES])
def test_invalid_input_is_rejected_naming_the_value(case: Case):
    with pytest.raises(case.exc) as info:
        case.call()
    assert case.names in str(info.value), f"message {str(info.value)!r} does not name {case.names!r}"
