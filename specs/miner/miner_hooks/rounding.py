"""`round(x, 6)` and `round(x, 9)`, the same floats without a decimal string.

The simulators round every value they report so that traces are short and stable; Python's
`round(x, n)` formats `x` as a decimal string and parses it back (~0.6 µs, several times a
cycle). Here `x` is scaled by 10**n (one floating multiplication, off the exact product by at
most half a unit in its last place) and rounded to a whole number `k`; when the scaled value
is not within 1/10,000 of a tie and the whole number is exact (|x * 10**n| < 10**11), `k` is
the nearest integer to the exact product too, so `k / 10**n` (one correctly rounded division
of two exact floats) is the double nearest to the decimal `round` makes: the same bits.
A result of zero keeps the sign of `x`, as `round`'s does; anything else (a near tie, a
large or non-finite value) is left to `round` itself. tests/test_miner.py compares the two
on 90,000 seeded values.
"""

from __future__ import annotations


def round6(x: float) -> float:
    """`round(x, 6)`, bit for bit."""
    p = x * 1e6
    if -1e11 < p < 1e11:
        k = round(p)
        if -0.4999 < p - k < 0.4999:
            return k / 1e6 if k else x * 0.0  # (zero keeps the sign of x, as round's)
    return round(x, 6)


def round9(x: float) -> float:
    """`round(x, 9)`, bit for bit."""
    p = x * 1e9
    if -1e11 < p < 1e11:
        k = round(p)
        if -0.4999 < p - k < 0.4999:
            return k / 1e9 if k else x * 0.0  # (zero keeps the sign of x, as round's)
    return round(x, 9)
