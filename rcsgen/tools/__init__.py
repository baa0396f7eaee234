"""Tools: what runs and inspects generated systems (harness, scenario runner); they may read
the compiler's IR and the runtime contract, and nothing in compiler or runtime imports them."""
