"""The comparison's runs: the same zoo hyperparameters and budget for every critic; the zoo's
yaml format read the same way from the built-in tables and from a user's file."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
import torch as th

from sb3_geogp.comparison.hyperparams import (
    ALL_CRITICS,
    CRITICS,
    ENVS,
    THRESHOLDS,
    TIMESTEPS,
    ZOO_HYPERPARAMS,
    ZOO_SOURCE,
    HyperparamsFile,
    algo_kwargs,
    hyperparams,
    normalize_kwargs,
    normalizes_actor,
    parse_policy_kwargs,
    threshold,
)
from sb3_geogp.comparison.results import PAIRS
from sb3_geogp.comparison.specs import SweepConfig
from sb3_geogp.kernels import KERNELS

TOY = "tests.comparison.toy_env:ToyEnv-v0"


@pytest.fixture(autouse=True)
def _tests_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    """``tests.comparison.toy_env`` importable however pytest was started."""
    monkeypatch.syspath_prepend(str(Path(__file__).parents[2]))


def test_every_gp_kernel_is_a_critic_compared_with_the_mlp() -> None:
    """Two lists that must not drift: the critics a sweep runs and the kernels the GP has."""
    assert ALL_CRITICS[: len(CRITICS)] == CRITICS == SweepConfig().critics
    assert sorted(ALL_CRITICS) == sorted(["mlp", *KERNELS])
    assert {a for a, b in PAIRS if b == "mlp"} == set(KERNELS)


def test_hyperparams_identical_across_critics_and_from_the_zoo() -> None:
    specs = SweepConfig(seeds=(0,)).specs()
    assert len(specs) == 2 * 3 * len(ENVS)
    hp = hyperparams("ppo", "Pendulum-v1")
    assert hp.source == ZOO_SOURCE and hp.n_timesteps == TIMESTEPS["Pendulum-v1"]
    n_envs, kwargs, policy_kwargs = algo_kwargs("ppo", hp.values)
    assert n_envs == 4 and kwargs["n_steps"] == 1024 and kwargs["gamma"] == 0.9
    assert "normalize" not in kwargs and "n_timesteps" not in kwargs
    _, kwargs, _ = algo_kwargs("ppo", hyperparams("ppo", "CartPole-v1").values)
    assert kwargs["learning_rate"](1.0) == pytest.approx(1e-3)  # lin_0.001
    assert kwargs["learning_rate"](0.5) == pytest.approx(5e-4)
    _, _, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", "MountainCarContinuous-v0").values)
    assert policy_kwargs == dict(log_std_init=0.0, ortho_init=False)
    assert set(ZOO_HYPERPARAMS["a2c"]) == set(ZOO_HYPERPARAMS["ppo"])
    assert hyperparams("a2c", "sb3_geogp/WallMaze-v0").source == "ours"
    by_cell: dict[tuple[str, str], set[int]] = {}
    for s in specs:
        by_cell.setdefault((s.algo, s.env_id), set()).add(s.total_timesteps)
        assert s.threshold == THRESHOLDS[s.env_id]
    assert all(len(v) == 1 for v in by_cell.values())  # same budget for the three critics


def test_policy_kwargs_string_is_read_without_eval() -> None:
    text = """dict(log_std_init=-2,
                   ortho_init=False,
                   activation_fn=nn.ReLU,
                   net_arch=dict(pi=[256, 256], vf=[256, 256]),
                   )"""
    assert parse_policy_kwargs(text) == dict(
        log_std_init=-2,
        ortho_init=False,
        activation_fn=th.nn.ReLU,
        net_arch=dict(pi=[256, 256], vf=[256, 256]),
    )
    assert parse_policy_kwargs("{'activation_fn': th.nn.Tanh, 'x': (1, -0.5, None)}") == {
        "activation_fn": th.nn.Tanh,
        "x": (1, -0.5, None),
    }
    # The mapping form names the activation function as text.
    _, _, policy_kwargs = algo_kwargs("ppo", {"policy_kwargs": {"activation_fn": "nn.GELU"}})
    assert policy_kwargs == {"activation_fn": th.nn.GELU}
    for code, named in (
        ("__import__('os').system('true')", "__import__"),
        ("dict(a=os.system)", "os.system"),
        ("dict(**other)", "dict(**other)"),
        ("dict(a=(lambda: 1))", "lambda"),
        ("dict(a=1 + 1)", "1 + 1"),
        ("[1, 2]", "must be dict"),
        ("dict(a=", "not a Python expression"),
    ):
        with pytest.raises(ValueError, match=re.escape(named)):
            parse_policy_kwargs(code)


def test_entries_are_checked_key_by_key() -> None:
    n_envs, kwargs, _ = algo_kwargs(
        "a2c", dict(n_envs=3, n_timesteps=1e5, normalize="dict(norm_obs=False)", gamma=1)
    )
    assert n_envs == 3 and kwargs == dict(gamma=1)
    for entry, message in (
        (dict(env_wrapper="gymnasium.wrappers.TimeAwareObservation"), "env_wrapper is not"),
        (dict(frame_stack=4), "frame_stack is not"),
        (dict(env_kwargs=dict(size=3)), "gymnasium.register"),
        (dict(callback="sb3_geogp.GPValueCallback"), "callback is not"),
        (dict(policy="CnnPolicy"), "policy: compare trains"),
        (dict(n_step=8), "unknown key 'n_step' for ppo"),
        (dict(batch_size=64), None),
        (dict(n_steps="8"), "n_steps must be an integer, got '8' .YAML reads 8 as text"),
        (dict(learning_rate="3e-4"), "learning_rate must be a number"),
        (dict(clip_range="lin_x"), "clip_range: expected 'lin_<number>'"),
        (dict(use_sde=1), "use_sde must be true or false"),
        (dict(n_envs=0), "n_envs must be at least 1"),
        (dict(n_timesteps="1e5"), "n_timesteps must be a positive number"),
        (dict(policy_kwargs=[1]), "policy_kwargs must be a mapping"),
    ):
        if message is None:
            algo_kwargs("ppo", entry)
        else:
            with pytest.raises(ValueError, match=message):
                algo_kwargs("ppo", entry)
    with pytest.raises(ValueError, match="unknown key 'batch_size' for a2c"):
        algo_kwargs("a2c", dict(batch_size=64))


@pytest.mark.skipif(importlib.util.find_spec("rl_zoo3") is None, reason="needs rl_zoo3")
def test_the_zoos_own_files_are_read() -> None:
    """Every entry of rl-baselines3-zoo's ppo.yml and a2c.yml is read, or refused naming a key
    compare cannot honour."""
    import rl_zoo3

    unsupported = ("env_wrapper", "frame_stack", "policy", "callback", "vec_env_wrapper")
    read = 0
    for algo in ("ppo", "a2c"):
        file = HyperparamsFile.read(Path(rl_zoo3.__file__).parent / "hyperparams" / f"{algo}.yml")
        for env_id, entry in file.entries.items():
            try:
                algo_kwargs(algo, entry)
                read += 1
            except ValueError as err:
                assert str(err).startswith(unsupported), (env_id, err)
        assert algo_kwargs(algo, file.entries["CartPole-v1"]) is not None
    assert read > 20


def test_files_and_their_errors(tmp_path: Path) -> None:
    path = tmp_path / "ppo.yml"
    path.write_text("ToyEnv-v0:\n  n_steps: 16\n  n_timesteps: !!float 1e3\n")
    file = HyperparamsFile.read(path)
    # Keyed by the id, or by its name without the module, as the zoo writes it.
    hp = hyperparams("ppo", TOY, file)
    assert hp == (dict(n_steps=16, n_timesteps=1000.0), str(path), 1000.0)
    # A built-in environment in a file: the file's entry, the built-in budget without its own.
    path.write_text("CartPole-v1:\n  n_steps: 16\n")
    assert hyperparams("ppo", "CartPole-v1", HyperparamsFile.read(path)).n_timesteps == 30_000
    with pytest.raises(ValueError, match=r"has no entry 'Acrobot-v1' \(its entries: CartPole-v1"):
        hyperparams("ppo", "Acrobot-v1", HyperparamsFile.read(path))
    with pytest.raises(ValueError, match=r"no built-in ppo hyperparameters for .*--hyperparams"):
        hyperparams("ppo", TOY)
    with pytest.raises(ValueError, match=r"cannot read .*missing\.yml"):
        HyperparamsFile.read(tmp_path / "missing.yml")
    path.write_text("ToyEnv-v0:\n  n_steps: [16\n")
    with pytest.raises(ValueError, match="is not valid YAML") as err:
        HyperparamsFile.read(path)
    assert "\n" not in str(err.value)
    for text in ("- 1\n- 2\n", "ToyEnv-v0: 3\n", ""):
        path.write_text(text)
        with pytest.raises(ValueError, match="not in rl-baselines3-zoo's format"):
            HyperparamsFile.read(path)


def test_threshold_given_built_in_registered_or_asked_for() -> None:
    assert threshold("CartPole-v1") == 475.0 and threshold("CartPole-v1", 100) == 100.0
    assert threshold("tests.comparison.toy_env:ToyEnvWarns-v0") == -2.0  # reward_threshold
    with pytest.raises(ValueError, match=r"no threshold for .*pass --threshold"):
        threshold(TOY)


def test_normalize_kwargs_are_those_rl_zoo3_builds() -> None:
    """rl-baselines3-zoo wraps a normalising entry in ``VecNormalize(**kwargs)``, with SB3's
    defaults for ``normalize: true`` and the entry's ``gamma`` added (``ExperimentManager``)."""
    assert normalize_kwargs(ZOO_HYPERPARAMS["ppo"]["Acrobot-v1"]) == {"gamma": 0.99}
    assert normalize_kwargs(ZOO_HYPERPARAMS["a2c"]["Acrobot-v1"]) == {}
    assert normalize_kwargs(ZOO_HYPERPARAMS["ppo"]["CartPole-v1"]) is None
    entry = dict(normalize="dict(norm_obs=False, norm_reward=True)", gamma=0.9)
    assert normalize_kwargs(entry) == {"norm_obs": False, "norm_reward": True, "gamma": 0.9}
    assert normalize_kwargs(dict(normalize=dict(norm_obs=True))) == {"norm_obs": True}
    for bad in (1, [True]):
        with pytest.raises(ValueError, match="normalize must be true, false or dict"):
            normalize_kwargs(dict(normalize=bad))
    # A string is read as policy_kwargs' are, and its mistakes name normalize.
    for bad, why in (
        ("dict(norm_obs=os.system)", "normalize: 'os.system' is not allowed"),
        ("[1]", "normalize must be dict"),
        ("dict(", "normalize is not a Python"),
    ):
        with pytest.raises(ValueError, match=re.escape(why)):
            normalize_kwargs(dict(normalize=bad))
    # Every zoo entry the comparison marks "(normalize)" gives VecNormalize's arguments.
    marked = [(a, e) for a, t in ZOO_HYPERPARAMS.items() for e, v in t.items() if "normalize" in v]
    assert len(marked) == 5
    for algo, env_id in marked:
        kwargs = normalize_kwargs(ZOO_HYPERPARAMS[algo][env_id])
        assert kwargs is not None and set(kwargs) <= {"gamma"}, (algo, env_id)


def test_the_actor_is_normalised_where_the_zoos_vecnormalize_normalises_observations() -> None:
    assert normalizes_actor(ZOO_HYPERPARAMS["ppo"]["Acrobot-v1"])
    assert normalizes_actor(ZOO_HYPERPARAMS["a2c"]["MountainCarContinuous-v0"])
    assert not normalizes_actor(ZOO_HYPERPARAMS["ppo"]["CartPole-v1"])
    assert not normalizes_actor(dict(normalize="dict(norm_obs=False, norm_reward=True)"))
    with pytest.raises(ValueError, match=r"normalize sets clip_obs; .* --gp-normalize"):
        normalizes_actor(dict(normalize=dict(clip_obs=5.0)))
