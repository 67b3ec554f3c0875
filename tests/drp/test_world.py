"""World, objective (Eq. 3.1) and JSON validation."""

import json

import numpy as np
import pytest

from jaxdc.drp import world
from tests.support import drp_reference as ref


def tiny():
    # base (0,0); node 1 at (3,4) (D=5), node 2 at (3,0) (D=3); D(1,2)=4
    return world.Graph(np.zeros(2), np.array([[3.0, 4.0], [3.0, 0.0]]), np.array([2.0, 1.0]), 0.9, 10.0)


def test_expected_reward_hand_computed():
    D, beta, psi = world.arrays(tiny())
    one = 0.9 ** 5 * 2 + 0.9 ** 10 * 10 - 10
    two = 0.9 ** 3 * 1 + 0.9 ** 7 * 2 + 0.9 ** 12 * 10 - 10
    assert float(world.tour_reward(D, beta, psi, np.array([1, -1]))) == pytest.approx(one, rel=1e-5)
    assert float(world.tour_reward(D, beta, psi, np.array([2, 1]))) == pytest.approx(two, rel=1e-5)
    plan = np.array([[1, -1], [2, -1]])
    sep = one + 0.9 ** 3 * 1 + 0.9 ** 6 * 10 - 10
    assert float(world.expected_reward(D, beta, psi, plan)) == pytest.approx(sep, rel=1e-5)
    assert float(world.expected_reward(D, beta, psi, np.array([[-1, -1]]))) == 0.0
    # tour_gain includes the return with beta(0) = alpha
    assert float(world.tour_gain(D, beta, psi, np.array([2, 1]))) == pytest.approx(two + 10, rel=1e-5)


def test_objective_matches_reference_on_random_tours():
    rng = np.random.default_rng(1)
    g = world.generate(4, n=8, size=30, alpha=15.0)
    D, beta, psi = world.arrays(g)
    Dl, bl = np.asarray(D, float).tolist(), np.asarray(beta, float).tolist()
    for _ in range(5):
        k = rng.integers(1, 9)
        t = list(rng.permutation(np.arange(1, 9))[:k])
        padded = np.array(t + [-1] * (8 - k))
        assert float(world.tour_reward(D, beta, psi, padded)) == pytest.approx(
            ref.tour_reward(Dl, bl, 0.99, t), rel=1e-4, abs=1e-4)


def test_generator_is_deterministic_and_matches_the_setup():
    a, b, c = world.generate(7), world.generate(7), world.generate(8)
    assert np.array_equal(a.nodes, b.nodes) and np.array_equal(a.rewards, b.rewards)
    assert not np.array_equal(a.nodes, c.nodes)
    assert a.nodes.shape == (100, 2) and (a.nodes >= 0).all() and (a.nodes <= 100).all()
    assert set(np.unique(a.rewards)) <= {4, 5, 6} and a.psi == 0.99
    assert set(np.unique(world.generate(1, rewards="1-9").rewards)) <= set(range(1, 10))
    assert (world.generate(1, rewards="5").rewards == 5).all()
    assert list(world.generate(1, base="centre").base) == [50, 50]
    assert list(world.generate(1, base="corner").base) == [0, 0]
    with pytest.raises(ValueError, match="base"):
        world.generate(1, base="middle")


GOOD = {"base": [0, 0], "nodes": [[1, 2], [3, 4]], "rewards": [1, 2], "psi": 0.99, "alpha": 20}


@pytest.mark.parametrize("change, exc, words", [
    ({"psi": None}, ValueError, "missing the key 'psi'"),
    ({"rewards": [1]}, ValueError, "len(rewards)=1"),
    ({"psi": 0.0}, ValueError, "psi must be in (0, 1]"),
    ({"psi": 1.5}, ValueError, "psi must be in (0, 1]"),
    ({"rewards": [1, -2]}, ValueError, "rewards[1] must be >= 0"),
    ({"alpha": -1}, ValueError, "alpha must be >= 0"),
    ({"alpha": "x"}, TypeError, "alpha must be a number"),
    ({"nodes": [[1, "a"], [3, 4]]}, TypeError, "nodes[0][1] must be a number"),
    ({"rewards": [1, True]}, TypeError, "rewards[1] must be a number"),
    ({"nodes": [], "rewards": []}, ValueError, "nodes must be a non-empty"),
    ({"base": [1]}, ValueError, "base must be a pair"),
])
def test_bad_json_names_the_field(tmp_path, change, exc, words):
    data = dict(GOOD)
    for k, v in change.items():
        if v is None:
            del data[k]
        else:
            data[k] = v
    path = tmp_path / "g.json"
    path.write_text(json.dumps(data))
    with pytest.raises(exc) as e:
        world.load(path)
    assert words in str(e.value)


def test_json_round_trip(tmp_path):
    g = world.generate(3, n=5)
    world.save(g, tmp_path / "g.json")
    h = world.load(tmp_path / "g.json")
    assert np.allclose(g.nodes, h.nodes) and np.allclose(g.rewards, h.rewards) and h.alpha == g.alpha
    (tmp_path / "bad.json").write_text("{nope")
    with pytest.raises(ValueError, match="not valid JSON"):
        world.load(tmp_path / "bad.json")
