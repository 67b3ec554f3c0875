"""Behaviour snapshot: run a fixed set of commands at fixed seeds and store what they print and write.

A structural change (moving code, merging copies of a rule) must leave every
output exactly as it was. Record a snapshot before the change and one after,
then compare them::

    python -m benchmarks.behaviour_snapshot record /tmp/snap_before      # on the old code
    python -m benchmarks.behaviour_snapshot record /tmp/snap_after       # on the new code
    python -m benchmarks.behaviour_snapshot compare /tmp/snap_before /tmp/snap_after

``record DIR --only a,b`` runs only the named cases (``list`` names them all).
Each case runs in a fresh process from the repository root with temporary
output folders (never ``results/`` or ``runs/``) and ``JAXDC_NO_CACHE=1``
(``--xla-cache`` keeps the CLIs' persistent compile cache on: the same
executables, only faster). ``DIR/<case>.json`` holds its exit status, its
stdout (parsed when it is JSON) and the files it wrote, with timing and
version fields dropped (:data:`DROPPED_KEYS`, the time columns of a
``metrics.csv``) and the temporary folder written as ``<TMP>``; beside them,
under ``"provenance"``, the code and machine that recorded it
(:func:`jaxdc.provenance.provenance`: its git commit tells the snapshots
apart), which ``compare`` ignores. Trained
parameters are stored as a SHA-256 of every leaf's path, dtype, shape and
bytes. ``compare`` prints each case as identical or not (with the first
differences) and exits 1 when any differs or is missing.

The cases use only named shipped networks (``enn`` by its setting,
``omn_conn``), so files added to ``jaxdc/assets`` do not change them. Not
included: ``eval.dcg figure`` (it picks networks by the metadata of every
shipped file, so a new file changes it) and anything slower than a minute.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Keys dropped anywhere in a JSON output: timing and versions, which differ from run to run.
DROPPED_KEYS = frozenset({"seconds", "wall_s", "steps_per_s", "elapsed", "elapsed_s", "duration", "timestamp",
                          "date", "created", "time_s", "version", "versions", "jax_version", "jaxlib_version",
                          "jaxdc_version", "python_version", "host", "hostname", "provenance"})
#: Columns dropped from a ``metrics.csv``.
DROPPED_COLUMNS = ("wall_s", "steps_per_s")

PY = sys.executable
TINY_DCP = ["--grid-size", "4", "--total-reward", "6", "--energy", "4", "8", "--risk", "low", "--steps", "2048",
            "--envs", "4", "--t-max", "8", "--eval-every", "1024", "--eval-episodes", "20", "--no-progress"]
TINY_DCG = ["--grid-size", "3", "--total-reward", "3", "--strategies", "restricted,patrol", "--history", "2",
            "--energy", "8", "--max-steps", "20", "--steps", "2048", "--envs", "8", "--t-max", "8",
            "--eval-every", "1024", "--eval-episodes", "50", "--no-progress"]

# python -c snippets (run with the TMP folder as argv[1])
HASH_SNIPPET = r'''
import hashlib, json, sys
import jax, numpy as np
def digest(tree):
    h = hashlib.sha256()
    for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
        a = np.asarray(leaf)
        h.update(f"{jax.tree_util.keystr(path)}|{a.dtype}|{a.shape}|".encode()); h.update(a.tobytes())
    return h.hexdigest()
'''
DCP_PARAMS = HASH_SNIPPET + r'''
from jaxdc.dcp import learned
for name in sys.argv[2:]:
    l = learned.load(f"{sys.argv[1]}/{name}")
    print(json.dumps({"run": name, "net": l.net_name, "params_sha256": digest(l.params), "setting": l.setting(),
                      "env_options": l.env_options(), "describe": l.describe().replace(sys.argv[1], "<TMP>")}))
'''
DCG_PARAMS = HASH_SNIPPET + r'''
from jaxdc import pretrained
from jaxdc.dcg import learned
run = learned.load(f"{sys.argv[1]}/run")
ship = learned.load(f"{sys.argv[1]}/ship.msgpack")
raw, meta = pretrained.load(f"{sys.argv[1]}/ship.msgpack")
print(json.dumps({"run_params_sha256": digest(run.params), "ship_params_sha256": digest(ship.params),
                  "raw_ship_sha256": digest(raw), "setting": run.setting(), "has_aux": run.has_aux,
                  "steps": run.steps, "describe": run.describe().replace(sys.argv[1], "<TMP>")}))
'''
DRP_GRAPHS = r'''
import sys
from jaxdc.drp import world
for seed, n, base in ((0, 40, "centre"), (1, 30, "corner"), (2, 60, "centre")):
    world.save(world.generate(seed, n=n, base=base), f"{sys.argv[1]}/g{seed}.json")
'''
RENDER = r'''
import jax, numpy as np
from jaxdc.wrappers.gymnasium import make_dcp, make_dcg
for make, kw in ((make_dcp, dict(grid_size=5, risk="low")), (make_dcp, dict(energy=(float("inf"), float("inf")))),
                 (make_dcg, dict(strategies=("patrol", "restricted", "with_fog")))):
    env = make(render_mode="ansi", **kw)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for t in range(12):
        print(env.render())
        _, r, term, trunc, info = env.step(int(rng.integers(9)))
        print(r, term, trunc, sorted((k, str(v)) for k, v in info.items()))
        if term or trunc:
            env.reset(seed=t)
'''


def cases():
    """``{name: [argv, ...]}``: each case is a list of commands run in order; ``{tmp}`` is the case's folder."""
    dcp = [PY, "-m", "eval.dcp"]
    dcg = [PY, "-m", "eval.dcg"]
    drp = [PY, "-m", "eval.drp", "--out", "{tmp}/drp"]
    return {
        "eval_dcp_table_4.3": [dcp + ["--table", "4.3", "--episodes", "200", "--json", "--out", "{tmp}"]],
        "eval_dcp_table_4.8": [dcp + ["--table", "4.8", "--episodes", "200", "--json", "--out", "{tmp}"]],
        "eval_dcp_energy_metrics": [dcp + ["--policy", "safe_both", "--episodes", "200", "--energy-metric", m,
                                           "--seed", "3", "--json"] for m in ("outside_base", "all_steps")]
                                   + [dcp + ["--policy", "lpg", "--episodes", "100", "--start", "base", "--energy",
                                             "5", "10", "--json"]],
        "eval_dcp_enn": [dcp + ["--policy", "enn", "--episodes", "200", "--json"]],
        "eval_dcg_omn_conn": [dcg + ["--net", "omn_conn", "--episodes", "500", "--json", "--out", "{tmp}"]],
        "eval_dcg_omn_conn_area": [dcg + ["--net", "omn_conn", "--episodes", "300", "--reward-area", "2",
                                          "--energy", "10", "--seed", "1", "--json", "--out", "{tmp}"]],
        "eval_dcg_optimum": [dcg + ["optimum", "--episodes", "50", "--json", "--no-progress", "--out", "{tmp}"]],
        "eval_drp_plan": [[PY, "-c", DRP_GRAPHS, "{tmp}"]]
                         + [drp + ["plan", "--graph", f"{{tmp}}/g{s}.json", "--builder", b, "--clustering", c,
                                   "--json"]
                            for s, b, c in ((0, "gi", "pgc"), (1, "ng", "nc"), (1, "lpg", "pgc"), (2, "tl", "nc"))],
        "train_dcp": [[PY, "-m", "train.dcp", "--net", net, *TINY_DCP, "--out", f"{{tmp}}/{net}"]
                      for net in ("linear", "eqn")] + [[PY, "-c", DCP_PARAMS, "{tmp}", "linear", "eqn"]],
        "train_dcg": [[PY, "-m", "train.dcg", "--net", "omn_conn", *TINY_DCG, "--out", "{tmp}/run",
                       "--ship", "{tmp}/ship.msgpack"],
                      [PY, "-c", DCG_PARAMS, "{tmp}"]],
        "render_ansi": [[PY, "-c", RENDER]],
    }


