"""Numbers as MJCF attribute text, deterministic: a float's repr is the shortest text that
reads back to the same float, so the same value always gives the same bytes."""

from __future__ import annotations

import numpy as np


def xml_number(x: float) -> str:
    """`x` as attribute text: "0" for zero (either sign), otherwise repr(float(x))."""
    x = float(x)
    return "0" if x == 0 else repr(x)


def xml_vector(v) -> str:
    """The values of `v` (any shape, flattened) as space-separated xml_number texts."""
    return " ".join(xml_number(x) for x in np.asarray(v, dtype=float).ravel())
