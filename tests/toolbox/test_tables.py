"""The decision of a registered reading: any failed rule decides, unfinished runs decide nothing."""

from __future__ import annotations

import pytest

from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

KEPT, ADOPTED = "keep the default", "adopt the candidate"


@pytest.mark.parametrize(
    ("states", "decision"),
    [
        (["holds", "holds"], ADOPTED),
        (["holds", "fails (CartPole-v1)"], KEPT),
        (["holds", PARTIAL], "partial, nothing changes"),
        # A rule already failed on the runs made fails whatever the unfinished ones show.
        ([PARTIAL, "fails (Acrobot-v1)"], KEPT),
    ],
)
def test_registered_decision(states: list[str], decision: str) -> None:
    rules = [(f"rule {i}", state) for i, state in enumerate(states)]
    lines = registered_decision(rules, KEPT, ADOPTED).split("\n")
    assert lines[: len(states)] == [f"- rule {i}: {s}" for i, s in enumerate(states)]
    assert lines[-1] == f"**Decision**: {decision}"