def scrub(x):
    """``x`` without :data:`DROPPED_KEYS` (recursively)."""
    if isinstance(x, dict):
        return {k: scrub(v) for k, v in x.items() if k not in DROPPED_KEYS}
    if isinstance(x, list):
        return [scrub(v) for v in x]
    return x


def _text(text: str, tmp: str):
    """Parsed JSON lines (scrubbed) where a line is JSON, else the line; the temporary folder as ``<TMP>``."""
    out = []
    for line in text.replace(tmp, "<TMP>").splitlines():
        try:
            out.append(scrub(json.loads(line)))
        except ValueError:
            out.append(line)
    return out


def _file(path: str, tmp: str):
    name = os.path.basename(path)
    if name.endswith(".json"):
        with open(path) as f:
            text = f.read()
        try:
            return scrub(json.loads(text.replace(tmp, "<TMP>")))
        except ValueError:
            return text.replace(tmp, "<TMP>")
    if name.endswith(".csv"):
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        return [{k: v for k, v in r.items() if k not in DROPPED_COLUMNS} for r in rows]
    if name.endswith((".md", ".txt")):
        with open(path) as f:
            return f.read().replace(tmp, "<TMP>")
    return None  # binary (checkpoints, msgpack): stored through the parameter hashes


def run_case(name: str, commands, xla_cache: bool) -> dict:
    env = dict(os.environ, PYTHONHASHSEED="0")
    if not xla_cache:
        env["JAXDC_NO_CACHE"] = "1"
    with tempfile.TemporaryDirectory(prefix=f"snap-{name}-") as tmp:
        steps = []
        t0 = time.perf_counter()
        for argv in commands:
            argv = [a.replace("{tmp}", tmp) for a in argv]
            p = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
            shown = [a if len(a) < 200 else "<snippet>" for a in argv[1:]]
            steps.append({"argv": " ".join(shown).replace(tmp, "<TMP>"), "rc": p.returncode,
                          "stdout": _text(p.stdout, tmp)})
            if p.returncode != 0:
                steps[-1]["stderr_tail"] = p.stderr.replace(tmp, "<TMP>").splitlines()[-15:]
        files = {}
        for root, dirs, names in os.walk(tmp):
            dirs.sort()
            if os.path.basename(root) == "checkpoints":
                dirs[:] = []
                continue
            for n in sorted(names):
                path = os.path.join(root, n)
                content = _file(path, tmp)
                if content is not None:
                    files[os.path.relpath(path, tmp)] = content
        return {"case": name, "steps": steps, "files": files, "wall": round(time.perf_counter() - t0, 1)}


