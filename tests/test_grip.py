"""The verdict's lost grip (sim.trial.Grip, docs/model.md 11.20) against a brute-force reading of
its rule over the whole tick sequence: no digit on the object for LOSS_WINDOW, or A or B absent
for LOSS_WINDOW when the termination begins; a contact that parts and comes back is kept."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from ungrasp_ompl.sim.trial import LOSS_WINDOW, Grip

TICK = 0.002  # s, the control period of the shipped scenes


def _run(ticks: list[tuple[bool, bool]]) -> tuple[Grip, float | None]:
    """Note the ticks (A, B touching) one control period apart until the object leaves the hand."""
    grip = Grip()
    for k, (a, b) in enumerate(ticks, 1):
        if (free := grip.note(k * TICK, a, b)) is not None:
            return grip, free
    return grip, None


def _first_free(ticks: list[tuple[bool, bool]]) -> float | None:
    """Brute force: the start of the first run of ticks with no digit that lasts LOSS_WINDOW."""
    times = [k * TICK for k in range(1, len(ticks) + 1)]
    for end in range(len(ticks)):
        for start in range(end + 1):
            if all(not a and not b for a, b in ticks[start:end + 1]) and times[end] - times[start] >= LOSS_WINDOW:
                return times[start]
    return None


def _trailing_absence(ticks: list[tuple[bool, bool]], digit: int) -> float | None:
    """Brute force: when the digit's last run of absence up to the last tick began (None if it touches then)."""
    k = len(ticks)
    while k > 0 and not ticks[k - 1][digit]:
        k -= 1
    return None if k == len(ticks) else (k + 1) * TICK


_runs = st.lists(st.tuples(st.sampled_from([(True, True), (True, False), (False, True), (False, False)]),
                           st.integers(1, 40)), min_size=1, max_size=12)


@settings(max_examples=300, deadline=None)
@given(_runs)
def test_the_grip_is_lost_as_the_rule_says_over_any_sequence_of_contacts(runs):
    ticks = [contact for contact, n in runs for _ in range(n)]
    grip, free = _run(ticks)
    expected = _first_free(ticks)
    assert (free is None) == (expected is None)
    if free is not None:
        assert abs(free - expected) < 1e-9
        return
    last = len(ticks) * TICK
    gone = [s for s in (_trailing_absence(ticks, 0), _trailing_absence(ticks, 1))
            if s is not None and last - s >= LOSS_WINDOW]
    assert grip.pinch_lost() == (min(gone) if gone else None)


def test_a_thumb_parted_for_260_ms_while_the_finger_presses_is_not_a_lost_grip():
    """Session 51's trial 78: B absent for 130 ticks in P_psi, A pressing throughout, then B back."""
    ticks = [(True, True)] * 100 + [(True, False)] * 130 + [(True, True)] * 100
    grip, free = _run(ticks)
    assert free is None and grip.pinch_lost() is None
    assert abs(grip.b_gap - 129 * TICK) < 1e-9 and grip.a_gap == 0.0


def test_a_pinch_without_b_when_the_termination_begins_is_a_lost_grip_dated_when_b_went():
    grip, free = _run([(True, True)] * 100 + [(True, False)] * 30)  # B absent for the last 58 ms
    assert free is None and abs(grip.pinch_lost() - 101 * TICK) < 1e-9
    grip, _ = _run([(True, True)] * 100 + [(True, False)] * 25)  # 48 ms: a sliding contact's flicker
    assert grip.pinch_lost() is None
    grip, free = _run([(True, True)] * 100 + [(False, False)] * 30)  # neither: out of the hand after 50 ms
    assert abs(free - 101 * TICK) < 1e-9
