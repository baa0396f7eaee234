"""The environmental simulator's sea bottom (second paper, section 4.6.5: "The ice keel and
sea bottom profiles were generated using fractals, which allowed a complex structure of
indefinite size and extent without the need for long and complex mappings. They are
generated prior to test runs.").

The bottom is fractal Brownian motion over the plan: OCTAVES layers of value noise, each
twice as fine as the last and half as high, from a lattice of pseudo-random heights that
the run's `bottom_seed` fixes before the run. Any point of the sea has its depth, with no
map to load; the same seed gives the same bottom, cycle for cycle.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

MEAN_DEPTH = 280.0  # m: the bottom's mean depth
RELIEF = 30.0  # m: the most the bottom departs from its mean, either way
COARSE = 4000.0  # m: the lattice spacing of the coarsest layer
OCTAVES = 5  # layers: 4000 m down to 250 m
DEFAULT_SEED = "1"


@dataclass(frozen=True)
class Bottom:
    """A fractal sea bottom, fixed by its seed."""

    seed: int

    def lattice(self, octave: int, i: int, j: int) -> float:
        """The pseudo-random height in -1..1 of lattice point (i, j) of a layer."""
        key = f"{self.seed}:{octave}:{i}:{j}".encode()
        word = int.from_bytes(hashlib.blake2b(key, digest_size=8).digest(), "big")
        return word / 2**63 - 1.0

    def layer(self, octave: int, x: float, y: float) -> float:
        """One layer's value at (x, y): its lattice, smoothly interpolated."""
        step = COARSE / 2**octave
        fx, fy = x / step, y / step
        i, j = math.floor(fx), math.floor(fy)
        tx, ty = fx - i, fy - j
        sx, sy = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)
        a = self.lattice(octave, i, j) + sx * (
            self.lattice(octave, i + 1, j) - self.lattice(octave, i, j)
        )
        b = self.lattice(octave, i, j + 1) + sx * (
            self.lattice(octave, i + 1, j + 1) - self.lattice(octave, i, j + 1)
        )
        return a + sy * (b - a)

    def depth(self, x: float, y: float) -> float:
        """The bottom's depth (m) under (x, y), to the centimetre."""
        total = sum(self.layer(k, x, y) / 2**k for k in range(OCTAVES))
        scale = sum(1 / 2**k for k in range(OCTAVES))
        return round(MEAN_DEPTH + RELIEF * total / scale, 2)


def new_bottom(settings: dict[str, str]) -> Bottom:
    """The run's sea bottom, from its `bottom_seed` setting (a whole number, default 1)."""
    text = settings.get("bottom_seed", DEFAULT_SEED)
    if not text.lstrip("-").isdigit():
        raise ValueError(f"bottom_seed must be a whole number, not {text!r}")
    return Bottom(int(text))


def bottom_at(bottom: Bottom, x: float, y: float) -> float:
    """The sea bottom's depth under the ship."""
    return bottom.depth(x, y)
