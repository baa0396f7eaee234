"""The CMM simulator's hooks: a part file and the run's seed -> what the probe reads.

A part file gives, one feature per line, the feature's name (as the inspection program
names it) and the part's true size in millimetres; `#` starts a comment. A feature the
file does not list is made exactly to the program's nominal size, so a part file lists
only its seeded deviations:

    # bracket B-7, serial 1002: the bore is oversize
    bore_diameter   12.050

Each reading is the true size plus probing noise (Gaussian, NOISE mm), from a generator
seeded by the run's `seed` setting, so runs with the same settings read the same values.

The CMM carries a camera (calibrate Camera, the paper's Figure 4): calibrating it images
the reference sphere (SPHERE_DIAMETER mm) and finds its diameter in pixels, the true
CAMERA_SCALE's plus edge-finding noise (PIXEL_NOISE pixels, a generator of its own from the
same seed, so the probe's readings are those they were without a camera); the scale found is
the sphere's diameter over the pixels.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path

from .ms import SYSTEM_DIR, Feature, ProgramError, _number, program_path, read_program

DEFAULT_PART = "parts/nominal.part"
NOISE = 0.002  # mm, one standard deviation of a reading
CAMERA_SCALE = 0.0125  # mm per pixel, the simulated camera's true scale
SPHERE_DIAMETER = 25.0  # mm, the reference sphere the camera images
PIXEL_NOISE = 0.5  # pixels, one standard deviation of the sphere's diameter found


@dataclass
class Part:
    """The part on the table: each program feature's true size, the probe's noise and the
    camera's."""

    features: list[Feature]
    sizes: dict[str, float]
    noise: random.Random
    camera: random.Random


def read_part(path: Path, features: list[Feature]) -> dict[str, float]:
    """The true size of every feature of the program on the part file at `path`."""
    sizes = {f.name: f.nominal for f in features}
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ProgramError(f"{path}: cannot read the part file ({error.strerror})") from None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        where = f"{path}:{number}"
        if len(line) != 2:
            raise ProgramError(f"{where}: expected `feature size`, got {raw.strip()!r}")
        if line[0] not in sizes:
            known = ", ".join(sorted(sizes))
            raise ProgramError(f"{where}: the program measures no feature `{line[0]}` ({known})")
        sizes[line[0]] = _number(line[1], where)
    return sizes


def new_part(settings: dict[str, str]) -> Part:
    """The CMM simulator's hook state: the run's part, under the run's program."""
    features = read_program(program_path(settings))
    sizes = read_part(SYSTEM_DIR / settings.get("part", DEFAULT_PART), features)
    try:
        seed = int(settings.get("seed", "1"))
    except ValueError:
        raise ProgramError(f"setting `seed`: `{settings['seed']}` is not an integer") from None
    return Part(features, sizes, random.Random(seed), random.Random(f"camera {seed}"))


def probe(part: Part, feature: int) -> float:
    """A reading of the program's `feature` on the part: its true size plus noise, to 0.1 um."""
    if not 0 <= feature < len(part.features):
        raise ProgramError(f"feature {feature} is not in the program (0-{len(part.features) - 1})")
    size = part.sizes[part.features[feature].name]
    return round(size + part.noise.gauss(0.0, NOISE), 4)


def image_sphere(part: Part) -> float:
    """Calibrate the camera: the reference sphere's diameter in pixels, as the image shows it
    (true scale plus edge-finding noise), gives the scale in mm per pixel, to 0.1 nm."""
    pixels = SPHERE_DIAMETER / CAMERA_SCALE + part.camera.gauss(0.0, PIXEL_NOISE)
    return round(SPHERE_DIAMETER / pixels, 7)
