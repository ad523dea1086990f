"""The core install: with every optional dependency unimportable, bathprint imports,
simulates, draws a run as PNG, sweeps on a process pool and makes and steps an environment;
the commands that need an extra refuse with one line naming it and its pip line.

Each check runs in a subprocess whose ``sitecustomize`` puts a finder first on
``sys.meta_path`` that refuses the optional modules (as a virtual environment without the
extras would); its child processes (the sweep's pool) load it too. ``.ci/core_install_check.sh``
does the same in a real virtual environment with only the core installed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from bathprint._extras import EXTRA_OF_MODULE

#: what the core must not need (every module an extra brings)
OPTIONAL = sorted(EXTRA_OF_MODULE)

BLOCKER = textwrap.dedent(
    f"""
    import importlib.abc
    import sys

    BLOCKED = set({OPTIONAL!r})


    class _Blocker(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {{name!r}} (blocked)", name=name)
            return None


    sys.meta_path.insert(0, _Blocker())
    """
)


@pytest.fixture
def core_env(tmp_path: Path) -> dict[str, str]:
    """The environment of a process (and its children) that cannot import the extras."""
    site = tmp_path / "blocker"
    site.mkdir()
    (site / "sitecustomize.py").write_text(BLOCKER)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(site), src, env.get("PYTHONPATH")) if p)
    return env


def _python(code: str, env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=cwd,
        timeout=900,
    )


def _cli(args: list[str], env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "bathprint.cli", *args], capture_output=True, text=True,
        env=env, cwd=cwd, timeout=900,
    )


def test_the_blocker_blocks(core_env, tmp_path):
    proc = _python("import torch", core_env, tmp_path)
    assert proc.returncode != 0 and "blocked" in proc.stderr
    proc = _python("import plotly.graph_objects", core_env, tmp_path)
    assert proc.returncode != 0 and "blocked" in proc.stderr


def test_core_simulates_and_steps_an_environment_without_the_extras(core_env, tmp_path):
    code = textwrap.dedent(
        f"""
        import json, sys
        import bathprint, gymnasium
        res = bathprint.simulate("paper_simulation", overrides={{"duration_s": 0.05}},
                                 out_dir="run", progress=False)
        env = gymnasium.make("bathprint/CoilRadius-v1")
        obs, info = env.reset(seed=0)
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        env.close()
        loaded = sorted(m for m in sys.modules if m.split(".")[0] in {OPTIONAL!r})
        print(json.dumps({{"time_s": res.summary["time_s"], "obs": len(obs),
                          "reward": float(reward), "loaded": loaded}}))
        """
    )
    proc = _python(code, core_env, tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["time_s"] == pytest.approx(0.05)
    assert out["obs"] > 0 and out["loaded"] == []
    assert (tmp_path / "run" / "filament.png").stat().st_size > 10_000


def test_core_commands_run_without_the_extras(core_env, tmp_path):
    """scenes, simulate, view --png, a sweep on a process pool."""
    proc = _cli(["scenes"], core_env, tmp_path)
    assert proc.returncode == 0 and "paper_simulation" in proc.stdout, proc.stderr
    args = ["simulate", "paper_simulation", "--set", "duration_s=0.05", "--out", "run", "--quiet"]
    proc = _cli(args, core_env, tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = _cli(["view", "run", "--png"], core_env, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "run" / "view.png").stat().st_size > 10_000
    sweep = ["sweep", "paper_simulation", "--grid", "duration_s=0.02,0.03", "--workers", "2"]
    proc = _cli([*sweep, "--out", "sweep.jsonl"], core_env, tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in (tmp_path / "sweep.jsonl").read_text().splitlines()]
    assert len([r for r in rows if r.get("status") == "ok"]) == 2, rows


def test_every_commands_help_builds_without_the_extras(core_env, tmp_path):
    """The parser (every command's options and help) imports no optional module."""
    code = textwrap.dedent(
        f"""
        import json, sys
        from bathprint.cli import build_parser
        parser = build_parser()
        (action,) = parser._subparsers._group_actions
        helps = {{name: p.format_help() for name, p in action.choices.items()}}
        loaded = sorted(m for m in sys.modules if m.split(".")[0] in {OPTIONAL!r})
        print(json.dumps({{"commands": sorted(helps), "loaded": loaded,
                          "usage": all(h.startswith("usage: bathprint") for h in helps.values())}}))
        """
    )
    proc = _python(code, core_env, tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    from bathprint.cli import COMMANDS

    assert out["commands"] == sorted(COMMANDS) and out["usage"] and out["loaded"] == []


@pytest.mark.parametrize(
    "args, extra",
    [
        (["train", "--algo", "ppo", "--env", "CoilRadius", "--timesteps", "8"], "rl"),
        (["train", "--campaign", "agents/campaigns/none.yml"], "rl"),
        (["evaluate", "random", "--env", "CoilRadius"], "rl"),
        (["write", "shape.csv", "--out", "w"], "rl"),
        (["baselines", "show", "--env", "CoilRadius"], "rl"),
        (["view", "run"], "viewer"),
        (["sweep", "paper_simulation", "--grid", "duration_s=0.02", "--out", "s.jsonl",
          "--scheduler", "local-dask"], "dask"),
    ],
)
def test_commands_that_need_an_extra_name_it(core_env, tmp_path, args, extra):
    (tmp_path / "run").mkdir()
    proc = _cli(args, core_env, tmp_path)
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert f"the {extra!r} extra" in lines[0]
    assert f'pip install -c requirements/constraints.txt -e ".[{extra}]"' in lines[0]
    assert not list(tmp_path.glob("runs")), "a refused command wrote nothing"


def test_tune_names_the_rl_extra(core_env, tmp_path):
    code = (
        "import sys; from bathprint.agents.tune import main; "
        "sys.exit(main(['--algo', 'ppo', '--env', 'CoilRadius', '--hyperparams', 'x.yml']))"
    )
    proc = _python(code, core_env, tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "'rl' extra" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_the_extras_of_pyproject_hold_what_the_code_needs():
    """The core lists no optional package; ``dev`` and ``all`` hold every line of ``rl``,
    ``dask`` and ``viewer`` (``all`` also ``hydro``); every module that
    ``bathprint._extras`` maps to an extra comes with that extra."""
    import re
    import tomllib

    project = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]

    def name(requirement: str) -> str:
        return re.split(r"[\[<>=!~ ;]", requirement, maxsplit=1)[0].lower().replace("_", "-")

    core = {name(r) for r in project["dependencies"]}
    assert core == {"numpy", "numba", "scipy", "matplotlib", "gymnasium", "tqdm", "tomli-w"}
    used = set(extras["rl"]) | set(extras["dask"]) | set(extras["viewer"])
    assert used <= set(extras["dev"]), used - set(extras["dev"])
    assert used | set(extras["hydro"]) == set(extras["all"])
    package = {"yaml": "pyyaml", "distributed": "dask", "stable_baselines3": "stable-baselines3",
               "sb3_contrib": "sb3-contrib"}
    for module, extra in EXTRA_OF_MODULE.items():
        assert package.get(module, module) in {name(r) for r in extras[extra]}, (module, extra)
