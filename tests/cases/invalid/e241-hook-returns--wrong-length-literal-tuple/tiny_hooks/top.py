def nudge(n, flag):
    if flag:
        return n * 2.5, 1.0, 0
    return 0.0, 0.0, 0
