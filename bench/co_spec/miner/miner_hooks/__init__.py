"""Hand-written hooks for the miner's generated controllers (never overwritten by rcsgen)."""
