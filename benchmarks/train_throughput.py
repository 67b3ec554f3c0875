"""Training throughput: jaxdc's A2C (ENN, plain CNN) vs Stable-Baselines3 A2C, env-steps/s, in one run.

Usage::

    python benchmarks/train_throughput.py [--json] [--envs 16 64 256] [--nets enn cnn]
                                          [--layouts loop scan] [--scan-envs 16] [--chunk-steps N]
                                          [--sb3-chunk-steps N] [--sb3-vec-envs dummy jaxvec] [--repeats R]
                                          [--ppo-envs 32] [--no-sb3] [--no-dcg] [--quick]

What is timed, all in one invocation so that the ratios are taken side by side on the
same (noisy, shared) machine:

* ``jaxdc``: :func:`jaxdc.agents.a2c.make_train` (Algorithm 10, synchronous: ``num_envs``
  environments x ``t_max = 32`` steps per update, one Adam step) on the DCP of Table 4.3
  (:func:`benchmarks.env_throughput.make_env`: 8x8, 30 units, high risk, energy (8, 16)),
  for ENN (Fig. 4.3, the ten heuristics computed every step) and the plain CNN (ENN's body,
  no heuristics), at each ``--envs``, in both layouts of ``train.dcp --layout``:
  ``loop`` (a Python loop over the jitted ``update``) and ``scan`` (``run``: the updates
  inside ``lax.scan``);
* ``sb3``: Stable-Baselines3 A2C (PyTorch, CPU) on ``gymnasium.make("jaxdc/DCP-v0")``
  with the same settings, ``make_vec_env`` (``DummyVecEnv``, what a user gets), the same
  body (conv 3x3 32 -> conv 3x3 16 -> dense 256, ReLU, linear policy and value heads:
  :class:`SB3ConvBody`), ``n_steps = t_max = 32``, Adam at 1e-4, ``ent_coef`` 0.01,
  ``vf_coef`` 1. It runs twice in a subprocess each, so that the thread setting takes
  effect: with torch's default threads, and with ``OMP_NUM_THREADS=1`` plus
  ``torch.set_num_threads(1)``. The same subprocess also times the ``DummyVecEnv`` alone
  under random actions (``env_only``), the share of SB3's time spent in the environment;
* ``jaxdc enn ppo``: the PPO-style option of ``train.dcp`` (:func:`ppo_options`, the options of
  docs/learning.md's "The PPO-style option at 1M steps": 4 epochs x 4 shuffled minibatches of
  each rollout, clipping 0.2, GAE 0.95), ``loop`` layout, at each ``--ppo-envs`` (default 32);
* ``dcg omn_conn`` (when :mod:`jaxdc.nets` has it): OMN + CoNN (section 5.4.5) with A2C and
  the auxiliary cross-entropy on the DCG of section 5.5.1, 16 environments, ``loop``.

Each row: one warm-up (compile; for SB3 the first ``learn``), then the best of ``--repeats``
chunks of about ``--chunk-steps`` environment steps, in wall time and in the process's CPU time
(all its threads; on a shared, loaded machine CPU time is the steadier of the two, and the
load average at the start and the end of the run is recorded). The FLOP ceiling of the plain CNN is
estimated from its layer sizes (:func:`flops_per_sample`: forward in the rollout, forward and
backward, about 2x the forward, in the update) and the CPU's FLOP rate, both an assumed one
(``--cpu-gflops``, the issue's 70) and one measured here (best float32 ``1024 x 1024`` matmul).
Output: a Markdown table (or, with ``--json``, exactly one JSON object on stdout), also written
atomically to ``results/benchmarks/train_throughput.{json,md}``.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from benchmarks.env_throughput import make_env  # noqa: E402
from benchmarks.publish import publish  # noqa: E402
from benchmarks.sb3_a2c import GYM_KWARGS, T_MAX, bench_sb3, sb3_available, sb3_child  # noqa: E402
from jaxdc.agents import a2c  # noqa: E402
from jaxdc.cli.args import positive_float, positive_int  # noqa: E402
from jaxdc.core.paths import safest_paths  # noqa: E402
from jaxdc.dcp import navigators  # noqa: E402
from jaxdc.io import atomic_write_json, check_output_folder, json_text  # noqa: E402
from jaxdc.nets import make_net  # noqa: E402
from jaxdc.provenance import provenance  # noqa: E402

DEFAULT_ENVS = (16, 64, 256)
NETS = ("enn", "cnn")
LAYOUTS = ("loop", "scan")
THREADS = ("default", "1")
SB3_VEC_ENVS = ("dummy", "jaxvec")
#: The default output folder, under the current directory (like every other command).
RESULTS_DIR = Path("results") / "benchmarks"
#: Targets of the issue (learning issue, "Speed").
TARGET_ENN_1M_S = 180.0
TARGET_VS_SB3_FASTEST = 2.0
TARGET_VS_SB3_DEFAULT = 8.0
TARGET_DCG_1M_S = 300.0


def ppo_options() -> dict:
    """The :class:`~jaxdc.agents.a2c.A2CConfig` fields of the PPO-style option, as ``jaxdc.training.presets.PPO``
    passes them to ``train.dcp`` (docs/learning.md); the ``jaxdc enn ppo`` rows time them (``num_envs`` from
    ``--ppo-envs``)."""
    from jaxdc.cli.train_dcp import build_parser
    from jaxdc.training.fields import flags
    from jaxdc.training.presets import PPO

    a = build_parser().parse_args(flags(PPO.items()))
    assert a.t_max == T_MAX, (a.t_max, T_MAX)
    return {"lr": a.lr, "clip_eps": a.clip_eps, "epochs": a.epochs, "minibatches": a.minibatches,
            "gae_lambda": a.gae_lambda, "normalize_advantages": a.normalize_advantages, "reset_slots": a.reset_slots}


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# -- the FLOP ceiling ------------------------------------------------------------------------
def flops_per_sample(grid_size: int = 8, channels: int = 2, num_outputs: int = 10) -> dict:
    """Multiply-adds x 2 of the plain CNN (section 4.5's body: conv 3x3 32, conv 3x3 16, dense 256;
    ``num_outputs`` = 9 logits + 1 value) per sample: ``forward``, and ``train`` = one forward in the
    rollout plus forward and backward (about 2 forwards) in the update = 4 forwards."""
    cells = grid_size * grid_size
    fwd = 2 * (cells * 32 * 9 * channels + cells * 16 * 9 * 32 + cells * 16 * 256 + 256 * num_outputs)
    return {"forward": fwd, "train": 4 * fwd}


def measured_gflops(size: int = 1024, repeats: int = 5) -> float:
    """Best float32 ``size x size`` matmul rate of this CPU under XLA, in GFLOP/s."""
    a = jnp.ones((size, size), jnp.float32)
    f = jax.jit(lambda x: x @ x)
    jax.block_until_ready(f(a))
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(f(a))
        best = min(best, time.perf_counter() - t0)
    return 2 * size**3 / best / 1e9


# -- jaxdc -----------------------------------------------------------------------------------
def make_trainer(net_name: str, num_envs: int, game: str = "dcp", total_steps: int = 1 << 30, options=None):
    """A2C :class:`~jaxdc.agents.common.Trainer` of ``net_name`` on the benchmark env (``t_max`` 32).

    ``total_steps`` only sets the learning-rate schedule; it is large so that the timed updates
    run at a nonzero rate. ``options``: further :class:`~jaxdc.agents.a2c.A2CConfig` fields
    (e.g. :func:`ppo_options`).
    """
    env, params = make_env(game)
    config = a2c.A2CConfig(total_steps=total_steps, num_envs=num_envs, t_max=T_MAX, **(options or {}))
    if game == "dcg":
        from jaxdc.nets import make_dcg_net

        net = make_dcg_net(net_name, history=env.history)
        return a2c.make_train(config, env, params, net, aux_target=lambda info: info["opponent_action"])
    heuristics = navigators.batched_heuristics(params, jax.jit(safest_paths)(params.risk))
    return a2c.make_train(config, env, params, make_net(net_name), heuristics)


def bench_jax(net_name: str, num_envs: int, layout: str, chunk_steps: int, repeats: int, seed: int = 0,
              game: str = "dcp", ppo: bool = False) -> dict:
    """env-steps/s of ``layout`` ('loop' or 'scan') training; the first call (compile) is untimed.
    ``ppo``: with :func:`ppo_options` (row ``jaxdc NET ppo``)."""
    trainer = make_trainer(net_name, num_envs, game, options=ppo_options() if ppo else None)
    batch = trainer.config.batch_size
    n = max(1, math.ceil(chunk_steps / batch))

    if layout == "loop":
        def chunk(state):
            for _ in range(n):
                state, _ = trainer.update(state)
            return state
        warm = trainer.update
    else:
        def chunk(state):
            return trainer.run(state, n)[0]
        warm = chunk

    state = trainer.init(jax.random.PRNGKey(seed))
    t0 = time.perf_counter()
    out = warm(state)
    state = jax.block_until_ready(out[0] if isinstance(out, tuple) else out)
    first = time.perf_counter() - t0
    best, cpu = math.inf, math.inf
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        state = jax.block_until_ready(chunk(state))
        best, cpu = min((best, cpu), (time.perf_counter() - t0, time.process_time() - c0))
    if layout == "loop":  # the warm-up was one update: its compile time is first minus one update
        compile_s = max(first - best / n, 0.0)
    else:
        compile_s = max(first - best, 0.0)
    impl = f"jaxdc {net_name}" if game == "dcp" else f"jaxdc dcg {net_name}"
    return {"impl": impl + (" ppo" if ppo else ""), "layout": layout,
            "threads": "xla", "num_envs": num_envs, "env_steps": n * batch, "seconds": best,
            "compile_s": compile_s, "steps_per_s": n * batch / best, "cpu_s": cpu, "steps_per_cpu_s": n * batch / cpu}


# -- the run ---------------------------------------------------------------------------------
def _save_partial(out_dir: Path, rows: list[dict]) -> None:
    """The rows so far, in ``train_throughput.partial.json`` (a long run cut short keeps them), with their
    provenance like the finished table's (:func:`benchmarks.publish.publish`)."""
    atomic_write_json(out_dir / "train_throughput.partial.json", {"rows": rows, "provenance": provenance()})


