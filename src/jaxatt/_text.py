"""Numbers as text for tables and printed reports."""

import math


def percent(fraction: float, decimals: int = 1) -> str:
    """`fraction` as a percentage with `decimals` decimals, more where rounding would hide
    that it is not all or not none: 9999 of 10000 reads `"99.99 %"`, never `"100.0 %"`, and 1
    of 10000 `"0.01 %"`, never `"0.0 %"`. NaN (a fraction of an empty set) reads `"-"`."""
    fraction = float(fraction)
    if math.isnan(fraction):
        return "-"
    for places in range(decimals, 16):
        text = f"{100 * fraction:.{places}f}"
        if (fraction < 1 and float(text) >= 100) or (fraction > 0 and float(text) <= 0):
            continue
        return f"{text} %"
    return f"{100 * fraction!r} %"
