"""Sweeps in the server: `routes` (REST), `schemas` (its bodies), `service` (the manager the
routes call), `job` (a sweep's own thread) and `files` (reading a sweep's folder). The runs,
statistics and figures themselves are the top-level `experiments` package."""
