"""Hooks of the typed test system."""


def describe(program: str, side: int) -> str:
    return f"{program}@{side}"