def recording_provenance(argv: list[str]) -> dict:
    """The provenance of the code that records (:func:`jaxdc.provenance.provenance`, command ``argv``), taken in a
    child process like the cases, so this one never holds the device."""
    code = "import json, sys; from jaxdc.provenance import provenance; print(json.dumps(provenance(sys.argv[1:])))"
    p = subprocess.run([PY, "-c", code, *argv], cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(p.stdout)


def record(out: str, only=None, xla_cache: bool = False) -> int:
    from jaxdc.io import atomic_write_json

    os.makedirs(out, exist_ok=True)
    todo = cases()
    names = list(todo) if not only else only
    unknown = [n for n in names if n not in todo]
    if unknown:
        raise SystemExit(f"unknown cases {unknown}; known: {list(todo)}")
    command = ["python", "-m", "benchmarks.behaviour_snapshot", "record", out]
    command += (["--only", ",".join(only)] if only else []) + (["--xla-cache"] if xla_cache else [])
    origin = recording_provenance(command)
    bad = 0
    for name in names:
        result = run_case(name, todo[name], xla_cache)
        wall = result.pop("wall")
        atomic_write_json(os.path.join(out, f"{name}.json"), {**result, "provenance": origin})
        rcs = [s["rc"] for s in result["steps"]]
        bad += any(rcs)
        print(f"{name:28s} rc {rcs}  {wall:6.1f} s", flush=True)
    return 1 if bad else 0


def _diff(a, b, where="", out=None, limit=8):
    out = [] if out is None else out
    if len(out) >= limit:
        return out
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{where}/{k}: only in {'after' if k in b else 'before'}")
            else:
                _diff(a[k], b[k], f"{where}/{k}", out, limit)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{where}[{i}]", out, limit)
    elif a != b:
        out.append(f"{where}: {json.dumps(a)[:160]} != {json.dumps(b)[:160]}")
    return out


def _recorded(path: str) -> dict:
    """A recorded case without its provenance (which differs between any two recordings): the recording's, and
    the ``provenance.json`` a training run writes into its folder (checkout path, git commit)."""
    with open(path) as f:
        case = json.load(f)
    case.pop("provenance", None)
    if isinstance(case.get("files"), dict):
        case["files"] = {k: v for k, v in case["files"].items() if os.path.basename(k) != "provenance.json"}
    return case


def compare(before: str, after: str) -> int:
    names = sorted({f[:-5] for d in (before, after) for f in os.listdir(d) if f.endswith(".json")})
    differ = 0
    for name in names:
        paths = [os.path.join(d, f"{name}.json") for d in (before, after)]
        if not all(os.path.exists(p) for p in paths):
            print(f"{name:28s} MISSING in {'before' if not os.path.exists(paths[0]) else 'after'}")
            differ += 1
            continue
        a, b = (_recorded(p) for p in paths)
        if a == b:
            print(f"{name:28s} identical ({len(a['steps'])} commands, {len(a['files'])} files)")
        else:
            differ += 1
            print(f"{name:28s} DIFFERENT")
            for line in _diff(a, b):
                print(f"    {line}")
    print(f"{len(names) - differ} of {len(names)} cases identical")
    return 1 if differ else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.behaviour_snapshot", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="mode", required=True)
    r = sub.add_parser("record", help="run the cases and store their outputs in DIR")
    r.add_argument("dir")
    r.add_argument("--only", type=lambda s: s.split(","), default=None, help="comma-separated case names")
    r.add_argument("--xla-cache", action="store_true", help="keep the CLIs' persistent XLA compile cache on")
    c = sub.add_parser("compare", help="compare two recorded snapshots")
    c.add_argument("before")
    c.add_argument("after")
    sub.add_parser("list", help="the case names")
    args = p.parse_args(argv)
    if args.mode == "record":
        return record(args.dir, args.only, args.xla_cache)
    if args.mode == "compare":
        return compare(args.before, args.after)
    print("\n".join(cases()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
