"""fixtures/logs/ is exactly what fixtures/regenerate.py makes (`make fixtures`)."""

import importlib.util
from pathlib import Path

import pytest

from flylog.cli.main import cli
from flylog.io.reader import open_log

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
spec = importlib.util.spec_from_file_location("regenerate", FIXTURES / "regenerate.py")
regenerate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(regenerate)


def _content(path):
    return [
        (r.channel.topic, r.message.log_time, bytes(r.message.data))
        for r in open_log(path).raw_messages()
    ]


@pytest.mark.parametrize("name", sorted(regenerate.FIXTURE_LOGS))
def test_fixture_log_is_reproduced_by_its_command(name, tmp_path):
    committed = FIXTURES / "logs" / f"{name}.mcap"
    fresh = tmp_path / f"{name}.mcap"
    cli.main(regenerate.command(name, fresh), standalone_mode=False)
    assert _content(fresh) == _content(committed)


def test_fixtures_stay_small():
    total = sum(p.stat().st_size for p in (FIXTURES / "logs").glob("*.mcap"))
    assert 0 < total < 5 * 1024 * 1024
