"""The defect study: how far each camera defect moves the fly engine and SGBM on `corridor`.

For each condition (the ideal camera, one defect group of the realistic camera at a time,
then all of them) and each simulation seed, `flylog simulate corridor` (10 s, 320×240,
``--camera`` through a scene file with the condition's ``[camera_defects]`` table), then
`flylog replay` with each similarity measure on the images as they come (``--config``
setting ``engine.similarity`` and ``engine.photometric = "none"``, every other setting at its
default), with the default configuration (photometric matching, zssd) and with
``--engine sgbm``, then `flylog metrics`: the
flies' (or SGBM's points') precision, recall and F-score against the scene's truth.

A condition other than ``ideal`` runs the camera model with every defect at its neutral
value except its group's, which keep the realistic defaults (``model_only``: none)
(:class:`flylog.sim.camera_defects.CameraDefects`); the exposure, white flux and gain keep
theirs everywhere, so every non-ideal condition has the realistic signal level (a white
surface at about 60 % of 255 DN) and its requantisation.

Each result is appended to ``bench-out/camera_defects.jsonl`` as it is made, so an
interrupted study keeps what it finished. ``python -m tests.benchmarks.bench_camera_defects
--quick`` runs 1 s at 160×120 (SGBM needs more than its 64 disparities of width) as a smoke
test of the whole chain.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq

SCENE = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "corridor.toml"
SECONDS = 10.0
RESOLUTION = "320x240"
SEEDS = (0, 1, 2)
MEASURES = ("zssd", "contrast_zncc", "gain_zssd", "zncc")
ENGINES = ("default", *MEASURES, "sgbm")
# The replay configuration of each engine: the measures alone, on the images as they come
# (engine.photometric = "none"), and the default (photometric matching, zssd).
ENGINE_TABLES = {
    "default": "",
    **{m: f'[engine]\nsimilarity = "{m}"\nphotometric = "none"\n' for m in MEASURES},
}
# Every defect at its neutral value: a condition turns its group back to the defaults.
NEUTRAL = {
    "right_gain_ratio": 1.0,
    "drift_sd": 0.0,
    "gamma": 1.0,
    "shot_noise": False,
    "read_noise_e": 0.0,
    "dsnu_e": 0.0,
    "prnu": 0.0,
    "vignetting_corner": 1.0,
    "psf_sigma_px": 0.0,
    "motion_samples": 1,
}
GROUPS = {
    "model_only": (),  # the realistic signal level and its requantisation, no defect
    "exposure_gain": ("right_gain_ratio", "drift_sd"),
    "gamma": ("gamma",),
    "noise": ("shot_noise", "read_noise_e", "dsnu_e", "prnu"),
    "temporal_noise": ("shot_noise", "read_noise_e"),  # noise's two parts, apart
    "fixed_pattern": ("dsnu_e", "prnu"),
    "vignetting": ("vignetting_corner",),
    "optical_blur": ("psf_sigma_px",),
    "motion_blur": ("motion_samples",),
}
CONDITIONS = ("ideal", *GROUPS, "all")


def defects_table(condition: str) -> str:
    """The ``[camera_defects]`` table of a condition, as TOML."""
    if condition == "ideal":
        return "[camera_defects]\nideal = true\n"
    if condition == "all":
        return "[camera_defects]\nideal = false\n"
    keep = GROUPS[condition]
    lines = ["[camera_defects]", "ideal = false"]
    for name, value in NEUTRAL.items():
        if name not in keep:
            lines.append(f"{name} = {json.dumps(value)}")
    return "\n".join(lines) + "\n"


def _flylog(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "flylog", *args], check=True, capture_output=True)


def _scores(run: Path, log: Path) -> dict[str, float]:
    _flylog("metrics", str(run), "--log", str(log))
    row = pq.read_table(run.with_suffix(".metrics.summary.parquet")).to_pylist()[0]
    return {k: float(row[k]) for k in ("precision", "recall", "f_score")}


def study(
    out_dir: Path,
    conditions: tuple[str, ...],
    seeds: tuple[int, ...],
    *,
    seconds: float = SECONDS,
    resolution: str = RESOLUTION,
    engines: tuple[str, ...] = ENGINES,
) -> list[dict]:
    """Every (condition, seed, engine) scored; each row also appended to the jsonl file."""
    work = out_dir / "camera_defects"
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for condition in conditions:
        scene = work / f"corridor_{condition}.toml"
        scene.write_text(without_defects(SCENE.read_text()) + "\n" + defects_table(condition))
        for seed in seeds:
            log = work / f"{condition}_s{seed}.mcap"
            t0 = time.perf_counter()
            _flylog(
                "simulate",
                *(str(scene), "-o", str(log), "--duration", str(seconds)),
                *("--resolution", resolution, "--seed", str(seed)),
            )
            sim_wall = time.perf_counter() - t0
            for engine in engines:
                run = work / f"{condition}_s{seed}_{engine}.mcap"
                if engine == "sgbm":
                    _flylog("replay", str(log), "-o", str(run), "--engine", "sgbm")
                else:
                    config = work / f"{engine}.toml"
                    config.write_text(ENGINE_TABLES[engine])
                    _flylog("replay", str(log), "-o", str(run), "--config", str(config))
                row = {"condition": condition, "seed": seed, "engine": engine}
                row |= {"simulate_wall_s": sim_wall, **_scores(run, log)}
                rows.append(row)
                with open(out_dir / "camera_defects.jsonl", "a") as fh:
                    fh.write(json.dumps(row) + "\n")
                run.unlink()
                for extra in run.parent.glob(f"{run.stem}.*parquet"):
                    extra.unlink()
            log.unlink()
    return rows


def figures(rows: list[dict]) -> list[dict]:
    """Mean F, precision and recall over the seeds, per condition and engine."""
    out = []
    for condition in dict.fromkeys(r["condition"] for r in rows):
        for engine in dict.fromkeys(r["engine"] for r in rows):
            got = [r for r in rows if r["condition"] == condition and r["engine"] == engine]
            if not got:
                continue
            mean = {k: sum(r[k] for r in got) / len(got) for k in ("precision", "recall")}
            f = sum(r["f_score"] for r in got) / len(got)
            out.append(
                {
                    "name": f"corridor {condition} {engine} F",
                    "value": f,
                    "unit": "",
                    "note": f"precision {mean['precision']:.3f}, recall {mean['recall']:.3f}, "
                    f"seeds {sorted(r['seed'] for r in got)}",
                }
            )
    return out


def without_defects(scene_text: str) -> str:
    """A scene file's text without its ``[camera_defects]`` table (the condition's replaces
    it)."""
    lines, keep = [], True
    for line in scene_text.splitlines():
        if line.startswith("["):
            keep = line.strip() != "[camera_defects]"
        if keep:
            lines.append(line)
    return "\n".join(lines) + "\n"


def run(out_dir: Path) -> list[dict]:
    return figures(study(out_dir, CONDITIONS, SEEDS))


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--conditions", default=",".join(CONDITIONS))
    parser.add_argument("--seeds", default=",".join(map(str, SEEDS)))
    parser.add_argument("--engines", default=",".join(ENGINES))
    parser.add_argument("--quick", action="store_true", help="1 s at 160x120: a smoke test")
    parser.add_argument("--out", type=Path, default=Path("bench-out"))
    args = parser.parse_args(argv)
    kwargs = {"seconds": 1.0, "resolution": "160x120"} if args.quick else {}
    rows = study(
        args.out,
        tuple(args.conditions.split(",")),
        tuple(int(s) for s in args.seeds.split(",")),
        engines=tuple(args.engines.split(",")),
        **kwargs,  # type: ignore[arg-type]
    )
    for fig in figures(rows):
        print(f"{fig['name']}: {fig['value']:.3f}  ({fig['note']})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
