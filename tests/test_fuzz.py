"""A fast subset of the fuzzer (`python -m tests.fuzz` runs the full one): no traceback, hang, non-finite
output, modified input or double race winner."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.fuzz import dataset_pair, run_fuzz, summary


@pytest.mark.slow
def test_fuzz_subset(tmp_path: Path) -> None:
    pair = dataset_pair()
    if pair is None:
        pytest.skip("the dataset is not here: set ELASTYLE_DATA")
    outcomes = run_fuzz(*pair, tmp_path, count=40, seed=1)
    assert not [o for o in outcomes if o.problems], summary(outcomes, 0)