def run(args) -> dict:
    load_start = os.getloadavg()[0]
    repeats = args.repeats
    rows = []
    for b in args.envs:
        for net in args.nets:
            for layout in args.layouts:
                if layout == "scan" and args.scan_envs is not None and b not in args.scan_envs:
                    continue
                row = bench_jax(net, b, layout, args.chunk_steps, repeats)
                log(f"{row['impl']:>14} {layout:>4} envs={b:<4} {row['steps_per_s']:>10,.0f} steps/s "
                    f"(compile {row['compile_s']:.1f} s)")
                rows.append(row)
                _save_partial(args.out_dir, rows)
        if args.sb3:
            for vec_env, threads in ((v, t) for v in args.sb3_vec_envs for t in THREADS):
                row = bench_sb3(b, threads, vec_env, args.sb3_chunk_steps, repeats)
                log(f"{row['impl']:>14} thr={row['threads']:<11} envs={b:<4} {row['steps_per_s']:>10,.0f} steps/s "
                    f"(env alone {row['env_only_steps_per_s']:,.0f})")
                rows.append(row)
                _save_partial(args.out_dir, rows)
    for b in args.ppo_envs:
        row = bench_jax("enn", b, "loop", args.chunk_steps, repeats, ppo=True)
        log(f"{row['impl']:>14} loop envs={b:<4} {row['steps_per_s']:>10,.0f} steps/s "
            f"(compile {row['compile_s']:.1f} s)")
        rows.append(row)
        _save_partial(args.out_dir, rows)
    dcg = None
    if args.dcg:
        dcg = bench_jax("omn_conn", 16, "loop", args.chunk_steps, repeats, game="dcg")
        dcg["est_1M_s"] = 1e6 / dcg["steps_per_s"] + dcg["compile_s"]
        log(f"{dcg['impl']:>14} loop envs=16   {dcg['steps_per_s']:>10,.0f} steps/s")
        rows.append(dcg)
    flops = flops_per_sample()
    gflops = measured_gflops()
    for r in rows:
        if r["impl"] == "jaxdc cnn" or _is_sb3(r):
            r["gflops"] = r["steps_per_s"] * flops["train"] / 1e9
    result = {
        "benchmark": "train_throughput",
        "config": {**GYM_KWARGS, "energy": list(GYM_KWARGS["energy"]), "t_max": T_MAX, "repeats": repeats,
                   "ppo_options": ppo_options(),
                   "chunk_steps": args.chunk_steps, "sb3_chunk_steps": args.sb3_chunk_steps},
        "machine": {"jax": jax.__version__, "backend": jax.default_backend(), "cpu_count": os.cpu_count(),
                    "python": platform.python_version(), "platform": platform.platform(),
                    "loadavg_1min_start": load_start, "loadavg_1min_end": os.getloadavg()[0]},
        "rows": rows,
        "flops": {"cnn_forward_per_sample": flops["forward"], "cnn_train_per_sample": flops["train"],
                  "assumed_cpu_gflops": args.cpu_gflops, "measured_cpu_gflops": gflops,
                  "ceiling_assumed_steps_per_s": args.cpu_gflops * 1e9 / flops["train"],
                  "ceiling_measured_steps_per_s": gflops * 1e9 / flops["train"]},
    }
    if not args.sb3:
        result["sb3"] = "skipped (--no-sb3 or stable-baselines3/torch not installed: pip install -e .[bench])"
    result["comparisons"] = comparisons(rows)
    result["targets"] = targets(result)
    return result


