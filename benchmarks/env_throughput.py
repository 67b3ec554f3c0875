"""Environment throughput of the DCP: JAX (vmap + scan + jit) vs a NumPy single-env loop.

Usage::

    python benchmarks/env_throughput.py [--json] [--batch-sizes 1 64 1024 4096 16384] [--steps N]
                                        [--quick] [--no-prng] [--no-table43]

Measures env-steps/s, all in one process so that the ratios are taken side by side:

* ``jax_random``: a uniformly random policy with auto-reset (``env.step``, vmapped
  over the batch, inside ``lax.scan`` over T steps, jitted);
* ``jax_batched``, ``jax_dcg_batched``, ``jax_dcg_team_batched``: the same random policy stepped by
  :func:`jaxdc.core.batched.step_batched` (one key per batch step, the step's random numbers drawn for the
  whole batch at once, fresh states only for the finished environments); issue 30's target is
  ``jax_batched`` >= 1.2x ``numpy_batched`` at B = 4096;
* ``jax_safe_reward``: the Safe-Reward navigator (Algorithm 9) acting on the batched
  states, stepping with auto-reset (the safest-path table is computed once, untimed);
* ``jax_dcg_random``: the same for the DCG (section 5.5.1 setting) at every batch size;
  the issue's target is DCG throughput within 2x of DCP's at the same batch size;
* ``jax_dcg_team_random``: the same for the team DCG with two collectors (``DCGTeam(collectors=2)``, the
  same game otherwise; a step is one team step); the issue-29 target is a per-collector cost within 2x of
  the one-collector step at the same batch size (``dcg_team_per_collector_within_2x_at_B``);
* ``jax_handbatched``: :mod:`benchmarks.handbatched_dcp`, the same rules hand-batched in
  JAX (one key per step for the batch, flat arrays, the observation built every step, fresh
  states drawn only for the finished environments): a yardstick of what JAX does here, at
  every batch size;
* ``numpy_batched``: :class:`benchmarks.numpy_dcp.BatchedNumpyDCP`, NumPy over the batch
  (only the finished environments are reset), at every batch size;
* ``numpy_loop``: :func:`benchmarks.numpy_dcp.plain_loop`, one environment in a plain
  Python loop as a NumPy user would write it (a NumPy Safe-Reward row is not provided:
  it would need a NumPy port of the LPG planner, Algorithm 7);
* ``jax_random [unsafe_rbg]``: ``jax_random`` once more at one batch size, in a
  subprocess with ``jax_default_prng_impl = "unsafe_rbg"`` (not the default);
* Table 4.3: the four navigators x 10,000 episodes with ``evaluate_heuristic`` on
  ``DCP(total_reward=30, idle_terminates=True)``, high risk, energy (8, 16),
  ``max_steps=200``: compile time and run time after compilation, separately.

JAX timings: one warm-up call (compile), then the best of ``--repeats`` calls, each
ended by ``block_until_ready``; the rows of one game and batch size that are compared (the public step,
its reset slots and the batched step) are timed in turn, one call each per repeat. Results are
printed as a Markdown table (or, with
``--json``, as exactly one JSON object on stdout; progress goes to stderr) and written
to ``results/benchmarks/env_throughput.{json,md}`` (``--out-dir``), which land together.
Every count flag must be an integer >= 1 (int32), ``--out-dir`` must be writable and the
largest batch must fit in memory; each is checked before any timing, and a bad value
exits with status 2 and one ``error:`` line (Ctrl-C: 130).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks import handbatched_dcp, numpy_dcp  # noqa: E402
from benchmarks.env_throughput_table import TABLE43_NAVIGATORS, TEAM_COLLECTORS, markdown, targets  # noqa: E402
from benchmarks.publish import publish  # noqa: E402
from jaxdc.cli.args import positive_int  # noqa: E402
from jaxdc.cli.runner import run as run_cli  # noqa: E402
from jaxdc.core.batched import step_batched  # noqa: E402
from jaxdc.core.env import step_batch  # noqa: E402
from jaxdc.core.paths import safest_paths  # noqa: E402
from jaxdc.dcp import navigators  # noqa: E402
from jaxdc.dcp.env import DCP  # noqa: E402
from jaxdc.dcp.evaluate import evaluate_heuristic  # noqa: E402
from jaxdc.io import check_output_folder, json_text  # noqa: E402

DEFAULT_BATCH_SIZES = (1, 64, 1024, 4096, 16384)
#: The default output folder, under the current directory (like every other command).
RESULTS_DIR = Path("results") / "benchmarks"


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def make_env(game: str = "dcp"):
    """The benchmarked configurations: the DCP of Table 4.3 (8x8, 30 units, high risk, energy (8, 16))
    or the DCG of section 5.5.1 (5x5, 10 units, the three standard opponents, energy 15, history 10), or
    (``"dcg_team"``) that game with two collectors (:class:`jaxdc.dcg.team.DCGTeam`)."""
    if game == "dcg_team":
        from jaxdc.dcg.team import DCGTeam

        team = DCGTeam(collectors=TEAM_COLLECTORS)
        return team, team.make_params(energy=15.0, max_steps=200)
    if game == "dcg":
        from jaxdc.dcg.env import DCG

        env = DCG()
        return env, env.make_params(energy=15.0, max_steps=200)
    env = DCP(grid_size=8, total_reward=30)
    return env, env.make_params("high", (8.0, 16.0), max_steps=200)


def _seconds(fn) -> float:
    """The wall time of one ``fn()``, its result ready."""
    t0 = time.perf_counter()
    jax.block_until_ready(fn())
    return time.perf_counter() - t0


def _time_best(fn, repeats: int) -> tuple[float, float]:
    """``(first_call_s, best_s)``: the first call compiles; best of ``repeats`` afterwards."""
    first = _seconds(fn)
    return first, min((_seconds(fn) for _ in range(repeats)), default=math.inf)


def make_rollout(env, params, batch: int, steps: int, policy: str, reset_slots: int | None = None,
                 batched: bool = False):
    """A jitted ``rollout(key) -> (final state, total reward)`` of ``steps`` auto-reset steps.

    ``reset_slots`` is passed to :func:`jaxdc.core.env.step_batch` (None: a reset per env and step);
    ``batched``: the steps are :func:`jaxdc.core.batched.step_batched`'s (batch-level random numbers).
    """
    table = safest_paths(params.risk) if policy == "safe_reward" else None

    def act(key, state):
        if policy == "random":
            return jax.random.randint(key, (batch,) + (env.action_shape or ()), 0, env.num_actions)
        return jax.vmap(lambda s: navigators.navigator_action("safe_reward", s, table))(state)


    @jax.jit
    def rollout(key):
        k_reset, k_loop = jax.random.split(key)
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k_reset, batch), params)

        def body(carry, _):
            key, obs, state, total = carry
            key, k_act, k_step = jax.random.split(key, 3)
            action = act(k_act, state)
            if batched:
                obs, state, reward, _, _, _ = step_batched(env, k_step, state, action, params)
            else:
                obs, state, reward, _, _, _ = step_batch(env, k_step, state, action, params, reset_slots)
            return (key, obs, state, total + reward.sum()), None

        carry, _ = jax.lax.scan(body, (k_loop, obs, state, jnp.float32(0.0)), None, length=steps)
        # Return the observation too, so that computing it is never optimised away.
        return carry[1], carry[2], carry[3]

    return rollout


def check_memory(batch_sizes) -> None:
    """``MemoryError`` (saying to lower ``--batch-sizes``) if the largest batch's states cannot be held.

    A rollout holds the batch's observation and state a few times over (the scan carry, the auto-reset
    candidates, the step's output); the NumPy batched loop holds its own copy.
    """
    from jaxdc.core import memory

    b = max(batch_sizes)
    per_env = 0
    for env, params in (make_env("dcp"), make_env("dcg"), make_env("dcg_team")):
        obs, state = jax.eval_shape(env.reset, jax.random.PRNGKey(0), params)
        per_env = max(per_env, memory.tree_bytes(obs) + memory.tree_bytes(state))
    memory.check_fits(4 * b * per_env, f"a batch of {b} environments", "--batch-sizes")


def _jax_case(policy: str, batch: int, steps: int, seed: int = 0, reset_slots=None, game: str = "dcp",
              batched: bool = False):
    """``(row name, call)`` of one JAX row: ``call()`` runs its jitted rollout once."""
    env, params = make_env(game)
    rollout = make_rollout(env, params, batch, steps, policy, reset_slots, batched)
    key = jax.random.key(seed)
    impl = {"dcp": "jax_", "dcg": "jax_dcg_", "dcg_team": "jax_dcg_team_"}[game] + (
        "batched" if batched else policy) + ("" if reset_slots is None else " [reset_slots=B/4]")
    return impl, lambda: rollout(key)


def _row(impl: str, batch: int, steps: int, first: float, best: float) -> dict:
    n = batch * steps
    return {"impl": impl, "batch": batch, "steps": steps, "env_steps": n,
            "seconds": best, "compile_s": max(first - best, 0.0), "steps_per_s": n / best}


def bench_jax(policy: str, batch: int, steps: int, repeats: int, seed: int = 0, reset_slots=None,
              game: str = "dcp", batched: bool = False) -> dict:
    case = {"policy": policy, "seed": seed, "reset_slots": reset_slots, "game": game, "batched": batched}
    return bench_jax_side_by_side([case], batch, steps, repeats)[0]


def bench_jax_side_by_side(cases: list[dict], batch: int, steps: int, repeats: int) -> list[dict]:
    """The rows of ``cases`` (``_jax_case`` keywords) timed in turn, repeat by repeat (best of ``repeats`` each),
    so that a slow spell of this noisy machine falls on all of them alike and their ratios stay fair."""
    calls = [_jax_case(batch=batch, steps=steps, **case) for case in cases]
    first = [_seconds(call) for _, call in calls]
    best = [math.inf] * len(calls)
    for _ in range(repeats):
        best = [min(b, _seconds(call)) for b, (_, call) in zip(best, calls)]
    return [_row(impl, batch, steps, f, b) for (impl, _), f, b in zip(calls, first, best)]


def bench_handbatched(batch: int, steps: int, repeats: int, seed: int = 0) -> dict:
    env, params = make_env("dcp")
    rollout = handbatched_dcp.make_rollout(np.asarray(params.risk), (8.0, 16.0), 200, env.total_reward, batch, steps)
    key = jax.random.PRNGKey(seed)
    first, best = _time_best(lambda: rollout(key), repeats)
    n = batch * steps
    return {"impl": "jax_handbatched", "batch": batch, "steps": steps, "env_steps": n,
            "seconds": best, "compile_s": max(first - best, 0.0), "steps_per_s": n / best}


def _bench_numpy(impl: str, batch: int, steps: int, repeats: int, run, seed: int = 0) -> dict:
    best = math.inf
    for r in range(repeats):
        rng = np.random.default_rng(seed + r)
        t0 = time.perf_counter()
        run(rng)
        best = min(best, time.perf_counter() - t0)
    return {"impl": impl, "batch": batch, "steps": steps, "env_steps": batch * steps,
            "seconds": best, "compile_s": 0.0, "steps_per_s": batch * steps / best}


def bench_numpy_loop(steps: int, repeats: int) -> dict:
    return _bench_numpy("numpy_loop", 1, steps, repeats, lambda rng: numpy_dcp.plain_loop(rng, steps))


def bench_numpy_batched(batch: int, steps: int, repeats: int) -> dict:
    env = numpy_dcp.BatchedNumpyDCP(batch)
    return _bench_numpy("numpy_batched", batch, steps, repeats, lambda rng: numpy_dcp.batched_rollout(env, rng, steps))


def bench_prng_subprocess(impl: str, batch: int, steps: int, repeats: int) -> dict:
    """``jax_random`` at ``batch`` in a fresh interpreter with another default PRNG."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--_prng-child", impl,
           "--batch-sizes", str(batch), "--steps", str(steps), "--repeats", str(repeats)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=ROOT)
    row = json.loads(out.stdout)
    row["impl"] = f"jax_random [{impl}]"
    return row


