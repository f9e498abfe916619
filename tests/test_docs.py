"""The documentation: generated pages current, every config class in them, prose without
history."""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
import re
import tomllib
from pathlib import Path

import pytest

import flylog
from flylog import config_reference, reference_docs
from flylog.config import from_mapping, param
from flylog.fly.config import Gradient
from flylog.replay.config import ReplayConfig
from flylog.scene.load import parse_scene

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def prose_files() -> list[Path]:
    return [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]


def test_generated_pages_are_current() -> None:
    stale = reference_docs.stale_pages(DOCS)
    assert not stale, f"out of date: {[str(p.relative_to(ROOT)) for p in stale]}; run `make docs`"


def test_sample_replay_file_loads_to_the_defaults() -> None:
    """fixtures/replay.toml, the file README's `replay --config` starts from, holds every key
    at its default: loaded, it is the default configuration (and it is current, above)."""
    path = ROOT / "fixtures" / "replay.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    assert from_mapping(ReplayConfig, data, source=str(path)) == ReplayConfig()
    keys = {t.path for t in config_reference.walk_tables(ReplayConfig, None)}
    assert {"engine", "sgbm", "planner", "obstacles", "heading"} <= keys
    assert set(data) >= {"engine", "planner", "obstacles", "seed"}


def test_configuration_lists_every_key_with_its_default() -> None:
    text = (DOCS / "configuration.md").read_text(encoding="utf-8")
    assert "| `evals_per_second` | float | `3700000.0` | evaluations/s | 1 … 1000000000 |" in text
    assert "### `[engine]`" in text and "### `[[obstacles]]`" in text
    # A nested table's defaults are its parent's, not its class's.
    ground = text.split("### `[ground.texture]`")[1].split("###")[0]
    assert "| `color` | [float, float, float] | `[0.45, 0.42, 0.38]` |" in ground


def _param_classes() -> set[str]:
    """Every dataclass in the library with a field made by ``param``."""
    found: set[str] = set()
    for info in pkgutil.walk_packages(flylog.__path__, "flylog."):
        if info.name.startswith("flylog.cli"):
            continue
        try:
            module = importlib.import_module(info.name)
        except ModuleNotFoundError as exc:  # an optional dependency (not flylog) is absent
            if (exc.name or "").startswith("flylog"):
                raise
            continue
        for obj in vars(module).values():
            if (
                isinstance(obj, type)
                and obj.__module__ == module.__name__
                and dataclasses.is_dataclass(obj)
                and any("help" in f.metadata for f in dataclasses.fields(obj))
            ):
                found.add(config_reference.qualified_name(obj))
    return found


def test_every_config_class_is_documented() -> None:
    documented = config_reference.config_classes()
    missing = _param_classes() - documented - set(config_reference.OPTIONS_ONLY)
    assert not missing, (
        f"{sorted(missing)} use param but no file in flylog.config_reference.config_files() loads "
        "them: add the file they are read from, or list them in OPTIONS_ONLY"
    )
    assert not set(config_reference.OPTIONS_ONLY) & documented


@dataclasses.dataclass(frozen=True)
class Inner:
    depth: float = param(2.5, help="how deep", unit="m", min=0.0, max=9.0)


@dataclasses.dataclass(frozen=True)
class Outer:
    inner: Inner = param(Inner(depth=4.0), help="an inner table")
    items: tuple[Inner, ...] = param((), help="some items")


def test_a_new_field_appears_in_the_table() -> None:
    tables = list(config_reference.walk_tables(Outer, None))
    assert [(t.path, t.form) for t in tables] == [
        ("", "table"),
        ("inner", "table"),
        ("items", "array of tables"),
    ]
    depth = config_reference.Key("depth", "float", "4.0", "m", "0 … 9", "how deep")
    assert tables[1].keys == (depth,)
    assert tables[2].keys[0].default == "2.5"


def test_stale_blocks_are_refilled() -> None:
    text = "# t\n<!-- generated: metrics-obstacles -->\nold\n<!-- end generated -->\nafter\n"
    filled = reference_docs.fill_blocks(text)
    assert "old" not in filled and "| `latency_s` | double | s |" in filled
    assert filled.endswith("<!-- end generated -->\nafter\n")
    assert reference_docs.fill_blocks(filled) == filled
    with pytest.raises(ValueError, match="unknown generated block 'nope'"):
        reference_docs.fill_blocks("<!-- generated: nope -->\n<!-- end generated -->")


def toml_blocks(path: Path) -> list[str]:
    return re.findall(r"```toml\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def test_the_annotated_scene_file_loads() -> None:
    (block,) = toml_blocks(DOCS / "simulator.md")
    scene = parse_scene(block, source="docs/simulator.md")
    assert scene.name == "corridor" and len(scene.obstacles) == 3 + 20


def test_the_paper_configuration_loads() -> None:
    (block,) = toml_blocks(DOCS / "departures.md")
    config = from_mapping(ReplayConfig, tomllib.loads(block), source="docs/departures.md")
    assert config.engine.gradient is Gradient.NORM and not config.heading.enabled
    assert not config.obstacles.uses_distinctness and config.planner.obstacle_weight == 1.0
    assert config.planner.warm_start_sweeps == 0 and config.planner.escape_rise == 0.0


def _anchors(path: Path) -> set[str]:
    """GitHub's anchors of a Markdown file's headings."""
    heads = re.findall(r"^#+ (.*)$", path.read_text(encoding="utf-8"), re.M)
    return {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in heads}


@pytest.mark.parametrize("path", prose_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_links_lead_somewhere(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if "://" in target:
            continue
        file, _, anchor = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        assert dest.exists(), f"{path.relative_to(ROOT)}: {target} does not exist"
        if anchor and dest.suffix == ".md":
            assert anchor in _anchors(dest), f"{path.relative_to(ROOT)}: no heading #{anchor}"


# History and first person belong in commit messages: the docs say what is and why.
FORBIDDEN = re.compile(r"session|I have not found|not understood yet|used to", re.IGNORECASE)
ALLOWED = re.compile(r"""scope\s*=\s*["']session["']""")


def forbidden_phrases(text: str) -> list[str]:
    return [m.group(0) for m in FORBIDDEN.finditer(ALLOWED.sub("", text))]


def test_forbidden_phrases_are_found() -> None:
    assert forbidden_phrases("Measured in session 8; not understood yet.") == [
        "session",
        "not understood yet",
    ]
    assert forbidden_phrases('@pytest.fixture(scope="session")') == []
    assert forbidden_phrases("The cache used to be cold. I have not found why.") == [
        "used to",
        "I have not found",
    ]


@pytest.mark.parametrize("path", prose_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_prose_has_no_history(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    found = [
        f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
        for n, line in enumerate(text.splitlines(), 1)
        if forbidden_phrases(line)
    ]
    assert not found, "\n".join(found)