def _best(rows, impl, num_envs, threads=None):
    cands = [r for r in rows if r["impl"] == impl and r["num_envs"] == num_envs
             and (threads is None or r["threads"].split()[0] == threads)]
    return max(cands, key=lambda r: r["steps_per_s"]) if cands else None


def _is_sb3(row) -> bool:
    return row["impl"].startswith("sb3 ")


def comparisons(rows) -> list[dict]:
    """Per env count and jaxdc net, its faster layout over each SB3 row of that env count
    (``vs``: ``"VEC_ENV/THREADS"`` -> ratio), over SB3 as a user gets it (``make_vec_env``,
    default threads) and over the fastest SB3 row."""
    out = []
    for b in sorted({r["num_envs"] for r in rows if _is_sb3(r)}):
        sb3 = [r for r in rows if _is_sb3(r) and r["num_envs"] == b]
        fastest = max(sb3, key=lambda r: r["steps_per_s"])
        default = next((r for r in sb3 if r["impl"] == "sb3 a2c dummy" and r["threads"].startswith("default")),
                       None)
        for net in NETS:
            j = _best(rows, f"jaxdc {net}", b)
            if j is None:
                continue
            c = {"net": net, "num_envs": b, "layout": j["layout"], "steps_per_s": j["steps_per_s"],
                 "vs": {f"{r['impl'].split()[-1]}/{r['threads'].split()[0]}": j["steps_per_s"] / r["steps_per_s"]
                        for r in sb3},
                 "vs_sb3_fastest": j["steps_per_s"] / fastest["steps_per_s"],
                 "sb3_fastest": f"{fastest['impl']}, threads {fastest['threads']}"}
            if default is not None:
                c["vs_sb3_default"] = j["steps_per_s"] / default["steps_per_s"]
            out.append(c)
    return out


