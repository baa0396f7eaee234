def nudge(n, flag):
    n = n * 2.5
