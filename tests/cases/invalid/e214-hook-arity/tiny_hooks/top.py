def nudge(n, m):
    return n
