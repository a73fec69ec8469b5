"""Printing :class:`gridbridge.classifiers.People` gives a short summary, not the whole mask."""

from __future__ import annotations

import numpy as np

from gridbridge.classifiers import People


def _people(n: int) -> People:
    mask = np.zeros((30, 30), dtype=bool)
    mask[:n, 0] = True
    return People(
        positions=np.column_stack((np.arange(n) + 0.123456, -np.arange(n) * 0.5 - 0.001)),
        scores=np.full(n, 0.876543),
        sizes=np.ones(n, dtype=np.int64),
        mask=mask,
    )


def test_repr_is_short_and_rounded() -> None:
    text = repr(_people(2))
    assert text == (
        "People(n=2, positions=[(0.12, 0.00), (1.12, -0.50)], scores=[0.88, 0.88], sizes=[1, 1], mask=(30, 30) 2 cells)"
    )
    assert str(_people(2)) == text


def test_repr_of_many_and_of_nobody() -> None:
    many = repr(_people(20))
    assert many.startswith("People(n=20, positions=[(0.12, 0.00),") and many.count("(") < 10
    assert many.endswith("sizes=[1, 1, 1, 1, 1, ...], mask=(30, 30) 20 cells)")
    assert len(many) < 250
    nobody = People(np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((4, 5), dtype=bool))
    assert repr(nobody) == "People(n=0, positions=[], scores=[], sizes=[], mask=(4, 5) 0 cells)"
