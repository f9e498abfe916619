"""A fly's confidence: the probability that it lies on a surface (within the metrics'
tolerance τ of the true depth), from what a snapshot holds of it: its fitness's rank among
the snapshot's valid flies, its age and its distinctness.

The model is fitted on simulated runs with ground truth (:mod:`flylog.metrics.calibration`,
``flylog calibrate``) and stored with the engine configuration it holds for
(``confidence.json`` beside this module). Invalid flies (fitness ≤ 0) have confidence 0.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from flylog.errors import ConfigError
from flylog.io.inputs import read_input_text
from flylog.io.records import FlyCloud

FORMAT = "flylog.confidence/1"
PACKAGED = "confidence.json"

# Features a model may read; each (N,) float64 over the snapshot's flies. The first four
# come from the cloud's fields; the others from them and the obstacle rule's distinctness
# threshold (``min_distinctness``, which the model records).
QUANTILE = "quantile"  # rank of the fitness among the valid flies, in (0, 1]
LOG_AGE = "log_age"  # log(1 + generations survived)
DISTINCT = "distinct"  # log(distinctness), 0 where not measured
MEASURED = "measured"  # 1 where the distinctness was measured (an obstacle candidate)
QUANTILE_SQUARED = "quantile_squared"
PASSES = "passes"  # 1 where the distinctness is at least min_distinctness (an obstacle fly)
QUANTILE_PASSES = "quantile_passes"  # quantile × passes
DISTINCT_PASSES = "distinct_passes"  # distinct × passes
BASE_FEATURES = (QUANTILE, LOG_AGE, DISTINCT, MEASURED)
FEATURES = (*BASE_FEATURES, QUANTILE_SQUARED, PASSES, QUANTILE_PASSES, DISTINCT_PASSES)


def derived(table: dict[str, np.ndarray], min_distinctness: float) -> dict[str, np.ndarray]:
    """Every feature of :data:`FEATURES` from the :data:`BASE_FEATURES` of ``table``."""
    q, log_d = table[QUANTILE], table[DISTINCT]
    passes = (table[MEASURED] > 0) & (log_d >= math.log(min_distinctness))
    passes = passes.astype(np.float64) if min_distinctness > 0 else table[MEASURED]
    return {
        **table,
        QUANTILE_SQUARED: q * q,
        PASSES: passes,
        QUANTILE_PASSES: q * passes,
        DISTINCT_PASSES: log_d * passes,
    }


def fitness_quantile(fitness: np.ndarray) -> np.ndarray:
    """(N,) the rank of each valid fly's fitness among the valid ones, (rank + 1) / count in
    (0, 1] (ties take their mean rank); 0 for the invalid flies. Scale-free: fitness units
    follow the images' contrast, ranks do not."""
    fitness = np.asarray(fitness, dtype=np.float64)
    out = np.zeros(len(fitness))
    valid = np.flatnonzero(fitness > 0)
    if len(valid) == 0:
        return out
    values = fitness[valid]
    order = np.argsort(values)
    ordered = values[order]
    # Runs of equal values in sorted order: each takes the mean of its positions lo..hi-1.
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    ends = np.r_[starts[1:], len(ordered)]
    mean_rank = 0.5 * (starts + ends - 1) + 1.0
    out[valid[order]] = np.repeat(mean_rank, ends - starts) / len(valid)
    return out


def features(
    fitness: np.ndarray, age: np.ndarray | None, distinct: np.ndarray | None
) -> dict[str, np.ndarray]:
    """The :data:`BASE_FEATURES` of one snapshot's flies."""
    n = len(fitness)
    a = np.zeros(n) if age is None else np.log1p(np.maximum(np.asarray(age, float), 0.0))
    d = np.full(n, np.nan) if distinct is None else np.asarray(distinct, dtype=np.float64)
    measured = np.isfinite(d) & (d > 0)
    log_d = np.zeros(n)
    log_d[measured] = np.log(d[measured])
    return {
        QUANTILE: fitness_quantile(fitness),
        LOG_AGE: a,
        DISTINCT: log_d,
        MEASURED: measured.astype(np.float64),
    }


