"""Hand-written hooks for the inspection workstation's generated controllers (never overwritten by rcsgen)."""
