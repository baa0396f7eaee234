"""Hand-written hooks for the submarine's generated controllers (never overwritten by rcsgen)."""
