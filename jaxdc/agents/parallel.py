"""Scale a trainer: data parallel over devices (``jax.sharding``) and several seeds at once (``vmap``).

Section 4.4.3 runs Algorithm 10 in 16 asynchronous threads, each acting in
its own environment and pushing gradients to shared parameters. The
synchronous trainers of this package (:mod:`jaxdc.agents.a2c`,
:mod:`jaxdc.agents.nstep_q`) keep one parameter copy and a batch of
``num_envs`` environments; :func:`parallelize` spreads that batch over the
devices of a one-axis :class:`jax.sharding.Mesh`:

* the environment batch (the training state's ``env_state`` and ``obs``, and
  with them the whole rollout) is sharded along the environment axis with
  ``NamedSharding(mesh, P("data"))``;
* the parameters, the optimizer state, the RNG key and the update counter are
  replicated (``P()``), so the gradient mean over the batch becomes an
  all-reduce that XLA inserts.

The program is the same global program on one CPU, several GPUs or a TPU
slice (GSPMD partitions it); random numbers are drawn for the global batch
(``jax_threefry_partitionable``), so a run's numbers do not depend on the
device count, up to the order of float reductions.

Several processes (hosts) run the same program over one mesh of all their
devices once ``jax.distributed.initialize`` has joined them
(:mod:`jaxdc.training.distributed`): :func:`data_mesh` then spans every
process's devices, each process steps the environments of its own shard, and
:func:`put` / :func:`host` move a state that every process holds whole onto
the global mesh and back (the reverse is a collective every process takes part
in).

``num_seeds`` stacks that many independent runs along a new leading axis and
``vmap`` s the trainer over it (PureJaxRL style): run ``i`` equals a single run
started with ``keys[i]``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding
from jax.sharding import PartitionSpec as P

from jaxdc.agents.common import Trainer
from jaxdc.core.validate import is_int

#: The mesh axis the environment batch is split along.
DATA_AXIS = "data"
#: Training-state fields that carry the environment axis (the rest is replicated).
BATCHED_FIELDS = ("env_state", "obs")


def data_mesh(num_devices: int | None = None) -> Mesh:
    """A one-axis mesh (``"data"``) over the first ``num_devices`` devices (all of them if ``None``).

    With several processes the mesh spans all devices of all processes, so ``num_devices`` must be ``None`` or
    their number.
    """
    devices = jax.devices()
    n = len(devices) if num_devices is None else num_devices
    if not is_int(n, numpy=False) or not 1 <= n <= len(devices):
        raise ValueError(f"num_devices must be an int in [1, {len(devices)}] (the devices JAX sees: "
                         f"{len(devices)} {devices[0].platform}), got {num_devices!r}")
    if jax.process_count() > 1 and n != len(devices):
        raise ValueError(f"num_devices must be {len(devices)} (all devices of the {jax.process_count()} processes) "
                         f"or None when several processes train together, got {num_devices!r}")
    return Mesh(np.asarray(devices[:n]), (DATA_AXIS,))


def put(tree: Any, shardings: Any) -> Any:
    """``tree`` placed as ``shardings`` say; with several processes each must pass the same whole ``tree`` (as
    the same key gives every process the same initial state), and each keeps only its devices' shards."""
    if jax.process_count() > 1:
        tree = jax.device_get(tree)  # host values: each process puts its own shards of them
    return jax.device_put(tree, shardings)


def host(tree: Any) -> Any:
    """``tree`` whole on every process: with several processes a collective that every process must call
    (``process_allgather``), giving NumPy arrays; with one process ``tree`` itself."""
    if jax.process_count() == 1:
        return tree
    from jax.experimental import multihost_utils

    return multihost_utils.process_allgather(tree, tiled=True)


