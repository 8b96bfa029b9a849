"""Field mode: every robot its own operating-system process, talking only over Zenoh.

`field.wire` is the versioned wire format and key space, `field.transport` the Zenoh bus
(the engine's `Bus` interface), `field.world_service` the ground truth served to the robots,
`field.agent` one robot's process and `field.fleet` the launcher. docs/field.md describes it.
The engine never imports this package; this package runs the engine's robots unchanged.
"""
