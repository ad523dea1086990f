"""Small model files: Stable-Baselines3 zips without their optimisers' state.

An SB3 model file is a zip of the policy's weights (``policy.pth``: PPO's actor and critic,
SAC's and TQC's actor, critics and target critics), the class's settings (``data``) and one
state dict per optimiser (``policy.optimizer.pth``; SAC and TQC: ``actor.optimizer.pth``,
``critic.optimizer.pth``, ``ent_coef_optimizer.pth``). Adam keeps two moments per weight
(Kingma & Ba 2015), so the optimisers weigh twice the weights, and nothing that plays a
model reads them. :func:`slim_model` empties every optimiser's ``state`` and keeps its
``param_groups`` (learning rate, betas, which parameters): the file loads with
``PPO.load`` / ``SAC.load`` / ``TQC.load`` as before (``set_parameters(exact_match=True)``
needs each optimiser's state dict, empty or not), every other member is kept byte for byte
(the weights are bit-identical, so are the actions), and fine-tuning a slimmed model starts
Adam's moments from zero as a new run does. The members are deflated (SB3 stores them
uncompressed; deflate is lossless). What was dropped is recorded beside the model in
``<stem>.slim.json``.

``python -m bathprint.agents.slim DIR...`` slims every SB3 zip under the folders (again:
nothing to do) and prints the bytes per kind of file before and after; ``--drop-curves``
also removes the per-run ``training_curve.png`` of exported runs, which
``python -m bathprint.agents.curves RUN_DIR...`` draws again, byte for byte, from the files
that stay (``run.json``, ``episodes.csv.gz``, ``eval/evaluations.npz``).
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import shutil
import sys
import zipfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: the keys of a torch optimizer's state dict
OPTIMIZER_KEYS = frozenset({"state", "param_groups"})
#: SB3's zip member of tensors that are not a state dict (SAC's log entropy coefficient)
VARIABLES = "pytorch_variables.pth"
#: what a slimmed model keeps of each optimiser (for the record beside it)
KEPT = (
    "param_groups (learning rate, betas, eps, parameter indices): the model loads with SB3's "
    "load as before; fine-tuning restarts Adam's moments from zero"
)


@dataclass
class SlimResult:
    """What :func:`slim_model` did to one file (sizes in bytes)."""

    path: Path
    bytes_before: int
    bytes_after: int
    #: optimiser member -> {"state_entries": parameters with moments, "bytes": its size}
    dropped: dict[str, dict[str, int]] = field(default_factory=dict)

    @property
    def changed(self) -> bool:
        return self.bytes_after != self.bytes_before or bool(self.dropped)


def is_sb3_zip(path: str | Path) -> bool:
    """Whether ``path`` is a Stable-Baselines3 model file (a zip with ``data`` and
    ``_stable_baselines3_version``)."""
    try:
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
    except (zipfile.BadZipFile, OSError):
        return False
    return {"data", "_stable_baselines3_version"} <= names


def _is_optimizer_state(obj: Any) -> bool:
    return isinstance(obj, dict) and set(obj) == OPTIMIZER_KEYS


def _torch_load(data: bytes) -> Any:
    import torch

    return torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)


def _empty_optimizer(data: bytes) -> tuple[bytes, int] | None:
    """(the state dict with no state, as bytes; how many entries ``state`` had) when
    ``data`` is an optimiser's state dict that holds state, else None."""
    import torch

    obj = _torch_load(data)
    if not _is_optimizer_state(obj) or not obj["state"]:
        return None
    buf = io.BytesIO()
    torch.save({"state": {}, "param_groups": obj["param_groups"]}, buf)
    return buf.getvalue(), len(obj["state"])


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def record_path(model: str | Path) -> Path:
    """Where :func:`slim_model` records what it dropped: ``<stem>.slim.json`` beside it."""
    model = Path(model)
    return model.with_name(model.stem + ".slim.json")


def slim_model(path: str | Path, record: bool = True) -> SlimResult:
    """Empty the optimisers' state of the SB3 model file ``path`` and deflate its members,
    in place and atomically (a kill leaves the old file); nothing to do for a file already
    slim. The other members are kept byte for byte (checked in the new file before it
    replaces the old one). With ``record``, ``<stem>.slim.json`` beside the file says what
    was dropped and the SHA-256 of the members kept. Raises ValueError for a file that is
    not an SB3 model."""
    path = Path(path)
    if not is_sb3_zip(path):
        raise ValueError(f"{path}: not a Stable-Baselines3 model file (a zip with 'data')")
    before = path.stat().st_size
    with zipfile.ZipFile(path) as z:
        infos = z.infolist()
        members = {i.filename: z.read(i) for i in infos}
    result = SlimResult(path, before, before)
    new: dict[str, bytes] = {}
    for name, data in members.items():
        if name.endswith(".pth") and name != VARIABLES:
            emptied = _empty_optimizer(data)
            if emptied is not None:
                new[name] = emptied[0]
                result.dropped[name] = {"state_entries": emptied[1], "bytes": len(data)}
    if not new and all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos):
        return result  # slim already
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with zipfile.ZipFile(tmp, "w") as z:
            for info in infos:
                out = zipfile.ZipInfo(info.filename, date_time=info.date_time)
                out.compress_type = zipfile.ZIP_DEFLATED
                out.external_attr = info.external_attr
                z.writestr(out, new.get(info.filename, members[info.filename]), compresslevel=9)
        with zipfile.ZipFile(tmp) as z:  # what replaces the file: the same members
            if [i.filename for i in z.infolist()] != list(members):
                raise RuntimeError(f"{tmp}: members differ from {path}'s")
            for name, data in members.items():
                got = z.read(name)
                if name in new:
                    kept = _torch_load(got)
                    if kept["state"] or kept["param_groups"] != _torch_load(data)["param_groups"]:
                        raise RuntimeError(f"{tmp}: {name} is not the emptied optimiser")
                elif got != data:
                    raise RuntimeError(f"{tmp}: {name} differs from {path}'s")
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        shutil.copymode(path, tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    result.bytes_after = path.stat().st_size
    if record:
        _write_record(result, {n: d for n, d in members.items() if n not in new})
    return result


def _write_record(result: SlimResult, kept: dict[str, bytes]) -> None:
    """``<stem>.slim.json``: what was dropped, what is kept (an earlier record's drops
    stay in it)."""
    from bathprint.provenance import code_version

    path = record_path(result.path)
    old = json.loads(path.read_text()) if path.is_file() else {}
    rec = {
        "model": result.path.name,
        "dropped": {**old.get("dropped", {}), **result.dropped},
        "kept_of_each_optimizer": KEPT,
        "bytes_before": old.get("bytes_before", result.bytes_before),
        "bytes_after": result.bytes_after,
        "members_kept_sha256": {n: _sha256(d) for n, d in kept.items() if n.endswith(".pth")},
        "by": {"function": "bathprint.agents.slim.slim_model", **code_version()},
    }
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(rec, indent=2) + "\n")
    os.replace(tmp, path)


