def nudged(n):
    return n
