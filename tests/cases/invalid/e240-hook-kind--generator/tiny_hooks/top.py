def nudge(n, flag):
    while True:
        yield n * 2.5
