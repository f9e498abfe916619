"""Options generated from configuration fields (flylog.cli.config_options)."""

import click
import pytest
from click.testing import CliRunner

from flylog.cli.config_options import ConfigOption, config_option, config_overrides
from flylog.cli.main import cli
from flylog.replay.config import Stereo

REPLAY = "flylog.replay.config:ReplayConfig"


def _options():
    ctx = click.Context(cli)
    for name in cli.list_commands(ctx):
        command = cli.get_command(ctx, name)
        for param in getattr(command, "params", []):
            if isinstance(param, ConfigOption):
                yield name, param


def test_commands_have_config_options_and_each_resolves_to_its_field():
    found = list(_options())
    assert {name for name, _ in found} >= {"replay", "metrics"}
    for name, option in found:
        field, kind, tp = option.resolved()
        assert option.is_flag == (tp is bool), (name, option.name)
        assert (kind is None) == (tp is bool), (name, option.name)
        assert field.metadata["help"], (name, option.name)


@pytest.mark.parametrize(("command", "path"), [("replay", "snapshot_rate"), ("metrics", "tau")])
def test_help_says_what_the_configuration_says(command, path):
    out = CliRunner().invoke(cli, [command, "--help"], terminal_width=2000).output
    option = next(o for name, o in _options() if name == command and o.config_path == path)
    field, _, _ = option.resolved()
    assert field.metadata["help"][1:] in out
    assert f"[default: {field.default:g}" in out


def test_a_value_out_of_the_fields_range_exits_2_naming_the_option(tmp_path):
    result = CliRunner().invoke(
        cli, ["replay", str(tmp_path / "x.mcap"), "-o", str(tmp_path / "r.mcap"), "--flies", "3"]
    )
    assert result.exit_code == 2
    assert "--flies" in result.output and "16<=x<=10000000" in result.output
    assert not (tmp_path / "r.mcap").exists()


def test_overrides_are_dotted_and_typed_and_only_the_given_ones():
    seen = {}

    @click.command()
    @config_option(REPLAY, "stereo", "--engine", "stereo")
    @config_option(REPLAY, "engine.flies", "--flies")
    @config_option(REPLAY, "sync", "--sync", flag=True)
    @config_option(REPLAY, "snapshot_rate", "--snapshot-rate")
    def command(**options):
        seen.update(config_overrides())

    result = CliRunner().invoke(command, ["--engine", "sgbm", "--flies", "400"])
    assert result.exit_code == 0, result.output
    assert seen == {
        "stereo": Stereo.SGBM,
        "engine.flies": 400,
        "sync": None,
        "snapshot_rate": None,
    }
    bad = CliRunner().invoke(command, ["--engine", "both"])
    assert bad.exit_code == 2 and "'both' is not one of 'flies', 'sgbm'" in bad.output
