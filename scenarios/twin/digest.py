"""Digest authentication of the served controller, as RWS 1.0 on an IRC5 has it: the
challenge (RFC 7616, MD5, qop=auth, the controller's realm), the nonces given out, the
answer checked against the controller's users, and the session cookie (ABBCX) that later
requests may show instead."""

from __future__ import annotations

import hashlib
import re
import secrets
import threading
from dataclasses import dataclass, field

REALM = "validusers@robapi.abb"
#: The controller's default user, as an IRC5 ships it.
DEFAULT_USERS = {"Default User": "robotics"}
#: The session cookie's name.
SESSION = "ABBCX"
_DIGEST_FIELD = re.compile(r'(\w+)=(?:"([^"]*)"|([^,\s]*))')


@dataclass
class Auth:
    """Digest authentication against `users` (name -> password) and the sessions of the
    clients that passed it."""

    users: dict[str, str]
    nonces: set[str] = field(default_factory=set)
    sessions: set[str] = field(default_factory=set)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def challenge(self) -> str:
        nonce = secrets.token_hex(16)
        with self.lock:
            self.nonces.add(nonce)
            if len(self.nonces) > 10_000:
                self.nonces.pop()
        return f'Digest realm="{REALM}", nonce="{nonce}", qop="auth", algorithm=MD5'

    def check(
        self, method: str, target: str, header: str | None, session: str | None
    ) -> str | None:
        """The session of a request (to `target`, its path and query) whose session cookie
        is a session's or whose Authorization is a right digest for it (a new session); None
        if neither."""
        if session is not None and session in self.sessions:
            return session
        if header is None or not header.startswith("Digest "):
            return None
        fields = {k: a or b for k, a, b in _DIGEST_FIELD.findall(header[7:])}
        password = self.users.get(fields.get("username", ""))
        if password is None or fields.get("nonce") not in self.nonces:
            return None
        if fields.get("uri") != target:
            return None
        ha1 = _md5(f"{fields['username']}:{REALM}:{password}")
        ha2 = _md5(f"{method}:{fields.get('uri', '')}")
        parts = [ha1, fields["nonce"]]
        if fields.get("qop"):
            parts += [fields.get("nc", ""), fields.get("cnonce", ""), fields["qop"]]
        if not secrets.compare_digest(_md5(":".join([*parts, ha2])), fields.get("response", "")):
            return None
        session = secrets.token_hex(16)
        with self.lock:
            self.sessions.add(session)
        return session


def _md5(text: str) -> str:
    return hashlib.md5(text.encode(), usedforsecurity=False).hexdigest()
