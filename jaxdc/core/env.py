"""The functional environment base shared by the DCP and the DCG (gymnax style).

A subclass writes three pure functions of arrays:

* ``reset_env(key, params) -> (obs, state)``
* ``step_env(key, state, action, params) -> (obs, state, reward, terminated, truncated, info)``
* ``observe(state, params) -> obs``

and the base class adds auto-reset: :meth:`Environment.step` resets an
environment whose episode ended, returns the *first* observation of the new
episode, and keeps the last observation of the finished one in
``info["final_observation"]``. ``terminated`` (a terminal state of the MDP)
and ``truncated`` (the step cap) are kept apart, as gymnasium does.

Static configuration (grid size, the thesis' ambiguity choices) belongs to
the constructor and is validated there; numeric settings that may differ
within one batch (risk maps, energies, the step cap) are ``EnvParams``
leaves, so ``jax.vmap`` can map over them.

What is specific to one problem travels with its environment, so generic code
(the wrappers, the viewer) calls hooks instead of testing the type: the
outcome names (:attr:`Environment.outcomes`), the state and parameter types
(``Environment.state_type``, ``Environment.params_type``), the text
picture (:meth:`Environment.render_ansi`) and the layers of a drawn frame
(:meth:`Environment.scene`, a :class:`~jaxdc.core.scene.Scene`);
:func:`writes` says whether an environment writes a hook.

Parameters and states of another environment (another grid size, another
history length) are refused: their shapes are static, so
:meth:`Environment.check_params` and :meth:`Environment.check_state` compare
them with the shapes this environment needs (:meth:`Environment.grid_shapes`),
and :meth:`Environment.reset` and :meth:`Environment.step` call them -- under
``jit`` when the function is traced, so the first call raises a ``ValueError``
instead of indexing with clamped indices.
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar

import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_batching import custom_vmap

from jaxdc.core import grid, spaces
from jaxdc.core.scene import Scene

S = TypeVar("S")
P = TypeVar("P")

#: What a step returns: ``(obs, state, reward, terminated, truncated, info)``.
Transition = tuple[jax.Array, Any, jax.Array, jax.Array, jax.Array, dict[str, Any]]


class Environment(Generic[S, P]):
    """Base of the jaxdc environments: pure, jittable and vmappable."""

    #: ``N``: the side of the square grid (set by the constructor).
    grid_size: int
    #: The names of how an episode ends: ``info["outcome"]`` (and ``state.outcome``) index this tuple;
    #: ``None`` where the environment names no outcomes.
    outcomes: tuple[str, ...] | None = None
    #: The classes of the environment's state and parameters (``None``: not declared), so that generic code can
    #: check what it is handed.
    state_type: type | None = None
    params_type: type | None = None
    #: The shape of one (unbatched) action: ``None`` (not checked; the one-agent environments take a scalar),
    #: or a tuple such as ``(k,)`` for ``k`` stacked agents, which :meth:`check_action` enforces.
    action_shape: tuple[int, ...] | None = None

    def make_params(self, *args: Any, **kwargs: Any) -> P:
        """Validated parameters (written by subclasses)."""
        raise NotImplementedError

    @property
    def default_params(self) -> P:
        return self.make_params()

    def _config(self) -> tuple:
        """The static configuration (constructor arguments) as a hashable tuple."""
        raise NotImplementedError

    # An environment is a static argument of jitted functions: equal configurations
    # compare and hash equal, so they share compiled code. ``reset_chunk`` changes the
    # compiled auto-reset, so it is part of the key.
    def _static_key(self) -> tuple:
        return self._config() + (self.reset_chunk,)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Environment) and type(other) is type(self)
                and other._static_key() == self._static_key())

    def __hash__(self) -> int:
        return hash((type(self).__name__,) + self._static_key())

    @property
    def num_actions(self) -> int:
        """The 9 grid actions of :data:`jaxdc.core.grid.ACTIONS` (both grid problems use them)."""
        return grid.NUM_ACTIONS

    def observation_shape(self, params: P) -> tuple[int, ...]:
        raise NotImplementedError

    @property
    def name(self) -> str:
        """The environment's name (gymnax's ``env.name``)."""
        return type(self).__name__

    def action_space(self, params: P | None = None) -> spaces.Discrete:
        """The 9 grid actions (gymnax's ``action_space(params)``)."""
        return spaces.Discrete(self.num_actions)

    def observation_space(self, params: P) -> spaces.Box:
        """The observations under ``params``, with finite bounds (gymnax's ``observation_space(params)``)."""
        low, high = self.observation_bounds(params)
        return spaces.Box(low, high, self.observation_shape(params), jnp.float32)

    def observation_bounds(self, params: P) -> tuple[Any, Any]:
        """``(low, high)`` arrays (or numbers) bounding every observation (written by subclasses)."""
        raise NotImplementedError

    def grid_shapes(self) -> tuple[dict[str, tuple[int, ...]], dict[str, tuple[int, ...]]]:
        """``(params, state)``: for each field of the parameters and of the state whose shape this environment
        sets (the grid, the history), that shape -- the last axes of the leaf (a ``vmap`` batch adds leading
        ones). Written by subclasses; the base declares none."""
        return {}, {}

    def check_params(self, params: P) -> P:
        """``params`` if they are this environment's kind and shape (:meth:`grid_shapes`), else a
        ``TypeError``/``ValueError`` naming the field, its shape and the one needed. Shapes are static, so
        this also works on traced parameters (inside ``jit``/``vmap``, when the function is traced)."""
        _check_kind(self, params, self.params_type, "params", "make_params()")
        _check_shapes(self, params, self.grid_shapes()[0], "params")
        return params

    def check_state(self, state: S) -> S:
        """``state`` if it is this environment's kind and shape (:meth:`grid_shapes`), else a
        ``TypeError``/``ValueError`` naming the field (see :meth:`check_params`)."""
        _check_kind(self, state, self.state_type, "state", "reset()")
        _check_shapes(self, state, self.grid_shapes()[1], "state")
        return state

    def check_action(self, action: Any, batch_dims: int = 0) -> Any:
        """``action`` if its shape is :attr:`action_shape` (after ``batch_dims`` leading batch axes), else a
        ``ValueError`` naming ``actions``, the shape given and the one expected. Shapes are static, so this runs
        when a jitted step is traced; environments that declare no :attr:`action_shape` accept any action."""
        want = self.action_shape
        if want is None:
            return action
        shape = tuple(np.shape(action))
        if len(shape) != batch_dims + len(want) or shape[batch_dims:] != want:
            lead = "[batch, " if batch_dims else "["
            raise ValueError(f"actions has shape {list(shape)}, but {self.name} takes {lead}"
                             f"{', '.join(map(str, want))}] (one action per agent)")
        return action

    # -- to be written by subclasses -------------------------------------------------
    def reset_env(self, key: jax.Array, params: P) -> tuple[jax.Array, S]:
        raise NotImplementedError

    def step_env(self, key: jax.Array, state: S, action: Any, params: P) -> Transition:
        raise NotImplementedError

    # -- the step's random numbers, drawn apart (optional; jaxdc.core.batched) -----------------
    def step_noise(self, key: jax.Array, batch: int | None, params: P) -> Any:
        """The random numbers one ``step_env`` consumes, for one environment (``batch=None``) or drawn for
        ``batch`` environments at once from one key (leading axis ``batch``).

        The base class draws keys (``key`` itself, or ``split(key, batch)``), which :meth:`step_with_noise`
        hands to ``step_env``. An environment whose step needs only a few numbers writes both hooks, so
        that :func:`jaxdc.core.batched.step_batched` draws them for the whole batch in one call; then
        ``step_env(key, ...)`` must equal ``step_with_noise(step_noise(key, None, params), ...)``.
        """
        return key if batch is None else jax.random.split(key, batch)

    def step_with_noise(self, noise: Any, state: S, action: Any, params: P) -> Transition:
        """``step_env`` given the numbers of :meth:`step_noise` (one environment's)."""
        return self.step_env(noise, state, action, params)

    def observe(self, state: S, params: P) -> jax.Array:
        raise NotImplementedError

    # -- hooks for generic code (outside jit; optional) ------------------------------------
    def render_ansi(self, state: S, params: P) -> str:
        """One unbatched state as text, one grid row per line, then a status line (written by subclasses)."""
        raise NotImplementedError(f"{self.name} has no text picture: write render_ansi(state, params)")

    def scene(self, state: S, params: P) -> Scene:
        """One unbatched host state as the layers of a picture (written by subclasses that can be drawn)."""
        raise NotImplementedError(f"{self.name} has no picture: write scene(state, params)")

    #: Under ``vmap``, the auto-reset draws fresh initial states only for the environments that finished, this
    #: many at a time (:func:`reset_where`); ``None``: :func:`reset_chunk_size` of the batch. A performance
    #: setting, exact for any value >= 1 (set it before the first jitted call: environments are static arguments).
    reset_chunk: int | None = None

    def check_param_values(self, params: P) -> P:
        """``params`` if their VALUES (not only their shapes) are ones :meth:`make_params` accepts; checked once at a
        non-jitted entry point (the evaluators, the gymnasium, SB3 and JaxMARL adapters), so that parameters edited
        with ``.replace(...)`` (a NaN risk, a negative energy) are refused naming the field instead of playing
        silently. Traced parameters are returned unchecked (:func:`is_traced`). The base class checks none; the DCP
        and the DCG check theirs (``jaxdc.dcp.param_values``, ``jaxdc.dcg.param_values``)."""
        return params

    # -- public API ---------------------------------------------------------------------
    def reset(self, key: jax.Array, params: P | None = None) -> tuple[jax.Array, S]:
        """Start an episode: ``(obs, state)``. Parameters of another environment (another grid size) are
        refused (:meth:`check_params`; under ``jit``, when traced)."""
        if params is None:
            params = self.default_params
        return self.reset_env(key, self.check_params(params))

    def step(self, key: jax.Array, state: S, action: Any, params: P | None = None) -> Transition:
        """One transition with auto-reset.

        Returns ``(obs, state, reward, terminated, truncated, info)``. When the
        episode ends, ``obs``/``state`` are those of a fresh episode and
        ``info["final_observation"]`` holds the last observation of the old one
        (it equals ``obs`` otherwise).

        Parameters or a state of another environment (another grid size or
        history length) raise a ``ValueError`` naming the field and both shapes
        (:meth:`check_params`, :meth:`check_state`). The shapes are static: under
        ``jit`` the check runs when the step is traced (the first call with those
        shapes), never inside the compiled step, which cannot raise; code that
        calls ``step_env`` directly skips it and must check at its entry.
        """
        if params is None:
            params = self.default_params
        self.check_params(params)
        self.check_state(state)
        self.check_action(action)
        key_step, key_reset = jax.random.split(key)
        obs_st, state_st, reward, terminated, truncated, info = self.step_env(
            key_step, state, action, params
        )
        done = jnp.logical_or(terminated, truncated)
        obs, state = reset_where(self, done, key_reset, params, obs_st, state_st)
        info = dict(info)
        info["final_observation"] = obs_st
        return obs, state, reward, terminated, truncated, info


def _check_kind(env: Environment, obj: Any, cls: type | None, what: str, maker: str) -> None:
    if cls is not None and not isinstance(obj, cls):
        raise TypeError(f"{what} must be the {cls.__name__} of {env.name}.{maker}, got {type(obj).__name__}")


def _check_shapes(env: Environment, obj: Any, shapes: dict[str, tuple[int, ...]], what: str) -> None:
    for field, want in shapes.items():
        leaf = getattr(obj, field, None)
        if leaf is None:
            continue
        shape = tuple(np.shape(leaf))
        if len(shape) < len(want) or shape[len(shape) - len(want):] != want:
            whose, maker = ("these params belong", "make_params()") if what == "params" else \
                ("this state belongs", "reset()")
            raise ValueError(f"{what}.{field} has shape {shape}, but {env.name}(grid_size={env.grid_size}) needs "
                             f"{want} (its last axes): {whose} to an environment of another grid size (or history "
                             f"length); make them with this environment's {maker}")


def writes(env: Environment, hook: str) -> bool:
    """Whether ``env``'s class writes the :class:`Environment` hook ``hook`` (``"render_ansi"``, ``"scene"``)
    instead of inheriting the base's, which raises ``NotImplementedError``."""
    return getattr(type(env), hook, None) is not getattr(Environment, hook)


def step_batch(env: Environment, key: jax.Array, state: Any, action: jax.Array, params: Any,
               reset_slots: int | None = None) -> Transition:
    """``B`` environments sharing ``params`` stepped at once, with auto-reset.

    With ``reset_slots=None`` this is ``vmap(env.step)`` over ``split(key, B)``.
    With ``reset_slots=K`` only ``K`` fresh initial states are drawn per step
    and handed to the environments that finished, in batch order; a step on
    which more than ``K`` finish falls back to ``B`` fresh states (a
    ``lax.cond``, so the fallback costs only when taken). Every new episode
    still starts from an independent initial state; the random streams differ
    from the ``None`` path, so the two give different (equally distributed)
    trajectories. Resets dominate the cost of a step when episodes are short,
    so a small ``K`` (a few times the expected number of finished episodes
    per step) makes large batches much faster.
    """
    env.check_action(action, batch_dims=1)
    b = action.shape[0]
    k_step, k_reset = jax.random.split(key)
    if reset_slots is None:
        return jax.vmap(env.step, in_axes=(0, 0, 0, None))(jax.random.split(key, b), state, action, params)
    obs_st, state_st, reward, terminated, truncated, info = jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(
        jax.random.split(k_step, b), state, action, params
    )
    done = terminated | truncated
    k = min(int(reset_slots), b)

    def few(_):
        fresh = jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, k), params)
        slot = jnp.clip(jnp.cumsum(done) - 1, 0, k - 1)
        return jax.tree_util.tree_map(lambda x: x[slot], fresh)

    def all_(_):
        return jax.vmap(env.reset_env, in_axes=(0, None))(jax.random.split(k_reset, b), params)

    obs_re, state_re = jax.lax.cond(jnp.sum(done) <= k, few, all_, None)
    info = dict(info)
    info["final_observation"] = obs_st
    return (tree_select(done, obs_re, obs_st), tree_select(done, state_re, state_st), reward,
            terminated, truncated, info)


