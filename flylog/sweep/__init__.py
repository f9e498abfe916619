"""Sweeps: inputs × engine seeds × a grid of configuration keys × variants, each cell a
replay (or a closed loop) and its metrics, on a local process pool or a Ray cluster."""
