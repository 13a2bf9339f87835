"""The documentation is part of the product: the parameter page is what the registry
generates, every relative link in README.md and docs/*.md lands on a file (and heading)
of the repository, nothing refers to files outside the repository, and the import rules
of docs/architecture.md hold."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from tools import paramdoc

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SKIP_DIRS = {".git", ".venv", "runs", "build", "dist", "__pycache__", ".pytest_cache"}


# ------------------------------------------------------------------ the checker ---
_FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
_CODE_SPAN = re.compile(r"`[^`\n]*`")
_LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")   # text may wrap
_IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")
_REF_DEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s+(\S+)", re.M)
_HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.M)


def _prose(text: str) -> str:
    """The text a reader sees as prose: fenced blocks and code spans removed."""
    return _CODE_SPAN.sub("", _FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to '-'."""
    h = _CODE_SPAN.sub(lambda m: m.group(0)[1:-1], heading).strip().lower()
    h = re.sub(r"[^\w\- ]", "", h)
    return h.replace(" ", "-")


def anchors(text: str) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for h in _HEADING.findall(_FENCE.sub("", text)):
        s = slug(h)
        n = seen.get(s, 0)
        seen[s] = n + 1
        out.add(s if n == 0 else f"{s}-{n}")
    return out


def broken_links(page: Path, root: Path = ROOT) -> list[str]:
    """Every relative link of ``page`` that does not resolve to a file (or directory) of
    the repository under ``root``, or to a heading of the page it names."""
    text = page.read_text()
    prose = _prose(text)
    targets = _LINK.findall(prose) + _IMAGE.findall(prose) + _REF_DEF.findall(prose)
    bad = []
    for target in targets:
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):        # http:, https:, mailto:
            continue
        path, _, frag = target.partition("#")
        dest = page if not path else (page.parent / path).resolve()
        if path and (root.resolve() not in dest.parents and dest != root.resolve()):
            bad.append(f"{target} (outside the repository)")
        elif not dest.exists():
            bad.append(f"{target} (no such file)")
        elif frag and dest.suffix == ".md" and frag not in anchors(dest.read_text()):
            bad.append(f"{target} (no heading #{frag} in {dest.name})")
    return bad


def _text_files():
    for p in sorted(ROOT.rglob("*")):
        if any(part in SKIP_DIRS or part.endswith(".egg-info") for part in p.relative_to(ROOT).parts):
            continue
        if p.is_file() and (p.suffix in (".py", ".md", ".toml", ".cfg", ".ini", ".yml", ".yaml", ".txt")
                            or p.relative_to(ROOT).as_posix() == ".ci/run"):
            yield p


# ------------------------------------------------------------------ the tests ---
def test_parameter_page_is_what_the_registry_generates():
    # GIVEN the parameter registry WHEN the page is generated THEN it is the checked-in one
    assert paramdoc.PAGE.read_text() == paramdoc.page(), \
        "docs/parameters.md is out of date: run python -m tools.paramdoc"
    # AND every parameter of both vehicles and the ground-station service is on it
    from autopilot.gcs import GCS_PARAMS
    from autopilot.vehicle import plane_param_declarations
    from autopilot.vehicle_quad import quad_param_declarations
    names = {p.name for p in [*plane_param_declarations(), *quad_param_declarations(), *GCS_PARAMS]}
    listed = set(re.findall(r"^\| `([A-Z0-9_]+)` \|", paramdoc.PAGE.read_text(), re.M))
    assert listed == names


def test_paramdoc_check_fails_on_a_stale_page_and_rewrites_it(tmp_path, monkeypatch):
    page = tmp_path / "parameters.md"
    page.write_text(paramdoc.page().replace("| `RLL_KP` | 1.2 |", "| `RLL_KP` | 1.3 |"))
    monkeypatch.setattr(paramdoc, "PAGE", page)
    assert paramdoc.main(["--check"]) == 1
    assert paramdoc.main([]) == 0
    assert paramdoc.main(["--check"]) == 0
    assert page.read_text() == paramdoc.page()


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_resolves(page):
    assert broken_links(page) == []


_UP = "." + "./"     # spelt so that a grep of the repository for it finds only real uses


def test_every_page_is_in_the_reading_order_and_the_readme_stays_short():
    # every page of docs/ is reachable from the index a newcomer reads in order
    index = (ROOT / "docs" / "index.md").read_text()
    linked = {t.partition("#")[0] for t in _LINK.findall(_prose(index))}
    pages = {p.name for p in (ROOT / "docs").glob("*.md")} - {"index.md"}
    assert sorted(pages - linked) == [], "list the page in docs/index.md"
    readme = (ROOT / "README.md").read_text()
    in_readme = {t.partition("#")[0].removeprefix("docs/") for t in _LINK.findall(_prose(readme))}
    assert sorted(pages - in_readme) == [], "list the page in the README's table of contents"
    # and the README stays the way in, not the manual: new material goes to docs/
    assert len((ROOT / "README.md").read_text().splitlines()) <= 150


