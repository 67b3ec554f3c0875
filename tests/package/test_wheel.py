"""The wheel that `pip install .` installs: only the jaxdc package (no top-level train, eval, benchmarks or tests),
its shipped networks, py.typed, the console script and the licence."""

import glob
import os
import shutil
import subprocess
import sys
import zipfile

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    src = tmp_path_factory.mktemp("src")
    for name in ("pyproject.toml", "README.md", "LICENSE", "jaxdc", "train", "eval", "benchmarks", "tests"):
        path = os.path.join(ROOT, name)
        if os.path.isdir(path):
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        elif os.path.exists(path):
            shutil.copy(path, src / name)
    out = tmp_path_factory.mktemp("wheel")
    try:  # the build backend of this environment when it has one, else pip's isolated build
        import setuptools  # noqa: F401
        isolation = ["--no-build-isolation"]
    except ImportError:
        isolation = []
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", *isolation, str(src), "-w", str(out)],
                   check=True, capture_output=True, text=True)
    (path,) = glob.glob(str(out / "jaxdc-*.whl"))
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist() if n.endswith((".txt", "LICENSE", "METADATA"))}, z.namelist()


def test_wheel_installs_only_jaxdc(wheel):
    _, names = wheel
    top = {n.split("/")[0] for n in names}
    assert {t for t in top if not t.endswith(".dist-info")} == {"jaxdc"}
    assert not any(n.startswith(("train/", "eval/", "benchmarks/", "tests/", "results/")) for n in names)


def test_wheel_carries_assets_typing_marker_and_licence(wheel):
    files, names = wheel
    assert "jaxdc/py.typed" in names
    for problem, name in (("dcp", "enn"), ("dcp", "enn_ppo_mix"), ("dcg", "omn_conn_strong")):
        assert f"jaxdc/assets/{problem}/{name}.msgpack" in names and f"jaxdc/assets/{problem}/{name}.json" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith(".dist-info/LICENSE") for n in names)
    entry = next(v for k, v in files.items() if k.endswith("entry_points.txt")).decode()
    assert "[console_scripts]" in entry and "jaxdc = jaxdc.cli.main:" in entry
