"""flylog.metrics: scoring runs against the ground truth of their sensor logs (read
through :mod:`flylog.sources`).

- ``flies``: precision, recall, F-score, depth error of fly snapshots (definitions there),
  scored a batch of snapshots at once (``score_snapshots``, what ``score_run`` uses).
- ``view``, ``depth``: the true views (the simulator's depth path in numpy, in batches).
- ``obstacles``: per-obstacle detection latency. ``trajectory``: ATE, RPE, path, goal.
- ``score``: ``score_run`` (``flylog metrics``): the input's truth decides between
  ``scene_score`` (a rendered scene) and ``image_run`` (ground-truth images); ``result``:
  the ``MetricsResult`` and the run's ``RunFacts``; ``write``: ``write_metrics``;
  ``tables``: the schemas.
- ``compare``: ``compare_files`` with per-metric tolerances (``flylog compare``).
- ``tum``: ``export_tum`` (``flylog export --tum``).
"""
