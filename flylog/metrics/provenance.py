"""Where a run and its scores come from: the fingerprint of the sensor log replayed (stored
by replay in the run's metadata, :mod:`flylog.io.fingerprint`) and digests of the replay
and metrics configurations (in the metrics summary).

``flylog metrics`` refuses to score a run against a log other than the one it was replayed
from (a wrong ``--log`` gives figures that look plausible and are wrong);
``flylog compare`` warns when its sides were scored against different logs or with
different configurations.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from flylog.errors import LogError
from flylog.io.fingerprint import log_fingerprint

FINGERPRINT_KEY = "log_fingerprint"  # in the run's REPLAY_METADATA
# summary columns naming where the scores come from (not metrics: compare never judges them)
PROVENANCE_COLUMNS = ("log_fingerprint", "run_config", "metrics_config")


class ProvenanceWarning(UserWarning):
    """The runs being compared were scored against different logs or configurations."""


def config_digest(mapping: Mapping[str, Any] | str) -> str:
    """A short digest of a configuration (its JSON text, keys sorted)."""
    if isinstance(mapping, str):
        with contextlib.suppress(json.JSONDecodeError):  # else the text as it is
            mapping = json.loads(mapping)
    text = mapping if isinstance(mapping, str) else json.dumps(mapping, sort_keys=True)
    return hashlib.blake2b(text.encode(), digest_size=6).hexdigest()


def check_run_log(
    run: str | os.PathLike[str], log: str | os.PathLike[str], meta: Mapping[str, str]
) -> str:
    """The fingerprint of ``log``; LogError if the run's metadata ``meta`` records the
    fingerprint of another log. A run that records none (a closed-loop log, scored against
    itself) is not checked."""
    actual = log_fingerprint(log)
    stored = meta.get(FINGERPRINT_KEY)
    same_file = Path(run) == Path(log) or (
        Path(log).exists() and Path(run).exists() and os.path.samefile(run, log)
    )
    if stored is not None and not same_file and stored != actual:
        msg = (
            f"{run} was replayed from {meta.get('log', 'another log')} (fingerprint {stored}), "
            f"not from {log} (fingerprint {actual}): score it against the log it was made from"
        )
        raise LogError(msg, parameter="log")
    return actual


def run_config_digest(meta: Mapping[str, str]) -> str | None:
    """The digest of the configuration a run was replayed with (None if it records none)."""
    config = meta.get("config")
    return None if config is None else config_digest(config)


def warn_if_mixed(
    base: Sequence[Mapping[str, Any]], candidate: Sequence[Mapping[str, Any]]
) -> list[str]:
    """ProvenanceWarnings (also returned) when the two sides of a comparison were scored
    against different logs, or replayed or scored with different configurations."""
    what = {
        "log_fingerprint": "against different sensor logs (fingerprints)",
        "run_config": "from runs with different replay configurations",
        "metrics_config": "with different metrics configurations",
    }
    out = []
    for column, how in what.items():
        b = sorted({str(r[column]) for r in base if r.get(column) is not None})
        c = sorted({str(r[column]) for r in candidate if r.get(column) is not None})
        if b and c and b != c:
            text = (
                f"the base and the candidate were scored {how}: {column} "
                f"{', '.join(b)} (base) vs {', '.join(c)} (candidate)"
            )
            out.append(text)
            warnings.warn(text, ProvenanceWarning, stacklevel=3)
    return out
