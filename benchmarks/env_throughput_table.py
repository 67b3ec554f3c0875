"""The targets and the Markdown table of ``benchmarks/env_throughput.py`` (issues 21, 29 and 30): which row is
held to which number, read from one run's result."""

from __future__ import annotations

TABLE43_NAVIGATORS = ("safe_reward", "safe_recharge", "safe_both", "safe_neither")
#: Targets: env-steps/s of jax_random at B=4096, its share of jax_handbatched's, Table 4.3's run time.
TARGET_RANDOM_4096 = 5e6  # steps/s
TARGET_SHARE_HANDBATCHED = 0.65
TARGET_TABLE43_S = 5.0
#: Issue 30: ``jax_batched`` at B=4096 against ``numpy_batched`` of the same run.
TARGET_BATCHED_OVER_NUMPY = 1.2
#: The team of the ``jax_dcg_team_random`` row, and the per-collector cost target against the one-collector step.
TEAM_COLLECTORS = 2
TARGET_TEAM_PER_COLLECTOR = 2.0


def targets(result: dict) -> dict:
    """``{target name: {value, target, met}}`` of the rows of ``result`` (those it has)."""
    out = {}

    def at(impl, b=4096):
        return next((r["steps_per_s"] for r in result["rows"] if r["impl"] == impl and r["batch"] == b), None)

    # the public step (issue 21: faster than NumPy) and the batched step (issue 30: >= 1.2x NumPy)
    steps = (("random", "jax_random", 1.0, True), ("batched", "jax_batched", TARGET_BATCHED_OVER_NUMPY, False))
    for name, impl, over_numpy, strict in steps:  # strict: "faster than", not "at least"
        rate = at(impl)
        if rate is None:
            continue
        out[f"{name}_4096_ge_5M"] = {"value": rate, "target": TARGET_RANDOM_4096, "met": rate >= TARGET_RANDOM_4096}
        if at("jax_handbatched"):
            share = rate / at("jax_handbatched")
            out[f"{name}_4096_share_of_handbatched"] = {"value": share, "target": TARGET_SHARE_HANDBATCHED,
                                                        "met": share >= TARGET_SHARE_HANDBATCHED}
        if at("numpy_batched"):
            ratio = rate / at("numpy_batched")
            met = ratio > over_numpy if strict else ratio >= over_numpy
            out[f"{name}_4096_over_numpy_batched"] = {"value": ratio, "target": over_numpy, "met": met}
    dcg = {r["batch"]: r["steps_per_s"] for r in result["rows"] if r["impl"] == "jax_dcg_random"}
    dcp = {r["batch"]: r["steps_per_s"] for r in result["rows"] if r["impl"] == "jax_random"}
    for b in sorted(set(dcg) & set(dcp)):
        ratio = dcp[b] / dcg[b]
        out[f"dcg_within_2x_of_dcp_at_{b}"] = {"value": ratio, "target": 2.0, "met": ratio <= 2.0}
    team = {r["batch"]: r["steps_per_s"] for r in result["rows"] if r["impl"] == "jax_dcg_team_random"}
    for b in sorted(set(team) & set(dcg)):
        ratio = team_cost_ratio(dcg[b], team[b])
        out[f"dcg_team_per_collector_within_2x_at_{b}"] = {"value": ratio, "target": TARGET_TEAM_PER_COLLECTOR,
                                                          "met": ratio <= TARGET_TEAM_PER_COLLECTOR}
    t43 = result.get("table43")
    if t43 and t43["episodes"] == 10_000 and tuple(t43["navigators"]) == TABLE43_NAVIGATORS:
        out["table43_lt_5s"] = {"value": t43["run_s"], "target": TARGET_TABLE43_S,
                                "met": t43["run_s"] < TARGET_TABLE43_S}
    return out


def team_cost_ratio(dcg_rate: float, team_rate: float, collectors: int = TEAM_COLLECTORS) -> float:
    """The team step's cost per collector over the one-collector step's: ``(dcg_rate / team_rate) / collectors``
    (at most 2 is the issue-29 target)."""
    return dcg_rate / team_rate / collectors


def markdown(result: dict) -> str:
    lines = [f"`{result['command']}`", ""] if result.get("command") else []
    lines += ["| implementation | batch | T | env-steps/s | vs NumPy | compile (s) |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in result["rows"]:
        lines.append(f"| {r['impl']} | {r['batch']} | {r['steps']} | {r['steps_per_s']:,.0f} | "
                     f"{r['vs_numpy']:.1f}x | {r['compile_s']:.2f} |")
    lines.append(f"| numpy_safe_reward | - | - | - | - | {result['numpy_safe_reward']} |")
    t43 = result.get("table43")
    if t43:
        lines += ["", f"Table 4.3 ({len(t43['navigators'])} navigators x {t43['episodes']} episodes, "
                  "`evaluate_heuristic`):", "",
                  "| navigator | compile (s) | run after compile (s) | env-steps |", "|---|---:|---:|---:|"]
        for name, p in t43["navigators"].items():
            lines.append(f"| {name} | {p['compile_s']:.2f} | {p['run_s']:.3f} | {p['episode_steps']:,} |")
        lines.append(f"| **total** | {t43['compile_s']:.2f} | {t43['run_s']:.3f} | |")
    if result["targets"]:
        lines += ["", "Targets:", ""]
        for name, t in result["targets"].items():
            lines.append(f"- {name}: {t['value']:,.3f} (target {t['target']:,}) -> "
                         f"{'met' if t['met'] else 'NOT met'}")
    m = result["machine"]
    load = (f"; load average {m['loadavg_1min_start']:.1f} at the start, {m['loadavg_1min_end']:.1f} at the end"
            if "loadavg_1min_start" in m else "")
    lines += ["", f"jax {m['jax']} on {m['backend']} ({m['cpu_count']} CPUs), {m['platform']}{load}"]
    return "\n".join(lines)
