"""Order statistics without numpy's first-call cost: `np.median` and numpy's interpolating percentiles
import numpy.ma on their first call in a process (about 20 ms of a command's start-up), so the transfer's
path takes its medians here."""

from __future__ import annotations

import numpy as np

from elastyle.types import FloatArray


def median(values: FloatArray, axis: int = 0) -> FloatArray:
    """The median of values along `axis` (the mean of the two middle values for an even count), as
    `np.median` gives it; NaN values are not skipped (sorted last, they are middle values only where more
    than half are NaN)."""
    ordered = np.sort(np.asarray(values, dtype=np.float64), axis=axis)
    count = ordered.shape[axis]
    lower = np.take(ordered, (count - 1) // 2, axis=axis)
    upper = np.take(ordered, count // 2, axis=axis)
    return (lower + upper) / 2
