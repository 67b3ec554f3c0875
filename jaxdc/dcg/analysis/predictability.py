"""How predictable is the opponent's action ``o_t`` at all? (the ceiling of Eq. 5.1's accuracy, section 5.5.3)

OMN and EMNN predict ``o_t`` from what the collector observes: the state
``s_t`` and the history ``h_t`` of the last ``k`` agent planes (sections
5.4.1-5.4.5). Some of ``o_t`` cannot be known from them: the strategy is drawn
per episode and is not shown, and a patrol's far end is drawn at reset and
is seen only once the patrol turns there (section 5.5.1). This module
measures that ceiling on recorded games.

* :func:`record` plays ``num_envs x steps`` steps of a collector policy with
  auto-reset and keeps, per step, what the observation shows (collector and
  opponent cells, whether the opponent is hidden), the episode time and
  strategy, and the label ``o_t`` (``info["opponent_action"]``).
* :func:`window_predict` is a Bayes predictor on exactly what ``(s_t, h_t)``
  shows: it enumerates every hidden opponent state at the start of the
  ``k + 1``-frame window (strategy; for a strategy with memory, its two ends
  and direction; the cell where the opponent was hidden), replays each
  through the registered strategy functions with the collector's observed
  cells, keeps those that reproduce every observed frame, and predicts the
  action with the largest prior mass among them (strategy uniform, as the
  env draws it; uniform within a strategy). Its accuracy is a lower bound on
  the best any network reading ``(s_t, h_t)`` can do, and close to it.
  ``deterministic`` marks the steps on which every consistent hypothesis
  agrees: there ``o_t`` is a function of the observation.
* With the full state (strategy and the patrol's ends included) ``o_t`` is
  the strategy function's output, a deterministic function for the
  deterministic tie rules (``chase_tie`` "straight" and "order").

The true hypothesis is always among the consistent ones; :func:`window_predict`
reports ``label_consistent`` (the label is predicted by some consistent
hypothesis) so that a misaligned label would show as a share below 1.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxdc.agents.a2c import aux_cross_entropy
from jaxdc.core import grid
from jaxdc.core.batched import reset_batched
from jaxdc.core.env import step_batch
from jaxdc.dcg.env import DCG, EnvParams
from jaxdc.dcg.opponents import OpponentState, in_fog
from jaxdc.nets.omn_conn import OMN

#: Strategies whose behaviour depends on the opponent's memory (``home``, ``target``, ``phase``).
MEMORY_STRATEGIES = ("patrol",)


class Record(NamedTuple):
    """One step per entry, ``[steps, num_envs]`` (positions ``[..., 2]``), as the collector saw the state."""

    pos: np.ndarray  # collector cell
    opp_pos: np.ndarray  # opponent cell (meaningless where hidden)
    hidden: np.ndarray  # bool: the opponent is not in the observation
    time: np.ndarray  # steps since the episode's reset
    strategy: np.ndarray  # index into env.strategies
    label: np.ndarray  # o_t


def record(env: DCG, params: EnvParams, policy, key, num_envs: int = 64, steps: int = 200) -> Record:
    """Play ``policy(key, obs, state) -> action`` (one game; vmapped here) in ``num_envs`` games for ``steps`` steps."""
    k_reset, k_run = jax.random.split(key)
    obs, state = reset_batched(env, k_reset, num_envs, params)

    def step(carry, k):
        obs, state = carry
        k_act, k_env = jax.random.split(k)
        action = jax.vmap(policy)(jax.random.split(k_act, num_envs), obs, state)
        seen = (state.pos, state.opponent.pos, jax.vmap(env.opponent_hidden)(state), state.time, state.strategy)
        obs2, state2, *_, info = step_batch(env, k_env, state, action, params)
        return (obs2, state2), (*seen, info["opponent_action"])

    _, out = jax.jit(lambda o, s, ks: jax.lax.scan(step, (o, s), ks))(obs, state, jax.random.split(k_run, steps))
    return Record(*(np.asarray(x) for x in out))


def windows(rec: Record, history: int, skip: int | None = None):
    """The ``k + 1`` frames ``t-k .. t`` of every step with ``t >= skip`` rows recorded before it (default ``k``).

    Returns ``(frames, label, strategy, time)``: ``frames`` a dict of ``[M, k + 1, ...]`` arrays
    ``pos, opp_pos, hidden, exists`` (``exists``: the frame belongs to the step's episode; frames before
    the reset are the zero planes of the history, which show the episode's start).
    """
    k = int(history)
    skip = k if skip is None else skip
    steps, b = rec.time.shape
    rows = np.arange(skip, steps)
    idx = rows[:, None] + np.arange(-k, 1)[None, :]  # [R, k+1]
    take = lambda x: np.moveaxis(x[idx], 2, 1).reshape((-1, k + 1) + x.shape[2:])  # noqa: E731
    time = rec.time[rows].reshape(-1)
    exists = np.arange(-k, 1)[None, :] >= -time[:, None]
    frames = {"pos": take(rec.pos), "opp_pos": take(rec.opp_pos), "hidden": take(rec.hidden), "exists": exists}
    return frames, rec.label[rows].reshape(-1), rec.strategy[rows].reshape(-1), time


def _hypotheses(env: DCG):
    """The enumerated hidden opponent states at a window's start: arrays ``[H]``.

    Per memory strategy: every ``(home, target, phase)`` with the opponent at the observed cell; per other
    strategy: every cell (used only where the opponent is hidden at the window's start).
    """
    n, cells = env.grid_size, env.grid_size ** 2
    strat, cell, home, target, phase, memory = [], [], [], [], [], []
    for s, name in enumerate(env.strategies):
        if name in MEMORY_STRATEGIES:
            h, t, p = np.meshgrid(np.arange(cells), np.arange(cells), np.arange(2), indexing="ij")
            m = h.size
            strat += [np.full(m, s)]; cell += [np.full(m, -1)]  # noqa: E702 -1: the observed cell
            home += [h.ravel()]; target += [t.ravel()]; phase += [p.ravel()]; memory += [np.ones(m, bool)]  # noqa: E702
        else:
            strat += [np.full(cells, s)]; cell += [np.arange(cells)]  # noqa: E702
            home += [np.zeros(cells, int)]; target += [np.zeros(cells, int)]  # noqa: E702
            phase += [np.zeros(cells, int)]; memory += [np.zeros(cells, bool)]  # noqa: E702
    cat = lambda xs: jnp.asarray(np.concatenate(xs), jnp.int32)  # noqa: E731
    hyp = dict(strategy=cat(strat), cell=cat(cell), home=cat(home), target=cat(target), phase=cat(phase))
    hyp["memory"] = jnp.asarray(np.concatenate(memory))
    hyp["unflat"] = lambda i: grid.unflat_index(i, n)
    return hyp


@functools.partial(jax.jit, static_argnums=0)
def _predict_chunk(env: DCG, params: EnvParams, fr_all: dict):
    """:func:`window_predict` on one chunk of windows (jitted once per env, params shape and chunk)."""
    hyp = _hypotheses(env)
    n, k1 = env.grid_size, fr_all["pos"].shape[1]
    num_strategies = len(env.strategies)
    hides = jnp.asarray([s.hides_in_fog for s in env._strategies])
    _, template = env.reset(jax.random.PRNGKey(0), params)
    key = jax.random.PRNGKey(0)  # the deterministic tie rules use no randomness
    # python bools as arrays: ``~True`` on a python bool is -2, not False
    start_not_base = jnp.bool_(env.opponent_start == "not_base")
    target_other = jnp.bool_(env.patrol_target == "other")

    def one_hypothesis(h, fr):
        first = jnp.argmax(fr["exists"])  # the first frame of the episode in the window
        obs_pos0 = fr["opp_pos"][first]
        pos0 = jnp.where(h["memory"], obs_pos0, hyp["unflat"](jnp.maximum(h["cell"], 0)))
        home, target = hyp["unflat"](h["home"]), hyp["unflat"](h["target"])
        ok = prior_ok(h, fr)
        opp = OpponentState(pos=pos0, home=home, target=target, phase=h["phase"])
        fns = [lambda k_, o, g, p, f=s.fn: tuple(jax.tree_util.tree_map(jnp.asarray, f(k_, o, g, p)))
               for s in env._strategies]

        def act(opp, cpos):
            game = template.replace(pos=cpos, opponent=opp)
            a, new = jax.lax.switch(h["strategy"], fns, key, opp, game, params)
            return jnp.asarray(a, jnp.int32), new

        def frame_ok(opp, j):
            hidden = hides[h["strategy"]] & in_fog(fr["pos"][j])
            seen_ok = hidden == fr["hidden"][j]
            return seen_ok & (hidden | jnp.all(opp.pos == fr["opp_pos"][j]))

        ok &= frame_ok(opp, first)

        def body(carry, j):
            opp, ok = carry
            live = (j >= first) & (j < k1 - 1)
            a, new = act(opp, fr["pos"][j])
            new = new.replace(pos=grid.move(opp.pos, a, n))
            opp = jax.tree_util.tree_map(lambda x, y: jnp.where(live, x, y), new, opp)
            ok = ok & (~live | frame_ok(opp, j + 1))
            return (opp, ok), None

        (opp, ok), _ = jax.lax.scan(body, (opp, ok), jnp.arange(k1))
        action, _ = act(opp, fr["pos"][k1 - 1])
        return ok, action

    def predict(fr):
        ok, action = jax.vmap(lambda f: jax.vmap(lambda h: one_hypothesis(h, f))(
            {k_: v for k_, v in hyp.items() if k_ != "unflat"}))(fr)  # [B, H]
        support = jax.vmap(lambda f: jax.vmap(lambda h: prior_ok(h, f))(
            {k_: v for k_, v in hyp.items() if k_ != "unflat"}))(fr)
        per_strategy = jax.vmap(lambda s: jnp.sum(support & (hyp["strategy"] == s), -1), out_axes=-1)(
            jnp.arange(num_strategies))  # [B, S]
        w = jnp.where(ok, 1.0 / jnp.maximum(jnp.take_along_axis(
            per_strategy, jnp.broadcast_to(hyp["strategy"], ok.shape), -1), 1), 0.0)
        votes = jax.vmap(lambda a: jnp.sum(jnp.where(action == a, w, 0.0), -1), out_axes=-1)(
            jnp.arange(grid.NUM_ACTIONS))  # [B, 9]
        any_ok = jnp.any(ok, -1)
        pred = jnp.where(any_ok, jnp.argmax(votes, -1), -1)
        first_action = jnp.take_along_axis(action, jnp.argmax(ok, -1)[:, None], -1)
        det = any_ok & jnp.all(~ok | (action == first_action), -1)
        return pred, det, votes > 0

    def prior_ok(h, fr):
        # the hypothesis' prior support before any frame is checked (for the uniform weights)
        first = jnp.argmax(fr["exists"])
        start_known = ~fr["exists"][0]
        obs_pos0 = fr["opp_pos"][first]
        mem = h["memory"]
        ok = ~mem | ((h["target"] != 0) & (~start_not_base | (h["home"] != 0)))
        ok &= ~mem | ~target_other | (h["target"] != h["home"])
        ok &= ~mem | ~start_known | (jnp.all(hyp["unflat"](h["home"]) == obs_pos0) & (h["phase"] == 0))
        ok &= mem | fr["hidden"][first] | (h["cell"] == grid.flat_index(obs_pos0, n))
        return ok

    # prior weight: strategies uniform, uniform within a strategy over its supported hypotheses
    return predict(fr_all)


def window_predict(env: DCG, params: EnvParams, frames: dict, chunk: int = 256):
    """The Bayes prediction of ``o_t`` from each window (see the module docs).

    Returns a dict of numpy arrays: ``prediction`` ``[M]`` (int; -1 if no hypothesis fits),
    ``deterministic`` ``[M]`` (every consistent hypothesis predicts the same action) and ``possible``
    ``[M, 9]`` (the actions some consistent hypothesis predicts).
    """
    m = frames["pos"].shape[0]
    preds, dets, possible = [], [], []
    for i in range(0, m, chunk):
        fr = {k_: jnp.asarray(v[i:i + chunk]) for k_, v in frames.items()}
        if fr["pos"].shape[0] < chunk:  # pad to one compiled shape
            pad = chunk - fr["pos"].shape[0]
            fr = {k_: jnp.concatenate([v, jnp.repeat(v[-1:], pad, 0)]) for k_, v in fr.items()}
        p, d, v = _predict_chunk(env, params, fr)
        take = min(chunk, m - i)
        preds.append(np.asarray(p)[:take]); dets.append(np.asarray(d)[:take]); possible.append(np.asarray(v)[:take])  # noqa: E702
    return {"prediction": np.concatenate(preds), "deterministic": np.concatenate(dets),
            "possible": np.concatenate(possible)}


def ceiling(env: DCG, params: EnvParams, rec: Record, chunk: int = 256) -> dict:
    """Accuracy of :func:`window_predict` on ``rec`` (with the env's history ``k``), overall and per strategy.

    ``accuracy``: the Bayes prediction equals ``o_t``; ``deterministic``: share of steps on which ``o_t`` is a
    function of the observation; ``label_consistent``: share of steps whose label some consistent hypothesis
    predicts (1.0 unless the label is misaligned with the observation or the enumeration misses a state).
    """
    frames, label, strategy, time = windows(rec, env.history)
    out = window_predict(env, params, frames, chunk)
    hit = out["prediction"] == label
    consistent = out["possible"][np.arange(label.size), label]
    res = {"steps": int(label.size), "accuracy": float(hit.mean()),
           "deterministic": float(out["deterministic"].mean()), "label_consistent": float(consistent.mean()),
           "per_strategy": {}}
    for s, name in enumerate(env.strategies):
        m = strategy == s
        if m.any():
            res["per_strategy"][name] = {"steps": int(m.sum()), "accuracy": float(hit[m].mean()),
                                         "deterministic": float(out["deterministic"][m].mean())}
    return res


def supervised_omn(env: DCG, params: EnvParams, net, net_params, key, lr: float = 1e-4, updates: int = 1953,
                   num_envs: int = 16, t_max: int = 32, evals: int = 3, eval_envs: int = 64,
                   eval_steps: int = 64) -> list[dict]:
    """How far OMN gets alone: OMN (:class:`jaxdc.nets.omn_conn.OMN`) trained only on Eq. 5.1's cross-entropy.

    The games are played by a fixed collector (``net`` with ``net_params``, sampling from its policy) in
    A2C's batches (``num_envs`` games x ``t_max`` steps per update, auto-reset); one Adam step per batch with
    the learning rate annealed linearly from ``lr`` to 0 over ``updates`` (section 5.5.2's schedule). Returns
    ``evals`` rows ``{"updates", "train_loss", "train_accuracy", "accuracy"}``; ``accuracy`` is measured on
    ``eval_envs x eval_steps`` held-out steps of the same collector.
    """
    def rollout(obs, state, k, n_envs, steps):
        def step(carry, k_):
            obs, state = carry
            k_act, k_env = jax.random.split(k_)
            logits = net.apply(net_params, obs)[0]
            action = jax.random.categorical(k_act, logits).astype(jnp.int32)
            obs2, state2, *_, info = step_batch(env, k_env, state, action, params)
            return (obs2, state2), (obs, info["opponent_action"])

        (obs, state), (x, y) = jax.lax.scan(step, (obs, state), jax.random.split(k, steps))
        return obs, state, x.reshape((-1,) + x.shape[2:]), y.reshape(-1)

    k_test, k_test_run, k_reset, k_init, k_run = jax.random.split(key, 5)
    reset = jax.vmap(env.reset, in_axes=(0, None))
    obs, state = reset(jax.random.split(k_test, eval_envs), params)
    _, _, test_x, test_y = jax.jit(rollout, static_argnums=(3, 4))(obs, state, k_test_run, eval_envs, eval_steps)
    obs, state = reset(jax.random.split(k_reset, num_envs), params)
    omn = OMN(grid.NUM_ACTIONS)
    omn_params = omn.init(k_init, obs)
    tx = optax.adam(optax.linear_schedule(lr, 0.0, updates), b1=0.9, b2=0.999)

    @jax.jit
    def update(carry):
        p, opt, obs, state, k = carry
        k, k_roll = jax.random.split(k)
        obs, state, x, y = rollout(obs, state, k_roll, num_envs, t_max)
        (loss, acc), g = jax.value_and_grad(lambda q: aux_cross_entropy(omn.apply(q, x), y), has_aux=True)(p)
        u, opt = tx.update(g, opt, p)
        return (optax.apply_updates(p, u), opt, obs, state, k), (loss, acc)

    carry, rows, done = (omn_params, tx.init(omn_params), obs, state, k_run), [], 0
    for e in range(evals):
        metrics = []
        for _ in range(updates * (e + 1) // evals - done):  # one jitted update per call: fast on XLA:CPU
            carry, m = update(carry)
            metrics.append(m)
        done = updates * (e + 1) // evals
        loss, acc = (float(np.mean(jax.device_get(list(v)))) for v in zip(*metrics))
        test = float(jnp.mean(jnp.argmax(omn.apply(carry[0], test_x), -1) == test_y))
        rows.append({"updates": done, "train_loss": loss, "train_accuracy": acc, "accuracy": test})
    return rows
