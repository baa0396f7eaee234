def nudge(n: int, flag: bool) -> float:
    return n * 2.5
