"""The README and the documentation: commands CI reads, tables rendered from the code and the
result files, provenance, links, and the present tense.

The site itself is built by ``.ci/run`` (``mkdocs build --strict``); the hook tests here run
where mkdocs is installed (``pip install -e ".[docs]"``) and are skipped elsewhere.
"""

from __future__ import annotations

import importlib.util
import json
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_gen"))

import render  # noqa: E402

#: pages other parts of the project write (not held to this file's checks)
NOT_OURS = ("envs/", "physics/hydrodynamics.md")

#: phrases that speak of how the project was built rather than of what it is
HISTORY = re.compile(
    r"\b(this session|previous session|earlier session|session's|the issue'?s?\b|"
    r"before this|earlier states?|helper|at the start of th|was tried|we tried|"
    r"final code|measured in the previous|not re-run|re-check)",
    re.I,
)


def _our_pages() -> list[Path]:
    pages = [p for p in DOCS.rglob("*.md") if "_gen" not in p.parts]
    return [p for p in pages if not p.relative_to(DOCS).as_posix().startswith(NOT_OURS)]


def _readme() -> str:
    return (ROOT / "README.md").read_text(encoding="utf-8")


def _bash_block_after(text: str, line_start: str) -> str:
    """What .ci/run reads: the first ```bash block after the line starting with line_start."""
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith(line_start))
    j = next(k for k in range(i, len(lines)) if lines[k].startswith("```bash"))
    k = next(k for k in range(j + 1, len(lines)) if lines[k].startswith("```"))
    return "\n".join(lines[j + 1 : k])


def test_readme_commands_set_up_and_run():
    text = _readme()
    run = _bash_block_after(text, "Set up and run the default scene")
    tests = _bash_block_after(text, "Set up and run the tests")
    assert text.index("Set up and run the default scene") < text.index("Set up and run the tests")
    assert run.strip().endswith("bathprint simulate")
    assert "-c requirements/constraints.txt" in run and "-c requirements/constraints.txt" in tests
    assert tests.strip().endswith("python -m pytest -q -n auto --dist loadfile")
    assert "ruff check" in tests
    ci = (ROOT / ".ci" / "run").read_text()
    assert "Set up and run the tests" in ci and "mkdocs build --strict" in ci


def test_readme_fits_on_two_screens():
    assert len(_readme().splitlines()) <= 160


def test_readme_headline_table_is_rendered_from_the_result_files():
    text = _readme()
    assert "<!-- render: headline -->" in text
    assert render.render_markdown(text, keep_markers=True) == text, (
        "README.md is out of date: python docs/_gen/render.py --write README.md"
    )


def test_filled_blocks_in_the_docs_match_their_result_files():
    # a page keeps a block's rendered text only where it is read as a file (bare markers are
    # filled at build time): that text must be what the result files give now
    stale = []
    for page in _our_pages():
        text = page.read_text(encoding="utf-8")
        for m in render.DIRECTIVE.finditer(text):
            if m.group(0).endswith("<!-- end render -->") and (
                render.render_markdown(m.group(0), keep_markers=True) != m.group(0)
            ):
                stale.append(f"{page.relative_to(ROOT)}: {m.group(1)}")
    assert not stale, f"out of date (python docs/_gen/render.py --write FILE): {stale}"


def test_figures_in_the_docs_are_copies_of_their_result_files():
    assert render.FIGURES and not render.stale_figures(), (
        "docs/img is out of date: python docs/_gen/render.py --write"
    )


def test_an_empty_rendered_block_keeps_what_follows_it():
    # an empty block (marker and end marker only) must end at its own end marker, not at
    # the next block's
    text = (
        "<!-- render: call-overhead-missing -->\n<!-- end render -->\n\n## Next\n\nkept\n\n"
        "<!-- render: other -->\n| old |\n<!-- end render -->\n"
    )
    blocks = [m.group(1) for m in render.DIRECTIVE.finditer(text)]
    assert blocks == ["call-overhead-missing", "other"]
    first = next(render.DIRECTIVE.finditer(text))
    assert "## Next" not in first.group(0) and "## Next" in text[first.end() :]


def test_a_bare_directive_before_a_filled_block_keeps_what_follows_it():
    # a bare line (filled at build time, or by --write) must not take the text up to the
    # next block's end marker as its own
    text = (
        "<!-- render: new -->\n\n## Next\n\nkept\n\n"
        "<!-- render: other -->\n| old |\n<!-- end render -->\n"
    )
    matches = list(render.DIRECTIVE.finditer(text))
    assert [m.group(1) for m in matches] == ["new", "other"]
    assert matches[0].group(0) == "<!-- render: new -->"
    assert matches[1].group(2) == "| old |"


