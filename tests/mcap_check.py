"""Read an exported MCAP file back with the `mcap` reader and check it: every schema a valid
JSON schema, every message valid against its channel's schema, log times never going back."""

from __future__ import annotations

import io
import json
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from jsonschema import Draft202012Validator
from mcap.reader import make_reader


@dataclass
class Export:
    """What the file holds: messages per topic (decoded, in file order) and its summary."""

    topics: dict[str, list[tuple[int, dict[str, Any]]]] = field(default_factory=dict)
    schemas: dict[str, str] = field(default_factory=dict)  # topic -> schema name
    metadata: dict[str, str] = field(default_factory=dict)
    statistics: Any = None

    def count(self, topic: str) -> int:
        return len(self.topics.get(topic, []))

    def kinds(self) -> Counter[str]:
        """Messages on each /events/<kind> topic, by kind."""
        return Counter(
            {t.removeprefix("/events/"): len(m) for t, m in self.topics.items() if "/events/" in t}
        )


def read_export(data: bytes) -> Export:
    """Decode and validate every message; fail on a bad schema, message or time order."""
    reader = make_reader(io.BytesIO(data))
    out = Export()
    validators: dict[int, Draft202012Validator] = {}
    last = -1
    for schema, channel, message in reader.iter_messages(log_time_order=False):
        assert schema is not None and schema.encoding == "jsonschema", channel.topic
        assert channel.message_encoding == "json", channel.topic
        if schema.id not in validators:
            body = json.loads(schema.data)
            Draft202012Validator.check_schema(body)  # raises SchemaError if invalid
            assert body.get("title") == schema.name, schema.name
            validators[schema.id] = Draft202012Validator(body)
        decoded = json.loads(message.data)
        validators[schema.id].validate(decoded)  # raises ValidationError, naming the field
        assert message.log_time >= last, f"{channel.topic}: log time went back"
        last = message.log_time
        out.topics.setdefault(channel.topic, []).append((message.log_time, decoded))
        out.schemas[channel.topic] = schema.name
    for record in reader.iter_metadata():
        out.metadata.update(record.metadata)
    summary = reader.get_summary()
    assert summary is not None and summary.statistics is not None
    out.statistics = summary.statistics
    assert summary.statistics.message_count == sum(len(m) for m in out.topics.values())
    return out