def bench_table43(episodes: int, repeats: int, names=TABLE43_NAVIGATORS, seed: int = 0) -> dict:
    """Table 4.3: 4 navigators x ``episodes`` with ``evaluate_heuristic`` (compile vs run)."""
    env = DCP(total_reward=30, idle_terminates=True)
    params = env.make_params("high", (8, 16), max_steps=200)
    key = jax.random.key(seed)
    per = {}
    for name in names:
        # timed within this iteration, so the lambda's `name` is this iteration's
        first, best = _time_best(lambda: evaluate_heuristic(env, params, name, key, episodes), repeats)  # noqa: B023
        steps = int(np.asarray(evaluate_heuristic(env, params, name, key, episodes).time).sum())
        per[name] = {"compile_s": max(first - best, 0.0), "run_s": best, "episode_steps": steps}
        log(f"  table 4.3 {name}: compile {per[name]['compile_s']:.2f} s, run {best:.3f} s")
    return {
        "episodes": episodes,
        "navigators": per,
        "compile_s": sum(p["compile_s"] for p in per.values()),
        "run_s": sum(p["run_s"] for p in per.values()),
    }


def steps_for(batch: int, steps: int | None, quick: bool) -> int:
    """Scan length: ``--steps`` if given, else enough for ~2M env-steps per call (at most 2000)."""
    if steps is not None:
        return steps
    target = 20_000 if quick else 2_000_000
    return int(min(2000, max(100, math.ceil(target / batch))))


