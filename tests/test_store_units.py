"""Placeholder."""


def test_placeholder():
    pass