# ----------------------------------------------------------------------- folders


def model_files(root: str | Path) -> list[Path]:
    """The SB3 model files under ``root`` (or ``root`` itself), sorted."""
    root = Path(root)
    zips = [root] if root.is_file() else sorted(root.rglob("*.zip"))
    return [p for p in zips if is_sb3_zip(p)]


def regenerable_curves(root: str | Path) -> list[Path]:
    """The ``training_curve.png`` under ``root`` that ``python -m bathprint.agents.curves``
    draws again from what stays beside it (run.json and the training episodes)."""
    return [
        p
        for p in sorted(Path(root).rglob("training_curve.png"))
        if (p.parent / "run.json").is_file()
        and ((p.parent / "episodes.csv.gz").is_file() or (p.parent / "episodes.csv").is_file())
    ]


def kind(path: Path) -> str:
    """A file's kind for the size table: ``model zip``, ``csv.gz``, or its suffix."""
    name = path.name
    if name.endswith(".zip"):
        return "model zip" if is_sb3_zip(path) else "zip"
    if name.endswith(".csv.gz"):
        return "csv.gz"
    return path.suffix.lstrip(".") or "(none)"


def bytes_by_kind(roots: Iterable[str | Path]) -> dict[str, int]:
    """Bytes of the files under ``roots`` per :func:`kind`, largest first."""
    sizes: dict[str, int] = {}
    for root in roots:
        root = Path(root)
        for p in [root] if root.is_file() else root.rglob("*"):
            if p.is_file():
                k = kind(p)
                sizes[k] = sizes.get(k, 0) + p.stat().st_size
    return dict(sorted(sizes.items(), key=lambda kv: -kv[1]))


def _mb(n: int) -> str:
    return f"{n / 1e6:.2f}"


def size_table(before: dict[str, int], after: dict[str, int]) -> str:
    """Markdown table of bytes per kind before and after (MB, 10^6 bytes)."""
    lines = ["| kind | before MB | after MB |", "|---|---:|---:|"]
    for k in dict.fromkeys([*before, *after]):
        lines.append(f"| {k} | {_mb(before.get(k, 0))} | {_mb(after.get(k, 0))} |")
    lines.append(f"| total | {_mb(sum(before.values()))} | {_mb(sum(after.values()))} |")
    return "\n".join(lines)


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="python -m bathprint.agents.slim",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("paths", nargs="+", help="folders (every SB3 zip under them) or model files")
    ap.add_argument(
        "--drop-curves",
        action="store_true",
        help="also remove exported runs' training_curve.png (python -m bathprint.agents.curves "
        "RUN_DIR draws it again)",
    )
    ap.add_argument(
        "--check", action="store_true", help="change nothing; exit 1 if anything is not slim"
    )
    return ap


def _check(paths: Sequence[Path], drop_curves: bool) -> int:
    """Report what a slimming would change (``--check``): 1 if anything, else 0."""
    todo = []
    for root in paths:
        for m in model_files(root):
            with zipfile.ZipFile(m) as z:
                infos = z.infolist()
                heavy = [
                    i.filename
                    for i in infos
                    if i.filename.endswith(".pth")
                    and i.filename != VARIABLES
                    and _empty_optimizer(z.read(i)) is not None
                ]
            if heavy or any(i.compress_type != zipfile.ZIP_DEFLATED for i in infos):
                why = f"optimiser state in {', '.join(heavy)}" if heavy else "members not deflated"
                todo.append(f"{m}: {why}")
        if drop_curves:
            todo += [f"{p}: regenerable" for p in regenerable_curves(root)]
    for line in todo:
        print(f"not slim: {line}")
    return 1 if todo else 0


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    paths = [Path(p) for p in args.paths]
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        print(f"slim: {', '.join(missing)} does not exist", file=sys.stderr)
        return 2
    if args.check:
        return _check(paths, args.drop_curves)
    before = bytes_by_kind(paths)
    for root in paths:
        for m in model_files(root):
            r = slim_model(m)
            what = ", ".join(r.dropped) or ("no optimiser state; deflated" if r.changed
                                            else "slim already")
            print(f"{m}: {r.bytes_before} -> {r.bytes_after} bytes ({what})")
        if args.drop_curves:
            for p in regenerable_curves(root):
                p.unlink()
                print(f"{p}: removed (python -m bathprint.agents.curves {p.parent})")
    print()
    print(size_table(before, bytes_by_kind(paths)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