def run(args) -> dict:
    repeats = args.repeats if args.repeats is not None else (1 if args.quick else 3)
    load_start = os.getloadavg()[0]
    rows = []
    for policy in ("random", "safe_reward"):
        # --quick: Safe-Reward only at the smallest batch size (each size is one more compile)
        sizes = [min(args.batch_sizes)] if (args.quick and policy == "safe_reward") else args.batch_sizes
        for b in sizes:
            t = steps_for(b, args.steps, args.quick)
            if policy == "safe_reward":
                t = max(1, t // 4) if args.steps is None else t  # ~4x slower per step
            cases = [{"policy": policy}]
            if policy == "random":  # the public step, reset slots and the batched step, side by side
                cases += [{"policy": policy, "reset_slots": max(1, b // 4)}, {"policy": policy, "batched": True}]
            for row in bench_jax_side_by_side(cases, b, t, repeats):
                log(f"{row['impl']:>16} B={b:<6} T={t:<5} {row['steps_per_s']:>14,.0f} steps/s "
                    f"(compile {row['compile_s']:.2f} s)")
                rows.append(row)
    for b in ([min(args.batch_sizes)] if args.quick else args.batch_sizes):
        t = steps_for(b, args.steps, args.quick)
        pairs = [bench_jax_side_by_side([{"policy": "random", "game": game}, {"policy": "random", "game": game,
                                                                             "batched": True}], b, t, repeats)
                 for game in ("dcg", "dcg_team")]
        for row in (*pairs[0], *pairs[1], bench_handbatched(b, t, repeats)):
            log(f"{row['impl']:>16} B={b:<6} T={t:<5} {row['steps_per_s']:>14,.0f} steps/s "
                f"(compile {row['compile_s']:.2f} s)")
            rows.append(row)
    np_steps = args.numpy_steps or (2_000 if args.quick else 50_000)
    for b in ([min(args.batch_sizes)] if args.quick else args.batch_sizes):
        t = max(20, min(np_steps // b, 200)) if args.steps is None else args.steps
        row = bench_numpy_batched(b, t, repeats)
        log(f"{row['impl']:>16} B={b:<6} T={t:<5} {row['steps_per_s']:>14,.0f} steps/s")
        rows.append(row)
    row = bench_numpy_loop(np_steps, repeats)
    log(f"{row['impl']:>16} B=1      T={np_steps:<5} {row['steps_per_s']:>14,.0f} steps/s")
    rows.append(row)
    if not (args.no_prng or args.quick):
        b = 4096 if 4096 in args.batch_sizes else max(args.batch_sizes)
        row = bench_prng_subprocess("unsafe_rbg", b, steps_for(b, args.steps, args.quick), repeats)
        log(f"{row['impl']:>16} B={b:<6} {row['steps_per_s']:>14,.0f} steps/s")
        rows.append(row)

    numpy_rate = next(r["steps_per_s"] for r in rows if r["impl"] == "numpy_loop")
    for r in rows:
        r["vs_numpy"] = r["steps_per_s"] / numpy_rate  # against the plain single-environment loop

    result = {
        "benchmark": "dcp_env_throughput",
        "config": {"grid_size": 8, "total_reward": 30, "risk": "high", "energy": [8.0, 16.0],
                   "max_steps": 200, "repeats": repeats, "quick": bool(args.quick)},
        "machine": {"jax": jax.__version__, "backend": jax.default_backend(),
                    "devices": [str(d) for d in jax.devices()], "cpu_count": os.cpu_count(),
                    "python": platform.python_version(), "platform": platform.platform(),
                    "loadavg_1min_start": load_start, "loadavg_1min_end": os.getloadavg()[0]},
        "rows": rows,
        "numpy_safe_reward": "skipped: needs a NumPy port of the LPG planner (Algorithm 7)",
    }
    if not args.no_table43:
        episodes = args.episodes or (64 if args.quick else 10_000)
        navs = TABLE43_NAVIGATORS[:1] if args.quick else TABLE43_NAVIGATORS
        result["table43"] = bench_table43(episodes, repeats, navs)
    result["targets"] = targets(result)
    return result


def parse_args(argv=None):
    p = argparse.ArgumentParser(prog="python benchmarks/env_throughput.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--batch-sizes", type=positive_int("--batch-sizes"), nargs="+", default=list(DEFAULT_BATCH_SIZES))
    p.add_argument("--steps", type=positive_int("--steps"), default=None,
                   help="scan length T (default: ~2M env-steps per call, 100..2000)")
    p.add_argument("--repeats", type=positive_int("--repeats"), default=None,
                   help="timed repeats, best taken (default 3)")
    p.add_argument("--numpy-steps", type=positive_int("--numpy-steps"), default=None,
                   help="NumPy loop steps (default 50,000)")
    p.add_argument("--episodes", type=positive_int("--episodes"), default=None,
                   help="Table 4.3 episodes (default 10,000)")
    p.add_argument("--quick", action="store_true",
                   help="tiny settings for smoke tests: 1 repeat, Safe-Reward only at the smallest batch, "
                        "no PRNG subprocess, Table 4.3 with safe_reward x 64 episodes")
    p.add_argument("--no-prng", action="store_true", help="skip the unsafe_rbg subprocess row")
    p.add_argument("--no-table43", action="store_true", help="skip the Table 4.3 timing")
    p.add_argument("--out-dir", type=Path, default=RESULTS_DIR)
    p.add_argument("--_prng-child", dest="prng_child", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if not args.prng_child:
        try:
            check_output_folder(args.out_dir, "--out-dir")
        except ValueError as e:
            p.error(str(e))
    return args


def main(argv=None) -> dict:
    args = parse_args(argv)
    if args.prng_child:  # internal: one jax_random row under another default PRNG
        jax.config.update("jax_default_prng_impl", args.prng_child)
        b = args.batch_sizes[0]
        row = bench_jax("random", b, steps_for(b, args.steps, False), args.repeats or 3)
        print(json_text(row, indent=None))
        return row
    check_memory(args.batch_sizes)
    result = run(args)
    result["command"] = " ".join(["python benchmarks/env_throughput.py", *(sys.argv[1:] if argv is None else argv)])
    md = markdown(result)
    publish(args.out_dir, "env_throughput", result, md, args.json)
    return result


if __name__ == "__main__":
    sys.exit(run_cli(lambda argv: (main(argv), 0)[1], "python benchmarks/env_throughput.py"))
