"""`pip install .` gives a working flylog: the wheel, built from a copy of the sources and
installed into a fresh virtual environment outside the checkout, runs simulate, replay,
metrics and an experiment from another directory, with the scenes it ships.

Offline and quick: the wheel is built without build isolation (setuptools is a test
extra), installed without its dependencies (the new environment sees this one's through a
``.pth`` line, not its editable flylog), and the installed copy's numba kernels are cached
under a directory that outlives the test (``NUMBA_CACHE_DIR``, keyed by this checkout's
path), with each installed file's time set to its source's, so that only modules changed
since the last run compile again. The first run on a machine compiles every kernel (about
a minute).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import site
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# What the build reads: pyproject's package-dir mapping names every source directory.
SOURCES = ("pyproject.toml", "README.md", "flylog", "cli", "fixtures/scenes")


def test_every_library_package_is_in_the_wheel() -> None:
    """pyproject lists packages by hand (the cli/ mapping needs it): a new subpackage must
    be listed, or an installed flylog lacks it."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]
    listed = set(config["setuptools"]["packages"])
    found = {
        ".".join(("flylog", *p.parent.relative_to(ROOT / "flylog").parts)).rstrip(".")
        for p in (ROOT / "flylog").rglob("__init__.py")
    }
    assert found - listed == set()
    assert {"flylog.cli", "flylog.scenes"} <= listed


def _copy_sources(to: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc", "*.pyc")
    for name in SOURCES:
        src, dst = ROOT / name, to / name
        if src.is_dir():
            shutil.copytree(src, dst, ignore=ignore)
        else:
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)


def _source_of(installed: Path, package: Path) -> Path:
    rel = installed.relative_to(package)
    if rel.parts[:1] == ("cli",):
        return ROOT / "cli" / Path(*rel.parts[1:])
    if rel.parts[:1] == ("scenes",):
        return ROOT / "fixtures" / "scenes" / Path(*rel.parts[1:])
    return ROOT / "flylog" / rel


@pytest.mark.slow
def test_the_installed_wheel_runs_from_another_directory(tmp_path: Path) -> None:
    wheels, sources = tmp_path / "wheels", tmp_path / "src"
    _copy_sources(sources)
    pip = [sys.executable, "-m", "pip"]
    subprocess.run(
        [
            *pip,
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-w",
            str(wheels),
            str(sources),
        ],
        check=True,
        capture_output=True,
    )
    (wheel,) = wheels.glob("flylog-*.whl")
    keyed = hashlib.sha256(str(ROOT).encode()).hexdigest()[:12]
    home = Path(tempfile.gettempdir()) / f"flylog-wheel-test-{keyed}"
    venv = home / "venv"
    shutil.rmtree(venv, ignore_errors=True)
    base = getattr(sys, "_base_executable", sys.executable)
    subprocess.run([base, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    subprocess.run(
        [*pip, "--python", str(python), "install", "-q", "--no-deps", "--no-index", str(wheel)],
        check=True,
        capture_output=True,
    )
    purelib = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    package = Path(purelib) / "flylog"
    for installed in package.rglob("*"):
        if installed.is_file() and _source_of(installed, package).is_file():
            stat = _source_of(installed, package).stat()
            os.utime(installed, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    (Path(purelib) / "dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")

    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {**os.environ, "NUMBA_CACHE_DIR": str(home / "numba-cache")}
    env.pop("PYTHONPATH", None)
    flylog = [str(venv / "bin" / "flylog")]

    def run(*args: str, command: list[str] = flylog) -> str:
        got = subprocess.run(
            [*command, *args], cwd=work, env=env, capture_output=True, text=True, check=False
        )
        assert got.returncode == 0, f"{args}: {got.returncode}\n{got.stdout}\n{got.stderr}"
        return got.stdout

    where = run("-c", "import flylog, flylog.scenes; print(flylog.__file__)", command=[str(python)])
    assert Path(where.strip()).is_relative_to(package)
    assert "version" in run("--version", command=[str(python), "-m", "flylog"])
    run("simulate", "corridor", "-o", "c.mcap", "--duration", "1", "--resolution", "160x120")
    run("replay", "c.mcap", "-o", "r.mcap", "--flies", "500")
    run("metrics", "r.mcap", "--log", "c.mcap")
    assert (work / "r.metrics.summary.parquet").is_file()
    run("experiment", "latency", "--quick", "--duration", "0.5", "--seeds", "1", "-o", "x")
    assert (work / "x" / "latency" / "summary.md").is_file()
