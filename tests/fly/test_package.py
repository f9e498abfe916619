"""flylog.fly imports its names on first use: the obstacle rule alone does not load the
engine (the metrics and the planner's configuration read it)."""

import subprocess
import sys

import pytest

import flylog.fly


def test_every_public_name_resolves_from_its_module():
    assert sorted(flylog.fly.__all__) == sorted(flylog.fly._WHERE)
    for name in flylog.fly.__all__:
        value = getattr(flylog.fly, name)
        module = f"flylog.fly.{flylog.fly._WHERE[name]}"
        assert value is getattr(sys.modules[module], name)
    with pytest.raises(AttributeError, match="no attribute 'FlyEngines'"):
        flylog.fly.FlyEngines  # noqa: B018


def test_the_package_alone_imports_no_engine():
    code = "import sys, flylog.fly, flylog.fly.config\nprint('flylog.fly.engine' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
