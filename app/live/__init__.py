"""The live runtime: `runner` (the registry of live missions and the event loop's work for
them), `stepper` (the one thread that advances missions), `gate` (exclusive access to the
engine), `hub` (WebSocket fan-out to viewers) and `gc_pause` (full garbage collections kept
off the hot path)."""