def targets(result: dict) -> dict:
    rows, out = result["rows"], {}
    enn16 = _best(rows, "jaxdc enn", 16)
    if enn16:
        est = 1e6 / enn16["steps_per_s"] + enn16["compile_s"]
        out["enn_1M_steps_le_3min (16 envs)"] = {"value": est, "target": TARGET_ENN_1M_S, "met": est <= TARGET_ENN_1M_S}
    enn = [r for r in rows if r["impl"] == "jaxdc enn"]
    if enn:
        r = max(enn, key=lambda r: r["steps_per_s"])
        est = 1e6 / r["steps_per_s"] + r["compile_s"]
        out[f"enn_1M_steps_le_3min (best: {r['num_envs']} envs, {r['layout']})"] = {
            "value": est, "target": TARGET_ENN_1M_S, "met": est <= TARGET_ENN_1M_S}
    for c in result.get("comparisons", []):
        key = f"{c['net']}@{c['num_envs']}"
        out[f"{key}_ge_2x_sb3_fastest"] = {"value": c["vs_sb3_fastest"], "target": TARGET_VS_SB3_FASTEST,
                                           "met": c["vs_sb3_fastest"] >= TARGET_VS_SB3_FASTEST}
        if "vs_sb3_default" in c:
            out[f"{key}_ge_8x_sb3_default"] = {"value": c["vs_sb3_default"], "target": TARGET_VS_SB3_DEFAULT,
                                               "met": c["vs_sb3_default"] >= TARGET_VS_SB3_DEFAULT}
    dcg = [r for r in rows if r["impl"] == "jaxdc dcg omn_conn"]
    if dcg:
        out["dcg_omn_conn_1M_steps_le_5min"] = {"value": dcg[0]["est_1M_s"], "target": TARGET_DCG_1M_S,
                                                "met": dcg[0]["est_1M_s"] <= TARGET_DCG_1M_S}
    return out


