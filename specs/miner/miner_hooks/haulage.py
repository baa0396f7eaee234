"""Haulage behind the conveyor (the `shuttle_car` setting) -> how much coal it takes each cycle.

Without the setting the haulage takes whatever the conveyor brings (a belt). With
`shuttle_car: "CAPACITY TRIP"` one shuttle car of CAPACITY tonnes waits under the conveyor
tail; full, it leaves to dump and is back TRIP cycles later, and until then the conveyor
has nowhere to put coal, so the gathering head stops taking it and loose coal piles up in
front of the machine (mining paper, section 2.1.2: the miner waits for the shuttle car).
"""

from __future__ import annotations

from .rounding import round9


class HaulageSettingError(ValueError):
    """The `shuttle_car` setting is not two positive numbers."""


class Haulage:
    def __init__(self, capacity: float, trip: int) -> None:
        self.capacity = capacity  # tonnes a car holds; 0: a belt, no limit
        self.trip = trip  # cycles a full car is away
        self.load = 0.0  # tonnes in the car under the tail
        self.away = 0  # cycles until the car is back (0: it is under the tail)


def new_haulage(settings: dict[str, str]) -> Haulage:
    """The haulage of a run: a belt, or the shuttle car of the `shuttle_car` setting."""
    text = settings.get("shuttle_car")
    if text is None:
        return Haulage(0.0, 0)
    parts = text.split()
    try:
        capacity, trip = float(parts[0]), int(parts[1])
    except (IndexError, ValueError):
        raise HaulageSettingError(
            f"shuttle_car setting {text!r}: want 'CAPACITY TRIP' (tonnes, cycles)"
        ) from None
    if len(parts) != 2 or capacity <= 0 or trip <= 0:
        raise HaulageSettingError(
            f"shuttle_car setting {text!r}: want two positive numbers, tonnes and cycles"
        )
    return Haulage(capacity, trip)


def haul(
    haulage: Haulage, loose: float, mined: float, running: bool, rate: float
) -> tuple[float, float, bool]:
    """One cycle of gathering and haulage: (loose coal left, coal hauled in all, the car is
    away). `running`: gathering head and conveyor on with the tail over the haulage."""
    if haulage.away > 0:
        haulage.away -= 1
        if haulage.away == 0:
            haulage.load = 0.0  # an empty car under the tail
    taken = 0.0
    if running and haulage.away == 0 and loose > 0.0:
        taken = min(loose, rate)
        if haulage.capacity > 0.0:
            taken = min(taken, haulage.capacity - haulage.load)
            haulage.load += taken
            if haulage.load >= haulage.capacity - 1e-9:
                haulage.away = haulage.trip  # full: off to the dump
    return round9(loose - taken), round9(mined + taken), haulage.away > 0
