"""The scene files flylog ships (``corridor``, ``turn``, …): package data of
``flylog.scenes``, read through :mod:`importlib.resources`, so an installed flylog finds
them wherever it runs. In a checkout the package is the directory ``fixtures/scenes``
(pyproject's package-dir mapping): one copy, used by the tests, the fixtures and the README.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from flylog.errors import ConfigError


def scenes_dir() -> Path:
    """The directory of the bundled scene files (flylog is installed as files, never as a
    zip archive: numba's caches need a directory too)."""
    root = resources.files("flylog.scenes")
    if not isinstance(root, Path):
        msg = f"flylog's bundled scenes are not files on disk ({root}): reinstall flylog"
        raise ConfigError(msg)
    return root


def bundled_names() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in scenes_dir().glob("*.toml")))


def resolve_scene(scene: str | Path) -> Path:
    """``scene`` if it names a file (or looks like a path), else the bundled scene of that
    name; ConfigError naming the bundled scenes when it is neither."""
    path = Path(scene)
    if path.exists() or path.suffix or len(path.parts) > 1:
        return path
    bundled = scenes_dir() / f"{scene}.toml"
    if bundled.is_file():
        return bundled
    names = ", ".join(bundled_names())
    msg = f"{scene}: no such scene file, nor a bundled scene (bundled: {names})"
    raise ConfigError(msg)
