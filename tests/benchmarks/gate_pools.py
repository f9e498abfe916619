"""The seed pools the gate's benchmark (``bench_gate``) draws its comparisons from: each
configuration runs once over a pool of engine seeds on short logs of the bundled
``corridor`` and ``near-obstacle`` scenes (2 s at 320×240, simulation seed 0), as sweeps
resumable in ``bench-out/gate/``.

- ``base``: the default configuration, engine seeds 0-39. Seeds 0-19 set the default
  tolerances (their seed-to-seed sd); seeds 20-39 are held out for the figures.
- three real regressions, engine seeds 20-39 (the held-out seeds): ``flies1500``
  (``engine.flies`` 5000 → 1500), ``immigrants0`` (``engine.immigration_fraction`` 0),
  ``nosonar`` (sonar fitness and sonar immigration off; ``near-obstacle`` only, the scene
  whose near post lies in a sonar cone); and a milder one, ``flies3500`` (5000 → 3500),
  to show what the gate makes of a change near the tolerances.
"""

from __future__ import annotations

from pathlib import Path

from flylog.sweep.runner import SweepOptions, SweepResult, run_sweep

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
TUNING_SEEDS = tuple(range(20))
HELD_OUT_SEEDS = tuple(range(20, 40))
DURATION_S = 2.0
RESOLUTION = (320, 240)

# name → (replay configuration TOML, scenes, engine seeds)
POOLS: dict[str, tuple[str, tuple[str, ...], tuple[int, ...]]] = {
    "base": ("", ("corridor", "near-obstacle"), TUNING_SEEDS + HELD_OUT_SEEDS),
    "flies1500": ("[engine]\nflies = 1500\n", ("corridor", "near-obstacle"), HELD_OUT_SEEDS),
    "flies3500": ("[engine]\nflies = 3500\n", ("corridor", "near-obstacle"), HELD_OUT_SEEDS),
    "immigrants0": (
        "[engine]\nimmigration_fraction = 0.0\n",
        ("corridor", "near-obstacle"),
        HELD_OUT_SEEDS,
    ),
    "nosonar": (
        "[engine]\nsonar_fitness = false\nsonar_immigration = false\n",
        ("near-obstacle",),
        HELD_OUT_SEEDS,
    ),
}


def spec_text(config: str, scenes: tuple[str, ...], seeds: tuple[int, ...]) -> str:
    lines = [f"seeds = {list(seeds)}"]
    if config:
        lines.append('config = "replay.toml"')
    for scene in scenes:
        lines += [
            "[[simulate]]",
            f'scene = "{SCENES / scene}.toml"',
            f"duration = {DURATION_S}",
            f"resolution = [{RESOLUTION[0]}, {RESOLUTION[1]}]",
            "seeds = [0]",
        ]
    return "\n".join(lines) + "\n"


def run_pool(name: str, out_dir: Path, workers: int = 2) -> SweepResult:
    """The pool ``name`` as a sweep in ``out_dir/name`` (cells already run are reused)."""
    config, scenes, seeds = POOLS[name]
    spec_dir = out_dir / "specs" / name
    spec_dir.mkdir(parents=True, exist_ok=True)
    if config:
        (spec_dir / "replay.toml").write_text(config, encoding="utf-8")
    spec = spec_dir / "spec.toml"
    spec.write_text(spec_text(config, scenes, seeds), encoding="utf-8")
    return run_sweep(spec, out_dir / name, SweepOptions(workers=workers))


if __name__ == "__main__":
    import sys
    import time

    root = Path("bench-out") / "gate"
    for pool in sys.argv[1:] or list(POOLS):
        t0 = time.perf_counter()
        result = run_pool(pool, root)
        print(
            f"{pool}: {len(result.rows)} cells, {result.ran} run, "
            f"{len(result.failed)} failed, {time.perf_counter() - t0:.0f} s",
            flush=True,
        )
