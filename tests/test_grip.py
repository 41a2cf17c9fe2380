"""The verdict's lost grip (sim.trial.Grip, docs/model.md 11.4) against a brute-force
reading of its rule over the whole tick sequence: A or B absent for max_gap, or no digit on the
object for LOSS_WINDOW, or A or B absent for the shorter of the two when the termination begins;
max_gap inf is the rule that let one contact part for any time."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ungrasp_ompl.sim.trial import GRAVITY, GRIP_SLACK, LOSS_WINDOW, MAX_CONTACT_GAP, Grip

TICK = 0.002  # s, the control period of the shipped scenes


def _run(ticks: list[tuple[bool, bool]], max_gap: float = MAX_CONTACT_GAP) -> tuple[Grip, float | None]:
    """Note the ticks (A, B touching) one control period apart until the object leaves the hand."""
    grip = Grip(max_gap)
    for k, (a, b) in enumerate(ticks, 1):
        if (free := grip.note(k * TICK, a, b)) is not None:
            return grip, free
    return grip, None


def _first_loss(ticks: list[tuple[bool, bool]], max_gap: float) -> float | None:
    """Brute force: at the first tick that ends a run long enough (no digit for LOSS_WINDOW, or A
    or B absent for max_gap), the earliest start of such a run ending there (each run walked back
    from that tick to its first tick)."""
    times = [k * TICK for k in range(1, len(ticks) + 1)]

    def start(end: int, absent) -> int | None:
        """The first tick of the run of ticks, up to end, at which absent holds (None: not at end)."""
        if not absent(ticks[end]):
            return None
        k = end
        while k > 0 and absent(ticks[k - 1]):
            k -= 1
        return k

    for end in range(len(ticks)):
        starts = []
        none = start(end, lambda t: not t[0] and not t[1])
        if none is not None and times[end] - times[none] >= LOSS_WINDOW:
            starts.append(times[none])
        for digit in (0, 1):
            first = start(end, lambda t: not t[digit])
            if first is not None and times[end] - times[first] >= max_gap:
                starts.append(times[first])
        if starts:
            return min(starts)
    return None


def _trailing_absence(ticks: list[tuple[bool, bool]], digit: int) -> float | None:
    """Brute force: when the digit's last run of absence up to the last tick began (None if it touches then)."""
    k = len(ticks)
    while k > 0 and not ticks[k - 1][digit]:
        k -= 1
    return None if k == len(ticks) else (k + 1) * TICK


_runs = st.lists(st.tuples(st.sampled_from([(True, True), (True, False), (False, True), (False, False)]),
                           st.integers(1, 40)), min_size=1, max_size=12)


@pytest.mark.parametrize("max_gap", [MAX_CONTACT_GAP, math.inf])
@settings(max_examples=300, deadline=None)
@given(runs=_runs)
def test_the_grip_is_lost_as_the_rule_says_over_any_sequence_of_contacts(max_gap, runs):
    ticks = [contact for contact, n in runs for _ in range(n)]
    grip, free = _run(ticks, max_gap)
    expected = _first_loss(ticks, max_gap)
    assert (free is None) == (expected is None)
    if free is not None:
        assert abs(free - expected) < 1e-9
        return
    last = len(ticks) * TICK
    gone = [s for s in (_trailing_absence(ticks, 0), _trailing_absence(ticks, 1))
            if s is not None and last - s >= min(LOSS_WINDOW, max_gap)]
    assert grip.pinch_lost() == (min(gone) if gone else None)


def test_the_longest_gap_is_the_time_in_which_gravity_moves_the_object_by_the_slack():
    """0.5 g t^2 = GRIP_SLACK at t = MAX_CONTACT_GAP: 1 mm in 14.3 ms, between 7 and 8 ticks."""
    assert 0.5 * GRAVITY * MAX_CONTACT_GAP ** 2 == pytest.approx(GRIP_SLACK, rel=1e-12)
    assert 7 * TICK < MAX_CONTACT_GAP < 8 * TICK


def test_a_thumb_parted_for_260_ms_while_the_finger_presses_is_a_lost_grip_only_under_the_bound():
    """B absent for 130 ticks in P_psi, A pressing throughout, then B back: lost once B has been
    away for the bound (dated when it went); kept where one contact may part for any time."""
    ticks = [(True, True)] * 100 + [(True, False)] * 130 + [(True, True)] * 100
    grip, free = _run(ticks, math.inf)
    assert free is None and grip.pinch_lost() is None
    assert abs(grip.b_gap - 129 * TICK) < 1e-9 and grip.a_gap == 0.0
    grip, free = _run(ticks)
    assert abs(free - 101 * TICK) < 1e-9 and abs(grip.b_gap - 8 * TICK) < 1e-9  # found at the 9th tick without B
    grip, free = _run([(True, True)] * 100 + [(True, False)] * 7 + [(True, True)] * 100)  # a 12 ms flicker
    assert free is None and abs(grip.b_gap - 6 * TICK) < 1e-9


def test_a_pinch_without_b_when_the_termination_begins_is_a_lost_grip_dated_when_b_went():
    grip, free = _run([(True, True)] * 100 + [(True, False)] * 30, math.inf)  # B absent for the last 58 ms
    assert free is None and abs(grip.pinch_lost() - 101 * TICK) < 1e-9
    grip, _ = _run([(True, True)] * 100 + [(True, False)] * 25, math.inf)  # 48 ms: a sliding contact's flicker
    assert grip.pinch_lost() is None
    grip, free = _run([(True, True)] * 100 + [(True, False)] * 7)  # 12 ms: under the bound
    assert free is None and grip.pinch_lost() is None
    grip, free = _run([(True, True)] * 100 + [(False, False)] * 30, math.inf)  # neither: out of the hand after 50 ms
    assert abs(free - 101 * TICK) < 1e-9
