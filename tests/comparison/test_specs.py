"""comparison.specs: what a recorded setting and a requested one differ in."""

from __future__ import annotations

from sb3_geogp.comparison.specs import setting_differences


def test_setting_differences_names_each_differing_key_and_nothing_else() -> None:
    made = {"algo": "ppo", "target": "monte_carlo", "seed": 0}
    asked = {"algo": "ppo", "target": "monte_carlo", "seed": 1, "horizon": 200}
    assert setting_differences(made, asked) == "horizon: unset there, 200 now; seed: 0 there, 1 now"
    assert setting_differences(asked, made) == "horizon: 200 there, unset now; seed: 1 there, 0 now"
    assert setting_differences(made, dict(made)) == ""
    assert setting_differences(-100.0, -90.0) == "-100.0 there, -90.0 now"
