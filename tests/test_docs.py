"""The documentation names everything a user can call: every subcommand and option of the `urdfkb` command
(read from its real argparse parser) in docs/cli.md, each option in its command's section, and every route
of the server (read from the real app's url_map) in docs/http-api.md; the README names every command, every
page under docs/ is linked from docs/index.md, and every link between the pages leads to a file and heading."""
import argparse
import re
from pathlib import Path

import pytest

from urdfkb.kb_server.app import create_app
from urdfkb.kb_server.cli import build_parser
from urdfkb.kb_server.jobs import JobManager

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
README = (REPO / "README.md").read_text()
PARAMETER = re.compile(r"<[^<>\s]*>")  # a route parameter: /jobs/<job_id> and /jobs/<id> name one route


def cli_sections() -> dict[str, str]:
    """docs/cli.md cut at its `## urdfkb COMMAND` headings: {COMMAND: its section}, "" for the text before them."""
    parts = re.split(r"^## urdfkb (\S+)$", (DOCS / "cli.md").read_text(), flags=re.MULTILINE)
    return {"": parts[0], **dict(zip(parts[1::2], parts[2::2]))}


def commands() -> dict[str, argparse.ArgumentParser]:
    """The `urdfkb` subcommands and their parsers (argparse offers no public walk of its subparsers)."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def names(parser: argparse.ArgumentParser, with_help: bool) -> list[str]:
    """Every option string of `parser` (each of -o and --output) and its positionals as NAME."""
    return [name for action in parser._actions if with_help or action.dest != "help"
            for name in (action.option_strings or [action.dest.upper()])]


def missing(names: list[str], text: str) -> list[str]:
    """The names `text` does not hold as whole words (`--store` is not found in `--store-dir`)."""
    return [n for n in names if not re.search(rf"(?<![\w-]){re.escape(n)}(?![\w-])", text)]


def test_every_command_has_its_section():
    sections = cli_sections()
    assert {"populate", "serve", "query"} <= set(commands())  # the walk found the subcommands
    lacking = sorted(set(commands()) - set(sections))
    assert not lacking, f"docs/cli.md has no `## urdfkb COMMAND` section for: {', '.join(lacking)}"


def test_every_option_is_in_its_commands_section():
    sections = cli_sections()
    undocumented = [f"urdfkb {command} {name}" for command, parser in commands().items()
                    for name in missing(names(parser, with_help=False), sections.get(command, ""))]
    undocumented += [f"urdfkb {name}" for name in missing(names(build_parser(), with_help=True), sections[""])]
    assert not undocumented, f"docs/cli.md does not document (in its command's section): {', '.join(undocumented)}"


def test_the_readme_names_every_command():
    unnamed = missing([f"urdfkb {c}" for c in commands()], README)
    assert not unnamed, f"README.md does not name: {', '.join(unnamed)}"


@pytest.fixture
def app(store):
    jobs = JobManager(store)
    yield create_app(store, jobs)
    jobs.shutdown()


def test_every_route_is_documented(app):
    text = PARAMETER.sub("<>", (DOCS / "http-api.md").read_text())
    routes = [f"{method} {rule.rule}" for rule in app.url_map.iter_rules() if rule.endpoint != "static"
              for method in sorted(rule.methods - {"HEAD", "OPTIONS"})]
    assert len(routes) > 10  # the walk found the app's routes
    undocumented = [r for r in routes if not re.search(rf"{re.escape(PARAMETER.sub('<>', r))}(?![\w/<>.-])", text)]
    assert not undocumented, f"docs/http-api.md does not document (as METHOD /path): {', '.join(undocumented)}"


def test_every_page_is_linked_from_the_index():
    index = (DOCS / "index.md").read_text()
    pages = sorted(p.name for p in DOCS.glob("*.md") if p.name != "index.md")
    unlinked = [p for p in pages if f"]({p})" not in index]
    assert pages and not unlinked, f"docs/index.md does not link: {', '.join(unlinked)}"


def anchors(page: Path) -> set[str]:
    """The anchors GitHub gives the headings of a Markdown page (lower case, punctuation dropped, spaces as -)."""
    # a `# comment` in a code block is no heading
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.MULTILINE | re.DOTALL)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
            for h in re.findall(r"^#+ (.*)$", text, flags=re.MULTILINE)}


def test_every_link_between_pages_leads_somewhere():
    pages = [REPO / "README.md", *sorted(DOCS.glob("*.md"))]
    links = [(page, target) for page in pages
             for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()) if "://" not in target]
    assert len(links) > 20  # the pages link each other
    broken = []
    for page, target in links:
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists() or (anchor and anchor not in anchors(file)):
            broken.append(f"{page.relative_to(REPO)}: {target}")
    assert not broken, f"these links lead to no file or heading: {', '.join(broken)}"
