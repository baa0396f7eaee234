def nudge(n: int, flag: bool) -> tuple[int, float]:
    return n + 1, n * 2.5
