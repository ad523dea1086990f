"""mkdocs hooks (``hooks:`` in mkdocs.yml): render the tables, list the environment pages.

- ``on_config``: the nav's *Environments* section (at any depth) gets every page of
  ``docs/envs/`` (its ``README.md`` first), so a new environment page needs no edit here;
- ``on_files``: pages that other parts of the project own and that the site links to get a
  stand-in when they are absent (``STAND_INS``), so the build never links into nothing;
- ``on_page_markdown``: each ``<!-- render: NAME -->`` line becomes its table
  (``docs/_gen/render.py``).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import render  # noqa: E402

DOCS = Path(__file__).resolve().parents[1]
ENVS_SECTION = "Environments"

#: page -> (title, text) used only while the page itself does not exist
STAND_INS = {
    "envs/README.md": (
        "The environment suite",
        "The pages of the environments live in `docs/envs/`; none is present in this build. "
        "See [Environments](../environments.md) for the environments and their reference "
        "in `envs/README.md`.",
    ),
    "studies/index.md": (
        "Studies",
        "The index of the studies (`docs/studies/index.md`) is not present in this build; "
        "each study page answers one question and is listed in the navigation.",
    ),
    "physics/hydrodynamics.md": (
        "Hydrodynamics",
        "The hydrodynamics page (`docs/physics/hydrodynamics.md`) is not present in this "
        "build. The drag law the simulator uses is in [The physical model](index.md#drag).",
    ),
}


def _title(path: Path) -> str:
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    return path.stem.replace("-", " ")


def on_config(config: Any) -> Any:
    pages = sorted((DOCS / "envs").glob("*.md")) if (DOCS / "envs").is_dir() else []
    pages.sort(key=lambda p: (p.name != "README.md", p.name))
    entries: list[Any] = [{_title(p): f"envs/{p.name}"} for p in pages]
    if not entries:
        entries = [{STAND_INS["envs/README.md"][0]: "envs/README.md"}]
    section = _find_section(config["nav"] or [], ENVS_SECTION)
    if section is not None:
        known = {v for e in section if isinstance(e, dict) for v in e.values()}
        section.extend(e for e in entries if next(iter(e.values())) not in known)
    return config


def _find_section(nav: list[Any], title: str) -> list[Any] | None:
    """The list of the nav section called ``title``, at any depth (the first found)."""
    for item in nav:
        if not isinstance(item, dict):
            continue
        for key, value in item.items():
            if not isinstance(value, list):
                continue
            if key == title:
                return value
            found = _find_section(value, title)
            if found is not None:
                return found
    return None


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File

    for src, (title, text) in STAND_INS.items():
        if files.get_file_from_path(src) is None:
            files.append(File.generated(config, src, content=f"# {title}\n\n{text}\n"))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    if "<!-- render:" not in markdown:
        return markdown
    return render.render_markdown(markdown)


def on_page_content(html: str, page: Any, config: Any, files: Any) -> str:
    return re.sub(r"<!-- end render -->", "", html)
