"""One process's signed link to a mission's key space: every put, query and reply it makes
is a frame sealed with its credential, and everything it takes in is opened (checked) first
(`field.trust`). Agents and mission control both talk through one `Link` each.

A query is answered by whoever declares a queryable on its key, strangers included, so an
asker takes only the reply signed by the one it asked (`expect`) that quotes its request
id, and asks every queryable (`QueryTarget.ALL`, no consolidation): a stranger's answer can
neither stand in for the true one nor hide it.
"""

from __future__ import annotations

import itertools
import logging
import time
from typing import Any

import zenoh

from field.trust import (
    CONTROL,
    MAX_FRAME,
    Channel,
    Credential,
    Opened,
    Opener,
    Rejected,
    Sealer,
)
from field.wire import decode_json, encode_json

log = logging.getLogger("regolith.field.link")


def reply_channel(key: str) -> str:
    """What a reply to a query on `key` is signed over (never a key anyone publishes on)."""
    return f"reply:{key}"


class Link:
    def __init__(self, session: zenoh.Session, cred: Credential, where: str) -> None:
        self.session = session
        self.cred = cred
        self.name = cred.name
        self.mission = cred.mission
        self.sealer = Sealer(cred)
        self.opener = Opener(cred.mission, cred.anchor, where)
        self._rids = itertools.count(1)
        self.late = 0  # queries that came after their asker stopped waiting

    @property
    def rejections(self) -> dict[str, Any]:
        return self.opener.rejections.snapshot()

    # --- sending ---------------------------------------------------------------------------
    def seal(self, key: str, data: dict[str, Any]) -> bytes:
        return self.sealer.seal(key, encode_json(data))

    def put(self, key: str, data: dict[str, Any], publisher: Any = None) -> None:
        payload = self.seal(key, data)
        if publisher is not None:
            publisher.put(payload)
        else:
            self.session.put(key, payload)

    def ask(
        self,
        key: str,
        req: dict[str, Any],
        expect: str | frozenset[str],
        timeout: float,
        limit: int = MAX_FRAME,
    ) -> dict[str, Any] | None:
        """The reply signed by `expect` (or one of them) to this request, or None if none
        came in time; `limit`: the largest reply taken (a journal's page is larger)."""
        rid = f"{self.name}:{self.cred.gen}:{next(self._rids)}"
        # `until`: the wall time past which nobody waits for the answer (a busy answerer
        # skips it rather than spend its time on what will be thrown away)
        payload = self.seal(key, {**req, "rid": rid, "until": time.time() + timeout})
        replies = self.session.get(
            key,
            payload=payload,
            timeout=timeout,
            target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE,
            # droppable, the query and its replies (they share its QoS): a reply to an
            # asker that reads nothing would hold the answerer's network thread for up to
            # five seconds a time, and every other link it reads; a dropped one is asked again
            congestion_control=zenoh.CongestionControl.DROP,
        )
        for reply in replies:
            if reply.ok is None:
                continue
            got = self.open_json(reply_channel(key), reply.ok.payload.to_bytes(), limit)
            if got is None:
                continue
            opened, data = got
            if not (
                opened.sender == expect if isinstance(expect, str) else opened.sender in expect
            ):
                self.opener.rejections.count(
                    Rejected("wrong responder", opened.sender, f"answered {key} for {expect}")
                )
            elif data.get("re") == rid:
                return data
        return None

    # --- receiving -------------------------------------------------------------------------
    def open_json(
        self, channel: Channel, payload: bytes, limit: int = MAX_FRAME
    ) -> tuple[Opened, dict[str, Any]] | None:
        """A checked frame whose body is a versioned JSON object, or None (counted)."""
        opened = self.opener.admit(channel, payload, limit)
        if opened is None:
            return None
        data = decode_json(opened.body)
        if data is None:
            self.opener.rejections.count(Rejected("malformed", opened.sender, "not a v1 object"))
            return None
        return opened, data

    def take_query(self, query: Any, key: str) -> tuple[Opened, dict[str, Any]] | None:
        """An incoming query to this process's queryable on `key`: its checked request;
        None (counted, not answered) otherwise, and None for one its asker no longer waits
        for (`late`: under a backlog, answering queries already given up on, each asked
        again, kept an answerer behind for good).

        The signature is checked against `key`, the queryable's own, not the key the query
        arrived with: under load Zenoh now and then hands a sample over under another
        declaration's prefix (a world event put on `regolith/<m>/event/world` reached a robot
        as `regolith/<m>/msg/world`), and such a request, honest and meant for this
        queryable, was dropped as forged."""
        payload = query.payload.to_bytes() if query.payload is not None else b""
        got = self.open_json(key, payload)
        if got is not None:
            until = got[1].get("until")
            if isinstance(until, int | float) and time.time() > until:
                self.late += 1
                return None
        return got

    def take_control_query(
        self, query: Any, key: str, what: str
    ) -> tuple[Opened, dict[str, Any]] | None:
        """`take_query` for a queryable only mission control may ask (a journal, the world's
        controls): anyone else's request is counted and left unanswered."""
        got = self.take_query(query, key)
        if got is not None and got[0].sender != CONTROL:
            self.opener.rejections.count(Rejected("not mission control", got[0].sender, what))
            return None
        return got

    def reply(self, query: Any, key: str, req: dict[str, Any], data: dict[str, Any]) -> None:
        """Answer a query taken with `take_query(query, key)`, signed for `key`."""
        body = encode_json({**data, "re": req.get("rid")})
        query.reply(query.key_expr, self.sealer.seal(reply_channel(key), body))
