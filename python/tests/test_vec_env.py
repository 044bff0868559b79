"""mbmf.VecEnv: the task's world and the simulated human, stepped by an agent of one's own."""

from __future__ import annotations

import numpy as np
import pytest

import mbmf


def test_shapes_and_types() -> None:
    env = mbmf.VecEnv("tidy1", 6, seed=2)
    assert (env.num_envs, env.n_actions) == (6, 7)
    assert len(env.state_names) == env.n_states
    obs = env.reset()
    assert obs.shape == (6,) and obs.dtype == np.int64
    obs, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.int64))
    assert obs.shape == reward.shape == terminated.shape == truncated.shape == (6,)
    assert reward.dtype == np.float64 and terminated.dtype == np.bool_
    assert ((0 <= obs) & (obs < env.n_states)).all()
    for key in ("action", "final_obs", "takeover", "congratulation", "punishment", "nuisance",
                "human_reward", "forgotten", "budget_left"):
        assert info[key].shape == (6,), key
    assert "task_state" not in info


def test_auto_reset_at_the_goal() -> None:
    env = mbmf.VecEnv("chain", 2, seed=1)
    assert env.reset().tolist() == [0, 0]
    obs, reward, terminated, truncated, info = env.step([1, 0])
    assert terminated.tolist() == [True, False]
    assert reward.tolist() == [1.0, 0.0]
    assert obs.tolist() == [0, 0]
    assert info["final_obs"].tolist() == [1, 0]
    env = mbmf.VecEnv("chain", 1, seed=1, max_episode_steps=2)
    env.reset()
    cut = [env.step([0])[3][0] for _ in range(4)]
    assert cut == [False, True, False, True]


def test_takeovers_and_the_budget_are_in_info() -> None:
    env = mbmf.VecEnv("tidy1", 4, seed=9, interaction="takeover", budget=3, forget_prob=0.0)
    env.reset()
    taken = np.zeros(4, dtype=int)
    for _ in range(300):
        _, _, _, _, info = env.step(np.zeros(4, dtype=np.int64))
        taken += info["takeover"]
        # A takeover executes the human's action, not the agent's 0.
        assert (info["action"][~info["takeover"]] == 0).all()
    assert taken.tolist() == [3, 3, 3, 3]
    assert info["budget_left"].tolist() == [0, 0, 0, 0]
    # reset restores the budget.
    env.reset()
    assert env.step(np.zeros(4, dtype=np.int64))[4]["budget_left"].max() <= 3


def test_congratulations_are_reported() -> None:
    env = mbmf.VecEnv("tidy1", 8, seed=4, interaction="congratulation", budget=1000,
                      forget_prob=0.0)
    env.reset()
    rng = np.random.default_rng(0)
    seen = 0
    for _ in range(200):
        _, _, _, _, info = env.step(rng.integers(0, env.n_actions, size=8))
        seen += int(info["congratulation"].sum())
        assert not info["punishment"].any() and not info["takeover"].any()
    assert seen > 0
    assert (info["budget_left"] == 1000 - 0).sum() < 8


def test_same_seed_same_episodes() -> None:
    def roll(seed: int) -> list[list[int]]:
        env = mbmf.VecEnv("twostep", 3, seed=seed)
        env.reset()
        out = []
        for t in range(50):
            obs, reward, *_ = env.step(np.full(3, t % 2))
            out.append(obs.tolist() + reward.tolist())
        return out

    assert roll(5) == roll(5)
    assert roll(5) != roll(6)


def test_twostep_reports_the_drifting_reward_probabilities() -> None:
    env = mbmf.VecEnv("twostep", 2, seed=1)
    env.reset()
    info = env.step([0, 1])[4]
    assert info["task_state"].shape == (2, 4)
    assert ((0.25 <= info["task_state"]) & (info["task_state"] <= 0.75)).all()


def test_bad_actions_and_parameters() -> None:
    env = mbmf.VecEnv("tidy1", 3, seed=1)
    env.reset()
    with pytest.raises(ValueError, match="action 7 at index 2 is out of range: expected 0 to 6"):
        env.step([0, 1, 7])
    with pytest.raises(ValueError, match="action -1 at index 0 is out of range"):
        env.step([-1, 1, 2])
    with pytest.raises(ValueError, match=r"expected shape \(3,\)"):
        env.step([0, 1])
    with pytest.raises(ValueError, match="expected integers"):
        env.step([0.5, 1, 2])
    with pytest.raises(ValueError, match="'interaction'"):
        mbmf.VecEnv("tidy1", 2, interaction="hug")
    with pytest.raises(TypeError, match="VecEnv\\(\\) got an unexpected keyword argument 'budgte'; did you mean 'budget'"):
        mbmf.VecEnv("tidy1", 2, budgte=3)
    with pytest.raises(ValueError, match="interaction 'takeover' is not defined for task 'chain'"):
        mbmf.VecEnv("chain", 2, interaction="takeover", budget=3)
    with pytest.raises(ValueError, match="num_envs"):
        mbmf.VecEnv("tidy1", 0)
