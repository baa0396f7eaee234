"""Hooks of top."""


def nudge(n):
    return n + 1