@pytest.mark.parametrize("path", ["README.md", "CHANGELOG.md"])
def test_relative_links_of_top_level_files_exist(path: str):
    text = (ROOT / path).read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [link for link in links if "://" not in link]
    assert local or path == "CHANGELOG.md"
    for link in local:
        assert (ROOT / link).exists(), f"{path} links to {link}, which does not exist"


def test_docs_and_readme_speak_in_the_present_tense():
    texts = {p.relative_to(ROOT).as_posix(): p.read_text(encoding="utf-8") for p in _our_pages()}
    texts["README.md"] = _readme()
    texts["CHANGELOG.md"] = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    found = {
        name: sorted({m.group(0) for m in HISTORY.finditer(text)})
        for name, text in texts.items()
        if HISTORY.search(text)
    }
    assert found == {}


def test_every_render_directive_names_a_table():
    names = set()
    for page in [*_our_pages(), ROOT / "README.md"]:
        names |= {m.group(1) for m in render.DIRECTIVE.finditer(page.read_text(encoding="utf-8"))}
    assert names, "no page asks for a rendered table"
    assert names <= set(render.TABLES), names - set(render.TABLES)


@pytest.mark.parametrize("name", [n for n in render.TABLES if n != "validation"])
def test_every_table_renders_with_its_source(name: str):
    text = render.render_table(name)
    assert text.count("|") > 10  # a markdown table
    if name not in ("scene-keys", "builtin-scenes"):
        assert "machine" in text and ("`" in text)  # command / file and machine stated
        assert re.search(r"\d{4}-\d{2}-\d{2}", text), "no date"


def test_scene_reference_has_every_key_with_unit_default_and_range():
    from bathprint.core.scene import _allowed

    text = render.scene_keys()
    fields = render.scene_fields()
    assert len(fields) > 60
    for key, f, _ in fields:
        row = next((line for line in text.splitlines() if line.startswith(f"| `{key}` |")), None)
        assert row is not None, f"{key} missing from the scene reference"
        assert _allowed(f) in row
    assert "| `flow.q_outer_ml_min` | ml/min | `10` |" in text
    assert "| `bath.density_kg_m3` | kg/m³ | `1051` |" in text


def test_scene_meanings_name_existing_keys():
    keys = {k for k, _, _ in render.scene_fields()}
    assert set(render.MEANINGS) <= keys


