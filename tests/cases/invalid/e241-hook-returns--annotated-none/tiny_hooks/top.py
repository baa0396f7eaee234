def nudge(n: int, flag: bool) -> None:
    print(n, flag)
