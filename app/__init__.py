"""Regolith's service layer: command line, web API, persistence, live runner."""