def markdown(result: dict) -> str:
    fl = result["flops"]
    lines = ["| implementation | layout | threads | envs | env-steps/s | 1M steps (min) | compile (s) | "
             "env-steps per CPU-s | 1M steps (CPU-min) | CNN GFLOP/s |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in result["rows"]:
        extra = f" (env alone {r['env_only_steps_per_s']:,.0f}/s)" if "env_only_steps_per_s" in r else ""
        gf = f"{r['gflops']:.1f}" if "gflops" in r else "-"
        lines.append(f"| {r['impl']}{extra} | {r['layout']} | {r['threads']} | {r['num_envs']} | "
                     f"{r['steps_per_s']:,.0f} | {(1e6 / r['steps_per_s'] + r['compile_s']) / 60:.1f} | "
                     f"{r['compile_s']:.1f} | {r['steps_per_cpu_s']:,.0f} | "
                     f"{1e6 / r['steps_per_cpu_s'] / 60:.1f} | {gf} |")
    if result["comparisons"]:
        keys = list(result["comparisons"][0]["vs"])
        lines += ["", "Ratios, jaxdc (its faster layout) / SB3 (vec env / torch threads), same run:", "",
                  "| net | envs | layout | " + " | ".join(f"vs SB3 {k}" for k in keys) + " | vs SB3 fastest |",
                  "|---|---:|---|" + "---:|" * (len(keys) + 1)]
        for c in result["comparisons"]:
            lines.append(f"| {c['net']} | {c['num_envs']} | {c['layout']} | "
                         + " | ".join(f"{c['vs'][k]:.1f}x" for k in keys) + f" | {c['vs_sb3_fastest']:.1f}x |")
    elif "sb3" in result:
        lines += ["", f"SB3: {result['sb3']}"]
    cnn = [r for r in result["rows"] if r["impl"] == "jaxdc cnn"]
    lines += ["", f"FLOP ceiling of the plain CNN: {fl['cnn_train_per_sample'] / 1e6:.2f} MFLOP per training sample "
              f"({fl['cnn_forward_per_sample'] / 1e6:.2f} forward x 4); at the assumed {fl['assumed_cpu_gflops']:.0f} "
              f"GFLOP/s that is {fl['ceiling_assumed_steps_per_s']:,.0f} steps/s, at the measured "
              f"{fl['measured_cpu_gflops']:.0f} GFLOP/s (float32 1024^2 matmul) "
              f"{fl['ceiling_measured_steps_per_s']:,.0f} "
              "steps/s."]
    if cnn:
        best = max(cnn, key=lambda r: r["steps_per_s"])
        lines.append(f"Best plain CNN: {best['steps_per_s']:,.0f} steps/s ({best['num_envs']} envs, {best['layout']}) "
                     f"= {best['steps_per_s'] / fl['ceiling_assumed_steps_per_s']:.0%} of the assumed ceiling, "
                     f"{best['steps_per_s'] / fl['ceiling_measured_steps_per_s']:.0%} of the measured one.")
    if result["targets"]:
        lines += ["", "Targets:", ""]
        for name, t in result["targets"].items():
            lines.append(f"- {name}: {t['value']:,.2f} (target {t['target']:,}) -> {'met' if t['met'] else 'NOT met'}")
    m = result["machine"]
    sb3 = next((r for r in result["rows"] if _is_sb3(r)), None)
    lib = f"; torch {sb3['torch']} (cuda: {sb3['torch_cuda']}), SB3 {sb3['sb3']}" if sb3 else ""
    lines += ["", f"jax {m['jax']} on {m['backend']} ({m['cpu_count']} CPUs){lib}, {m['platform']}; "
              f"load average {m['loadavg_1min_start']:.1f} at the start, {m['loadavg_1min_end']:.1f} at the end"]
    return "\n".join(lines)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--json", action="store_true", help="print exactly one JSON object on stdout")
    p.add_argument("--envs", type=positive_int("--envs"), nargs="+", default=list(DEFAULT_ENVS),
                   help="numbers of environments")
    p.add_argument("--nets", nargs="+", choices=NETS, default=list(NETS))
    p.add_argument("--layouts", nargs="+", choices=LAYOUTS, default=list(LAYOUTS))
    p.add_argument("--scan-envs", type=positive_int("--scan-envs"), nargs="+", default=None,
                   help="run the scan layout only at these numbers of environments (default: all of --envs)")
    p.add_argument("--chunk-steps", type=positive_int("--chunk-steps"), default=65_536,
                   help="env-steps per timed jaxdc chunk")
    p.add_argument("--sb3-chunk-steps", type=positive_int("--sb3-chunk-steps"), default=4096,
                   help="env-steps per timed SB3 chunk (>= 1 update)")
    p.add_argument("--sb3-vec-envs", nargs="+", choices=SB3_VEC_ENVS, default=list(SB3_VEC_ENVS),
                   help="SB3's vectorized env: dummy (make_vec_env, per-env calls), jaxvec (one batched call)")
    p.add_argument("--repeats", type=positive_int("--repeats"), default=2, help="timed chunks per row, best taken")
    p.add_argument("--cpu-gflops", type=positive_float("--cpu-gflops"), default=70.0,
                   help="assumed CPU FLOP rate for the ceiling")
    p.add_argument("--ppo-envs", type=positive_int("--ppo-envs"), nargs="*", default=None,
                   help="numbers of environments of the PPO-style ENN rows (default 32; none given: no PPO row)")
    p.add_argument("--no-sb3", dest="sb3", action="store_false", help="skip Stable-Baselines3")
    p.add_argument("--no-dcg", dest="dcg", action="store_false", help="skip the DCG OMN+CoNN row")
    p.add_argument("--quick", action="store_true",
                   help="tiny settings for smoke tests: 1 repeat, chunks of one update, no DCG row, "
                        "no PPO row unless --ppo-envs is given")
    p.add_argument("--out-dir", type=Path, default=RESULTS_DIR)
    p.add_argument("--_sb3-child", dest="sb3_child", choices=THREADS, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.ppo_envs is None:
        args.ppo_envs = [] if args.quick else [32]
    for name in ("envs", "ppo_envs"):
        if any(v < 1 for v in getattr(args, name)):
            p.error(f"--{name.replace('_', '-')} must all be >= 1, got {getattr(args, name)}")
    for name in ("chunk_steps", "sb3_chunk_steps", "repeats"):
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if not args.cpu_gflops > 0:
        p.error(f"--cpu-gflops must be > 0, got {args.cpu_gflops}")
    try:
        check_output_folder(args.out_dir, "--out-dir")
    except ValueError as e:
        p.error(str(e))
    if args.quick:
        args.repeats, args.chunk_steps, args.sb3_chunk_steps, args.dcg = 1, 1, 1, False
    if args.sb3 and args.sb3_child is None and not sb3_available():
        log("stable-baselines3/torch not installed (pip install -e .[bench]): skipping the SB3 rows")
        args.sb3 = False
    return args


def main(argv=None) -> dict:
    args = parse_args(argv)
    if args.sb3_child:  # internal: one SB3 row in this (fresh) interpreter
        row = sb3_child(args.envs[0], args.sb3_child, args.sb3_vec_envs[0], args.sb3_chunk_steps, args.repeats)
        print(json_text(row, indent=None))
        return row
    cmd = "python benchmarks/train_throughput.py " + " ".join(sys.argv[1:] if argv is None else argv)
    log(f"$ {cmd}")
    result = run(args)
    result["command"] = cmd.strip()
    md = f"`{result['command']}`\n\n" + markdown(result)
    publish(args.out_dir, "train_throughput", result, md, args.json)
    (args.out_dir / "train_throughput.partial.json").unlink(missing_ok=True)
    return result


if __name__ == "__main__":
    from jaxdc.cli.runner import run as run_cli

    sys.exit(run_cli(lambda argv: main(argv) and 0, "python benchmarks/train_throughput.py"))
