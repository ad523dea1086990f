"""Newton's residual line search (``numerics.line_search``): when it is on, what it does to a
pressed coil stack, and that it leaves scenes without contact alone."""

from __future__ import annotations

import pytest

from bathprint import SceneError, Simulation


@pytest.mark.parametrize(
    ("effects", "value", "expected"),
    [
        (["elasticity", "drag", "gravity"], "auto", False),
        (["elasticity", "drag", "gravity", "contact"], "auto", True),
        (["elasticity", "drag", "gravity"], "residual", True),
        (["elasticity", "drag", "gravity", "contact"], "off", False),
    ],
)
def test_auto_searches_where_contact_is_listed(effects, value, expected) -> None:
    sim = Simulation("drag_coiling_22G", {"effects": effects, "numerics.line_search": value})
    assert bool(sim.model.params[0]["line_search"]) is expected


def test_a_bad_line_search_is_refused_by_name() -> None:
    with pytest.raises(SceneError, match=r"numerics\.line_search"):
        Simulation("drag_coiling_22G", {"numerics.line_search": "wolfe"})


def test_a_tall_pressed_stack_needs_few_newton_iterations_with_or_without_the_line_search(
    pressed_stack,
) -> None:
    """1000 nodes (16 turns pressed onto each other) for 20 ms. With contact at the closest
    points of nearly parallel turns, Newton wandered, and without the line search a stalled
    solve halved its updates for good (294 Newton iterations against 148 with it). With
    contact at the middle of their overlap (``contact_params``) neither needs it: 96 and 95
    iterations on the machine this was written on. What holds: the line search costs no
    more iterations or failures than the plain updates. The bound leaves room for a CPU's
    rounding to move a few iterations either way."""
    counts = {}
    for mode in ("off", "residual"):
        sim = pressed_stack(1000, **{"numerics.line_search": mode})
        sim.advance(0.02)
        assert sim.t == pytest.approx(0.02)
        counts[mode] = sim.counts()
    assert counts["off"]["line_search_backtracks"] == 0
    assert counts["residual"]["newton_iterations"] <= 1.05 * counts["off"]["newton_iterations"]
    assert counts["residual"]["newton_failures"] <= counts["off"]["newton_failures"]
    # 5.0 per step (7.8 with contact at the closest points)
    assert counts["residual"]["newton_iterations"] < 6 * counts["residual"]["steps"]
