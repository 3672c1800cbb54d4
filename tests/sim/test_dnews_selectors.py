"""DNEWS into a direction selector: the header allows any DREG as the destination."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.sim import R1, R2, R3, R4, R5, Scamp5, east, north, south, west

LONE = np.zeros((5, 5), dtype=bool)
LONE[2, 2] = True


@pytest.mark.parametrize("dst", [R1, R2, R3, R4])
@pytest.mark.parametrize("direction", [north, east, south, west, north | east])
def test_dnews_into_a_selector_reads_the_neighbours(dst, direction) -> None:
    sim = Scamp5(5, 5)
    sim.write(R5, LONE)
    sim.DNEWS(dst, R5, direction)
    want = np.zeros((5, 5), dtype=bool)
    for d in (north, east, south, west):
        if d in direction:  # the elements whose neighbour in d is the lone 1
            dr, dc = d.offset
            want[2 - dr, 2 - dc] = True
    np.testing.assert_array_equal(sim.read(dst), want)
    assert sim.read(dst).any()
