"""rcsgen: NIST RCS controllers from declared state tables."""

__version__ = "0.1.0"
