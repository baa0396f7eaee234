"""Hand-written hooks for the platoon's generated controllers (never overwritten by rcsgen)."""
