def nudge(n: int, flag: bool) -> float:
    return n * 2.5 if flag else 0.0
