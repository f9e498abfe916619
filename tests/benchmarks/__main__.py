"""Run every benchmark module (or those named on the command line) and print the figures."""

from __future__ import annotations

import importlib
import json
import pkgutil
import sys
import time
from pathlib import Path

from tests import benchmarks


def main(argv: list[str]) -> int:
    out_dir = Path("bench-out")
    out_dir.mkdir(exist_ok=True)
    names = sorted(
        m.name for m in pkgutil.iter_modules(benchmarks.__path__) if m.name.startswith("bench_")
    )
    if argv:
        names = [n for n in names if any(a in n for a in argv)]
    results: list[dict] = []
    for name in names:
        module = importlib.import_module(f"tests.benchmarks.{name}")
        t0 = time.perf_counter()
        figures = module.run(out_dir)
        print(f"== {name} ({time.perf_counter() - t0:.1f} s)")
        for fig in figures:
            fig = {"bench": name, **fig}
            results.append(fig)
            ratio = f"  (ratio {fig['ratio']:.3g} vs {fig['reference']})" if "ratio" in fig else ""
            note = f"  — {fig['note']}" if fig.get("note") else ""
            print(f"  {fig['name']}: {fig['value']:.4g} {fig['unit']}{ratio}{note}")
    (out_dir / "results.json").write_text(json.dumps(results, indent=2))
    print(f"wrote {out_dir / 'results.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