@dataclass(frozen=True)
class ConfidenceModel:
    """A linear score s = b + Σ w_i f_i over the features ``names`` (``coefficients``:
    b, then one weight a feature), turned into a probability: logistic, P = 1 / (1 + e^−s);
    isotonic, P piecewise linear in s through the points (``knots``, ``values``), a
    monotone recalibration of the score fitted apart."""

    kind: str  # "logistic" or "isotonic"
    names: tuple[str, ...]
    coefficients: tuple[float, ...]
    knots: tuple[float, ...] = ()  # isotonic
    values: tuple[float, ...] = ()  # isotonic
    min_distinctness: float = 1.5  # the obstacle rule's threshold the "passes" features use
    tau: float = 0.05  # the surface tolerance it was fitted for (MetricsConfig.tau)
    engine: str = ""  # digest of the engine and obstacle configuration it holds for
    provenance: str = ""  # JSON: what it was fitted and checked on

    def __post_init__(self) -> None:
        unknown = [n for n in self.names if n not in FEATURES]
        if self.kind not in ("logistic", "isotonic") or unknown or not self.names:
            msg = f"confidence model of kind {self.kind!r} with features {list(self.names)}"
            raise ConfigError(msg)
        if len(self.coefficients) != len(self.names) + 1:
            msg = "a confidence model needs an intercept and one weight a feature"
            raise ConfigError(msg)
        if self.kind == "isotonic" and (len(self.knots) != len(self.values) or not self.knots):
            msg = "an isotonic confidence model needs its knots and values, as many"
            raise ConfigError(msg)

    def score(self, table: dict[str, np.ndarray]) -> np.ndarray:
        """(N,) the linear score of the flies whose :data:`BASE_FEATURES` are ``table``."""
        full = derived(table, self.min_distinctness)
        z = np.full(len(table[QUANTILE]), self.coefficients[0])
        for name, w in zip(self.names, self.coefficients[1:], strict=True):
            z += w * full[name]
        return z

    def predict(self, table: dict[str, np.ndarray], valid: np.ndarray) -> np.ndarray:
        """(N,) confidence from a table of :data:`BASE_FEATURES`; 0 where not ``valid``."""
        z = self.score(table)
        if self.kind == "logistic":
            p = 1.0 / (1.0 + np.exp(-z))
        else:
            p = np.interp(z, self.knots, self.values)
        return np.where(valid, p, 0.0)

    def of(
        self, fitness: np.ndarray, age: np.ndarray | None, distinct: np.ndarray | None
    ) -> np.ndarray:
        """(N,) float32 confidence of one snapshot's flies."""
        table = features(fitness, age, distinct)
        return self.predict(table, np.asarray(fitness) > 0).astype(np.float32)

    def of_cloud(self, cloud: FlyCloud) -> np.ndarray:
        return self.of(cloud.fitness, cloud.age, cloud.distinct)

    def to_json(self) -> str:
        body: dict[str, Any] = {
            "format": FORMAT,
            "kind": self.kind,
            "features": list(self.names),
            "coefficients": list(self.coefficients),
            "min_distinctness": self.min_distinctness,
            "tau": self.tau,
            "engine": self.engine,
        }
        if self.kind == "isotonic":
            body["knots"], body["values"] = list(self.knots), list(self.values)
        body["provenance"] = json.loads(self.provenance) if self.provenance else {}
        return json.dumps(body, indent=1) + "\n"


def from_json(text: str, source: str) -> ConfidenceModel:
    """A model from its JSON text; ConfigError naming ``source`` when it is not one."""
    try:
        body = json.loads(text)
        if body.get("format") != FORMAT:
            msg = f"{source}: format {body.get('format')!r}, expected {FORMAT!r}"
            raise ConfigError(msg)
        numbers = [*body.get("coefficients", ()), *body.get("knots", ()), *body.get("values", ())]
        if not all(isinstance(v, int | float) and math.isfinite(v) for v in numbers):
            msg = f"{source}: the model's numbers must be finite"
            raise ConfigError(msg)
        return ConfidenceModel(
            kind=body["kind"],
            names=tuple(body["features"]),
            coefficients=tuple(body["coefficients"]),
            knots=tuple(body.get("knots", ())),
            values=tuple(body.get("values", ())),
            min_distinctness=float(body["min_distinctness"]),
            tau=float(body["tau"]),
            engine=str(body["engine"]),
            provenance=json.dumps(body.get("provenance", {})),
        )
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        msg = f"{source}: not a confidence model ({type(exc).__name__}: {exc})"
        raise ConfigError(msg) from None


def load(path: str | Path | None = None) -> ConfidenceModel | None:
    """The model at ``path``, or the packaged one (None when the package holds none)."""
    if path is not None:
        return from_json(read_input_text(path, "the confidence model"), str(path))
    packaged = resources.files("flylog.fly").joinpath(PACKAGED)
    if not packaged.is_file():
        return None
    return from_json(packaged.read_text(encoding="utf-8"), f"flylog/fly/{PACKAGED}")
