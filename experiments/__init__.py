"""Experiments: policy × seed sweeps, their statistics, figures and reports.

Import from the submodules (`experiments.runner`, `.stats`, …). This package file stays
empty on purpose: sweep workers import `experiments.worker` and must not pay for
matplotlib or scipy at start-up.
"""