def state_shardings(state: Any, mesh: Mesh, seed_axis: bool = False) -> Any:
    """Shardings of a training state: ``env_state``/``obs`` split along the environment axis, the rest replicated.

    ``seed_axis``: the state carries a leading seed axis (:func:`parallelize` with ``num_seeds``), so the
    environment axis is the second one.
    """
    env = NamedSharding(mesh, P(None, DATA_AXIS) if seed_axis else P(DATA_AXIS))
    rep = NamedSharding(mesh, P())
    return type(state)(**{
        f.name: jax.tree_util.tree_map(lambda _, s=(env if f.name in BATCHED_FIELDS else rep): s,
                                       getattr(state, f.name))
        for f in dataclasses.fields(state)})


def check_divisible(num_envs: int, num_devices: int) -> None:
    """Raise a ``ValueError`` unless ``num_envs`` splits evenly over ``num_devices`` devices."""
    d = num_devices
    if num_envs % d:
        raise ValueError(f"num_envs ({num_envs}) must be divisible by the number of devices ({d}); "
                         f"use a multiple of {d} or fewer devices")


def check_batched_divisible(state: Any, num_devices: int, seed_axis: bool = False) -> None:
    """Raise a ``ValueError`` unless every environment batch of the training state (``state``, shapes suffice)
    splits evenly over ``num_devices``: with ``make_train``'s ``extra_envs`` each group holds ``num_envs / G``
    environments, which must be a multiple of the devices too."""
    axis = 1 if seed_axis else 0
    for name in BATCHED_FIELDS:
        for leaf in jax.tree_util.tree_leaves(getattr(state, name)):
            if leaf.shape[axis] % num_devices:
                raise ValueError(f"an environment batch of {leaf.shape[axis]} (num_envs, or its share per "
                                 f"environment group with extra_envs) must be divisible by the number of devices "
                                 f"({num_devices})")


def parallelize(trainer: Trainer, mesh: Mesh | None = None, num_seeds: int | None = None) -> Trainer:
    """The same :class:`Trainer` spread over ``mesh`` (default: all devices) and, if ``num_seeds``, vmapped.

    ``init`` then takes one key (``num_seeds=None``) or ``[num_seeds]`` keys; the states it returns and
    ``update``/``run``/``train`` take and return are placed by :func:`state_shardings`; metrics are
    replicated (with a leading seed axis when vmapped).
    """
    mesh = data_mesh() if mesh is None else mesh
    check_divisible(trainer.config.num_envs, mesh.devices.size)
    if num_seeds is not None and (not is_int(num_seeds, numpy=False) or num_seeds < 1):
        raise ValueError(f"num_seeds must be an int >= 1 or None, got {num_seeds!r}")
    vm = (lambda f: f) if num_seeds is None else jax.vmap
    key_shape = jax.eval_shape(jax.random.PRNGKey, 0)
    if num_seeds is not None:
        key_shape = jax.ShapeDtypeStruct((num_seeds,) + key_shape.shape, key_shape.dtype)
    shapes = jax.eval_shape(vm(trainer.init), key_shape)
    check_batched_divisible(shapes, mesh.devices.size, num_seeds is not None)
    shardings = state_shardings(shapes, mesh, num_seeds is not None)
    rep = NamedSharding(mesh, P())

    def run(state, n: int):
        return vm(lambda s: trainer.run(s, n))(state)

    def train(keys):
        return vm(trainer.train)(keys)

    def init(key):  # not jitted, as the trainer's own init: a jitted one would compile the heuristics once more
        return put(vm(trainer.init)(key), shardings)

    return Trainer(
        init=init,
        update=jax.jit(vm(trainer.update), in_shardings=(shardings,), out_shardings=(shardings, rep)),
        run=jax.jit(run, static_argnums=1, in_shardings=(shardings,), out_shardings=(shardings, rep)),
        train=jax.jit(train, out_shardings=(shardings, rep)),
        config=trainer.config)


def place(state: Any, mesh: Mesh, seed_axis: bool = False) -> Any:
    """Put a (restored, host) training state on ``mesh`` as :func:`state_shardings` says."""
    return put(state, state_shardings(state, mesh, seed_axis))