def test_validation_table_from_validate_json(capsys, monkeypatch):
    """bathprint validate --json: every check with its verdict, date and machine; the
    table renders from it."""
    from bathprint.cli import main

    code = main(["validate", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert code == 0
    assert {"command", "date", "machine", "checks", "wall_s"} <= set(data)
    assert len(data["checks"]) >= 7
    for c in data["checks"]:
        assert {"name", "simulated", "exact", "tolerance", "relative_error", "passed"} <= set(c)
        assert c["passed"] == (c["relative_error"] <= c["tolerance"])
    monkeypatch.setattr(render, "validation_data", lambda: data)
    text = render.validation()
    assert text.count("\n|") == len(data["checks"]) + 1
    assert data["machine"] in text and data["date"] in text


def test_result_files_have_their_provenance():
    """Every experiment's result file has its NAME.meta.json (the paper's figures share
    ``bathprint reproduce``'s reproduce.meta.json)."""
    csvs = sorted((ROOT / "experiments").glob("*/results/**/*.csv"))
    assert len(csvs) > 50
    paper = ROOT / "experiments" / "paper" / "results"
    for path in csvs:
        meta = path.with_suffix(".meta.json")
        if path.parent == paper:
            meta = paper / "reproduce.meta.json"
        assert meta.is_file(), f"{path.relative_to(ROOT)} has no provenance ({meta.name})"
        m = json.loads(meta.read_text())
        assert m["command"] and re.fullmatch(r"\d{4}-\d{2}-\d{2}", m["date"]) and m["machine"]


def test_help_texts_quote_no_timings(capsys):
    from bathprint.cli import build_parser

    parser = build_parser()
    texts = [parser.format_help()]
    for action in parser._subparsers._group_actions:  # type: ignore[union-attr]
        texts += [p.format_help() for p in action.choices.values()]
    timing = re.compile(r"\b(about|~|takes?)\s*\d+(\.\d+)?\s*(s|sec|seconds?|min|minutes?)\b", re.I)
    hits = [m.group(0) for t in texts for m in timing.finditer(t)]
    assert hits == []


# ---------------------------------------------------------------- the mkdocs hooks
needs_mkdocs = pytest.mark.skipif(
    importlib.util.find_spec("mkdocs") is None, reason="mkdocs is not installed (.[docs])"
)


def _hooks():
    spec = importlib.util.spec_from_file_location(
        "bathprint_docs_hooks", DOCS / "_gen" / "hooks.py"
    )
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


@needs_mkdocs
def test_environments_section_lists_the_env_pages(tmp_path: Path):
    hooks = _hooks()
    (tmp_path / "envs").mkdir()
    for name, title in (("README.md", "Suite"), ("B-v1.md", "Bee"), ("A-v1.md", "Ay")):
        (tmp_path / "envs" / name).write_text(f"# {title}\n\ntext\n")
    hooks.DOCS = tmp_path
    config = {"nav": [{"Home": "index.md"}, {"Environments": [{"Overview": "environments.md"}]}]}
    hooks.on_config(config)
    assert config["nav"][1]["Environments"] == [
        {"Overview": "environments.md"},
        {"Suite": "envs/README.md"},
        {"Ay": "envs/A-v1.md"},
        {"Bee": "envs/B-v1.md"},
    ]


@needs_mkdocs
def test_environments_section_is_found_inside_another_section(tmp_path: Path):
    hooks = _hooks()
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "A-v1.md").write_text("# Ay\n\ntext\n")
    hooks.DOCS = tmp_path
    guide = [{"Getting started": "getting-started.md"}, {"Environments": ["environments.md"]}]
    config = {"nav": [{"Home": "index.md"}, {"User guide": guide}]}
    hooks.on_config(config)
    assert config["nav"][1]["User guide"][1]["Environments"] == [
        "environments.md",
        {"Ay": "envs/A-v1.md"},
    ]


@needs_mkdocs
def test_build_with_stand_ins_only_for_absent_pages(tmp_path: Path):
    """A strict build of a small site with the project's hooks: the absent environment page
    gets a stand-in, the present hydrodynamics page stays itself, tables are rendered."""
    from mkdocs.commands.build import build
    from mkdocs.config import load_config

    docs = tmp_path / "docs"
    (docs / "physics").mkdir(parents=True)
    (docs / "physics" / "hydrodynamics.md").write_text("# Real hydrodynamics\n")
    (docs / "environments.md").write_text("# Environments\n")
    (docs / "index.md").write_text(
        "# Home\n\n[suite](envs/README.md), [hydro](physics/hydrodynamics.md)\n\n"
        "<!-- render: builtin-scenes -->\n"
    )
    (tmp_path / "mkdocs.yml").write_text(
        "site_name: t\nstrict: true\n"
        f"hooks: [{DOCS / '_gen' / 'hooks.py'}]\n"
        "nav:\n  - Home: index.md\n  - Hydro: physics/hydrodynamics.md\n"
        "  - Environments:\n      - Overview: environments.md\n"
    )
    config = load_config(str(tmp_path / "mkdocs.yml"))
    for plugin in config.plugins.values():  # point the hook at this small site
        if hasattr(plugin, "DOCS"):
            plugin.DOCS = docs
    build(config)
    site = Path(config.site_dir)
    assert "Real hydrodynamics" in (site / "physics" / "hydrodynamics" / "index.html").read_text()
    suite = (site / "envs" / "index.html").read_text()
    assert "The environment suite" in suite
    home = (site / "index.html").read_text()
    assert "paper_simulation" in home and "render:" not in home


@needs_mkdocs
def test_page_directives_become_tables():
    hooks = _hooks()
    out = hooks.on_page_markdown("intro\n\n<!-- render: builtin-scenes -->\n", None, None, None)
    assert "<!-- render" not in out and "| `paper_simulation` |" in out


def test_commit_hashes_in_the_docs_do_not_depend_on_the_clone(monkeypatch):
    # git's own abbreviation grows with a repository's object count, so another clone of
    # the same history (CI's) would print longer hashes: the docs keep seven digits always
    path = ROOT / "agents" / "results" / "WriteShape-v1" / "results.json"
    _, short = render._committed(path)
    assert len(short) == 7
    monkeypatch.setenv("GIT_CONFIG_COUNT", "1")
    monkeypatch.setenv("GIT_CONFIG_KEY_0", "core.abbrev")
    monkeypatch.setenv("GIT_CONFIG_VALUE_0", "12")
    assert render._committed(path)[1] == short