def test_the_checker_finds_a_broken_link(tmp_path):
    # GIVEN a page with one good and three broken links, and links the reader never sees
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "a.md").write_text("# A page\n\n## Second part\n")
    page = tmp_path / "README.md"
    page.write_text("\n".join([
        "# Title", "",
        "[good](docs/a.md#second-part) [file gone](docs/missing.md)",
        f"[heading gone](docs/a.md#third-part) [up and out]({_UP}elsewhere/notes.md)",
        "[web](https://example.org/x.md) `[in code](nowhere.md)`",
        "```", "[in a block](nowhere.md)", "```",
        "[here](#title)",
    ]))
    # THEN exactly the three broken ones are reported
    assert broken_links(page, tmp_path) == [
        "docs/missing.md (no such file)",
        "docs/a.md#third-part (no heading #third-part in a.md)",
        f"{_UP}elsewhere/notes.md (outside the repository)",
    ]


def test_headings_anchor_as_github_makes_them():
    assert slug("What the summary adds") == "what-the-summary-adds"
    assert slug("`sitl run` flags") == "sitl-run-flags"
    assert slug("Faults: injection and the onboard monitor") == "faults-injection-and-the-onboard-monitor"
    assert anchors("# A\n## Links\n## Links\n") == {"a", "links", "links-1"}


# Files outside the repository that the project's own text must not lean on: a clone
# has none of them (the design notes and style guide beside the repository, anything
# up a level). Written as classes so that the pattern does not find itself.
_OUTSIDE = re.compile(r"share[d]/|DESIG[N]\.md|STYL[E]\.md|\.[.]/")

# Docstrings being rewritten elsewhere: each must go; the test fails once it has gone
# and is still listed here, so the list only shrinks.
_PENDING: set = set()


def test_nothing_refers_to_files_outside_the_repository():
    hits = {}
    for p in _text_files():
        for n, line in enumerate(p.read_text(errors="replace").splitlines(), 1):
            if _OUTSIDE.search(line):
                hits.setdefault(p.relative_to(ROOT).as_posix(), []).append(f"{n}: {line.strip()}")
    assert {k: v for k, v in hits.items() if k not in _PENDING} == {}
    assert sorted(_PENDING - set(hits)) == [], "gone: drop them from _PENDING"


_DOC_REF = re.compile(r'docs/([\w.-]+\.md)(?:,\s+"([^"]+)")?')


def test_docstrings_name_pages_and_sections_that_exist():
    # GIVEN every "docs/PAGE.md" or "docs/PAGE.md, "Section"" named in the code
    bad = []
    for top in ("autopilot", "sim_bridge", "tools"):
        for p in _modules(top):
            for page, section in _DOC_REF.findall(p.read_text()):
                dest = ROOT / "docs" / page
                if not dest.exists():
                    bad.append(f"{p.relative_to(ROOT)}: docs/{page}")
                elif section and slug(" ".join(section.split())) not in anchors(dest.read_text()):
                    bad.append(f"{p.relative_to(ROOT)}: docs/{page}, {section!r}")
    # THEN each names a page, and a heading of it, that exist
    assert bad == []


def test_every_sitl_command_and_run_flag_is_documented():
    # GIVEN the command line as argparse builds it
    import argparse
    from tools.sitl import build_parser
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    run_flags = {o for a in sub.choices["run"]._actions for o in a.option_strings
                 if o.startswith("--") and o != "--help"}
    running = (ROOT / "docs" / "running.md").read_text()
    docs = "\n".join(p.read_text() for p in PAGES)
    # THEN every flag of sitl run is in the table of docs/running.md, and every command
    # of sitl is shown somewhere in the documentation
    assert sorted(f for f in run_flags if f"`{f}" not in running) == []
    assert sorted(c for c in sub.choices if f"sitl {c}" not in docs) == []


# --- import rules (docs/architecture.md, "What may import what") ---
def _imports(path: Path) -> set[str]:
    """Absolute module names ``path`` imports (relative imports resolved)."""
    rel = path.relative_to(ROOT).with_suffix("")
    package = list(rel.parts[:-1])        # the package a relative import starts from
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out |= {f"{mod}.{a.name}" for a in node.names}
    return out


def _modules(top: str):
    return sorted((ROOT / top).rglob("*.py"))


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_the_autopilot_imports_nothing_of_the_simulator_or_the_tools():
    bad = [f"{p.relative_to(ROOT)}: {m}" for p in _modules("autopilot") for m in _imports(p)
           if _within(m, ("sim_bridge", "tools"))]
    assert bad == []


def test_the_simulator_imports_only_the_autopilots_leaves_and_nothing_of_the_tools():
    allowed = ("autopilot.geo", "autopilot.link", "autopilot.mission", "autopilot.frozen",
               "autopilot.jit", "autopilot.heap", "autopilot.interrupt")
    bad = [f"{p.relative_to(ROOT)}: {m}" for p in _modules("sim_bridge") for m in _imports(p)
           if _within(m, ("tools",)) or (_within(m, ("autopilot",)) and not _within(m, allowed)
                                        and m != "autopilot")]
    assert bad == []


def test_the_leaf_modules_import_nothing_else_of_the_project():
    leaves = {"autopilot/geo": ("autopilot.geo", "autopilot.jit"), "autopilot/messages.py": ("autopilot.frozen",),
              "autopilot/params.py": (), "autopilot/frozen.py": (), "autopilot/jit.py": (),
              "autopilot/heap.py": (),
              "autopilot/link": ("autopilot.link", "autopilot.messages")}
    bad = []
    for where, allowed in leaves.items():
        paths = [ROOT / where] if where.endswith(".py") else _modules(where)
        for p in paths:
            for m in _imports(p):
                if _within(m, ("autopilot", "sim_bridge", "tools")) and not _within(m, allowed):
                    bad.append(f"{p.relative_to(ROOT)}: {m}")
    assert bad == []