#: The bounds of the automatic reset chunk: a thirty-second of the batch, between these.
RESET_CHUNK_MIN, RESET_CHUNK_MAX = 8, 128


def reset_chunk_size(batch: int) -> int:
    """How many finished environments one pass of the batched auto-reset resets: ``batch / 32`` within
    ``[RESET_CHUNK_MIN, RESET_CHUNK_MAX]`` (a short loop of small resets; measured on CPU, docs/results.md)."""
    return max(RESET_CHUNK_MIN, min(RESET_CHUNK_MAX, batch // 32))


def reset_where(env: Environment, done: jax.Array, key: jax.Array, params: Any, obs: Any, state: Any) -> Any:
    """``(obs, state)``, replaced by ``env.reset_env(key, params)`` where ``done``: the auto-reset of
    :meth:`Environment.step`.

    Unbatched, this computes the reset and selects. Under ``vmap`` (a ``custom_vmap`` rule) the fresh
    states are computed only for the environments that finished, ``env.reset_chunk`` (or
    :func:`reset_chunk_size`) at a time in a loop that runs ``ceil(finished / chunk)`` times, each
    from its own key, and scattered into the batch: every value is the one the unbatched rule
    gives, so trajectories are bit-identical, while a step no longer pays a reset for every
    environment (about 75% of a random-policy step on the DCP; docs/results.md, "Speed (DCP)").
    With parameters that differ across the batch the rule falls back to resetting every
    environment.
    """

    @custom_vmap
    def reset(done, key, params, obs, state):
        return tree_select(done, env.reset_env(key, params), (obs, state))

    @reset.def_vmap
    def reset_batched(axis_size, in_batched, done, key, params, obs, state):
        done_b, key_b, params_b, obs_b, state_b = in_batched
        b = axis_size

        def batched(x, is_batched):
            return x if is_batched else jnp.broadcast_to(x, (b,) + jnp.shape(x))

        done, key = batched(done, done_b), batched(key, key_b)
        current = jax.tree_util.tree_map(batched, (obs, state), (obs_b, state_b))
        if any(jax.tree_util.tree_leaves(params_b)):  # per-environment params: reset every environment
            axes = jax.tree_util.tree_map(lambda x: 0 if x else None, params_b)
            out = jax.vmap(lambda d, k, p, c: tree_select(d, env.reset_env(k, p), c), in_axes=(0, 0, axes, 0))(
                done, key, params, current)
        else:
            out = reset_finished(env, done, lambda i, ids: key[jnp.minimum(ids, b - 1)], params, current)
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return reset(done, key, params, obs, state)


def reset_finished(env: Environment, done: jax.Array, chunk_keys: Any, params: Any, current: Any) -> Any:
    """The batch ``current`` (``(obs, state)``, leading axis ``B``) with a fresh ``env.reset_env`` state at every
    environment where ``done``: ``env.reset_chunk`` (or :func:`reset_chunk_size`) finished environments at a time,
    in a loop that runs ``ceil(finished / chunk)`` times. ``chunk_keys(i, ids)`` gives the keys of pass ``i``, whose
    environments are ``ids`` (``B`` for an unused slot). ``params`` are shared by the batch."""
    b = done.shape[0]
    chunk = min(int(env.reset_chunk or reset_chunk_size(b)), b)
    chunks = -(-b // chunk)
    where = jnp.nonzero(done, size=chunks * chunk, fill_value=b)[0]  # finished first; b: no one

    def fill(i, cur):
        ids = jax.lax.dynamic_slice_in_dim(where, i * chunk, chunk)
        fresh = jax.vmap(env.reset_env, in_axes=(0, None))(chunk_keys(i, ids), params)
        return jax.tree_util.tree_map(lambda a, f: a.at[ids].set(f, mode="drop"), cur, fresh)

    finished = jnp.sum(done, dtype=jnp.int32)
    return jax.lax.fori_loop(0, (finished + chunk - 1) // chunk, fill, current)


def is_traced(tree: Any) -> bool:
    """Whether a leaf of ``tree`` is a tracer (inside ``jit``/``vmap``), whose values are not known."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(tree))


def check_each(params: Any, field: str, check: Any, name: str = "params") -> None:
    """``check(v)`` for every value ``v`` of the field ``field`` of ``params`` (one per element of a batch, as a
    Python number); an error is re-raised naming ``name.field``."""
    a = np.asarray(getattr(params, field))
    if a.size == 0:
        raise ValueError(f"{name}.{field} is empty")
    for v in a.reshape(-1).tolist():
        try:
            check(v)
        except (TypeError, ValueError) as e:
            raise type(e)(f"{name}.{field}: {e}") from None


def tree_select(pred: Any, on_true: Any, on_false: Any) -> Any:
    """``jnp.where(pred, a, b)`` leaf by leaf over two pytrees of the same structure.

    ``pred`` may be batched (shape ``[B]``) over leaves of shape ``[B, ...]``.
    """

    def select(a, b):
        p = jnp.reshape(pred, jnp.shape(pred) + (1,) * (jnp.ndim(a) - jnp.ndim(pred)))
        return jnp.where(p, a, b)

    return jax.tree_util.tree_map(select, on_true, on_false)
