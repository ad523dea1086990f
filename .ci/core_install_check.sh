#!/usr/bin/env bash
# The core install on its own: a new virtual environment with only bathprint's core
# dependencies (no extra: no torch, stable-baselines3, plotly, dask, ...), installed as the
# README's first command does (`pip install -c requirements/constraints.txt -e .`), then, from
# a folder outside the checkout: a short run of the default scene, its PNG view, one
# environment step, and the refusals of the commands that need an extra (one line naming
# it, exit code 2). Run after the test suite, it finds
# the kernels that the suite compiled in the checkout's numba cache.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
export PIP_DISABLE_PIP_VERSION_CHECK=1
start=$(date +%s)
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "+ python3 -m venv; pip install -c requirements/constraints.txt -e . (the core only)"
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q -c requirements/constraints.txt -e "$root"
py="$work/venv/bin/python"
bp="$work/venv/bin/bathprint"

"$py" - <<'PY'
import importlib.util

extras = ["torch", "stable_baselines3", "sb3_contrib", "optuna", "rliable", "tensorboard",
          "dask", "distributed", "plotly", "yaml", "rich"]
present = [m for m in extras if importlib.util.find_spec(m) is not None]
assert not present, f"the core install brought optional packages: {present}"
print("core install: none of", ", ".join(extras))
PY

cd "$work"
echo "+ bathprint simulate paper_simulation --set duration_s=0.05"
"$bp" simulate paper_simulation --set duration_s=0.05 --out run --quiet
test -s run/trajectory.npz && test -s run/filament.png
"$bp" view run --png
test -s run/view.png
"$py" - <<'PY'
import gymnasium

import bathprint  # noqa: F401  (registers the environments)

env = gymnasium.make("bathprint/CoilRadius-v1")
obs, _ = env.reset(seed=0)
obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
env.close()
print(f"bathprint/CoilRadius-v1: one step, observation of {obs.size}, reward {reward:.4f}")
PY

# the commands that need an extra: exit code 2 and one line naming it
refuse() {
    local extra="$1"; shift
    local code=0
    "$bp" "$@" >"$work/out.txt" 2>"$work/err.txt" || code=$?
    if [ "$code" != 2 ] || [ "$(wc -l <"$work/err.txt")" != 1 ] \
        || ! grep -q "the '$extra' extra" "$work/err.txt"; then
        echo "core_install_check: bathprint $* exited $code; expected 2 and one line naming" \
            "the '$extra' extra:" >&2
        cat "$work/err.txt" >&2
        exit 1
    fi
    echo "bathprint $1 (needs $extra): $(cat "$work/err.txt")"
}
refuse rl train --algo ppo --env CoilRadius-v1 --timesteps 8 --out "$work/never"
refuse rl evaluate random --env CoilRadius-v1
refuse rl write shape.csv --out "$work/never"
refuse viewer view run
refuse dask sweep paper_simulation --grid duration_s=0.02 --out s.jsonl --scheduler local-dask
test ! -e "$work/never"
echo "core_install_check: passed in $(( $(date +%s) - start )) s"
