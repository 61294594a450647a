"""The cone hull's angle reduction (`hand.angle_in_turn`, MODEL 7) is Python's `a % (2 pi)` bit
for bit: the same value and the same sign of zero, for the angles the hull meets (within one
turn of [0, 2 pi)), at the turn's edges, and for any other finite angle."""
from __future__ import annotations

import math

from hypothesis import example, given, settings
from hypothesis import strategies as st

from profiles import LONG_PROPERTIES
from sweep.kernels.hand import angle_in_turn

TURN = 2.0 * math.pi


def same_bits(a: float, b: float) -> bool:
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


@settings(max_examples=20_000 if LONG_PROPERTIES else 2_000, deadline=None)
@given(st.one_of(st.floats(-2.0 * TURN, 3.0 * TURN, allow_nan=False),
                 st.floats(-1e6, 1e6, allow_nan=False)))
@example(0.0)
@example(-0.0)
@example(TURN)
@example(-TURN)
@example(2.0 * TURN)
@example(math.nextafter(TURN, 0.0))
@example(math.nextafter(-TURN, 0.0))
@example(math.nextafter(2.0 * TURN, 0.0))
@example(math.nextafter(0.0, -1.0))
@example(-5e-324)
def test_angle_in_turn_is_pythons_modulo(a):
    assert same_bits(angle_in_turn(a), a % TURN)
