"""The vector-env contract (rl/vec_env.py), its gymnasium adapter and observation stacking."""

from __future__ import annotations

import numpy as np
import pytest

from rl.gym_vec import GymVecEnv
from rl.stack import StackObs
from rl.vec_env import StatefulVecEnv, VecEnv, check_step
from tests.toy_env import StatefulToyEnv, ToyEnv


class CounterEnv:
    """obs = 100 * episode + t (t: steps into the episode); env i's episodes last i + 2
    steps and end terminated (even envs) or truncated (odd envs)."""

    obs_dim = 1
    act_dim = 1

    def __init__(self, num_envs: int = 3) -> None:
        self.num_envs = num_envs
        self.t = np.zeros(num_envs, dtype=np.int64)
        self.ep = np.zeros(num_envs, dtype=np.int64)

    def _obs(self) -> np.ndarray:
        return (100.0 * self.ep + self.t)[:, None].astype(np.float32)

    def reset(self, seed: int | None = None) -> np.ndarray:
        self.t[:] = 0
        self.ep[:] = 0
        return self._obs()

    def step(self, actions: np.ndarray):
        self.t += 1
        done = self.t >= np.arange(self.num_envs) + 2
        odd = np.arange(self.num_envs) % 2 == 1
        info = {
            "final_obs": self._obs(),
            "success": done & ~odd,
            "episode_return": self.t.astype(float),
            "episode_length": self.t.copy(),
            "time_to_success": np.where(done & ~odd, self.t * 0.02, np.nan),
        }
        self.ep[done] += 1
        self.t[done] = 0
        n = self.num_envs
        return self._obs(), np.ones(n, np.float32), done & ~odd, done & odd, info


@pytest.mark.parametrize("make", [lambda: ToyEnv(4), lambda: CounterEnv(3)])
def test_envs_satisfy_contract(make) -> None:
    env = make()
    assert isinstance(env, VecEnv)
    obs = env.reset(seed=0)
    assert obs.shape == (env.num_envs, env.obs_dim) and obs.dtype == np.float32
    for _ in range(25):
        check_step(env, env.step(np.zeros((env.num_envs, env.act_dim), np.float32)))


def test_check_step_names_the_bad_array() -> None:
    env = ToyEnv(2)
    env.reset(seed=0)
    obs, r, term, trunc, info = env.step(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="reward has shape"):
        check_step(env, (obs, r[:1], term, trunc, info))
    with pytest.raises(ValueError, match="info lacks 'success'"):
        check_step(env, (obs, r, term, trunc, {k: v for k, v in info.items() if k != "success"}))


def test_toy_env_is_reproducible_and_stateful() -> None:
    a, b = StatefulToyEnv(3), StatefulToyEnv(3)
    assert isinstance(a, StatefulVecEnv) and not isinstance(ToyEnv(1), StatefulVecEnv)
    np.testing.assert_array_equal(a.reset(seed=5), b.reset(seed=5))
    rng = np.random.default_rng(0)
    for _ in range(30):
        act = rng.uniform(-1, 1, (3, 2))
        np.testing.assert_array_equal(a.step(act)[0], b.step(act)[0])
    c = StatefulToyEnv(3)
    c.set_state(a.get_state())
    act = rng.uniform(-1, 1, (3, 2))
    np.testing.assert_array_equal(a.step(act)[0], c.step(act)[0])


def test_gym_adapter_pendulum() -> None:
    env = GymVecEnv("Pendulum-v1", 2)
    obs = env.reset(seed=3)
    assert obs.shape == (2, 3) and obs.dtype == np.float32 and env.act_dim == 1
    np.testing.assert_array_equal(obs, GymVecEnv("Pendulum-v1", 2).reset(seed=3))
    for _ in range(200):
        result = env.step(np.ones((2, 1), np.float32))
        check_step(env, result)
        _, reward, term, trunc, info = result
        assert reward.dtype == np.float32 and not term.any()
    # Pendulum's time limit: 200 steps, then truncation with the final observation kept
    assert trunc.all() and (info["episode_length"] == 200).all()
    assert np.isnan(info["time_to_success"]).all() and not info["success"].any()
    assert np.abs(np.linalg.norm(info["final_obs"][:, :2], axis=1) - 1).max() < 1e-5


def test_gym_adapter_rescales_actions() -> None:
    env = GymVecEnv("Pendulum-v1", 1)
    env.reset(seed=0)
    seen = []
    env.envs[0].step = lambda a: (seen.append(a), (np.zeros(3), 0.0, False, False, {}))[1]
    env.step(np.array([[-1.0]]))
    env.step(np.array([[0.5]]))
    np.testing.assert_allclose([s[0] for s in seen], [-2.0, 1.0])  # torque bounds +-2


def test_stack_order_and_fill() -> None:
    env = StackObs(CounterEnv(3), 3)
    assert env.obs_dim == 3
    obs = env.reset()
    np.testing.assert_array_equal(obs, np.zeros((3, 3)))  # first observation repeated
    obs, _, _, _, _ = env.step(np.zeros((3, 1)))
    # env 0 ends after 2 steps, env 1 after 3, env 2 after 4: after one step, all go on
    np.testing.assert_array_equal(obs, [[1, 0, 0]] * 3)  # newest first
    obs, _, term, trunc, info = env.step(np.zeros((3, 1)))
    assert term[0] and not trunc[0] and not (term | trunc)[1:].any()
    np.testing.assert_array_equal(info["final_obs"][0], [2, 1, 0])  # stacked like obs
    np.testing.assert_array_equal(obs[0], [100, 100, 100])  # new episode: filled
    np.testing.assert_array_equal(obs[1:], [[2, 1, 0]] * 2)
    obs, _, term, trunc, info = env.step(np.zeros((3, 1)))
    assert trunc[1] and not term[1]
    np.testing.assert_array_equal(info["final_obs"][1], [3, 2, 1])
    np.testing.assert_array_equal(obs, [[101, 100, 100], [100, 100, 100], [3, 2, 1]])


def test_stack_one_is_identity_and_state_round_trip() -> None:
    inner = StatefulToyEnv(2)
    env = StackObs(inner, 1)
    np.testing.assert_array_equal(env.reset(seed=1), StatefulToyEnv(2).reset(seed=1))
    env = StackObs(StatefulToyEnv(2), 4)
    env.reset(seed=1)
    env.step(np.ones((2, 2)))
    other = StackObs(StatefulToyEnv(2), 4)
    other.set_state(env.get_state())
    act = np.full((2, 2), -0.5)
    np.testing.assert_array_equal(env.step(act)[0], other.step(act)[0])
    assert not hasattr(StackObs(ToyEnv(1), 2), "get_state")
    with pytest.raises(ValueError, match="stack at least 1"):
        StackObs(ToyEnv(1), 0)
