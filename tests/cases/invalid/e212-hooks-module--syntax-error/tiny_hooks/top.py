def nudge(n:
