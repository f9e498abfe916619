"""``flylog scene``: generated worlds (:mod:`flylog.scene.generate`)."""

from __future__ import annotations

from pathlib import Path

import click

from flylog.cli.common import Finite, OutputPath, progress_bar, reports_errors, stdout

_FAMILIES = ("passages", "clutter", "dead-end")


def _seed_range(ctx: click.Context, param: click.Parameter, value: str | None):
    if value is None:
        return None
    try:
        a, _, b = value.partition("-")
        lo, hi = int(a), int(b or a)
    except ValueError:
        msg = f"expected FIRST-LAST, e.g. 0-29, got {value!r}"
        raise click.BadParameter(msg) from None
    if not 0 <= lo <= hi:
        msg = f"expected 0 <= FIRST <= LAST, got {value!r}"
        raise click.BadParameter(msg)
    return range(lo, hi + 1)


@click.group()
def scene() -> None:
    """Generated worlds: scene files drawn from a family and a seed, checked first."""


@scene.command()
@click.argument("family", type=click.Choice(_FAMILIES))
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Seed of the world: same family, seed and options, same file.",
)
@click.option(
    "--seeds",
    "seeds",
    callback=_seed_range,
    metavar="FIRST-LAST",
    help="A range of seeds instead of --seed; -o is then a folder, which gets "
    "FAMILY-SEED.toml for each.",
)
@click.option(
    "-o",
    "--output",
    type=OutputPath(path_type=Path),
    required=True,
    help="The scene file to write (with --seeds: the folder).",
)
@click.option(
    "--passage-width",
    nargs=2,
    type=Finite(0.0, 5.0, min_open=True),
    default=(1.0, 1.8),
    show_default=True,
    metavar="MIN MAX",
    help="passages, dead-end: passage width, wall face to wall face, in metres.",
)
@click.option(
    "--difficulty",
    type=Finite(0.0, 1.0),
    default=0.5,
    show_default=True,
    help="clutter, dead-end: 0 (sparse) to 1 (dense): 0.1 + 0.3 × this obstacles "
    "per square metre of the field.",
)
@reports_errors
def generate(
    family: str,
    seed: int,
    seeds: range | None,
    output: Path,
    passage_width: tuple[float, float],
    difficulty: float,
) -> None:
    """Write a world of FAMILY (passages, clutter or dead-end), checked before it is
    written: start and goal free, a path for the robot's footprint (0.3 m radius and a
    0.05 m margin) exists (dead-end: provably none), its length stored in the file."""
    from flylog.errors import ConfigError
    from flylog.io.atomic import write_text
    from flylog.scene.generate import (
        Family,
        GenerateConfig,
        check_world_folder,
        generate_text,
        write_worlds,
    )

    lo, hi = passage_width
    if lo > hi:
        msg = f"--passage-width: MIN must not exceed MAX, got {lo} {hi}"
        raise ConfigError(msg)
    config = GenerateConfig(passage_width=(lo, hi), difficulty=difficulty)
    kind = Family(family)
    if seeds is None:
        write_text(output, generate_text(kind, seed, config))
        stdout.print(f"{output}: {family} world, seed {seed}")
        return
    check_world_folder(output, len(seeds))
    texts = {}
    with progress_bar(f"{family} worlds", "worlds") as update:
        for k, s in enumerate(seeds):
            texts[output / f"{family}-{s}.toml"] = generate_text(kind, s, config)
            update(k + 1, len(seeds))
    write_worlds(texts, output)
    stdout.print(f"{output}: {len(texts)} {family} worlds, seeds {seeds[0]}-{seeds[-1]}")
